//! The factorization of K: the node blocks W_k + δ I one by one
//! ([`KktSolver::factor_node`]), then R formed from them and factored
//! ([`KktSolver::factor_reduced`]), densely or, on an hp mesh, block by
//! block ([`super::banded`]); the inertia of K by Sylvester's law.

#![allow(clippy::needless_range_loop)] // Dense block algebra indexes several arrays by one index.

use faer::linalg::matmul::matmul;
use faer::reborrow::ReborrowMut;
use faer::{Accum, MatMut, MatRef, Par};

use super::dense::small_ldlt_inverse;
use super::{banded, Inertia, KktMatrix, KktSolver, ReducedPath, X};

impl<const NS: usize, const NL: usize> KktSolver<NS, NL> {
    /// Factor W_k + δ I over node k's free slots and keep its inverse;
    /// returns its inertia (any zero eigenvalue leaves the inverse unusable).
    pub fn factor_node(&mut self, k: usize, w: &[[f64; NL]; NL], delta: f64) -> Inertia {
        let sl = &self.slots[k];
        let b = sl.len();
        if b == 0 {
            return Inertia::default();
        }
        let mut packed = [[0.0; NL]; NL];
        for p in 0..b {
            for q in 0..b {
                packed[p][q] = w[sl[p]][sl[q]] + if p == q { delta } else { 0.0 };
            }
        }
        if let Some(inertia) = small_ldlt_inverse(&packed, b, self.growth_max, &mut self.m_inv[k]) {
            return inertia;
        }
        let a = &mut self.node.a;
        for q in 0..b {
            for p in 0..b {
                a[q * b + p] = w[sl[p]][sl[q]] + if p == q { delta } else { 0.0 };
            }
        }
        let inertia = self.node.factor(b);
        if inertia.zero > 0 {
            return inertia;
        }
        let mut x = [[0.0; NL]; NL];
        let x = x.as_flattened_mut();
        for p in 0..b {
            x[p * b + p] = 1.0;
        }
        self.node.solve(b, &mut x[..b * b], b);
        let m = &mut self.m_inv[k];
        for p in 0..b {
            for q in 0..b {
                // Symmetrize: M is symmetric up to rounding.
                m[p][q] = 0.5 * (x[q * b + p] + x[p * b + q]);
            }
        }
        inertia
    }

    /// Form and factor R after every node is factored; returns its inertia.
    /// The unpivoted LDLᵀ works in R's storage; on the rare fallback (about
    /// one factorization in 3,000 on the envelope) R is formed again for
    /// Bunch–Kaufman, which is cheaper on average than keeping a copy.
    pub fn factor_reduced(&mut self, kkt: &KktMatrix<NS, NL>) -> Inertia {
        let rd = self.dim() + 1;
        if let Some(mut banded) = self.banded.take() {
            let (s_nunu, a) = self.node_terms(kkt, false);
            let terms = banded::Terms {
                c0: self.c0,
                d: &self.d,
                q: &self.q,
                cross: &self.cross,
                s_nu: &self.s_nu,
                g: &self.rhs,
                nu_diagonal: self.nu_diagonal(s_nunu, kkt.delta_c),
                a,
                delta_c: kkt.delta_c,
            };
            let inertia = banded.factor(&terms, self.growth_max);
            self.banded = Some(banded);
            if let Some(inertia) = inertia {
                self.path = ReducedPath::Banded;
                return self.with_eliminated(inertia);
            }
        }
        self.form_reduced(kkt);
        if let Some(inertia) =
            self.unpivoted
                .factor(&mut self.reduced.a[..rd * rd], rd, self.growth_max)
        {
            self.path = ReducedPath::Unpivoted;
            return self.with_eliminated(inertia);
        }
        self.form_reduced(kkt);
        self.path = ReducedPath::BunchKaufman;
        let inertia = self.reduced.factor(rd);
        self.with_eliminated(inertia)
    }

    /// K's inertia from R's: plus the eliminated pairs (x_k, its part of
    /// λ_x), N − 1 positive and N − 1 negative eigenvalues; where x is
    /// kept, none, and one negative fewer for ν's placeholder row
    /// ([`Self::nu_diagonal`]).
    fn with_eliminated(&self, reduced: Inertia) -> Inertia {
        let ne = self.x.nodes.len();
        Inertia {
            positive: reduced.positive + ne,
            negative: (reduced.negative + ne).saturating_sub(usize::from(self.c0 == 0)),
            zero: reduced.zero,
        }
    }

    /// R's ν diagonal: −S_νν − δ_c, or −1 where x is kept and ν's row is a
    /// placeholder (no couplings, so its solution is 0 and its eigenvalue
    /// −1, which [`Self::with_eliminated`] takes off).
    fn nu_diagonal(&self, s_nunu: f64, delta_c: f64) -> f64 {
        if self.c0 == 0 {
            -1.0
        } else {
            -s_nunu - delta_c
        }
    }

    /// Form R's lower triangle in `reduced.a`, and g in `rhs`.
    ///
    /// Inside R the kept multipliers are ordered state-major (λ of state c at
    /// point i is row (c − c0)·N + i), so that the D ⊗ I part of S,
    /// S^{cc2} = D·diag(Q_k(c, c2))·Dᵀ, is seven (eight with x) dense
    /// products P_{c2}·Dᵀ
    /// (faer's SIMD matmul) instead of a scattered 49·N³ loop, which took
    /// 56 % of a solve at N = 40 (perf). ν's row is formed like any other
    /// constraint's, from its per-node coefficients e_k.
    fn form_reduced(&mut self, kkt: &KktMatrix<NS, NL>) {
        let (s_nunu, a) = self.node_terms(kkt, true);
        self.assemble_dense(kkt, s_nunu, a);
    }

    /// What R is made of, node by node: g (in `rhs`), ν's couplings S_{ν·}
    /// (in `s_nu`), the kept states' Q_k, the cross terms R_k and T_k, e_k
    /// and M_k e_k, and (for the dense path, `dense`) P; returns S_νν and
    /// R's t̂_f diagonal h_tt − h_tᵀ W⁻¹ h_t.
    fn node_terms(&mut self, kkt: &KktMatrix<NS, NL>, dense: bool) -> (f64, f64) {
        let n = self.n;
        let nn = n + 1;
        let (c0, nr) = (self.c0, self.nr);
        let pdim = nr * n;
        let nu = pdim;
        let sm = |c: usize, i: usize| (c - c0) * n + i;
        let mut g = std::mem::take(&mut self.rhs);
        for i in 0..n {
            for c in c0..NS {
                g[sm(c, i)] = kkt.j_t[i][c];
            }
        }
        g[nu] = (0..n).map(|i| self.x.null[i] * kkt.j_t[i][X]).sum();
        self.s_nu.iter_mut().for_each(|v| *v = 0.0);
        let mut s_nunu = 0.0;
        let mut a = kkt.h_tt;
        // P is not cleared: every factorization writes the same entries (the
        // free slots do not change), and the others stay at the zeros of
        // `new` (clearing it was 1.5 % of a solve at N = 20).
        // Per node: P, g, a, ν's couplings; the cross terms R_k and T_k are
        // kept for later.
        for k in 0..=n {
            let sl = &self.slots[k];
            let b = sl.len();
            let m = &self.m_inv[k];
            // The kept states' positions in the block.
            let state = |p: usize| (sl[p] >= c0 && sl[p] < NS).then_some(sl[p]);
            // ν's row over the block: ŵ_k·(x's defect row at k) and, at node
            // N, x_N's column of D.
            let mut e = [0.0; NL];
            for p in 0..b {
                e[p] = if k < n {
                    self.x.null[k] * kkt.b[k][X][sl[p]]
                } else if sl[p] == X {
                    self.x.null_d_last
                } else {
                    0.0
                };
            }
            let mut u = [0.0; NL];
            let mut me = [0.0; NL];
            for p in 0..b {
                u[p] = (0..b).map(|q| m[p][q] * kkt.h_t[k][sl[q]]).sum();
                me[p] = (0..b).map(|q| m[p][q] * e[q]).sum();
                a -= kkt.h_t[k][sl[p]] * u[p];
                g[nu] -= e[p] * u[p];
                s_nunu += e[p] * me[p];
            }
            self.e[k] = e;
            self.me[k] = me;
            let qk = &mut self.q[k];
            *qk = [[0.0; NS]; NS];
            // Column k of D over its nonzero rows lo..hi, so that each write
            // below is one contiguous, vectorizable run over i (P's other
            // entries stay at the zeros of `new`).
            let (lo, hi) = self.col_rows[k];
            let d_col = &self.d[k * n + lo..k * n + hi];
            for p in 0..b {
                let Some(c) = state(p) else { continue };
                for (gi, d) in g[sm(c, lo)..sm(c, hi)].iter_mut().zip(d_col) {
                    *gi -= d * u[p];
                }
                for (si, d) in self.s_nu[sm(c, lo)..sm(c, hi)].iter_mut().zip(d_col) {
                    *si += d * me[p];
                }
                for q in 0..b {
                    let Some(c2) = state(q) else { continue };
                    let mpq = m[p][q];
                    qk[c][c2] = mpq;
                    if dense {
                        let base = ((c2 - c0) * nn + k) * pdim + sm(c, 0);
                        for (x, d) in self.p[base + lo..base + hi].iter_mut().zip(d_col) {
                            *x = d * mpq;
                        }
                    }
                }
            }
            if k == n {
                continue;
            }
            let bk = &kkt.b[k];
            let gm = Self::m_bt(m, bk, sl, c0);
            let mut rm = [[0.0; NS]; NS];
            for p in 0..b {
                if let Some(c) = state(p) {
                    rm[c] = gm[p];
                }
            }
            let tm = Self::b_m_bt(bk, &gm, sl, c0);
            for c in c0..NS {
                g[sm(c, k)] -= (0..b).map(|p| bk[c][sl[p]] * u[p]).sum::<f64>();
                self.s_nu[sm(c, k)] += (0..b).map(|p| bk[c][sl[p]] * me[p]).sum::<f64>();
            }
            self.cross[k] = (rm, tm);
        }
        self.rhs = g;
        (s_nunu, a)
    }

    /// M_k B_kᵀ over node k's block (`sl`: its slots), rows c0…NS of B_k.
    /// Each sum keeps its order (q = 0, 1, …, from −0.0 as `Sum` does), so
    /// the results are bit for bit those of the sums one by one, several
    /// at a time over contiguous rows of B_kᵀ: the scalar reductions were
    /// latency-bound (perf: 11 % of a 6-DoF solve).
    fn m_bt(m: &[[f64; NL]; NL], bk: &[[f64; NL]; NS], sl: &[usize], c0: usize) -> [[f64; NS]; NL] {
        let b = sl.len();
        let mut bt = [[0.0; NS]; NL];
        for q in 0..b {
            for row in c0..NS {
                bt[q][row] = bk[row][sl[q]];
            }
        }
        let mut gm = [[0.0; NS]; NL];
        for p in 0..b {
            let mut acc = [-0.0; NS];
            for q in 0..b {
                let mpq = m[p][q];
                for row in c0..NS {
                    acc[row] += mpq * bt[q][row];
                }
            }
            gm[p][c0..].copy_from_slice(&acc[c0..]);
        }
        gm
    }

    /// B_k (M_k B_kᵀ) over rows and columns c0…NS, its sums in order as
    /// in [`Self::m_bt`].
    fn b_m_bt(
        bk: &[[f64; NL]; NS],
        gm: &[[f64; NS]; NL],
        sl: &[usize],
        c0: usize,
    ) -> [[f64; NS]; NS] {
        let mut tm = [[0.0; NS]; NS];
        for c in c0..NS {
            let tc = &mut tm[c];
            tc[c0..].fill(-0.0);
            for (p, &slot) in sl.iter().enumerate() {
                let v = bk[c][slot];
                for c2 in c0..NS {
                    tc[c2] += v * gm[p][c2];
                }
            }
        }
        tm
    }

    /// The first product of [`Self::assemble_dense`]'s shape, on a scratch
    /// copy, discarded. gemm (faer's matrix product) allocates a packing
    /// slab per thread at its first product; a flight loop's setup does one
    /// on its thread, so that the solves that follow there allocate nothing
    /// (issue 27).
    pub fn warm_up_thread(&self) {
        let n = self.n;
        let rd = self.dim() + 1;
        let (nn, pdim) = (n + 1, self.nr * n);
        let mut r = vec![0.0; rd * rd];
        let mut r = MatMut::from_column_major_slice_mut(&mut r, rd, rd);
        let pm = MatRef::from_column_major_slice(&self.p, pdim, self.nr * nn);
        let d = MatRef::from_column_major_slice(&self.d, n, nn);
        matmul(
            r.rb_mut().submatrix_mut(0, 0, pdim, n),
            Accum::Replace,
            pm.subcols(0, nn),
            d.transpose(),
            -1.0,
            Par::Seq,
        );
    }

    /// R's lower triangle in `reduced.a` from the node terms, and g's t̂_f
    /// column.
    fn assemble_dense(&mut self, kkt: &KktMatrix<NS, NL>, s_nunu: f64, a: f64) {
        let n = self.n;
        let dim = self.dim();
        let rd = dim + 1;
        let nn = n + 1;
        let (c0, nr) = (self.c0, self.nr);
        let pdim = nr * n;
        let nu = pdim;
        let sm = |c: usize, i: usize| (c - c0) * n + i;
        let nu_diagonal = self.nu_diagonal(s_nunu, kkt.delta_c);
        let g = &self.rhs;
        // −S = −Σ_k (d_k d_kᵀ) ⊗ Q_k by one product per kept state, into R's leading
        // block; only the blocks on and below the diagonal (c ≥ c2) are
        // formed, since the factorization reads the lower triangle alone.
        {
            let mut r = MatMut::from_column_major_slice_mut(&mut self.reduced.a[..rd * rd], rd, rd);
            let pm = MatRef::from_column_major_slice(&self.p, pdim, nr * nn);
            let d = MatRef::from_column_major_slice(&self.d, n, nn);
            for c2 in c0..NS {
                let rows = sm(c2, 0);
                matmul(
                    r.rb_mut().submatrix_mut(rows, rows, pdim - rows, n),
                    Accum::Replace,
                    pm.subcols((c2 - c0) * nn, nn).subrows(rows, pdim - rows),
                    d.transpose(),
                    -1.0,
                    Par::Seq,
                );
            }
        }
        // R_i[c2][c] by (c2, c), contiguous in i.
        for i in 0..n {
            let ri = &self.cross[i].0;
            for c2 in 0..NS {
                for c in 0..NS {
                    self.rt[(c2 * NS + c) * n + i] = ri[c2][c];
                }
            }
        }
        let r = &mut self.reduced.a;
        // The cross terms of block (c, c2), column j, row i:
        // D_ij R_j[c][c2] + D_ji R_i[c2][c], and T_j on the diagonal blocks.
        // Every operand and write runs contiguously in i.
        for c2 in c0..NS {
            for j in 0..n {
                let base = sm(c2, j) * rd;
                let (rj, tj) = &self.cross[j];
                let d_col = &self.d[j * n..(j + 1) * n];
                let d_row = &self.d_rows[j * nn..j * nn + n];
                for c in c2..NS {
                    let col = &mut r[base + sm(c, 0)..base + sm(c, 0) + n];
                    let a_j = rj[c][c2];
                    let rt = &self.rt[(c2 * NS + c) * n..(c2 * NS + c + 1) * n];
                    for (((x, dc), dr), t) in col.iter_mut().zip(d_col).zip(d_row).zip(rt) {
                        *x -= dc * a_j + dr * t;
                    }
                    col[j] -= tj[c][c2];
                }
            }
        }
        // R = [−S g; gᵀ a] (lower triangle), ν's row last among the
        // multipliers.
        for c in 0..pdim {
            r[c * rd + nu] = -self.s_nu[c];
        }
        for c in 0..dim {
            r[c * rd + c] -= kkt.delta_c;
            r[c * rd + dim] = g[c];
        }
        r[nu * rd + nu] = nu_diagonal;
        r[dim * rd + dim] = a;
    }
}

#[cfg(test)]
mod tests {
    use crate::input::scenario::Scenario;
    use crate::method::direct::kkt::KktSolver;
    use crate::method::direct::nlp::{slot, Nlp, NL};

    #[test]
    fn node_inertia_counts_negative_and_zero_eigenvalues() {
        let s = Scenario::paper();
        let nlp = Nlp::new(&s, &Default::default());
        let mut solver = KktSolver::new(&nlp);
        let mut w = [[0.0; NL]; NL];
        for (r, row) in w.iter_mut().enumerate() {
            row[r] = 1.0;
        }
        // A 2×2 block [[0, 1], [1, 0]] (eigenvalues ±1) and one −0.5.
        w[3][3] = 0.0;
        w[4][4] = 0.0;
        w[3][4] = 1.0;
        w[4][3] = 1.0;
        w[6][6] = -0.5;
        // Node 2's block: its nine free slots but x (eliminated).
        assert_eq!(solver.node_size(2), 9);
        assert!(solver.eliminates(2, slot::X));
        let i = solver.factor_node(2, &w, 0.0);
        assert_eq!((i.positive, i.negative, i.zero), (7, 2, 0));
        let i = solver.factor_node(2, &w, 1.5);
        assert_eq!((i.positive, i.negative, i.zero), (9, 0, 0));
        w[6][6] = 0.0;
        assert_eq!(solver.factor_node(2, &w, 0.0).zero, 1);
    }
}
