//! The relative error of a solution on each mesh interval: the estimate that
//! hp mesh refinement acts on (issue 16; Patterson, Hager & Rao, "A ph mesh
//! refinement method for optimal control", OCAM 2015, §3).
//!
//! On interval k, with its n_k collocation points:
//! - the solution's state polynomial X(τ) is the degree-n_k interpolant
//!   through the interval's n_k + 1 nodes;
//! - X̃(τ) integrates the dynamics (Eq. 1–3) from X at the interval's first
//!   node with the controls as they are flown when the landing error is
//!   measured ([`crate::verify::propagate`]'s default nozzle model): the thrust of
//!   [`crate::collocation::control_profile`] (within its bounds, each collocation point's
//!   impulse kept; on interior arcs the interpolant through the collocation
//!   points), and the nozzle angle δ as its state polynomial, clamped to
//!   ±δ_max (its own error is that clamp), by DOP853 at tolerance 1e-10,
//!   stopping at the thrust's jumps. δ's polynomial has χ's interpolant as
//!   its derivative, so integrating δ̇ = χ with χ's interpolant would give
//!   it back; with χ held within its bounds instead, the estimate read the
//!   χ switches' placement inside their quadrature cells (about 1e-3 rad of
//!   δ, the worst state on 97 of 101 refined envelope states) that the
//!   landing does not feel;
//! - they are compared at the n_k + 1 LGR points of one degree higher,
//!   mapped to the interval, and at its end. The error is relative, as
//!   GPOPS-II's is:
//!
//! ```text
//! e_k = max over those points and the 8 states i of |X̃_i − X_i| / (1 + max_j |X_i(τ_j)|)
//! ```
//!
//! with the maximum over all the nodes of the trajectory.

use crate::collocation::control_profile::Profile;
use crate::collocation::radau::{interpolate, Lgr};
use crate::input::scenario::Scenario;
use crate::problem::dynamics::{self, Model};
pub use crate::solution::IntervalError;
use crate::solution::{Solution, STATE_COLUMN_NAMES};
use crate::verify::ode::{Dop853, IntegrationError, Stats};

/// The estimate on every interval of `solution`'s mesh ([`Solution::mesh`]),
/// with the vehicle model of `scenario`.
pub fn estimate(
    scenario: &Scenario,
    solution: &Solution,
) -> Result<Vec<IntervalError>, IntegrationError> {
    let s = solution;
    let n = s.nodes;
    let states = s.state_columns();
    if let Err(e) = crate::input::validate::mesh_layout("mesh_layout", &s.mesh) {
        return Err(IntegrationError::BadSolution(format!(
            "a mesh error estimate needs the solution's mesh: {e}"
        )));
    }
    if n < 1
        || s.mesh.nodes() != n
        || states.iter().any(|v| v.len() != n + 1)
        || s.thrust_n.len() < n
        || s.gimbal_rate_radps.len() < n
        || !(s.tf_s.is_finite() && s.tf_s > 0.0)
    {
        return Err(IntegrationError::BadSolution(format!(
            "a mesh error estimate needs N + 1 = {} nodes of every state, N controls and t_f > 0",
            n + 1
        )));
    }
    let mesh = s.mesh();
    let model = Model::new(&scenario.vehicle, &scenario.environment);
    let scale: [f64; 8] =
        std::array::from_fn(|i| 1.0 + states[i].iter().fold(0.0f64, |m, v| m.max(v.abs())));
    let integrator = Dop853::default();
    let tf = s.tf_s;
    let time = |tau: f64| 0.5 * (tau + 1.0) * tf;
    // The controls as flown (clamped, impulse kept: crate::collocation::control_profile).
    let t_nodes: Vec<f64> = mesh.nodes.iter().map(|&tau| time(tau)).collect();
    let delta_max = model.max_gimbal_rad;
    let thrust = Profile::new(
        &t_nodes,
        &s.mesh.points,
        &s.thrust_n,
        model.min_thrust_n,
        model.max_thrust_n,
    );
    let mut stops = Vec::new();
    let mut out = Vec::with_capacity(mesh.intervals.len());
    for (k, iv) in mesh.intervals.iter().enumerate() {
        let nodes = &mesh.nodes[iv.start..=iv.start + iv.points];
        let state_poly = |i: usize, tau: f64| {
            interpolate(
                nodes,
                &iv.lgr.bary,
                &states[i][iv.start..=iv.start + iv.points],
                tau,
            )
        };
        // The points of comparison: one degree higher, and the interval's end.
        let half = 0.5 * (iv.tau_hi - iv.tau_lo);
        let check = Lgr::new(iv.points + 1);
        let taus: Vec<f64> = check
            .nodes
            .iter()
            .map(|&r| iv.tau_lo + half * (r + 1.0))
            .skip(1) // τ_lo itself: the integration starts there.
            .collect();
        // The nozzle as flown: δ's polynomial within its bounds.
        let delta = |tau: f64| state_poly(7, tau).clamp(-delta_max, delta_max);
        let rhs = |t: f64, y: &[f64; 7]| -> [f64; 7] {
            dynamics::rhs_physical(&model, y, thrust.at(t), delta(2.0 * t / tf - 1.0))
        };
        let mut y: [f64; 7] = std::array::from_fn(|i| states[i][iv.start]);
        let (mut t, mut h, mut stats) = (time(iv.tau_lo), 0.0, Stats::default());
        let (mut worst, mut worst_state) = (0.0f64, 0usize);
        for &tau in &taus {
            let t1 = time(tau);
            // Stop at the controls' jumps rather than step across them.
            Profile::stops(t, t1, &[&thrust], &mut stops);
            for span in stops.windows(2) {
                if span[1] > span[0] {
                    y = integrator.integrate(
                        &rhs,
                        span[0],
                        y,
                        span[1],
                        &mut h,
                        &mut stats,
                        |_, _| {},
                    )?;
                }
            }
            t = t1;
            for i in 0..8 {
                let flown = if i < 7 { y[i] } else { delta(tau) };
                let e = (flown - state_poly(i, tau)).abs() / scale[i];
                if e > worst || !e.is_finite() {
                    worst = e;
                    worst_state = i;
                }
            }
        }
        out.push(IntervalError {
            interval: k,
            points: iv.points,
            t_start_s: time(iv.tau_lo),
            t_end_s: time(iv.tau_hi),
            relative_error: worst,
            worst_state: STATE_COLUMN_NAMES[worst_state],
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collocation::mesh::Mesh;
    use crate::input::scenario::Scenario;

    /// A trajectory whose controls are linear in time (so that every mesh's
    /// control polynomials are exact), integrated accurately: the "solution"
    /// samples it at the mesh's nodes, so its only error is the state
    /// polynomials' interpolation error.
    fn exact(n: usize, intervals: usize) -> (Scenario, Solution, Vec<f64>, Vec<[f64; 8]>) {
        known(n, intervals, None)
    }

    /// [`exact`], or with `switch_s` the thrust bang–bang instead, T_min
    /// then T_max from `switch_s` on; its value at each collocation point
    /// is then its mean over the point's quadrature cell (the impulse a
    /// collocation answer gives the point), which the flown profile
    /// reproduces exactly.
    fn known(
        n: usize,
        intervals: usize,
        switch_s: Option<f64>,
    ) -> (Scenario, Solution, Vec<f64>, Vec<[f64; 8]>) {
        let mut s = Scenario::paper();
        s.discretization.nodes = n;
        s.discretization.intervals = intervals;
        let model = Model::new(&s.vehicle, &s.environment);
        let tf = 11.5;
        let (t_min, t_max) = (model.min_thrust_n, model.max_thrust_n);
        let thrust = |t: f64| match switch_s {
            None => 1.2e6 + 4.0e4 * t,
            Some(ts) if t < ts => t_min,
            Some(_) => t_max,
        };
        let chi = |t: f64| 0.02 - 0.003 * t;
        let y0 = s.initial.state_si();
        let rhs = |t: f64, y: &[f64; 8]| -> [f64; 8] {
            let p = [y[0], y[1], y[2], y[3], y[4], y[5], y[6]];
            let f = dynamics::rhs_physical(&model, &p, thrust(t), y[7]);
            [f[0], f[1], f[2], f[3], f[4], f[5], f[6], chi(t)]
        };
        let tight = Dop853 {
            rtol: 1e-13,
            atol: 1e-13,
            ..Dop853::default()
        };
        let mesh = Mesh::uniform(n, intervals);
        let t_nodes: Vec<f64> = (0..=n).map(|k| mesh.time_s(k, tf)).collect();
        // Dense samples for the independent measure, node times among them.
        let (mut ts, mut ys) = (vec![0.0], vec![y0]);
        let (mut y, mut h, mut stats) = (y0, 0.0, Stats::default());
        for w in t_nodes.windows(2) {
            for j in 1..=20 {
                let t1 = w[0] + (w[1] - w[0]) * j as f64 / 20.0;
                let t0 = *ts.last().unwrap();
                // Stop at the switch, not across it.
                let mid = switch_s.filter(|&x| x > t0 && x < t1);
                for (a, b) in [(t0, mid.unwrap_or(t0)), (mid.unwrap_or(t0), t1)] {
                    if b > a {
                        y = tight
                            .integrate(rhs, a, y, b, &mut h, &mut stats, |_, _| {})
                            .unwrap();
                    }
                }
                ts.push(t1);
                ys.push(y);
            }
        }
        let at_nodes: Vec<[f64; 8]> = (0..=n).map(|k| ys[20 * k]).collect();
        let col = |i: usize| at_nodes.iter().map(|y| y[i]).collect::<Vec<f64>>();
        // A solution of the right shape, its arrays then replaced.
        let mut sol = crate::solve(
            &s,
            &Default::default(),
            &mut crate::method::observer::Silent,
        )
        .expect("a planar scenario");
        assert_eq!((sol.nodes, sol.intervals), (n, intervals));
        sol.tf_s = tf;
        sol.t_s = t_nodes.clone();
        sol.x_m = col(0);
        sol.z_m = col(1);
        sol.vx_mps = col(2);
        sol.vz_mps = col(3);
        sol.theta_rad = col(4);
        sol.pitch_rate_radps = col(5);
        sol.mass_kg = col(6);
        sol.delta_rad = col(7);
        sol.thrust_n = t_nodes.iter().map(|&t| thrust(t)).collect();
        if let Some(ts) = switch_s {
            // Cell i of interval k starts at τ_lo + Σ_{j<i} w_j.
            for iv in &mesh.intervals {
                let mut at = mesh.time_s(iv.start, tf);
                for i in iv.start..iv.start + iv.points {
                    let end = at + 0.5 * tf * mesh.weights[i];
                    let before = (ts.clamp(at, end) - at) / (end - at);
                    sol.thrust_n[i] = before * t_min + (1.0 - before) * t_max;
                    at = end;
                }
            }
        }
        sol.gimbal_rate_radps = t_nodes.iter().map(|&t| chi(t)).collect();
        (s, sol, ts, ys)
    }

    /// The largest relative interpolation error of the node polynomials on
    /// each interval, measured on the dense samples: what the estimate
    /// approximates.
    fn dense_error(sol: &Solution, ts: &[f64], ys: &[[f64; 8]]) -> Vec<f64> {
        let mesh = sol.mesh();
        let states = sol.state_columns();
        let mut out = vec![0.0f64; mesh.intervals.len()];
        for (t, y) in ts.iter().zip(ys) {
            let tau = 2.0 * t / sol.tf_s - 1.0;
            let k = mesh.interval_of(tau);
            for i in 0..8 {
                let scale = 1.0 + states[i].iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let e = (mesh.interpolate_states(states[i], tau) - y[i]).abs() / scale;
                out[k] = out[k].max(e);
            }
        }
        out
    }

    #[test]
    fn estimate_matches_the_interpolation_error_of_a_known_trajectory() {
        for (n, intervals) in [(6, 1), (8, 2), (12, 4)] {
            let (s, sol, ts, ys) = exact(n, intervals);
            let est = estimate(&s, &sol).expect("estimate");
            let dense = dense_error(&sol, &ts, &ys);
            assert_eq!(est.len(), intervals);
            for (e, d) in est.iter().zip(&dense) {
                assert!(
                    *d > 1e-9,
                    "{n}/{intervals}: a coarse mesh has a visible error ({d:e})"
                );
                let ratio = e.relative_error / d;
                assert!(
                    (0.2..=1.5).contains(&ratio),
                    "{n}/{intervals} interval {}: estimate {:e} against {d:e}",
                    e.interval,
                    e.relative_error
                );
            }
        }
    }

    /// With the thrust switching inside a quadrature cell, the estimate
    /// integrates the bang–bang thrust the collocation values stand for
    /// (control_profile), so it measures the state polynomials'
    /// interpolation error as on smooth controls, and on the interval with
    /// the switch too.
    #[test]
    fn estimate_matches_the_interpolation_error_across_a_thrust_switch() {
        let (n, intervals) = (12, 3);
        let mesh = Mesh::uniform(n, intervals);
        // Inside the third cell of interval 1, 30 % of the way in.
        let iv = &mesh.intervals[1];
        let cell_lo: f64 = iv.tau_lo + mesh.weights[iv.start..iv.start + 2].iter().sum::<f64>();
        let tau = cell_lo + 0.3 * mesh.weights[iv.start + 2];
        let switch_s = 0.5 * (tau + 1.0) * 11.5;
        let (s, sol, ts, ys) = known(n, intervals, Some(switch_s));
        assert!(sol.thrust_n[iv.start + 2] > sol.thrust_n[iv.start + 1]);
        assert!(sol.thrust_n[iv.start + 2] < sol.thrust_n[iv.start + 3]);
        let est = estimate(&s, &sol).expect("estimate");
        let dense = dense_error(&sol, &ts, &ys);
        for (e, d) in est.iter().zip(&dense) {
            let ratio = e.relative_error / d;
            assert!(
                (0.2..=1.5).contains(&ratio),
                "interval {}: estimate {:e} against {d:e}",
                e.interval,
                e.relative_error
            );
        }
        // Sharper: at the estimate's own points of comparison the true
        // trajectory (integrated from t = 0, stopping at the switch) against
        // the state polynomials gives the estimate itself; the thrust
        // polynomial through the points (the estimate before
        // control_profile) read 2.9e-2 on interval 1 against the truth's
        // 1.5e-2.
        let model = Model::new(&s.vehicle, &s.environment);
        let tight = Dop853 {
            rtol: 1e-13,
            atol: 1e-13,
            ..Dop853::default()
        };
        let (t_min, t_max) = (model.min_thrust_n, model.max_thrust_n);
        let rhs = |t: f64, y: &[f64; 8]| -> [f64; 8] {
            let p = [y[0], y[1], y[2], y[3], y[4], y[5], y[6]];
            let thrust = if t < switch_s { t_min } else { t_max };
            let f = dynamics::rhs_physical(&model, &p, thrust, y[7]);
            [f[0], f[1], f[2], f[3], f[4], f[5], f[6], 0.02 - 0.003 * t]
        };
        let truth = |t: f64| {
            let (mut y, mut h, mut stats) = (s.initial.state_si(), 0.0, Stats::default());
            let mid = switch_s.min(t);
            for (a, b) in [(0.0, mid), (mid, t)] {
                if b > a {
                    y = tight
                        .integrate(rhs, a, y, b, &mut h, &mut stats, |_, _| {})
                        .unwrap();
                }
            }
            y
        };
        let states = sol.state_columns();
        let scale: Vec<f64> = (0..8)
            .map(|i| 1.0 + states[i].iter().fold(0.0f64, |m, v| m.max(v.abs())))
            .collect();
        let iv = &mesh.intervals[1];
        let half = 0.5 * (iv.tau_hi - iv.tau_lo);
        let check = Lgr::new(iv.points + 1);
        let mut worst = 0.0f64;
        for r in check.nodes.iter().skip(1) {
            let tau = iv.tau_lo + half * (r + 1.0);
            let y = truth(0.5 * (tau + 1.0) * 11.5);
            for i in 0..7 {
                let e = (y[i] - mesh.interpolate_states(states[i], tau)).abs() / scale[i];
                worst = worst.max(e);
            }
        }
        let got = est[1].relative_error;
        assert!(
            (got - worst).abs() <= 1e-3 * worst,
            "interval 1: estimate {got:e} against the truth's {worst:e}"
        );
    }

    #[test]
    fn estimate_falls_spectrally_with_the_degree() {
        let worst = |n: usize| {
            let (s, sol, _, _) = exact(n, 2);
            estimate(&s, &sol)
                .expect("estimate")
                .iter()
                .fold(0.0f64, |m, e| m.max(e.relative_error))
        };
        // Two intervals of 4, 6 and 8 points.
        let (e8, e12, e16) = (worst(8), worst(12), worst(16));
        assert!(
            e12 < 0.2 * e8 && e16 < 0.2 * e12 && e16 < 0.02 * e8,
            "8 points: {e8:e}, 12: {e12:e}, 16: {e16:e}"
        );
    }

    /// A node moved off the trajectory shows in its interval, and only there.
    #[test]
    fn a_perturbed_node_flags_its_interval() {
        let (s, mut sol, _, _) = exact(16, 4);
        let clean = estimate(&s, &sol).expect("estimate");
        // Node 9 is interior to interval 2 (nodes 8..=12).
        sol.z_m[9] += 20.0;
        let hit = estimate(&s, &sol).expect("estimate");
        assert_eq!(hit[2].worst_state, "z_m");
        assert!(
            hit[2].relative_error > 10.0 * clean[2].relative_error,
            "{:e} against {:e}",
            hit[2].relative_error,
            clean[2].relative_error
        );
        for k in [0, 1, 3] {
            assert_eq!(
                hit[k].relative_error, clean[k].relative_error,
                "interval {k}"
            );
        }
    }

    #[test]
    fn a_solution_without_nodes_is_an_error() {
        let s = Scenario::paper();
        let mut sol = crate::solve(
            &s,
            &Default::default(),
            &mut crate::method::observer::Silent,
        )
        .expect("a planar scenario");
        sol.z_m.pop();
        assert!(matches!(
            estimate(&s, &sol),
            Err(IntegrationError::BadSolution(_))
        ));
        sol.z_m.push(0.0);
        sol.tf_s = f64::NAN;
        assert!(matches!(
            estimate(&s, &sol),
            Err(IntegrationError::BadSolution(_))
        ));
    }
}
