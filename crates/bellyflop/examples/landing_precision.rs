//! Landing precision of the paper's case by re-propagation (Tables 4–5), for
//! each way of rebuilding the controls between nodes.
//!
//! `cargo run --release -p bellyflop --example landing_precision [paper] [N ...]`
//!
//! For each N it solves the paper's case, then integrates Eq. (1)–(3) with
//! DOP853 (tolerance 1e-10) and prints the miss at t_f for:
//! - linear and PCHIP interpolation of T and δ (nozzle `angle`), and of T and χ
//!   with δ integrated (nozzle `rate`);
//! - as a diagnostic, the collocation's own polynomials: the degree-(N−1)
//!   Lagrange interpolant of T through the collocation points and the degree-N
//!   interpolant of δ through all nodes, sampled finely (`lagrange`), and the
//!   same with the thrust clipped to [T_min, T_max] (`lagr-clip`).
//!
//! A first argument `paper` solves with the paper's formulation instead of the
//! default one.
use bellyflop::collocation::interpolation::Interpolation;
use bellyflop::method::observer::Silent;
use bellyflop::problem::dynamics::Model;
use bellyflop::verify::propagate::{
    integrate_controls, landing_error, propagate, Controls, NozzleModel, Options,
};
use bellyflop::Case;

fn main() {
    let paper = std::env::args().nth(1).as_deref() == Some("paper");
    let mut nodes: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    if nodes.is_empty() {
        nodes = vec![15, 20, 30, 40];
    }
    println!(
        "{:>3} {:<14} {:<8} {:>10} {:>11} {:>11} {:>12} {:>10} {:>10}  {:>6}",
        "N",
        "status",
        "controls",
        "nozzle",
        "pos [m]",
        "vel [m/s]",
        "pitch [deg]",
        "w [deg/s]",
        "dm [kg]",
        "steps"
    );
    for n in nodes {
        let mut s = Case::paper();
        s.scenario.discretization.nodes = n;
        if paper {
            s.solver.formulation = bellyflop::Formulation::Paper;
        }
        let sol = bellyflop::solve(&s.scenario, &s.solver, &mut Silent).expect("a planar scenario");
        for interpolation in [Interpolation::Linear, Interpolation::Pchip] {
            for nozzle in [NozzleModel::Angle, NozzleModel::Rate] {
                let opts = Options {
                    interpolation,
                    nozzle,
                    ..Options::default()
                };
                match propagate(&s.scenario, &sol, &opts) {
                    Ok(p) => {
                        let e = p.landing_error;
                        println!(
                            "{n:>3} {:<14} {:<8} {:>10} {:>11.5} {:>11.5} {:>12.5} {:>10.5} {:>10.3}  {:>6}",
                            sol.status.as_str(),
                            interpolation.as_str(),
                            format!("{nozzle:?}").to_lowercase(),
                            e.position_m,
                            e.velocity_mps,
                            e.pitch_rad.to_degrees(),
                            e.rate_radps.to_degrees(),
                            p.mass_error_kg,
                            p.stats.accepted_steps
                        );
                    }
                    Err(e) => println!("{n:>3} {interpolation:?} {nozzle:?}: {e}"),
                }
            }
        }
        // The collocation polynomials themselves, sampled on a fine grid and
        // integrated with linear interpolation between samples.
        let lgr = sol.mesh();
        let samples = 4000;
        let t: Vec<f64> = (0..=samples)
            .map(|i| sol.tf_s * i as f64 / samples as f64)
            .collect();
        let tau = |t: f64| 2.0 * t / sol.tf_s - 1.0;
        let model = Model::new(&s.scenario.vehicle, &s.scenario.environment);
        let delta: Vec<f64> = t
            .iter()
            .map(|&t| lgr.interpolate_states(&sol.delta_rad, tau(t)))
            .collect();
        for clip in [false, true] {
            let thrust: Vec<f64> = t
                .iter()
                .map(|&t| {
                    let v = lgr.interpolate_controls(&sol.thrust_n[..n], tau(t));
                    if clip {
                        v.clamp(model.min_thrust_n, model.max_thrust_n)
                    } else {
                        v
                    }
                })
                .collect();
            let controls = Controls {
                t_s: &t,
                thrust_n: &thrust,
                delta_rad: &delta,
                gimbal_rate_radps: &delta,
                initial: [
                    sol.x_m[0],
                    sol.z_m[0],
                    sol.vx_mps[0],
                    sol.vz_mps[0],
                    sol.theta_rad[0],
                    sol.pitch_rate_radps[0],
                    sol.mass_kg[0],
                ],
                interval_points: &[],
                collocation: false,
            };
            let opts = Options {
                interpolation: Interpolation::Linear,
                ..Options::default()
            };
            if let Ok((_, states, _, stats)) = integrate_controls(&model, &controls, &opts) {
                let end = *states.last().unwrap();
                let e = landing_error(&s.scenario, &end);
                let (tmin, tmax) = thrust
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                        (a.min(v), b.max(v))
                    });
                println!(
                    "{n:>3} {:<14} {:<8} {:>10} {:>11.5} {:>11.5} {:>12.5} {:>10.5} {:>10.3}  {:>6}   (T in [{:.4e}, {:.4e}] N)",
                    sol.status.as_str(),
                    if clip { "lagr-clip" } else { "lagrange" },
                    "angle",
                    e.position_m,
                    e.velocity_mps,
                    e.pitch_rad.to_degrees(),
                    e.rate_radps.to_degrees(),
                    end[6] - sol.final_mass_kg,
                    stats.accepted_steps,
                    tmin,
                    tmax
                );
            }
        }
    }
}
