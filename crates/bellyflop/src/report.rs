//! The JSON object of one solve, as `bellyflop solve --json` prints it and
//! the Python package's `Solution.to_dict()` returns it: the solution's own
//! fields plus its landing precision (`landing_error`, `propagation`).

use serde_json::{json, Value};

use crate::propagate::{self, IntegrationError, Interpolation, Options, Propagation};
use crate::{Scenario, Solution};

/// Re-propagate `solution` with the default integrator and nozzle model and
/// the given control interpolation.
pub fn propagate(
    scenario: &Scenario,
    solution: &Solution,
    interpolation: Interpolation,
) -> Result<Propagation, IntegrationError> {
    let options = Options {
        interpolation,
        ..Options::default()
    };
    propagate::propagate(scenario, solution, &options)
}

/// `landing_error` ({position_m, velocity_mps, pitch_rad, rate_radps}, or null
/// when the propagation failed).
pub fn landing_error_json(p: &Result<Propagation, IntegrationError>) -> Value {
    match p {
        Ok(p) => serde_json::to_value(p.landing_error).unwrap_or(Value::Null),
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
pub fn add_landing_json(v: &mut Value, p: &Result<Propagation, IntegrationError>) {
    v["landing_error"] = landing_error_json(p);
    v["propagation"] = propagation_json(p);
}

/// The whole `solve --json` object: [`Solution::to_json`] with the landing
/// precision of `p` added.
pub fn solve_json(solution: &Solution, p: &Result<Propagation, IntegrationError>) -> Value {
    let mut v = solution.to_json();
    add_landing_json(&mut v, p);
    v
}
