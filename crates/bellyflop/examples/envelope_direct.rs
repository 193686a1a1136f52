//! The direct method over the envelope's states in one process, against the
//! IPOPT answers that `bench/envelope.py --save` recorded: a fast loop for
//! tuning the method on the benchmark's seeded states (the timed comparison
//! stays `bench/envelope.py`, which runs both solvers side by side).
//!
//!     bench/envelope.py --methods direct --save /tmp/envelope{n}.csv
//!     cargo run --release -p bellyflop --example envelope_direct -- /tmp/envelope20.csv [N] [--table] [key=value ...]
//!
//! where each `key=value` sets a field of `[solver.direct]` (for example
//! `coarse_tolerance=1e-3`).
//!
//! Prints the states converged, the median iterations (ours, IPOPT's), the
//! summed solve time, the mass gaps to IPOPT, and every state where we do
//! worse.

use bellyflop::method::observer::Silent;
use bellyflop::{Case, Method, Status};

struct Row {
    name: String,
    state: [f64; 6],
    ipopt_ok: bool,
    ipopt_mf: f64,
    ipopt_its: usize,
    ipopt_ms: f64,
}

fn read(path: &str) -> Vec<Row> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let num = |i: usize| -> f64 { f[i].parse().unwrap_or(f64::NAN) };
            Row {
                name: f[0].to_string(),
                state: std::array::from_fn(|k| num(k + 1)),
                ipopt_ok: f[7] == "1",
                ipopt_mf: num(8),
                ipopt_its: f[9].parse().unwrap_or(0),
                ipopt_ms: num(10),
            }
        })
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return f64::NAN;
    }
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args
        .first()
        .expect("usage: envelope_direct CSV [N] [--table]");
    let n: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(20);
    let table = args.iter().any(|a| a == "--table");
    let overrides: Vec<String> = args[1..]
        .iter()
        .filter(|a| a.contains('='))
        .map(|a| a.replacen('=', " = ", 1))
        .collect();
    let rows = read(path);
    let (mut ms, mut ipopt_ms) = (0.0, 0.0);
    let (mut its, mut ipopt_its, mut gaps) = (Vec::new(), Vec::new(), Vec::new());
    let (mut converged, mut coarse_its) = (0, Vec::new());
    for r in &rows {
        let mut s = Case::paper();
        s.scenario.discretization.nodes = n;
        s.solver.method = Method::Direct;
        if !overrides.is_empty() {
            s.solver.direct =
                toml::from_str(&overrides.join("\n")).expect("key=value of [solver.direct]");
        }
        let i = &mut s.scenario.initial;
        [i.x_m, i.z_m, i.vx_mps, i.vz_mps, i.theta_deg, i.mass_kg] = r.state;
        s.scenario.discretization.final_mass_guess_kg = r.state[5] - 5000.0;
        let sol = bellyflop::solve(&s.scenario, &s.solver, &mut Silent).expect("a planar scenario");
        let ok = matches!(sol.status, Status::Solved | Status::Inaccurate);
        converged += usize::from(ok);
        ms += sol.solve_time_ms;
        ipopt_ms += r.ipopt_ms;
        its.push(sol.iterations as f64);
        ipopt_its.push(r.ipopt_its as f64);
        let coarse = sol
            .history
            .direct
            .iter()
            .filter(|h| h.mesh_nodes != n)
            .count();
        coarse_its.push(coarse as f64);
        let gap = sol.final_mass_kg - r.ipopt_mf;
        if ok && r.ipopt_ok {
            gaps.push(gap);
        }
        if table || (r.ipopt_ok && (!ok || gap < -0.5)) {
            println!(
                "{:7} {:13} {:3} its ({:2} coarse) {:7.1} ms {:10.1} kg | IPOPT {} {:3} its {:7.1} ms {:10.1} kg | gap {:+.2} kg",
                r.name,
                sol.status.as_str(),
                sol.iterations,
                coarse,
                sol.solve_time_ms,
                sol.final_mass_kg,
                if r.ipopt_ok { "ok    " } else { "FAILED" },
                r.ipopt_its,
                r.ipopt_ms,
                r.ipopt_mf,
                gap
            );
        }
    }
    let coarse_total: f64 = coarse_its.iter().sum();
    let fine_total = its.iter().sum::<f64>() - coarse_total;
    let within = gaps.iter().filter(|&&g| g >= -0.5).count();
    let min_gap = gaps.iter().copied().fold(f64::INFINITY, f64::min);
    println!(
        "N = {n}: converged {converged}/{}; m_f >= IPOPT - 0.5 kg on {within}/{} (min gap {min_gap:+.2} kg); \
         median iterations {} ({} coarse) vs IPOPT {}; time {:.2} s vs IPOPT's recorded {:.2} s ({:.2}x); iterations in all: {} coarse, {} fine",
        rows.len(),
        gaps.len(),
        median(its),
        median(coarse_its),
        median(ipopt_its),
        ms / 1e3,
        ipopt_ms / 1e3,
        ipopt_ms / ms,
        coarse_total,
        fine_total
    );
}
