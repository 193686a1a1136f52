//! The true vehicle, shared by the plant that integrates it and the
//! dispersions that draw it: its state ([`PlantState`]) and its deviations
//! from the guidance model ([`TruthParams`]).
//!
//! Its own module so that the imports run one way: [`super::plant`] and
//! [`super::disturbance`] both use these types, and the plant uses the
//! disturbance's [`super::Realization`].

use serde::Serialize;

use crate::input::error::InputError;
use crate::input::range::Range;
use crate::input::scenario::InitialState;

/// The full plant state, SI units and radians.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PlantState {
    /// Downrange position x \[m\].
    pub x_m: f64,
    /// Altitude z \[m\]; the pad is at the scenario's terminal z_f.
    pub z_m: f64,
    /// Ground-relative horizontal velocity Vx [m/s].
    pub vx_mps: f64,
    /// Ground-relative vertical velocity Vz [m/s] (negative descending).
    pub vz_mps: f64,
    /// Pitch θ from the vertical \[rad\].
    pub theta_rad: f64,
    /// Pitch rate w = θ̇ [rad/s].
    pub pitch_rate_radps: f64,
    /// Mass m \[kg\].
    pub mass_kg: f64,
    /// Nozzle (gimbal) angle δ \[rad\], the state of δ̇ = χ.
    pub gimbal_rad: f64,
}

impl PlantState {
    /// The nominal initial state of a scenario (degrees converted to radians).
    pub fn from_initial(i: &InitialState) -> Self {
        PlantState {
            x_m: i.x_m,
            z_m: i.z_m,
            vx_mps: i.vx_mps,
            vz_mps: i.vz_mps,
            theta_rad: i.theta_deg.to_radians(),
            pitch_rate_radps: i.pitch_rate_degps.to_radians(),
            mass_kg: i.mass_kg,
            gimbal_rad: i.gimbal_deg.to_radians(),
        }
    }

    /// (x, z, Vx, Vz, θ, w, m, δ), the order of [`crate::problem::dynamics::rhs_augmented`].
    pub fn to_array(&self) -> [f64; 8] {
        [
            self.x_m,
            self.z_m,
            self.vx_mps,
            self.vz_mps,
            self.theta_rad,
            self.pitch_rate_radps,
            self.mass_kg,
            self.gimbal_rad,
        ]
    }

    /// Inverse of [`PlantState::to_array`].
    pub fn from_array(y: &[f64; 8]) -> Self {
        PlantState {
            x_m: y[0],
            z_m: y[1],
            vx_mps: y[2],
            vz_mps: y[3],
            theta_rad: y[4],
            pitch_rate_radps: y[5],
            mass_kg: y[6],
            gimbal_rad: y[7],
        }
    }

    /// Every component is finite.
    pub fn is_finite(&self) -> bool {
        self.to_array().iter().all(|v| v.is_finite())
    }
}

/// The true vehicle's deviations from the guidance model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TruthParams {
    /// Factor k_D on the drag coefficient C_LD (1 = nominal).
    pub c_ld_factor: f64,
    /// Factor k_T on the thrust magnitude (1 = nominal).
    pub thrust_factor: f64,
    /// Thrust-axis misalignment b \[rad\], added to δ.
    pub gimbal_bias_rad: f64,
}

impl Default for TruthParams {
    /// The nominal vehicle: k_D = k_T = 1, b = 0.
    fn default() -> Self {
        TruthParams {
            c_ld_factor: 1.0,
            thrust_factor: 1.0,
            gimbal_bias_rad: 0.0,
        }
    }
}

impl TruthParams {
    /// Factors finite and non-negative, at most 10; |b| < 90°.
    pub fn validate(&self) -> Result<(), InputError> {
        Range::closed(0.0, 10.0, "").check("truth.c_ld_factor", self.c_ld_factor)?;
        Range::closed(0.0, 10.0, "").check("truth.thrust_factor", self.thrust_factor)?;
        Range::open(
            -std::f64::consts::FRAC_PI_2,
            std::f64::consts::FRAC_PI_2,
            "rad",
        )
        .check("truth.gimbal_bias_rad", self.gimbal_bias_rad)
    }
}
