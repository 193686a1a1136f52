//! Whether a `solved` answer lands: its controls re-integrated against the
//! scenario's landing tolerances.
//!
//! Collocation meets the dynamics only at its nodes. [`check`] re-integrates
//! the controls with [`propagate::propagate`] (DOP853 at 1e-10; the flown
//! controls of a polished answer, [`crate::polish`]; else PCHIP through the
//! nodes, the nozzle angle interpolated: the defaults of `bellyflop
//! solve`) and compares the miss at t_f,
//! ‖(x, z)(t_f) − (x_f, z_f)‖ \[m\] and ‖(Vx, Vz)(t_f) − (Vx_f, Vz_f)‖ [m/s],
//! with `solver.landing_position_tolerance_m` and
//! `solver.landing_velocity_tolerance_mps`. Beyond either, the status becomes
//! [`Status::Inaccurate`].

use crate::input::scenario::Scenario;
use crate::input::settings::SolverSettings;
use crate::solution::{Solution, Status};
use crate::verify::propagate::{self, Options};

/// Demote a `solved` answer whose re-integrated landing error exceeds the
/// scenario's tolerances (or cannot be measured) to `inaccurate`, with a
/// message that names the error and what to do. Other statuses are left alone.
pub fn check(scenario: &Scenario, settings: &SolverSettings, sol: &mut Solution) {
    if sol.status != Status::Solved {
        return;
    }
    let (tol_m, tol_mps) = (
        settings.landing_position_tolerance_m,
        settings.landing_velocity_tolerance_mps,
    );
    let n = sol.nodes;
    let more_nodes = format!(
        "use more nodes (discretization.nodes or --nodes, e.g. {}) or an hp mesh of several intervals (discretization.intervals or --intervals)",
        (2 * n).min(100)
    );
    let remedy = if sol.controls_flown.is_some() {
        "the polished controls should land within micrometres: please report this state".to_string()
    } else if settings.polish {
        // The polish ran and could not make these controls fly: advising it
        // again would send the user round in a circle.
        format!("the collocation meets the dynamics only at its N = {n} nodes and the polish could not make its controls fly; {more_nodes}")
    } else {
        format!("the collocation meets the dynamics only at its N = {n} nodes: polish the answer (solver.polish = true, the default; without --fast), or {more_nodes}")
    };
    let controls = if sol.controls_flown.is_some() {
        "the flown controls re-integrated (DOP853)"
    } else {
        "the controls re-integrated (DOP853, PCHIP)"
    };
    let before = if sol.message.is_empty() {
        String::new()
    } else {
        format!(" ({})", sol.message)
    };
    let reason = match propagate::propagate(scenario, sol, &Options::default()) {
        Ok(p) => {
            let e = p.landing_error;
            // Written so that a NaN error fails the test.
            if e.position_m <= tol_m && e.velocity_mps <= tol_mps {
                return;
            }
            format!(
                "{controls} land {:.3} m and {:.3} m/s from the target, beyond the tolerances of {tol_m} m and {tol_mps} m/s (solver.landing_position_tolerance_m, solver.landing_velocity_tolerance_mps){before}; {remedy}",
                e.position_m, e.velocity_mps
            )
        }
        Err(e) => {
            format!("the landing error could not be measured by re-integration ({e}); {remedy}")
        }
    };
    sol.status = Status::Inaccurate;
    sol.message = reason;
}
