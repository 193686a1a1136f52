//! The pipeline of a solve: a certificate of infeasibility first, then the
//! method the settings name (on the scenario's mesh, or refined), then the
//! check of the answer against the nonlinear model. Statuses are claims
//! (see [`solve`]).

use crate::input::scenario::Scenario;
use crate::input::settings::{Method, SolverSettings};
use crate::method::observer::Observer;
use crate::method::{direct, scvx};
use crate::problem::feasibility;
use crate::solution::{self, Solution, Status};
use crate::verify::accuracy;
use crate::{method::direct::nlp, refine};

/// Solve a scenario with the method its settings name
/// (`solver.method`: SCvx or the direct interior-point method), with
/// statuses that are claims:
///
/// 1. a state that [`feasibility::certify`] proves infeasible is
///    `infeasible` at once, its certificate the message, without solving;
/// 2. a method that stops locally infeasible without a certificate gives
///    `not_converged`: no trajectory was found, the method's reason, and that
///    infeasibility is not proven;
/// 3. a `solved` answer whose controls, re-integrated, land beyond the
///    scenario's tolerances is `inaccurate` ([`accuracy::check`]).
///
/// With `solver.refinement.tolerance` > 0 the mesh is refined until every
/// interval's relative error is within it ([`refine::solve`]), and step 3
/// checks the last pass's answer.
///
/// `solve_time_ms` is the method's own time (the certificate's alone when it
/// answers; every pass and its error estimate when refining); the
/// re-integration of step 3 is not counted. The methods on their own
/// ([`scvx::solve`], [`direct::solve`], and the closed loop's re-plans) skip
/// all three steps.
pub fn solve(
    scenario: &Scenario,
    settings: &SolverSettings,
    observer: &mut dyn Observer,
) -> Solution {
    let mut sol = if settings.refinement.tolerance > 0.0 {
        refine::solve(scenario, settings, observer)
    } else {
        solve_on_mesh(scenario, settings, observer)
    };
    if sol.status == Status::Solved {
        accuracy::check(scenario, settings, &mut sol);
    }
    sol
}

/// Steps 1 and 2 of [`solve`] on the scenario's own mesh.
pub(crate) fn solve_on_mesh(
    scenario: &Scenario,
    settings: &SolverSettings,
    observer: &mut dyn Observer,
) -> Solution {
    solve_on_mesh_keeping_duals(scenario, settings, observer).0
}

/// [`solve_on_mesh`], and with the direct method the NLP and the
/// multipliers of its answer (the warm start of refinement's next pass).
pub(crate) fn solve_on_mesh_keeping_duals(
    scenario: &Scenario,
    settings: &SolverSettings,
    observer: &mut dyn Observer,
) -> (Solution, Option<(nlp::Nlp, direct::Duals)>) {
    let start = std::time::Instant::now();
    if let Some(certificate) = feasibility::certify(scenario) {
        return (certified(scenario, settings, &certificate, start), None);
    }
    let (mut sol, duals) = match settings.method {
        Method::Scvx => (scvx::solve(scenario, settings, observer), None),
        Method::Direct => {
            let (sol, nlp, duals) = direct::solve_keeping_duals(scenario, settings, observer);
            (sol, Some((nlp, duals)))
        }
    };
    if sol.status == Status::Infeasible {
        sol.status = Status::NotConverged;
        sol.message = format!(
            "no trajectory was found, but infeasibility is not proven ({}); try another discretization.tf_guess_s, the other method (solver.method or --method) or more nodes. The {} method stopped locally infeasible: {}",
            feasibility::not_proven(scenario),
            sol.method.as_str(),
            sol.message
        );
    }
    (sol, duals)
}

/// The answer for a certified-infeasible scenario: status `infeasible`, the
/// certificate as the message, and the straight-line guess as the trajectory
/// (no iterations).
fn certified(
    scenario: &Scenario,
    settings: &SolverSettings,
    certificate: &feasibility::Certificate,
    start: std::time::Instant,
) -> Solution {
    let tr = scvx::transcription::Transcription::new(scenario, settings);
    let d = &scenario.discretization;
    let guess = scvx::straight_line(&tr, d.tf_guess_s, d.final_mass_guess_kg);
    let checks = solution::check(&tr, &guess, 0.0);
    let ms = start.elapsed().as_secs_f64() * 1e3;
    let mut sol = Solution::new(
        &tr,
        guess,
        Status::Infeasible,
        certificate.to_string(),
        checks,
        Vec::new(),
        ms,
    );
    sol.method = settings.method;
    sol
}
