//! bellyflop: fuel-optimal flip-and-land trajectories by Legendre–Gauss–Radau
//! collocation and successive convexification (Chen, Ma, Wang, Su 2023).
//!
//! - [`scenario`], [`validate`]: parameters from TOML, checked before anything runs;
//! - [`dynamics`]: the models of Eq. (1)–(3), (8), (21)–(22) and their Jacobians;
//! - [`radau`]: LGR nodes, weights, differentiation and interpolation;
//! - [`mesh`]: the global LGR mesh or an hp mesh of LGR intervals;
//! - [`control_profile`]: the flyable controls between the collocation points;
//! - [`mesh_error`]: the relative error of a solution on each mesh interval;
//! - [`refine`]: hp mesh refinement to a tolerance, with breaks at the switches;
//! - [`transcription`]: the convex subproblem P4 as conic data for Clarabel;
//! - [`conic`]: Clarabel, set up once per structure and updated in place;
//! - [`scvx`]: the successive-convexification driver loop;
//! - [`solution`]: status, physical trajectory, checks and history;
//! - [`replan`]: warm re-plans from the shifted previous plan;
//! - [`propagate`]: landing precision by re-integrating the nonlinear model;
//! - [`feasibility`]: certificates that no trajectory exists (a stopping bound);
//! - [`fuzzing`]: the function the fuzz target and the corpus replay run on raw
//!   scenario bytes, with the invariants every answer must keep;
//! - [`accuracy`]: the re-integrated landing error of a `solved` answer against
//!   its tolerances;
//! - [`sim`]: the truth plant and Monte-Carlo dispersions for closed-loop guidance;
//! - [`navigation`]: filters on the measured state (position, wind);
//! - [`guidance`]: the closed loop — navigation, re-planning, control;
//! - [`report`]: the JSON of a solve with its landing precision (the CLI's `--json`);
//! - [`campaign`]: Monte Carlo rows (runs.csv) and summary.
pub mod accuracy;
pub mod campaign;
pub mod control_profile;

pub mod direct;
pub mod dynamics;
pub mod error;
pub mod feasibility;
pub mod fuzzing;
pub mod guidance;
pub mod kkt;
pub mod mesh;
pub mod mesh_error;
pub mod navigation;
pub mod nlp;
pub mod observer;
pub mod propagate;
pub mod radau;
pub mod refine;
pub mod replan;
pub mod report;
pub mod scenario;
pub mod scvx;
pub mod settings;
pub mod sim;
pub mod solution;
pub mod transcription;
pub mod validate;

pub use error::InputError;
pub use mesh::{Mesh, MeshLayout};
pub use observer::Observer;
pub use scenario::{Case, Formulation, Method, Scenario, SolverSettings};
pub use solution::{Solution, Status};

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
    let tr = transcription::Transcription::new(scenario, settings);
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
