//! The costates along a polished shot, and the switching functions they
//! give (Pontryagin's necessary conditions).
//!
//! The polish solves max m(t_f) s.t. r̂(y(t_f)) = 0 with the terminal
//! multipliers μ of its last QP. With the Lagrangian of the end,
//! Λ = −m_f/M + Σ μ_i·r̂_i, the discrete adjoint of the RK4 steps,
//!
//!   λ_K = ∂Λ/∂y(t_f),   λ_k = (∂y_{k+1}/∂y_k)ᵀ·λ_{k+1},
//!
//! approximates the costate λ(t_k) of the continuous problem (scaled by
//! M), and with H = λᵀ·f(y, T, δ):
//!
//! - the thrust's switching function S_T = ∂H/∂T: the minimum principle
//!   wants T = T_max where S_T < 0 and T_min where S_T > 0, and S_T ≡ 0 on a
//!   singular (free) arc;
//! - S_δ = ∂H/∂δ, the rate of the nozzle angle's own costate
//!   (λ̇_δ = −S_δ); on an arc where δ is free of its bounds S_δ ≡ 0.
//!
//! The ground's path rows carry multipliers of their own, which this
//! leaves out: where the ground is active the costates are not these.

use num_dual::{Dual64, DualNum, DualSVec64};

use crate::polish::shooting::{rk4_step, Layout, SegmentControls};
use crate::problem::dynamics::{rhs_physical, Model};

type D7 = DualSVec64<7>;

/// The switching functions at the start of every RK4 step and at t_f.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Switching {
    pub t_s: Vec<f64>,
    /// The segment of each point (the last segment's for t_f).
    pub segment: Vec<usize>,
    /// The thrust applied at each point \[N\].
    pub thrust_n: Vec<f64>,
    /// S_T = ∂H/∂T.
    pub thrust: Vec<f64>,
    /// S_δ = ∂H/∂δ.
    pub delta: Vec<f64>,
}

/// One step of the shot ([`rk4_step`]) of segment j from y at s, in any
/// dual number of the state (the parameters are constants).
fn rk4<T: DualNum<Primitive = f64> + Copy>(
    model: &Model,
    layout: &Layout,
    p: &[f64],
    j: usize,
    mut y: [T; 7],
    s: f64,
    h: f64,
) -> [T; 7] {
    let c = SegmentControls::new(layout, p, j);
    let thrust = c.thrust.map_err(|t| t.map(T::from));
    rk4_step(
        model,
        &mut y,
        T::from(c.d),
        &c.delta.map(T::from),
        &thrust,
        s,
        h,
    );
    y
}

/// The switching functions along the shot of p from y0, with λ(t_f) =
/// `lambda_f` (module docs). The same steps as the polish's shot
/// ([`crate::polish::shooting`]).
pub fn switching(
    model: &Model,
    layout: &Layout,
    y0: [f64; 7],
    p: &[f64],
    lambda_f: [f64; 7],
) -> Switching {
    // Forward: the state at the start of every step, and where it is.
    let mut points: Vec<(usize, f64, f64, [f64; 7])> = Vec::new();
    let (mut y, mut t) = (y0, 0.0);
    for (j, seg) in layout.segments.iter().enumerate() {
        let h = 1.0 / seg.steps as f64;
        let d = p[layout.duration(j)];
        for k in 0..seg.steps {
            let s = k as f64 * h;
            points.push((j, s, t + s * d, y));
            y = rk4(model, layout, p, j, y, s, h);
        }
        t += d;
    }
    let last = layout.segments.len().saturating_sub(1);
    points.push((last, 1.0, t, y));
    // Backward: the discrete adjoint, and S_T, S_δ at every point.
    let n = points.len();
    let mut out = Switching {
        t_s: vec![0.0; n],
        segment: vec![0; n],
        thrust_n: vec![0.0; n],
        thrust: vec![0.0; n],
        delta: vec![0.0; n],
    };
    let mut lambda = lambda_f;
    for k in (0..n).rev() {
        let (j, s, t, y) = points[k];
        if k + 1 < n {
            let h = 1.0 / layout.segments[j].steps as f64;
            let yd: [D7; 7] = std::array::from_fn(|i| D7::from_re(y[i]).derivative(i));
            let next = rk4(model, layout, p, j, yd, s, h);
            lambda = std::array::from_fn(|c| {
                (0..7)
                    .map(|i| next[i].eps.0.as_ref().map_or(0.0, |e| e[c]) * lambda[i])
                    .sum()
            });
        }
        let (thrust, delta) = SegmentControls::new(layout, p, j).at(s);
        let h_of = |tn: Dual64, dn: Dual64| {
            let yd: [Dual64; 7] = y.map(Dual64::from);
            let f = rhs_physical(model, &yd, tn, dn);
            (0..7).map(|i| lambda[i] * f[i].eps).sum::<f64>()
        };
        out.t_s[k] = t;
        out.segment[k] = j;
        out.thrust_n[k] = thrust;
        out.thrust[k] = h_of(Dual64::from(thrust).derivative(), Dual64::from(delta));
        out.delta[k] = h_of(Dual64::from(thrust), Dual64::from(delta).derivative());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flown::legendre;
    use crate::input::scenario::Scenario;
    use crate::polish::arcs::ArcKind;
    use crate::polish::shooting::{fixture, sensitivity, NC};

    /// The discrete adjoint is the gradient of Λ: integrated against a
    /// change of the thrust on a free segment, ∫ S_T·P̃_k dt matches
    /// λ_fᵀ·∂y(t_f)/∂c_k of the forward sensitivities (checked against
    /// finite differences in [`crate::polish::shooting`]), coefficient by
    /// coefficient, to the trapezoid's accuracy.
    #[test]
    fn the_adjoint_is_the_gradient_of_the_end() {
        let s = Scenario::paper();
        let model = Model::new(&s.vehicle, &s.environment);
        let (lo, hi) = (model.min_thrust_n, model.max_thrust_n);
        let layout = Layout::new(vec![
            fixture::segment(ArcKind::Bound(hi), 40),
            fixture::segment(ArcKind::Free, 800),
        ]);
        let mut p = vec![0.0; layout.len];
        p[layout.duration(0)] = 1.0;
        p[layout.duration(1)] = 2.0;
        p[layout.delta(0)] = 0.05;
        p[layout.delta(1)] = 0.05;
        p[layout.delta(1) + 1] = 0.01;
        let t = layout.thrust(1).unwrap();
        p[t] = 0.5 * (lo + hi);
        p[t + 1] = 0.1 * (hi - lo);
        let y0 = fixture::Y0;
        let lambda_f = [0.3, -0.2, 0.1, 0.5, 20.0, -3.0, -1e-3];
        let sw = switching(&model, &layout, y0, &p, lambda_f);
        let sens = sensitivity(&model, &layout, y0, &p);
        // ∂Λ/∂c_k = ∫ S_T·P̃_k(s) dt over segment 1 (trapezoid on its steps).
        for k in 0..NC {
            let exact: f64 = (0..7).map(|i| lambda_f[i] * sens.d(i, t + k)).sum();
            let idx: Vec<usize> = (0..sw.t_s.len()).filter(|&i| sw.segment[i] == 1).collect();
            let (mut integral, mut size) = (0.0, 0.0);
            for w in idx.windows(2) {
                let (a, b) = (w[0], w[1]);
                let (sa, sb) = ((sw.t_s[a] - 1.0) / 2.0, (sw.t_s[b] - 1.0) / 2.0);
                let fa = sw.thrust[a] * legendre(sa)[k];
                let fb = sw.thrust[b] * legendre(sb)[k];
                integral += 0.5 * (fa + fb) * (sw.t_s[b] - sw.t_s[a]);
                size += 0.5 * (fa.abs() + fb.abs()) * (sw.t_s[b] - sw.t_s[a]);
            }
            // The last step of the segment ends at t_f, the final point.
            let (a, b) = (*idx.last().unwrap(), sw.t_s.len() - 1);
            if a != b {
                let (sa, sb) = ((sw.t_s[a] - 1.0) / 2.0, 1.0);
                integral += 0.5
                    * (sw.thrust[a] * legendre(sa)[k] + sw.thrust[b] * legendre(sb)[k])
                    * (sw.t_s[b] - sw.t_s[a]);
            }
            // The trapezoid's error, ~(h²/12)·∫|(S_T·P̃_k)''| with h =
            // 1/800 in s (about 2e-5 of ∫|S_T·P̃_k| dt for k = 3), against
            // that size: the cancellation of a high coefficient leaves the
            // integral itself far smaller.
            assert!(
                (integral - exact).abs() <= 1e-4 * size,
                "coefficient {k}: ∫S_T·P̃_k dt = {integral}, λ_fᵀ·∂y/∂c = {exact}"
            );
        }
    }
}
