//! The labelled set (issue 18, "What to build" 5; "Must show"): states known
//! to be feasible (solved by a method) or infeasible (certified by the
//! bound), in `tests/data/labelled_states.toml`. No feasible state is
//! labelled `infeasible` by `bellyflop::solve`, and every certified state is.

use bellyflop::feasibility::{self, Certificate};
use bellyflop::scvx::Silent;
use bellyflop::{Method, Scenario, Solution, Status};
use serde::Deserialize;

const DATA: &str = include_str!("data/labelled_states.toml");

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
enum Label {
    Feasible,
    Infeasible,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
enum Set {
    Envelope,
    Outside,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Entry {
    name: String,
    label: Label,
    set: Set,
    /// The method whose `solved` answer is the evidence (feasible states),
    /// and its number of collocation points.
    method: Option<Method>,
    nodes: Option<usize>,
    x_m: f64,
    z_m: f64,
    vx_mps: f64,
    vz_mps: f64,
    theta_deg: f64,
    mass_kg: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Data {
    state: Vec<Entry>,
}

fn entries() -> Vec<Entry> {
    toml::from_str::<Data>(DATA)
        .expect("labelled_states.toml parses")
        .state
}

/// The paper's case from the entry's initial state.
fn scenario(e: &Entry, method: Method) -> Scenario {
    let mut s = Scenario::paper();
    s.discretization.nodes = e.nodes.unwrap_or(20);
    s.initial.x_m = e.x_m;
    s.initial.z_m = e.z_m;
    s.initial.vx_mps = e.vx_mps;
    s.initial.vz_mps = e.vz_mps;
    s.initial.theta_deg = e.theta_deg;
    s.initial.mass_kg = e.mass_kg;
    s.discretization.final_mass_guess_kg = (e.mass_kg - 5000.0).max(s.vehicle.dry_mass_kg);
    s.solver.method = method;
    s.validate()
        .unwrap_or_else(|err| panic!("{}: {err}", e.name));
    s
}

fn in_envelope(e: &Entry) -> bool {
    e.x_m.abs() <= 200.0
        && (500.0..=800.0).contains(&e.z_m)
        && e.vx_mps.abs() <= 15.0
        && (-95.0..=-70.0).contains(&e.vz_mps)
        && (80.0..=95.0).contains(&e.theta_deg)
        && (110_000.0..=125_000.0).contains(&e.mass_kg)
}

/// The set is as documented: at least 40 states, both labels and both sets
/// well represented, and `set` matches the envelope's bounds.
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
                let bound = feasibility::stopping_bound(&s);
                assert!(
                    feasibility::certify(&s).is_none(),
                    "{}: a feasible state is certified infeasible ({bound:?})",
                    e.name
                );
                let sol = bellyflop::solve(&s, &mut Silent);
                assert_ne!(sol.status, Status::Infeasible, "{}", e.name);
                assert_eq!(
                    sol.status,
                    Status::Solved,
                    "{} ({method:?}, N = {}): {}",
                    e.name,
                    s.discretization.nodes,
                    sol.message
                );
            }
            Label::Infeasible => {
                for method in [Method::Direct, Method::Scvx] {
                    let s = scenario(&e, method);
                    let certificate = feasibility::certify(&s);
                    assert!(
                        matches!(
                            certificate,
                            Some(Certificate::Altitude(_) | Certificate::Propellant(_))
                        ),
                        "{}: not certified ({:?})",
                        e.name,
                        feasibility::stopping_bound(&s)
                    );
                    let sol = bellyflop::solve(&s, &mut Silent);
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

fn describe(sol: &Solution) -> String {
    let short: String = sol.message.chars().take(90).collect();
    format!(
        "{:<13} {:>4} it  {short}",
        sol.status.as_str(),
        sol.iterations
    )
}

/// How the labels were made: each state's bound, and what both methods do
/// with it on their own (no certificate, no accuracy check) at N = 20 and
/// 40, with the re-integrated landing error. Run with `--ignored --nocapture`
/// (about 2 minutes).
#[test]
#[ignore]
fn report() {
    for e in entries() {
        let s = scenario(&e, Method::Direct);
        let bound = feasibility::stopping_bound(&s);
        println!(
            "{:<22} {:?} {:?}: bound {} m of {:.0} m, certified {}",
            e.name,
            e.label,
            e.set,
            bound.map_or("-".into(), |b| format!("{:.1}", b.distance_m)),
            e.z_m,
            feasibility::certify(&s).is_some()
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
            s.discretization.nodes = nodes;
            let alone = match method {
                Method::Direct => bellyflop::direct::solve(&s, &mut Silent),
                Method::Scvx => bellyflop::scvx::solve(&s, &mut Silent),
            };
            let landing = bellyflop::propagate::propagate(&s, &alone, &Default::default())
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
