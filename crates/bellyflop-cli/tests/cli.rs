//! The `bellyflop` binary: JSON output, exit codes and error messages.

mod common;
use common::bellyflop;

fn write_scenario(name: &str, edit: impl Fn(&str) -> String) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("bellyflop-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, edit(bellyflop::input::scenario::PAPER_TOML)).unwrap();
    path
}

/// At N = 20, where the paper's case lands within the tolerances (at N = 10
/// its re-integrated controls miss by more: `inaccurate`).
#[test]
fn json_has_the_documented_fields() {
    let (code, stdout, _) = bellyflop(&["solve", "--json", "--nodes", "20"]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("one JSON object");
    assert_eq!(v["status"], "solved");
    assert_eq!(v["nodes"], 20);
    for key in ["tf_s", "final_mass_kg", "fuel_kg", "solve_time_ms"] {
        assert!(v[key].as_f64().unwrap() > 0.0, "{key}");
    }
    assert!(v["iterations"].as_u64().unwrap() >= 1);
    for key in [
        "t_s",
        "x_m",
        "z_m",
        "vx_mps",
        "vz_mps",
        "theta_rad",
        "pitch_rate_radps",
        "mass_kg",
        "delta_rad",
        "thrust_n",
    ] {
        assert_eq!(v[key].as_array().unwrap().len(), 21, "{key}");
    }
    let fuel = v["fuel_kg"].as_f64().unwrap();
    let m = v["mass_kg"].as_array().unwrap();
    let burnt = m[0].as_f64().unwrap() - m[20].as_f64().unwrap();
    assert!((fuel - burnt).abs() < 1e-6);
    // Polished: the flown controls are published, their pieces cover
    // [0, t_f], and no mesh error applies (they are integrated).
    let pieces = v["controls_flown"]["pieces"]
        .as_array()
        .expect("controls_flown.pieces");
    assert_eq!(pieces[0]["t_start_s"].as_f64(), Some(0.0));
    assert_eq!(pieces.last().unwrap()["t_end_s"], v["tf_s"]);
    assert!(v["mesh"]["error"]
        .as_str()
        .unwrap()
        .contains("not applicable"));
    let (_, raw, _) = bellyflop(&["solve", "--json", "--fast", "--nodes", "20"]);
    let v: serde_json::Value = serde_json::from_str(&raw).expect("one JSON object");
    assert!(v.get("controls_flown").is_none());
    // The raw answer's mesh error: one interval on the global mesh, its span [0, t_f].
    // It integrates the thrust as flown (bang-bang across the switch at
    // 6 s, control_profile), against which the single degree-20 state
    // polynomial is some 10 % off in Vx (9.9e-2 measured; the same controls
    // re-integrated miss the pad by 3.7 m): an estimate of that order, not
    // the 2.3e-3 of the ringing, unflyable thrust polynomial.
    let intervals = v["mesh"]["intervals"].as_array().expect("mesh.intervals");
    assert_eq!(intervals.len(), 1);
    let e = intervals[0]["relative_error"].as_f64().unwrap();
    assert!(e > 1e-2 && e < 1.0, "{e}");
    assert_eq!(v["mesh"]["max_relative_error"].as_f64().unwrap(), e);
    assert_eq!(intervals[0]["points"], 20);
    assert_eq!(intervals[0]["t_start_s"].as_f64().unwrap(), 0.0);
    assert_eq!(intervals[0]["t_end_s"], v["tf_s"]);
}

/// On an hp mesh, `mesh` has one entry per interval, contiguous in time.
#[test]
fn json_mesh_has_every_interval() {
    // The mesh error is the collocation's: the raw answer (a polished one
    // is integrated, not collocated, and has none).
    let (code, stdout, _) = bellyflop(&[
        "solve",
        "--json",
        "--fast",
        "--nodes",
        "20",
        "--intervals",
        "4",
    ]);
    assert!(code == 0 || code == 9, "solved or inaccurate: {code}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let intervals = v["mesh"]["intervals"].as_array().expect("mesh.intervals");
    assert_eq!(intervals.len(), 4);
    for (k, iv) in intervals.iter().enumerate() {
        assert_eq!(iv["interval"], k);
        assert_eq!(iv["points"], 5);
        assert!(iv["relative_error"].as_f64().unwrap() >= 0.0);
        assert!(iv["worst_state"].is_string());
        if k > 0 {
            assert_eq!(iv["t_start_s"], intervals[k - 1]["t_end_s"]);
        }
    }
    // The mesh solved on, beside the error estimate's `mesh`.
    let layout = &v["mesh_layout"];
    assert_eq!(layout["points"], serde_json::json!([5, 5, 5, 5]));
    assert_eq!(
        layout["breaks_tau"],
        serde_json::json!([-1.0, -0.5, 0.0, 0.5, 1.0])
    );
}

/// `--mesh-tolerance`: the JSON records every pass (its mesh, its error
/// per interval), the answer is the last pass's mesh, its landing error
/// re-integrates the collocation's polynomials, and stderr has one line per
/// pass.
#[test]
fn json_refinement_records_every_pass() {
    let (code, stdout, _) = bellyflop(&["solve", "--json", "--mesh-tolerance", "1e-6"]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let r = &v["refinement"];
    assert_eq!(r["tolerance"].as_f64(), Some(1e-6));
    assert!(r["stop"].is_string());
    let passes = r["passes"].as_array().expect("refinement.passes");
    assert!(passes.len() >= 2, "{}", passes.len());
    for (k, p) in passes.iter().enumerate() {
        assert_eq!(p["pass"], k + 1);
        let points = p["mesh"]["points"].as_array().unwrap();
        let total: u64 = points.iter().map(|x| x.as_u64().unwrap()).sum();
        assert_eq!(p["nodes"].as_u64(), Some(total));
        assert_eq!(
            p["mesh"]["breaks_tau"].as_array().unwrap().len(),
            points.len() + 1
        );
        let intervals = p["intervals"].as_array().unwrap();
        assert_eq!(intervals.len(), points.len());
        let worst = intervals
            .iter()
            .map(|i| i["relative_error"].as_f64().unwrap())
            .fold(0.0, f64::max);
        assert_eq!(p["max_relative_error"].as_f64(), Some(worst));
        assert!(p["events_s"].is_array());
    }
    // The answer is on the last pass's mesh, N = Σ n_k of it.
    let last = passes.last().unwrap();
    assert_eq!(v["mesh_layout"], last["mesh"]);
    assert_eq!(v["nodes"], last["nodes"]);
    // Polished by default: the check integrates the flown controls.
    assert_eq!(v["propagation"]["controls"], "flown");
    let landing = v["landing_error"]["position_m"].as_f64().unwrap();
    assert!(landing < 0.1, "{landing}");
    let (_, _, stderr) = bellyflop(&["solve", "--mesh-tolerance", "1e-6"]);
    assert_eq!(
        stderr.lines().filter(|l| l.starts_with("pass ")).count(),
        passes.len(),
        "{stderr}"
    );
}

/// `--repeat R` solves R times in one process: the answer of one run, the
/// median time between the minimum and the maximum; R = 0 is bad input.
#[test]
fn repeat_reports_the_median_of_identical_runs() {
    let (code, once, _) = bellyflop(&["solve", "--json", "--nodes", "20"]);
    assert_eq!(code, 0);
    let (code, rep, _) = bellyflop(&["solve", "--json", "--nodes", "20", "--repeat", "3"]);
    assert_eq!(code, 0);
    let once: serde_json::Value = serde_json::from_str(&once).unwrap();
    let rep: serde_json::Value = serde_json::from_str(&rep).unwrap();
    assert_eq!(rep["repeat"], 3);
    assert!(once.get("repeat").is_none());
    assert_eq!(rep["final_mass_kg"], once["final_mass_kg"]);
    assert_eq!(rep["iterations"], once["iterations"]);
    let t = |k: &str| rep[k].as_f64().unwrap();
    assert!(t("solve_time_min_ms") <= t("solve_time_ms"));
    assert!(t("solve_time_ms") <= t("solve_time_max_ms"));
    let (code, _, stderr) = bellyflop(&["solve", "--repeat", "0"]);
    assert_eq!(code, 2);
    assert!(
        stderr.contains("--repeat") && stderr.contains("1..=10000"),
        "{stderr}"
    );
}

#[test]
fn toml_error_names_the_line_and_exits_2() {
    let path = write_scenario("broken.toml", |t| {
        t.replace("isp_s = 330.0", "isp_s = = 330.0")
    });
    let (code, stdout, stderr) = bellyflop(&["solve", "--scenario", path.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(stdout.is_empty());
    let line = bellyflop::input::scenario::PAPER_TOML
        .lines()
        .position(|l| l.starts_with("isp_s"))
        .unwrap()
        + 1;
    assert!(stderr.contains(&format!("line {line}")), "{stderr}");
}

#[test]
fn out_of_range_names_field_value_and_range() {
    let (code, _, stderr) = bellyflop(&["solve", "--nodes", "3"]);
    assert_eq!(code, 2);
    assert!(stderr.contains("discretization.nodes"), "{stderr}");
    assert!(stderr.contains("4 to 200"), "{stderr}");

    let path = write_scenario("negative.toml", |t| {
        t.replace("mass_kg = 120000.0", "mass_kg = -5.0")
    });
    let (code, _, stderr) = bellyflop(&["solve", "--scenario", path.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(
        stderr.contains("initial.mass_kg") && stderr.contains("-5"),
        "{stderr}"
    );
}

#[test]
fn missing_file_is_bad_input() {
    let (code, _, stderr) = bellyflop(&["solve", "--scenario", "/nonexistent/none.toml"]);
    assert_eq!(code, 2);
    assert!(stderr.contains("/nonexistent/none.toml"), "{stderr}");
}

#[test]
fn infeasible_case_exits_3_with_reason() {
    let path = write_scenario("low.toml", |t| t.replace("z_m = 600.0", "z_m = 100.0"));
    for method in ["scvx", "direct"] {
        let (code, stdout, _) = bellyflop(&[
            "solve",
            "--json",
            "--method",
            method,
            "--scenario",
            path.to_str().unwrap(),
        ]);
        assert_eq!(code, 3, "{method}");
        let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        assert_eq!(v["status"], "infeasible", "{method}");
        assert!(
            v["message"].as_str().unwrap().contains("no trajectory"),
            "{method}: {}",
            v["message"]
        );
    }
}

/// A solved answer that re-integrates beyond the landing tolerance is
/// `inaccurate`, exit 9, for both methods; the message names the error and
/// what to do.
#[test]
fn inaccurate_landing_exits_9_with_the_error() {
    let path = write_scenario("tight.toml", |t| {
        t.replace(
            "max_iterations = 100",
            "max_iterations = 100\nlanding_position_tolerance_m = 0.01",
        )
    });
    for method in ["scvx", "direct"] {
        let (code, stdout, _) = bellyflop(&[
            "solve",
            "--json",
            "--fast",
            "--method",
            method,
            "--scenario",
            path.to_str().unwrap(),
        ]);
        assert_eq!(code, 9, "{method}");
        let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        assert_eq!(v["status"], "inaccurate", "{method}");
        let message = v["message"].as_str().unwrap();
        assert!(
            message.contains("re-integrated") && message.contains("--nodes"),
            "{method}: {message}"
        );
        // The JSON's own landing error is the one the message names.
        let miss = v["landing_error"]["position_m"].as_f64().unwrap();
        assert!(miss > 0.01, "{method}: {miss}");
        assert!(
            message.contains(&format!("{miss:.3} m")),
            "{method}: {message}"
        );
    }
}

/// A local infeasibility without a certificate is not `infeasible`: the
/// paper's case on N = 4 points exits 4, saying that none was found.
#[test]
fn uncertified_infeasibility_exits_4() {
    let (code, stdout, _) = bellyflop(&["solve", "--json", "--method", "scvx", "--nodes", "4"]);
    assert_eq!(code, 4);
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["status"], "not_converged");
    let message = v["message"].as_str().unwrap();
    assert!(
        message.starts_with("no trajectory was found, but infeasibility is not proven"),
        "{message}"
    );
}

#[test]
fn iteration_limit_exits_4() {
    // SCvx's limit, and the direct method's own.
    let path = write_scenario("short.toml", |t| {
        t.replace("max_iterations = 100", "max_iterations = 2")
            + "\n[solver.direct]\nmax_iterations = 3\n"
    });
    for method in ["scvx", "direct"] {
        let (code, stdout, _) = bellyflop(&[
            "solve",
            "--json",
            "--method",
            method,
            "--scenario",
            path.to_str().unwrap(),
        ]);
        assert_eq!(code, 4, "{method}");
        let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        assert_eq!(v["status"], "not_converged", "{method}");
        assert_eq!(v["method"], method);
        assert!(
            v["message"].as_str().unwrap().contains("iterate"),
            "{method}"
        );
    }
}

/// Issue 18's messages: each names the problem, and each is bad input (2).
#[test]
fn bad_input_messages_name_the_problem() {
    // A file that is not UTF-8: the file, the byte, the line.
    let path = write_scenario("latin1.toml", |t| t.to_string());
    let mut bytes = std::fs::read(&path).unwrap();
    let at = bytes.iter().position(|&b| b == b'\n').unwrap() + 1;
    bytes.splice(at..at, b"# caf\xe9\n".iter().copied());
    std::fs::write(&path, &bytes).unwrap();
    let (code, _, stderr) = bellyflop(&["solve", "--scenario", path.to_str().unwrap()]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains(path.to_str().unwrap()), "{stderr}");
    assert!(
        stderr.contains(&format!("at byte {}", at + 5)) && stderr.contains("(line 2, column 6)"),
        "{stderr}"
    );

    // An empty name.
    let path = write_scenario("noname.toml", |t| {
        t.replace("name = \"paper\"", "name = \"\"")
    });
    let (code, _, stderr) = bellyflop(&["solve", "--scenario", path.to_str().unwrap()]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("name must be non-empty"), "{stderr}");

    // A bad guidance configuration is called one.
    let path = write_scenario("config.toml", |_| "[guidance]\nreplan = 3\n".into());
    let (code, _, stderr) = bellyflop(&["sim", "--config", path.to_str().unwrap()]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("guidance config TOML, line 2"), "{stderr}");
    assert!(!stderr.contains("scenario"), "{stderr}");

    // `init` into a directory that does not exist.
    let dir = std::env::temp_dir().join(format!("bellyflop-no-such-dir-{}", std::process::id()));
    let file = dir.join("s.toml");
    let (code, _, stderr) = bellyflop(&["init", file.to_str().unwrap()]);
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("does not exist") && stderr.contains(dir.to_str().unwrap()),
        "{stderr}"
    );
    assert!(!file.exists());
}

/// A 6-DoF scenario (as `init --model 6dof` writes it, valid) is refused by
/// every command that would fly it or solve it as planar: exit 2, the typed
/// error naming the command and the library's 6-DoF solve, nothing
/// written, and no solve started. `solve` solves it (the next test).
#[test]
fn a_six_dof_scenario_is_refused_not_solved_as_planar() {
    let (dir, file) = six_dof_file("6dof", str::to_string);
    let text = std::fs::read_to_string(&file).unwrap();
    let case =
        bellyflop::Case::from_toml_str(&text).expect("init --model 6dof writes a valid file");
    assert_eq!(
        case.scenario.model,
        bellyflop::input::scenario::ModelKind::SixDof
    );
    let path = file.to_str().unwrap();
    let out = dir.join("out");
    let out_str = out.to_str().unwrap();
    for args in [
        vec!["sweep", "--scenario", path, "--nodes", "10,20"],
        vec!["sim", "--scenario", path],
        vec![
            "montecarlo",
            "--scenario",
            path,
            "--runs",
            "2",
            "--out",
            out_str,
        ],
    ] {
        let (code, stdout, stderr) = bellyflop(&args);
        assert_eq!(code, 2, "{args:?}: {stderr}");
        assert!(stdout.is_empty(), "{args:?}: {stdout}");
        let command = format!("`bellyflop {}`", args[0]);
        assert!(
            stderr.contains("model = \"6dof\" is not yet available in")
                && stderr.contains(&command)
                && stderr.contains("bellyflop::pipeline::six_dof::solve"),
            "{args:?}: {stderr}"
        );
        assert!(!stderr.contains("solving"), "{args:?}: {stderr}");
        assert!(!out.exists(), "{args:?} wrote {}", out.display());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `solve` on a 6-DoF scenario runs the 6-DoF pipeline: one JSON object
/// whose tables take their names from the model, a status that is a claim
/// (its exit code), and with `--out` the solution and the node table; the
/// SCvx method, planar only, is refused.
#[test]
fn solve_solves_a_six_dof_scenario() {
    let (dir, file) = six_dof_file("6dof-solve", str::to_string);
    let path = file.to_str().unwrap();
    let out = dir.join("out");
    let (code, stdout, stderr) = bellyflop(&[
        "solve",
        "--json",
        "--scenario",
        path,
        "--out",
        out.to_str().unwrap(),
    ]);
    let v: serde_json::Value = serde_json::from_str(&stdout).expect(&stderr);
    assert_eq!(v["model"], "6dof");
    let status = v["status"].as_str().unwrap();
    let want_code = match status {
        "solved" => 0,
        "inaccurate" => 9,
        other => panic!("{other}: {stderr}"),
    };
    assert_eq!(code, want_code, "{stderr}");
    assert_eq!(v["states"]["names"][1], "y_m");
    assert_eq!(v["controls"]["names"][0], "thrust_n");
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    assert!(csv.starts_with("t_s,x_m,y_m,z_m"), "{}", &csv[..40]);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("solution.json")).unwrap()).unwrap();
    assert_eq!(json["status"], v["status"]);
    // The 6-DoF plots, named as the planar ones; no convergence plot.
    for stem in ["path", "histories"] {
        let svg = std::fs::read_to_string(out.join(format!("{stem}.svg"))).unwrap();
        assert!(
            svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"),
            "{stem}"
        );
        assert!(svg.contains("6-DoF"), "{stem}: no title");
        let png = std::fs::read(out.join(format!("{stem}.png"))).unwrap();
        assert!(
            png.starts_with(b"\x89PNG\r\n\x1a\n") && png.len() > 10_000,
            "{stem}"
        );
    }
    let path_svg = std::fs::read_to_string(out.join("path.svg")).unwrap();
    for view in ["side view x–z", "side view y–z", "top view x–y"] {
        assert!(path_svg.contains(view), "{view}");
    }
    let histories_svg = std::fs::read_to_string(out.join("histories.svg")).unwrap();
    for panel in [
        "thrust",
        "gimbal angles",
        "tilt",
        "body rates",
        "mass",
        "speed",
    ] {
        assert!(histories_svg.contains(panel), "{panel}");
    }
    assert!(!out.join("convergence.svg").exists());
    let (code, _, stderr) = bellyflop(&["solve", "--scenario", path, "--method", "scvx"]);
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("--method scvx does not apply to a 6-DoF scenario"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A 6-DoF scenario as `init --model 6dof` writes it, in a directory of
/// its own named `name`, with `edit` applied to its text: the directory
/// and the file.
fn six_dof_file(
    name: &str,
    edit: impl Fn(&str) -> String,
) -> (std::path::PathBuf, std::path::PathBuf) {
    let dir = std::env::temp_dir().join(format!("bellyflop-cli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("six.toml");
    let (code, _, stderr) =
        bellyflop(&["init", "--force", "--model", "6dof", file.to_str().unwrap()]);
    assert_eq!(code, 0, "{stderr}");
    let text = std::fs::read_to_string(&file).unwrap();
    let edited = edit(&text);
    std::fs::write(&file, edited).unwrap();
    (dir, file)
}

/// `text` with the one line `from` replaced by `to`.
fn replace_line(text: &str, from: &str, to: &str) -> String {
    assert_eq!(text.lines().filter(|l| *l == from).count(), 1, "{from}");
    text.lines()
        .map(|l| if l == from { to } else { l })
        .map(|l| format!("{l}\n"))
        .collect()
}

/// `solve` on a 6-DoF scenario refuses each flag that its solve would
/// ignore, as the Python binding refuses the same arguments: exit 2, the
/// error naming the flag, the value given and why, before any solve and
/// before `--out` is created.
#[test]
fn six_dof_solve_refuses_the_flags_it_would_ignore() {
    let (dir, file) = six_dof_file("6dof-flags", str::to_string);
    let path = file.to_str().unwrap();
    let out = dir.join("out");
    for (flag, value, why) in [
        (
            "--method",
            "scvx",
            "only the direct method solves the 6-DoF model",
        ),
        ("--formulation", "paper", "the planar model's SCvx's"),
        // Even the default: the formulations are not the 6-DoF model's.
        ("--formulation", "exact", "the planar model's SCvx's"),
        (
            "--interpolation",
            "linear",
            "not interpolated through the nodes",
        ),
        (
            "--interpolation",
            "pchip",
            "not interpolated through the nodes",
        ),
        ("--mesh-tolerance", "1e-6", "does not refine its mesh"),
    ] {
        let args = [
            "solve",
            "--json",
            "--scenario",
            path,
            "--out",
            out.to_str().unwrap(),
            flag,
            value,
        ];
        let (code, stdout, stderr) = bellyflop(&args);
        assert_eq!(code, 2, "{flag} {value}: {stderr}");
        assert!(stdout.is_empty(), "{flag} {value}: {stdout}");
        let named = format!(
            "error: {flag} {value} does not apply to a 6-DoF scenario (model = \"6dof\"): "
        );
        assert!(
            stderr.starts_with(&named) && stderr.contains(why),
            "{flag} {value}: {stderr}"
        );
        assert!(!out.exists(), "{flag} {value} created {}", out.display());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A 6-DoF scenario's settings that its solve does not read, at a value
/// other than their default, are refused by name (exit 2); a flag that
/// sets them back (`--method direct`, `--mesh-tolerance 0`) is honoured,
/// and so is `--repeat`.
#[test]
fn six_dof_solve_refuses_the_settings_it_would_ignore() {
    let cases = [
        (
            "formulation = \"exact\"",
            "formulation = \"vector\"",
            "solver.formulation = \"vector\"",
        ),
        (
            "tolerance = 0.0",
            "tolerance = 1e-4",
            "solver.refinement.tolerance = 0.0001",
        ),
        (
            "method = \"direct\"",
            "method = \"scvx\"",
            "solver.method = \"scvx\"",
        ),
        (
            "polish_repairs = 3",
            "polish_repairs = 0",
            "solver.polish_repairs = 0",
        ),
        (
            "max_iterations = 100",
            "max_iterations = 50",
            "solver.max_iterations = 50",
        ),
    ];
    for (from, to, named) in cases {
        let (dir, file) = six_dof_file("6dof-settings", |t| replace_line(t, from, to));
        let (code, stdout, stderr) = bellyflop(&["solve", "--scenario", file.to_str().unwrap()]);
        assert_eq!(code, 2, "{to}: {stderr}");
        assert!(stdout.is_empty(), "{to}: {stdout}");
        let want =
            format!("error: {named} does not apply to a 6-DoF scenario (model = \"6dof\"): ");
        assert!(stderr.starts_with(&want), "{to}: {stderr}");
        assert!(
            stderr.contains("(remove it, or set its default "),
            "{stderr}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
    // The flags override the file: the direct method, no refinement.
    let (dir, file) = six_dof_file("6dof-settings-overridden", |t| {
        let t = replace_line(t, "method = \"direct\"", "method = \"scvx\"");
        replace_line(&t, "tolerance = 0.0", "tolerance = 1e-4")
    });
    let (code, stdout, stderr) = bellyflop(&[
        "solve",
        "--json",
        "--scenario",
        file.to_str().unwrap(),
        "--method",
        "direct",
        "--mesh-tolerance",
        "0",
        "--nodes",
        "12",
        "--fast",
        "--repeat",
        "2",
    ]);
    let v: serde_json::Value = serde_json::from_str(&stdout).expect(&stderr);
    assert!(code == 0 || code == 9, "exit {code}: {stderr}");
    assert_eq!(v["model"], "6dof");
    assert_eq!(v["nodes"], 12);
    assert!(v["polish_iterations"].is_null(), "--fast: no polish");
    assert_eq!(v["repeat"], 2);
    let t = |k: &str| v[k].as_f64().unwrap();
    assert!(
        t("solve_time_min_ms") <= t("solve_time_ms")
            && t("solve_time_ms") <= t("solve_time_max_ms"),
        "{v}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
