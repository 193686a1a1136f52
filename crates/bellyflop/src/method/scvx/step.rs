//! One SCvx step (Mao, Szmuk, Açıkmeşe 2016): the convex subproblem P4
//! solved about the reference, and its candidate judged by the ratio ρ of
//! the actual to the predicted decrease of the penalized cost J — after the
//! candidate's second-order correction when that agrees better with the
//! model.

use super::conic::ConicSolver;
use super::socp::SubproblemResult;
use crate::collocation::trajectory::Trajectory;
use crate::input::settings::SolverSettings;
use crate::method::scvx::transcription::{Merit, Transcription};

/// The iterate that the next subproblem linearizes about: the last accepted
/// candidate (at first the initial guess).
pub(super) struct Reference {
    pub trajectory: Trajectory,
    /// Its scaled trajectory variables ẑ_ref.
    pub z: Vec<f64>,
    /// Its merit J(ẑ_ref).
    pub merit: f64,
    /// The virtual control (scaled) of the subproblem that produced it;
    /// infinite for the initial guess.
    pub virtual_control: f64,
}

impl Reference {
    pub fn new(tr: &Transcription, guess: Trajectory) -> Self {
        let z = tr.to_scaled(&guess);
        let merit = tr.merit(&guess).total;
        Reference {
            trajectory: guess,
            z,
            merit,
            virtual_control: f64::INFINITY,
        }
    }

    /// Take `candidate` as the new reference.
    pub fn accept(&mut self, candidate: Candidate) {
        self.merit = candidate.merit.total;
        self.virtual_control = candidate.sub.virtual_control;
        self.trajectory = candidate.sub.trajectory;
        self.z = candidate.sub.z;
    }
}

/// A subproblem's answer as a candidate for the next reference.
pub(super) struct Candidate {
    pub sub: SubproblemResult,
    /// Its merit J (nonlinear cost plus exact penalty).
    pub merit: Merit,
    /// ‖ẑ − ẑ_ref‖∞, the step from the reference (scaled).
    pub step: f64,
    /// The decrease of J that the convex model predicts: J(ẑ_ref) − L(ẑ).
    pub predicted: f64,
    /// The ratio ρ of the actual to the predicted decrease.
    pub rho: f64,
    /// Whether the candidate is the subproblem's answer after its
    /// second-order correction.
    pub corrected: bool,
}

/// ρ = (J(ẑ_ref) − J) / predicted, or 1 when the model predicts no decrease.
fn ratio(j_ref: f64, predicted: f64, j: f64) -> f64 {
    if predicted.abs() > 1e-12 {
        (j_ref - j) / predicted
    } else {
        1.0
    }
}

fn inf_norm_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

/// Solve the subproblem about `reference` within the trust region of
/// `radius`, and evaluate its answer. An error is the conic solver's.
pub(super) fn step(
    tr: &Transcription,
    conic: &mut ConicSolver,
    reference: &Reference,
    radius: f64,
    settings: &SolverSettings,
) -> Result<Candidate, String> {
    let data = tr.assemble(&reference.trajectory, radius, settings.proximal_weight);
    let mut sub = tr.solve_with(conic, &data)?;
    let j_ref = reference.merit;
    let mut merit = tr.merit(&sub.trajectory);
    let mut step = inf_norm_diff(&sub.z, &reference.z);
    let predicted = j_ref - sub.model_cost;
    let mut rho = ratio(j_ref, predicted, merit.total);
    // A poor candidate is judged after its second-order correction, when
    // that agrees better with the model (same predicted decrease).
    let mut corrected = false;
    if settings.second_order_correction && rho < settings.rho1 && step > settings.step_tolerance {
        if let Some((z, t)) = tr.second_order_correction(&data, &sub) {
            let m = tr.merit(&t);
            if ratio(j_ref, predicted, m.total) > rho {
                sub.z = z;
                sub.trajectory = t;
                step = inf_norm_diff(&sub.z, &reference.z);
                merit = m;
                rho = ratio(j_ref, predicted, m.total);
                corrected = true;
            }
        }
    }
    Ok(Candidate {
        sub,
        merit,
        step,
        predicted,
        rho,
        corrected,
    })
}
