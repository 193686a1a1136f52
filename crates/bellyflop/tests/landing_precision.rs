//! Landing precision by re-propagation (issue 3): the paper's case at N = 20,
//! integrated through Eq. (1)–(3) with the optimized controls, lands within
//! 2 m and 0.5 m/s of the target.

use bellyflop::collocation::interpolation::Interpolation;
use bellyflop::method::observer::Silent;
use bellyflop::verify::propagate::{propagate, Options, Propagation};
use bellyflop::{Case, Formulation, Status};

const MAX_POSITION_M: f64 = 2.0;
const MAX_VELOCITY_MPS: f64 = 0.5;

fn propagate_paper_case(form: Formulation, interpolation: Interpolation) -> Propagation {
    let mut s = Case::paper();
    s.scenario.discretization.nodes = 20;
    s.solver.formulation = form;
    let sol = s.solve(&mut Silent).expect("a planar scenario");
    assert_eq!(sol.status, Status::Solved, "{form:?}: {}", sol.message);
    let opts = Options {
        interpolation,
        ..Options::default()
    };
    let p = propagate(&s.scenario, &sol, &opts).expect("the propagation runs");
    // The mass equation does not depend on the attitude: the propagated fuel
    // agrees with the optimized one to well under a kilogram.
    assert!(
        p.mass_error_kg.abs() < 1.0,
        "mass error {}",
        p.mass_error_kg
    );
    assert_eq!(*p.t_s.last().unwrap(), sol.tf_s);
    for t in &sol.t_s {
        assert!(p.t_s.contains(t), "node time {t} not a step end");
    }
    p
}

fn assert_lands(p: &Propagation, what: &str) {
    let e = p.landing_error;
    assert!(
        e.position_m <= MAX_POSITION_M && e.velocity_mps <= MAX_VELOCITY_MPS,
        "{what}: lands {:.4} m / {:.4} m/s from the target (limits {MAX_POSITION_M} m / {MAX_VELOCITY_MPS} m/s); {e:?}",
        e.position_m,
        e.velocity_mps
    );
}

/// The paper's own formulation (P4, Eq. 26–30), whose N = 20 optimum matches the
/// CasADi + IPOPT reference: 0.81 m / 0.32 m/s with PCHIP controls
/// (the paper's Table 4: 0.77127 m / 0.30135 m/s).
#[test]
fn paper_formulation_n20_lands_within_2m_and_half_mps() {
    let p = propagate_paper_case(Formulation::Paper, Interpolation::default());
    assert_lands(&p, "paper formulation, PCHIP");
}

/// The default (exact) formulation, whose relaxed first phase lands on the
/// reference optimum at N = 20. (The exact form solved directly stops 0.6 kg
/// short and misses by 1.32 m / 0.65 m/s; see the `propagate` module docs.)
#[test]
fn default_formulation_n20_lands_within_2m_and_half_mps() {
    let p = propagate_paper_case(Formulation::Exact, Interpolation::default());
    assert_lands(&p, "exact formulation, PCHIP");
}
