//! Navigation filters: what guidance makes of the noisy measured state.
//!
//! - [`PositionFilter`]: a complementary filter that keeps white position
//!   noise out of the height the terminal descent divides by;
//! - [`WindEstimator`]: a Kalman filter on the horizontal velocity that
//!   estimates the steady wind from the drag it causes, so re-plans fly with
//!   the wind the vehicle is in rather than the still air of Eq. (2).

use nalgebra::{Matrix2, Vector2};
use num_dual::Dual64;

use crate::problem::dynamics::{self, Model};
use crate::sim::{Command, PlantState};

/// A complementary filter on the navigation output's position: the position
/// estimate is carried forward with the measured velocity and pulled toward
/// the measured position with time constant τ,
/// p̂ₖ = p̂ₖ₋₁ + v̂ₖ·Δt + (Δt/τ)·(pₖ − p̂ₖ₋₁ − v̂ₖ·Δt).
///
/// The navigation noise is white at the control rate (0.2 m and 0.05 m/s by
/// default); the terminal descent divides by the height above the pad, so
/// raw position noise of 0.2 m near the ground makes its thrust command
/// jump. With τ = 1 s at 100 Hz the estimate's noise is about
/// 0.2·√(Δt/2τ) ≈ 0.014 m from the position plus a few millimetres from the
/// integrated velocity noise (the test measures < 0.04 m rms). Velocity,
/// attitude and mass pass through.
#[derive(Debug, Clone)]
pub struct PositionFilter {
    gain: f64,
    dt_s: f64,
    estimate: Option<(f64, f64)>,
}

impl PositionFilter {
    /// A filter of time constant `tau_s` (0: pass-through) at step `dt_s`.
    pub fn new(tau_s: f64, dt_s: f64) -> Self {
        let gain = if tau_s > 0.0 {
            (dt_s / tau_s).min(1.0)
        } else {
            1.0
        };
        PositionFilter {
            gain,
            dt_s,
            estimate: None,
        }
    }

    /// Filter one measurement.
    pub fn update(&mut self, mut m: PlantState) -> PlantState {
        let (x, z) = match self.estimate {
            None => (m.x_m, m.z_m),
            Some((x, z)) => {
                let (xp, zp) = (x + m.vx_mps * self.dt_s, z + m.vz_mps * self.dt_s);
                (xp + self.gain * (m.x_m - xp), zp + self.gain * (m.z_m - zp))
            }
        };
        self.estimate = Some((x, z));
        m.x_m = x;
        m.z_m = z;
        m
    }
}

/// Random-walk intensity of the wind in [`WindEstimator`] [m/s per √s]: the
/// default gusts (Gauss–Markov, σ = 2 m/s, τ = 2 s) change at
/// √(2σ²/τ) = 2 m/s per √s.
pub const WIND_WALK_MPS_PER_SQRT_S: f64 = 2.0;

/// White acceleration the horizontal model leaves out [m/s² per √Hz]:
/// gimbal bias (0.5° 3σ of ~20 m/s² thrust, 0.06 m/s²), thrust and C_LD
/// errors, and the pitch loop's residual; 0.3 covers them with margin.
pub const UNMODELLED_ACCEL_MPS2: f64 = 0.3;

/// Standard deviation of the measured horizontal velocity [m/s] (the
/// navigation's stated accuracy, the default dispersions' 0.05 m/s).
pub const VELOCITY_NOISE_MPS: f64 = 0.05;

/// 1σ of the wind before any measurement [m/s]: the default steady wind is
/// uniform in ±5 m/s (σ 2.9) plus gusts of 2 m/s.
pub const WIND_PRIOR_SIGMA_MPS: f64 = 3.5;

/// A two-state Kalman filter, (V̂x, Ŵ), on the horizontal equation of motion
/// with drag on the air-relative velocity (Eq. 2 with Vx − W):
///
/// V̇x = (−T sin(θ + δ) − C_LD ‖V_a‖ (Vx − W)) / m,  Ẇ = white noise,
///
/// measured through V̂x. The wind is observable through its drag,
/// ∂V̇x/∂W = k = C_LD (‖V_a‖ + (Vx − W)²/‖V_a‖)/m: about 0.3 /s in the
/// belly-flop at 85 m/s, nothing at the hover. Where k vanishes the
/// estimate holds and its variance grows. Thrust T is the command, clamped
/// to the engine's range; θ, δ and m are the measured ones.
#[derive(Debug, Clone)]
pub struct WindEstimator {
    dt_s: f64,
    /// (V̂x, Ŵ) and their covariance, once the first measurement arrived.
    state: Option<(Vector2<f64>, Matrix2<f64>)>,
    prior_wind_mps: f64,
    /// The previous measurement and the command applied since.
    last: Option<(PlantState, Command)>,
}

impl WindEstimator {
    /// An estimator at step `dt_s` starting from `prior_wind_mps` (the
    /// scenario's steady wind).
    pub fn new(dt_s: f64, prior_wind_mps: f64) -> Self {
        WindEstimator {
            dt_s,
            state: None,
            prior_wind_mps,
            last: None,
        }
    }

    /// The wind estimate Ŵ [m/s] and its 1σ.
    pub fn wind(&self) -> (f64, f64) {
        match &self.state {
            Some((x, p)) => (x[1], p[(1, 1)].max(0.0).sqrt()),
            None => (self.prior_wind_mps, WIND_PRIOR_SIGMA_MPS),
        }
    }

    /// Take measurement `m`; `applied` is the command that will act until
    /// the next measurement.
    pub fn update(&mut self, m: &PlantState, applied: &Command, model: &Model) {
        let r = VELOCITY_NOISE_MPS * VELOCITY_NOISE_MPS;
        let (x, p) = match (self.state, &self.last) {
            (Some((x, p)), Some((prev, cmd))) => predict(x, p, prev, cmd, model, self.dt_s),
            _ => (
                Vector2::new(m.vx_mps, self.prior_wind_mps),
                Matrix2::new(r, 0.0, 0.0, WIND_PRIOR_SIGMA_MPS * WIND_PRIOR_SIGMA_MPS),
            ),
        };
        // Measurement update, H = [1 0].
        let gain = p.column(0) / (p[(0, 0)] + r);
        let x = x + gain * (m.vx_mps - x[0]);
        let p = p - gain * p.row(0);
        if x.iter().all(|v| v.is_finite()) {
            self.state = Some((x, p));
        }
        self.last = Some((*m, *applied));
    }
}

/// Time update of [`WindEstimator`] over one step (Euler; the step is 10 ms
/// against time constants of seconds). V̇x is Eq. (2)'s, from
/// [`dynamics::rhs_physical`] in the wind Ŵ, differentiated in Vx by
/// num-dual; the drag depends on Vx − W only, so ∂V̇x/∂W = −∂V̇x/∂Vx.
fn predict(
    x: Vector2<f64>,
    p: Matrix2<f64>,
    m: &PlantState,
    cmd: &Command,
    model: &Model,
    dt: f64,
) -> (Vector2<f64>, Matrix2<f64>) {
    let windy = Model {
        wind_x_mps: x[1],
        ..model.clone()
    };
    let thrust = cmd.thrust_n.clamp(model.min_thrust_n, model.max_thrust_n);
    let c = Dual64::from_re;
    let state = [
        c(m.x_m),
        c(m.z_m),
        Dual64::new(x[0], 1.0),
        c(m.vz_mps),
        c(m.theta_rad),
        c(m.pitch_rate_radps),
        c(m.mass_kg.max(1.0)),
    ];
    let ax = dynamics::rhs_physical(&windy, &state, c(thrust), c(m.gimbal_rad))[2];
    let k = -ax.eps;
    let f = Matrix2::new(1.0 - k * dt, k * dt, 0.0, 1.0);
    let q = Matrix2::from_diagonal(&Vector2::new(
        UNMODELLED_ACCEL_MPS2 * UNMODELLED_ACCEL_MPS2 * dt,
        WIND_WALK_MPS_PER_SQRT_S * WIND_WALK_MPS_PER_SQRT_S * dt,
    ));
    (
        Vector2::new(x[0] + ax.re * dt, x[1]),
        f * p * f.transpose() + q,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::plant::rk4_step;
    use crate::sim::truth::TruthParams;
    use crate::Scenario;

    /// The position filter cuts white navigation noise by more than 5×
    /// without lagging a moving vehicle.
    #[test]
    fn position_filter_removes_noise_without_lag() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let dt = 0.01;
        let mut f = PositionFilter::new(1.0, dt);
        let (mut sum_sq, mut sum, mut n) = (0.0, 0.0, 0.0);
        for k in 0..3000 {
            let t = k as f64 * dt;
            let truth_z = 100.0 - 5.0 * t;
            let noise: f64 = StandardNormal.sample(&mut rng);
            let v_noise: f64 = StandardNormal.sample(&mut rng);
            let m = PlantState {
                x_m: 0.0,
                z_m: truth_z + 0.2 * noise,
                vx_mps: 0.0,
                vz_mps: -5.0 + 0.05 * v_noise,
                theta_rad: 0.0,
                pitch_rate_radps: 0.0,
                mass_kg: 1e5,
                gimbal_rad: 0.0,
            };
            let e = f.update(m).z_m - truth_z;
            if k >= 500 {
                sum_sq += e * e;
                sum += e;
                n += 1.0;
            }
        }
        let (mean, rms) = (sum / n, (sum_sq / n).sqrt());
        assert!(rms < 0.04, "rms {rms}");
        assert!(mean.abs() < 0.02, "bias {mean}");
    }

    /// A belly-first fall at 80 m/s gives away a steady wind within 3 s,
    /// from the drag alone and through 0.05-m/s velocity noise.
    #[test]
    fn wind_estimator_finds_a_steady_wind() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let s = Scenario::paper();
        let model = Model::new(&s.vehicle, &s.environment);
        for wind in [4.0, 0.0, -3.0] {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
            let dt = 0.01;
            let mut est = WindEstimator::new(dt, 0.0);
            let cmd = Command {
                thrust_n: model.min_thrust_n,
                gimbal_rate_radps: 0.0,
            };
            let mut y = [0.0, 600.0, 0.0, -80.0, 1.5, 0.0, 1.2e5, 0.0];
            let truth = TruthParams::default();
            for _ in 0..300 {
                let noise: f64 = StandardNormal.sample(&mut rng);
                let m = PlantState {
                    x_m: y[0],
                    z_m: y[1],
                    vx_mps: y[2] + VELOCITY_NOISE_MPS * noise,
                    vz_mps: y[3],
                    theta_rad: y[4],
                    pitch_rate_radps: 0.0,
                    mass_kg: y[6],
                    gimbal_rad: y[7],
                };
                est.update(&m, &cmd, &model);
                y = rk4_step(&model, &truth, &y, &cmd, wind, dt);
                y[5] = 0.0; // hold the attitude: only the wind is under test
                y[4] = 1.5;
            }
            let (w, sigma) = est.wind();
            // Measured: 3.61, −0.24 and −3.11 m/s. The filter's own σ stays
            // near 2 m/s, as it expects gusts of 2 m/s per √s.
            assert!(
                (w - wind).abs() < 0.5,
                "wind {wind}: estimate {w} ± {sigma}"
            );
            assert!(sigma < WIND_PRIOR_SIGMA_MPS, "σ {sigma}");
        }
    }
}
