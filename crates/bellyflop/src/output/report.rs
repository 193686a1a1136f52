//! The JSON object of one solve, as `bellyflop solve --json` prints it and
//! the Python package's `Solution.to_dict()` returns it: the solution's own
//! fields plus its landing precision (`landing_error`, `propagation`), its
//! mesh error (`mesh`) and the scenario's `warnings` ([`solve_json`]).

use serde_json::{json, Value};

use crate::collocation::interpolation::Interpolation;
use crate::guidance::{Flight, SimConfig, TraceSample};
use crate::sim::RunOutcome;
use crate::verify::ode::IntegrationError;
use crate::verify::propagate::{self, Options, Propagation};
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
                "controls": p.options.controls,
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

/// The `mesh` field: the solution's relative error on each interval
/// ([`crate::verify::mesh_error`]) and the largest, or why it could not be estimated.
///
/// A refined solution's last pass estimated it already (refinement returns
/// the answer of its last estimated pass); that estimate is reused.
pub fn add_mesh_json(v: &mut Value, scenario: &Scenario, solution: &Solution) {
    if solution.controls_flown.is_some() {
        v["mesh"] = json!({ "error": "not applicable: the answer was polished, and its controls_flown are integrated, not collocated (the landing error is their error)" });
        return;
    }
    let done = solution
        .refinement
        .as_ref()
        .and_then(|r| r.passes.last())
        .filter(|p| p.mesh == solution.mesh);
    let errors = match done {
        Some(p) => Ok(p.intervals.clone()),
        None => crate::verify::mesh_error::estimate(scenario, solution),
    };
    v["mesh"] = match errors {
        Ok(errors) => json!({
            "max_relative_error": errors.iter().fold(0.0f64, |m, e| m.max(e.relative_error)),
            "intervals": errors,
        }),
        Err(e) => json!({ "error": e.to_string() }),
    };
}

/// The scenario's `warnings` ([`crate::Case::warnings`]: a guess clamped
/// into its range) as the JSON's `warnings` list, only when there are any:
/// the JSON of a file without warnings has no such key.
pub fn add_warnings(v: &mut Value, warnings: &[String]) {
    if !warnings.is_empty() {
        v["warnings"] = warnings.into();
    }
}

/// The whole `solve --json` object: [`Solution::to_json`] with the landing
/// precision of `p`, the mesh error and the scenario's `warnings` added
/// (the CLI adds `--repeat`'s timing fields to it, and nothing else).
pub fn solve_json(
    scenario: &Scenario,
    solution: &Solution,
    p: &Result<Propagation, IntegrationError>,
    warnings: &[String],
) -> Value {
    let mut v = solution.to_json();
    add_landing_json(&mut v, p);
    add_mesh_json(&mut v, scenario, solution);
    add_warnings(&mut v, warnings);
    v
}

/// The flight as one JSON object.
pub fn flight_json(
    f: &Flight,
    outcome: RunOutcome,
    seed: u64,
    run: u64,
    config: &SimConfig,
) -> Value {
    json!({
        "seed": seed,
        "run": run,
        "outcome": f.outcome,
        "outcome_name": outcome,
        "fuel_kg": f.fuel_kg(),
        "first_plan": {
            "status": f.first_plan.status.as_str(),
            "nominal": f.first_plan_nominal,
            "tf_s": f.first_plan.tf_s,
            "final_mass_kg": f.first_plan.final_mass_kg,
            "iterations": f.first_plan.iterations,
        },
        "replans": f.replans,
        "saturation": f.saturation,
        "config": config,
    })
}

/// One column of flight.csv: its name and the value of a plant step.
type TraceColumn = (&'static str, fn(&TraceSample) -> f64);

/// flight.csv's columns, in order: the one definition [`TRACE_COLUMNS`] and
/// [`trace_columns`] are read from.
const TRACE: [TraceColumn; 12] = [
    ("t_s", |s| s.t_s),
    ("x_m", |s| s.state.x_m),
    ("z_m", |s| s.state.z_m),
    ("vx_mps", |s| s.state.vx_mps),
    ("vz_mps", |s| s.state.vz_mps),
    ("theta_rad", |s| s.state.theta_rad),
    ("pitch_rate_radps", |s| s.state.pitch_rate_radps),
    ("mass_kg", |s| s.state.mass_kg),
    ("delta_rad", |s| s.state.gimbal_rad),
    ("thrust_cmd_n", |s| s.thrust_cmd_n),
    ("gimbal_rate_cmd_radps", |s| s.gimbal_rate_cmd_radps),
    ("wind_mps", |s| s.wind_mps),
];

/// The columns of flight.csv, in order: the names of the table `TRACE`.
pub const TRACE_COLUMNS: [&str; 12] = {
    let mut names = [""; 12];
    let mut i = 0;
    while i < names.len() {
        names[i] = TRACE[i].0;
        i += 1;
    }
    names
};

/// The flown trace as columns ([`TRACE_COLUMNS`]): one value per plant step.
pub fn trace_columns(f: &Flight) -> [Vec<f64>; 12] {
    TRACE.map(|(_, value)| f.trace.iter().map(value).collect())
}

/// The text of flight.csv: the header ([`TRACE_COLUMNS`]) and one line per
/// plant step, numbers in full precision.
pub fn trace_csv(f: &Flight) -> String {
    let cols = trace_columns(f);
    let mut csv = TRACE_COLUMNS.join(",");
    csv.push('\n');
    for i in 0..f.trace.len() {
        let line: Vec<String> = cols.iter().map(|c| c[i].to_string()).collect();
        csv.push_str(&line.join(","));
        csv.push('\n');
    }
    csv
}
