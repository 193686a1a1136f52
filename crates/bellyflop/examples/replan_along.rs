//! Re-plan from states along the paper's plan, every 0.5 s: iterations,
//! status and time of each warm re-plan (a diagnostic for the guidance loop).
//!
//! `cargo run --release -p bellyflop --example replan_along \[N\]`
use bellyflop::guidance::planner::{initial_state, Planner};
use bellyflop::method::observer::Silent;
use bellyflop::Case;

fn main() {
    let n = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(20);
    let mut s = Case::paper();
    s.scenario.discretization.nodes = n;
    let mut planner = Planner::new(s.scenario, s.solver);
    // The SCvx warm re-plan (the scenario's default method is direct).
    planner.method = bellyflop::Method::Scvx;
    let cold = planner.cold(&mut Silent);
    let plan = planner.plan.clone().expect("cold solve solved");
    println!("cold: {} its, tf {:.3} s", cold.iterations, cold.tf_s);
    let mut t = 0.5;
    while t < plan.tf_s() - 0.4 {
        planner.plan = Some(plan.clone());
        let state = initial_state(&plan.state_at(t));
        let sol = planner.replan(&state, t, &mut Silent).expect("valid");
        println!(
            "t {t:5.2}  its {:>3}  {:<13} {:6.1} ms  tf {:.3} (plan {:.3})  m_f {:+.2} kg  {}",
            sol.iterations,
            sol.status.as_str(),
            sol.solve_time_ms,
            sol.tf_s,
            plan.tf_s() - t,
            sol.final_mass_kg - cold.final_mass_kg,
            sol.message
        );
        t += 0.5;
    }
}
