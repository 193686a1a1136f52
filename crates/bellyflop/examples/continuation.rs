//! Coarse-to-fine cold solve (mesh continuation), measured against the direct
//! cold solve (issue 5). Not used by `bellyflop::solve`; see BENCHMARKS.md.
//!
//! `cargo run --release -p bellyflop --example continuation [CHAIN ...]`
//!
//! A chain such as `10,40` solves the paper's case at N = 10 from the straight
//! line, then at N = 40 from that solution resampled on the finer mesh
//! ([`Planner::replan`] at elapsed time 0: relaxed phase first, as in a cold
//! solve). Prints the SCvx iterations per stage, the total wall time, and the
//! direct cold solve at the last N with the ratio (three repetitions each,
//! single runs; the criterion benches time the direct solve).

use std::time::Instant;

use bellyflop::guidance::planner::Planner;
use bellyflop::method::observer::Silent;
use bellyflop::{Case, Status};

fn paper(n: usize) -> Case {
    let mut s = Case::paper();
    s.scenario.discretization.nodes = n;
    s
}

fn main() {
    let mut chains: Vec<Vec<usize>> = std::env::args()
        .skip(1)
        .map(|a| a.split(',').map(|n| n.parse().expect("N")).collect())
        .collect();
    if chains.is_empty() {
        chains = vec![vec![10, 20], vec![10, 40], vec![10, 20, 40]];
    }
    for chain in chains {
        for _ in 0..3 {
            let t0 = Instant::now();
            let mut sol = paper(chain[0])
                .solve(&mut Silent)
                .expect("a planar scenario");
            let mut its = vec![sol.iterations];
            for &n in &chain[1..] {
                if sol.status != Status::Solved {
                    break;
                }
                let s = paper(n);
                let mut planner = Planner::new(s.scenario.clone(), s.solver.clone());
                // The SCvx warm re-plan (the scenario's default method is direct).
                planner.method = bellyflop::Method::Scvx;
                planner.plan = Some(sol.plan());
                sol = planner
                    .replan(&s.scenario.initial, 0.0, &mut Silent)
                    .expect("valid");
                its.push(sol.iterations);
            }
            let ms = t0.elapsed().as_secs_f64() * 1e3;
            let t1 = Instant::now();
            let direct = paper(*chain.last().unwrap())
                .solve(&mut Silent)
                .expect("a planar scenario");
            let direct_ms = t1.elapsed().as_secs_f64() * 1e3;
            println!(
                "{chain:?}: its {its:?} {} {ms:.1} ms m_f {:.2} kg | direct: {} its {direct_ms:.1} ms m_f {:.2} kg | ratio {:.2}",
                sol.status.as_str(),
                sol.final_mass_kg,
                direct.iterations,
                direct.final_mass_kg,
                ms / direct_ms
            );
        }
    }
}
