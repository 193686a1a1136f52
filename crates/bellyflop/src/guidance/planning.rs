//! Planning setup: the problem the planner solves for one run, and the
//! first plan. The planner sees the vehicle less the feedback margins and
//! plans to the gate above the pad (the module docs of [`crate::guidance`]);
//! the first plan is a cold solve from the measured initial state, and the
//! planner is then set up for the re-plans' budget.

use crate::guidance::config::GuidanceConfig;
use crate::guidance::planner::{final_mass_guess, initial_state, Planner};
use crate::input::error::InputError;
use crate::input::scenario::{Case, InitialState, Scenario, TerminalState};
use crate::input::settings::SolverSettings;
use crate::method::observer::Silent;
use crate::problem::dynamics::{ix, Model};
use crate::sim::PlantState;
use crate::solution::{Solution, Status};

/// The planner's problem for one run, derived from the case and the
/// guidance settings.
pub(super) struct Planning {
    /// The scenario the planner solves: the thrust margin (hard, or soft in
    /// `settings`), the gimbal margin, and the gate as its terminal state.
    pub scenario: Scenario,
    pub settings: SolverSettings,
    /// Where the terminal descent lands: the case's terminal state.
    pub pad: TerminalState,
    /// The case's steady wind [m/s].
    pub steady_wind_mps: f64,
    /// The plans' (soft or hard) thrust limit \[N\].
    pub max_thrust_n: f64,
    /// The plans' gimbal limit \[rad\].
    pub gimbal_max_rad: f64,
}

impl Planning {
    /// The planning problem of `case` for the true vehicle `model`. Errors
    /// if the margins leave an invalid scenario or settings.
    pub fn new(case: &Case, guidance: &GuidanceConfig, model: &Model) -> Result<Self, InputError> {
        let scenario = &case.scenario;
        // The planner's engine: the true one less the feedback margin.
        let mut planning = scenario.clone();
        let mut settings = case.solver.clone();
        let mu = guidance.thrust_margin_frac;
        if guidance.thrust_margin_soft {
            settings.thrust_margin_frac = mu;
            settings.thrust_margin_weight = guidance.thrust_margin_weight;
        } else {
            planning.vehicle.min_thrust_n *= 1.0 + mu;
            planning.vehicle.max_thrust_n *= 1.0 - mu;
        }
        // Plans end at the gate; the terminal descent aims at the pad.
        let pad = scenario.terminal.clone();
        let steady_wind_mps = scenario.environment.wind_x_mps;
        planning.terminal.z_m += guidance.gate_height_m;
        planning.terminal.vz_mps -= guidance.gate_speed_mps;
        // The plan's (soft or hard) thrust limit.
        let max_thrust_n = model.max_thrust_n * (1.0 - mu);
        planning.vehicle.max_gimbal_deg *= 1.0 - guidance.gimbal_margin_frac;
        planning.vehicle.max_gimbal_rate_degps *= 1.0 - guidance.gimbal_margin_frac;
        planning.validate()?;
        settings.validate()?;
        let gimbal_max_rad = planning.vehicle.max_gimbal_deg.to_radians();
        Ok(Planning {
            scenario: planning,
            settings,
            pad,
            steady_wind_mps,
            max_thrust_n,
            gimbal_max_rad,
        })
    }

    /// A measured state as the planner's initial state, the nozzle angle
    /// within the plans' gimbal limit.
    pub fn start(&self, measured: &PlantState) -> InitialState {
        let mut x = lcvx(measured);
        x[ix::DELTA] = x[ix::DELTA].clamp(-self.gimbal_max_rad, self.gimbal_max_rad);
        initial_state(&x)
    }

    /// The first plan, a cold solve from `measured0`, and the planner set up
    /// for the re-plans. If the cold solve does not solve (or `measured0` is
    /// out of range), the nominal scenario's plan is the first plan, and the
    /// flag is true. The planner has no plan if even that fails.
    pub fn first_plan(
        &self,
        measured0: &PlantState,
        guidance: &GuidanceConfig,
    ) -> (Planner, Solution, bool) {
        let mut s0 = self.scenario.clone();
        s0.initial = self.start(measured0);
        s0.discretization.final_mass_guess_kg = final_mass_guess(
            None,
            0.0,
            s0.initial.mass_kg,
            s0.vehicle.dry_mass_kg,
            s0.discretization.final_mass_guess_kg,
        );
        let mut planner = Planner::new(self.scenario.clone(), self.settings.clone());
        planner.method = guidance.replan_method;
        planner.direct_max_iterations = guidance.replan_direct_max_iterations;
        let mut first_plan = None;
        if s0.validate().is_ok() {
            let mut p = Planner::new(s0, self.settings.clone());
            p.method = guidance.replan_method;
            let sol = p.cold(&mut Silent);
            if sol.status == Status::Solved {
                planner.plan = p.plan;
                first_plan = Some(sol);
            }
        }
        let (first_plan, nominal) = match first_plan {
            Some(sol) => (sol, false),
            None => (planner.cold(&mut Silent), true),
        };
        set_up_replans(&mut planner, guidance);
        (planner, first_plan, nominal)
    }
}

/// Re-plans run on the iteration budget (the cold first plan does not),
/// with the re-plans' own phases, weights and nodes.
fn set_up_replans(planner: &mut Planner, guidance: &GuidanceConfig) {
    planner.settings.max_iterations = guidance.replan_max_iterations;
    planner.warm_relaxed_iterations = guidance.replan_relaxed_iterations;
    planner.warm_proximal_weight = guidance.replan_proximal_weight;
    planner.settings.second_order_correction = guidance.replan_second_order_correction;
    planner.settings.terminal_lateral_weight = guidance.terminal_lateral_weight;
    if guidance.replan_nodes > 0 {
        let d = &mut planner.scenario.discretization;
        d.nodes = guidance.replan_nodes;
        d.intervals = d.intervals.min(d.nodes / 2);
    }
}

/// The LCvx state (x, z, Vx, Vz, θ, w, ln m, δ) of a plant state.
fn lcvx(s: &PlantState) -> [f64; 8] {
    [
        s.x_m,
        s.z_m,
        s.vx_mps,
        s.vz_mps,
        s.theta_rad,
        s.pitch_rate_radps,
        s.mass_kg.max(1.0).ln(),
        s.gimbal_rad,
    ]
}
