//! Solve one scenario many times with the direct method and print the
//! median solve time and the iterations: a loop to profile (`perf record`).
//!
//!     cargo run --release -p bellyflop --example direct_repeat -- [N] [RUNS] [INTERVALS]

use bellyflop::method::observer::Silent;
use bellyflop::{Case, Method};

fn main() {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(20);
    let runs: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(50);
    let intervals: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(1);
    let mut s = Case::paper();
    s.scenario.discretization.nodes = n;
    s.scenario.discretization.intervals = intervals;
    s.solver.method = Method::Direct;
    let mut ms = Vec::with_capacity(runs);
    let mut last = None;
    for _ in 0..runs {
        let sol = bellyflop::solve(&s.scenario, &s.solver, &mut Silent).expect("a planar scenario");
        ms.push(sol.solve_time_ms);
        last = Some(sol);
    }
    ms.sort_by(f64::total_cmp);
    let sol = last.expect("at least one run");
    println!(
        "N = {n} over {intervals} intervals: {} in {} iterations, m_f = {:.1} kg; median {:.2} ms over {runs} runs ({:.3} ms per iteration), fastest {:.2} ms",
        sol.status.as_str(),
        sol.iterations,
        sol.final_mass_kg,
        ms[runs / 2],
        ms[runs / 2] / sol.iterations as f64,
        ms[0]
    );
}
