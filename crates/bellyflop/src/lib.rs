//! bellyflop: fuel-optimal flip-and-land trajectories by Legendre–Gauss–Radau
//! collocation and successive convexification (Chen, Ma, Wang, Su 2023).
//!
//! - [`scenario`], [`validate`]: parameters from TOML, checked before anything runs;
//! - [`dynamics`]: the models of Eq. (1)–(3), (8), (21)–(22) and their Jacobians;
//! - [`radau`]: LGR nodes, weights, differentiation and interpolation;
//! - [`mesh`]: the global LGR mesh or an hp mesh of LGR intervals;
//! - [`transcription`]: the convex subproblem P4 as conic data for Clarabel;
//! - [`conic`]: Clarabel, set up once per structure and updated in place;
//! - [`scvx`]: the successive-convexification driver loop;
//! - [`solution`]: status, physical trajectory, checks and history;
//! - [`replan`]: warm re-plans from the shifted previous plan;
//! - [`propagate`]: landing precision by re-integrating the nonlinear model;
//! - [`accuracy`]: the re-integrated landing error of a `solved` answer against
//!   its tolerances;
//! - [`sim`]: the truth plant and Monte-Carlo dispersions for closed-loop guidance;
//! - [`navigation`]: filters on the measured state (position, wind);
//! - [`guidance`]: the closed loop — navigation, re-planning, control.
pub mod accuracy;
pub mod conic;
pub mod direct;
pub mod dynamics;
pub mod error;
pub mod guidance;
pub mod kkt;
pub mod mesh;
pub mod navigation;
pub mod nlp;
pub mod propagate;
pub mod radau;
pub mod replan;
pub mod scenario;
pub mod scvx;
pub mod sim;
pub mod solution;
pub mod transcription;
pub mod validate;

pub use error::InputError;
pub use scenario::{Formulation, Method, Scenario};
pub use scvx::Observer;
pub use solution::{Solution, Status};

/// Solve a scenario with the method its settings name
/// (`solver.method`: SCvx or the direct interior-point method). A `solved`
/// answer whose controls, re-integrated, land beyond the scenario's
/// tolerances is `inaccurate` ([`accuracy::check`]). `solve_time_ms` is the
/// method's own time: the re-integration is not counted. The methods on
/// their own ([`scvx::solve`], [`direct::solve`], and the closed loop's
/// re-plans) skip the check.
pub fn solve(scenario: &Scenario, observer: &mut dyn Observer) -> Solution {
    let mut sol = match scenario.solver.method {
        Method::Scvx => scvx::solve(scenario, observer),
        Method::Direct => direct::solve(scenario, observer),
    };
    accuracy::check(scenario, &mut sol);
    sol
}
