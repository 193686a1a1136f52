//! The labelled set (issue 18, "What to build" 5; "Must show"): states known
//! to be feasible (solved by a method) or infeasible (certified by the
//! bound), in `tests/data/labelled_states.toml`. No feasible state is
//! labelled `infeasible` by `bellyflop::solve`, and every certified state is.

use bellyflop::method::observer::Silent;
use bellyflop::problem::feasibility::{self, Certificate};
use bellyflop::{Method, Status};

mod common;
use common::labelled::*;

#[test]
fn the_set_is_large_and_mixed() {
    let all = entries();
    assert!(all.len() >= 40, "{} states", all.len());
    let count = |l: Label, s: Set| all.iter().filter(|e| e.label == l && e.set == s).count();
    assert!(count(Label::Feasible, Set::Envelope) >= 15);
    assert!(count(Label::Feasible, Set::Outside) >= 5);
    assert!(count(Label::Infeasible, Set::Outside) >= 15);
    for e in &all {
        assert_eq!(
            e.set == Set::Envelope,
            in_envelope(e),
            "{}: set {:?}",
            e.name,
            e.set
        );
        assert_eq!(
            e.method.is_some() && e.nodes.is_some(),
            e.label == Label::Feasible,
            "{}: a feasible state names the method and mesh that solved it",
            e.name
        );
    }
}

/// Every label holds: a feasible state is not certified and its method
/// solves it (so `bellyflop::solve` does not call it `infeasible`); an
/// infeasible one is certified, and `bellyflop::solve` reports it
/// `infeasible` with the certificate, without iterating.
#[test]
fn every_label_holds() {
    for e in entries() {
        match e.label {
            Label::Feasible => {
                let method = e.method.expect("checked by the_set_is_large_and_mixed");
                let s = scenario(&e, method);
                let bound = feasibility::stopping_bound(&s.scenario);
                assert!(
                    feasibility::certify(&s.scenario).is_none(),
                    "{}: a feasible state is certified infeasible ({bound:?})",
                    e.name
                );
                let sol = bellyflop::solve(&s.scenario, &s.solver, &mut Silent)
                    .expect("a planar scenario");
                assert_ne!(sol.status, Status::Infeasible, "{}", e.name);
                assert_eq!(
                    sol.status,
                    Status::Solved,
                    "{} ({method:?}, N = {}): {}",
                    e.name,
                    s.scenario.discretization.nodes,
                    sol.message
                );
            }
            Label::Infeasible => {
                for method in [Method::Direct, Method::Scvx] {
                    let s = scenario(&e, method);
                    let certificate = feasibility::certify(&s.scenario);
                    assert!(
                        matches!(
                            certificate,
                            Some(Certificate::Altitude(_) | Certificate::Propellant(_))
                        ),
                        "{}: not certified ({:?})",
                        e.name,
                        feasibility::stopping_bound(&s.scenario)
                    );
                    let sol = bellyflop::solve(&s.scenario, &s.solver, &mut Silent)
                        .expect("a planar scenario");
                    assert_eq!(sol.status, Status::Infeasible, "{}", e.name);
                    assert_eq!(sol.iterations, 0, "{}: solved although certified", e.name);
                    assert_eq!(sol.method, method);
                    assert!(
                        sol.message.starts_with("no trajectory exists (certified"),
                        "{}: {}",
                        e.name,
                        sol.message
                    );
                    assert_eq!(sol.status.exit_code(), 3);
                }
            }
        }
    }
}
