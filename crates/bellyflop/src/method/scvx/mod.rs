//! Successive convexification (Section 3.4) with the trust-region update of
//! SCvx (Mao, Szmuk, Açıkmeşe 2016): each candidate is judged by the ratio ρ of
//! the actual to the predicted decrease of the penalized cost J, which gives
//! global convergence where a radius that only shrinks can freeze early.
//!
//! This module is the one driver loop. Progress goes to an [`Observer`]; nothing
//! here prints.

use std::time::Instant;

pub mod conic;
mod socp;
mod subproblem;
pub mod transcription;

use crate::input::scenario::{Formulation, Scenario, SolverSettings};
pub use crate::method::observer::{Observer, Silent};
use crate::method::scvx::transcription::{Trajectory, Transcription};
use crate::problem::dynamics::{ix, NU_MAX, NX};
pub use crate::solution::GROUND_TOLERANCE_M;
use crate::solution::{self, IterationRecord, Solution, Status};
pub use conic::ConicSolver;
pub use socp::{ConicData, SubproblemResult};

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

/// A converged virtual control at least this large (scaled) is a certificate
/// that the nonlinear constraints cannot be met; below it, and above the
/// tolerance, the answer is only "not converged".
pub const INFEASIBLE_VIRTUAL_CONTROL: f64 = 1e-4;

/// How far a `solved` thrust may leave [T_min, T_max], as a fraction of
/// T_max (2.2 N on the paper's case). The bounds are linearized in ω (Eq. 28),
/// which costs T_min·Δω²/2 below T_min, and held with penalized buffers up
/// to the virtual-control tolerance: measured 4e-5 N with T_min = T_max.
pub const THRUST_TOLERANCE_FRAC: f64 = 1e-6;

/// Consecutive creeping steps (see `solve_from_with`) after which the trust
/// region shrinks.
const CREEP_WINDOW: usize = 5;
/// A step at least this fraction of the radius reaches the trust region.
const CREEP_BOUND: f64 = 0.99;

/// Iterations over which [`stalled`] judges progress.
const STALL_WINDOW: usize = 8;
/// Relative merit decrease over the window below which the search has stalled.
const STALL_DECREASE: f64 = 0.02;
/// Virtual control (scaled) that the stalled iterates must all still need.
const STALL_VIRTUAL_CONTROL: f64 = 1e-2;

/// Detect a stalled minimum-violation search: over the last [`STALL_WINDOW`]
/// iterations every candidate needed virtual control ≥ [`STALL_VIRTUAL_CONTROL`]
/// and the merit fell by less than [`STALL_DECREASE`] (relative).
fn stalled(history: &[IterationRecord]) -> Option<String> {
    if history.len() <= STALL_WINDOW {
        return None;
    }
    let window = &history[history.len() - STALL_WINDOW - 1..];
    if window
        .iter()
        .any(|h| h.virtual_control < STALL_VIRTUAL_CONTROL)
    {
        return None;
    }
    let accepted: Vec<f64> = window
        .iter()
        .filter(|h| h.accepted)
        .map(|h| h.cost)
        .collect();
    let (first, last) = (accepted.first()?, accepted.last()?);
    let decrease = (first - last) / first.abs().max(1e-12);
    (decrease < STALL_DECREASE).then(|| {
        format!(
            "over the last {STALL_WINDOW} iterations the merit fell by only {:.2}% while the virtual control stayed above {STALL_VIRTUAL_CONTROL:.0e}",
            100.0 * decrease
        )
    })
}

fn inf_norm_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

const STATE_NAMES: [&str; NX] = [
    "x (horizontal position)",
    "z (altitude)",
    "Vx (horizontal velocity)",
    "Vz (vertical velocity)",
    "theta (pitch)",
    "w (pitch rate)",
    "omega = ln m (mass)",
    "delta (nozzle angle)",
];

/// Below this many collocation points an `infeasible` answer says only that
/// no trajectory was found on the mesh: the paper's case is `infeasible` at
/// N = 4 (the smallest accepted) and solved from N = 5 on.
pub const COARSE_MESH_NODES: usize = 10;

/// Explain why a stationary point with virtual control is infeasible.
fn infeasibility_reason(tr: &Transcription, t: &Trajectory, vc: f64) -> String {
    let d = tr.defects(t);
    let (mut worst, mut node, mut comp) = (0.0, 0, 0);
    for (i, row) in d.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            if v.abs() > worst {
                (worst, node, comp) = (v.abs(), i, c);
            }
        }
    }
    let n = tr.layout.n;
    let claim = if n < COARSE_MESH_NODES {
        format!(
            "no trajectory was found on this mesh of N = {n} collocation points, which may be too coarse: try more nodes (discretization.nodes or --nodes, e.g. 20)"
        )
    } else {
        "SCvx found no trajectory that meets the dynamics and boundary conditions".to_string()
    };
    let mut reason = format!(
        "{claim}: SCvx settled with virtual control {vc:.2e} (scaled); the largest violation is in the {} equation at t = {:.2} s",
        STATE_NAMES[comp],
        tr.mesh.time_s(node, t.tf_s)
    );
    let mf = t.x[n][ix::OMEGA].exp();
    if mf <= tr.model.dry_mass_kg * (1.0 + 1e-6) {
        reason += &format!(
            "; the propellant runs out (final mass at the dry mass {:.0} kg)",
            tr.model.dry_mass_kg
        );
    }
    let si = tr.sigma_index();
    let at_max = (0..n)
        .filter(|&i| t.u[i][si] * t.x[i][ix::OMEGA].exp() >= tr.model.max_thrust_n * (1.0 - 1e-3))
        .count();
    if at_max * 2 >= n {
        reason += &format!("; thrust is at T_max at {at_max} of {n} nodes");
    }
    reason
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
    let offset = history.len();
    history.extend(sol.history.drain(..).map(|mut h| {
        h.iteration += offset;
        h
    }));
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
    let mut reference = guess;
    let mut z_ref = tr.to_scaled(&reference);
    let mut j_ref = tr.merit(&reference).total;
    let mut radius = settings.trust_region_initial;
    let mut history = Vec::new();
    let mut last_vc = f64::INFINITY;
    let mut failures = 0;
    let mut creep = 0usize;
    let mut outcome: Option<(Status, String)> = None;

    for iteration in 1..=settings.max_iterations {
        let t0 = Instant::now();
        let data = tr.assemble(&reference, radius, settings.proximal_weight);
        let mut sub = match tr.solve_with(conic, &data) {
            Ok(s) => s,
            Err(msg) => {
                // A failed subproblem is treated like a rejected step.
                failures += 1;
                radius /= settings.shrink;
                if radius < settings.trust_region_min || failures > 5 {
                    outcome = Some((Status::SolverFailed, msg));
                    break;
                }
                continue;
            }
        };
        let mut merit = tr.merit(&sub.trajectory);
        let mut step = inf_norm_diff(&sub.z, &z_ref);
        let predicted = j_ref - sub.model_cost;
        let ratio = |j: f64| {
            if predicted.abs() > 1e-12 {
                (j_ref - j) / predicted
            } else {
                1.0
            }
        };
        let mut rho = ratio(merit.total);
        // A poor candidate is judged after its second-order correction, when
        // that agrees better with the model (same predicted decrease).
        let mut corrected = false;
        if settings.second_order_correction && rho < settings.rho1 && step > settings.step_tolerance
        {
            if let Some((z, t)) = tr.second_order_correction(&data, &sub) {
                let m = tr.merit(&t);
                if ratio(m.total) > rho {
                    sub.z = z;
                    sub.trajectory = t;
                    step = inf_norm_diff(&sub.z, &z_ref);
                    merit = m;
                    rho = ratio(m.total);
                    corrected = true;
                }
            }
        }
        // Converged: the step (or the predicted decrease) is negligible, and the
        // candidate meets the nonlinear collocation defects — unless it still
        // needs so much virtual control that no step can fix it.
        let converged = (step <= settings.step_tolerance
            || predicted.abs() <= 1e-10 * (1.0 + j_ref.abs()))
            && (merit.defect_max <= settings.defect_tolerance
                || sub.virtual_control >= INFEASIBLE_VIRTUAL_CONTROL);
        let accepted = converged || rho >= settings.rho0;

        let record = IterationRecord {
            iteration,
            cost: merit.total,
            final_mass_kg: sub.trajectory.x[tr.layout.n][ix::OMEGA].exp(),
            step,
            virtual_control: sub.virtual_control,
            defect: merit.defect_max,
            trust_radius: radius,
            rho,
            accepted,
            corrected,
            ipm_iterations: sub.ipm_iterations,
            ms: t0.elapsed().as_secs_f64() * 1e3,
        };
        observer.on_iteration(&record);
        history.push(record);

        if accepted {
            reference = sub.trajectory;
            z_ref = sub.z;
            j_ref = merit.total;
            last_vc = sub.virtual_control;
        }
        if converged {
            let vc = sub.virtual_control;
            outcome = Some(if vc <= settings.virtual_control_tolerance {
                (Status::Solved, String::new())
            } else if vc >= INFEASIBLE_VIRTUAL_CONTROL {
                (Status::Infeasible, infeasibility_reason(tr, &reference, vc))
            } else {
                (
                    Status::NotConverged,
                    format!(
                        "the step converged but the virtual control {vc:.2e} is above the tolerance {:.1e}",
                        settings.virtual_control_tolerance
                    ),
                )
            });
            break;
        }
        // A search that keeps needing large virtual control while its merit
        // barely moves has settled on a minimum of the constraint violation.
        if let Some(reason) = stalled(&history) {
            outcome = Some((
                Status::Infeasible,
                format!(
                    "{}; {reason}",
                    infeasibility_reason(tr, &reference, sub.virtual_control)
                ),
            ));
            break;
        }
        // Creep: on a feasible reference, accepted steps that all reach the
        // trust region while the model over-predicts (ρ < ρ2). The ∞-norm
        // linear model moves every free variable to the box, so its steps
        // never shrink on their own near the optimum; CREEP_WINDOW such
        // steps in a row are treated like ρ < ρ1. (Without the second-order
        // correction the rejected steps shrink the radius instead.)
        let creeping = settings.second_order_correction
            && accepted
            && rho < settings.rho2
            && step >= CREEP_BOUND * radius
            && last_vc <= settings.virtual_control_tolerance;
        creep = if creeping { creep + 1 } else { 0 };
        if !accepted || rho < settings.rho1 || creep >= CREEP_WINDOW {
            radius /= settings.shrink;
            creep = 0;
        } else if rho >= settings.rho2 {
            radius = (radius * settings.grow).min(settings.trust_region_max);
        }
        if radius < settings.trust_region_min {
            // No step, however short, lowers the merit: the reference is a
            // stationary point of it. It is a solution if it is feasible.
            let feasible = tr.merit(&reference).defect_max <= settings.defect_tolerance
                && last_vc <= settings.virtual_control_tolerance;
            outcome = Some(if feasible {
                (Status::Solved, String::new())
            } else {
                (
                    Status::NotConverged,
                    format!(
                        "trust region shrank below {:.1e} without convergence; best iterate returned",
                        settings.trust_region_min
                    ),
                )
            });
            break;
        }
    }

    let (mut status, mut message) = outcome.unwrap_or((
        Status::NotConverged,
        format!(
            "no convergence in {} iterations; best iterate returned",
            settings.max_iterations
        ),
    ));
    let checks = solution::check(tr, &reference, last_vc);
    if status == Status::Solved {
        if checks.relaxation_gap > settings.relaxation_gap_tolerance {
            status = Status::NonPhysical;
            message = format!(
                "lossless relaxation not tight: max(1 - |T|/sigma) = {:.3e} > {:.1e}",
                checks.relaxation_gap, settings.relaxation_gap_tolerance
            );
        } else if checks.min_altitude_margin_m < -GROUND_TOLERANCE_M {
            status = Status::NonPhysical;
            message = format!(
                "the trajectory passes {:.3e} m below the landing altitude (more than the {GROUND_TOLERANCE_M} m tolerance)",
                -checks.min_altitude_margin_m
            );
        } else if checks.thrust_bound_violation_n > THRUST_TOLERANCE_FRAC * tr.model.max_thrust_n {
            status = Status::NonPhysical;
            message = format!(
                "the thrust leaves [T_min, T_max] by {:.3e} N (more than {THRUST_TOLERANCE_FRAC:.0e} of T_max)",
                checks.thrust_bound_violation_n
            );
        } else if checks.thrust_backwards() {
            status = Status::NonPhysical;
            message = format!(
                "thrust points backwards out of the nozzle (min cosine {:.3})",
                checks.thrust_alignment_min
            );
        }
    }
    let ms = start.elapsed().as_secs_f64() * 1e3;
    Solution::new(tr, reference, status, message, checks, history, ms)
}
