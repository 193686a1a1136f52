//! The guidance loop's settings ([`GuidanceConfig`]): their defaults, the
//! measurements behind them, and their ranges.

use serde::{Deserialize, Serialize};

use crate::input::error::InputError;
use crate::input::range::{check_all, count_in_range, Range};

/// Guidance-loop settings. Missing fields take the defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GuidanceConfig {
    /// Re-plan from the measured state at all; false flies the first plan
    /// open loop. Default true.
    pub replan: bool,
    /// Re-plan rate \[Hz\]. Default 2. Range (0, 100].
    pub replan_rate_hz: f64,
    /// Deadline of one re-plan, as an SCvx iteration budget (relaxed and
    /// exact phases together): a re-plan that has not converged within it
    /// has missed its deadline, and its iterate is flown only if usable
    /// ([`crate::guidance::ReplanOutcome::Usable`]). A budget rather than a
    /// clock keeps runs reproducible on a loaded machine; 12 iterations take about 200 ms at
    /// N = 20 here, well within the 500-ms period. Default 12: on 20-run
    /// campaigns budgets of 12, 20 and 100 gave the same touchdown errors to
    /// within 1 cm and 0.03 m/s, and 12 runs the campaign 25 % faster than
    /// 20. Range 1 to 1000.
    pub replan_max_iterations: usize,
    /// The planner's method, for the first plan and the re-plans: `direct`
    /// (default) or `scvx`, with which the other defaults were tuned.
    /// 1000-run campaigns (seeds 1 and 2, docs/guidance.md): 995 and 994
    /// within spec with direct re-plans, 996 and 994 with SCvx, at re-plan
    /// times p50 3 against 49 ms and 16× less campaign time: most direct
    /// re-plans converge within their budget, where SCvx's are flown
    /// unconverged.
    pub replan_method: crate::Method,
    /// Deadline of a direct re-plan, as an interior-point iteration budget.
    /// Default [`crate::guidance::planner::DIRECT_REPLAN_ITERATIONS`]. Range 1 to 1000.
    pub replan_direct_max_iterations: usize,
    /// Iterations of the re-plans' relaxed first phase (the paper's
    /// formulation, [`crate::guidance::planner::Planner::warm_relaxed_iterations`]),
    /// within the budget; the cold first plan keeps the scenario's
    /// `solver.relaxed_first_iterations`.
    /// Default 0: from a warm start the relaxed phase often spent its 10
    /// iterations without converging and left the exact phase 2 (of the 42
    /// runs outside spec in the first 1000-run campaign with the gate, 18
    /// land within spec with 0 and 19 with 2; 100-run campaigns unchanged).
    /// The exact phase then meets the dynamics within the budget but seldom
    /// its step tolerance (the trust region oscillates on the singular
    /// arcs), so most re-plans are flown `usable`. Range 0 to 1000.
    pub replan_relaxed_iterations: usize,
    /// Proximal weight of the re-plans' subproblems
    /// ([`crate::guidance::planner::Planner::warm_proximal_weight`]). Default 0 (see
    /// docs/guidance.md for the campaigns with the planner's 0.01).
    /// Range [0, 1e6].
    pub replan_proximal_weight: f64,
    /// Whether re-plans use the second-order correction of poor steps
    /// (`solver.second_order_correction`, which the cold first plan keeps).
    /// Default false: re-plans are flown unconverged at their iteration
    /// budget, where the correction costs time and buys no accuracy
    /// (docs/guidance.md, "Second-order correction").
    pub replan_second_order_correction: bool,
    /// Wall-clock deadline of one re-plan \[s\], reported only (re-plans past
    /// it count as `late`); 0 means the re-plan period. Default 0.
    pub deadline_s: f64,
    /// No re-plan once the plan's time-to-go is below this \[s\]; the terminal
    /// descent flies the rest. Plans end at the gate
    /// ([`GuidanceConfig::gate_height_m`]), so this is the time to the gate.
    /// Default 1.
    pub stop_time_to_go_s: f64,
    /// No re-plan below this measured altitude above the gate \[m\]. Default 2.
    pub stop_altitude_m: f64,
    /// Stop re-planning once the plan's final burn (thrust at the planning
    /// limit) has begun. Default false: re-plans on the final burn often
    /// miss (the plan's tail has no thrust slack), but those that solve
    /// remove the position error the tracking loops cannot (100-run
    /// campaign: 63 % → 75 % of runs within spec, docs/guidance.md).
    pub stop_at_final_burn: bool,
    /// LGR points N of the re-plans (the first plan uses the scenario's);
    /// 0 keeps the scenario's. A re-plan covers a shrinking horizon, so fewer
    /// points keep its node spacing. Default 10: in 100-run campaigns
    /// N = 10, 12 and 20 put 77, 74 and 75 % of runs within spec, in 60,
    /// 82 and 180 s. Range 0 or 4 to 100.
    pub replan_nodes: usize,
    /// Track the plan's states between re-plans, and fly the terminal
    /// descent (module docs). Default true.
    pub feedback: bool,
    /// Thrust margin kept for feedback: plans use [T_min·(1 + μ),
    /// T_max·(1 − μ)] while the engine can do [T_min, T_max]. A fuel-optimal
    /// plan ends at full thrust, so without a margin nothing is left to
    /// correct a 3 % thrust error. Default 0.10: at 0.05 the terminal
    /// descent often ran out of thrust (20-run campaigns: touchdown vertical
    /// speed p95 1.4 m/s at 0.05, 1.2 at 0.08, 1.0 at 0.12); each 0.01 costs
    /// about 40 kg of propellant. Range [0, 0.3].
    pub thrust_margin_frac: f64,
    /// Warm-start the next re-plan from a missed re-plan's iterate (not
    /// flown) rather than from the flown plan, so that successive re-plans
    /// add up their iterations. Default true (100-run campaign: 95 → 96 %
    /// within spec; a run whose re-plans all missed after the wind estimate
    /// moved the optimum now lands within 0.2 m).
    pub continue_missed: bool,
    /// Estimate the wind from the measured velocity
    /// ([`crate::guidance::navigation::WindEstimator`]) and plan each
    /// re-plan in it. Default true. The plans otherwise assume still air: with the wind dispersion off, 100
    /// of 100 runs landed within spec, against 94 with it; with the
    /// estimate 95, and the horizontal touchdown speed p95 fell from 0.71
    /// to 0.43 m/s.
    pub wind_estimate: bool,
    /// Make the thrust margin soft: plans may use the engine's full range
    /// where they must, at a cost ([`crate::input::settings::SolverSettings::thrust_margin_frac`],
    /// weight `thrust_margin_weight`), so a vehicle that has fallen
    /// slightly behind its plan on the final burn still gets a re-plan
    /// instead of an infeasible one. False: the margin is a hard limit.
    /// Default true: with the gate, 100-run campaigns put 70 % of runs
    /// within spec with the hard margin and 94 % with the soft one.
    pub thrust_margin_soft: bool,
    /// Cost weight of the soft margin's use (scaled units, where the fuel
    /// cost is of order one). It must stay below the virtual-control weight
    /// λ by the ratio of the two variables' scales, or SCvx prefers virtual
    /// control (it settled "infeasible" on states the full engine can land
    /// from), and high enough that the plans keep the margin where they can.
    /// Default 100 (100-run campaigns: 73, 99, 97 and 96 % within spec at
    /// 10, 100, 300 and 1000; with the other defaults of their time).
    /// Range (0, 1e6].
    pub thrust_margin_weight: f64,
    /// Height of the plans' end above the pad \[m\] (the gate); the terminal
    /// descent flies from there to touchdown. 0 plans to the pad itself.
    /// A fuel-optimal plan ends on full (planning) thrust, so a vehicle
    /// that reaches the pad's neighbourhood slightly behind its plan has no
    /// thrust left to stop; at the gate the terminal descent needs about
    /// hover thrust, half the engine's. Default 3 (100-run campaigns with
    /// the soft margin: 93, 94 and 83 % within spec at 2, 3 and 5 m; the
    /// plan-to-the-pad design of 2026-11-30 reached 79 %). It costs 150–200
    /// kg of propellant (fuel p50). Range [0, 50].
    pub gate_height_m: f64,
    /// Descent speed of the plans at the gate [m/s]. Default 2 (84 % within
    /// spec at 3). Range [0, 10].
    pub gate_speed_mps: f64,
    /// Weight of the re-plans' soft terminal x and Vx
    /// ([`crate::input::settings::SolverSettings::terminal_lateral_weight`]);
    /// 0 = hard. In the last seconds a late re-plan can seldom null the
    /// lateral error any more (the pitch dynamics are slow); with hard
    /// terminal x and Vx it failed, and the stale plan flew the vehicle past
    /// the pad. Default 1000 (of the 42 runs above, 18, 34 and 39 land
    /// within spec at 0, 100 and 1000; 100-run campaigns 100 and 98 %
    /// within spec with seeds 1 and 2). A soft lateral constraint at the
    /// gate, |Vx| ≤ 0.5 m/s + k·(z − z_gate) on every node, did not help
    /// (16 and 15 of the 42 at k = 0.1 and 0.2 /s) and was removed.
    /// Range [0, 1e12].
    pub terminal_lateral_weight: f64,
    /// Nozzle margin kept for the pitch loop: plans use δ_max·(1 − μ_δ) and
    /// χ_max·(1 − μ_δ). Default 0.2. Range [0, 0.5].
    pub gimbal_margin_frac: f64,
    /// Time constant of the position filter applied to the navigation
    /// output before guidance uses it \[s\]
    /// ([`crate::guidance::navigation::PositionFilter`]); 0 uses the raw
    /// measurement. Default 1. Range [0, 10].
    pub position_filter_s: f64,
    /// Vertical speed the terminal descent lands at [m/s]. Default 0.5
    /// (100-run campaigns: 78, 79 and 79 % within spec at 0.6, 0.5 and
    /// 0.4, at 6005, 6035 and 6080 kg of propellant). Range (0, 3].
    pub touchdown_speed_mps: f64,
    /// Height above the pad where the terminal descent has slowed to
    /// `touchdown_speed_mps` and holds it \[m\] (the flare). Default 0.5;
    /// each metre costs about one second of hover, ~350 kg of propellant
    /// for the paper's vehicle. Range [0, 10].
    pub flare_height_m: f64,
}

impl Default for GuidanceConfig {
    fn default() -> Self {
        GuidanceConfig {
            replan: true,
            replan_rate_hz: 2.0,
            replan_max_iterations: 12,
            replan_method: crate::Method::Direct,
            replan_direct_max_iterations: crate::guidance::planner::DIRECT_REPLAN_ITERATIONS,
            replan_relaxed_iterations: 0,
            replan_proximal_weight: 0.0,
            replan_second_order_correction: false,
            deadline_s: 0.0,
            stop_time_to_go_s: 1.0,
            stop_altitude_m: 2.0,
            stop_at_final_burn: false,
            replan_nodes: 10,
            feedback: true,
            thrust_margin_frac: 0.10,
            continue_missed: true,
            wind_estimate: true,
            thrust_margin_soft: true,
            thrust_margin_weight: 100.0,
            gate_height_m: 3.0,
            gate_speed_mps: 2.0,
            terminal_lateral_weight: 1000.0,
            gimbal_margin_frac: 0.2,
            position_filter_s: 1.0,
            touchdown_speed_mps: 0.5,
            flare_height_m: 0.5,
        }
    }
}

impl GuidanceConfig {
    /// Ranges of every field; the error names the field, value and range.
    pub fn validate(&self) -> Result<(), InputError> {
        count_in_range(
            "guidance.replan_max_iterations",
            self.replan_max_iterations,
            (1, 1000),
        )?;
        count_in_range(
            "guidance.replan_direct_max_iterations",
            self.replan_direct_max_iterations,
            (1, 1000),
        )?;
        count_in_range(
            "guidance.replan_relaxed_iterations",
            self.replan_relaxed_iterations,
            (0, 1000),
        )?;
        if self.replan_nodes != 0 {
            count_in_range("guidance.replan_nodes", self.replan_nodes, (4, 100))?;
        }
        check_all(&[
            (
                "guidance.replan_rate_hz",
                self.replan_rate_hz,
                Range::open_closed(0.0, 100.0, "Hz"),
            ),
            (
                "guidance.deadline_s",
                self.deadline_s,
                Range::closed(0.0, 60.0, "s"),
            ),
            (
                "guidance.terminal_lateral_weight",
                self.terminal_lateral_weight,
                Range::closed(0.0, 1e12, ""),
            ),
            (
                "guidance.replan_proximal_weight",
                self.replan_proximal_weight,
                Range::closed(0.0, 1e6, ""),
            ),
            (
                "guidance.stop_time_to_go_s",
                self.stop_time_to_go_s,
                Range::closed(0.0, 1000.0, "s"),
            ),
            (
                "guidance.stop_altitude_m",
                self.stop_altitude_m,
                Range::closed(0.0, 1e4, "m"),
            ),
            (
                "guidance.thrust_margin_frac",
                self.thrust_margin_frac,
                Range::closed(0.0, 0.3, ""),
            ),
            (
                "guidance.thrust_margin_weight",
                self.thrust_margin_weight,
                Range::open_closed(0.0, 1e6, ""),
            ),
            (
                "guidance.gimbal_margin_frac",
                self.gimbal_margin_frac,
                Range::closed(0.0, 0.5, ""),
            ),
            (
                "guidance.position_filter_s",
                self.position_filter_s,
                Range::closed(0.0, 10.0, "s"),
            ),
            (
                "guidance.touchdown_speed_mps",
                self.touchdown_speed_mps,
                Range::open_closed(0.0, 3.0, "m/s"),
            ),
            (
                "guidance.flare_height_m",
                self.flare_height_m,
                Range::closed(0.0, 10.0, "m"),
            ),
            (
                "guidance.gate_height_m",
                self.gate_height_m,
                Range::closed(0.0, 50.0, "m"),
            ),
            (
                "guidance.gate_speed_mps",
                self.gate_speed_mps,
                Range::closed(0.0, 10.0, "m/s"),
            ),
        ])
    }

    /// The deadline actually applied \[s\].
    pub fn deadline(&self) -> f64 {
        if self.deadline_s > 0.0 {
            self.deadline_s
        } else {
            1.0 / self.replan_rate_hz
        }
    }
}
