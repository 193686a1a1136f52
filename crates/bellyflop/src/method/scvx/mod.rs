//! Successive convexification (Section 3.4) with the trust-region update of
//! SCvx (Mao, Szmuk, Açıkmeşe 2016): each candidate is judged by the ratio ρ of
//! the actual to the predicted decrease of the penalized cost J, which gives
//! global convergence where a radius that only shrinks can freeze early.
//!
//! This module is the one driver loop, in the shape of argmin's: a step
//! (`step`: solve the subproblem about the reference, judge the candidate by
//! ρ, its second-order correction), the trust-region rules (`trust_region`:
//! accept when ρ ≥ ρ0, shrink below ρ1, grow from ρ2) and the classification
//! of how the run ends (`classify`: the stopping tests, the status and its
//! message). The subproblem's data are built in `subproblem`, typed in
//! `socp` and solved by [`conic`]. Progress goes to an [`Observer`]; nothing
//! here prints.

use std::time::Instant;

mod classify;
#[doc(hidden)] // internals, for the benchmarks and tests; not the API
pub mod conic;
mod socp;
pub mod solver;
mod step;
mod subproblem;
#[doc(hidden)] // internals, for the benchmarks and tests; not the API
pub mod transcription;
mod trust_region;

use crate::collocation::trajectory::Trajectory;
use crate::input::scenario::Scenario;
use crate::input::settings::Method;
use crate::input::settings::{Formulation, SolverSettings};
use crate::method::observer::Iteration;
use crate::method::observer::{deadline_message, Observer};
use crate::method::scvx::transcription::Transcription;
use crate::problem::dynamics::{ix, NU_MAX, NX};

use crate::solution::{History, IterationRecord, Solution, SolveOutcome, Status};
use classify::Outcome;
pub use classify::{COARSE_MESH_NODES, INFEASIBLE_VIRTUAL_CONTROL, THRUST_TOLERANCE_FRAC};
use conic::ConicSolver;
pub use socp::{ConicData, SubproblemResult};
use step::Reference;
use trust_region::TrustRegion;

/// The paper's initial reference: the straight line from the initial to the
/// terminal state (mass from m0 to the final-mass guess, δ from δ0 to 0),
/// with σ at the middle of its bounds and the nozzle-aligned thrust direction.
pub fn straight_line(tr: &Transcription, tf_s: f64, final_mass_kg: f64) -> Trajectory {
    let n = tr.layout.n;
    let mut end = [0.0; NX];
    end[..6].copy_from_slice(&tr.xf);
    end[ix::OMEGA] = final_mass_kg.ln();
    end[ix::DELTA] = 0.0;
    let x: Vec<[f64; NX]> = tr
        .mesh
        .nodes
        .iter()
        .map(|&tau| {
            let s = 0.5 * (tau + 1.0);
            std::array::from_fn(|c| tr.x0[c] + s * (end[c] - tr.x0[c]))
        })
        .collect();
    let chi_max = tr.model.max_gimbal_rate_radps;
    let chi = (-tr.x0[ix::DELTA] / tf_s).clamp(-chi_max, chi_max);
    let thrust = 0.5 * (tr.model.min_thrust_n + tr.model.max_thrust_n);
    let u = (0..n)
        .map(|i| {
            let sigma = thrust * (-x[i][ix::OMEGA]).exp();
            let phi = x[i][ix::THETA] + x[i][ix::DELTA];
            let mut u = [0.0; NU_MAX];
            match tr.form {
                Formulation::Paper | Formulation::Vector => {
                    u[0] = sigma * phi.sin();
                    u[1] = sigma * phi.cos();
                    u[2] = sigma;
                    u[3] = chi;
                }
                Formulation::Exact => {
                    u[0] = sigma;
                    u[1] = chi;
                }
            }
            u
        })
        .collect();
    Trajectory { x, u, tf_s }
}

/// Solve a scenario from the straight-line guess (Section 3.4), in
/// [`Phases`]: with the exact formulation and `relaxed_first_iterations`
/// K > 0 (the default), the paper's relaxation first, whose translational
/// dynamics are linear in (Txm, Tzm), so that from a reasonable guess it
/// converges in 5–8 iterations where the exact form needs 16–25.
pub fn solve(
    scenario: &Scenario,
    settings: &SolverSettings,
    observer: &mut dyn Observer,
) -> Solution {
    let d = &scenario.discretization;
    let phases = Phases {
        relaxed_iterations: settings.relaxed_first_iterations,
        // Measured with examples/convergence: the relaxed phase does best with
        // a trust region that grows readily. (The exact phase uses the
        // scenario's ρ1, ρ2, chosen with the second-order correction on.)
        relaxed_tuning: |s: &mut SolverSettings| {
            s.rho1 = RELAXED_RHO1;
            s.rho2 = RELAXED_RHO2;
            s.grow = RELAXED_GROW;
            s.shrink = RELAXED_SHRINK;
            s.trust_region_initial = RELAXED_TRUST_REGION_INITIAL;
        },
        exact_tuning: |_: &mut SolverSettings| {},
    };
    let guess = |tr: &Transcription| straight_line(tr, d.tf_guess_s, d.final_mass_guess_kg);
    let mut conics = (ConicSolver::new(), ConicSolver::new());
    phases.solve(scenario, settings, &guess, &mut conics, observer)
}

/// SCvx's relaxed-then-exact strategy, shared by cold solves ([`solve`]) and
/// re-plans ([`crate::guidance::planner::Planner`]), which differ only in these fields
/// and in their reference trajectory.
///
/// With the exact formulation and `relaxed_iterations` K > 0, the paper's
/// relaxation is tried first for at most K iterations (without the ground
/// bound, which bends its path although it is inactive at the optimum); its
/// answer is kept only if it passes every physical check, being then a
/// solution of the exact problem too. Otherwise the exact formulation is
/// solved from the same kind of reference, within what is left of
/// `solver.max_iterations`, and the first phase's iterations are counted in
/// the history.
pub struct Phases<R: Fn(&mut SolverSettings), E: Fn(&mut SolverSettings)> {
    pub relaxed_iterations: usize,
    /// Changes to the scenario's settings in each phase.
    pub relaxed_tuning: R,
    pub exact_tuning: E,
}

impl<R: Fn(&mut SolverSettings), E: Fn(&mut SolverSettings)> Phases<R, E> {
    /// Solve `scenario` from `reference(transcription)`, with one conic
    /// solver per phase (relaxed, exact) kept by the caller.
    pub fn solve(
        &self,
        scenario: &Scenario,
        settings: &SolverSettings,
        reference: &dyn Fn(&Transcription) -> Trajectory,
        conics: &mut (ConicSolver, ConicSolver),
        observer: &mut dyn Observer,
    ) -> Solution {
        let max_iterations = settings.max_iterations;
        let mut spent: Option<Solution> = None;
        if settings.formulation == Formulation::Exact && self.relaxed_iterations > 0 {
            let mut relaxed = settings.clone();
            relaxed.formulation = Formulation::Paper;
            relaxed.max_iterations = self.relaxed_iterations.min(max_iterations);
            (self.relaxed_tuning)(&mut relaxed);
            let tr = Transcription::new(scenario, &relaxed).without_ground_bound();
            let first = solve_from_with(&tr, reference(&tr), &relaxed, observer, &mut conics.0);
            if first.status == Status::Solved || first.iterations >= max_iterations {
                return first;
            }
            spent = Some(first);
        }
        let tr = Transcription::new(scenario, settings);
        let mut exact = settings.clone();
        (self.exact_tuning)(&mut exact);
        if let Some(first) = &spent {
            exact.max_iterations -= first.iterations;
        }
        let sol = solve_from_with(&tr, reference(&tr), &exact, observer, &mut conics.1);
        match spent {
            Some(first) => append_phase(first, sol),
            None => sol,
        }
    }
}

/// The answer of a second phase `sol` with the first phase's iterations and
/// time counted in: its history is `first`'s followed by its own.
pub fn append_phase(first: Solution, mut sol: Solution) -> Solution {
    let mut history = first.history;
    history.append(std::mem::take(&mut sol.history));
    sol.history = history;
    sol.iterations = sol.history.len();
    sol.solve_time_ms += first.solve_time_ms;
    sol
}

/// Initial trust radius (scaled ∞-norm) of the relaxed first phase. Measured
/// with examples/convergence over N ∈ {10, 15, 20, 30, 40} × four t_f
/// guesses: 0.6 needs 5–8 iterations (124 in all), 0.3 needs 5–9 (143) and
/// 1.0 has outliers of 27–34; every run reaches the same optimum. The exact
/// phase keeps `solver.trust_region_initial`: there a larger radius changes
/// which local optimum the dispersed cases reach.
const RELAXED_TRUST_REGION_INITIAL: f64 = 0.6;
/// Trust-region shrink threshold ρ1 of the relaxed first phase.
const RELAXED_RHO1: f64 = 0.1;
/// Trust-region growth threshold ρ2 of the relaxed first phase.
const RELAXED_RHO2: f64 = 0.5;
/// Trust-region growth factor of the relaxed first phase.
const RELAXED_GROW: f64 = 2.0;
/// Trust-region shrink factor of the relaxed first phase.
const RELAXED_SHRINK: f64 = 2.0;

/// Solve from a given reference trajectory (a straight line, or a previous plan).
pub fn solve_from(
    tr: &Transcription,
    guess: Trajectory,
    settings: &SolverSettings,
    observer: &mut dyn Observer,
) -> Solution {
    solve_from_with(tr, guess, settings, observer, &mut ConicSolver::new())
}

/// [`solve_from`] with a caller-owned conic solver, so that successive solves
/// of the same structure (the re-plans of a guidance loop) skip Clarabel's
/// setup.
pub fn solve_from_with(
    tr: &Transcription,
    guess: Trajectory,
    settings: &SolverSettings,
    observer: &mut dyn Observer,
    conic: &mut ConicSolver,
) -> Solution {
    let start = Instant::now();
    let mut reference = Reference::new(tr, guess);
    let mut region = TrustRegion::new(settings);
    let mut history = Vec::new();
    let mut outcome: Option<Outcome> = None;

    for iteration in 1..=settings.max_iterations {
        let t0 = Instant::now();
        let candidate = match step::step(tr, conic, &reference, region.radius, settings) {
            Ok(c) => c,
            Err(msg) => {
                if region.after_failure(settings) {
                    outcome = Some((Status::SolverFailed, msg));
                    break;
                }
                continue;
            }
        };
        let converged = classify::converged(&candidate, reference.merit, settings);
        let accepted = TrustRegion::accepts(converged, candidate.rho, settings);

        let record = IterationRecord {
            iteration,
            cost: candidate.merit.total,
            final_mass_kg: candidate.sub.trajectory.x[tr.layout.n][ix::OMEGA].exp(),
            step: candidate.step,
            virtual_control: candidate.sub.virtual_control,
            defect: candidate.merit.defect_max,
            trust_radius: region.radius,
            rho: candidate.rho,
            accepted,
            corrected: candidate.corrected,
            ipm_iterations: candidate.sub.ipm_iterations,
            ms: t0.elapsed().as_secs_f64() * 1e3,
        };
        observer.iteration(Iteration::Scvx(&record));
        history.push(record);

        let (rho, step, vc) = (candidate.rho, candidate.step, candidate.sub.virtual_control);
        if accepted {
            reference.accept(candidate);
        }
        if converged {
            outcome = Some(classify::at_convergence(
                tr,
                &reference.trajectory,
                vc,
                settings,
            ));
            break;
        }
        if let Some(stall) = classify::at_stall(tr, &reference.trajectory, vc, &history) {
            outcome = Some(stall);
            break;
        }
        region.update(accepted, rho, step, reference.virtual_control, settings);
        if region.collapsed(settings) {
            outcome = Some(classify::at_collapse(
                tr,
                &reference.trajectory,
                reference.virtual_control,
                settings,
            ));
            break;
        }
        if observer.deadline_passed() {
            outcome = Some((Status::NotConverged, deadline_message(iteration, "SCvx")));
            break;
        }
    }

    let outcome = outcome.unwrap_or_else(|| classify::at_iteration_limit(settings));
    let checks = tr.checks(&reference.trajectory, reference.virtual_control);
    let (status, message) = classify::physical(tr, outcome, &checks, settings);
    let outcome = SolveOutcome {
        method: Method::Scvx,
        status,
        message,
        checks,
        history: History::scvx(history),
        solve_time_ms: start.elapsed().as_secs_f64() * 1e3,
    };
    Solution::new(&tr.mesh, &tr.model, tr.form, reference.trajectory, outcome)
}
