//! `viewer.html`: one self-contained page (data, script and style inline;
//! no network) that plays a solve, a closed-loop flight or a campaign.
//!
//! The page's source is kept as files beside the crate (`viewer/`), read in
//! at compile time. [`html`] takes the data as JSON text, so the CLI
//! (`solve --out`, `sim --out`, `montecarlo --out`) and the Python package
//! (`Solution.save_html`) build the same page; [`solve_data`],
//! [`flight_data`] and [`campaign_data`] assemble that data.

use serde_json::{json, Map, Value};

use crate::collocation::interpolation::Interpolant;
use crate::guidance::Flight;
use crate::output::campaign::{RunRow, RUNS_CSV_COLUMNS};
use crate::output::report;
use crate::output::samples::{self, COLUMN_NAMES};
use crate::sim::verdict::TouchdownLimits;
use crate::verify::propagate::Propagation;
use crate::{Scenario, Solution};

const TEMPLATE: &str = include_str!("../../viewer/viewer.html");
const STYLE: &str = include_str!("../../viewer/viewer.css");
const SCRIPT: &str = include_str!("../../viewer/viewer.js");

/// Samples per interval between LGR nodes in the viewer's curves: as in
/// `trajectory.csv`.
pub const SAMPLES_PER_INTERVAL: usize = 10;

/// The kinds of page, the data's `kind`.
pub const KINDS: [&str; 3] = ["solve", "flight", "campaign"];

/// Why the data given to [`html`] cannot make a page.
#[derive(Debug, Clone, PartialEq)]
pub enum ViewerError {
    /// The text is not JSON (serde_json's message).
    NotJson(String),
    /// The JSON is not an object with a `kind` of [`KINDS`].
    BadKind(String),
}

impl std::fmt::Display for ViewerError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ViewerError::NotJson(e) => write!(f, "viewer data is not JSON: {e}"),
            ViewerError::BadKind(k) => write!(
                f,
                "viewer data needs a \"kind\" of {}, got {k}",
                KINDS.join(", ")
            ),
        }
    }
}

impl std::error::Error for ViewerError {}

/// The page for `data_json` (an object from [`solve_data`], [`flight_data`]
/// or [`campaign_data`]). The JSON is embedded in a `<script
/// type="application/json">` with every `<` written `\u003c`, so no text in
/// it can close the tag.
pub fn html(data_json: &str) -> Result<String, ViewerError> {
    let v: Value =
        serde_json::from_str(data_json).map_err(|e| ViewerError::NotJson(e.to_string()))?;
    let kind = v.get("kind").and_then(Value::as_str);
    if !kind.is_some_and(|k| KINDS.contains(&k)) {
        let got = v.get("kind").map_or("none".to_string(), Value::to_string);
        return Err(ViewerError::BadKind(got));
    }
    let data = v.to_string().replace('<', "\\u003c");
    Ok(TEMPLATE
        .replace("/*STYLE*/", STYLE)
        .replace("/*SCRIPT*/", &SCRIPT.replace("</script", "<\\/script"))
        .replace("/*DATA*/", &data))
}

/// Columns as one JSON object, name → array.
fn columns_json(names: &[&str], columns: &[Vec<f64>]) -> Value {
    let m: Map<String, Value> = names
        .iter()
        .zip(columns)
        .map(|(n, c)| (n.to_string(), json!(c)))
        .collect();
    Value::Object(m)
}

/// The re-integrated trajectory in [`COLUMN_NAMES`]'s columns, sampled at
/// the integrator's accepted steps; its thrust and gimbal rate are the
/// interpolants the integration used.
pub fn propagation_columns(solution: &Solution, p: &Propagation) -> [Vec<f64>; 11] {
    let state = |c: usize| p.states.iter().map(|s| s[c]).collect::<Vec<f64>>();
    let along = |values: &[f64]| {
        let f = Interpolant::new(p.options.interpolation, &solution.t_s, values);
        p.t_s.iter().map(|&t| f.eval(t)).collect::<Vec<f64>>()
    };
    [
        p.t_s.clone(),
        state(0),
        state(1),
        state(2),
        state(3),
        state(4),
        state(5),
        state(6),
        p.delta_rad.clone(),
        along(&solution.thrust_n),
        along(&solution.gimbal_rate_radps),
    ]
}

/// The times of the mesh's inner interval breaks \[s\].
fn breaks_s(solution: &Solution) -> Vec<f64> {
    let b = &solution.mesh.breaks_tau;
    b.iter()
        .skip(1)
        .take(b.len().saturating_sub(2))
        .map(|tau| 0.5 * (tau + 1.0) * solution.tf_s)
        .collect()
}

/// A plan as the viewer draws it: its JSON (`json`, e.g. the `solve --json`
/// object), its dense samples and inner mesh breaks.
fn plan_json(scenario: &Scenario, solution: &Solution, json: &Value) -> Value {
    let s = samples::of(scenario, solution, SAMPLES_PER_INTERVAL);
    json!({
        "solution": json,
        "dense": columns_json(&COLUMN_NAMES, &s.columns),
        "breaks_s": breaks_s(solution),
    })
}

/// The data of a solve's page: `json` is the `solve --json` object,
/// `propagation` the re-integration drawn as flown (if it succeeded).
pub fn solve_data(
    scenario: &Scenario,
    solution: &Solution,
    json: &Value,
    propagation: Option<&Propagation>,
) -> Value {
    let flown = propagation.map(|p| columns_json(&COLUMN_NAMES, &propagation_columns(solution, p)));
    json!({
        "kind": "solve",
        "scenario": scenario,
        "plan": plan_json(scenario, solution, json),
        "flown": flown,
    })
}

/// The data of a flight's page: `json` is the `sim --json` object; the
/// flight must have its trace recorded. Each re-plan's answer is drawn at
/// its nodes (`replan_paths`, in the order of the JSON's `replans`).
pub fn flight_data(scenario: &Scenario, flight: &Flight, json: &Value) -> Value {
    let trace = report::trace_columns(flight);
    let replans: Vec<Value> = flight
        .replans
        .iter()
        .map(|r| {
            let p = &r.path;
            json!({
                "outcome": r.outcome,
                "t_s": p.t_s, "x_m": p.x_m, "z_m": p.z_m,
                "vx_mps": p.vx_mps, "vz_mps": p.vz_mps, "theta_rad": p.theta_rad,
            })
        })
        .collect();
    json!({
        "kind": "flight",
        "scenario": scenario,
        "plan": plan_json(scenario, &flight.first_plan, &flight.first_plan.to_json()),
        "replan_paths": replans,
        "flight": json,
        "trace": columns_json(&report::TRACE_COLUMNS, &trace),
    })
}

/// The data of a campaign's page: its rows (as runs.csv's columns), the
/// `montecarlo --json` summary, the touchdown limits and `sim_command`, the
/// command that flies one of its runs again without its `--run K`.
pub fn campaign_data(
    rows: &[RunRow],
    summary: &Value,
    limits: &TouchdownLimits,
    sim_command: &str,
) -> Value {
    let values: Vec<Value> = rows
        .iter()
        .map(|r| {
            let o = serde_json::to_value(r).unwrap_or(Value::Null);
            RUNS_CSV_COLUMNS.iter().map(|c| o[*c].clone()).collect()
        })
        .collect();
    json!({
        "kind": "campaign",
        "summary": summary,
        "limits": limits,
        "columns": RUNS_CSV_COLUMNS,
        "rows": values,
        "sim_command": sim_command,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_data_is_a_typed_error() {
        assert!(matches!(html("{"), Err(ViewerError::NotJson(_))));
        assert!(matches!(html("[1]"), Err(ViewerError::BadKind(_))));
        assert!(matches!(
            html(r#"{"kind":"map"}"#),
            Err(ViewerError::BadKind(_))
        ));
    }

    #[test]
    fn no_text_in_the_data_closes_its_script() {
        let page = html(r#"{"kind":"campaign","sim_command":"</script><b>"}"#).unwrap();
        assert_eq!(
            page.matches("</script>").count(),
            page.matches("<script").count()
        );
        assert!(page.contains("\\u003c/script>\\u003cb>"));
        // Self-contained: nothing is fetched.
        for fetch in ["src=\"http", "href=\"http", "@import", "fetch("] {
            assert!(!page.contains(fetch), "{fetch}");
        }
    }
}
