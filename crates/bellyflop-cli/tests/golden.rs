//! Outputs recorded before a restructure, compared number for number.
//!
//! Each case runs the CLI and compares its JSON (and a campaign's runs.csv)
//! with the file under `tests/golden/`, after dropping only the wall-clock
//! fields ([`WALL_CLOCK`]). Every other number must be bit-identical: a
//! change of behaviour, however small, fails here.
//!
//! A change that is meant to change the numbers records them again:
//!
//! ```text
//! BELLYFLOP_RECORD_GOLDEN=1 cargo test -p bellyflop-cli --test golden
//! ```
//!
//! and the commit says why they moved.

mod common;
use common::bellyflop;

use std::path::{Path, PathBuf};

use serde_json::Value;

/// Keys whose values are wall-clock times, or flags and counts derived from
/// them (a re-plan is `late` when its solve took longer than its period).
const WALL_CLOCK: [&str; 10] = [
    "solve_time_ms",
    "time_ms",
    "total_time_ms",
    "ms",
    "solve_ms",
    "replan_time_ms",
    "wall_time_s",
    "max_replan_ms",
    "late",
    "late_replans",
];

fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

fn recording() -> bool {
    std::env::var_os("BELLYFLOP_RECORD_GOLDEN").is_some()
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("bellyflop-golden-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `v` without the [`WALL_CLOCK`] keys, at any depth.
fn without_wall_clock(v: &mut Value) {
    match v {
        Value::Object(map) => {
            map.retain(|k, _| !WALL_CLOCK.contains(&k.as_str()));
            map.values_mut().for_each(without_wall_clock);
        }
        Value::Array(items) => items.iter_mut().for_each(without_wall_clock),
        _ => {}
    }
}

/// The first path at which `a` and `b` differ, with both values.
fn first_difference(a: &Value, b: &Value, path: &str) -> Option<String> {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
            keys.into_iter().find_map(|k| match (x.get(k), y.get(k)) {
                (Some(p), Some(q)) => first_difference(p, q, &format!("{path}.{k}")),
                (p, q) => Some(format!("{path}.{k}: {p:?} against {q:?}")),
            })
        }
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => x
            .iter()
            .zip(y)
            .enumerate()
            .find_map(|(i, (p, q))| first_difference(p, q, &format!("{path}[{i}]"))),
        _ if a == b => None,
        _ => Some(format!("{path}: {a} against {b}")),
    }
}

/// Compare `json` (a command's stdout) with `golden/<name>.json`, or record it.
fn check_json(name: &str, json: &str) {
    let mut got: Value = serde_json::from_str(json).expect("one JSON object");
    without_wall_clock(&mut got);
    let file = golden_dir().join(format!("{name}.json"));
    if recording() {
        std::fs::create_dir_all(golden_dir()).unwrap();
        std::fs::write(&file, serde_json::to_string_pretty(&got).unwrap() + "\n").unwrap();
        return;
    }
    let text = std::fs::read_to_string(&file).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (record with BELLYFLOP_RECORD_GOLDEN=1)",
            file.display()
        )
    });
    let want: Value = serde_json::from_str(&text).unwrap();
    if let Some(diff) = first_difference(&got, &want, name) {
        panic!("{name} changed (now against recorded): {diff}");
    }
}

/// Compare a CSV with `golden/<name>.csv`, the [`WALL_CLOCK`] columns dropped.
fn check_csv(name: &str, csv: &str) {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("a header").split(',').collect();
    let keep: Vec<usize> = (0..header.len())
        .filter(|&i| !WALL_CLOCK.contains(&header[i]))
        .collect();
    let pick = |line: &str| {
        let cells: Vec<&str> = line.split(',').collect();
        keep.iter().map(|&i| cells[i]).collect::<Vec<_>>().join(",")
    };
    let got: Vec<String> = std::iter::once(pick(&header.join(",")))
        .chain(lines.map(pick))
        .collect();
    let file = golden_dir().join(format!("{name}.csv"));
    if recording() {
        std::fs::create_dir_all(golden_dir()).unwrap();
        std::fs::write(&file, got.join("\n") + "\n").unwrap();
        return;
    }
    let want = std::fs::read_to_string(&file).unwrap();
    for (i, (g, w)) in got.iter().zip(want.lines()).enumerate() {
        assert_eq!(g, w, "{name}.csv line {} changed", i + 1);
    }
    assert_eq!(
        got.len(),
        want.lines().count(),
        "{name}.csv: row count changed"
    );
}

fn run_ok(args: &[&str]) -> String {
    let (code, stdout, stderr) = bellyflop(args);
    // 1 (output not written) and 2 (bad input) are failures of the test;
    // any status of a solve or outcome of a flight is an output to compare.
    assert!(
        code != 1 && code != 2,
        "bellyflop {args:?} exited {code}: {stderr}"
    );
    stdout
}

fn solve(name: &str, extra: &[&str]) {
    let mut args = vec!["solve", "--json", "--quiet"];
    args.extend_from_slice(extra);
    check_json(name, &run_ok(&args));
}

/// A dispersed state inside the documented envelope (not the paper's).
fn dispersed_scenario(dir: &Path) -> String {
    let paper = include_str!("../../../scenarios/paper.toml");
    let text = paper
        .replace("x_m = 100.0", "x_m = 260.0")
        .replace("z_m = 600.0", "z_m = 720.0")
        .replace(
            "vx_mps = 0.0\nvz_mps = -85.0",
            "vx_mps = -6.0\nvz_mps = -78.0",
        )
        .replace("mass_kg = 120000.0", "mass_kg = 116000.0");
    assert_ne!(text, paper);
    let file = dir.join("dispersed.toml");
    std::fs::write(&file, text).unwrap();
    file.to_str().unwrap().to_string()
}

#[test]
fn solve_scvx_global() {
    solve("solve_scvx_global", &["--method", "scvx"]);
}

#[test]
fn solve_scvx_paper_formulation() {
    solve(
        "solve_scvx_paper",
        &["--method", "scvx", "--formulation", "paper"],
    );
}

#[test]
fn solve_direct_global() {
    solve("solve_direct_global", &["--method", "direct"]);
}

#[test]
fn solve_direct_dispersed() {
    let dir = tmp("dispersed");
    let file = dispersed_scenario(&dir);
    solve(
        "solve_direct_dispersed",
        &["--method", "direct", "--scenario", &file],
    );
}

#[test]
fn solve_direct_hp() {
    solve(
        "solve_direct_hp",
        &["--method", "direct", "--nodes", "40", "--intervals", "5"],
    );
}

#[test]
fn solve_scvx_hp() {
    solve(
        "solve_scvx_hp",
        &["--method", "scvx", "--nodes", "40", "--intervals", "5"],
    );
}

#[test]
fn solve_direct_refined() {
    solve(
        "solve_direct_refined",
        &["--method", "direct", "--mesh-tolerance", "1e-6"],
    );
}

#[test]
fn solve_scvx_refined() {
    solve(
        "solve_scvx_refined",
        &["--method", "scvx", "--mesh-tolerance", "1e-4"],
    );
}

#[test]
fn sweep() {
    check_json("sweep", &run_ok(&["sweep", "--json", "--nodes", "15,20"]));
}

#[test]
fn sim_direct_replans() {
    check_json(
        "sim_direct",
        &run_ok(&["sim", "--json", "--seed", "3", "--run", "2"]),
    );
}

#[test]
fn sim_scvx_replans() {
    let dir = tmp("sim-scvx");
    let config = dir.join("scvx.toml");
    std::fs::write(&config, "[guidance]\nreplan_method = \"scvx\"\n").unwrap();
    check_json(
        "sim_scvx",
        &run_ok(&["sim", "--json", "--config", config.to_str().unwrap()]),
    );
}

#[test]
fn montecarlo_twenty_runs() {
    let dir = tmp("mc");
    let out = dir.join("out");
    let stdout = run_ok(&[
        "montecarlo",
        "--runs",
        "20",
        "--seed",
        "5",
        "--json",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    check_json("montecarlo_summary", &stdout);
    check_csv(
        "montecarlo_runs",
        &std::fs::read_to_string(out.join("runs.csv")).unwrap(),
    );
}
