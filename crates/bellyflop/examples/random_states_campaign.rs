//! The random-states half of issue 18's fuzz campaign (docs/reliability.md):
//! states drawn uniformly from the box of `tests/random_states.rs` (wider
//! than the envelope), each through `bellyflop::solve` with both methods,
//! checking the same invariants, and counting panics, violations and
//! statuses. State k is drawn from its own seeded generator, so any range
//! of states can be run on its own, in chunks:
//!
//!     cargo run --release -p bellyflop --example random_states_campaign -- START COUNT [NODES]
//!
//! (NODES defaults to 20, the issue's.) Exits 1 on any panic or violation.

#[path = "../tests/common/random_states.rs"]
mod random_states;

use std::collections::BTreeMap;

use bellyflop::method::observer::Silent;
use bellyflop::Method;
use rand::{Rng, SeedableRng};
use random_states::{check, scenario, BOX};

/// The seed of state k is SEED + k.
const SEED: u64 = 18_000_000;

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("START COUNT [NODES] are counts"))
        .collect();
    let (start, count) = (
        args.first().copied().unwrap_or(0),
        args.get(1).copied().unwrap_or(10),
    );
    let nodes = args.get(2).copied().unwrap_or(20);
    std::panic::set_hook(Box::new(|_| {}));
    let mut statuses: BTreeMap<String, usize> = BTreeMap::new();
    let mut bad = Vec::new();
    let t0 = std::time::Instant::now();
    for k in start..start + count {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(SEED + k as u64);
        let x: [f64; 6] = std::array::from_fn(|i| rng.gen_range(BOX[i].0..BOX[i].1));
        for method in [Method::Direct, Method::Scvx] {
            let s = scenario(x, method, nodes);
            let result = std::panic::catch_unwind(|| {
                let sol = bellyflop::solve(&s.scenario, &s.solver, &mut Silent)
                    .expect("a planar scenario");
                check(&s, &sol).map(|()| sol.status)
            });
            match result {
                Ok(Ok(status)) => {
                    *statuses
                        .entry(format!("{}/{}", method.as_str(), status.as_str()))
                        .or_default() += 1
                }
                Ok(Err(violation)) => bad.push(format!("state {k} {x:?} {method:?}: {violation}")),
                Err(e) => {
                    let what = e
                        .downcast_ref::<String>()
                        .cloned()
                        .or_else(|| e.downcast_ref::<&str>().map(|m| m.to_string()))
                        .unwrap_or_default();
                    bad.push(format!("state {k} {x:?} {method:?}: PANIC {what}"))
                }
            }
        }
    }
    println!(
        "states {start}..{} (N = {nodes}), both methods, {:.0} s: {} solves, {} panics or violations",
        start + count,
        t0.elapsed().as_secs_f64(),
        2 * count,
        bad.len()
    );
    for (k, n) in &statuses {
        println!("  {k}: {n}");
    }
    for b in &bad {
        println!("  {b}");
    }
    if !bad.is_empty() {
        std::process::exit(1);
    }
}
