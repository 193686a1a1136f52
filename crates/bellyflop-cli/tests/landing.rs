//! `bellyflop solve` and `bellyflop sweep` report the landing precision.

mod common;
use common::bellyflop;

fn assert_landing_error(v: &serde_json::Value, what: &str) {
    let e = &v["landing_error"];
    for key in ["position_m", "velocity_mps", "pitch_rad", "rate_radps"] {
        let x = e[key]
            .as_f64()
            .unwrap_or_else(|| panic!("{what}: landing_error.{key} missing in {e}"));
        assert!(x.is_finite() && x >= 0.0, "{what}: {key} = {x}");
    }
    let p = &v["propagation"];
    let m = p["terminal_mass_kg"].as_f64().expect("terminal_mass_kg");
    let mf = v["final_mass_kg"].as_f64().unwrap();
    assert!((m - mf).abs() < 5.0, "{what}: terminal mass {m} vs {mf}");
    assert!(p["error"].is_null());
}

/// N = 12 and 15: the paper's case lands within the default tolerances
/// there (at N = 10 it misses by 2.07 m/s: `inaccurate`, exit 9).
#[test]
fn solve_json_has_the_landing_error() {
    let (code, stdout, _) = bellyflop(&["solve", "--json", "--nodes", "12"]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("one JSON object");
    assert_landing_error(&v, "solve");
    assert_eq!(v["propagation"]["interpolation"], "pchip");

    let (_, stdout, _) = bellyflop(&[
        "solve",
        "--json",
        "--nodes",
        "12",
        "--interpolation",
        "linear",
    ]);
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_landing_error(&v, "solve --interpolation linear");
    assert_eq!(v["propagation"]["interpolation"], "linear");
}

#[test]
fn solve_summary_prints_the_landing_error() {
    let (code, stdout, _) = bellyflop(&["solve", "--quiet", "--nodes", "12"]);
    assert_eq!(code, 0);
    let line = stdout
        .lines()
        .find(|l| l.starts_with("landing error"))
        .unwrap_or_else(|| panic!("no landing error line in\n{stdout}"));
    for unit in [" m,", " m/s,", " deg,", " deg/s"] {
        assert!(line.contains(unit), "{line}");
    }
    assert!(stdout.contains("terminal mass"), "{stdout}");
}

#[test]
fn sweep_tabulates_each_n() {
    let (code, stdout, _) = bellyflop(&["sweep", "--nodes", "12,15"]);
    assert_eq!(code, 0, "{stdout}");
    let rows: Vec<&str> = stdout
        .lines()
        .filter(|l| {
            let first = l.split_whitespace().next().unwrap_or("");
            first == "12" || first == "15"
        })
        .collect();
    assert_eq!(rows.len(), 2, "{stdout}");
    for row in rows {
        assert!(row.contains("solved"), "{row}");
        // N, status, t_f, m_f, position, velocity, pitch, rate, iterations, ms
        assert_eq!(row.split_whitespace().count(), 10, "{row}");
    }

    let (code, stdout, _) = bellyflop(&["sweep", "--nodes", "12,15", "--json"]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("one JSON object");
    let runs = v["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 2);
    for (run, n) in runs.iter().zip([12, 15]) {
        assert_eq!(run["nodes"], n);
        assert_eq!(run["status"], "solved");
        for key in ["tf_s", "final_mass_kg", "solve_time_ms"] {
            assert!(run[key].as_f64().unwrap() > 0.0, "{key}");
        }
        assert!(run["iterations"].as_u64().unwrap() >= 1);
        assert_landing_error(run, &format!("sweep N = {n}"));
    }
}

#[test]
fn sweep_rejects_a_bad_n_before_solving() {
    let (code, stdout, stderr) = bellyflop(&["sweep", "--nodes", "10,3"]);
    assert_eq!(code, 2);
    assert!(stdout.is_empty(), "{stdout}");
    assert!(stderr.contains("discretization.nodes"), "{stderr}");
}
