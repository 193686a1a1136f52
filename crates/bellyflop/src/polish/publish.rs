//! A polished answer published in the solution: `controls_flown`, and the
//! node arrays resampled from an integration of those controls.
//!
//! The mesh keeps its nodes in τ; t_f becomes the flown controls' end, so
//! the node times scale to it. At each node time the states are those of
//! [`integrate_flown`] (DOP853, the landing check's integrator), T, δ and
//! χ = δ̇ those of the flown controls. The LCvx trajectory behind the node
//! arrays (warm starts, dense samples) is rebuilt from them: ω = ln m, and
//! the controls of the formulation (exact: σ = T/m, χ; paper: σ·sin(θ +
//! δ), σ·cos(θ + δ), σ, χ).

use crate::collocation::scaling::Scaling;
use crate::input::scenario::Scenario;
use crate::input::settings::Formulation;
use crate::polish::Polished;
use crate::problem::dynamics::{Model, NU_MAX, NX};
use crate::solution::{Checks, Solution};
use crate::verify::ode::{Dop853, IntegrationError};
use crate::verify::propagate::integrate_flown;

/// Replace `sol`'s answer by the polished one (module docs).
pub fn publish(
    scenario: &Scenario,
    sol: &mut Solution,
    polished: Polished,
) -> Result<(), IntegrationError> {
    let model = Model::new(&scenario.vehicle, &scenario.environment);
    let flown = polished.controls;
    let tf_s = flown.tf_s();
    let scale = tf_s / sol.tf_s;
    let t_s: Vec<f64> = sol.t_s.iter().map(|t| t * scale).collect();
    let s0 = scenario.initial.state_si();
    let y0 = [s0[0], s0[1], s0[2], s0[3], s0[4], s0[5], s0[6]];
    let (_, states) = integrate_flown(&model, &flown, &y0, &Dop853::default(), &t_s)?;
    let controls: Vec<(f64, f64, f64)> = t_s
        .iter()
        .map(|&t| flown.at(t).unwrap_or((f64::NAN, f64::NAN, f64::NAN)))
        .collect();
    let col = |c: usize| states.iter().map(|y| y[c]).collect::<Vec<f64>>();
    sol.x_m = col(0);
    sol.z_m = col(1);
    sol.vx_mps = col(2);
    sol.vz_mps = col(3);
    sol.theta_rad = col(4);
    sol.pitch_rate_radps = col(5);
    sol.mass_kg = col(6);
    sol.thrust_n = controls.iter().map(|c| c.0).collect();
    sol.delta_rad = controls.iter().map(|c| c.1).collect();
    sol.gimbal_rate_radps = controls.iter().map(|c| c.2).collect();
    sol.final_mass_kg = *sol.mass_kg.last().unwrap_or(&f64::NAN);
    sol.fuel_kg = sol.mass_kg.first().unwrap_or(&f64::NAN) - sol.final_mass_kg;
    sol.tf_s = tf_s;
    sol.t_s = t_s;
    rebuild_trajectory(sol);
    sol.checks = checks(scenario, &model, sol, &flown, &polished.final_state);
    sol.controls_flown = Some(flown);
    sol.polish = Some(polished.report);
    sol.optimality = Some(polished.optimality);
    Ok(())
}

/// The checks of the published answer, its own (not the collocation's it
/// started from): no relaxation and the thrust along the nozzle by
/// construction; the largest bound violation of the flown thrust, exactly
/// over every piece; as the "defect", the largest scaled difference at t_f
/// between the polish's own RK4 shot and the DOP853 flight of the node
/// arrays (how well the shot met the dynamics); no virtual control; the
/// lowest node above z_f.
fn checks(
    scenario: &Scenario,
    model: &Model,
    sol: &Solution,
    flown: &crate::flown::FlownControls,
    shot: &[f64; 7],
) -> Checks {
    let scale = Scaling::new(scenario, model, sol.formulation).x_scale;
    let flight =
        std::array::from_fn::<f64, 7, _>(|c| *sol.state_columns()[c].last().unwrap_or(&f64::NAN));
    let mut defect: f64 = (0..6)
        .map(|i| (shot[i] - flight[i]).abs() / scale[i])
        .fold(0.0, f64::max);
    defect = defect.max((shot[6].ln() - flight[6].ln()).abs() / scale[6]);
    let (lo, hi) = flown
        .pieces
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            let (a, b) = p.thrust_n.range();
            (lo.min(a), hi.max(b))
        });
    let z_f = scenario.terminal.z_m;
    Checks {
        relaxation_gap: 0.0,
        thrust_alignment_min: 1.0,
        thrust_bound_violation_n: (model.min_thrust_n - lo)
            .max(hi - model.max_thrust_n)
            .max(0.0),
        max_defect: defect,
        virtual_control: 0.0,
        min_altitude_margin_m: sol
            .z_m
            .iter()
            .map(|z| z - z_f)
            .fold(f64::INFINITY, f64::min),
    }
}

/// The LCvx trajectory of the resampled node arrays (module docs).
fn rebuild_trajectory(sol: &mut Solution) {
    let n = sol.t_s.len() - 1;
    let x: Vec<[f64; NX]> = (0..=n)
        .map(|k| {
            [
                sol.x_m[k],
                sol.z_m[k],
                sol.vx_mps[k],
                sol.vz_mps[k],
                sol.theta_rad[k],
                sol.pitch_rate_radps[k],
                sol.mass_kg[k].ln(),
                sol.delta_rad[k],
            ]
        })
        .collect();
    let u: Vec<[f64; NU_MAX]> = (0..n)
        .map(|k| {
            let sigma = sol.thrust_n[k] / sol.mass_kg[k];
            let chi = sol.gimbal_rate_radps[k];
            match sol.formulation {
                Formulation::Exact => [sigma, chi, 0.0, 0.0],
                Formulation::Paper | Formulation::Vector => {
                    let (s, c) = (sol.theta_rad[k] + sol.delta_rad[k]).sin_cos();
                    [sigma * s, sigma * c, sigma, chi]
                }
            }
        })
        .collect();
    sol.trajectory.x = x;
    sol.trajectory.u = u;
    sol.trajectory.tf_s = sol.tf_s;
}
