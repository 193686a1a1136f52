//! The truth plant: Eq. (1)–(3) plus δ̇ = χ (Eq. 8), with model errors and
//! wind, integrated by fixed-step RK4 under a zero-order-hold command.
//!
//! # Truth dynamics ([`truth_rhs`])
//!
//! State (x, z, Vx, Vz, θ, w, m, δ) as in [`dynamics::rhs_augmented`], control
//! (T, χ). The plant differs from the guidance model of [`dynamics`] by
//! ([`TruthParams`] and the wind):
//! - drag acts on the air-relative velocity (Vx − W, Vz), W the horizontal
//!   wind [m/s] (Eq. 2 with V replaced by V − W), and so does its pitching
//!   moment (Eq. 3); the position rates stay the ground-relative (Vx, Vz);
//! - the drag coefficient is C_LD·k_D;
//! - the engine delivers T·k_T, and burns propellant at the delivered thrust,
//!   ṁ = −T·k_T/(I_sp·g0) (I_sp itself is exact);
//! - the thrust acts at δ + b: b is a thrust-axis misalignment. The gimbal
//!   stops limit the commanded nozzle angle δ (the state), not δ + b.
//!
//! # Actuators ([`saturate`])
//!
//! The guidance commands thrust and gimbal rate ([`Command`]). Before each
//! step: T is clamped to [T_min, T_max], and is 0 once the mass is at or below
//! the dry mass (propellant exhausted); χ is clamped to ±χ_max, and further so
//! that δ + χ·Δt stays within ±δ_max (so χ = 0 at a stop when pushing
//! outwards, and δ reaches the stop exactly rather than overshooting it).
//! Every clamp is reported ([`Saturation`], counted in [`SaturationCounts`]).
//!
//! # Integration ([`Plant`])
//!
//! Classical RK4 at a fixed step Δt = 1/[`PlantConfig::rate_hz`] (default
//! 100 Hz), command and wind held constant over the step. A step ends the run
//! when, within it,
//! - z crosses the pad altitude z_f from above: the crossing time is found
//!   by safeguarded Newton iteration on the RK4 sub-step from the step start
//!   (RK4 over a sub-step τ, with the same held command and wind), and the
//!   state at that time is returned ([`Touchdown`]);
//! - the mass reaches the dry mass: with T constant over the step, m is linear
//!   in time (and integrated exactly by RK4), so the crossing time is exact
//!   ([`Outcome::PropellantExhausted`]);
//! - whichever comes first. A run also ends at [`PlantConfig::max_time_s`]
//!   ([`Outcome::TimeLimit`]) and if the state becomes non-finite
//!   ([`Outcome::NonFinite`]). Nothing here panics or loops without bound.
//!
//! Only a crossing from above is a touchdown: a dip below z_f that comes back
//! above it within one step (10 ms by default) is not detected, and a run
//! that starts at or below z_f is not checked until it has risen above it
//! (it still ends, at the time limit at the latest).

use serde::{Deserialize, Serialize};

use crate::input::error::InputError;
use crate::input::range::Range;
use crate::input::scenario::{Scenario, TerminalState};
use crate::problem::dynamics::{self, ix, Model};
use crate::sim::disturbance::Realization;
use crate::sim::truth::{PlantState, TruthParams};

/// An actuator command, held constant over one plant step: the controls
/// (T, χ) of problem P2 (Eq. 8).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Command {
    /// Thrust magnitude T \[N\].
    pub thrust_n: f64,
    /// Gimbal rate χ = δ̇ [rad/s].
    pub gimbal_rate_radps: f64,
}

impl Command {
    /// A command that tracks a nozzle angle: χ = clamp((δ_cmd − δ)/Δt, ±χ_max),
    /// which reaches δ_cmd at the end of a step of `dt_s` when the rate allows.
    ///
    /// `gimbal_rad` is the current (measured) δ. A non-positive or non-finite
    /// `dt_s` gives χ = 0. The angle limit ±δ_max is left to [`saturate`], so
    /// that a command beyond the stop shows up as saturation.
    pub fn tracking_gimbal(
        thrust_n: f64,
        gimbal_cmd_rad: f64,
        gimbal_rad: f64,
        dt_s: f64,
        max_gimbal_rate_radps: f64,
    ) -> Self {
        let rate = if dt_s > 0.0 && dt_s.is_finite() {
            let r = (gimbal_cmd_rad - gimbal_rad) / dt_s;
            let lim = max_gimbal_rate_radps.abs();
            if r.is_finite() {
                r.max(-lim).min(lim)
            } else {
                0.0
            }
        } else {
            0.0
        };
        Command {
            thrust_n,
            gimbal_rate_radps: rate,
        }
    }
}

/// Which actuator limits were active in one step.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Saturation {
    /// The thrust command exceeded T_max.
    pub thrust_max: bool,
    /// The thrust command was below T_min (or not a number).
    pub thrust_min: bool,
    /// The mass was at the dry mass: thrust forced to 0.
    pub propellant_out: bool,
    /// |χ| command exceeded χ_max (or was not a number).
    pub gimbal_rate: bool,
    /// The rate was cut so that δ stays within ±δ_max.
    pub gimbal_angle: bool,
}

impl Saturation {
    /// Any limit was active.
    pub fn any(&self) -> bool {
        self.thrust_max
            || self.thrust_min
            || self.propellant_out
            || self.gimbal_rate
            || self.gimbal_angle
    }
}

/// Number of plant steps in which each limit was active.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct SaturationCounts {
    /// Steps taken (the denominator).
    pub steps: u64,
    pub thrust_max_steps: u64,
    pub thrust_min_steps: u64,
    pub propellant_out_steps: u64,
    pub gimbal_rate_steps: u64,
    pub gimbal_angle_steps: u64,
}

impl SaturationCounts {
    /// Count one step with the given flags.
    pub fn add(&mut self, s: &Saturation) {
        self.steps += 1;
        self.thrust_max_steps += u64::from(s.thrust_max);
        self.thrust_min_steps += u64::from(s.thrust_min);
        self.propellant_out_steps += u64::from(s.propellant_out);
        self.gimbal_rate_steps += u64::from(s.gimbal_rate);
        self.gimbal_angle_steps += u64::from(s.gimbal_angle);
    }
}

/// Apply the actuator limits to a command for a step of `dt_s` from `state`.
/// Returns the command the plant actually receives and the active limits.
///
/// Never panics: NaN thrust becomes T_min and NaN rate becomes 0 (both
/// flagged), and inconsistent limits in `model` are handled by min/max in a
/// fixed order rather than `clamp`.
pub fn saturate(
    model: &Model,
    state: &PlantState,
    cmd: Command,
    dt_s: f64,
) -> (Command, Saturation) {
    let mut sat = Saturation::default();

    let thrust_n = if state.mass_kg <= model.dry_mass_kg {
        sat.propellant_out = true;
        0.0
    } else if cmd.thrust_n > model.max_thrust_n {
        sat.thrust_max = true;
        model.max_thrust_n
    } else if cmd.thrust_n >= model.min_thrust_n {
        cmd.thrust_n
    } else {
        sat.thrust_min = true;
        model.min_thrust_n.min(model.max_thrust_n)
    };

    let chi_max = model.max_gimbal_rate_radps.abs();
    let mut rate = cmd.gimbal_rate_radps;
    if rate.is_nan() {
        sat.gimbal_rate = true;
        rate = 0.0;
    } else if rate.abs() > chi_max {
        sat.gimbal_rate = true;
        rate = rate.signum() * chi_max;
    }

    // Keep δ + χ·Δt within ±δ_max (δ is linear in t over a held step).
    let delta_max = model.max_gimbal_rad.abs();
    let delta = state.gimbal_rad;
    let (rate_hi, rate_lo) = if dt_s > 0.0 && dt_s.is_finite() {
        ((delta_max - delta) / dt_s, (-delta_max - delta) / dt_s)
    } else {
        // No step length: only stop outward motion at (or beyond) a stop.
        (
            if delta >= delta_max {
                0.0
            } else {
                f64::INFINITY
            },
            if delta <= -delta_max {
                0.0
            } else {
                f64::NEG_INFINITY
            },
        )
    };
    if rate > rate_hi {
        sat.gimbal_angle = true;
        rate = rate_hi.max(-chi_max);
    } else if rate < rate_lo {
        sat.gimbal_angle = true;
        rate = rate_lo.min(chi_max);
    }

    (
        Command {
            thrust_n,
            gimbal_rate_radps: rate,
        },
        sat,
    )
}

/// Truth dynamics: the derivative of (x, z, Vx, Vz, θ, w, m, δ) under the
/// applied (already saturated) command and a horizontal wind `wind_x_mps`
/// [m/s].
///
/// Eq. (1)–(3) via [`dynamics::rhs_physical`] with C_LD·k_D, the air-relative
/// velocity (Vx − W, Vz), thrust T·k_T at angle δ + b; then the position rates
/// are set back to the ground-relative (Vx, Vz); δ̇ = χ (Eq. 8).
pub fn truth_rhs(
    model: &Model,
    truth: &TruthParams,
    y: &[f64; 8],
    cmd: &Command,
    wind_x_mps: f64,
) -> [f64; 8] {
    let scaled = Model {
        c_ld_kgpm: model.c_ld_kgpm * truth.c_ld_factor,
        // The velocity passed is already air-relative.
        wind_x_mps: 0.0,
        ..model.clone()
    };
    let air = [y[0], y[1], y[2] - wind_x_mps, y[3], y[4], y[5], y[6]];
    let f = dynamics::rhs_physical(
        &scaled,
        &air,
        cmd.thrust_n * truth.thrust_factor,
        y[7] + truth.gimbal_bias_rad,
    );
    [
        y[2],
        y[3],
        f[2],
        f[3],
        f[4],
        f[5],
        f[6],
        cmd.gimbal_rate_radps,
    ]
}

/// One classical fourth-order Runge–Kutta step of size `h_s` of [`truth_rhs`],
/// command and wind held constant.
pub fn rk4_step(
    model: &Model,
    truth: &TruthParams,
    y: &[f64; 8],
    cmd: &Command,
    wind_x_mps: f64,
    h_s: f64,
) -> [f64; 8] {
    let f = |y: &[f64; 8]| truth_rhs(model, truth, y, cmd, wind_x_mps);
    let add = |a: &[f64; 8], k: &[f64; 8], s: f64| -> [f64; 8] {
        std::array::from_fn(|i| a[i] + s * k[i])
    };
    let k1 = f(y);
    let k2 = f(&add(y, &k1, 0.5 * h_s));
    let k3 = f(&add(y, &k2, 0.5 * h_s));
    let k4 = f(&add(y, &k3, h_s));
    std::array::from_fn(|i| y[i] + h_s / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
}

/// Plant settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlantConfig {
    /// Integration (and command) rate 1/Δt \[Hz\]; default 100 Hz. Range
    /// (0, 10000].
    pub rate_hz: f64,
    /// The run ends with [`Outcome::TimeLimit`] at this time \[s\]; default
    /// 60 s (about 5× the paper's 12-s burn). Range (0, 3600].
    pub max_time_s: f64,
}

impl Default for PlantConfig {
    fn default() -> Self {
        PlantConfig {
            rate_hz: 100.0,
            max_time_s: 60.0,
        }
    }
}

impl PlantConfig {
    /// Default rate, time limit 3× a planned flight time `tf_s` \[s\].
    pub fn for_plan(tf_s: f64) -> Self {
        PlantConfig {
            max_time_s: 3.0 * tf_s,
            ..PlantConfig::default()
        }
    }

    /// Rate in (0, 10000] Hz, time limit in (0, 3600] s.
    pub fn validate(&self) -> Result<(), InputError> {
        Range::open_closed(0.0, 1e4, "Hz").check("plant.rate_hz", self.rate_hz)?;
        Range::open_closed(0.0, 3600.0, "s").check("plant.max_time_s", self.max_time_s)
    }
}

/// The state at touchdown (z = z_f) and its errors against the scenario's
/// terminal state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Touchdown {
    /// Time of touchdown since the start of the run \[s\].
    pub time_s: f64,
    /// Downrange miss x − x_f \[m\].
    pub x_error_m: f64,
    /// Vertical velocity Vz at touchdown [m/s] (negative descending).
    pub vertical_velocity_mps: f64,
    /// Horizontal velocity Vx at touchdown [m/s].
    pub horizontal_velocity_mps: f64,
    /// Speed ‖(Vx, Vz)‖ at touchdown [m/s].
    pub speed_mps: f64,
    /// Pitch error θ − θ_f \[deg\], wrapped to [−180, 180).
    pub pitch_error_deg: f64,
    /// Pitch rate w at touchdown [deg/s].
    pub pitch_rate_degps: f64,
    /// Propellant left, m − m_dry \[kg\].
    pub propellant_left_kg: f64,
    /// The full state at touchdown.
    pub state: PlantState,
}

impl Touchdown {
    fn new(time_s: f64, s: PlantState, target: &TerminalState, dry_mass_kg: f64) -> Self {
        let pitch_error_deg =
            (s.theta_rad.to_degrees() - target.theta_deg + 180.0).rem_euclid(360.0) - 180.0;
        Touchdown {
            time_s,
            x_error_m: s.x_m - target.x_m,
            vertical_velocity_mps: s.vz_mps,
            horizontal_velocity_mps: s.vx_mps,
            speed_mps: s.vx_mps.hypot(s.vz_mps),
            pitch_error_deg,
            pitch_rate_degps: s.pitch_rate_radps.to_degrees(),
            propellant_left_kg: s.mass_kg - dry_mass_kg,
            state: s,
        }
    }
}

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "outcome", rename_all = "snake_case")]
pub enum Outcome {
    /// z reached the pad altitude z_f.
    Touchdown(Touchdown),
    /// The mass reached the dry mass in flight (or started at or below it).
    PropellantExhausted { time_s: f64, state: PlantState },
    /// [`PlantConfig::max_time_s`] was reached in flight.
    TimeLimit { time_s: f64, state: PlantState },
    /// A step produced a non-finite state; `state` is the last finite one.
    NonFinite { time_s: f64, state: PlantState },
}

/// What one [`Plant::step`] did.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum StepResult {
    /// Still flying; the limits active in this step.
    Flying(Saturation),
    /// The run has ended (this and every later call).
    Ended(Outcome),
}

/// The simulated vehicle: truth model, state, clock and saturation log.
#[derive(Debug, Clone)]
pub struct Plant {
    model: Model,
    truth: TruthParams,
    target: TerminalState,
    dt_s: f64,
    max_steps: u64,
    steps: u64,
    time_s: f64,
    state: PlantState,
    saturation: SaturationCounts,
    outcome: Option<Outcome>,
}

impl Plant {
    /// A plant for `scenario`'s vehicle and target, starting at `initial` at
    /// t = 0. The configuration and `truth` are validated; the scenario is
    /// assumed valid ([`Scenario::validate`]).
    pub fn new(
        scenario: &Scenario,
        config: &PlantConfig,
        truth: TruthParams,
        initial: PlantState,
    ) -> Result<Self, InputError> {
        config.validate()?;
        truth.validate()?;
        let dt_s = 1.0 / config.rate_hz;
        // Whole steps up to max_time_s (tolerant to round-off in the product).
        let max_steps = (config.max_time_s * config.rate_hz - 1e-9).ceil().max(1.0) as u64;
        Ok(Plant {
            model: Model::new(&scenario.vehicle, &scenario.environment),
            truth,
            target: scenario.terminal.clone(),
            dt_s,
            max_steps,
            steps: 0,
            time_s: 0.0,
            state: initial,
            saturation: SaturationCounts::default(),
            outcome: None,
        })
    }

    /// A plant started from a dispersed draw: its initial state
    /// ([`Realization::apply_initial`]) and model errors ([`Realization::truth`]).
    pub fn from_realization(
        scenario: &Scenario,
        config: &PlantConfig,
        realization: &Realization,
    ) -> Result<Self, InputError> {
        Self::new(
            scenario,
            config,
            realization.truth(),
            realization.apply_initial(&scenario.initial),
        )
    }

    /// The nominal model constants (the limits and the guidance model).
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The model errors of this plant.
    pub fn truth(&self) -> &TruthParams {
        &self.truth
    }

    /// The step Δt \[s\].
    pub fn dt_s(&self) -> f64 {
        self.dt_s
    }

    /// Time since the start \[s\] (the event time once the run has ended).
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// The true state (at the event once the run has ended).
    pub fn state(&self) -> &PlantState {
        &self.state
    }

    /// Saturation counts so far.
    pub fn saturation(&self) -> &SaturationCounts {
        &self.saturation
    }

    /// How the run ended, if it has.
    pub fn outcome(&self) -> Option<&Outcome> {
        self.outcome.as_ref()
    }

    /// Advance one step Δt with `cmd` (saturated here) and the horizontal wind
    /// `wind_x_mps` [m/s], both held over the step. Ends the run on touchdown,
    /// propellant exhaustion, the time limit or a non-finite state.
    pub fn step(&mut self, cmd: Command, wind_x_mps: f64) -> StepResult {
        if let Some(outcome) = self.outcome {
            return StepResult::Ended(outcome);
        }
        let t0 = self.time_s;
        let state = self.state;
        if !state.is_finite() {
            return self.end(Outcome::NonFinite { time_s: t0, state });
        }
        if state.mass_kg <= self.model.dry_mass_kg {
            return self.end(Outcome::PropellantExhausted { time_s: t0, state });
        }
        if self.steps >= self.max_steps {
            return self.end(Outcome::TimeLimit { time_s: t0, state });
        }

        let (applied, sat) = saturate(&self.model, &state, cmd, self.dt_s);
        self.saturation.add(&sat);
        let (model, truth, dt) = (&self.model, &self.truth, self.dt_s);
        let sub = |h: f64| rk4_step(model, truth, &state.to_array(), &applied, wind_x_mps, h);
        let y0 = state.to_array();
        let y1 = sub(dt);
        if y1.iter().any(|v| !v.is_finite()) {
            return self.end(Outcome::NonFinite { time_s: t0, state });
        }

        let z_f = self.target.z_m;
        let tau_touch = (y0[ix::Z] > z_f && y1[ix::Z] <= z_f)
            .then(|| crossing_time(&sub, y0[ix::Z] - z_f, y1[ix::Z] - z_f, z_f, dt));
        let dry = self.model.dry_mass_kg;
        let tau_dry = (y1[ix::M] <= dry).then(|| {
            // m is linear over the held step: m(τ) = m0 + ṁ·τ, ṁ < 0 here.
            let mdot = (y1[ix::M] - y0[ix::M]) / dt;
            if mdot < 0.0 {
                ((dry - y0[ix::M]) / mdot).max(0.0).min(dt)
            } else {
                dt
            }
        });

        match (tau_touch, tau_dry) {
            (Some((tau, y)), td) if td.is_none_or(|td| tau <= td) => {
                let s = PlantState::from_array(&y);
                self.state = s;
                self.time_s = t0 + tau;
                self.end(Outcome::Touchdown(Touchdown::new(
                    t0 + tau,
                    s,
                    &self.target,
                    dry,
                )))
            }
            (_, Some(td)) => {
                let mut y = sub(td);
                y[ix::M] = y[ix::M].max(dry);
                let s = PlantState::from_array(&y);
                self.state = s;
                self.time_s = t0 + td;
                self.end(Outcome::PropellantExhausted {
                    time_s: t0 + td,
                    state: s,
                })
            }
            _ => {
                self.steps += 1;
                self.time_s = self.steps as f64 * dt;
                self.state = PlantState::from_array(&y1);
                StepResult::Flying(sat)
            }
        }
    }

    fn end(&mut self, outcome: Outcome) -> StepResult {
        self.outcome = Some(outcome);
        StepResult::Ended(outcome)
    }
}

/// The sub-step τ ∈ (0, h] at which the RK4 solution `sub(τ)` crosses z = z_f,
/// and the state there, given g(0) = z(0) − z_f > 0 ≥ g(h).
///
/// Safeguarded Newton on g(τ) = z(τ) − z_f with ġ ≈ Vz(τ), starting from the
/// secant; steps leaving the bracket are replaced by bisection. Stops when
/// |g| ≤ 1e-10 m or the bracket is at round-off, after at most 100 RK4
/// sub-steps.
fn crossing_time(
    sub: &impl Fn(f64) -> [f64; 8],
    g0: f64,
    g1: f64,
    z_f: f64,
    h: f64,
) -> (f64, [f64; 8]) {
    let (mut lo, mut hi) = (0.0, h);
    let mut tau = (h * g0 / (g0 - g1)).max(0.0).min(h);
    let mut best = (h, sub(h), g1.abs());
    for _ in 0..100 {
        let y = sub(tau);
        let g = y[ix::Z] - z_f;
        if g.abs() < best.2 {
            best = (tau, y, g.abs());
        }
        if g.abs() <= 1e-10 || hi - lo <= 4.0 * f64::EPSILON * h {
            break;
        }
        if g > 0.0 {
            lo = tau;
        } else {
            hi = tau;
        }
        let vz = y[ix::VZ];
        let newton = tau - g / vz;
        tau = if vz < 0.0 && newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
    }
    (best.0, best.1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::verify::ode::{Dop853, Stats};

    /// The paper's scenario with optional vacuum and a deep-throttling engine.
    fn scenario(vacuum: bool, min_thrust_n: f64) -> Scenario {
        let mut s = Scenario::paper();
        if vacuum {
            s.vehicle.drag_coefficient_kgpm = 0.0;
        }
        s.vehicle.min_thrust_n = min_thrust_n;
        s
    }

    fn model_of(s: &Scenario) -> Model {
        Model::new(&s.vehicle, &s.environment)
    }

    #[test]
    fn ballistic_fall_matches_the_parabola() {
        // No drag, T = 0, χ = 0: x = x0 + Vx·t, z = z0 + Vz0·t − g·t²/2.
        // RK4 integrates polynomials of degree ≤ 4 exactly.
        let s = scenario(true, 0.0);
        let m = model_of(&s);
        let y0 = [10.0, 500.0, 3.0, -20.0, 0.3, 0.0, 1e5, 0.0];
        let cmd = Command {
            thrust_n: 0.0,
            gimbal_rate_radps: 0.0,
        };
        let dt = 0.01;
        let mut y = y0;
        for _ in 0..300 {
            y = rk4_step(&m, &TruthParams::default(), &y, &cmd, 0.0, dt);
        }
        let t = 3.0;
        let g = s.environment.g0_mps2;
        assert!((y[0] - (10.0 + 3.0 * t)).abs() < 1e-9);
        assert!((y[1] - (500.0 - 20.0 * t - 0.5 * g * t * t)).abs() < 1e-9);
        assert!((y[3] - (-20.0 - g * t)).abs() < 1e-10);
        assert_eq!((y[4], y[6], y[7]), (0.3, 1e5, 0.0));
    }

    #[test]
    fn rk4_matches_dop853_with_fourth_order_convergence() {
        // Paper vehicle with drag, constant thrust and gimbal rate, 4 s from the
        // paper's initial state; the reference is DOP853 on the library's own
        // Eq. (8) (dynamics::rhs_augmented), a separate code path.
        let s = Scenario::paper();
        let m = model_of(&s);
        let y0 = PlantState::from_initial(&s.initial).to_array();
        let cmd = Command {
            thrust_n: 1.6e6,
            gimbal_rate_radps: 0.03,
        };
        let t_end = 4.0;
        let dop = Dop853 {
            rtol: 1e-13,
            atol: 1e-12,
            ..Dop853::default()
        };
        let (mut h, mut stats) = (0.0, Stats::default());
        let reference = dop
            .integrate(
                |_, y: &[f64; 8]| {
                    dynamics::rhs_augmented(&m, y, cmd.thrust_n, cmd.gimbal_rate_radps)
                },
                0.0,
                y0,
                t_end,
                &mut h,
                &mut stats,
                |_, _| {},
            )
            .unwrap();
        let error = |n: usize| {
            let dt = t_end / n as f64;
            let mut y = y0;
            for _ in 0..n {
                y = rk4_step(&m, &TruthParams::default(), &y, &cmd, 0.0, dt);
            }
            // Position and velocity error, scaled per component.
            (0..8)
                .map(|i| (y[i] - reference[i]).abs() / (1.0 + reference[i].abs()))
                .fold(0.0, f64::max)
        };
        let (e1, e2, e3) = (error(100), error(200), error(400));
        assert!(e2 < 1e-9, "RK4 at 50 Hz vs DOP853: {e2:e}");
        for (coarse, fine) in [(e1, e2), (e2, e3)] {
            let order = (coarse / fine).log2();
            assert!(
                (3.7..4.3).contains(&order),
                "order {order} ({coarse:e}, {fine:e})"
            );
        }
    }

    #[test]
    fn drag_acts_on_air_relative_velocity() {
        let s = Scenario::paper();
        let m = model_of(&s);
        let truth = TruthParams::default();
        let coast = Command {
            thrust_n: 0.0,
            gimbal_rate_radps: 0.0,
        };
        let y = [0.0, 300.0, 30.0, -50.0, 0.4, 0.0, 1e5, 0.0];
        // Wind equal to Vx: no horizontal drag, so no horizontal acceleration
        // without thrust, and the position rate stays ground-relative.
        let f = truth_rhs(&m, &truth, &y, &coast, 30.0);
        assert_eq!(f[0], 30.0);
        assert_eq!(f[1], -50.0);
        assert_eq!(f[2], 0.0);
        // The vertical drag and its moment are those of the pure (0, Vz) flow.
        let still = [0.0, 300.0, 0.0, -50.0, 0.4, 0.0, 1e5, 0.0];
        let g = dynamics::rhs_augmented(&m, &still, 0.0, 0.0);
        assert!((f[3] - g[3]).abs() < 1e-12);
        assert!((f[5] - g[5]).abs() < 1e-15);
        assert!(f[3] > -s.environment.g0_mps2, "drag decelerates the fall");
        // Without wind the horizontal drag opposes Vx.
        assert!(truth_rhs(&m, &truth, &y, &coast, 0.0)[2] < 0.0);
        // A tail wind faster than the vehicle pushes it forward.
        assert!(truth_rhs(&m, &truth, &y, &coast, 40.0)[2] > 0.0);
    }

    #[test]
    fn model_errors_enter_the_truth_dynamics() {
        let s = Scenario::paper();
        let m = model_of(&s);
        let y = [0.0, 300.0, 10.0, -50.0, 0.4, 0.1, 1e5, 0.05];
        let cmd = Command {
            thrust_n: 1.5e6,
            gimbal_rate_radps: 0.01,
        };
        let truth = TruthParams {
            c_ld_factor: 1.1,
            thrust_factor: 0.97,
            gimbal_bias_rad: 0.01,
        };
        let mut scaled = m.clone();
        scaled.c_ld_kgpm *= 1.1;
        let expect = dynamics::rhs_augmented(
            &scaled,
            &[y[0], y[1], y[2], y[3], y[4], y[5], y[6], 0.06],
            1.5e6 * 0.97,
            0.01,
        );
        let f = truth_rhs(&m, &truth, &y, &cmd, 0.0);
        for i in 0..8 {
            assert!(
                (f[i] - expect[i]).abs() <= 1e-14 * (1.0 + expect[i].abs()),
                "row {i}"
            );
        }
    }

    #[test]
    fn actuators_saturate() {
        let s = Scenario::paper();
        let m = model_of(&s);
        let state = PlantState::from_initial(&s.initial);
        let dt = 0.01;
        let cmd = |t, r| Command {
            thrust_n: t,
            gimbal_rate_radps: r,
        };
        // Thrust above T_max, below T_min, NaN, and with no propellant.
        let (a, sat) = saturate(&m, &state, cmd(3e6, 0.0), dt);
        assert_eq!(a.thrust_n, m.max_thrust_n);
        assert!(sat.thrust_max && !sat.thrust_min && sat.any());
        let (a, sat) = saturate(&m, &state, cmd(1e5, 0.0), dt);
        assert_eq!(a.thrust_n, m.min_thrust_n);
        assert!(sat.thrust_min);
        let (a, sat) = saturate(&m, &state, cmd(f64::NAN, f64::NAN), dt);
        assert_eq!((a.thrust_n, a.gimbal_rate_radps), (m.min_thrust_n, 0.0));
        assert!(sat.thrust_min && sat.gimbal_rate);
        let empty = PlantState {
            mass_kg: m.dry_mass_kg,
            ..state
        };
        let (a, sat) = saturate(&m, &empty, cmd(2e6, 0.0), dt);
        assert_eq!(a.thrust_n, 0.0);
        assert!(sat.propellant_out);
        let (a, sat) = saturate(&m, &state, cmd(2e6, 0.0), dt);
        assert_eq!(a.thrust_n, 2e6);
        assert!(!sat.any());
        // Gimbal rate limited to ±χ_max.
        let (a, sat) = saturate(&m, &state, cmd(2e6, -1.0), dt);
        assert_eq!(a.gimbal_rate_radps, -m.max_gimbal_rate_radps);
        assert!(sat.gimbal_rate && !sat.gimbal_angle);

        // Drive the plant into the stop: δ rises at χ_max, reaches δ_max
        // exactly and stays there; every step is counted.
        let mut plant = Plant::new(
            &s,
            &PlantConfig::default(),
            TruthParams::default(),
            PlantState {
                theta_rad: 0.0,
                ..state
            },
        )
        .unwrap();
        let mut peak: f64 = 0.0;
        for k in 0..150 {
            let r = plant.step(cmd(2.5e6, 10.0), 0.0);
            let StepResult::Flying(sat) = r else {
                panic!("ended early: {r:?}")
            };
            assert!(sat.thrust_max && sat.gimbal_rate);
            let delta = plant.state().gimbal_rad;
            peak = peak.max(delta);
            if k < 99 {
                // 20° at 20°/s: the stop is reached after 1 s = 100 steps.
                let expected = (k + 1) as f64 * 0.01 * m.max_gimbal_rate_radps;
                assert!((delta - expected).abs() < 1e-12, "step {k}");
            }
        }
        assert!((peak - m.max_gimbal_rad).abs() < 1e-12 && peak <= m.max_gimbal_rad);
        assert_eq!(plant.state().gimbal_rad, m.max_gimbal_rad);
        let counts = *plant.saturation();
        assert_eq!(counts.steps, 150);
        assert_eq!(counts.thrust_max_steps, 150);
        assert_eq!(counts.gimbal_rate_steps, 150);
        // The last step to the stop and the 50 steps at the stop.
        assert!((50..=51).contains(&counts.gimbal_angle_steps), "{counts:?}");
        // Pulling back from the stop is not limited.
        let (a, sat) = saturate(&m, plant.state(), cmd(2e6, -0.1), dt);
        assert_eq!(a.gimbal_rate_radps, -0.1);
        assert!(!sat.any());
    }

    #[test]
    fn tracking_gimbal_reaches_the_angle_or_the_rate_limit() {
        let c = Command::tracking_gimbal(1e6, 0.105, 0.1, 0.01, 0.35);
        assert!((c.gimbal_rate_radps - 0.5f64.min(0.35)).abs() < 1e-12);
        let c = Command::tracking_gimbal(1e6, 0.101, 0.1, 0.01, 0.35);
        assert!((c.gimbal_rate_radps - 0.1).abs() < 1e-12);
        assert_eq!(c.thrust_n, 1e6);
        assert_eq!(
            Command::tracking_gimbal(1e6, 0.2, 0.1, 0.0, 0.35).gimbal_rate_radps,
            0.0
        );
    }

    #[test]
    fn touchdown_of_a_ballistic_fall_at_the_analytic_time() {
        // z(t) = z0 + Vz0·t − g·t²/2 = 0 at t = (Vz0 + sqrt(Vz0² + 2·g·z0))/g.
        let s = scenario(true, 0.0);
        let (z0, vz0, vx0) = (100.0, -10.0, 2.0);
        let g = s.environment.g0_mps2;
        let t_analytic = (vz0 + (vz0 * vz0 + 2.0 * g * z0).sqrt()) / g;
        let initial = PlantState {
            x_m: -3.0,
            z_m: z0,
            vx_mps: vx0,
            vz_mps: vz0,
            theta_rad: 0.05,
            pitch_rate_radps: 0.0,
            mass_kg: 1e5,
            gimbal_rad: 0.0,
        };
        for rate_hz in [100.0, 37.0] {
            let config = PlantConfig {
                rate_hz,
                ..PlantConfig::default()
            };
            let mut plant = Plant::new(&s, &config, TruthParams::default(), initial).unwrap();
            let coast = Command {
                thrust_n: 0.0,
                gimbal_rate_radps: 0.0,
            };
            let outcome = loop {
                if let StepResult::Ended(o) = plant.step(coast, 0.0) {
                    break o;
                }
            };
            let Outcome::Touchdown(td) = outcome else {
                panic!("{outcome:?}")
            };
            assert!(
                (td.time_s - t_analytic).abs() < 1e-9,
                "{} Hz: {}",
                rate_hz,
                td.time_s
            );
            assert!(td.state.z_m.abs() < 1e-9);
            assert!((td.vertical_velocity_mps - (vz0 - g * t_analytic)).abs() < 1e-8);
            assert!((td.x_error_m - (-3.0 + vx0 * t_analytic)).abs() < 1e-9);
            assert_eq!(td.horizontal_velocity_mps, vx0);
            assert!((td.speed_mps - vx0.hypot(td.vertical_velocity_mps)).abs() < 1e-12);
            assert!((td.pitch_error_deg - 0.05f64.to_degrees()).abs() < 1e-12);
            assert_eq!(td.propellant_left_kg, 1e5 - s.vehicle.dry_mass_kg);
            assert_eq!(plant.time_s(), td.time_s);
            // Ended for good.
            assert_eq!(plant.step(coast, 0.0), StepResult::Ended(outcome));
        }
    }

    #[test]
    fn runs_end_on_time_limit_and_on_propellant() {
        let s = Scenario::paper();
        let up = PlantState {
            x_m: 0.0,
            z_m: 100.0,
            vx_mps: 0.0,
            vz_mps: 0.0,
            theta_rad: 0.0,
            pitch_rate_radps: 0.0,
            mass_kg: 1e5,
            gimbal_rad: 0.0,
        };
        let full = Command {
            thrust_n: s.vehicle.max_thrust_n,
            gimbal_rate_radps: 0.0,
        };
        let drive = |plant: &mut Plant| loop {
            if let StepResult::Ended(o) = plant.step(full, 0.0) {
                return o;
            }
        };
        // Full thrust upright climbs: the time limit ends it.
        let config = PlantConfig {
            max_time_s: 2.0,
            ..PlantConfig::default()
        };
        let mut plant = Plant::new(&s, &config, TruthParams::default(), up).unwrap();
        let Outcome::TimeLimit { time_s, state } = drive(&mut plant) else {
            panic!()
        };
        assert!((time_s - 2.0).abs() < 1e-12);
        assert!(state.z_m > 100.0);
        assert_eq!(plant.saturation().steps, 200);

        // 100 kg of propellant at T_max lasts 100/(T_max/(I_sp·g0)) s.
        let m = model_of(&s);
        let low = PlantState {
            mass_kg: m.dry_mass_kg + 100.0,
            ..up
        };
        let mut plant = Plant::new(&s, &config, TruthParams::default(), low).unwrap();
        let Outcome::PropellantExhausted { time_s, state } = drive(&mut plant) else {
            panic!()
        };
        let t_burn = 100.0 / (-m.max_thrust_n * m.alpha_spm);
        assert!((time_s - t_burn).abs() < 1e-9, "{time_s} vs {t_burn}");
        assert!((state.mass_kg - m.dry_mass_kg).abs() < 1e-6);
        // Starting empty ends at once.
        let empty = PlantState {
            mass_kg: m.dry_mass_kg,
            ..up
        };
        let mut plant = Plant::new(&s, &config, TruthParams::default(), empty).unwrap();
        assert!(matches!(
            plant.step(full, 0.0),
            StepResult::Ended(Outcome::PropellantExhausted { time_s: 0.0, .. })
        ));
        // A non-finite wind ends the run without a panic.
        let mut plant = Plant::new(&s, &config, TruthParams::default(), up).unwrap();
        assert!(matches!(
            plant.step(full, f64::NAN),
            StepResult::Ended(Outcome::NonFinite { time_s: 0.0, .. })
        ));
    }

    #[test]
    fn bad_configuration_is_rejected() {
        let s = Scenario::paper();
        let init = PlantState::from_initial(&s.initial);
        let bad = PlantConfig {
            rate_hz: 0.0,
            ..PlantConfig::default()
        };
        let err = Plant::new(&s, &bad, TruthParams::default(), init).unwrap_err();
        assert!(err.to_string().starts_with("plant.rate_hz = 0"), "{err}");
        let truth = TruthParams {
            thrust_factor: -0.1,
            ..TruthParams::default()
        };
        let err = Plant::new(&s, &PlantConfig::default(), truth, init).unwrap_err();
        assert!(
            matches!(err, InputError::OutOfRange { ref field, .. } if field == "truth.thrust_factor")
        );
        assert_eq!(PlantConfig::for_plan(12.0).max_time_s, 36.0);
        let parsed: PlantConfig = toml::from_str("rate_hz = 50.0").unwrap();
        assert_eq!(parsed.max_time_s, 60.0);
        assert!(toml::from_str::<PlantConfig>("rate = 50.0").is_err());
    }
}
