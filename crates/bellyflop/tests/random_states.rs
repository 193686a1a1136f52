//! Random initial states, within and beyond the documented envelope, through
//! `bellyflop::solve` with both methods (issue 18, "a proptest over random
//! states"): never a panic, a status that tells the truth, and JSON for every
//! status. Seeded (proptest's deterministic runner), N = 10 to stay fast.

use bellyflop::scvx::Silent;
use bellyflop::{Method, Scenario, Status};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

fn scenario(x: [f64; 6], method: Method) -> Scenario {
    let mut s = Scenario::paper();
    let i = &mut s.initial;
    (i.x_m, i.z_m, i.vx_mps, i.vz_mps, i.theta_deg, i.mass_kg) =
        (x[0], x[1], x[2], x[3], x[4], x[5]);
    s.discretization.final_mass_guess_kg = x[5] - 5000.0;
    s.discretization.nodes = 10;
    s.solver.method = method;
    s
}

#[test]
fn random_states_get_truthful_statuses() {
    // A box wider than the documented envelope: low and fast states too.
    let state = (
        -400.0..400.0f64,
        150.0..1000.0f64,
        -30.0..30.0f64,
        -120.0..-40.0f64,
        60.0..110.0f64,
        100_000.0..128_000.0f64,
    );
    let config = Config {
        cases: 24,
        failure_persistence: None,
        ..Config::default()
    };
    let rng = TestRng::from_seed(RngAlgorithm::ChaCha, &[18; 32]);
    let mut runner = TestRunner::new_with_rng(config, rng);
    runner
        .run(&state, |(x, z, vx, vz, th, m)| {
            for method in [Method::Direct, Method::Scvx] {
                let s = scenario([x, z, vx, vz, th, m], method);
                prop_assert!(s.validate().is_ok());
                let sol = bellyflop::solve(&s, &mut Silent);
                // JSON for every status, with the status and method named.
                let v = sol.to_json();
                prop_assert_eq!(v["status"].as_str().unwrap(), sol.status.as_str());
                prop_assert_eq!(v["method"].as_str().unwrap(), method.as_str());
                prop_assert!(sol.trajectory.is_finite() || sol.status != Status::Solved);
                if sol.status == Status::Solved {
                    // `solved` means every check passes.
                    prop_assert!(
                        sol.checks.max_defect < 1e-6,
                        "defect {}",
                        sol.checks.max_defect
                    );
                    prop_assert!(sol.checks.min_altitude_margin_m > -1e-3);
                    prop_assert!(
                        sol.checks.thrust_bound_violation_n < 1e-6 * s.vehicle.max_thrust_n
                    );
                    prop_assert!(sol.checks.thrust_alignment_min > 0.0);
                } else {
                    prop_assert!(!sol.message.is_empty(), "{:?} without a reason", sol.status);
                }
            }
            Ok(())
        })
        .unwrap();
}
