//! One re-plan: from the measured state, warm-started from the flown plan
//! (or the last missed iterate), within the iteration budget, and what
//! became of it ([`ReplanEvent`], [`ReplanOutcome`]). The step adopts a
//! solved or usable plan into the [`FlownPlan`] and keeps the planner's warm
//! start; the flight loop ([`crate::guidance::fly`]) decides when to call it.

use std::time::Instant;

use serde::Serialize;

use crate::collocation::plan::Plan;
use crate::guidance::config::GuidanceConfig;
use crate::guidance::navigation::WindEstimator;
use crate::guidance::planner::Planner;
use crate::input::error::InputError;
use crate::input::scenario::{InitialState, Scenario};
use crate::method::observer::Silent;
use crate::solution::{Solution, Status};

/// What became of one re-plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ReplanOutcome {
    /// Solved within the deadline; the new plan is flown.
    Accepted,
    /// Not `solved` (or the measured state was out of range); old plan kept.
    Failed,
    /// Not converged within the iteration budget (the deadline), but the
    /// returned iterate meets the dynamics (defect ≤ [`USABLE_DEFECT`],
    /// virtual control ≤ [`USABLE_VIRTUAL_CONTROL`]) and every physical
    /// check: flown, as a real-time iteration would be.
    Usable,
    /// Not converged within the iteration budget and not usable; old plan
    /// kept.
    Missed,
}

/// How a re-plan's solve ended. Written as the method's status name
/// (`solved`, `not_converged`, …, [`Status::as_str`]) or `bad_state`, in the
/// JSON and in `replans.csv` alike.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReplanStatus {
    /// The method ran and ended with this status.
    Solver(Status),
    /// The measured state was outside the planner's validated ranges: no
    /// solve ([`Planner::replan`] returned an error, named in
    /// [`ReplanEvent::reason`]).
    BadState,
}

impl ReplanStatus {
    /// The name written to the outputs.
    pub fn as_str(self) -> &'static str {
        match self {
            ReplanStatus::Solver(status) => status.as_str(),
            ReplanStatus::BadState => "bad_state",
        }
    }
}

impl std::fmt::Display for ReplanStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Serialize for ReplanStatus {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.as_str())
    }
}

/// One re-plan of a run.
#[derive(Debug, Clone, Serialize)]
pub struct ReplanEvent {
    /// Time of the measurement it started from \[s\].
    pub time_s: f64,
    /// Wall-clock solve time \[ms\].
    pub solve_ms: f64,
    /// The wall-clock time exceeded [`GuidanceConfig::deadline`] (reported
    /// only; the budget decides).
    pub late: bool,
    /// Iterations of the planner's method (SCvx or interior-point
    /// iterations, [`GuidanceConfig::replan_method`]); 0 for `bad_state`.
    pub iterations: usize,
    /// How the solve ended: the method's status (`solved`, `infeasible`, …)
    /// or `bad_state`.
    pub status: ReplanStatus,
    /// Why it was not `solved`, or empty.
    pub reason: String,
    /// Largest nonlinear collocation defect and virtual control of the
    /// returned iterate (scaled; see `solution::Checks`).
    pub max_defect: f64,
    pub virtual_control: f64,
    /// The wind the re-plan was made in [m/s] (the estimate, or the
    /// scenario's steady wind without [`GuidanceConfig::wind_estimate`]).
    pub wind_estimate_mps: f64,
    pub outcome: ReplanOutcome,
    /// The answer the re-plan returned, at its nodes, for drawing it against
    /// the flight (the viewer); empty for `bad_state`. Not serialized: the
    /// JSON of a flight keeps its shape.
    #[serde(skip)]
    pub path: PlanPath,
}

/// A re-plan's answer at its LGR nodes, on the flight's clock.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlanPath {
    /// Flight time \[s\]: the re-plan's measurement time plus the plan's.
    pub t_s: Vec<f64>,
    pub x_m: Vec<f64>,
    pub z_m: Vec<f64>,
    pub vx_mps: Vec<f64>,
    pub vz_mps: Vec<f64>,
    pub theta_rad: Vec<f64>,
}

impl PlanPath {
    /// The nodes of `sol`, a plan that starts at flight time `t0_s`.
    fn of(sol: &Solution, t0_s: f64) -> PlanPath {
        PlanPath {
            t_s: sol.t_s.iter().map(|t| t0_s + t).collect(),
            x_m: sol.x_m.clone(),
            z_m: sol.z_m.clone(),
            vx_mps: sol.vx_mps.clone(),
            vz_mps: sol.vz_mps.clone(),
            theta_rad: sol.theta_rad.clone(),
        }
    }
}

/// The plan being flown, with the times the loop keeps with it.
pub(super) struct FlownPlan {
    pub plan: Plan,
    /// Flight time at which the flown plan starts \[s\].
    pub start_s: f64,
    /// Start time of the planner's warm start \[s\]: the flown plan's, or
    /// the last missed re-plan's with [`GuidanceConfig::continue_missed`].
    pub warm_start_s: f64,
}

/// Re-plan at flight time `t_s` from `start` (the measured state as the
/// planner's initial state), in the estimated wind with
/// [`GuidanceConfig::wind_estimate`]. A solved or usable plan becomes the
/// flown one; the planner keeps the warm start for the next re-plan
/// ([`adopt`]). Returns the event to log.
pub(super) fn replan(
    planner: &mut Planner,
    flown: &mut FlownPlan,
    start: &InitialState,
    t_s: f64,
    wind: &WindEstimator,
    guidance: &GuidanceConfig,
    scenario: &Scenario,
) -> ReplanEvent {
    let previous = planner.plan.clone();
    if guidance.wind_estimate {
        planner.scenario.environment.wind_x_mps = wind.wind().0.clamp(-100.0, 100.0);
    }
    let clock = Instant::now();
    let result = planner.replan(start, t_s - flown.warm_start_s, &mut Silent);
    let solve_ms = clock.elapsed().as_secs_f64() * 1e3;
    let outcome = classify(&result, scenario);
    adopt(
        planner,
        flown,
        previous,
        &result,
        outcome,
        t_s,
        guidance.continue_missed,
    );
    let (iterations, status, reason, max_defect, virtual_control) = match &result {
        Ok(sol) => (
            sol.iterations,
            ReplanStatus::Solver(sol.status),
            sol.message.clone(),
            sol.checks.max_defect,
            sol.checks.virtual_control,
        ),
        Err(e) => (0, ReplanStatus::BadState, e.to_string(), f64::NAN, f64::NAN),
    };
    ReplanEvent {
        time_s: t_s,
        solve_ms,
        late: solve_ms > guidance.deadline() * 1e3,
        iterations,
        status,
        reason,
        max_defect,
        virtual_control,
        wind_estimate_mps: planner.scenario.environment.wind_x_mps,
        outcome,
        path: result
            .as_ref()
            .map_or_else(|_| PlanPath::default(), |sol| PlanPath::of(sol, t_s)),
    }
}

/// What becomes of a re-plan's result: flown if solved, or unconverged at
/// the budget and [`usable`]; otherwise failed or missed.
fn classify(result: &Result<Solution, InputError>, scenario: &Scenario) -> ReplanOutcome {
    match result {
        Err(_) => ReplanOutcome::Failed,
        Ok(sol) if sol.status == Status::Solved => ReplanOutcome::Accepted,
        Ok(sol) if sol.status == Status::NotConverged => {
            if usable(sol, scenario) {
                ReplanOutcome::Usable
            } else {
                ReplanOutcome::Missed
            }
        }
        Ok(_) => ReplanOutcome::Failed,
    }
}

/// Fly an accepted or usable re-plan from `t_s` on, and set the planner's
/// warm start: the new plan, a missed re-plan's iterate (with
/// `continue_missed`), or else the plan it had before (`previous`).
fn adopt(
    planner: &mut Planner,
    flown: &mut FlownPlan,
    previous: Option<Plan>,
    result: &Result<Solution, InputError>,
    outcome: ReplanOutcome,
    t_s: f64,
    continue_missed: bool,
) {
    match (result, outcome) {
        (_, ReplanOutcome::Accepted) => {
            flown.plan = planner
                .plan
                .clone()
                .expect("a solved re-plan sets the plan");
            flown.start_s = t_s;
            flown.warm_start_s = t_s;
        }
        // The planner keeps only solved plans; a usable iterate is
        // adopted here, and warm-starts the next re-plan.
        (Ok(sol), ReplanOutcome::Usable) => {
            flown.plan = sol.plan();
            planner.plan = Some(flown.plan.clone());
            flown.start_s = t_s;
            flown.warm_start_s = t_s;
        }
        // A missed re-plan is not flown, but its iterate is nearer the new
        // optimum than the flown plan: the next re-plan continues from it.
        (Ok(sol), ReplanOutcome::Missed) if continue_missed && sol.trajectory.is_finite() => {
            planner.plan = Some(sol.plan());
            flown.warm_start_s = t_s;
        }
        _ => planner.plan = previous,
    }
}

/// Largest scaled collocation defect of a usable unconverged re-plan. The
/// best iterates at the budget measured 1e-7 to 3e-4 (their virtual control
/// 1e-10 or less), against 1e-6 for convergence.
pub const USABLE_DEFECT: f64 = 1e-3;

/// Largest scaled virtual control of a usable unconverged re-plan.
pub const USABLE_VIRTUAL_CONTROL: f64 = 1e-6;

/// An unconverged re-plan's iterate is flown if it meets the dynamics and
/// every physical check: thrust along the nozzle and within its bounds (to
/// 1 %), no relaxation gap, and above the ground (to 0.5 m).
fn usable(sol: &Solution, scenario: &Scenario) -> bool {
    let c = &sol.checks;
    c.max_defect <= USABLE_DEFECT
        && c.virtual_control <= USABLE_VIRTUAL_CONTROL
        && c.relaxation_gap <= 1e-6
        && !c.thrust_backwards()
        && c.thrust_bound_violation_n <= 0.01 * scenario.vehicle.max_thrust_n
        && c.min_altitude_margin_m >= -0.5
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The status is written as today's strings: the method's status name,
    /// or `bad_state`.
    #[test]
    fn status_names_are_the_outputs_strings() {
        for s in [
            Status::Solved,
            Status::NonPhysical,
            Status::Infeasible,
            Status::NotConverged,
            Status::SolverFailed,
            Status::Inaccurate,
        ] {
            let r = ReplanStatus::Solver(s);
            assert_eq!(r.to_string(), s.as_str());
            assert_eq!(
                serde_json::to_value(r).unwrap(),
                serde_json::to_value(s).unwrap()
            );
        }
        assert_eq!(ReplanStatus::BadState.to_string(), "bad_state");
        assert_eq!(
            serde_json::to_string(&ReplanStatus::BadState).unwrap(),
            "\"bad_state\""
        );
    }
}
