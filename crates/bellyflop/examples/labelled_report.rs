//! How the labelled set (`crates/bellyflop/tests/data/labelled_states.toml`)
//! was made: each state's stopping bound, and what both methods do with it
//! on their own (no certificate, no accuracy check) at N = 20 and 40, with
//! the re-integrated landing error. About 2 minutes.
//!
//!     cargo run --release -p bellyflop --example labelled_report

#[path = "../tests/common/labelled.rs"]
mod labelled;

use bellyflop::method::observer::Silent;
use bellyflop::problem::feasibility;
use bellyflop::Method;
use labelled::*;

fn main() {
    for e in entries() {
        let s = scenario(&e, Method::Direct);
        let bound = feasibility::stopping_bound(&s.scenario);
        println!(
            "{:<22} {:?} {:?}: bound {} m of {:.0} m, certified {}",
            e.name,
            e.label,
            e.set,
            bound.map_or("-".into(), |b| format!("{:.1}", b.distance_m)),
            e.z_m,
            feasibility::certify(&s.scenario).is_some()
        );
        for (method, nodes) in [
            (Method::Direct, 20),
            (Method::Scvx, 20),
            (Method::Direct, 40),
            (Method::Scvx, 40),
        ] {
            if nodes != 20 && e.label == Label::Infeasible {
                continue;
            }
            let mut s = scenario(&e, method);
            s.scenario.discretization.nodes = nodes;
            let alone = match method {
                Method::Direct => {
                    bellyflop::method::direct::solve(&s.scenario, &s.solver, &mut Silent)
                }
                Method::Scvx => bellyflop::method::scvx::solve(&s.scenario, &s.solver, &mut Silent),
            };
            let landing =
                bellyflop::verify::propagate::propagate(&s.scenario, &alone, &Default::default())
                    .map(|p| {
                        format!(
                            "{:.2} m {:.2} m/s",
                            p.landing_error.position_m, p.landing_error.velocity_mps
                        )
                    })
                    .unwrap_or_else(|err| err.to_string());
            println!(
                "    {:<6} N = {nodes} alone: {}  landing {landing}",
                method.as_str(),
                describe(&alone)
            );
        }
    }
}
