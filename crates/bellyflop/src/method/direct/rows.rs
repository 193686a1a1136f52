//! The rows g(y) ≤ 0 that the direct method holds at its nodes beyond the
//! simple bounds:
//!
//! - the planar operational rows of issue 37 ([`crate::problem::constraints`])
//!   at the free nodes: the tilt limit and the final descent, and the
//!   approach cone. The pitch-rate limit is a simple bound on w
//!   ([`crate::method::direct::nlp`]). The cone involves x, so with it the
//!   KKT solve keeps x in its node blocks instead of eliminating it
//!   ([`crate::method::direct::kkt::Layout::eliminates_x`]);
//! - the model's path rows ([`Dynamics::path_rows`]: in 3-D the nozzle's
//!   cone and the gimbal rate's disc), at every node where one of the row's
//!   inputs is free.
//!
//! Each row, over its scale (ĝ = g/scale, order one), enters the barrier
//! problem without a slack, as the bounds do: −μ·ln(−ĝ) in φ_μ, a
//! multiplier z > 0 with z·(−ĝ) = μ, and in the Newton system
//! W += z·∇²ĝ + (z/(−ĝ))·∇ĝ∇ĝᵀ, r_w −= (μ/(−ĝ))·∇ĝ,
//! Δz = μ/(−ĝ) − z + (z/(−ĝ))·∇ĝᵀΔw (the bounds' Eq. 13 with the slack
//! −ĝ). Every operational row is concave (linear in θ or Vx, minus a convex
//! softplus of z), so ĝ(w + αΔw) ≤ ĝ(w) + α∇ĝᵀΔw: the fraction to the
//! boundary on the linear prediction keeps every trial point strictly
//! inside. The model's path rows are convex, where the prediction is
//! optimistic: their step is then shortened until their actual values keep
//! the fraction ([`NodeRows::max_step`]).

use crate::collocation::derivatives::{Differentiable, RowDerivatives, MAX_PATH_ROWS};
use crate::method::direct::nlp::Transcription;
use crate::problem::constraints::Row;
use crate::problem::dynamics::ix;

/// How far inside its limit a start's own state is put (relative).
const PUSH: f64 = 0.02;

/// The least height above the pad of a start's free node inside the cone
/// \[m\] (the cone is empty at the pad's own height).
const CONE_MIN_HEIGHT_M: f64 = 0.1;

/// Halvings of a step that a convex row may ask for before the step is
/// taken as zero.
const MAX_HALVINGS: usize = 60;

/// Which row an instance is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    /// Operational row `r` of the transcription's limits (planar).
    Limit(usize),
    /// The model's path row `r`.
    Path(usize),
}

/// The rows at their nodes, their values and derivatives at the last
/// evaluated point. Instances are ordered by node, the operational rows
/// before the model's at each node.
pub(super) struct NodeRows<const NL: usize> {
    rows: Vec<Row>,
    /// Per instance: its node and row.
    at: Vec<(usize, Kind)>,
    /// The first instance of node k at `first[k]` (N + 2 entries).
    first: Vec<usize>,
    /// ĝ and ∇ĝ over the node's local slots per instance, and its Hessian's
    /// nonzero entries (r, s, value) at `hess[hess_at[i]..hess_at[i + 1]]`.
    pub(super) value: Vec<f64>,
    grad: Vec<[f64; NL]>,
    hess: Vec<(usize, usize, f64)>,
    hess_at: Vec<usize>,
    /// The model's rows at one node (scratch).
    path: Vec<RowDerivatives<NL>>,
}

impl<const NL: usize> Default for NodeRows<NL> {
    fn default() -> Self {
        NodeRows {
            rows: Vec::new(),
            at: Vec::new(),
            first: Vec::new(),
            value: Vec::new(),
            grad: Vec::new(),
            hess: Vec::new(),
            hess_at: Vec::new(),
            path: Vec::new(),
        }
    }
}

/// The physical (x, u) of node k at w + a·d (d: None for w itself), with
/// the thrust slot holding the thrust (the slacks added).
fn node_at<M, const NS: usize, const NL: usize>(
    tr: &Transcription<M, NS, NL>,
    w: &[f64],
    d: Option<(&[f64], f64)>,
    k: usize,
) -> [f64; NL]
where
    M: Differentiable,
{
    let mut p: [f64; NL] = std::array::from_fn(|s| {
        let j = tr.idx(k, s);
        let v = match d {
            Some((d, a)) => w[j] + a * d[j],
            None => w[j],
        };
        tr.physical(s, v)
    });
    let (t, above, below) = (
        Transcription::<M, NS, NL>::T,
        Transcription::<M, NS, NL>::ABOVE,
        Transcription::<M, NS, NL>::BELOW,
    );
    p[t] += p[above] - p[below];
    p
}

/// The model's path rows at the physical node p, into g (f64).
fn path_values<M: Differentiable, const NL: usize>(
    model: &M,
    p: &[f64; NL],
    g: &mut [f64; MAX_PATH_ROWS],
) {
    let (nx, nu) = (M::NX, M::NU);
    model.path_rows(&p[..nx], &p[nx..nx + nu], &mut g[..M::PATH_ROWS]);
}

impl<const NL: usize> NodeRows<NL> {
    /// The rows of `tr` at their nodes, in this storage (which grows only
    /// when the rows or nodes outnumber any earlier solve's, so that a
    /// flight loop's re-plans allocate nothing: issue 27).
    pub(super) fn refill<M, const NS: usize>(&mut self, tr: &Transcription<M, NS, NL>)
    where
        M: Differentiable,
    {
        self.rows.clear();
        self.rows.extend_from_slice(&tr.limits);
        self.at.clear();
        self.first.clear();
        for k in 0..=tr.n {
            self.first.push(self.at.len());
            if k > 0 && k < tr.n {
                self.at
                    .extend((0..self.rows.len()).map(|r| (k, Kind::Limit(r))));
            }
            for (r, inputs) in M::PATH_ROW_INPUTS.iter().enumerate() {
                if inputs.iter().any(|&s| !tr.is_fixed(tr.idx(k, s))) {
                    self.at.push((k, Kind::Path(r)));
                }
            }
        }
        self.first.push(self.at.len());
        let m = self.at.len();
        self.value.clear();
        self.value.resize(m, 0.0);
        self.grad.clear();
        self.grad.resize(m, [0.0; NL]);
        // Room for every Hessian entry that `evaluate` can push (one per
        // planar limit, at most the square of its inputs per model row),
        // so that no solve in this storage allocates (issue 27).
        let entries: usize = self
            .at
            .iter()
            .map(|&(_, kind)| match kind {
                Kind::Limit(_) => 1,
                Kind::Path(r) => M::PATH_ROW_INPUTS[r].len().pow(2),
            })
            .sum();
        self.hess.clear();
        self.hess.reserve(entries);
        self.hess_at.clear();
        self.hess_at.resize(m + 1, 0);
        self.path.resize_with(M::PATH_ROWS, RowDerivatives::default);
        for (d, inputs) in self.path.iter_mut().zip(M::PATH_ROW_INPUTS) {
            d.hess.reserve(inputs.len().pow(2));
        }
    }

    pub(super) fn len(&self) -> usize {
        self.value.len()
    }

    /// The physical planar state (x, z, Vx, Vz, θ, w, m) of node k of w:
    /// the operational rows are planar (only [`crate::method::direct::nlp::Nlp`]
    /// has them).
    fn state<M, const NS: usize>(tr: &Transcription<M, NS, NL>, w: &[f64], k: usize) -> [f64; 7]
    where
        M: Differentiable,
    {
        std::array::from_fn(|s| tr.physical(s, w[tr.idx(k, s)]))
    }

    /// Values and derivatives at w.
    pub(super) fn evaluate<M, const NS: usize>(&mut self, tr: &Transcription<M, NS, NL>, w: &[f64])
    where
        M: Differentiable,
    {
        self.hess.clear();
        let mut node = usize::MAX;
        for i in 0..self.len() {
            self.hess_at[i] = self.hess.len();
            let (k, kind) = self.at[i];
            match kind {
                Kind::Limit(r) => {
                    let row = &self.rows[r];
                    let ev = row.eval(&Self::state(tr, w, k));
                    let unit = 1.0 / row.scale();
                    self.value[i] = ev.g * unit;
                    let mut g = [0.0; NL];
                    for s in 0..7 {
                        g[s] = ev.grad[s] * tr.scale[s] * unit;
                    }
                    self.grad[i] = g;
                    let d2 = ev.d2_dz2 * tr.scale[ix::Z] * tr.scale[ix::Z] * unit;
                    self.hess.push((ix::Z, ix::Z, d2));
                }
                Kind::Path(r) => {
                    if node != k {
                        let p = node_at(tr, w, None, k);
                        tr.model.path_row_derivatives(&p, &tr.scale, &mut self.path);
                        node = k;
                    }
                    let d = &self.path[r];
                    self.value[i] = d.value;
                    self.grad[i] = d.grad;
                    self.hess.extend_from_slice(&d.hess);
                }
            }
        }
        let m = self.len();
        self.hess_at[m] = self.hess.len();
    }

    /// ĝ of instance i at w + a·d (not the cached point).
    fn value_at<M, const NS: usize>(
        &self,
        tr: &Transcription<M, NS, NL>,
        w: &[f64],
        d: Option<(&[f64], f64)>,
        i: usize,
    ) -> f64
    where
        M: Differentiable,
    {
        let (k, kind) = self.at[i];
        match kind {
            Kind::Limit(r) => {
                let row = &self.rows[r];
                let y: [f64; 7] = match d {
                    None => Self::state(tr, w, k),
                    Some((d, a)) => std::array::from_fn(|s| {
                        let j = tr.idx(k, s);
                        tr.physical(s, w[j] + a * d[j])
                    }),
                };
                row.value(&y) / row.scale()
            }
            Kind::Path(r) => {
                let mut g = [0.0; MAX_PATH_ROWS];
                path_values(&tr.model, &node_at(tr, w, d, k), &mut g);
                g[r]
            }
        }
    }

    /// −μ Σ ln(−ĝ) at w (+∞ outside).
    pub(super) fn barrier<M, const NS: usize>(
        &self,
        tr: &Transcription<M, NS, NL>,
        w: &[f64],
        mu: f64,
    ) -> f64
    where
        M: Differentiable,
    {
        (0..self.len())
            .map(|i| {
                let s = -self.value_at(tr, w, None, i);
                if s > 0.0 {
                    -mu * s.ln()
                } else {
                    f64::INFINITY
                }
            })
            .sum()
    }

    /// ∇ĝ_iᵀ d at the cached point, d over the full vector.
    fn directional<M, const NS: usize>(
        &self,
        tr: &Transcription<M, NS, NL>,
        i: usize,
        d: &[f64],
    ) -> f64
    where
        M: Differentiable,
    {
        let at = tr.idx(self.at[i].0, 0);
        self.grad[i]
            .iter()
            .zip(&d[at..at + NL])
            .map(|(g, d)| g * d)
            .sum()
    }

    /// Largest α ≤ 1 keeping a fraction τ of each −ĝ: on the linear
    /// prediction (module docs: safe for the concave operational rows),
    /// then, for the model's convex rows, halved until their values at
    /// w + α·d keep it too.
    pub(super) fn max_step<M, const NS: usize>(
        &self,
        tr: &Transcription<M, NS, NL>,
        w: &[f64],
        d: &[f64],
        tau: f64,
    ) -> f64
    where
        M: Differentiable,
    {
        let mut a = 1.0f64;
        for i in 0..self.len() {
            let rate = self.directional(tr, i, d);
            if rate > 0.0 {
                a = a.min(tau * (-self.value[i]) / rate);
            }
        }
        for i in 0..self.len() {
            if !matches!(self.at[i].1, Kind::Path(_)) {
                continue;
            }
            let keep = (1.0 - tau) * -self.value[i];
            let mut halvings = 0;
            while -self.value_at(tr, w, Some((d, a)), i) < keep {
                a *= 0.5;
                halvings += 1;
                if halvings == MAX_HALVINGS {
                    return 0.0;
                }
            }
        }
        a
    }

    /// W += z·∇²ĝ + (z/(−ĝ))·∇ĝ∇ĝᵀ per node block; `diagonal_only` keeps
    /// the diagonal alone (the restoration's W).
    pub(super) fn add_hessian(
        &self,
        z: &[f64],
        blocks: &mut [[[f64; NL]; NL]],
        diagonal_only: bool,
    ) {
        for i in 0..self.len() {
            let k = self.at[i].0;
            let (g, sigma) = (&self.grad[i], z[i] / -self.value[i]);
            let b = &mut blocks[k];
            for &(r, c, v) in &self.hess[self.hess_at[i]..self.hess_at[i + 1]] {
                if !diagonal_only || r == c {
                    b[r][c] += z[i] * v;
                }
            }
            for r in 0..NL {
                if g[r] == 0.0 {
                    continue;
                }
                for c in 0..NL {
                    if g[c] != 0.0 && (!diagonal_only || r == c) {
                        b[r][c] += sigma * g[r] * g[c];
                    }
                }
            }
        }
    }

    /// out += Σ_i c_i·∇ĝ_i, with c_i = `coefficient(i)`.
    pub(super) fn add_gradients<M, const NS: usize>(
        &self,
        tr: &Transcription<M, NS, NL>,
        coefficient: impl Fn(usize) -> f64,
        out: &mut [f64],
    ) where
        M: Differentiable,
    {
        for i in 0..self.len() {
            let at = tr.idx(self.at[i].0, 0);
            let c = coefficient(i);
            for (o, g) in out[at..at + NL].iter_mut().zip(&self.grad[i]) {
                *o += c * g;
            }
        }
    }

    /// Entry j of Σ_i z_i∇ĝ_i (the rows of j's node only).
    pub(super) fn gradient_entry<M, const NS: usize>(
        &self,
        tr: &Transcription<M, NS, NL>,
        z: &[f64],
        j: usize,
    ) -> f64
    where
        M: Differentiable,
    {
        let (k, s) = (j / NL, j % NL);
        if self.at.is_empty() || k > tr.n {
            return 0.0;
        }
        (self.first[k]..self.first[k + 1])
            .map(|i| z[i] * self.grad[i][s])
            .sum()
    }

    /// The barrier's gradient Σ (μ/(−ĝ))·∇ĝ, added to `out`.
    pub(super) fn add_barrier_gradient<M, const NS: usize>(
        &self,
        tr: &Transcription<M, NS, NL>,
        mu: f64,
        out: &mut [f64],
    ) where
        M: Differentiable,
    {
        self.add_gradients(tr, |i| mu / -self.value[i], out);
    }

    /// Δz (module docs) into `dz`, and its largest step at fraction τ.
    pub(super) fn dual_step<M, const NS: usize>(
        &self,
        nlp: &Transcription<M, NS, NL>,
        z: &[f64],
        dw: &[f64],
        dz: &mut [f64],
        (mu, tau): (f64, f64),
    ) -> f64
    where
        M: Differentiable,
    {
        let mut a = 1.0f64;
        for i in 0..self.len() {
            let s = -self.value[i];
            dz[i] = mu / s - z[i] + z[i] / s * self.directional(nlp, i, dw);
            if dz[i] < 0.0 {
                a = a.min(-tau * z[i] / dz[i]);
            }
        }
        a
    }

    /// z += α_z·Δz at the new point w, with the safeguard of Eq. 16.
    pub(super) fn accept<M, const NS: usize>(
        &self,
        nlp: &Transcription<M, NS, NL>,
        w: &[f64],
        z: &mut [f64],
        dz: &[f64],
        (az, mu, kappa): (f64, f64, f64),
    ) where
        M: Differentiable,
    {
        for i in 0..self.len() {
            let s = -self.value_at(nlp, w, None, i);
            let v = z[i] + az * dz[i];
            z[i] = v.clamp(mu / (kappa * s), kappa * mu / s);
        }
    }

    /// (max |z·(−ĝ) − μ|, Σ z) at the cached point.
    pub(super) fn complementarity_error(&self, z: &[f64], mu: f64) -> (f64, f64) {
        (0..self.len()).fold((0.0f64, 0.0), |(e, sum), i| {
            (e.max((z[i] * -self.value[i] - mu).abs()), sum + z[i])
        })
    }

    /// Σ (−ĝ − α_p∇ĝᵀdw)(z + α_d dz) over the rows, and their count.
    pub(super) fn complementarity<M, const NS: usize>(
        &self,
        nlp: &Transcription<M, NS, NL>,
        z: &[f64],
        dw: &[f64],
        dz: &[f64],
        (ap, ad): (f64, f64),
    ) -> (f64, usize)
    where
        M: Differentiable,
    {
        let sum = (0..self.len())
            .map(|i| {
                let s = -self.value[i] - ap * self.directional(nlp, i, dw);
                s * (z[i] + ad * dz[i])
            })
            .sum();
        (sum, self.len())
    }

    /// Put each row's own state (θ or Vx) of w strictly inside its limit
    /// at its node's z: |own| ≤ (1 − PUSH)·B(z); and each node's (x, z)
    /// strictly inside the cone ([`Row::inside_cone`], z at least
    /// [`CONE_MIN_HEIGHT_M`] above the pad). The cone first: it may raise
    /// z, which the triggered rows' limits depend on. A model's path row
    /// at ĝ > −PUSH has its free inputs scaled toward zero, where it holds
    /// ([`Dynamics::path_rows`](crate::problem::model::Dynamics::path_rows)),
    /// until ĝ ≤ −PUSH.
    pub(super) fn push_inside<M, const NS: usize>(
        &self,
        nlp: &Transcription<M, NS, NL>,
        w: &mut [f64],
    ) where
        M: Differentiable,
    {
        for i in 0..self.len() {
            let (k, kind) = self.at[i];
            let row = match kind {
                Kind::Limit(r) if self.rows[r].sign > 0.0 => &self.rows[r],
                Kind::Limit(_) => continue,
                Kind::Path(r) => {
                    self.push_path_inside(nlp, w, k, r, i);
                    continue;
                }
            };
            let y = Self::state(nlp, w, k);
            if let Some(inside) = row.inside_cone(&y, PUSH, CONE_MIN_HEIGHT_M) {
                for s in [ix::X, ix::Z] {
                    w[nlp.idx(k, s)] = (inside[s] - nlp.offset[s]) / nlp.scale[s];
                }
                continue;
            }
            let Some((own, limit)) = row.own_and_limit(&y) else {
                continue;
            };
            let inside = (1.0 - PUSH) * limit;
            let v = y[own].clamp(-inside, inside);
            let j = nlp.idx(k, own);
            w[j] = (v - nlp.offset[own]) / nlp.scale[own];
        }
    }

    /// [`Self::push_inside`] for the model's path row r at node k
    /// (instance i): its free inputs scaled by 0.9 until ĝ ≤ −PUSH.
    fn push_path_inside<M, const NS: usize>(
        &self,
        nlp: &Transcription<M, NS, NL>,
        w: &mut [f64],
        k: usize,
        r: usize,
        i: usize,
    ) where
        M: Differentiable,
    {
        for _ in 0..MAX_HALVINGS {
            if self.value_at(nlp, w, None, i) <= -PUSH {
                return;
            }
            for &s in M::PATH_ROW_INPUTS[r] {
                let j = nlp.idx(k, s);
                if !nlp.is_fixed(j) {
                    let v = 0.9 * nlp.physical(s, w[j]);
                    w[j] = (v - nlp.offset[s]) / nlp.scale[s];
                }
            }
        }
    }
}
