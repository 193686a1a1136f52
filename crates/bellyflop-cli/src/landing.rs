//! Landing precision of a solution: re-propagation through the library, and
//! its summary lines and JSON fields.

use bellyflop::propagate::{self, IntegrationError, Interpolation, Options, Propagation};
use bellyflop::{Scenario, Solution};
use clap::ValueEnum;
use serde_json::{json, Value};

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
    let options = Options {
        interpolation: interpolation.into(),
        ..Options::default()
    };
    propagate::propagate(scenario, solution, &options)
}

/// The summary lines of `bellyflop solve`.
pub fn print_summary(p: &Result<Propagation, IntegrationError>, optimized_mass_kg: f64) {
    match p {
        Ok(p) => {
            let e = &p.landing_error;
            println!(
                "landing error position {:.4} m, velocity {:.4} m/s, pitch {:.4} deg, rate {:.4} deg/s",
                e.position_m,
                e.velocity_mps,
                e.pitch_rad.to_degrees(),
                e.rate_radps.to_degrees()
            );
            let o = &p.options;
            println!(
                "              re-propagated (DOP853, tolerance {:.0e}, {} controls): terminal mass {:.1} kg ({:+.3} kg against {:.1} kg)",
                o.integrator.rtol,
                o.interpolation.as_str(),
                p.terminal_mass_kg,
                p.mass_error_kg,
                optimized_mass_kg
            );
        }
        Err(e) => println!("landing error unavailable: {e}"),
    }
}

/// `landing_error` ({position_m, velocity_mps, pitch_rad, rate_radps}, or null
/// when the propagation failed).
pub fn landing_error_json(p: &Result<Propagation, IntegrationError>) -> Value {
    match p {
        Ok(p) => serde_json::to_value(p.landing_error).expect("a LandingError serializes"),
        Err(_) => Value::Null,
    }
}

/// `propagation`: how the landing error was measured, the terminal mass, the
/// propagated final state, or the reason it failed.
pub fn propagation_json(p: &Result<Propagation, IntegrationError>) -> Value {
    match p {
        Ok(p) => {
            let [x, z, vx, vz, theta, w, m] = p.final_state();
            json!({
                "integrator": "dop853",
                "rtol": p.options.integrator.rtol,
                "atol": p.options.integrator.atol,
                "interpolation": p.options.interpolation,
                "nozzle": p.options.nozzle,
                "terminal_mass_kg": p.terminal_mass_kg,
                "mass_error_kg": p.mass_error_kg,
                "final_state": {
                    "x_m": x, "z_m": z, "vx_mps": vx, "vz_mps": vz,
                    "theta_rad": theta, "pitch_rate_radps": w, "mass_kg": m,
                },
                "steps": p.stats.accepted_steps,
                "error": Value::Null,
            })
        }
        Err(e) => json!({ "error": e.to_string() }),
    }
}

/// Add `landing_error` and `propagation` to the JSON of a solution.
pub fn add_to_json(v: &mut Value, p: &Result<Propagation, IntegrationError>) {
    v["landing_error"] = landing_error_json(p);
    v["propagation"] = propagation_json(p);
}
