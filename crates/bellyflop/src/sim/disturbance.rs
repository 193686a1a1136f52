//! Monte-Carlo dispersions: the configuration ([`Dispersions`]) and one
//! deterministic draw of it ([`Realization`]).
//!
//! # Defaults
//!
//! | quantity | default | level | field |
//! |---|---|---|---|
//! | initial x, z | 20 m per axis | 3σ | `initial_position_3sigma_m` |
//! | initial Vx, Vz | 3 m/s per axis | 3σ | `initial_velocity_3sigma_mps` |
//! | initial θ | 3° | 3σ | `initial_pitch_3sigma_deg` |
//! | initial w | 1°/s | 3σ | `initial_pitch_rate_3sigma_degps` |
//! | initial mass | 2 % | 3σ | `initial_mass_3sigma_frac` |
//! | C_LD error | 10 % | 3σ | `drag_coefficient_3sigma_frac` |
//! | thrust-magnitude error | 3 % | 3σ | `thrust_3sigma_frac` |
//! | thrust-axis (gimbal) bias | 0.5° | 3σ | `gimbal_bias_3sigma_deg` |
//! | steady horizontal wind | magnitude U[0, 5] m/s, random sign | bound | `steady_wind_max_mps` |
//! | gusts (Gauss–Markov) | 2 m/s, τ = 2 s | 1σ | `gust_sigma_mps`, `gust_correlation_time_s` |
//! | navigation: x, z | 0.2 m | 1σ | `nav_position_sigma_m` |
//! | navigation: Vx, Vz | 0.05 m/s | 1σ | `nav_velocity_sigma_mps` |
//! | navigation: θ | 0.1° | 1σ | `nav_pitch_sigma_deg` |
//! | navigation: w | 0.05°/s | 1σ | `nav_pitch_rate_sigma_degps` |
//! | navigation: m | 100 kg | 1σ | `nav_mass_sigma_kg` |
//!
//! Every dispersion is switched off by setting its value to 0;
//! [`Dispersions::none`] switches all off.
//!
//! # Distributions
//!
//! Gaussian quantities are plain (untruncated) normal draws with the stated σ
//! (3σ fields are divided by 3), so a draw beyond 3σ occurs with probability
//! 0.27 %. The only clipping is physical: the C_LD, thrust and mass factors
//! are at least 0. The steady wind is W_s = s·U·W_max with U uniform on [0, 1)
//! and s = ±1 with equal probability, i.e. uniform on (−W_max, W_max).
//!
//! Gusts are a first-order Gauss–Markov (Ornstein–Uhlenbeck) process,
//! dg = −g/τ·dt + σ·sqrt(2/τ)·dB, started from its stationary law N(0, σ²) and
//! discretized exactly at the plant step Δt:
//! g_{k+1} = a·g_k + σ·sqrt(1 − a²)·n_k, a = exp(−Δt/τ), n_k ~ N(0, 1).
//! The wind over step k is W_s + g_k (horizontal).
//!
//! Navigation noise is white: each [`Realization::measure`] adds independent
//! N(0, σ²) errors to x, z, Vx, Vz, θ, w and m; δ is measured exactly (it is the
//! actuator's own encoder reading; the thrust-axis bias is not observable).
//!
//! # Determinism
//!
//! A realization depends only on (seed, run_index) and the configuration.
//! Its random numbers come from [`ChaCha8Rng`] keyed by
//! `seed_from_u64(seed)` on stream `run_index`, so runs are independent of
//! thread count and order. Three disjoint ranges of that stream (word
//! positions 0, 2⁶⁴ and 2·2⁶⁴, each 2⁶⁴ words long) feed the three uses:
//! the parameters drawn at sampling, the gust sequence, and the navigation
//! noise. Measuring more or less often therefore does not change the gusts.
//! Every draw is made whether or not its dispersion is enabled, so switching
//! one dispersion off leaves the others' values unchanged.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::input::error::InputError;
use crate::input::range::Range;
use crate::input::scenario::InitialState;
use crate::sim::truth::{PlantState, TruthParams};

/// Dispersions of a Monte-Carlo campaign. Missing fields take the defaults
/// (see the module documentation); 0 switches a dispersion off.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Dispersions {
    /// Initial position x and z, per axis, 3σ \[m\]. Default 20. Range [0, 1000].
    pub initial_position_3sigma_m: f64,
    /// Initial velocity Vx and Vz, per axis, 3σ [m/s]. Default 3. Range [0, 100].
    pub initial_velocity_3sigma_mps: f64,
    /// Initial pitch θ, 3σ \[deg\]. Default 3. Range [0, 45].
    pub initial_pitch_3sigma_deg: f64,
    /// Initial pitch rate w, 3σ [deg/s]. Default 1. Range [0, 30].
    pub initial_pitch_rate_3sigma_degps: f64,
    /// Initial mass, relative, 3σ [-] (0.02 = 2 %). Default 0.02. Range [0, 0.2].
    pub initial_mass_3sigma_frac: f64,
    /// Drag coefficient C_LD, relative error, 3σ [-]. Default 0.10. Range [0, 1].
    pub drag_coefficient_3sigma_frac: f64,
    /// Thrust magnitude, relative error, 3σ [-]. Default 0.03. Range [0, 0.5].
    pub thrust_3sigma_frac: f64,
    /// Thrust-axis misalignment added to δ, 3σ \[deg\]. Default 0.5. Range [0, 10].
    pub gimbal_bias_3sigma_deg: f64,
    /// Largest steady horizontal wind speed W_max [m/s]; the steady wind is
    /// uniform on (−W_max, W_max). Default 5. Range [0, 50].
    pub steady_wind_max_mps: f64,
    /// Gust standard deviation σ_g, 1σ [m/s]. Default 2. Range [0, 30].
    pub gust_sigma_mps: f64,
    /// Gust correlation time τ \[s\]. Default 2. Range (0, 1000].
    pub gust_correlation_time_s: f64,
    /// Navigation noise on x and z, 1σ \[m\]. Default 0.2. Range [0, 100].
    pub nav_position_sigma_m: f64,
    /// Navigation noise on Vx and Vz, 1σ [m/s]. Default 0.05. Range [0, 10].
    pub nav_velocity_sigma_mps: f64,
    /// Navigation noise on θ, 1σ \[deg\]. Default 0.1. Range [0, 10].
    pub nav_pitch_sigma_deg: f64,
    /// Navigation noise on w, 1σ [deg/s]. Default 0.05. Range [0, 10].
    pub nav_pitch_rate_sigma_degps: f64,
    /// Navigation noise on the mass, 1σ \[kg\]. Default 100 (≈ 0.1 % of the
    /// paper's landing mass). Range [0, 1e5].
    pub nav_mass_sigma_kg: f64,
}

impl Default for Dispersions {
    fn default() -> Self {
        Dispersions {
            initial_position_3sigma_m: 20.0,
            initial_velocity_3sigma_mps: 3.0,
            initial_pitch_3sigma_deg: 3.0,
            initial_pitch_rate_3sigma_degps: 1.0,
            initial_mass_3sigma_frac: 0.02,
            drag_coefficient_3sigma_frac: 0.10,
            thrust_3sigma_frac: 0.03,
            gimbal_bias_3sigma_deg: 0.5,
            steady_wind_max_mps: 5.0,
            gust_sigma_mps: 2.0,
            gust_correlation_time_s: 2.0,
            nav_position_sigma_m: 0.2,
            nav_velocity_sigma_mps: 0.05,
            nav_pitch_sigma_deg: 0.1,
            nav_pitch_rate_sigma_degps: 0.05,
            nav_mass_sigma_kg: 100.0,
        }
    }
}

/// Word offsets of the three uses of a run's ChaCha stream.
const WORDS_PARAMETERS: u128 = 0;
const WORDS_GUSTS: u128 = 1 << 64;
const WORDS_NAVIGATION: u128 = 2 << 64;

impl Dispersions {
    /// Everything off: the nominal initial state and vehicle, no wind, exact
    /// navigation. (The gust correlation time keeps its default; it is unused.)
    pub fn none() -> Self {
        Dispersions {
            initial_position_3sigma_m: 0.0,
            initial_velocity_3sigma_mps: 0.0,
            initial_pitch_3sigma_deg: 0.0,
            initial_pitch_rate_3sigma_degps: 0.0,
            initial_mass_3sigma_frac: 0.0,
            drag_coefficient_3sigma_frac: 0.0,
            thrust_3sigma_frac: 0.0,
            gimbal_bias_3sigma_deg: 0.0,
            steady_wind_max_mps: 0.0,
            gust_sigma_mps: 0.0,
            nav_position_sigma_m: 0.0,
            nav_velocity_sigma_mps: 0.0,
            nav_pitch_sigma_deg: 0.0,
            nav_pitch_rate_sigma_degps: 0.0,
            nav_mass_sigma_kg: 0.0,
            ..Dispersions::default()
        }
    }

    /// Check every field against its range (see the field docs): finite, not
    /// negative, and below a bound past which the case is no longer a
    /// dispersed landing. The gust correlation time must be positive.
    pub fn validate(&self) -> Result<(), InputError> {
        // (field, value, largest allowed value, unit); all may be 0 (off).
        let non_negative = [
            (
                "initial_position_3sigma_m",
                self.initial_position_3sigma_m,
                1000.0,
                "m",
            ),
            (
                "initial_velocity_3sigma_mps",
                self.initial_velocity_3sigma_mps,
                100.0,
                "m/s",
            ),
            (
                "initial_pitch_3sigma_deg",
                self.initial_pitch_3sigma_deg,
                45.0,
                "deg",
            ),
            (
                "initial_pitch_rate_3sigma_degps",
                self.initial_pitch_rate_3sigma_degps,
                30.0,
                "deg/s",
            ),
            (
                "initial_mass_3sigma_frac",
                self.initial_mass_3sigma_frac,
                0.2,
                "",
            ),
            (
                "drag_coefficient_3sigma_frac",
                self.drag_coefficient_3sigma_frac,
                1.0,
                "",
            ),
            ("thrust_3sigma_frac", self.thrust_3sigma_frac, 0.5, ""),
            (
                "gimbal_bias_3sigma_deg",
                self.gimbal_bias_3sigma_deg,
                10.0,
                "deg",
            ),
            ("steady_wind_max_mps", self.steady_wind_max_mps, 50.0, "m/s"),
            ("gust_sigma_mps", self.gust_sigma_mps, 30.0, "m/s"),
            (
                "nav_position_sigma_m",
                self.nav_position_sigma_m,
                100.0,
                "m",
            ),
            (
                "nav_velocity_sigma_mps",
                self.nav_velocity_sigma_mps,
                10.0,
                "m/s",
            ),
            ("nav_pitch_sigma_deg", self.nav_pitch_sigma_deg, 10.0, "deg"),
            (
                "nav_pitch_rate_sigma_degps",
                self.nav_pitch_rate_sigma_degps,
                10.0,
                "deg/s",
            ),
            ("nav_mass_sigma_kg", self.nav_mass_sigma_kg, 1e5, "kg"),
        ];
        for (name, value, hi, unit) in non_negative {
            let field = format!("dispersions.{name}");
            Range::closed(0.0, hi, unit).check(&field, value)?;
        }
        // A divisor in a = exp(−Δt/τ): positive even when gusts are off.
        Range::open_closed(0.0, 1000.0, "s").check(
            "dispersions.gust_correlation_time_s",
            self.gust_correlation_time_s,
        )
    }

    /// Draw realization `run_index` of the campaign `seed`. Deterministic:
    /// the same (seed, run_index, self) always gives the same realization,
    /// whatever the thread or order it is drawn in. `self` should be valid
    /// ([`Dispersions::validate`]); invalid values do not panic but give
    /// meaningless draws.
    pub fn sample(&self, seed: u64, run_index: u64) -> Realization {
        let rng_at = |words: u128| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(run_index);
            rng.set_word_pos(words);
            rng
        };
        let mut p = rng_at(WORDS_PARAMETERS);
        let mut normal = || -> f64 { p.sample(StandardNormal) };
        // Fixed draw order, independent of which dispersions are on.
        let n: [f64; 10] = std::array::from_fn(|_| normal());
        let wind_u: f64 = p.gen();
        let wind_positive: bool = p.gen();

        let pos = self.initial_position_3sigma_m / 3.0;
        let vel = self.initial_velocity_3sigma_mps / 3.0;
        let initial_offset = InitialOffset {
            x_m: pos * n[0],
            z_m: pos * n[1],
            vx_mps: vel * n[2],
            vz_mps: vel * n[3],
            theta_rad: (self.initial_pitch_3sigma_deg / 3.0).to_radians() * n[4],
            pitch_rate_radps: (self.initial_pitch_rate_3sigma_degps / 3.0).to_radians() * n[5],
            mass_factor: (1.0 + self.initial_mass_3sigma_frac / 3.0 * n[6]).max(0.0),
        };
        let wind_mag = self.steady_wind_max_mps * wind_u;

        let mut gust_rng = rng_at(WORDS_GUSTS);
        let gust_n: f64 = gust_rng.sample(StandardNormal);
        Realization {
            seed,
            run_index,
            initial_offset,
            c_ld_factor: (1.0 + self.drag_coefficient_3sigma_frac / 3.0 * n[7]).max(0.0),
            thrust_factor: (1.0 + self.thrust_3sigma_frac / 3.0 * n[8]).max(0.0),
            gimbal_bias_rad: (self.gimbal_bias_3sigma_deg / 3.0).to_radians() * n[9],
            steady_wind_mps: if wind_positive { wind_mag } else { -wind_mag },
            gust_mps: self.gust_sigma_mps * gust_n,
            gust_sigma_mps: self.gust_sigma_mps,
            gust_correlation_time_s: self.gust_correlation_time_s,
            gust_rng,
            nav: NavSigmas {
                position_m: self.nav_position_sigma_m,
                velocity_mps: self.nav_velocity_sigma_mps,
                pitch_rad: self.nav_pitch_sigma_deg.to_radians(),
                pitch_rate_radps: self.nav_pitch_rate_sigma_degps.to_radians(),
                mass_kg: self.nav_mass_sigma_kg,
            },
            nav_rng: rng_at(WORDS_NAVIGATION),
        }
    }
}

/// Offsets added to the scenario's initial state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct InitialOffset {
    pub x_m: f64,
    pub z_m: f64,
    pub vx_mps: f64,
    pub vz_mps: f64,
    pub theta_rad: f64,
    pub pitch_rate_radps: f64,
    /// Factor on the initial mass (1 = nominal).
    pub mass_factor: f64,
}

/// 1σ navigation errors, SI units and radians.
#[derive(Debug, Clone, Copy, PartialEq)]
struct NavSigmas {
    position_m: f64,
    velocity_mps: f64,
    pitch_rad: f64,
    pitch_rate_radps: f64,
    mass_kg: f64,
}

/// One sampled draw of [`Dispersions`]: fixed parameters, and the running
/// state of the gust process and of the navigation noise.
///
/// Serializes its parameters and the current gust (for logs), not the random
/// generators.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Realization {
    /// The campaign seed this draw came from.
    pub seed: u64,
    /// The run index (ChaCha stream) of this draw.
    pub run_index: u64,
    pub initial_offset: InitialOffset,
    /// Factor k_D on C_LD.
    pub c_ld_factor: f64,
    /// Factor k_T on the thrust.
    pub thrust_factor: f64,
    /// Thrust-axis misalignment b \[rad\].
    pub gimbal_bias_rad: f64,
    /// Steady horizontal wind W_s [m/s] (positive along +x).
    pub steady_wind_mps: f64,
    /// Current gust g_k [m/s], the wind of the next step minus W_s.
    gust_mps: f64,
    #[serde(skip)]
    gust_sigma_mps: f64,
    #[serde(skip)]
    gust_correlation_time_s: f64,
    #[serde(skip)]
    gust_rng: ChaCha8Rng,
    #[serde(skip)]
    nav: NavSigmas,
    #[serde(skip)]
    nav_rng: ChaCha8Rng,
}

impl Realization {
    /// The model errors of this draw, for [`crate::sim::Plant::new`].
    pub fn truth(&self) -> TruthParams {
        TruthParams {
            c_ld_factor: self.c_ld_factor,
            thrust_factor: self.thrust_factor,
            gimbal_bias_rad: self.gimbal_bias_rad,
        }
    }

    /// The dispersed initial state: the scenario's initial state plus the
    /// offsets (mass times its factor; δ undispersed).
    pub fn apply_initial(&self, initial: &InitialState) -> PlantState {
        let o = &self.initial_offset;
        let nominal = PlantState::from_initial(initial);
        PlantState {
            x_m: nominal.x_m + o.x_m,
            z_m: nominal.z_m + o.z_m,
            vx_mps: nominal.vx_mps + o.vx_mps,
            vz_mps: nominal.vz_mps + o.vz_mps,
            theta_rad: nominal.theta_rad + o.theta_rad,
            pitch_rate_radps: nominal.pitch_rate_radps + o.pitch_rate_radps,
            mass_kg: nominal.mass_kg * o.mass_factor,
            gimbal_rad: nominal.gimbal_rad,
        }
    }

    /// The current gust g_k [m/s].
    pub fn gust_mps(&self) -> f64 {
        self.gust_mps
    }

    /// The horizontal wind W_s + g_k [m/s] to hold over the coming step of
    /// `dt_s` \[s\], then advance the gust process exactly by `dt_s`:
    /// g_{k+1} = a·g_k + σ·sqrt(1 − a²)·n_k, a = exp(−Δt/τ).
    ///
    /// One normal draw per call, even with gusts off. A non-positive `dt_s`
    /// leaves the gust unchanged.
    pub fn wind_at_step(&mut self, dt_s: f64) -> f64 {
        let wind = self.steady_wind_mps + self.gust_mps;
        let n: f64 = self.gust_rng.sample(StandardNormal);
        if dt_s > 0.0 {
            let a = (-dt_s / self.gust_correlation_time_s).exp();
            self.gust_mps = a * self.gust_mps + self.gust_sigma_mps * (1.0 - a * a).sqrt() * n;
        }
        wind
    }

    /// The navigation solution: the true state plus white noise on x, z, Vx,
    /// Vz, θ, w and m (δ exact). Seven normal draws per call, from the
    /// navigation range of the stream only.
    pub fn measure(&mut self, truth: &PlantState) -> PlantState {
        let s = self.nav;
        let mut n = || -> f64 { self.nav_rng.sample(StandardNormal) };
        PlantState {
            x_m: truth.x_m + s.position_m * n(),
            z_m: truth.z_m + s.position_m * n(),
            vx_mps: truth.vx_mps + s.velocity_mps * n(),
            vz_mps: truth.vz_mps + s.velocity_mps * n(),
            theta_rad: truth.theta_rad + s.pitch_rad * n(),
            pitch_rate_radps: truth.pitch_rate_radps + s.pitch_rate_radps * n(),
            mass_kg: truth.mass_kg + s.mass_kg * n(),
            gimbal_rad: truth.gimbal_rad,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;

    fn std_dev(v: &[f64]) -> (f64, f64) {
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, var.sqrt())
    }

    fn assert_sigma(name: &str, v: &[f64], sigma: f64) {
        let (mean, sd) = std_dev(v);
        assert!(
            (sd / sigma - 1.0).abs() < 0.1,
            "{name}: σ = {sd}, configured {sigma}"
        );
        // The mean is within 4 standard errors of 0.
        assert!(
            mean.abs() < 4.0 * sigma / (v.len() as f64).sqrt(),
            "{name}: mean {mean}"
        );
    }

    #[test]
    fn same_seed_and_run_give_identical_realizations() {
        let d = Dispersions::default();
        let (mut a, mut b) = (d.sample(42, 17), d.sample(42, 17));
        assert_eq!(a, b);
        let truth = PlantState::from_initial(&Scenario::paper().initial);
        for _ in 0..50 {
            assert_eq!(a.wind_at_step(0.01), b.wind_at_step(0.01));
            assert_eq!(a.measure(&truth), b.measure(&truth));
        }
        assert_eq!(a, b);
    }

    #[test]
    fn different_runs_and_seeds_differ() {
        let d = Dispersions::default();
        let base = d.sample(42, 17);
        for other in [d.sample(42, 18), d.sample(43, 17), d.sample(17, 42)] {
            assert_ne!(base.initial_offset, other.initial_offset);
            assert_ne!(base.c_ld_factor, other.c_ld_factor);
            assert_ne!(base.gust_mps(), other.gust_mps());
        }
    }

    #[test]
    fn sample_statistics_match_the_configured_sigmas() {
        let d = Dispersions::default();
        let draws: Vec<Realization> = (0..2000).map(|k| d.sample(2024, k)).collect();
        let col = |f: &dyn Fn(&Realization) -> f64| draws.iter().map(f).collect::<Vec<f64>>();
        let o = |r: &Realization| r.initial_offset;
        assert_sigma("x", &col(&|r| o(r).x_m), 20.0 / 3.0);
        assert_sigma("z", &col(&|r| o(r).z_m), 20.0 / 3.0);
        assert_sigma("vx", &col(&|r| o(r).vx_mps), 1.0);
        assert_sigma("vz", &col(&|r| o(r).vz_mps), 1.0);
        assert_sigma("theta", &col(&|r| o(r).theta_rad), 1f64.to_radians());
        assert_sigma(
            "w",
            &col(&|r| o(r).pitch_rate_radps),
            (1.0f64 / 3.0).to_radians(),
        );
        assert_sigma("mass", &col(&|r| o(r).mass_factor - 1.0), 0.02 / 3.0);
        assert_sigma("c_ld", &col(&|r| r.c_ld_factor - 1.0), 0.1 / 3.0);
        assert_sigma("thrust", &col(&|r| r.thrust_factor - 1.0), 0.01);
        assert_sigma(
            "bias",
            &col(&|r| r.gimbal_bias_rad),
            (0.5f64 / 3.0).to_radians(),
        );
        assert_sigma("gust", &col(&|r| r.gust_mps()), 2.0);
        // Steady wind: uniform on (−5, 5), σ = 5/√3, both signs.
        let wind = col(&|r| r.steady_wind_mps);
        assert!(wind.iter().all(|w| w.abs() < 5.0));
        assert_sigma("steady wind", &wind, 5.0 / 3f64.sqrt());
    }

    #[test]
    fn gusts_are_gauss_markov_with_the_configured_sigma_and_time() {
        // Across 2000 runs: after 10 s the gust is still N(0, σ²) (stationary
        // start), and its correlation over 1 s is exp(−1/τ).
        let d = Dispersions::default();
        let dt = 0.01;
        let (mut g10, mut g11) = (Vec::new(), Vec::new());
        for k in 0..2000 {
            let mut r = d.sample(5, k);
            let w0 = r.steady_wind_mps;
            for _ in 0..1000 {
                r.wind_at_step(dt);
            }
            g10.push(r.wind_at_step(dt) - w0);
            for _ in 0..99 {
                r.wind_at_step(dt);
            }
            g11.push(r.wind_at_step(dt) - w0);
        }
        assert_sigma("gust at 10 s", &g10, 2.0);
        assert_sigma("gust at 11 s", &g11, 2.0);
        let (_, s10) = std_dev(&g10);
        let (_, s11) = std_dev(&g11);
        let cov = g10.iter().zip(&g11).map(|(a, b)| a * b).sum::<f64>() / 1999.0;
        let rho = cov / (s10 * s11);
        let expected = (-1.0f64 / 2.0).exp();
        assert!(
            (rho - expected).abs() < 0.05,
            "ρ(1 s) = {rho}, expected {expected}"
        );
    }

    #[test]
    fn navigation_noise_has_its_own_stream_and_sigma() {
        let d = Dispersions::default();
        let truth = PlantState::from_initial(&Scenario::paper().initial);
        let (mut a, mut b) = (d.sample(9, 1), d.sample(9, 1));
        // Measuring five times per step in one copy does not change the wind.
        let mut xs = Vec::new();
        for _ in 0..400 {
            for _ in 0..5 {
                xs.push(b.measure(&truth));
            }
            assert_eq!(a.wind_at_step(0.01), b.wind_at_step(0.01));
        }
        let col = |f: fn(&PlantState) -> f64| xs.iter().map(f).collect::<Vec<f64>>();
        assert_sigma("nav x", &col(|s| s.x_m - 100.0), 0.2);
        assert_sigma("nav z", &col(|s| s.z_m - 600.0), 0.2);
        assert_sigma("nav vz", &col(|s| s.vz_mps + 85.0), 0.05);
        assert_sigma(
            "nav theta",
            &col(|s| s.theta_rad - 90f64.to_radians()),
            0.1f64.to_radians(),
        );
        assert_sigma("nav mass", &col(|s| s.mass_kg - 120_000.0), 100.0);
        assert!(xs.iter().all(|s| s.gimbal_rad == truth.gimbal_rad));
    }

    #[test]
    fn none_switches_everything_off() {
        let d = Dispersions::none();
        d.validate().unwrap();
        let initial = Scenario::paper().initial;
        let mut r = d.sample(1, 2);
        assert_eq!(
            r.apply_initial(&initial),
            PlantState::from_initial(&initial)
        );
        assert_eq!(r.truth(), TruthParams::default());
        let s = PlantState::from_initial(&initial);
        for _ in 0..10 {
            assert_eq!(r.wind_at_step(0.01), 0.0);
            assert_eq!(r.measure(&s), s);
        }
        // Switching one dispersion off leaves the others' draws unchanged.
        let full = Dispersions::default().sample(3, 4);
        let no_drag = Dispersions {
            drag_coefficient_3sigma_frac: 0.0,
            ..Dispersions::default()
        }
        .sample(3, 4);
        assert_eq!(no_drag.c_ld_factor, 1.0);
        assert_eq!(no_drag.thrust_factor, full.thrust_factor);
        assert_eq!(no_drag.initial_offset, full.initial_offset);
        assert_eq!(no_drag.steady_wind_mps, full.steady_wind_mps);
    }

    #[test]
    fn validation_names_the_bad_field() {
        Dispersions::default().validate().unwrap();
        let bad = Dispersions {
            thrust_3sigma_frac: -0.01,
            ..Dispersions::default()
        };
        match bad.validate().unwrap_err() {
            InputError::OutOfRange {
                field,
                value,
                allowed,
            } => {
                assert_eq!(field, "dispersions.thrust_3sigma_frac");
                assert_eq!(value, -0.01);
                assert_eq!(allowed, "[0, 0.5]");
            }
            other => panic!("{other:?}"),
        }
        let bad = Dispersions {
            gust_correlation_time_s: 0.0,
            ..Dispersions::default()
        };
        assert!(bad
            .validate()
            .unwrap_err()
            .to_string()
            .contains("gust_correlation_time_s"));
        let bad = Dispersions {
            nav_position_sigma_m: f64::NAN,
            ..Dispersions::default()
        };
        assert!(bad.validate().is_err());
    }

    #[test]
    fn toml_takes_defaults_and_rejects_unknown_fields() {
        let d: Dispersions = toml::from_str("steady_wind_max_mps = 0.0").unwrap();
        assert_eq!(d.steady_wind_max_mps, 0.0);
        assert_eq!(d.gust_sigma_mps, 2.0);
        assert!(toml::from_str::<Dispersions>("wind = 3.0").is_err());
    }
}
