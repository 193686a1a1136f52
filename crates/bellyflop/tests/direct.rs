//! The direct method against the CasADi + IPOPT reference on the same
//! transcription (issue 15, "Tests").
//!
//! The reference values are IPOPT's optima of P2 with bellyflop's ground
//! bound, from `bench/reference/nlp_reference.py --scenario F --nodes N
//! --problem P2 --ground [--intervals M]` (tol 1e-9), measured on 2026-12-01.

use bellyflop::input::settings::DirectSettings;
use bellyflop::method::direct;
use bellyflop::method::direct::nlp::Nlp;
use bellyflop::method::observer::Silent;
use bellyflop::{Case, Method, Solution, Status};

fn direct_paper(edit: impl FnOnce(&mut Case)) -> Solution {
    let mut s = Case::paper();
    s.solver.method = Method::Direct;
    // The transcription's own optimum, against IPOPT's on the same
    // transcription: unpolished, judged by the tolerances of before the
    // polish (5 m, 2 m/s; it misses by 0.81 m and 0.32 m/s).
    s.solver.polish = false;
    s.solver.landing_position_tolerance_m = 5.0;
    s.solver.landing_velocity_tolerance_mps = 2.0;
    edit(&mut s);
    s.validate().expect("test scenario is valid");
    s.solve(&mut Silent).expect("a planar scenario")
}

/// The method alone (no certificate, no accuracy check): these tests compare
/// the transcription's optimum with IPOPT's, whether or not its controls land
/// within the tolerances once re-integrated (the dispersed states at N = 20
/// miss by 0.6 to 21 m; `tests/accuracy.rs` and `tests/labelled.rs` judge that).
fn direct_alone(edit: impl FnOnce(&mut Case)) -> Solution {
    let mut s = Case::paper();
    s.solver.method = Method::Direct;
    edit(&mut s);
    s.validate().expect("test scenario is valid");
    direct::solve(&s.scenario, &s.solver, &mut Silent)
}

/// Solved, on IPOPT's optimum within 0.1 kg, and meets the collocation
/// equations of the nonlinear problem.
fn assert_reference(sol: &Solution, mass_kg: f64, tf_s: f64, what: &str) {
    assert_eq!(sol.status, Status::Solved, "{what}: {}", sol.message);
    assert_eq!(sol.method, Method::Direct);
    assert!(
        (sol.final_mass_kg - mass_kg).abs() < 0.1,
        "{what}: m_f {} against IPOPT's {mass_kg}",
        sol.final_mass_kg
    );
    assert!(
        (sol.tf_s - tf_s).abs() < 1e-3,
        "{what}: t_f {} against IPOPT's {tf_s}",
        sol.tf_s
    );
    assert!(
        sol.checks.max_defect < 1e-7,
        "{what}: defect {}",
        sol.checks.max_defect
    );
    assert!(sol.checks.min_altitude_margin_m >= -1e-9, "{what}");
    assert!(sol.checks.thrust_bound_violation_n <= 1e-6, "{what}");
    assert_eq!(sol.iterations, sol.history.direct.len());
    assert!(sol.history.scvx.is_empty(), "no SCvx history");
}

#[test]
fn paper_case_reaches_the_ipopt_optimum_at_n20_and_n40() {
    for (n, mass, tf) in [(20, 114_569.455, 11.56895), (40, 114_575.296, 11.56058)] {
        let sol = direct_alone(|s| s.scenario.discretization.nodes = n);
        assert_reference(&sol, mass, tf, &format!("N = {n}"));
    }
}

#[test]
fn hp_mesh_reaches_the_ipopt_optimum() {
    let sol = direct_alone(|s| s.scenario.discretization.intervals = 4);
    assert_reference(&sol, 114_574.792, 11.56338, "N = 20, M = 4");
}

#[test]
fn six_dispersed_states_reach_the_ipopt_optimum() {
    // x0 [m], z0 [m], vx0, vz0 [m/s], theta0 [deg], m0 [kg]; IPOPT's m_f, t_f.
    let cases = [
        (
            [-200.0, 500.0, 15.0, -70.0, 80.0, 110_000.0],
            103_317.99,
            14.01242,
        ),
        (
            [200.0, 800.0, -15.0, -95.0, 95.0, 125_000.0],
            118_749.67,
            14.50382,
        ),
        (
            [0.0, 650.0, 0.0, -80.0, 88.0, 118_000.0],
            112_129.68,
            12.61052,
        ),
        (
            [150.0, 550.0, 10.0, -90.0, 85.0, 122_000.0],
            115_758.17,
            10.99321,
        ),
        (
            [-120.0, 750.0, -8.0, -75.0, 92.0, 112_000.0],
            105_135.60,
            15.61072,
        ),
        (
            [60.0, 700.0, 5.0, -88.0, 82.0, 124_000.0],
            118_092.66,
            13.25504,
        ),
    ];
    for (x, mass, tf) in cases {
        let sol = direct_alone(|s| {
            let i = &mut s.scenario.initial;
            (i.x_m, i.z_m, i.vx_mps, i.vz_mps, i.theta_deg, i.mass_kg) =
                (x[0], x[1], x[2], x[3], x[4], x[5]);
            s.scenario.discretization.final_mass_guess_kg = x[5] - 5000.0;
        });
        assert_reference(&sol, mass, tf, &format!("{x:?}"));
        // IPOPT's t_f agrees to 5e-4 s on these (the optimum is flat in t_f).
    }
}

/// 100 m up at 85 m/s: the method alone ends locally infeasible (its
/// restoration stalls); `bellyflop::solve` has the stopping bound's
/// certificate and does not solve.
#[test]
fn too_low_to_stop_is_infeasible_with_a_reason() {
    let mut s = Case::paper();
    s.solver.method = Method::Direct;
    s.scenario.initial.z_m = 100.0;
    let alone = direct::solve(&s.scenario, &s.solver, &mut Silent);
    assert_eq!(alone.status, Status::Infeasible, "{}", alone.message);
    assert!(
        alone.message.contains("locally infeasible"),
        "{}",
        alone.message
    );
    assert!(alone.trajectory.is_finite());
    let sol = direct_paper(|s| s.scenario.initial.z_m = 100.0);
    assert_eq!(sol.status, Status::Infeasible, "{}", sol.message);
    assert!(
        sol.message.starts_with(
            "no trajectory exists (certified from the initial state by the vertical stopping bound)"
        ),
        "{}",
        sol.message
    );
    assert_eq!((sol.iterations, sol.method), (0, Method::Direct));
    assert!(sol.trajectory.is_finite());
}

#[test]
fn iteration_limit_is_not_converged_with_the_last_iterate() {
    // With and without the coarse start: the limit counts every phase.
    for coarse in [0, 10] {
        let sol = direct_paper(|s| {
            s.solver.direct.max_iterations = 4;
            s.solver.direct.coarse_nodes = coarse;
        });
        assert_eq!(sol.status, Status::NotConverged);
        assert_eq!(sol.iterations, 4, "coarse {coarse}");
        assert!(
            sol.message.contains("4 interior-point iterations"),
            "{}",
            sol.message
        );
        assert!(sol.trajectory.is_finite());
        assert!(
            sol.checks.max_defect > 1e-6,
            "not yet feasible after 4 iterations"
        );
    }
    // A limit that the coarse phase does not use up leaves the rest to the
    // fine one: halfway between the coarse phase's end and convergence.
    let full = direct_paper(|_| ());
    assert_eq!(full.status, Status::Solved);
    let coarse = full
        .history
        .direct
        .iter()
        .filter(|h| h.mesh_nodes == 10)
        .count();
    let limit = (coarse + full.iterations) / 2;
    assert!(coarse < limit && limit < full.iterations);
    let sol = direct_paper(|s| s.solver.direct.max_iterations = limit);
    assert_eq!(sol.status, Status::NotConverged, "{}", sol.message);
    assert_eq!(sol.iterations, limit);
    assert!(sol.history.direct.iter().any(|h| h.mesh_nodes == 20));
}

/// The coarse start and the straight line reach the same optimum.
#[test]
fn coarse_start_and_straight_line_agree() {
    let a = direct_paper(|s| s.solver.direct.coarse_nodes = 0);
    let b = direct_paper(|s| s.solver.direct.coarse_nodes = 10);
    assert!((a.final_mass_kg - b.final_mass_kg).abs() < 0.01);
    assert!(b.history.direct.iter().any(|h| h.mesh_nodes == 10));
    assert!(a.history.direct.iter().all(|h| h.mesh_nodes == 20));
}

#[test]
fn history_records_the_interior_point_iterations() {
    let sol = direct_paper(|_| ());
    let h = &sol.history.direct;
    assert!(h.len() >= 5);
    // μ never rises within a mesh; the coarse start (N = 10) comes first.
    assert!(h
        .windows(2)
        .all(|w| w[1].mu <= w[0].mu || w[1].mesh_nodes != w[0].mesh_nodes));
    assert_eq!(h[0].mesh_nodes, 10);
    assert_eq!(h.last().unwrap().mesh_nodes, 20);
    assert!(h.iter().enumerate().all(|(k, r)| r.iteration == k + 1));
    assert!(h
        .iter()
        .all(|r| r.restoration || (r.step > 0.0 && r.step <= 1.0)));
    let last = h.last().unwrap();
    assert!(last.primal_infeasibility < 1e-5 && last.dual_infeasibility < 1e-5);
    assert!(
        h[0].primal_infeasibility > 1e-2,
        "the straight line is infeasible"
    );
}

/// A warm start from the solution with its multipliers converges at once.
#[test]
fn warm_start_from_the_answer_converges_in_a_few_iterations() {
    let mut s = Case::paper();
    s.solver.method = Method::Direct;
    let nlp = Nlp::new(&s.scenario, &s.solver);
    let w0 = nlp.straight_line(
        s.scenario.discretization.tf_guess_s,
        s.scenario.discretization.final_mass_guess_kg,
    );
    let cold = direct::solve_nlp(&nlp, &w0, None, &DirectSettings::default(), &mut Silent);
    assert_eq!(cold.status, Status::Solved);
    let warm_settings = DirectSettings {
        mu_init: 1e-6,
        ..DirectSettings::default()
    };
    let warm = direct::solve_nlp(
        &nlp,
        &cold.w,
        Some(&cold.lambda),
        &warm_settings,
        &mut Silent,
    );
    assert_eq!(warm.status, Status::Solved, "{}", warm.message);
    assert!(
        warm.history.len() * 2 < cold.history.len(),
        "warm {} against cold {} iterations",
        warm.history.len(),
        cold.history.len()
    );
}

/// The adaptive barrier rule reaches the same optimum (BENCHMARKS.md has
/// its iteration counts: no fewer than the monotone rule's on dispersed states).
#[test]
fn adaptive_barrier_rule_reaches_the_same_optimum() {
    let sol = direct_paper(|s| {
        s.solver.direct.mu_strategy = bellyflop::input::settings::MuStrategy::Adaptive
    });
    assert_reference(&sol, 114_569.455, 11.56895, "adaptive μ");
}

/// The closed-loop plans' soft constraints (a 10 % thrust margin at weight
/// 100, soft terminal x and Vx at weight 1000) give the direct method SCvx's
/// optimum of the same program: the thrust stays within the engine, and on
/// the margin's band wherever the margin is not worth its cost.
#[test]
fn soft_margin_and_terminal_reach_the_scvx_optimum() {
    let soft = |s: &mut Case| {
        s.solver.thrust_margin_frac = 0.1;
        s.solver.thrust_margin_weight = 100.0;
        s.solver.terminal_lateral_weight = 1000.0;
    };
    let d = direct_alone(soft);
    let mut s = Case::paper();
    soft(&mut s);
    let c = bellyflop::method::scvx::solve(&s.scenario, &s.solver, &mut Silent);
    assert_eq!(d.status, Status::Solved, "{}", d.message);
    assert_eq!(c.status, Status::Solved, "{}", c.message);
    assert!(
        (d.final_mass_kg - c.final_mass_kg).abs() < 0.5,
        "direct {} against SCvx {}",
        d.final_mass_kg,
        c.final_mass_kg
    );
    let hard = Case::paper();
    assert!(d.final_mass_kg < direct_alone(|_| ()).final_mass_kg - 100.0);
    let t_max = hard.scenario.vehicle.max_thrust_n;
    let band = 0.9 * t_max;
    let peak = d.thrust_n[..d.nodes].iter().fold(0.0f64, |a, &t| a.max(t));
    assert!(peak <= t_max && peak > band - 1.0, "peak thrust {peak} N");
    assert!(d.checks.thrust_bound_violation_n <= 0.0, "{:?}", d.checks);
    assert!(d.x_m[d.nodes].abs() < 1e-3 && d.vx_mps[d.nodes].abs() < 1e-3);
}
