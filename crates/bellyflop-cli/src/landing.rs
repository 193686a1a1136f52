//! Landing precision of a solution: re-propagation through the library, and
//! its summary lines and JSON fields.

use bellyflop::collocation::interpolation::Interpolation;
use bellyflop::verify::ode::IntegrationError;
use bellyflop::verify::propagate::Propagation;
use bellyflop::{Scenario, Solution};
use clap::ValueEnum;

/// `--interpolation`: how the controls are rebuilt between nodes.
#[derive(Clone, Copy, Debug, Default, ValueEnum)]
pub enum InterpolationArg {
    /// Piecewise linear.
    Linear,
    /// Monotone piecewise cubic (PCHIP), the default.
    #[default]
    Pchip,
}

impl From<InterpolationArg> for Interpolation {
    fn from(a: InterpolationArg) -> Self {
        match a {
            InterpolationArg::Linear => Interpolation::Linear,
            InterpolationArg::Pchip => Interpolation::Pchip,
        }
    }
}

/// Re-propagate `solution` with the default integrator and nozzle model.
pub fn propagate(
    scenario: &Scenario,
    solution: &Solution,
    interpolation: InterpolationArg,
) -> Result<Propagation, IntegrationError> {
    bellyflop::output::report::propagate(scenario, solution, interpolation.into())
}

/// The summary lines of `bellyflop solve`.
pub fn print_summary(p: &Result<Propagation, IntegrationError>, optimized_mass_kg: f64) {
    match p {
        Ok(p) => {
            let e = &p.landing_error;
            outln!(
                "landing error position {:.4} m, velocity {:.4} m/s, pitch {:.4} deg, rate {:.4} deg/s",
                e.position_m,
                e.velocity_mps,
                e.pitch_rad.to_degrees(),
                e.rate_radps.to_degrees()
            );
            let o = &p.options;
            let controls = match o.controls {
                bellyflop::verify::propagate::ControlSource::Collocation => {
                    "the collocation's controls as flown, per interval".to_string()
                }
                bellyflop::verify::propagate::ControlSource::Flown => {
                    "the flown controls, piece by piece".to_string()
                }
                _ => format!("{} controls", o.interpolation.as_str()),
            };
            outln!(
                "              re-propagated (DOP853, tolerance {:.0e}, {controls}): terminal mass {:.1} kg ({:+.3} kg against {:.1} kg)",
                o.integrator.rtol,
                p.terminal_mass_kg,
                p.mass_error_kg,
                optimized_mass_kg
            );
        }
        Err(e) => outln!("landing error unavailable: {e}"),
    }
}

pub use bellyflop::output::report::{landing_error_json, propagation_json};
