//! A fixed 1 ms RK4 of published flown controls, written from their format
//! alone (`crate::flown`'s docs): not the library's integrators.

// Each test binary that declares `mod common` compiles this; not each flies.
#![allow(dead_code)]

use bellyflop::flown::FlownControls;
use bellyflop::input::scenario::Scenario;
use bellyflop::problem::dynamics::{rhs_physical, Model};

/// Fly `flown` from the scenario's initial state, piece by piece, calling
/// `on_step(last, y)` after every step (`last`: the step that ends at t_f).
/// Returns the final state (x, z, Vx, Vz, θ, w, m).
pub fn fly(
    scenario: &Scenario,
    flown: &FlownControls,
    mut on_step: impl FnMut(bool, &[f64; 7]),
) -> [f64; 7] {
    let model = Model::new(&scenario.vehicle, &scenario.environment);
    let s0 = scenario.initial.state_si();
    let mut y = [s0[0], s0[1], s0[2], s0[3], s0[4], s0[5], s0[6]];
    let last = flown.pieces.len() - 1;
    for (j, piece) in flown.pieces.iter().enumerate() {
        let d = piece.t_end_s - piece.t_start_s;
        let steps = (d / 1e-3).ceil().max(1.0) as usize;
        let h = d / steps as f64;
        let f = |t: f64, y: &[f64; 7]| {
            let s = (t - piece.t_start_s) / d;
            rhs_physical(&model, y, piece.thrust_n.value(s), piece.delta_rad.value(s))
        };
        for k in 0..steps {
            let t = piece.t_start_s + k as f64 * h;
            let add = |y: &[f64; 7], k: &[f64; 7], c: f64| std::array::from_fn(|i| y[i] + c * k[i]);
            let k1 = f(t, &y);
            let k2 = f(t + 0.5 * h, &add(&y, &k1, 0.5 * h));
            let k3 = f(t + 0.5 * h, &add(&y, &k2, 0.5 * h));
            let k4 = f(t + h, &add(&y, &k3, h));
            for i in 0..7 {
                y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            on_step(j == last && k + 1 == steps, &y);
        }
    }
    y
}
