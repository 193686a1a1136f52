//! Single shooting of the flown controls, with exact sensitivities.
//!
//! The polish's decision vector p holds, per segment j of [0, t_f]: its
//! duration d_j \[s\], the four shifted-Legendre coefficients of δ \[rad\],
//! and, on a segment where the thrust is free, the four of T \[N\]
//! ([`crate::flown`]). In the segment's normalized time s ∈ [0, 1] the
//! dynamics of Eq. (1)–(3) read dy/ds = d_j·f(y, T(s), δ(s))
//! ([`crate::problem::dynamics::rhs_physical`]), integrated by `steps` classical RK4 steps
//! of size 1/steps. The step count of a segment is fixed for a polish, so
//! that the end state is a smooth function of p; the steps stay below
//! [`STEP_S`] on the longest duration the segment may take.
//!
//! The derivatives come from forward-mode automatic differentiation through
//! the RK4 steps (num-dual): per segment the end state's Jacobian against
//! its start state, Φ_j (7 × 7), and against its own parameters, G_j. The
//! chain ∂y(t_f)/∂p_j = Φ_J ⋯ Φ_{j+1}·G_j then costs 7 × 7 products.

use num_dual::{DualNum, DualSVec64};

use crate::flown::{legendre, DEGREE};
use crate::polish::arcs::ArcKind;
use crate::problem::dynamics::{rhs_physical, Model};

/// Largest RK4 step in time \[s\]. The landing check integrates the same
/// controls by DOP853 at 1e-10; at 0.05 s the two ends agree to ~1e-4 m on
/// the paper's case.
pub const STEP_S: f64 = 0.05;

/// Coefficients per polynomial.
pub const NC: usize = DEGREE + 1;
/// Most parameters of one segment: d, δ's coefficients, T's.
pub const MAX_SEGMENT_PARAMS: usize = 1 + 2 * NC;
/// Dual dimension: 7 start states and a segment's parameters.
const ND: usize = 7 + MAX_SEGMENT_PARAMS;
type D = DualSVec64<ND>;

/// One segment of the polish.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// The thrust on the segment: a bound, or free (four coefficients).
    pub thrust: ArcKind,
    /// RK4 steps.
    pub steps: usize,
    /// Bounds of the duration \[s\].
    pub d_min_s: f64,
    pub d_max_s: f64,
}

impl Segment {
    /// Parameters of this segment in p.
    pub fn params(&self) -> usize {
        match self.thrust {
            ArcKind::Bound(_) => 1 + NC,
            ArcKind::Free => 1 + 2 * NC,
        }
    }
}

/// Offsets of each segment's parameters in p: [d, δ coefficients, T
/// coefficients (free thrust only)].
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    pub segments: Vec<Segment>,
    pub offset: Vec<usize>,
    pub len: usize,
}

impl Layout {
    pub fn new(segments: Vec<Segment>) -> Self {
        let mut offset = Vec::with_capacity(segments.len());
        let mut len = 0;
        for s in &segments {
            offset.push(len);
            len += s.params();
        }
        Layout {
            segments,
            offset,
            len,
        }
    }

    /// Index of segment j's duration.
    pub fn duration(&self, j: usize) -> usize {
        self.offset[j]
    }

    /// Index of segment j's first δ coefficient.
    pub fn delta(&self, j: usize) -> usize {
        self.offset[j] + 1
    }

    /// Index of segment j's first T coefficient (free thrust only).
    pub fn thrust(&self, j: usize) -> Option<usize> {
        match self.segments[j].thrust {
            ArcKind::Free => Some(self.offset[j] + 1 + NC),
            ArcKind::Bound(_) => None,
        }
    }
}

/// Integrate one segment from `y0` with duration `d`, δ coefficients `a`
/// and thrust `thrust` (a bound, or coefficients).
fn segment<T: DualNum<Primitive = f64> + Copy>(
    model: &Model,
    y0: [T; 7],
    d: T,
    a: [T; NC],
    thrust: Result<f64, [T; NC]>,
    steps: usize,
) -> [T; 7] {
    let eval = |c: &[T; NC], s: f64| -> T {
        let p = legendre(s);
        let mut v = c[0] * p[0];
        for k in 1..NC {
            v += c[k] * p[k];
        }
        v
    };
    let f = |y: &[T; 7], s: f64| -> [T; 7] {
        let t = match &thrust {
            Ok(v) => T::from(*v),
            Err(c) => eval(c, s),
        };
        let r = rhs_physical(model, y, t, eval(&a, s));
        r.map(|v| v * d)
    };
    let h = 1.0 / steps as f64;
    let mut y = y0;
    for k in 0..steps {
        let s = k as f64 * h;
        let k1 = f(&y, s);
        let k2 = f(&add(&y, &k1, 0.5 * h), s + 0.5 * h);
        let k3 = f(&add(&y, &k2, 0.5 * h), s + 0.5 * h);
        let k4 = f(&add(&y, &k3, h), s + h);
        for i in 0..7 {
            y[i] += (k1[i] + (k2[i] + k3[i]) * 2.0 + k4[i]) * (h / 6.0);
        }
    }
    y
}

fn add<T: DualNum<Primitive = f64> + Copy>(y: &[T; 7], k: &[T; 7], h: f64) -> [T; 7] {
    std::array::from_fn(|i| y[i] + k[i] * h)
}

/// The coefficients of a polynomial at `p[at..at + NC]`.
fn coefficients<T: Copy>(p: &[T], at: usize) -> [T; NC] {
    std::array::from_fn(|k| p[at + k])
}

/// The states at every segment's end, in f64 (the last is y(t_f)).
pub fn shoot(model: &Model, layout: &Layout, y0: [f64; 7], p: &[f64]) -> Vec<[f64; 7]> {
    let mut y = y0;
    let mut ends = Vec::with_capacity(layout.segments.len());
    for (j, seg) in layout.segments.iter().enumerate() {
        let thrust = match layout.thrust(j) {
            Some(at) => Err(coefficients(p, at)),
            None => Ok(bound(seg)),
        };
        let d = p[layout.duration(j)];
        y = segment(
            model,
            y,
            d,
            coefficients(p, layout.delta(j)),
            thrust,
            seg.steps,
        );
        ends.push(y);
    }
    ends
}

fn bound(seg: &Segment) -> f64 {
    match seg.thrust {
        ArcKind::Bound(v) => v,
        ArcKind::Free => f64::NAN,
    }
}

/// y(t_f) and its Jacobian against p (7 × layout.len, row-major).
#[derive(Debug, Clone, PartialEq)]
pub struct Sensitivity {
    pub final_state: [f64; 7],
    pub jacobian: Vec<[f64; 7]>,
}

impl Sensitivity {
    /// ∂y_i(t_f)/∂p_c.
    pub fn d(&self, i: usize, c: usize) -> f64 {
        self.jacobian[c][i]
    }
}

/// y(t_f) and ∂y(t_f)/∂p by forward-mode differentiation, segment by
/// segment, chained backwards (module docs).
pub fn sensitivity(model: &Model, layout: &Layout, y0: [f64; 7], p: &[f64]) -> Sensitivity {
    let nseg = layout.segments.len();
    let mut phi: Vec<[[f64; 7]; 7]> = Vec::with_capacity(nseg);
    let mut g: Vec<[[f64; MAX_SEGMENT_PARAMS]; 7]> = Vec::with_capacity(nseg);
    let mut y = y0;
    for (j, seg) in layout.segments.iter().enumerate() {
        let yd: [D; 7] = std::array::from_fn(|i| D::from_re(y[i]).derivative(i));
        let o = layout.offset[j];
        let pd: Vec<D> = (0..seg.params())
            .map(|k| D::from_re(p[o + k]).derivative(7 + k))
            .collect();
        let thrust = match seg.thrust {
            ArcKind::Free => Err(coefficients(&pd, 1 + NC)),
            ArcKind::Bound(v) => Ok(v),
        };
        let end = segment(model, yd, pd[0], coefficients(&pd, 1), thrust, seg.steps);
        let mut ph = [[0.0; 7]; 7];
        let mut gj = [[0.0; MAX_SEGMENT_PARAMS]; 7];
        for (i, e) in end.iter().enumerate() {
            y[i] = e.re;
            if let Some(eps) = &e.eps.0 {
                for c in 0..7 {
                    ph[i][c] = eps[c];
                }
                for c in 0..seg.params() {
                    gj[i][c] = eps[7 + c];
                }
            }
        }
        phi.push(ph);
        g.push(gj);
    }
    let mut jacobian = vec![[0.0; 7]; layout.len];
    // w = ∂y(t_f)/∂y(end of segment j), from the last segment backwards.
    let mut w = identity();
    for j in (0..nseg).rev() {
        let o = layout.offset[j];
        for c in 0..layout.segments[j].params() {
            for i in 0..7 {
                jacobian[o + c][i] = (0..7).map(|k| w[i][k] * g[j][k][c]).sum();
            }
        }
        w = mul(&w, &phi[j]);
    }
    Sensitivity {
        final_state: y,
        jacobian,
    }
}

fn identity() -> [[f64; 7]; 7] {
    std::array::from_fn(|i| std::array::from_fn(|j| f64::from(u8::from(i == j))))
}

fn mul(a: &[[f64; 7]; 7], b: &[[f64; 7]; 7]) -> [[f64; 7]; 7] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..7).map(|k| a[i][k] * b[k][j]).sum()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;

    /// The sensitivities agree with central finite differences of
    /// [`shoot`] on every parameter.
    #[test]
    fn sensitivities_match_finite_differences() {
        let s = Scenario::paper();
        let model = Model::new(&s.vehicle, &s.environment);
        let (lo, hi) = (model.min_thrust_n, model.max_thrust_n);
        let seg = |thrust, steps| Segment {
            thrust,
            steps,
            d_min_s: 0.0,
            d_max_s: 10.0,
        };
        let layout = Layout::new(vec![
            seg(ArcKind::Bound(hi), 20),
            seg(ArcKind::Free, 30),
            seg(ArcKind::Bound(lo), 10),
        ]);
        let mut p = vec![0.0; layout.len];
        for j in 0..3 {
            p[layout.duration(j)] = 1.0 + 0.3 * j as f64;
            p[layout.delta(j)] = 0.05;
            p[layout.delta(j) + 1] = -0.02 * j as f64;
            p[layout.delta(j) + 3] = 0.01;
        }
        let t = layout.thrust(1).unwrap();
        p[t] = 0.5 * (lo + hi);
        p[t + 1] = 0.1 * (hi - lo);
        p[t + 2] = -0.05 * (hi - lo);
        let y0 = [0.0, 1000.0, 10.0, -80.0, 1.4, -0.1, 100_000.0];
        let sens = sensitivity(&model, &layout, y0, &p);
        let last = *shoot(&model, &layout, y0, &p).last().unwrap();
        // The same arithmetic on the real parts, to rounding.
        for (a, b) in sens.final_state.iter().zip(&last) {
            assert!((a - b).abs() <= 1e-12 * b.abs().max(1.0));
        }
        for c in 0..layout.len {
            // A step of 1e-6 of each parameter's size: 0.1 for durations
            // and δ [rad], 1e5 N for T.
            let size = if (t..t + NC).contains(&c) { 1e5 } else { 0.1 };
            let h = 1e-6 * p[c].abs().max(size);
            let (mut a, mut b) = (p.clone(), p.clone());
            a[c] += h;
            b[c] -= h;
            let ya = *shoot(&model, &layout, y0, &a).last().unwrap();
            let yb = *shoot(&model, &layout, y0, &b).last().unwrap();
            for i in 0..7 {
                let fd = (ya[i] - yb[i]) / (2.0 * h);
                // The floor: the rounding of y_i (~1e3) over h, about 1e-7.
                let scale = fd.abs().max(sens.d(i, c).abs()).max(1e-2);
                assert!(
                    (fd - sens.d(i, c)).abs() <= 1e-5 * scale,
                    "∂y{i}/∂p{c}: {} vs fd {fd}",
                    sens.d(i, c)
                );
            }
        }
    }
}
