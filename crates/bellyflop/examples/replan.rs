//! Warm re-plan against a cold solve (issue 5): solve the paper's case, move
//! 0.5 s along the plan, and re-plan from the plan's own state there.
//!
//! `cargo run --release -p bellyflop --example replan [N ...] [--relaxed K] [--proximal W] [--intervals M]`
//!
//! Prints, per N, the iterations and wall time of the cold solve and of the
//! warm re-plan, the re-plan's final mass against the cold plan's, whether
//! both are `solved`, and each re-plan iteration. `--relaxed K` and
//! `--proximal W` set the planner's `warm_relaxed_iterations` (default 0) and
//! `warm_proximal_weight` (default 0.01); `--intervals M` solves on an hp
//! mesh of M intervals. Timing lives in the criterion bench (`warm_replan`);
//! these are single runs.

use bellyflop::guidance::planner::{initial_state, Planner};
use bellyflop::method::observer::Silent;
use bellyflop::Case;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let flag = |name: &str| -> Option<f64> {
        let i = args.iter().position(|a| a == name)?;
        args.get(i + 1)?.parse().ok()
    };
    let (relaxed, proximal) = (flag("--relaxed"), flag("--proximal"));
    let intervals = flag("--intervals");
    let ns: Vec<usize> = args
        .iter()
        .enumerate()
        .filter(|(i, _)| *i == 0 || !args[i - 1].starts_with("--"))
        .filter_map(|(_, a)| a.parse().ok())
        .collect();
    let ns = if ns.is_empty() { vec![10, 20, 40] } else { ns };
    println!("  N  cold its    ms  status   | warm its    ms  status   m_f change");
    for n in ns {
        let mut s = Case::paper();
        s.scenario.discretization.nodes = n;
        if let Some(m) = intervals {
            s.scenario.discretization.intervals = m as usize;
        }
        let mut planner = Planner::new(s.scenario, s.solver);
        // The SCvx warm re-plan (the scenario's default method is direct).
        planner.method = bellyflop::Method::Scvx;
        let cold = planner.cold(&mut Silent);
        let Some(plan) = planner.plan.clone() else {
            println!(
                "{n:>3}  cold solve {}: {}",
                cold.status.as_str(),
                cold.message
            );
            continue;
        };
        if let Some(k) = relaxed {
            planner.warm_relaxed_iterations = k as usize;
        }
        if let Some(w) = proximal {
            planner.warm_proximal_weight = w;
        }
        let state = initial_state(&plan.state_at(0.5));
        let warm = planner
            .replan(&state, 0.5, &mut Silent)
            .expect("valid state");
        println!(
            "{n:>3}  {:>8} {:>6.1}  {:<8} | {:>8} {:>6.1}  {:<8} {:+.2} kg",
            cold.iterations,
            cold.solve_time_ms,
            cold.status.as_str(),
            warm.iterations,
            warm.solve_time_ms,
            warm.status.as_str(),
            warm.final_mass_kg - cold.final_mass_kg,
        );
        for h in &warm.history.scvx {
            println!(
                "       warm iter {}: J {:.9e} m_f {:.4} step {:.2e} defect {:.2e} vc {:.2e} rho {:+.3} ipm {}",
                h.iteration, h.cost, h.final_mass_kg, h.step, h.defect, h.virtual_control, h.rho, h.ipm_iterations
            );
        }
    }
}
