//! The Rust side of the C API's latency bench: the same engine calls that
//! `tests/c/bench_latency.c` makes through the C functions, made directly
//! on [`bellyflop_c::engine::FlightSolver`] on the same inputs, with the
//! same output records (see that file). The difference between the two is
//! the C boundary: the pointer checks, `catch_unwind`, and the copy of the
//! answer into the caller's nodes.
//!
//! `cargo run --release -p bellyflop-c --example bench_latency --
//! REPLANS_TXT PLANNING_TOML COLD_RUNS ROUNDS`
use std::time::Instant;

use bellyflop::Status;
use bellyflop_c::engine::{default_settings, FlightSolver, Problem};
use bellyflop_c::types::bf_state;

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    assert_eq!(
        args.len(),
        5,
        "usage: bench_latency REPLANS_TXT PLANNING_TOML COLD_RUNS ROUNDS"
    );
    let text = std::fs::read_to_string(&args[1]).expect("read REPLANS_TXT");
    let rows: Vec<(f64, bf_state)> = text
        .lines()
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|w| w.parse().unwrap()).collect();
            let x = bf_state {
                x_m: v[1],
                z_m: v[2],
                vx_mps: v[3],
                vz_mps: v[4],
                theta_rad: v[5],
                pitch_rate_radps: v[6],
                mass_kg: v[7],
                gimbal_rad: v[8],
            };
            (v[0], x)
        })
        .collect();
    let cold_runs: usize = args[3].parse().unwrap();
    let rounds: usize = args[4].parse().unwrap();
    let settings = default_settings();

    let mut s = FlightSolver::new(&Problem::paper(), &settings).unwrap();
    s.solve();
    for _ in 0..cold_runs {
        let t0 = Instant::now();
        let answer = s.solve();
        let dt = ms(t0);
        assert_eq!(answer.solution.status, Status::Solved);
        println!("cold {dt:.6}");
    }

    let mut planning = Problem::from_file(args[2].as_ref()).unwrap();
    planning.set_initial_state(&rows[0].1).unwrap();
    for r in 0..rounds {
        let mut s = FlightSolver::new(&planning, &settings).unwrap();
        s.solve();
        for (k, (t, x)) in rows.iter().enumerate().skip(1) {
            let t0 = Instant::now();
            let answer = s.replan(x, *t);
            let dt = ms(t0);
            let answer = answer.unwrap_or_else(|e| panic!("re-plan {k}: {}", e.message));
            println!("replan {r} {k} {dt:.6}");
            if r == 0 {
                let sol = &answer.solution;
                println!(
                    "answer {k} {} {} {} 0x{:016x} 0x{:016x}",
                    sol.status.as_str(),
                    sol.iterations,
                    u8::from(answer.adopted),
                    sol.tf_s.to_bits(),
                    sol.final_mass_kg.to_bits()
                );
            }
        }
    }
}
