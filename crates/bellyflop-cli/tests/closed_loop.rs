//! `bellyflop sim` and `bellyflop montecarlo`: outputs, determinism, errors.

mod common;
use common::bellyflop;

use serde_json::Value;

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("bellyflop-cl-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn sim_lands_and_writes_its_files() {
    let dir = tmp("sim");
    let d = dir.to_str().unwrap();
    let (code, stdout, stderr) = bellyflop(&["sim", "--no-dispersions", "--json", "--out", d]);
    assert_eq!(code, 0, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).expect("one JSON object");
    assert_eq!(v["outcome_name"], "landed");
    let td = &v["outcome"];
    assert!(td["x_error_m"].as_f64().unwrap().abs() < 1.0, "{td}");
    assert!(td["speed_mps"].as_f64().unwrap() < 1.5, "{td}");
    assert!(!v["replans"].as_array().unwrap().is_empty());
    for f in [
        "trajectory.csv",
        "solution.json",
        "path.png",
        "histories.svg",
        "flight.csv",
        "replans.csv",
        "flight.json",
        "timeline.png",
        "timeline.svg",
        "viewer.html",
    ] {
        assert!(dir.join(f).is_file(), "{f} missing");
    }
    // The flight ends at the pad (last row of flight.csv at z = 0).
    let csv = std::fs::read_to_string(dir.join("flight.csv")).unwrap();
    let last: Vec<f64> = csv
        .lines()
        .last()
        .unwrap()
        .split(',')
        .map(|x| x.parse().unwrap())
        .collect();
    assert!(last[2].abs() < 1e-6, "z at the end {}", last[2]);
}

#[test]
fn montecarlo_summary_has_the_documented_fields_and_is_thread_independent() {
    let (d1, d2) = (tmp("mc1"), tmp("mc2"));
    let run = |threads: &str, dir: &std::path::Path| {
        let (code, stdout, stderr) = bellyflop(&[
            "montecarlo",
            "--runs",
            "4",
            "--seed",
            "11",
            "--threads",
            threads,
            "--json",
            "--out",
            dir.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{stderr}");
        serde_json::from_str::<Value>(&stdout).expect("one JSON object")
    };
    let v = run("1", &d1);
    assert_eq!(v["runs"], 4);
    // Every run has one outcome, and each outcome is counted.
    let outcomes = v["outcomes"].as_object().unwrap();
    assert_eq!(outcomes.len(), 6, "{outcomes:?}");
    let total: u64 = outcomes.values().map(|n| n.as_u64().unwrap()).sum();
    assert_eq!(total, 4, "{outcomes:?}");
    assert!(v["worst"]["outcome"].is_string());
    assert_eq!(v["threads"], 1);
    for key in ["failures", "missed_replans"] {
        assert!(v[key].is_u64(), "{key}");
    }
    for key in [
        "touchdown_position_m",
        "touchdown_speed_mps",
        "touchdown_pitch_deg",
        "fuel_kg",
        "replan_time_ms",
    ] {
        let p = &v[key];
        let (p50, p95, p99, max) = (
            p["p50"].as_f64().unwrap(),
            p["p95"].as_f64().unwrap(),
            p["p99"].as_f64().unwrap(),
            p["max"].as_f64().unwrap(),
        );
        assert!(p50 <= p95 && p95 <= p99 && p99 <= max, "{key}: {p}");
    }
    let _ = run("2", &d2);
    // Everything but the timing columns is identical with 1 and 2 threads.
    let strip = |dir: &std::path::Path| -> Vec<String> {
        std::fs::read_to_string(dir.join("runs.csv"))
            .unwrap()
            .lines()
            .map(|l| l.split(',').take(15).collect::<Vec<_>>().join(","))
            .collect()
    };
    let a = strip(&d1);
    assert_eq!(a.len(), 5, "header + 4 runs");
    assert_eq!(a, strip(&d2));
    for f in [
        "summary.json",
        "touchdown.png",
        "touchdown.svg",
        "replan_times.png",
        "viewer.html",
    ] {
        assert!(d1.join(f).is_file(), "{f} missing");
    }
}

#[test]
fn bad_campaign_input_is_rejected_with_exit_2() {
    let (code, _, stderr) = bellyflop(&["montecarlo", "--runs", "0"]);
    assert_eq!(code, 2);
    assert!(stderr.contains("--runs"), "{stderr}");
    let dir = tmp("cfg");
    std::fs::create_dir_all(&dir).unwrap();
    let cfg = dir.join("c.toml");
    std::fs::write(&cfg, "[dispersions]\nthrust_3sigma_frac = -0.1\n").unwrap();
    let (code, _, stderr) = bellyflop(&["sim", "--config", cfg.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(
        stderr.contains("dispersions.thrust_3sigma_frac"),
        "{stderr}"
    );
}

/// A touchdown at 84 m/s is a `crash` and exits 8 (issue 18: a 116 m/s
/// impact was a `touchdown` with exit 0). From 60 m up at 85 m/s no plan
/// solves, and the vehicle falls.
#[test]
fn crash_is_reported_and_exits_8() {
    let dir = tmp("crash");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("low.toml");
    let text = bellyflop::input::scenario::PAPER_TOML
        .replacen("z_m = 600.0", "z_m = 60.0", 1)
        .replacen("nodes = 20 ", "nodes = 6 ", 1)
        .replacen("max_iterations = 100", "max_iterations = 5", 1);
    std::fs::write(&path, text).unwrap();
    let p = path.to_str().unwrap();
    let (code, stdout, stderr) = bellyflop(&["sim", "--scenario", p, "--no-dispersions", "--json"]);
    assert_eq!(code, 8, "{stderr}");
    let v: Value = serde_json::from_str(&stdout).expect("one JSON object");
    assert_eq!(v["outcome_name"], "crash");
    assert!(v["outcome"]["speed_mps"].as_f64().unwrap() > 50.0, "{v}");
    let (code, stdout, _) = bellyflop(&["sim", "--scenario", p, "--no-dispersions"]);
    assert_eq!(code, 8);
    assert!(stdout.contains("outcome       crash"), "{stdout}");
}
