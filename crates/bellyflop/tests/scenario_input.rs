//! Scenario input: parsing, validation and the error messages for bad input.

use bellyflop::input::scenario::PAPER_TOML;
use bellyflop::{Case, Formulation, InputError};

/// PAPER_TOML with `from` (which must occur exactly once) replaced by `to`.
fn paper_with(from: &str, to: &str) -> String {
    assert_eq!(
        PAPER_TOML.matches(from).count(),
        1,
        "`{from}` must occur exactly once in paper.toml"
    );
    PAPER_TOML.replacen(from, to, 1)
}

/// 1-based line number of the first line of `text` that starts with `prefix`.
fn line_of(text: &str, prefix: &str) -> usize {
    text.lines()
        .position(|l| l.trim_start().starts_with(prefix))
        .unwrap_or_else(|| panic!("no line starts with `{prefix}`"))
        + 1
}

/// Parse `text`, expecting an out-of-range error; return (field, value, allowed, display).
fn out_of_range(text: &str) -> (String, f64, String, String) {
    match Case::from_toml_str(text) {
        Err(e @ InputError::OutOfRange { .. }) => {
            let display = e.to_string();
            let InputError::OutOfRange {
                field,
                value,
                allowed,
            } = e
            else {
                unreachable!()
            };
            (field, value, allowed, display)
        }
        other => panic!("expected OutOfRange, got {other:?}"),
    }
}

/// Parse `text`, expecting an inconsistency error; return (field, value, reason, display).
fn inconsistent(text: &str) -> (String, f64, String, String) {
    match Case::from_toml_str(text) {
        Err(e @ InputError::Inconsistent { .. }) => {
            let display = e.to_string();
            let InputError::Inconsistent {
                field,
                value,
                reason,
            } = e
            else {
                unreachable!()
            };
            (field, value, reason, display)
        }
        other => panic!("expected Inconsistent, got {other:?}"),
    }
}

/// Parse `text`, expecting a TOML error; return (line, column, message, display).
fn toml_error(text: &str) -> (usize, usize, String, String) {
    match Case::from_toml_str(text) {
        Err(e @ InputError::Toml { .. }) => {
            let display = e.to_string();
            let InputError::Toml {
                line,
                column,
                message,
                ..
            } = e
            else {
                unreachable!()
            };
            (line, column, message, display)
        }
        other => panic!("expected Toml, got {other:?}"),
    }
}

#[test]
fn paper_scenario_parses_and_validates_with_table_1_values() {
    let s = Case::from_toml_str(PAPER_TOML).expect("paper.toml is valid");
    assert_eq!(s, Case::paper());
    assert!(s.validate().is_ok());
    assert_eq!(s.scenario.name, "paper");

    // Table 1.
    let v = &s.scenario.vehicle;
    assert_eq!(v.dry_mass_kg, 85_000.0);
    assert_eq!(v.length_m, 50.0);
    assert_eq!(v.radius_m, 4.5);
    assert_eq!(v.cg_m, 20.0);
    assert_eq!(v.cp_m, 22.5);
    assert_eq!(v.max_thrust_n, 2.21e6);
    assert_eq!(v.min_thrust_n, 8.8e5);
    assert_eq!(v.isp_s, 330.0);
    assert_eq!(v.max_gimbal_deg, 20.0);
    assert_eq!(v.max_gimbal_rate_degps, 20.0);
    assert_eq!(v.drag_coefficient_kgpm, 195.52);
    assert_eq!(s.scenario.environment.g0_mps2, 9.81);

    // Section 4 boundary conditions.
    let i = &s.scenario.initial;
    assert_eq!(
        (i.x_m, i.z_m, i.vx_mps, i.vz_mps),
        (100.0, 600.0, 0.0, -85.0)
    );
    assert_eq!((i.theta_deg, i.pitch_rate_degps), (90.0, 0.0));
    assert_eq!((i.mass_kg, i.gimbal_deg), (120_000.0, 0.0));
    let t = &s.scenario.terminal;
    assert_eq!(
        (
            t.x_m,
            t.z_m,
            t.vx_mps,
            t.vz_mps,
            t.theta_deg,
            t.pitch_rate_degps
        ),
        (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    );

    assert_eq!(s.scenario.discretization.nodes, 20);
    assert_eq!(s.solver.formulation, Formulation::Exact);
    assert_eq!(s.solver.max_iterations, 100);
}

#[test]
fn default_solver_settings_validate() {
    // The [solver] table is optional; its defaults must pass validation.
    let start = PAPER_TOML.find("[solver]").unwrap();
    let without_solver = &PAPER_TOML[..start];
    let s = Case::from_toml_str(without_solver).expect("defaults are valid");
    assert_eq!(
        s.solver,
        bellyflop::input::settings::SolverSettings::default()
    );
}

#[test]
fn toml_syntax_error_reports_its_line() {
    // A hand-built text: the unclosed table header is on line 4.
    let text = "name = \"x\"\n\n# comment\n[vehicle\ndry_mass_kg = 1.0\n";
    let (line, _, _, display) = toml_error(text);
    assert_eq!(line, 4);
    assert!(display.contains("line 4"), "{display}");

    // A broken value inside the paper scenario.
    let text = paper_with("isp_s = 330.0", "isp_s = = 330.0");
    let expected = line_of(&text, "isp_s");
    let (line, column, _, display) = toml_error(&text);
    assert_eq!(line, expected);
    assert!(column >= 1);
    assert!(display.contains(&format!("line {expected}")), "{display}");
}

#[test]
fn unknown_field_is_rejected_by_name() {
    let text = paper_with("isp_s = 330.0", "isp_s = 330.0\nturbo_boost = 1.0");
    let expected = line_of(&text, "turbo_boost");
    let (line, _, message, display) = toml_error(&text);
    assert!(message.contains("turbo_boost"), "{message}");
    assert!(display.contains("turbo_boost"), "{display}");
    assert_eq!(line, expected);

    // An unknown top-level table too.
    let text = format!("{PAPER_TOML}\n[extras]\nx = 1\n");
    let (_, _, message, _) = toml_error(&text);
    assert!(message.contains("extras"), "{message}");
}

#[test]
fn wrong_type_is_rejected_with_its_line() {
    let text = paper_with("nodes = 20 ", "nodes = \"twenty\" ");
    let expected = line_of(&text, "nodes");
    let (line, _, _, display) = toml_error(&text);
    assert_eq!(line, expected);
    assert!(display.contains(&format!("line {expected}")), "{display}");

    let text = paper_with("mass_kg = 120000.0", "mass_kg = true");
    let expected = line_of(&text, "mass_kg");
    let (line, _, _, _) = toml_error(&text);
    assert_eq!(line, expected);

    let text = paper_with("formulation = \"exact\"", "formulation = \"fancy\"");
    let expected = line_of(&text, "formulation");
    let (line, _, message, _) = toml_error(&text);
    assert_eq!(line, expected);
    assert!(message.contains("fancy"), "{message}");
}

#[test]
fn negative_mass_is_out_of_range() {
    let (field, value, allowed, display) = out_of_range(&paper_with(
        "dry_mass_kg = 85000.0",
        "dry_mass_kg = -85000.0",
    ));
    assert_eq!(field, "vehicle.dry_mass_kg");
    assert_eq!(value, -85_000.0);
    assert_eq!(allowed, "[1, 1e7] kg");
    assert_eq!(
        display,
        "vehicle.dry_mass_kg = -85000 is out of range: allowed [1, 1e7] kg"
    );

    let (field, value, _, display) =
        out_of_range(&paper_with("mass_kg = 120000.0", "mass_kg = -1.0"));
    assert_eq!(field, "initial.mass_kg");
    assert_eq!(value, -1.0);
    assert!(display.contains("initial.mass_kg = -1"), "{display}");
}

#[test]
fn min_thrust_above_max_thrust_is_inconsistent() {
    let (field, value, reason, display) = inconsistent(&paper_with(
        "min_thrust_n = 880000.0",
        "min_thrust_n = 3000000.0",
    ));
    assert_eq!(field, "vehicle.min_thrust_n");
    assert_eq!(value, 3.0e6);
    assert!(reason.contains("vehicle.max_thrust_n"), "{reason}");
    assert!(
        display.contains("vehicle.min_thrust_n = 3000000"),
        "{display}"
    );
    assert!(display.contains("2210000"), "{display}");
}

#[test]
fn node_count_outside_4_to_100_is_out_of_range() {
    // 4 to 200 in all; the global mesh (the paper's file has one interval)
    // at most 100, a check against discretization.intervals.
    for (n, intervals, ok) in [
        (0, 1, false),
        (3, 1, false),
        (4, 1, true),
        (100, 1, true),
        (200, 2, true),
        (201, 3, false),
    ] {
        let text = paper_with(
            "nodes = 20 ",
            &format!("nodes = {n}\nintervals = {intervals} "),
        );
        if ok {
            assert!(Case::from_toml_str(&text).is_ok(), "N = {n}");
            continue;
        }
        let (field, value, allowed, display) = out_of_range(&text);
        assert_eq!(field, "discretization.nodes");
        assert_eq!(value, n as f64);
        assert_eq!(allowed, "4 to 200");
        assert_eq!(
            display,
            format!("discretization.nodes = {n} is out of range: allowed 4 to 200")
        );
    }
    let text = paper_with("nodes = 20 ", "nodes = 101 ");
    match Case::from_toml_str(&text) {
        Err(bellyflop::InputError::Inconsistent {
            field,
            value,
            reason,
        }) => {
            assert_eq!((field.as_str(), value), ("discretization.nodes", 101.0));
            assert!(
                reason.contains("at most 100 on the global mesh"),
                "{reason}"
            );
        }
        other => panic!("N = 101 on the global mesh: {other:?}"),
    }
    // A negative count is not a usize: a TOML error at the right line.
    let text = paper_with("nodes = 20 ", "nodes = -5 ");
    let (line, _, _, _) = toml_error(&text);
    assert_eq!(line, line_of(&text, "nodes"));
}

#[test]
fn nan_is_out_of_range() {
    let (field, value, allowed, display) =
        out_of_range(&paper_with("isp_s = 330.0", "isp_s = nan"));
    assert_eq!(field, "vehicle.isp_s");
    assert!(value.is_nan());
    assert_eq!(allowed, "[1, 1000] s");
    assert_eq!(
        display,
        "vehicle.isp_s = NaN is out of range: allowed [1, 1000] s"
    );
}

#[test]
fn infinity_is_out_of_range() {
    let (field, value, allowed, display) = out_of_range(&paper_with(
        "max_thrust_n = 2210000.0",
        "max_thrust_n = inf",
    ));
    assert_eq!(field, "vehicle.max_thrust_n");
    assert_eq!(value, f64::INFINITY);
    assert_eq!(allowed, "[1, 1e9] N");
    assert!(display.contains("vehicle.max_thrust_n = inf"), "{display}");
    assert!(display.contains("[1, 1e9] N"), "{display}");

    // -inf in a field whose range is symmetric.
    let (field, value, allowed, _) = out_of_range(&paper_with("vz_mps = -85.0", "vz_mps = -inf"));
    assert_eq!(field, "initial.vz_mps");
    assert_eq!(value, f64::NEG_INFINITY);
    assert_eq!(allowed, "[-1e4, 1e4] m/s");
}

#[test]
fn dry_mass_above_initial_mass_is_inconsistent() {
    let (field, value, reason, display) = inconsistent(&paper_with(
        "dry_mass_kg = 85000.0",
        "dry_mass_kg = 130000.0",
    ));
    assert_eq!(field, "vehicle.dry_mass_kg");
    assert_eq!(value, 130_000.0);
    assert!(
        reason.contains("130000") && reason.contains("120000"),
        "{reason}"
    );
    assert!(
        display.contains("vehicle.dry_mass_kg = 130000"),
        "{display}"
    );
    assert!(display.contains("initial.mass_kg"), "{display}");

    // Equal masses leave no propellant: also rejected.
    let (field, _, _, _) = inconsistent(&paper_with(
        "dry_mass_kg = 85000.0",
        "dry_mass_kg = 120000.0",
    ));
    assert_eq!(field, "vehicle.dry_mass_kg");
}

#[test]
fn zero_isp_is_out_of_range() {
    let (field, value, allowed, display) =
        out_of_range(&paper_with("isp_s = 330.0", "isp_s = 0.0"));
    assert_eq!(field, "vehicle.isp_s");
    assert_eq!(value, 0.0);
    assert_eq!(allowed, "[1, 1000] s");
    assert_eq!(
        display,
        "vehicle.isp_s = 0 is out of range: allowed [1, 1000] s"
    );
}

#[test]
fn other_contradictions_are_inconsistent() {
    // A final-mass guess outside [m_dry, m0] is no longer one of them: it is
    // clamped (issue 29, `a_guess_outside_its_range_is_clamped_with_a_warning`).
    let cases: [(&str, &str, &str); 5] = [
        ("cg_m = 20.0", "cg_m = 60.0", "vehicle.cg_m"),
        ("cp_m = 22.5", "cp_m = 51.0", "vehicle.cp_m"),
        (
            "gimbal_deg = 0.0",
            "gimbal_deg = -25.0",
            "initial.gimbal_deg",
        ),
        ("z_m = 600.0", "z_m = 0.0", "initial.z_m"),
        (
            "max_iterations = 100",
            "max_iterations = 100\nrho0 = 0.3",
            "solver.rho1",
        ),
    ];
    for (from, to, expected) in cases {
        let (field, _, reason, display) = inconsistent(&paper_with(from, to));
        assert_eq!(field, expected, "{to}: {display}");
        assert!(display.starts_with(expected), "{display}");
        assert!(!reason.is_empty());
    }

    let solver_cases: [(&str, &str); 3] = [
        ("rho2 = 0.05", "solver.rho2"),
        ("trust_region_min = 2.0", "solver.trust_region_initial"),
        ("trust_region_max = 0.2", "solver.trust_region_initial"),
    ];
    for (extra, expected) in solver_cases {
        let text = format!("{PAPER_TOML}{extra}\n");
        let (field, _, _, display) = inconsistent(&text);
        assert_eq!(field, expected, "{extra}: {display}");
    }
}

#[test]
fn terminal_altitude_below_ground_is_out_of_range() {
    let text = PAPER_TOML.replacen("z_m = 0.0", "z_m = -1.0", 1);
    let (field, value, allowed, _) = out_of_range(&text);
    assert_eq!(field, "terminal.z_m");
    assert_eq!(value, -1.0);
    assert_eq!(allowed, "[0, 1e5] m");
}

/// An empty or blank name says so (issue 18: it read "name = 0 is out of
/// range").
#[test]
fn empty_name_is_rejected() {
    for name in ["\"\"", "\"  \""] {
        let e = Case::from_toml_str(&paper_with("name = \"paper\"", &format!("name = {name}")))
            .unwrap_err();
        assert_eq!(
            e,
            InputError::Empty {
                field: "name".into()
            }
        );
        assert_eq!(
            e.to_string(),
            "name must be non-empty (at least one non-blank character)"
        );
    }
}

/// Every numeric field in paper.toml, plus every solver setting, given
/// each of a set of bad values: the error is an `OutOfRange` naming that
/// field (never a panic).
#[test]
fn every_numeric_field_rejects_non_finite_and_absurd_values() {
    // Collect (section, key, line index) for each `key = number` line.
    let lines: Vec<&str> = PAPER_TOML.lines().collect();
    let mut section = String::new();
    let mut fields = Vec::new();
    for (idx, line) in lines.iter().enumerate() {
        let code = line.split('#').next().unwrap().trim();
        if let Some(name) = code.strip_prefix('[').and_then(|c| c.strip_suffix(']')) {
            section = name.to_string();
        } else if let Some((key, value)) = code.split_once('=') {
            if value.trim().parse::<f64>().is_ok() {
                fields.push((section.clone(), key.trim().to_string(), Some(idx)));
            }
        }
    }
    for key in [
        "step_tolerance",
        "virtual_control_tolerance",
        "virtual_control_weight",
        "trust_region_initial",
        "trust_region_min",
        "trust_region_max",
        "rho0",
        "rho1",
        "rho2",
        "shrink",
        "grow",
        "relaxation_gap_tolerance",
    ] {
        fields.push(("solver".to_string(), key.to_string(), None));
    }
    assert!(fields.len() > 40, "found only {} fields", fields.len());

    for (section, key, idx) in &fields {
        let dotted = format!("{section}.{key}");
        let is_count = key == "nodes" || key == "max_iterations";
        // A guess of 1e300 is a finite positive number outside its range:
        // clamped with a warning, not rejected (issue 29).
        let is_guess = key == "tf_guess_s" || key == "final_mass_guess_kg";
        let bad: &[&str] = if is_count {
            &["0", "1000000"]
        } else if is_guess {
            &["nan", "inf", "-inf", "-1e300"]
        } else {
            &["nan", "inf", "-inf", "1e300", "-1e300"]
        };
        for value in bad {
            let text = match idx {
                Some(i) => {
                    let mut l = lines.clone();
                    let new = format!("{key} = {value}");
                    l[*i] = &new;
                    l.join("\n")
                }
                None => format!("{PAPER_TOML}{key} = {value}\n"),
            };
            let result = std::panic::catch_unwind(|| Case::from_toml_str(&text));
            let result = result.unwrap_or_else(|_| panic!("{dotted} = {value} panicked"));
            match result {
                Err(InputError::OutOfRange { field, .. }) => {
                    assert_eq!(field, dotted, "{dotted} = {value}")
                }
                other => panic!("{dotted} = {value}: expected OutOfRange, got {other:?}"),
            }
        }
    }
}

/// Issue 29: a guess outside its range is clamped into it with a warning
/// naming the field, the value, the range and the value used; the same file
/// with the guesses left out reads without warnings.
#[test]
fn a_guess_outside_its_range_is_clamped_with_a_warning() {
    for (to, used) in [
        ("final_mass_guess_kg = 80000.0", 85_000.0),
        ("final_mass_guess_kg = 125000.0", 120_000.0),
        ("final_mass_guess_kg = 1e300", 120_000.0),
    ] {
        let case = Case::from_toml_str(&paper_with("final_mass_guess_kg = 110000.0", to))
            .unwrap_or_else(|e| panic!("{to}: {e}"));
        assert_eq!(case.scenario.discretization.final_mass_guess_kg, used);
        assert_eq!(case.warnings.len(), 1, "{to}");
        let w = &case.warnings[0];
        assert!(
            w.starts_with("discretization.final_mass_guess_kg = ")
                && w.contains("[vehicle.dry_mass_kg, initial.mass_kg] = [85000, 120000] kg")
                && w.ends_with(&format!("clamped to {used} kg")),
            "{w}"
        );
    }
    let case = Case::from_toml_str(&paper_with("tf_guess_s = 12.0", "tf_guess_s = 1e300")).unwrap();
    assert_eq!(case.scenario.discretization.tf_guess_s, 1000.0);
    assert_eq!(case.warnings.len(), 1);
    assert!(Case::paper().warnings.is_empty());
    let bare: String = PAPER_TOML
        .lines()
        .filter(|l| !l.starts_with("tf_guess_s") && !l.starts_with("final_mass_guess_kg"))
        .map(|l| format!("{l}\n"))
        .collect();
    let case = Case::from_toml_str(&bare).expect("the guesses are optional");
    assert!(case.warnings.is_empty());
    let d = &case.scenario.discretization;
    assert!((5.0..20.0).contains(&d.tf_guess_s), "{d:?}");
    assert!(
        (85_000.0..120_000.0).contains(&d.final_mass_guess_kg),
        "{d:?}"
    );
}

/// A gimbal limit that is 0 or subnormal in radians is bad input (issue 18:
/// 5e-324 deg passed the degree range, became 0 rad and panicked in the
/// subproblem's bounds).
#[test]
fn gimbal_limits_that_vanish_in_radians_are_out_of_range() {
    for (from, key) in [
        ("max_gimbal_deg = 20.0", "vehicle.max_gimbal_deg"),
        (
            "max_gimbal_rate_degps = 20.0",
            "vehicle.max_gimbal_rate_degps",
        ),
    ] {
        let name = from.split(' ').next().unwrap();
        for value in ["5e-324", "1e-300", "0.09"] {
            let (field, v, allowed, display) =
                out_of_range(&paper_with(from, &format!("{name} = {value}")));
            assert_eq!(field, key, "{display}");
            assert_eq!(v, value.parse::<f64>().unwrap());
            assert!(allowed.starts_with("[0.1, "), "{display}");
        }
    }
}

/// The smallest accepted gimbal limits give a subproblem that assembles and
/// solves without a panic.
#[test]
fn smallest_gimbal_limits_assemble_and_solve_one_subproblem() {
    let text = paper_with("max_gimbal_deg = 20.0", "max_gimbal_deg = 0.1").replacen(
        "max_gimbal_rate_degps = 20.0",
        "max_gimbal_rate_degps = 0.1",
        1,
    );
    let s = Case::from_toml_str(&text).expect("0.1 deg and 0.1 deg/s are accepted");
    let tr = bellyflop::method::scvx::transcription::Transcription::new(&s.scenario, &s.solver);
    let guess = bellyflop::method::scvx::straight_line(&tr, 12.0, 110_000.0);
    let data = tr.assemble(&guess, 0.3, 0.0);
    let mut conic = bellyflop::method::scvx::conic::ConicSolver::new();
    // Solved or not, it returns.
    let _ = tr.solve_with(&mut conic, &data);
}

/// A virtual-control weight at which Clarabel always fails (1e12 exited 6 on
/// the paper's case) is out of range; the documented bounds are accepted.
#[test]
fn unworkable_virtual_control_weights_are_out_of_range() {
    for value in ["1e12", "1e7", "0.5"] {
        let text = format!("{PAPER_TOML}virtual_control_weight = {value}\n");
        let (field, _, allowed, display) = out_of_range(&text);
        assert_eq!(field, "solver.virtual_control_weight", "{display}");
        assert_eq!(allowed, "[1, 1e5]");
    }
    for value in ["1.0", "1e5"] {
        let text = format!("{PAPER_TOML}virtual_control_weight = {value}\n");
        assert!(Case::from_toml_str(&text).is_ok(), "{value}");
    }
}

/// The centre of mass at an end of the body (cg_m = length_m gave a `solved`
/// plan whose re-flown path ended 1.1 km below the pad) is inconsistent with
/// the model's pitch inertia; the bound is l·(1 − √(2/3))/2 from either end.
#[test]
fn centre_of_mass_near_an_end_is_inconsistent() {
    for cg in ["50.0", "46.0", "4.5", "0.1"] {
        let (field, value, reason, display) =
            inconsistent(&paper_with("cg_m = 20.0", &format!("cg_m = {cg}")));
        assert_eq!(field, "vehicle.cg_m", "{display}");
        assert_eq!(value, cg.parse::<f64>().unwrap());
        assert!(reason.contains("[4.5876, 45.4124] m"), "{display}");
    }
    for cg in ["4.6", "25.0", "45.4"] {
        let text = paper_with("cg_m = 20.0", &format!("cg_m = {cg}"));
        assert!(Case::from_toml_str(&text).is_ok(), "cg_m = {cg}");
    }
}

/// Values that are positive but vanishing (subnormal, or far below any
/// vehicle) made the subproblem fail (exit 6); they are bad input now.
#[test]
fn vanishing_physical_values_are_out_of_range() {
    let cases = [
        (
            "dry_mass_kg = 85000.0",
            "vehicle.dry_mass_kg",
            "[1, 1e7] kg",
        ),
        (
            "max_thrust_n = 2210000.0",
            "vehicle.max_thrust_n",
            "[1, 1e9] N",
        ),
        ("isp_s = 330.0", "vehicle.isp_s", "[1, 1000] s"),
        (
            "g0_mps2 = 9.81",
            "environment.g0_mps2",
            "[0.001, 100] m/s^2",
        ),
        ("radius_m = 4.5", "vehicle.radius_m", "[0.01, 1000] m"),
        ("length_m = 50.0", "vehicle.length_m", "[0.01, 1000] m"),
    ];
    for (from, field, range) in cases {
        let key = from.split(' ').next().unwrap();
        for value in ["5e-324", "1e-8"] {
            let (f, _, allowed, display) =
                out_of_range(&paper_with(from, &format!("{key} = {value}")));
            assert_eq!(f, field, "{display}");
            assert_eq!(allowed, range, "{display}");
        }
    }
}

// ---------------------------------------------------------------------------
// The 6-DoF model's fields (issue 38): `model = "6dof"` and the
// out-of-plane start.
// ---------------------------------------------------------------------------

/// The paper's file as a 6-DoF scenario, with `initial` and `environment`
/// lines added (TOML `key = value` lines) to their tables.
fn six_dof_with(initial: &str, environment: &str) -> String {
    let text = paper_with("name = \"paper\"\n", "name = \"paper\"\nmodel = \"6dof\"\n");
    let text = text.replacen("\n[initial]\n", &format!("\n[initial]\n{initial}\n"), 1);
    text.replacen(
        "\n[environment]\n",
        &format!("\n[environment]\n{environment}\n"),
        1,
    )
}

/// Every out-of-plane field: its table, key, a value just outside its range,
/// and the range as the error gives it.
const OUT_OF_PLANE: [(&str, &str, f64, &str); 8] = [
    ("initial", "y_m", 1.5e5, "[-1e5, 1e5] m"),
    ("initial", "vy_mps", -2e4, "[-1e4, 1e4] m/s"),
    ("initial", "yaw_deg", 181.0, "[-180, 180] deg"),
    ("initial", "roll_deg", -180.5, "[-180, 180] deg"),
    ("initial", "body_rate_x_degps", 361.0, "[-360, 360] deg/s"),
    ("initial", "roll_rate_degps", -400.0, "[-360, 360] deg/s"),
    ("initial", "gimbal2_deg", 90.0, "(-90, 90) deg"),
    ("environment", "wind_y_mps", 100.5, "[-100, 100] m/s"),
];

/// A 6-DoF scenario with one out-of-plane field set.
fn six_dof_one(table: &str, key: &str, value: f64) -> String {
    let line = format!("{key} = {value:?}");
    match table {
        "initial" => six_dof_with(&line, ""),
        _ => six_dof_with("", &line),
    }
}

#[test]
fn each_out_of_plane_field_out_of_range_names_field_value_and_range() {
    for (table, key, value, range) in OUT_OF_PLANE {
        let (field, got, allowed, display) = out_of_range(&six_dof_one(table, key, value));
        let name = format!("{table}.{key}");
        assert_eq!(field, name);
        assert_eq!(got, value, "{name}");
        assert_eq!(allowed, range, "{name}");
        assert!(
            display.contains(&name) && display.contains(range),
            "{display}"
        );
        // A planar file too: the range comes first, then the model.
        let planar = six_dof_one(table, key, value).replace("model = \"6dof\"\n", "");
        assert_eq!(out_of_range(&planar).0, name);
    }
    // NaN and infinity are out of range as everywhere.
    let (field, value, _, _) = out_of_range(&six_dof_with("yaw_deg = nan", ""));
    assert_eq!(field, "initial.yaw_deg");
    assert!(value.is_nan());
    let (field, _, _, _) = out_of_range(&six_dof_with("", "wind_y_mps = -inf"));
    assert_eq!(field, "environment.wind_y_mps");
}

/// The second gimbal angle is held to the gimbal bound, like the first.
#[test]
fn the_second_gimbal_must_be_within_the_gimbal_bound() {
    let (field, value, reason, display) = inconsistent(&six_dof_with("gimbal2_deg = -25.0", ""));
    assert_eq!((field.as_str(), value), ("initial.gimbal2_deg", -25.0));
    assert!(reason.contains("vehicle.max_gimbal_deg = 20"), "{display}");
    assert!(Case::from_toml_str(&six_dof_with("gimbal2_deg = -20.0", "")).is_ok());
}

/// Each out-of-plane field, nonzero in a planar scenario, is refused with
/// an error that names it and `model = "6dof"`: nothing is silently
/// ignored. At 0, written or not, it is accepted.
#[test]
fn a_planar_scenario_with_an_out_of_plane_field_needs_model_6dof() {
    for (table, key, _, _) in OUT_OF_PLANE {
        let text = six_dof_one(table, key, 1.5).replace("model = \"6dof\"\n", "");
        let (field, value, reason, display) = inconsistent(&text);
        assert_eq!((field.as_str(), value), (&*format!("{table}.{key}"), 1.5));
        assert!(reason.contains("needs model = \"6dof\""), "{display}");
        assert!(
            display.starts_with(&format!(
                "{table}.{key} = 1.5 is inconsistent: needs model = \"6dof\""
            )),
            "{display}"
        );
        // The same field at 0 is the paper's planar case; with the model,
        // any in-range value is accepted.
        let zero = six_dof_one(table, key, 0.0).replace("model = \"6dof\"\n", "");
        assert_eq!(Case::from_toml_str(&zero).unwrap(), Case::paper());
        let six = Case::from_toml_str(&six_dof_one(table, key, 1.5)).expect("valid 6-DoF");
        let name = format!("{table}.{key}");
        let fields = six.scenario.out_of_plane();
        assert!(
            fields.iter().any(|(f, v)| *f == name && *v == 1.5),
            "{name}"
        );
    }
    // `model = "planar"` said out loud is the default.
    let text = paper_with(
        "name = \"paper\"\n",
        "name = \"paper\"\nmodel = \"planar\"\n",
    );
    assert_eq!(Case::from_toml_str(&text).unwrap(), Case::paper());
    // An unknown model is a TOML error naming it.
    let text = paper_with("name = \"paper\"\n", "name = \"paper\"\nmodel = \"3dof\"\n");
    let (line, _, message, _) = toml_error(&text);
    assert_eq!(line, line_of(&text, "model"));
    assert!(
        message.contains("3dof") && message.contains("6dof"),
        "{message}"
    );
}

/// A 6-DoF scenario with every out-of-plane field set writes to TOML (the
/// model and the fields included) and reads back equal; a planar one writes
/// none of them.
#[test]
fn a_six_dof_scenario_round_trips_through_toml() {
    let text = six_dof_with(
        "y_m = -35.0\nvy_mps = 6.5\nyaw_deg = 30.0\nroll_deg = -50.0\n\
         body_rate_x_degps = 2.5\nroll_rate_degps = -7.0\ngimbal2_deg = 4.0",
        "wind_y_mps = -3.0",
    );
    let case = Case::from_toml_str(&text).expect("valid");
    let s = &case.scenario;
    assert_eq!(s.model, bellyflop::input::scenario::ModelKind::SixDof);
    let i = &s.initial;
    assert_eq!(
        (i.y_m, i.vy_mps, i.yaw_deg, i.roll_deg),
        (-35.0, 6.5, 30.0, -50.0)
    );
    assert_eq!(
        (i.body_rate_x_degps, i.roll_rate_degps, i.gimbal2_deg),
        (2.5, -7.0, 4.0)
    );
    assert_eq!(s.environment.wind_y_mps, -3.0);
    let written = toml::to_string(&case).expect("serializes");
    assert!(written.contains("model = \"6dof\""), "{written}");
    assert!(written.contains("roll_rate_degps = -7.0"), "{written}");
    assert_eq!(Case::from_toml_str(&written).expect("reads back"), case);
    // The start it gives the 6-DoF model.
    let start = bellyflop::problem::six_dof::start_state(&s.initial);
    assert_eq!((start[1], start[4]), (-35.0, 6.5));
    // Planar: nothing new is written.
    let paper = toml::to_string(&Case::paper()).unwrap();
    for key in [
        "model",
        "wind_y",
        "\ny_m",
        "vy_mps",
        "yaw",
        "roll",
        "gimbal2",
        "body_rate",
    ] {
        assert!(!paper.contains(key), "{key}: {paper}");
    }
}

/// The planar consumers refuse a 6-DoF scenario with the typed error that
/// names them; a planar one passes.
#[test]
fn a_six_dof_scenario_is_refused_by_the_planar_consumers() {
    let case = Case::from_toml_str(&six_dof_with("yaw_deg = 10.0", "")).unwrap();
    let e = case.scenario.require_planar("the test").unwrap_err();
    assert!(
        matches!(
            &e,
            InputError::ModelUnavailable { model, operation }
                if *model == bellyflop::input::scenario::ModelKind::SixDof && operation == "the test"
        ),
        "{e:?}"
    );
    let msg = e.to_string();
    assert!(
        msg.starts_with("model = \"6dof\" is not yet available in the test")
            && msg.contains("bellyflop::pipeline::six_dof::solve"),
        "{msg}"
    );
    assert!(Case::paper().scenario.require_planar("the test").is_ok());
    // The planar pipeline refuses it before any work, by either entry point
    // (it used to solve it as planar, dropping its out-of-plane fields).
    let mut silent = bellyflop::method::observer::Silent;
    let refusals = [
        bellyflop::solve(&case.scenario, &case.solver, &mut silent).unwrap_err(),
        case.solve(&mut silent).unwrap_err(),
    ];
    for e in refusals {
        assert!(
            matches!(
                &e,
                InputError::ModelUnavailable { model, operation }
                    if *model == bellyflop::input::scenario::ModelKind::SixDof
                        && operation.contains("bellyflop::pipeline::solve")
            ),
            "{e:?}"
        );
    }
    // The closed loop refuses it too (its planner flies the planar model).
    let config = bellyflop::guidance::SimConfig::default();
    let e = config.fly(&case, 1, 0, false).unwrap_err();
    assert!(matches!(e, InputError::ModelUnavailable { .. }), "{e}");
}
