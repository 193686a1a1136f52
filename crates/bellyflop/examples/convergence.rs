//! Iteration counts and optima over N, t_f guesses and dispersed initial states.
//!
//! `cargo run --release -p bellyflop --example convergence [exact|paper|vector ...]`
use bellyflop::method::observer::Silent;
use bellyflop::{Case, Formulation};

fn report(label: &str, s: &Case) {
    let sol = s.solve(&mut Silent).expect("a planar scenario");
    println!(
        "{label:<44} {:<13} it {:>3}  t_f {:>8.4} s  m_f {:>9.1} kg  defect {:>7.1e}  gap {:>7.1e}  {:>6.0} ms",
        sol.status.as_str(),
        sol.iterations,
        sol.tf_s,
        sol.final_mass_kg,
        sol.checks.max_defect,
        sol.checks.relaxation_gap,
        sol.solve_time_ms
    );
}

fn main() {
    let mut forms: Vec<Formulation> = std::env::args()
        .skip(1)
        .map(|a| match a.as_str() {
            "paper" => Formulation::Paper,
            "vector" => Formulation::Vector,
            _ => Formulation::Exact,
        })
        .collect();
    if forms.is_empty() {
        forms = vec![Formulation::Exact, Formulation::Paper];
    }
    for &form in &forms {
        for n in [10, 15, 20, 30, 40] {
            for tf in [8.0, 12.0, 16.0, 20.0] {
                let mut s = Case::paper();
                s.solver.formulation = form;
                s.scenario.discretization.nodes = n;
                s.scenario.discretization.tf_guess_s = tf;
                report(&format!("{form:?} paper case N={n} tf_guess={tf}"), &s);
            }
        }
    }
    // x0, z0, vx0, vz0, theta0 [deg], m0
    for d in [
        [-200.0, 500.0, 15.0, -70.0, 80.0, 110_000.0],
        [200.0, 800.0, -15.0, -95.0, 95.0, 125_000.0],
        [0.0, 650.0, 0.0, -80.0, 88.0, 118_000.0],
        [150.0, 550.0, 10.0, -90.0, 85.0, 122_000.0],
        [-120.0, 750.0, -8.0, -75.0, 92.0, 112_000.0],
        [60.0, 700.0, 5.0, -88.0, 82.0, 124_000.0],
    ] {
        for &form in &forms {
            let mut s = Case::paper();
            s.scenario.initial.x_m = d[0];
            s.scenario.initial.z_m = d[1];
            s.scenario.initial.vx_mps = d[2];
            s.scenario.initial.vz_mps = d[3];
            s.scenario.initial.theta_deg = d[4];
            s.scenario.initial.mass_kg = d[5];
            s.scenario.discretization.final_mass_guess_kg = d[5] - 5_000.0;
            s.solver.formulation = form;
            report(&format!("{form:?} {d:?}"), &s);
        }
    }
}
