//! The exact elimination of the positions x_1 … x_{N−1} and their defects
//! from the KKT system ([`XElimination`]).

use nalgebra::DMatrix;

use super::{Layout, X};

/// The exact elimination of the positions x_1 … x_{N−1} and of their
/// defects.
///
/// x enters P2 only through its own defects, D x − (t_f/2)·Vx = 0 (scaled),
/// so its rows of W and h_t are zero: the block of K over (x, λ_x) is
/// [0 Aᵀ; A −δ_c I] with A = D over the free x columns (N × (N − 1), full
/// column rank) and the rest of K touches it only through λ_x's rows
/// B̃ y (B̃: the Vx and t̂_f entries, and x_N's column of D when the soft
/// terminal term frees it). Splitting λ_x = A s + ŵ ν with ŵ the unit left
/// null vector of A (the quadrature weights: ŵᵀA = 0):
///
/// - x's rows give Aᵀ A s = r_x, so A s = q = A⁺ᵀ r_x is known;
/// - ŵᵀ(λ_x's rows) is one row of R, ŵᵀB̃ y − δ_c ν = ŵᵀ r_λx;
/// - the rest of K sees B̃ᵀ q on its right-hand side, and no change in its
///   matrix (the Schur complement of [0 Aᵀ; A −δ_c I] onto it is zero);
/// - afterwards Δx = A⁺(r_λx − B̃ y + δ_c q).
///
/// R shrinks from 8N + 1 to 7N + 2 (a third less to factor), the node blocks
/// lose x's zero row, and the pair adds N − 1 positive and N − 1 negative
/// eigenvalues to K's inertia.
pub(super) struct XElimination {
    /// Per node: whether x is eliminated (free and k < N).
    pub(super) at: Vec<bool>,
    /// The eliminated nodes, in order.
    pub(super) nodes: Vec<usize>,
    /// A⁺ = (AᵀA)⁻¹Aᵀ, (N − 1) × N, row-major (row e: node `nodes[e]`).
    pub(super) pinv: Vec<f64>,
    /// ŵ, N.
    pub(super) null: Vec<f64>,
    /// ŵᵀ D_{·N}: the coefficient of x_N in ν's row when x_N is free.
    pub(super) null_d_last: f64,
}

impl XElimination {
    /// The elimination on `nlp`'s mesh (D column-major), or, when not
    /// `eliminate`, none: no node eliminated, ŵ = 0, so that ν's row is
    /// empty and the solve keeps x among the node blocks and R.
    pub(super) fn new<const NS: usize, const NL: usize>(
        nlp: &impl Layout<NS, NL>,
        d: &[f64],
        eliminate: bool,
    ) -> Self {
        let n = nlp.n();
        if !eliminate {
            return XElimination {
                at: vec![false; n + 1],
                nodes: Vec::new(),
                pinv: Vec::new(),
                null: vec![0.0; n],
                null_d_last: 0.0,
            };
        }
        let at: Vec<bool> = (0..=n)
            .map(|k| k < n && !nlp.is_fixed(nlp.idx(k, X)))
            .collect();
        let nodes: Vec<usize> = (0..=n).filter(|&k| at[k]).collect();
        let ne = nodes.len();
        let a = DMatrix::from_fn(n, ne, |i, e| d[nodes[e] * n + i]);
        // A = Q₁R (Householder): A⁺ = R⁻¹Q₁ᵀ, conditioned as A, not AᵀA.
        let qr = a.clone().qr();
        let (q, r) = (qr.q(), qr.r());
        let pinv = r
            .solve_upper_triangular(&q.transpose())
            .expect("A has full column rank: D without x_0's column is nonsingular");
        // ŵ: the unit vector orthogonal to Q₁, from the basis vector e_j it
        // leaves most of: (I − Q₁Q₁ᵀ)e_j, whose squared norm is 1 − (Q₁Q₁ᵀ)_jj.
        let proj = &q * q.transpose();
        let j = (0..n)
            .max_by(|&a, &b| proj[(b, b)].total_cmp(&proj[(a, a)]))
            .expect("N ≥ 1");
        let mut best = -proj.column(j);
        best[j] += 1.0;
        // The sign is free; the weights' (positive) one reads best.
        let null = best.normalize() * best.sum().signum();
        let null_d_last = (0..n).map(|i| null[i] * d[n * n + i]).sum();
        XElimination {
            at,
            nodes,
            pinv: (0..ne)
                .flat_map(|e| (0..n).map(move |i| (e, i)))
                .map(|(e, i)| pinv[(e, i)])
                .collect(),
            null: null.iter().copied().collect(),
            null_d_last,
        }
    }

    /// y ← A⁺ v (y: one entry per eliminated node).
    pub(super) fn pinv_mul(&self, v: &[f64], y: &mut [f64]) {
        let n = v.len();
        for (e, ye) in y.iter_mut().enumerate() {
            *ye = self.pinv[e * n..(e + 1) * n]
                .iter()
                .zip(v)
                .map(|(p, v)| p * v)
                .sum();
        }
    }

    /// q ← A⁺ᵀ r (r: one entry per eliminated node).
    pub(super) fn pinv_t_mul(&self, r: &[f64], q: &mut [f64]) {
        let n = q.len();
        q.iter_mut().for_each(|v| *v = 0.0);
        for (e, re) in r.iter().enumerate() {
            for (qi, p) in q.iter_mut().zip(&self.pinv[e * n..(e + 1) * n]) {
                *qi += p * re;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::input::scenario::Scenario;
    use crate::method::direct::kkt::KktSolver;
    use crate::method::direct::nlp::Nlp;

    /// x's elimination: ŵ is the mesh's quadrature weights, normalized (the
    /// left null vector of D without x_0's and x_N's columns), and A⁺A = I,
    /// on the global mesh and on an hp mesh.
    #[test]
    fn x_elimination_uses_the_quadrature_weights() {
        for (nodes, intervals) in [(20, 1), (12, 4), (60, 1)] {
            let mut s = Scenario::paper();
            s.discretization.nodes = nodes;
            s.discretization.intervals = intervals;
            let nlp = Nlp::new(&s, &Default::default());
            let solver = KktSolver::new(&nlp);
            let x = &solver.x;
            let n = nlp.n;
            assert_eq!(x.nodes, (1..n).collect::<Vec<_>>());
            let norm = nlp.mesh.weights.iter().map(|w| w * w).sum::<f64>().sqrt();
            for i in 0..n {
                let want = nlp.mesh.weights[i] / norm;
                assert!(
                    (x.null[i] - want).abs() < 1e-12,
                    "{nodes}/{intervals}: ŵ_{i}"
                );
            }
            for (e, &k) in x.nodes.iter().enumerate() {
                for (f, &k2) in x.nodes.iter().enumerate() {
                    let pa: f64 = (0..n)
                        .map(|i| x.pinv[e * n + i] * solver.d[k2 * n + i])
                        .sum();
                    let want = if k == k2 { 1.0 } else { 0.0 };
                    assert!(
                        (pa - want).abs() < 1e-10,
                        "{nodes}/{intervals}: (A⁺A)_{e}{f}"
                    );
                }
            }
        }
    }
}
