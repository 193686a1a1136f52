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
//! The derivatives are the RK4 steps' own (the discrete variational
//! equations, stage by stage, with the model's Jacobian written out; the
//! same numbers as forward-mode differentiation through [`rk4_step`], which
//! the tests check): per segment the end state's Jacobian against its start
//! state, Φ_j (7 × 7), and against its own parameters, G_j. The chain
//! ∂y(t_f)/∂p_j = Φ_J ⋯ Φ_{j+1}·G_j then costs 7 × 7 products.

use num_dual::DualNum;

use crate::flown::{legendre, DEGREE};
use crate::polish::arcs::ArcKind;
use crate::problem::constraints::Row;
use crate::problem::dynamics::{rhs_physical, rhs_physical_jacobian, Model};

/// Largest RK4 step in time \[s\]. The landing check integrates the same
/// controls by DOP853 at 1e-10; at 0.05 s the two ends agree to ~1e-4 m on
/// the paper's case.
pub const STEP_S: f64 = 0.05;

/// Coefficients per polynomial.
pub const NC: usize = DEGREE + 1;
/// Most parameters of one segment: d, δ's coefficients, T's.
pub const MAX_SEGMENT_PARAMS: usize = 1 + 2 * NC;
/// Local derivative columns: 7 start states and a segment's parameters.
pub(crate) const ND: usize = 7 + MAX_SEGMENT_PARAMS;

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

/// A polynomial of the flown controls, Σ c_k·P̃_k(s).
pub fn polynomial<T: DualNum<Primitive = f64> + Copy>(c: &[T; NC], s: f64) -> T {
    let p = legendre(s);
    let mut v = c[0] * p[0];
    for k in 1..NC {
        v += c[k] * p[k];
    }
    v
}

/// One classical RK4 step of dy/ds = d·f(y, T(s), δ(s)) from s to s + h,
/// in place: the step of the polish's shot, shared by its sensitivities
/// and its adjoint ([`crate::polish::adjoint`]), so that all three see the
/// same discrete flight.
pub fn rk4_step<T: DualNum<Primitive = f64> + Copy>(
    model: &Model,
    y: &mut [T; 7],
    d: T,
    a: &[T; NC],
    thrust: &Result<f64, [T; NC]>,
    s: f64,
    h: f64,
) {
    let f = |y: &[T; 7], s: f64| -> [T; 7] {
        let t = match thrust {
            Ok(v) => T::from(*v),
            Err(c) => polynomial(c, s),
        };
        let r = rhs_physical(model, y, t, polynomial(a, s));
        r.map(|v| v * d)
    };
    let k1 = f(y, s);
    let k2 = f(&add(y, &k1, 0.5 * h), s + 0.5 * h);
    let k3 = f(&add(y, &k2, 0.5 * h), s + 0.5 * h);
    let k4 = f(&add(y, &k3, h), s + h);
    for i in 0..7 {
        y[i] += (k1[i] + (k2[i] + k3[i]) * 2.0 + k4[i]) * (h / 6.0);
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
    mut on_step: impl FnMut(&[T; 7]),
) -> [T; 7] {
    let h = 1.0 / steps as f64;
    let mut y = y0;
    for k in 0..steps {
        rk4_step(model, &mut y, d, &a, &thrust, k as f64 * h, h);
        on_step(&y);
    }
    y
}

fn add<T: DualNum<Primitive = f64> + Copy>(y: &[T; 7], k: &[T; 7], h: f64) -> [T; 7] {
    std::array::from_fn(|i| y[i] + k[i] * h)
}

/// The coefficients of a polynomial at `p[at..at + NC]`.
pub(crate) fn coefficients<T: Copy>(p: &[T], at: usize) -> [T; NC] {
    std::array::from_fn(|k| p[at + k])
}

/// Segment j's controls, read from p: its duration d_j \[s\], δ's
/// coefficients, and its thrust (a bound \[N\], or T's coefficients).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentControls {
    pub d: f64,
    pub delta: [f64; NC],
    pub thrust: Result<f64, [f64; NC]>,
}

impl SegmentControls {
    pub fn new(layout: &Layout, p: &[f64], j: usize) -> Self {
        SegmentControls {
            d: p[layout.duration(j)],
            delta: coefficients(p, layout.delta(j)),
            thrust: match layout.thrust(j) {
                Some(at) => Err(coefficients(p, at)),
                None => Ok(bound(&layout.segments[j])),
            },
        }
    }

    /// T(s) \[N\] and δ(s) \[rad\] at s ∈ [0, 1].
    pub fn at(&self, s: f64) -> (f64, f64) {
        let t = match &self.thrust {
            Ok(v) => *v,
            Err(c) => polynomial(c, s),
        };
        (t, polynomial(&self.delta, s))
    }
}

/// The states at every segment's end, in f64 (the last is y(t_f)).
pub fn shoot(model: &Model, layout: &Layout, y0: [f64; 7], p: &[f64]) -> Vec<[f64; 7]> {
    shoot_with(model, layout, y0, p, |_, _| ())
}

/// [`shoot`], calling `on_step(j, y)` after every RK4 step of segment j.
pub fn shoot_with(
    model: &Model,
    layout: &Layout,
    y0: [f64; 7],
    p: &[f64],
    mut on_step: impl FnMut(usize, &[f64; 7]),
) -> Vec<[f64; 7]> {
    let mut y = y0;
    let mut ends = Vec::with_capacity(layout.segments.len());
    for (j, seg) in layout.segments.iter().enumerate() {
        let c = SegmentControls::new(layout, p, j);
        y = segment(model, y, c.d, c.delta, c.thrust, seg.steps, |y| {
            on_step(j, y)
        });
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

/// y(t_f) and its Jacobian against p (7 × layout.len, row-major), and the
/// shot's track of (z, Vz) at every RK4 step with their gradients
/// ([`crate::polish::ground`] builds the ground's rows from them).
#[derive(Debug, Clone, PartialEq)]
pub struct Sensitivity {
    pub final_state: [f64; 7],
    pub jacobian: Vec<[f64; 7]>,
    pub track: Track,
    /// ∂z/∂p at track point k: `dz[k·len..(k + 1)·len]` (zero at k = 0).
    pub dz: Vec<f64>,
    /// ∂Vz/∂p at track point k, likewise.
    pub dvz: Vec<f64>,
    /// ∂g_r/∂p of the operational rows `r` given to [`sensitivity_with`] at
    /// track point k: `dlimits[(k·rows + r)·len..][..len]` (zero at k = 0);
    /// empty without rows.
    pub dlimits: Vec<f64>,
}

impl Sensitivity {
    /// ∂y_i(t_f)/∂p_c.
    pub fn d(&self, i: usize, c: usize) -> f64 {
        self.jacobian[c][i]
    }
}

/// (z, Vz) of a shot at its start (k = 0) and after every RK4 step
/// (k = 1..=K, the last at t_f), with the length of the step that ends at
/// k in time (h_s\[0\] = 0) and its segment.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Track {
    pub z_m: Vec<f64>,
    pub vz_mps: Vec<f64>,
    pub h_s: Vec<f64>,
    pub segment: Vec<usize>,
    /// The whole state (x, z, Vx, Vz, θ, w, m) at each point.
    pub states: Vec<[f64; 7]>,
}

impl Track {
    fn start(y0: &[f64; 7], capacity: usize) -> Self {
        let mut t = Track {
            z_m: Vec::with_capacity(capacity),
            vz_mps: Vec::with_capacity(capacity),
            h_s: Vec::with_capacity(capacity),
            segment: Vec::with_capacity(capacity),
            states: Vec::with_capacity(capacity),
        };
        t.push(y0, 0.0, 0);
        t
    }

    fn push(&mut self, y: &[f64; 7], h: f64, j: usize) {
        self.z_m.push(y[1]);
        self.vz_mps.push(y[3]);
        self.h_s.push(h);
        self.segment.push(j);
        self.states.push(*y);
    }

    /// Points of the track: the start and one per RK4 step.
    pub fn len(&self) -> usize {
        self.z_m.len()
    }

    pub fn is_empty(&self) -> bool {
        self.z_m.is_empty()
    }
}

/// Total RK4 steps of a layout.
fn total_steps(layout: &Layout) -> usize {
    layout.segments.iter().map(|s| s.steps).sum()
}

/// y(t_f) and the track of a shot, in f64.
pub fn shoot_track(model: &Model, layout: &Layout, y0: [f64; 7], p: &[f64]) -> ([f64; 7], Track) {
    let mut track = Track::start(&y0, total_steps(layout) + 1);
    let ends = shoot_with(model, layout, y0, p, |j, y| {
        let h = p[layout.duration(j)] / layout.segments[j].steps as f64;
        track.push(y, h, j);
    });
    (*ends.last().unwrap_or(&y0), track)
}

/// y(t_f), ∂y(t_f)/∂p and the track's gradients by forward-mode
/// differentiation, segment by segment: the end state chained backwards,
/// the track forwards through A_j = ∂y(start of segment j)/∂p (module docs).
pub fn sensitivity(model: &Model, layout: &Layout, y0: [f64; 7], p: &[f64]) -> Sensitivity {
    sensitivity_with(model, layout, y0, p, &[])
}

/// [`sensitivity`], with the gradients of the operational rows `rows` at
/// every track point besides ([`Sensitivity::dlimits`]): each row's local
/// derivative Σ_c ∂g/∂y_c·∂y_c/∂v, chained like z's.
pub fn sensitivity_with(
    model: &Model,
    layout: &Layout,
    y0: [f64; 7],
    p: &[f64],
    rows: &[Row],
) -> Sensitivity {
    let nseg = layout.segments.len();
    let len = layout.len;
    let points = total_steps(layout) + 1;
    let mut dlimits = vec![0.0; points * rows.len() * len];
    let mut phi: Vec<[[f64; 7]; 7]> = Vec::with_capacity(nseg);
    let mut g: Vec<[[f64; MAX_SEGMENT_PARAMS]; 7]> = Vec::with_capacity(nseg);
    let mut track = Track::start(&y0, points);
    let mut dz = vec![0.0; points * len];
    let mut dvz = vec![0.0; points * len];
    // A = ∂y(start of the current segment)/∂p, 7 rows of len.
    let mut a = vec![0.0; 7 * len];
    let mut y = y0;
    let mut k = 0;
    for (j, seg) in layout.segments.iter().enumerate() {
        let o = layout.offset[j];
        let params = seg.params();
        let controls = SegmentControls::new(layout, p, j);
        let h = controls.d / seg.steps as f64;
        let (end, dend) = segment_sensitivity(
            model,
            y,
            &controls,
            7 + params,
            seg.steps,
            |ys, dys| {
                k += 1;
                track.push(ys, h, j);
                chain(&dys[1], &a, o, params, &mut dz[k * len..(k + 1) * len]);
                chain(&dys[3], &a, o, params, &mut dvz[k * len..(k + 1) * len]);
                for (r, row) in rows.iter().enumerate() {
                    let grad = row.eval(ys).grad;
                    let mut local = [0.0; ND];
                    for (c, g) in grad.iter().enumerate().filter(|(_, g)| **g != 0.0) {
                        for (l, d) in local.iter_mut().zip(&dys[c]) {
                            *l += g * d;
                        }
                    }
                    let at = (k * rows.len() + r) * len;
                    chain(&local, &a, o, params, &mut dlimits[at..at + len]);
                }
            },
            |_, _, _, _, _| (),
        );
        let mut ph = [[0.0; 7]; 7];
        let mut gj = [[0.0; MAX_SEGMENT_PARAMS]; 7];
        for i in 0..7 {
            ph[i].copy_from_slice(&dend[i][..7]);
            gj[i][..params].copy_from_slice(&dend[i][7..7 + params]);
        }
        y = end;
        a = chained(&dend, &a, o, params);
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
        track,
        dz,
        dvz,
        dlimits,
    }
}

/// ∂y(end of a segment)/∂p (7 rows of len) from its local derivatives
/// `yv` and `a` = ∂y(its start)/∂p ([`chain`] row by row).
pub(crate) fn chained(yv: &Local, a: &[f64], o: usize, params: usize) -> Vec<f64> {
    let len = a.len() / 7;
    let mut next = vec![0.0; 7 * len];
    for (i, row) in yv.iter().enumerate() {
        chain(row, a, o, params, &mut next[i * len..(i + 1) * len]);
    }
    next
}

/// ∂v/∂p of a value v of the current segment from its local derivatives
/// `dv` (against the segment's start state, then its own parameters):
/// through A for the start state, plus those against the segment's own
/// `params` parameters at offset `o`.
fn chain(dv: &[f64; ND], a: &[f64], o: usize, params: usize, out: &mut [f64]) {
    let len = out.len();
    out.fill(0.0);
    for c in 0..7 {
        let e = dv[c];
        if e != 0.0 {
            for (o, a) in out.iter_mut().zip(&a[c * len..(c + 1) * len]) {
                *o += e * a;
            }
        }
    }
    for c in 0..params {
        out[o + c] += dv[7 + c];
    }
}

/// Local derivatives of a segment's state: ∂y/∂(y at the segment's start,
/// its d, δ's coefficients, T's coefficients), 7 rows of [`ND`].
pub(crate) type Local = [[f64; ND]; 7];

/// One stage of [`segment_sensitivity`]: k = d·f(y, T(s), δ(s)) and its
/// local derivatives kv = d·(f_y·yv + f_T·∂T/∂v + f_δ·∂δ/∂v) + f·∂d/∂v on
/// the first `cols` columns, with f and its Jacobian written out
/// ([`rhs_physical_jacobian`]). The value k is [`rk4_step`]'s to the bit.
fn stage(
    model: &Model,
    y: &[f64; 7],
    yv: &Local,
    controls: &SegmentControls,
    s: f64,
    cols: usize,
) -> ([f64; 7], Local) {
    let basis = legendre(s);
    let d = controls.d;
    let (t, delta) = controls.at(s);
    let (f, jac) = rhs_physical_jacobian(model, y, t, delta);
    let k = f.map(|v| v * d);
    let mut kv = [[0.0; ND]; 7];
    for c in 0..cols {
        kv[0][c] = d * yv[2][c];
        kv[1][c] = d * yv[3][c];
        kv[4][c] = d * yv[5][c];
        for r in [2, 3, 5] {
            let j = &jac[r];
            kv[r][c] = d * (j[2] * yv[2][c] + j[3] * yv[3][c] + j[4] * yv[4][c] + j[6] * yv[6][c]);
        }
    }
    // The duration, then δ's coefficients, then T's.
    for r in 0..7 {
        kv[r][7] += f[r];
    }
    for (k, b) in basis.iter().enumerate() {
        for r in [2, 3, 5] {
            kv[r][8 + k] += d * jac[r][8] * b;
        }
        if controls.thrust.is_err() {
            for r in [2, 3, 5, 6] {
                kv[r][8 + NC + k] += d * jac[r][7] * b;
            }
        }
    }
    (k, kv)
}

/// y + h·k and yv + h·kv (the first `cols` columns).
fn advance(
    y: &[f64; 7],
    yv: &Local,
    k: &[f64; 7],
    kv: &Local,
    h: f64,
    cols: usize,
) -> ([f64; 7], Local) {
    let mut v = *yv;
    for r in 0..7 {
        for c in 0..cols {
            v[r][c] += kv[r][c] * h;
        }
    }
    (add(y, k, h), v)
}

/// [`segment`] with the local derivatives of its state carried through
/// every RK4 stage (the discrete variational equations: the same
/// derivatives as forward-mode differentiation of [`rk4_step`], whose
/// values it reproduces to the bit), on the first `cols` columns (7 and
/// the segment's parameters). Calls `on_stage(step, i, Y_i, ∂Y_i, s_i)`
/// at each stage i ∈ 0..4 of every step before its evaluation
/// ([`crate::polish::hessian`] sums its second derivatives there) and
/// `on_step(y, yv)` after every step; returns the end state and its local
/// derivatives.
pub(crate) fn segment_sensitivity(
    model: &Model,
    y0: [f64; 7],
    controls: &SegmentControls,
    cols: usize,
    steps: usize,
    mut on_step: impl FnMut(&[f64; 7], &Local),
    mut on_stage: impl FnMut(usize, usize, &[f64; 7], &Local, f64),
) -> ([f64; 7], Local) {
    let h = 1.0 / steps as f64;
    let mut y = y0;
    let mut yv = [[0.0; ND]; 7];
    for (i, row) in yv.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for step in 0..steps {
        let s = step as f64 * h;
        let mut stage = |i: usize, y: &[f64; 7], yv: &Local, s: f64| {
            on_stage(step, i, y, yv, s);
            stage(model, y, yv, controls, s, cols)
        };
        let (k1, k1v) = stage(0, &y, &yv, s);
        let (y2, y2v) = advance(&y, &yv, &k1, &k1v, 0.5 * h, cols);
        let (k2, k2v) = stage(1, &y2, &y2v, s + 0.5 * h);
        let (y3, y3v) = advance(&y, &yv, &k2, &k2v, 0.5 * h, cols);
        let (k3, k3v) = stage(2, &y3, &y3v, s + 0.5 * h);
        let (y4, y4v) = advance(&y, &yv, &k3, &k3v, h, cols);
        let (k4, k4v) = stage(3, &y4, &y4v, s + h);
        for i in 0..7 {
            y[i] += (k1[i] + (k2[i] + k3[i]) * 2.0 + k4[i]) * (h / 6.0);
            for c in 0..cols {
                yv[i][c] += (k1v[i][c] + (k2v[i][c] + k3v[i][c]) * 2.0 + k4v[i][c]) * (h / 6.0);
            }
        }
        on_step(&y, &yv);
    }
    (y, yv)
}

fn identity() -> [[f64; 7]; 7] {
    std::array::from_fn(|i| std::array::from_fn(|j| f64::from(u8::from(i == j))))
}

fn mul(a: &[[f64; 7]; 7], b: &[[f64; 7]; 7]) -> [[f64; 7]; 7] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..7).map(|k| a[i][k] * b[k][j]).sum()))
}

/// The layouts of the polish's derivative tests ([`crate::polish::hessian`],
/// [`crate::polish::ground`], [`crate::polish::limits`],
/// [`crate::polish::adjoint`] and this module's).
#[cfg(test)]
pub(crate) mod fixture {
    use super::{Layout, Segment};
    use crate::polish::arcs::ArcKind;
    use crate::problem::dynamics::Model;

    /// A start state 1 km up, falling at 80 m/s, belly first.
    pub(crate) const Y0: [f64; 7] = [0.0, 1000.0, 10.0, -80.0, 1.4, -0.1, 100_000.0];

    /// A segment of `steps` RK4 steps whose duration may range over
    /// [0, 10] s.
    pub(crate) fn segment(thrust: ArcKind, steps: usize) -> Segment {
        Segment {
            thrust,
            steps,
            d_min_s: 0.0,
            d_max_s: 10.0,
        }
    }

    /// Three segments, on T_max, free and on T_min, of `steps` RK4 steps
    /// and durations `d_s`; δ's coefficients on segment j are (δ₀, −δ₁·j,
    /// 0, δ₃) for `delta` = [δ₀, δ₁, δ₃], and the free thrust's first ones
    /// are `thrust` \[N\]. Returns the layout, p, and where the free
    /// thrust's coefficients start in p.
    fn three_arcs(
        model: &Model,
        steps: [usize; 3],
        d_s: [f64; 3],
        delta: [f64; 3],
        thrust: &[f64],
    ) -> (Layout, Vec<f64>, usize) {
        let (lo, hi) = (model.min_thrust_n, model.max_thrust_n);
        let layout = Layout::new(vec![
            segment(ArcKind::Bound(hi), steps[0]),
            segment(ArcKind::Free, steps[1]),
            segment(ArcKind::Bound(lo), steps[2]),
        ]);
        let mut p = vec![0.0; layout.len];
        for (j, d) in d_s.into_iter().enumerate() {
            p[layout.duration(j)] = d;
            p[layout.delta(j)] = delta[0];
            p[layout.delta(j) + 1] = -delta[1] * j as f64;
            p[layout.delta(j) + 3] = delta[2];
        }
        let t = layout
            .thrust(1)
            .expect("the middle segment's thrust is free");
        p[t..t + thrust.len()].copy_from_slice(thrust);
        (layout, p, t)
    }

    /// [`three_arcs`] of 20, 30 and 10 steps over 1.0, 1.3 and 1.6 s, with
    /// a cubic free thrust: the derivative tests' case from [`Y0`].
    pub(crate) fn varied(model: &Model) -> (Layout, Vec<f64>, usize) {
        let (lo, hi) = (model.min_thrust_n, model.max_thrust_n);
        three_arcs(
            model,
            [20, 30, 10],
            [1.0, 1.3, 1.6],
            [0.05, 0.02, 0.01],
            &[0.5 * (lo + hi), 0.1 * (hi - lo), -0.05 * (hi - lo)],
        )
    }

    /// [`three_arcs`] for a start upright 40 m up, falling at 20 m/s: full
    /// thrust for 1.2 s, then a free arc at ~0.7·T_max that stops the fall
    /// near 22 m and climbs, then a low arc (the path rows' tests).
    pub(crate) fn dip(model: &Model) -> (Layout, Vec<f64>, usize) {
        let (lo, hi) = (model.min_thrust_n, model.max_thrust_n);
        three_arcs(
            model,
            [37, 23, 11],
            [1.2, 1.4, 0.5],
            [0.01, 0.005, 0.002],
            &[0.7 * hi, -0.1 * (hi - lo)],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;

    /// The stage-by-stage derivatives of one segment are forward-mode
    /// differentiation's through [`rk4_step`] (num-dual), to rounding,
    /// and its values are the f64 step's to the bit.
    #[test]
    fn the_variational_steps_are_forward_differentiation() {
        use num_dual::DualSVec64;
        type D = DualSVec64<ND>;
        let s = Scenario::paper();
        let model = Model::new(&s.vehicle, &s.environment);
        let y0 = [5.0, 800.0, 10.0, -80.0, 1.4, -0.1, 110_000.0];
        let (d, a) = (2.3, [0.05, -0.02, 0.01, 0.004]);
        let tc = [1.6e6, 2e5, -1e5, 3e4];
        for thrust in [Ok(2.0e6), Err(tc)] {
            let cols = 7 + 1 + NC + if thrust.is_err() { NC } else { 0 };
            let controls = SegmentControls {
                d,
                delta: a,
                thrust,
            };
            let (y, yv) = segment_sensitivity(
                &model,
                y0,
                &controls,
                cols,
                23,
                |_, _| (),
                |_, _, _, _, _| (),
            );
            let mut plain = y0;
            for k in 0..23 {
                rk4_step(
                    &model,
                    &mut plain,
                    d,
                    &a,
                    &thrust,
                    k as f64 / 23.0,
                    1.0 / 23.0,
                );
            }
            assert_eq!(y, plain);
            let mut yd: [D; 7] = std::array::from_fn(|i| D::from_re(y0[i]).derivative(i));
            let dd = D::from_re(d).derivative(7);
            let ad: [D; NC] = std::array::from_fn(|k| D::from_re(a[k]).derivative(8 + k));
            let td = thrust.map_err(|c| {
                std::array::from_fn::<D, NC, _>(|k| D::from_re(c[k]).derivative(8 + NC + k))
            });
            for k in 0..23 {
                rk4_step(&model, &mut yd, dd, &ad, &td, k as f64 / 23.0, 1.0 / 23.0);
            }
            for i in 0..7 {
                let eps = yd[i].eps.0.unwrap_or_default();
                // A derivative that cancels to rounding (∂m/∂ of T's odd
                // coefficients) is judged against its row's size.
                let row = eps.iter().map(|v| v.abs()).fold(0.0, f64::max);
                for c in 0..ND {
                    let want = if c < cols { eps[c] } else { 0.0 };
                    let scale = want.abs().max(yv[i][c].abs()).max(1e-9 * row);
                    assert!(
                        (yv[i][c] - want).abs() <= 1e-11 * scale,
                        "∂y{i}/∂v{c}: {} vs {want}",
                        yv[i][c]
                    );
                }
            }
        }
    }

    /// The sensitivities agree with central finite differences of
    /// [`shoot`] on every parameter.
    #[test]
    fn sensitivities_match_finite_differences() {
        let s = Scenario::paper();
        let model = Model::new(&s.vehicle, &s.environment);
        let (layout, p, t) = fixture::varied(&model);
        let y0 = fixture::Y0;
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
