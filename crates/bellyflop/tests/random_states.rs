//! Random initial states, within and beyond the documented envelope, through
//! `bellyflop::solve` with both methods (issue 18, "a proptest over random
//! states"): never a panic, a status that tells the truth, and JSON for every
//! status. Seeded (proptest's deterministic runner), N = 10 to stay fast.

#[path = "common/random_states.rs"]
mod random_states;

use bellyflop::method::observer::Silent;
use bellyflop::Method;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use random_states::{check, scenario, BOX};

#[test]
fn random_states_get_truthful_statuses() {
    // A box wider than the documented envelope: low and fast states too.
    let state = (
        BOX[0].0..BOX[0].1,
        BOX[1].0..BOX[1].1,
        BOX[2].0..BOX[2].1,
        BOX[3].0..BOX[3].1,
        BOX[4].0..BOX[4].1,
        BOX[5].0..BOX[5].1,
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
                let s = scenario([x, z, vx, vz, th, m], method, 10);
                prop_assert!(s.validate().is_ok());
                let sol = bellyflop::solve(&s.scenario, &s.solver, &mut Silent)
                    .expect("a planar scenario");
                let checked = check(&s, &sol);
                prop_assert!(checked.is_ok(), "{}", checked.unwrap_err());
            }
            Ok(())
        })
        .unwrap();
}
