//! Control: the commands between re-plans and after them. [`command`]
//! tracks the flown plan (the module docs of [`crate::guidance`] give the
//! loops); [`terminal_command`] flies the terminal descent from the gate to
//! touchdown on the measured state alone. Both are pure functions of their
//! inputs.

use crate::collocation::plan::Plan;
use crate::guidance::config::GuidanceConfig;
use crate::input::scenario::TerminalState;
use crate::problem::dynamics::{ix, Model};
use crate::sim::{Command, PlantState};

/// Bandwidths of the tracking loops (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gains {
    /// Pitch loop natural frequency [rad/s] and damping ratio.
    pub pitch_wn_radps: f64,
    pub pitch_zeta: f64,
    /// Translational loops (x and z) natural frequency [rad/s] and damping.
    pub trans_wn_radps: f64,
    pub trans_zeta: f64,
}

/// The default loop shapes: the pitch loop above the translational ones. At
/// 1.5 rad/s the pitch loop saturated the nozzle (δ and χ limits) in some
/// dispersed runs and went into a limit cycle (3 crashes in 20 runs); at 1
/// rad/s none of 20 did.
pub const GAINS: Gains = Gains {
    pitch_wn_radps: 1.0,
    pitch_zeta: 0.8,
    trans_wn_radps: 0.5,
    trans_zeta: 1.0,
};

/// Largest pitch offset the horizontal loop may ask for \[deg\].
pub const MAX_PITCH_OFFSET_DEG: f64 = 5.0;

/// Below this cos(θ + δ) the thrust is too far from vertical for the
/// translational loops (during the belly-flop); they are off there.
const MIN_COS_PHI: f64 = 0.5;

/// The control law between re-plans (module docs): plan time `t_plan_s`.
///
/// Beyond the plan's end the reference is the plan's final state with the
/// feed-forward σ = g0 / cos(θ + δ) (hover), so the feedback settles the
/// vehicle onto the pad instead of holding the final burn's thrust.
pub(super) fn command(
    plan: &Plan,
    t_plan_s: f64,
    measured: &PlantState,
    dt_s: f64,
    feedback: bool,
    model: &Model,
) -> Command {
    let (mut sigma, _) = plan.flight_controls_at(t_plan_s);
    let (_, mut delta_next) = plan.flight_controls_at(t_plan_s + dt_s);
    let r = plan.state_at(t_plan_s);
    let phi_ref = r[ix::THETA] + r[ix::DELTA];
    if t_plan_s > plan.tf_s() {
        sigma = model.g0_mps2 / phi_ref.cos().max(MIN_COS_PHI);
    }
    if feedback {
        let m = measured;
        let g = GAINS;
        let (wt, zt) = (g.trans_wn_radps, g.trans_zeta);
        let cos_phi = phi_ref.cos();
        let mut dtheta = 0.0;
        if cos_phi > MIN_COS_PHI {
            // V̇z = σ cos φ − g: Δσ = a_z / cos φ.
            let az = wt * wt * (r[ix::Z] - m.z_m) + 2.0 * zt * wt * (r[ix::VZ] - m.vz_mps);
            sigma += az / cos_phi;
            // V̇x = −σ sin φ: Δφ = −a_x / (σ cos φ), taken by the pitch.
            let ax = wt * wt * (r[ix::X] - m.x_m) + 2.0 * zt * wt * (r[ix::VX] - m.vx_mps);
            let lim = MAX_PITCH_OFFSET_DEG.to_radians();
            dtheta = (-ax / (sigma.max(1.0) * cos_phi)).clamp(-lim, lim);
        }
        // ẇ ≈ L_T σ sin δ + … with L_T < 0: a nozzle step Δδ gives
        // Δẇ ≈ −b Δδ, b = −L_T σ cos δ > 0. Place the pitch loop's poles.
        let b = (-model.l_t_pm * sigma.max(0.0) * r[ix::DELTA].cos()).max(1e-3);
        let (wp, zp) = (g.pitch_wn_radps, g.pitch_zeta);
        let e = m.theta_rad - r[ix::THETA] - dtheta;
        let edot = m.pitch_rate_radps - r[ix::W];
        delta_next += (wp * wp * e + 2.0 * zp * wp * edot) / b;
        let dmax = model.max_gimbal_rad;
        delta_next = delta_next.clamp(-dmax, dmax);
    }
    let chi_max = model.max_gimbal_rate_radps;
    let chi = (delta_next - measured.gimbal_rad) / dt_s;
    Command {
        thrust_n: sigma * measured.mass_kg,
        gimbal_rate_radps: chi.clamp(-chi_max, chi_max),
    }
}

/// Gain of the flare's vertical-speed loop [1/s]: a_z = g0 + k(−v_td − V̂z).
pub const TERMINAL_FLARE_GAIN_PER_S: f64 = 2.0;

/// Largest tilt the terminal descent commands \[deg\].
pub const TERMINAL_MAX_TILT_DEG: f64 = 5.0;

/// Bandwidth of the terminal descent's horizontal loop [rad/s] (critically
/// damped), well below the pitch loop's that executes it.
pub const TERMINAL_HORIZONTAL_WN_RADPS: f64 = 0.4;

/// Pitch-loop bandwidth of the terminal descent [rad/s]: faster than between
/// re-plans (1 rad/s), as the vehicle is upright and the thrust high, so it
/// settles before touchdown (20-run campaigns: touchdown pitch p95 0.9° at
/// 1.5 rad/s against 2.9° at 1 rad/s).
pub const TERMINAL_PITCH_WN_RADPS: f64 = 1.5;

/// With less time-to-go than this the terminal descent stops steering
/// horizontally and holds the vehicle upright, leaving the pitch loop time to
/// settle \[s\].
const TERMINAL_UPRIGHT_TGO_S: f64 = 2.0;

/// The terminal descent, a feedback law on the measured (filtered) state
/// alone, no plan, from where re-planning stops to touchdown:
///
/// - vertical, above the flare height h_fl
///   ([`GuidanceConfig::flare_height_m`]): the constant deceleration that
///   brings V̂z to −v_td ([`GuidanceConfig::touchdown_speed_mps`]) at h_fl,
///   a_z = (V̂z² − v_td²)/(2(h − h_fl)) + g0; below it (or once slower than
///   v_td) a speed hold, a_z = g0 + k(−v_td − V̂z)
///   ([`TERMINAL_FLARE_GAIN_PER_S`]); σ = a_z / cos φ. Aiming the
///   deceleration at the pad itself (h_fl = 0) landed 0.2–0.3 m/s faster
///   than aimed (the law's gain 1/h grows without bound there), 39 % of a
///   100-run campaign above 1 m/s; with the flare 12 % (docs/guidance.md);
/// - horizontal: a_x = −ω_h²(x̂ − x_f) − 2ω_h(V̂x − Vx_f)
///   ([`TERMINAL_HORIZONTAL_WN_RADPS`]; a zero-effort-miss law with
///   t_go = 2h/|V̂z| over-steered as t_go shrank, and ω_h = 0.6 overshot,
///   measured), taken by tilting, θ_cmd = −a_x/σ within
///   ±[`TERMINAL_MAX_TILT_DEG`], and upright once t_go = 2h/max(|V̂z|, v_td)
///   is below [`TERMINAL_UPRIGHT_TGO_S`];
/// - pitch: the same pole placement as between re-plans, at
///   [`TERMINAL_PITCH_WN_RADPS`].
pub(super) fn terminal_command(
    m: &PlantState,
    target: &TerminalState,
    guidance: &GuidanceConfig,
    dt_s: f64,
    model: &Model,
) -> Command {
    let h = m.z_m - target.z_m;
    let g0 = model.g0_mps2;
    let v_td = guidance.touchdown_speed_mps;
    let above_flare = h - guidance.flare_height_m;
    let az = if above_flare > 0.0 && -m.vz_mps > v_td {
        (m.vz_mps * m.vz_mps - v_td * v_td) / (2.0 * above_flare.max(0.1)) + g0
    } else {
        g0 + TERMINAL_FLARE_GAIN_PER_S * (-v_td - m.vz_mps)
    };
    let phi = m.theta_rad + m.gimbal_rad;
    let sigma = az.max(0.0) / phi.cos().max(MIN_COS_PHI);
    let mut theta_cmd = target.theta_deg.to_radians();
    let tgo = 2.0 * h.max(0.05) / (-m.vz_mps).max(v_td);
    if tgo > TERMINAL_UPRIGHT_TGO_S {
        let wh = TERMINAL_HORIZONTAL_WN_RADPS;
        let ax = -wh * wh * (m.x_m - target.x_m) - 2.0 * wh * (m.vx_mps - target.vx_mps);
        let lim = TERMINAL_MAX_TILT_DEG.to_radians();
        theta_cmd += (-ax / sigma.max(1.0)).clamp(-lim, lim);
    }
    let b = (-model.l_t_pm * sigma * m.gimbal_rad.cos()).max(1e-3);
    let (wp, zp) = (TERMINAL_PITCH_WN_RADPS, GAINS.pitch_zeta);
    let e = m.theta_rad - theta_cmd;
    let edot = m.pitch_rate_radps - target.pitch_rate_degps.to_radians();
    let dmax = model.max_gimbal_rad;
    let delta = ((wp * wp * e + 2.0 * zp * wp * edot) / b).clamp(-dmax, dmax);
    let chi_max = model.max_gimbal_rate_radps;
    Command {
        thrust_n: sigma * m.mass_kg,
        gimbal_rate_radps: ((delta - m.gimbal_rad) / dt_s).clamp(-chi_max, chi_max),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;
    use crate::sim::{Dispersions, Outcome, Plant, PlantConfig, StepResult};

    /// The terminal descent alone, from 12 m up at 6 m/s and 1.5 m off the
    /// pad, lands at the aimed vertical speed, near the pad and upright.
    #[test]
    fn terminal_descent_lands_at_the_aimed_speed() {
        let mut s = Scenario::paper();
        s.initial = crate::input::scenario::InitialState {
            x_m: 1.5,
            z_m: 12.0,
            vx_mps: 0.0,
            vz_mps: -6.0,
            theta_deg: 0.0,
            pitch_rate_degps: 0.0,
            mass_kg: 115_000.0,
            gimbal_deg: 0.0,
            ..Default::default()
        };
        let r = Dispersions::none().sample(1, 0);
        let mut plant = Plant::from_realization(&s, &PlantConfig::default(), &r).unwrap();
        let model = plant.model().clone();
        let g = GuidanceConfig::default();
        let td = loop {
            let cmd = terminal_command(plant.state(), &s.terminal, &g, plant.dt_s(), &model);
            if let StepResult::Ended(o) = plant.step(cmd, 0.0) {
                let Outcome::Touchdown(td) = o else {
                    panic!("{o:?}")
                };
                break td;
            }
        };
        let vz = -td.vertical_velocity_mps;
        assert!((vz - g.touchdown_speed_mps).abs() < 0.05, "{td:?}");
        assert!(td.x_error_m.abs() < 1.0, "{td:?}");
        // The horizontal loop is slow (it acts through the pitch) and stops
        // for the last 2 s: it leaves about 0.5 m/s sideways from a 1.5-m
        // offset (docs/guidance.md), within the 1-m/s touchdown speed.
        assert!(td.speed_mps <= 1.0, "{td:?}");
        assert!(td.pitch_error_deg.abs() < 1.0, "{td:?}");
    }
}
