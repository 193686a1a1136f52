//! The flight: one closed-loop landing ([`fly`]). Every plant step the loop
//! measures the state, re-plans when one is due ([`super::replan`]), and
//! commands the plant by tracking the flown plan or, from the gate, by the
//! terminal descent ([`super::control`]).

use serde::Serialize;

use crate::guidance::config::GuidanceConfig;
use crate::guidance::control::{command, terminal_command};
use crate::guidance::navigation::{PositionFilter, WindEstimator};
use crate::guidance::planner::Planner;
use crate::guidance::planning::Planning;
use crate::guidance::replan::{replan, FlownPlan, ReplanEvent, ReplanOutcome};
use crate::input::error::InputError;
use crate::input::scenario::Case;
use crate::problem::dynamics::{ix, Model};
use crate::sim::{
    Command, Dispersions, Outcome, Plant, PlantConfig, PlantState, Realization, SaturationCounts,
    StepResult,
};
use crate::solution::Solution;

/// One sample of the flown trajectory (at the plant rate).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct TraceSample {
    pub t_s: f64,
    pub state: PlantState,
    pub thrust_cmd_n: f64,
    pub gimbal_rate_cmd_radps: f64,
    pub wind_mps: f64,
}

impl TraceSample {
    /// The plant's time and state now, with the command and wind of the
    /// step it is about to take (or has just ended).
    fn of(plant: &Plant, cmd: &Command, wind_mps: f64) -> Self {
        TraceSample {
            t_s: plant.time_s(),
            state: *plant.state(),
            thrust_cmd_n: cmd.thrust_n,
            gimbal_rate_cmd_radps: cmd.gimbal_rate_radps,
            wind_mps,
        }
    }
}

/// The result of one closed-loop landing.
#[derive(Debug, Clone)]
pub struct Flight {
    pub outcome: Outcome,
    /// The first plan (cold solve) that the run started with.
    pub first_plan: Solution,
    /// True if the first plan is the nominal scenario's (the cold solve
    /// from the measured initial state did not solve).
    pub first_plan_nominal: bool,
    pub replans: Vec<ReplanEvent>,
    pub saturation: SaturationCounts,
    /// Initial mass of the true vehicle \[kg\].
    pub initial_mass_kg: f64,
    /// The flown trajectory; empty unless asked for.
    pub trace: Vec<TraceSample>,
}

impl Flight {
    /// Propellant burnt \[kg\] (initial mass minus mass at the end).
    pub fn fuel_kg(&self) -> f64 {
        self.initial_mass_kg - end_state(&self.outcome).mass_kg
    }

    /// Re-plans that failed or missed their deadline.
    pub fn count(&self, outcome: ReplanOutcome) -> usize {
        self.replans.iter().filter(|r| r.outcome == outcome).count()
    }
}

/// The plant state at which a run ended.
pub fn end_state(o: &Outcome) -> PlantState {
    match o {
        Outcome::Touchdown(t) => t.state,
        Outcome::PropellantExhausted { state, .. }
        | Outcome::TimeLimit { state, .. }
        | Outcome::NonFinite { state, .. } => *state,
    }
}

/// Fly run `run_index` of campaign `seed`: draw the dispersions, plan, and
/// land in closed loop (or open loop with `guidance.replan = false`).
///
/// Errors only for invalid configurations, and for a 6-DoF scenario
/// ([`InputError::ModelUnavailable`]: the closed loop flies the planar
/// model); every other valid input gives a [`Flight`], whatever happens in
/// it.
pub fn fly(
    case: &Case,
    dispersions: &Dispersions,
    plant_config: &PlantConfig,
    guidance: &GuidanceConfig,
    seed: u64,
    run_index: u64,
    keep_trace: bool,
) -> Result<Flight, InputError> {
    case.validate()?;
    case.scenario
        .require_planar("the closed loop (guidance::fly)")?;
    dispersions.validate()?;
    guidance.validate()?;
    let mut realization = dispersions.sample(seed, run_index);
    let plant = Plant::from_realization(&case.scenario, plant_config, &realization)?;
    let initial_mass_kg = plant.state().mass_kg;
    let model = plant.model().clone();
    let planning = Planning::new(case, guidance, &model)?;

    // First plan: a cold solve from the measured initial state.
    let measured0 = realization.measure(plant.state());
    let (planner, first_plan, nominal) = planning.first_plan(&measured0, guidance);
    let Some(plan) = planner.plan.clone() else {
        // Not even the nominal scenario solves: nothing to fly. The plant
        // falls with the engine at minimum thrust until it ends.
        return Ok(fall_without_plan(
            plant,
            realization,
            first_plan,
            initial_mass_kg,
            keep_trace,
            &model,
            planning.steady_wind_mps,
        ));
    };
    let flown = FlownPlan {
        plan,
        start_s: 0.0,
        warm_start_s: 0.0,
    };
    let mut run = ClosedLoop {
        guidance,
        planning,
        planner,
        flown,
        model,
        plant,
        realization,
        replans: Vec::new(),
    };
    let (outcome, trace) = run.fly(keep_trace);
    Ok(Flight {
        outcome,
        first_plan,
        first_plan_nominal: nominal,
        replans: run.replans,
        saturation: *run.plant.saturation(),
        initial_mass_kg,
        trace,
    })
}

/// A run in flight: the plant and its draw, the planner and the flown plan.
struct ClosedLoop<'a> {
    guidance: &'a GuidanceConfig,
    planning: Planning,
    planner: Planner,
    flown: FlownPlan,
    /// The true vehicle's nominal model (limits and constants).
    model: Model,
    plant: Plant,
    realization: Realization,
    replans: Vec<ReplanEvent>,
}

impl ClosedLoop<'_> {
    /// Fly to the end of the run; returns how it ended and the trace (empty
    /// unless `keep_trace`).
    fn fly(&mut self, keep_trace: bool) -> (Outcome, Vec<TraceSample>) {
        let guidance = self.guidance;
        let dt_s = self.plant.dt_s();
        let period_s = 1.0 / guidance.replan_rate_hz;
        let mut next_replan_s = period_s;
        let mut trace = Vec::new();
        let mut terminal = false;
        let mut final_burn = false;
        let mut filter = PositionFilter::new(guidance.position_filter_s, dt_s);
        let mut wind_estimator = WindEstimator::new(dt_s, self.planning.steady_wind_mps);
        loop {
            let t = self.plant.time_s();
            let measured = filter.update(self.realization.measure(self.plant.state()));
            let time_to_go = self.flown.plan.tf_s() - (t - self.flown.start_s);
            let high_enough =
                measured.z_m - self.planning.scenario.terminal.z_m > guidance.stop_altitude_m;
            // With `stop_at_final_burn`, re-planning ends where the plan's
            // thrust reaches the planning limit: a re-plan from there has no
            // slack and often fails (measured: every re-plan after its start
            // on the nominal case, each after 15-40 iterations). A re-plan is
            // skipped too when the burn starts within the period. Evaluated
            // only when it matters, and no more once the burn has begun.
            final_burn =
                final_burn || (guidance.stop_at_final_burn && self.final_burn_within(t, period_s));
            if guidance.replan
                && t + 1e-9 >= next_replan_s
                && time_to_go > guidance.stop_time_to_go_s
                && high_enough
                && !final_burn
                && !terminal
            {
                next_replan_s += period_s;
                let event = replan(
                    &mut self.planner,
                    &mut self.flown,
                    &self.planning.start(&measured),
                    t,
                    &wind_estimator,
                    guidance,
                    &self.planning.scenario,
                );
                self.replans.push(event);
            }

            // The terminal descent takes over where re-planning stops.
            terminal |=
                guidance.feedback && (time_to_go <= guidance.stop_time_to_go_s || !high_enough);
            let cmd = if terminal {
                terminal_command(&measured, &self.planning.pad, guidance, dt_s, &self.model)
            } else {
                command(
                    &self.flown.plan,
                    t - self.flown.start_s,
                    &measured,
                    dt_s,
                    guidance.feedback,
                    &self.model,
                )
            };
            if guidance.wind_estimate {
                wind_estimator.update(&measured, &cmd, &self.model);
            }
            let wind = self.planning.steady_wind_mps + self.realization.wind_at_step(dt_s);
            if keep_trace {
                trace.push(TraceSample::of(&self.plant, &cmd, wind));
            }
            if let StepResult::Ended(outcome) = self.plant.step(cmd, wind) {
                if keep_trace {
                    trace.push(TraceSample::of(&self.plant, &cmd, wind));
                }
                return (outcome, trace);
            }
        }
    }

    /// The flown plan's thrust one re-plan period after flight time `t_s` is
    /// on its final burn (at [`FINAL_BURN_FRACTION`] of the planning limit or
    /// above).
    fn final_burn_within(&self, t_s: f64, period_s: f64) -> bool {
        let plan = &self.flown.plan;
        let tp = t_s - self.flown.start_s + period_s;
        let x = plan.state_at(tp);
        let (sigma, _) = plan.flight_controls_at(tp);
        sigma * x[ix::OMEGA].exp() >= FINAL_BURN_FRACTION * self.planning.max_thrust_n
    }
}

/// The plan is on its final burn from this fraction of the planning thrust
/// limit on.
const FINAL_BURN_FRACTION: f64 = 0.99;

/// A run with no plan at all: minimum thrust, nozzle centred, to the end.
fn fall_without_plan(
    mut plant: Plant,
    mut realization: Realization,
    first_plan: Solution,
    initial_mass_kg: f64,
    keep_trace: bool,
    model: &Model,
    steady_wind_mps: f64,
) -> Flight {
    let mut trace = Vec::new();
    loop {
        let cmd = Command {
            thrust_n: model.min_thrust_n,
            gimbal_rate_radps: 0.0,
        };
        let wind = steady_wind_mps + realization.wind_at_step(plant.dt_s());
        if keep_trace {
            trace.push(TraceSample::of(&plant, &cmd, wind));
        }
        if let StepResult::Ended(outcome) = plant.step(cmd, wind) {
            return Flight {
                outcome,
                first_plan,
                first_plan_nominal: true,
                replans: Vec::new(),
                saturation: *plant.saturation(),
                initial_mass_kg,
                trace,
            };
        }
    }
}
