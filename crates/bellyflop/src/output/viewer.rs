//! `viewer.html`: one self-contained page (data, script and style inline;
//! no network) that plays a solve, a closed-loop flight or a campaign.
//!
//! The page's source is kept as files beside the crate (`viewer/`), read in
//! at compile time. [`html`] takes the data as JSON text, so the CLI
//! (`solve --out`, `sim --out`, `montecarlo --out`) and the Python package
//! (`Solution.save_html`) build the same page; [`solve_data`],
//! [`flight_data`] and [`campaign_data`] assemble that data.
//!
//! A scenario with operational constraints (`[constraints]`,
//! [`crate::problem::constraints`]) adds a `constraints` object to a solve's
//! or a flight's data: each limit's values, and for the pitch-rate, tilt and
//! final-descent limits their bound B along the drawn track (for the
//! altitude-triggered ones B(z(t)), opening above the trigger), so the page
//! draws them without doing the math again. Without constraints the data
//! has no such key and the page draws nothing new.

use serde_json::{json, Map, Value};

use crate::collocation::interpolation::Interpolant;
use crate::guidance::Flight;
use crate::output::campaign::{RunRow, RUNS_CSV_COLUMNS};
use crate::output::report;
use crate::output::samples::{self, Samples, COLUMN_NAMES};
use crate::problem::constraints::{self, Limit};
use crate::sim::verdict::TouchdownLimits;
use crate::solution::LimitReport;
use crate::verify::path::{limit_reports, LIMIT_TOLERANCE};
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
/// object), its dense samples `s` and inner mesh breaks.
fn plan_json(solution: &Solution, json: &Value, s: &Samples) -> Value {
    json!({
        "solution": json,
        "dense": columns_json(&COLUMN_NAMES, &s.columns),
        "breaks_s": breaks_s(solution),
    })
}

/// The data of a solve's page: `json` is the `solve --json` object,
/// `propagation` the re-integration drawn as flown (if it succeeded). The
/// scenario's limits, if any, are drawn along the plan's samples, each at
/// its worst as the answer's `path.limits` has it.
pub fn solve_data(
    scenario: &Scenario,
    solution: &Solution,
    json: &Value,
    propagation: Option<&Propagation>,
) -> Value {
    let flown = propagation.map(|p| columns_json(&COLUMN_NAMES, &propagation_columns(solution, p)));
    let s = samples::of(scenario, solution, SAMPLES_PER_INTERVAL);
    let mut data = json!({
        "kind": "solve",
        "scenario": scenario,
        "plan": plan_json(solution, json, &s),
        "flown": flown,
    });
    let reports = solution.path.as_ref().map_or(&[][..], |p| &p.limits[..]);
    if let Some(c) = constraints_json(scenario, &s.columns, reports) {
        data["constraints"] = c;
    }
    data
}

/// The states (x, z, Vx, Vz, θ, w, m) of a track whose columns are t, then
/// [`COLUMN_NAMES`]' states in order (the dense samples and flight.csv).
fn track_states(columns: &[Vec<f64>]) -> Vec<[f64; 7]> {
    (0..columns[0].len())
        .map(|k| std::array::from_fn(|i| columns[1 + i][k]))
        .collect()
}

/// A value of a limit's rows in the unit the page shows: degrees for the
/// tilt and the pitch rate.
fn shown(limit: Limit, value: f64) -> (f64, &'static str) {
    match limit {
        Limit::Cone => (value, "m"),
        Limit::PitchRate => (value.to_degrees(), "°/s"),
        Limit::Tilt => (value.to_degrees(), "°"),
        Limit::FinalDescent => (value, "m/s"),
    }
}

/// The `constraints` object of a page's data (module docs), or None when
/// the scenario has none. `columns` is the track drawn (t, then the
/// states: the plan's samples, or a flight's trace); `reports` each limit
/// at its worst (`path.limits`), given as `worst` {`margin` = −g in the
/// shown unit, `unit`, `t_s`, `held`: g within `verify::path`'s tolerance}.
///
/// Keys: `pad_x_m`, `pad_z_m`, `t_s` (the track's times), then one object
/// per limit switched on, named as in `path.limits`: `cone`
/// {`half_angle_deg`, `tan`}; `pitch_rate` {`max_degps`}; `tilt`
/// {`max_deg`, `below_m`}; `final_descent` {`max_lateral_mps`, `below_m`}.
/// Each but the cone has `column` (the state it bounds, a key of the
/// track) and `bound`, B at each of `t_s` in that column's unit:
/// |column| ≤ B.
fn constraints_json(
    scenario: &Scenario,
    columns: &[Vec<f64>],
    reports: &[LimitReport],
) -> Option<Value> {
    let rows = constraints::rows(scenario);
    if rows.is_empty() {
        return None;
    }
    let c = &scenario.constraints;
    let states = track_states(columns);
    let mut out = json!({
        "pad_x_m": scenario.terminal.x_m,
        "pad_z_m": scenario.terminal.z_m,
        "t_s": columns[0],
    });
    for row in rows.iter().filter(|r| r.sign > 0.0) {
        let mut o = match row.limit {
            Limit::Cone => {
                let gamma_deg = c.cone_half_angle_deg.unwrap_or(f64::NAN);
                json!({ "half_angle_deg": gamma_deg, "tan": gamma_deg.to_radians().tan() })
            }
            Limit::PitchRate => json!({ "max_degps": c.max_pitch_rate_degps }),
            Limit::Tilt => json!({ "max_deg": c.max_tilt_deg, "below_m": c.tilt_below_m }),
            Limit::FinalDescent => json!({
                "max_lateral_mps": c.final_descent_lateral_mps,
                "below_m": c.final_descent_m,
            }),
        };
        if let Some((state, _)) = states.first().and_then(|y| row.own_and_limit(y)) {
            let bound: Vec<Option<f64>> = states
                .iter()
                .map(|y| row.own_and_limit(y).map(|(_, b)| b))
                .collect();
            o["column"] = json!(COLUMN_NAMES[1 + state]);
            o["bound"] = json!(bound);
        }
        if let Some(r) = reports.iter().find(|r| r.limit == row.limit) {
            let (margin, unit) = shown(r.limit, -r.worst);
            let held = r.worst <= LIMIT_TOLERANCE * r.scale;
            o["worst"] = json!({ "margin": margin, "unit": unit, "t_s": r.t_s, "held": held });
        }
        let key = serde_json::to_value(row.limit).unwrap_or(Value::Null);
        out[key.as_str().unwrap_or("limit")] = o;
    }
    Some(out)
}

/// The data of a flight's page: `json` is the `sim --json` object; the
/// flight must have its trace recorded. Each re-plan's answer is drawn at
/// its nodes (`replan_paths`, in the order of the JSON's `replans`). The
/// scenario's limits, if any, are drawn and measured along the trace.
pub fn flight_data(scenario: &Scenario, flight: &Flight, json: &Value) -> Value {
    let trace = report::trace_columns(flight);
    let first = &flight.first_plan;
    let s = samples::of(scenario, first, SAMPLES_PER_INTERVAL);
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
    let mut data = json!({
        "kind": "flight",
        "scenario": scenario,
        "plan": plan_json(first, &first.to_json(), &s),
        "replan_paths": replans,
        "flight": json,
        "trace": columns_json(&report::TRACE_COLUMNS, &trace),
    });
    // The limits along the flown trace, each at its worst there.
    let rows = constraints::rows(scenario);
    let reports = limit_reports(&rows, &trace[0], &track_states(&trace));
    if let Some(c) = constraints_json(scenario, &trace, &reports) {
        data["constraints"] = c;
    }
    data
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
    use crate::input::scenario::Constraints;
    use crate::problem::constraints::TRIGGER_WIDTH_M;
    use crate::{SolverSettings, Status};

    /// The straight-line guess of `scenario`, its path measured, and the
    /// data of its solve page.
    fn guess_data(scenario: &Scenario) -> (Solution, Value) {
        let settings = SolverSettings::default();
        let mut sol = crate::method::guess_answer(
            scenario,
            &settings,
            Status::NotConverged,
            String::new(),
            0.0,
        );
        sol.path = crate::verify::path::measure(scenario, &sol).ok();
        let data = solve_data(scenario, &sol, &sol.to_json(), None);
        (sol, data)
    }

    /// With all four limits on, the solve data carries each: its values,
    /// the cone's tan, a bound per sample (the trigger's: the limit below
    /// its height, open above), and its worst margin from `path.limits`.
    /// The paper's case carries none.
    #[test]
    fn a_constrained_solve_carries_its_limits_and_the_paper_none() {
        let mut scenario = Scenario::paper();
        let want = Constraints::recommended();
        scenario.constraints = want.clone();
        let (sol, data) = guess_data(&scenario);
        let c = &data["constraints"];
        let num = |v: &Value| v.as_f64().unwrap();
        let gamma = want.cone_half_angle_deg.unwrap();
        assert_eq!(num(&c["cone"]["half_angle_deg"]), gamma);
        assert!((num(&c["cone"]["tan"]) - gamma.to_radians().tan()).abs() < 1e-15);
        assert_eq!(
            num(&c["pitch_rate"]["max_degps"]),
            want.max_pitch_rate_degps.unwrap()
        );
        assert_eq!(num(&c["tilt"]["max_deg"]), want.max_tilt_deg.unwrap());
        assert_eq!(num(&c["tilt"]["below_m"]), want.tilt_below_m.unwrap());
        let fd = &c["final_descent"];
        assert_eq!(
            num(&fd["max_lateral_mps"]),
            want.final_descent_lateral_mps.unwrap()
        );
        assert_eq!(num(&fd["below_m"]), want.final_descent_m.unwrap());
        assert!(c["cone"].get("bound").is_none());
        let t = data["plan"]["dense"]["t_s"].as_array().unwrap();
        assert_eq!(c["t_s"].as_array().unwrap(), t);
        let z: Vec<f64> = data["plan"]["dense"]["z_m"]
            .as_array()
            .unwrap()
            .iter()
            .map(num)
            .collect();
        let z_f = scenario.terminal.z_m;
        for (key, column, limit, h) in [
            (
                "pitch_rate",
                "pitch_rate_radps",
                want.max_pitch_rate_degps.unwrap().to_radians(),
                None,
            ),
            (
                "tilt",
                "theta_rad",
                want.max_tilt_deg.unwrap().to_radians(),
                want.tilt_below_m,
            ),
            (
                "final_descent",
                "vx_mps",
                want.final_descent_lateral_mps.unwrap(),
                want.final_descent_m,
            ),
        ] {
            assert_eq!(c[key]["column"], column);
            let bound: Vec<f64> = c[key]["bound"]
                .as_array()
                .unwrap()
                .iter()
                .map(num)
                .collect();
            assert_eq!(bound.len(), t.len(), "{key}");
            let (mut below, mut above) = (0, 0);
            for (b, z) in bound.iter().zip(&z) {
                let dz = z - z_f - h.unwrap_or(f64::INFINITY);
                if dz < -10.0 * TRIGGER_WIDTH_M {
                    assert!((b - limit).abs() < 1e-3 * limit, "{key} at z = {z}: {b}");
                    below += 1;
                } else if dz > 10.0 * TRIGGER_WIDTH_M {
                    assert!(*b > limit * 1.5, "{key} at z = {z}: {b}");
                    above += 1;
                }
            }
            assert!(
                below > 0 && (h.is_none() || above > 0),
                "{key}: {below} below, {above} above"
            );
        }
        let limits = &sol.path.as_ref().expect("the guess flies").limits;
        assert_eq!(limits.len(), 4);
        for r in limits {
            let key = serde_json::to_value(r.limit).unwrap();
            let w = &c[key.as_str().unwrap()]["worst"];
            assert_eq!(num(&w["t_s"]), r.t_s);
            assert!((num(&w["margin"]) - shown(r.limit, -r.worst).0).abs() < 1e-12);
            assert_eq!(w["held"], r.worst <= LIMIT_TOLERANCE * r.scale);
        }
        assert_eq!(
            num(&c["pitch_rate"]["worst"]["margin"]),
            -limits[1].worst.to_degrees()
        );

        let (_, paper) = guess_data(&Scenario::paper());
        assert!(paper.get("constraints").is_none());
        assert!(!html(&paper.to_string())
            .unwrap()
            .contains("\"constraints\""));
    }

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
