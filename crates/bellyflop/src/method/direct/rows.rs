//! The operational rows g(y) ≤ 0 that the direct method holds at its free
//! nodes (issue 37, [`crate::problem::constraints`]): the tilt limit and
//! the final descent, and the approach cone. The pitch-rate limit is a
//! simple bound on w ([`crate::method::direct::nlp`]). The cone involves x,
//! so with it the KKT solve keeps x in its node blocks instead of
//! eliminating it ([`crate::method::direct::kkt::Layout::eliminates_x`]).
//!
//! Each row, over its scale (ĝ = g/scale, order one), enters the barrier
//! problem without a slack, as the bounds do: −μ·ln(−ĝ) in φ_μ, a
//! multiplier z > 0 with z·(−ĝ) = μ, and in the Newton system
//! W += z·∇²ĝ + (z/(−ĝ))·∇ĝ∇ĝᵀ, r_w −= (μ/(−ĝ))·∇ĝ,
//! Δz = μ/(−ĝ) − z + (z/(−ĝ))·∇ĝᵀΔw (the bounds' Eq. 13 with the slack
//! −ĝ). Every row is concave (linear in θ or Vx, minus a convex softplus
//! of z), so ĝ(w + αΔw) ≤ ĝ(w) + α∇ĝᵀΔw: the fraction to the boundary on
//! the linear prediction ([`NodeRows::max_step`]) keeps every trial point
//! strictly inside.

use crate::method::direct::nlp::{Nlp, NL, NS};
use crate::problem::constraints::Row;
use crate::problem::dynamics::ix;

/// How far inside its limit a start's own state is put (relative).
const PUSH: f64 = 0.02;

/// The least height above the pad of a start's free node inside the cone
/// \[m\] (the cone is empty at the pad's own height).
const CONE_MIN_HEIGHT_M: f64 = 0.1;

/// The rows at the free nodes 1 … N−1, their values and derivatives at the
/// last evaluated point.
#[derive(Default)]
pub(super) struct NodeRows {
    rows: Vec<Row>,
    /// Nodes holding rows.
    nodes: Vec<usize>,
    /// ĝ, ∇ĝ over the node's local slots, ∂²ĝ/∂ẑ², per (node e, row r) at
    /// e·rows + r.
    pub(super) value: Vec<f64>,
    grad: Vec<[f64; NL]>,
    d2: Vec<f64>,
}

impl NodeRows {
    /// The rows of `nlp` at its free nodes, in this storage (which grows
    /// only when the rows or nodes outnumber any earlier solve's, so that a
    /// flight loop's re-plans allocate nothing: issue 27).
    pub(super) fn refill(&mut self, nlp: &Nlp) {
        self.rows.clear();
        self.rows.extend_from_slice(&nlp.limits);
        self.nodes.clear();
        if !self.rows.is_empty() {
            self.nodes.extend(1..nlp.n);
        }
        let m = self.rows.len() * self.nodes.len();
        self.value.clear();
        self.value.resize(m, 0.0);
        self.grad.clear();
        self.grad.resize(m, [0.0; NL]);
        self.d2.clear();
        self.d2.resize(m, 0.0);
    }

    pub(super) fn len(&self) -> usize {
        self.value.len()
    }

    /// The physical state (x, z, Vx, Vz, θ, w, m) of node k of w.
    fn state(nlp: &Nlp, w: &[f64], k: usize) -> [f64; 7] {
        std::array::from_fn(|s| nlp.physical(s, w[nlp.idx(k, s)]))
    }

    /// Values and derivatives at w.
    pub(super) fn evaluate(&mut self, nlp: &Nlp, w: &[f64]) {
        let nr = self.rows.len();
        for (e, &k) in self.nodes.iter().enumerate() {
            let y = Self::state(nlp, w, k);
            for (r, row) in self.rows.iter().enumerate() {
                let i = e * nr + r;
                let ev = row.eval(&y);
                let unit = 1.0 / row.scale();
                self.value[i] = ev.g * unit;
                let mut g = [0.0; NL];
                for s in 0..7 {
                    g[s] = ev.grad[s] * nlp.scale[s] * unit;
                }
                self.grad[i] = g;
                self.d2[i] = ev.d2_dz2 * nlp.scale[ix::Z] * nlp.scale[ix::Z] * unit;
            }
        }
    }

    /// ĝ of row i at w (not the cached point).
    fn value_at(&self, nlp: &Nlp, w: &[f64], i: usize) -> f64 {
        let nr = self.rows.len();
        let (k, row) = (self.nodes[i / nr], &self.rows[i % nr]);
        row.value(&Self::state(nlp, w, k)) / row.scale()
    }

    /// −μ Σ ln(−ĝ) at w (+∞ outside).
    pub(super) fn barrier(&self, nlp: &Nlp, w: &[f64], mu: f64) -> f64 {
        (0..self.len())
            .map(|i| {
                let s = -self.value_at(nlp, w, i);
                if s > 0.0 {
                    -mu * s.ln()
                } else {
                    f64::INFINITY
                }
            })
            .sum()
    }

    /// ∇ĝ_iᵀ d at the cached point, d over the full vector.
    fn directional(&self, nlp: &Nlp, i: usize, d: &[f64]) -> f64 {
        let k = self.nodes[i / self.rows.len()];
        let at = nlp.idx(k, 0);
        self.grad[i]
            .iter()
            .zip(&d[at..at + NL])
            .map(|(g, d)| g * d)
            .sum()
    }

    /// Largest α ≤ 1 keeping a fraction τ of each −ĝ on the linear
    /// prediction (module docs: safe for concave rows).
    pub(super) fn max_step(&self, nlp: &Nlp, d: &[f64], tau: f64) -> f64 {
        let mut a = 1.0f64;
        for i in 0..self.len() {
            let rate = self.directional(nlp, i, d);
            if rate > 0.0 {
                a = a.min(tau * (-self.value[i]) / rate);
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
        let nr = self.rows.len();
        for i in 0..self.len() {
            let k = self.nodes[i / nr];
            let (g, sigma) = (&self.grad[i], z[i] / -self.value[i]);
            let b = &mut blocks[k];
            b[ix::Z][ix::Z] += z[i] * self.d2[i];
            for r in 0..NS {
                if g[r] == 0.0 {
                    continue;
                }
                for c in 0..NS {
                    if g[c] != 0.0 && (!diagonal_only || r == c) {
                        b[r][c] += sigma * g[r] * g[c];
                    }
                }
            }
        }
    }

    /// out += Σ_i c_i·∇ĝ_i, with c_i = `coefficient(i)`.
    pub(super) fn add_gradients(
        &self,
        nlp: &Nlp,
        coefficient: impl Fn(usize) -> f64,
        out: &mut [f64],
    ) {
        for i in 0..self.len() {
            let k = self.nodes[i / self.rows.len()];
            let at = nlp.idx(k, 0);
            let c = coefficient(i);
            for (o, g) in out[at..at + NL].iter_mut().zip(&self.grad[i]) {
                *o += c * g;
            }
        }
    }

    /// Entry j of Σ_i z_i∇ĝ_i (the rows of j's node only).
    pub(super) fn gradient_entry(&self, nlp: &Nlp, z: &[f64], j: usize) -> f64 {
        let (k, s) = (j / NL, j % NL);
        if self.rows.is_empty() || k == 0 || k >= nlp.n || s >= NL {
            return 0.0;
        }
        let nr = self.rows.len();
        let e = k - 1;
        (0..nr)
            .map(|r| z[e * nr + r] * self.grad[e * nr + r][s])
            .sum()
    }

    /// The barrier's gradient Σ (μ/(−ĝ))·∇ĝ, added to `out`.
    pub(super) fn add_barrier_gradient(&self, nlp: &Nlp, mu: f64, out: &mut [f64]) {
        self.add_gradients(nlp, |i| mu / -self.value[i], out);
    }

    /// Δz (module docs) into `dz`, and its largest step at fraction τ.
    pub(super) fn dual_step(
        &self,
        nlp: &Nlp,
        z: &[f64],
        dw: &[f64],
        dz: &mut [f64],
        (mu, tau): (f64, f64),
    ) -> f64 {
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
    pub(super) fn accept(
        &self,
        nlp: &Nlp,
        w: &[f64],
        z: &mut [f64],
        dz: &[f64],
        (az, mu, kappa): (f64, f64, f64),
    ) {
        for i in 0..self.len() {
            let s = -self.value_at(nlp, w, i);
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
    pub(super) fn complementarity(
        &self,
        nlp: &Nlp,
        z: &[f64],
        dw: &[f64],
        dz: &[f64],
        (ap, ad): (f64, f64),
    ) -> (f64, usize) {
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
    /// z, which the triggered rows' limits depend on.
    pub(super) fn push_inside(&self, nlp: &Nlp, w: &mut [f64]) {
        for &k in &self.nodes {
            for row in self.rows.iter().filter(|r| r.sign > 0.0) {
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
    }
}
