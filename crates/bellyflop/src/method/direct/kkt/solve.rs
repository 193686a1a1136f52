//! The structured solve of K with the factors of [`KktSolver::factor_node`]
//! and [`KktSolver::factor_reduced`]: x's part of the right-hand side, the
//! node blocks forward, R's right-hand side and solve, the node blocks back,
//! and x and its multipliers last ([`super::XElimination`]).

#![allow(clippy::needless_range_loop)] // Dense block algebra indexes several arrays by one index.

use super::{KktMatrix, KktSolver, Layout, Ldlt, ReducedPath, X};

impl<const NS: usize, const NL: usize> KktSolver<NS, NL> {
    /// Solve K [x_w; x_l] = [r_w; r_l] with the current factors (full layout;
    /// fixed slots of x_w are zero).
    pub fn solve(
        &mut self,
        nlp: &impl Layout<NS, NL>,
        kkt: &KktMatrix<NS, NL>,
        r_w: &[f64],
        r_l: &[f64],
        x_w: &mut [f64],
        x_l: &mut [f64],
    ) {
        let dim = self.dim();
        let nu = dim - 1;
        self.project_x_rhs(nlp, r_w);
        let rt = self.forward_nodes(nlp, kkt, r_w);
        let mut rl = std::mem::take(&mut self.rhs);
        self.reduced_rhs(kkt, r_l, rt, &mut rl);
        self.solve_reduced(&mut rl);
        let t = rl[dim];
        let nu_v = rl[nu];
        self.back_substitute(nlp, kkt, &rl, (t, nu_v), x_w);
        self.kept_multipliers(&rl, x_l);
        self.recover_x(nlp, kkt, r_l, (t, nu_v), x_w, x_l);
        self.rhs = rl;
    }

    /// x: q = A⁺ᵀ r_x (in `xq`), λ_x's part in range(A); B̃ᵀq leaves the
    /// right-hand side.
    fn project_x_rhs(&mut self, nlp: &impl Layout<NS, NL>, r_w: &[f64]) {
        for (e, &k) in self.x.nodes.iter().enumerate() {
            self.xe[e] = r_w[nlp.idx(k, X)];
        }
        self.x.pinv_t_mul(&self.xe, &mut self.xq);
    }

    /// Per node: r_k (less B̃ᵀq), ỹ = M r_k, r̃_t = r_t − h_tᵀ ỹ, and ỹ by
    /// state; returns r̃_t.
    fn forward_nodes(
        &mut self,
        nlp: &impl Layout<NS, NL>,
        kkt: &KktMatrix<NS, NL>,
        r_w: &[f64],
    ) -> f64 {
        let n = self.n;
        let nn = n + 1;
        let tf = nlp.tf_idx();
        let q = &self.xq;
        let mut rt = r_w[tf] - (0..n).map(|i| kkt.j_t[i][X] * q[i]).sum::<f64>();
        for k in 0..=n {
            let sl = &self.slots[k];
            let mut r = [0.0; NL];
            for (p, &s) in sl.iter().enumerate() {
                r[p] = r_w[nlp.idx(k, s)]
                    - if k < n {
                        kkt.b[k][X][s] * q[k]
                    } else if s == X {
                        let d_col = &self.d[n * n..nn * n];
                        d_col.iter().zip(q).map(|(d, q)| d * q).sum::<f64>()
                    } else {
                        0.0
                    };
            }
            let m = &self.m_inv[k];
            let mut y = [0.0; NL];
            for p in 0..sl.len() {
                y[p] = (0..sl.len()).map(|q| m[p][q] * r[q]).sum();
                rt -= kkt.h_t[k][sl[p]] * y[p];
            }
            for c in self.c0..NS {
                let p = self.pos[k][c];
                self.by_state[(c - self.c0) * nn + k] = if p == usize::MAX { 0.0 } else { y[p] };
            }
            self.r_tmp[k] = r;
            self.y_tmp[k] = y;
        }
        rt
    }

    /// R's right-hand side into `rl`: r_λ − J ỹ over the kept rows,
    /// ŵᵀr_λx − eᵀỹ, r̃_t.
    fn reduced_rhs(&self, kkt: &KktMatrix<NS, NL>, r_l: &[f64], rt: f64, rl: &mut [f64]) {
        let n = self.n;
        let nn = n + 1;
        let dim = self.dim();
        let nu = dim - 1;
        let c0 = self.c0;
        let sm = |c: usize, i: usize| (c - c0) * n + i;
        for i in 0..n {
            for c in c0..NS {
                let y = &self.y_tmp[i];
                let sl = &self.slots[i];
                rl[sm(c, i)] = r_l[i * NS + c]
                    - (0..sl.len())
                        .map(|p| kkt.b[i][c][sl[p]] * y[p])
                        .sum::<f64>();
            }
        }
        for c in c0..NS {
            // r −= D ỹ_c, one contiguous axpy per node.
            let yc = &self.by_state[(c - c0) * nn..(c - c0 + 1) * nn];
            let out = &mut rl[sm(c, 0)..sm(c, 0) + n];
            for (k, &yk) in yc.iter().enumerate() {
                if yk != 0.0 {
                    let (lo, hi) = self.col_rows[k];
                    for (o, d) in out[lo..hi].iter_mut().zip(&self.d[k * n + lo..k * n + hi]) {
                        *o -= d * yk;
                    }
                }
            }
        }
        rl[nu] = (0..n)
            .map(|i| self.x.null[i] * r_l[i * NS + X])
            .sum::<f64>()
            - (0..=n)
                .map(|k| {
                    let (e, y) = (&self.e[k], &self.y_tmp[k]);
                    (0..self.slots[k].len()).map(|p| e[p] * y[p]).sum::<f64>()
                })
                .sum::<f64>();
        rl[dim] = rt;
    }

    /// Solve R in place with the factorization of the last
    /// [`Self::factor_reduced`].
    fn solve_reduced(&mut self, rl: &mut [f64]) {
        let dim = self.dim();
        match self.path {
            ReducedPath::Unpivoted => {
                Ldlt::solve(&self.reduced.a[..(dim + 1) * (dim + 1)], &mut rl[..dim + 1])
            }
            ReducedPath::BunchKaufman => self.reduced.solve(dim + 1, rl, 1),
            ReducedPath::Banded => self
                .banded
                .as_mut()
                .expect("the banded path has its factors")
                .solve::<NS>(&mut rl[..dim + 1]),
        }
    }

    /// y_k = M_k (r_k − h_t t − J_kᵀ λ − e_k ν) into `x_w` (and ỹ), with
    /// J_kᵀλ's D part as one contiguous dot product per kept state.
    fn back_substitute(
        &mut self,
        nlp: &impl Layout<NS, NL>,
        kkt: &KktMatrix<NS, NL>,
        rl: &[f64],
        (t, nu_v): (f64, f64),
        x_w: &mut [f64],
    ) {
        let n = self.n;
        let tf = nlp.tf_idx();
        let c0 = self.c0;
        let sm = |c: usize, i: usize| (c - c0) * n + i;
        x_w.iter_mut().for_each(|v| *v = 0.0);
        x_w[tf] = t;
        for k in 0..=n {
            let sl = &self.slots[k];
            let mut r = self.r_tmp[k];
            let (lo, hi) = self.col_rows[k];
            let d_col = &self.d[k * n + lo..k * n + hi];
            for (p, &s) in sl.iter().enumerate() {
                r[p] -= kkt.h_t[k][s] * t + self.e[k][p] * nu_v;
                if (c0..NS).contains(&s) {
                    let lam = &rl[sm(s, lo)..sm(s, hi)];
                    r[p] -= d_col.iter().zip(lam).map(|(d, l)| d * l).sum::<f64>();
                }
                if k < n {
                    r[p] -= (c0..NS).map(|c| kkt.b[k][c][s] * rl[sm(c, k)]).sum::<f64>();
                }
            }
            let m = &self.m_inv[k];
            let mut y = [0.0; NL];
            for p in 0..sl.len() {
                y[p] = (0..sl.len()).map(|q| m[p][q] * r[q]).sum();
                x_w[nlp.idx(k, sl[p])] = y[p];
            }
            self.y_tmp[k] = y;
        }
    }

    /// The kept multipliers, from R's solution (state-major) into `x_l`.
    fn kept_multipliers(&self, rl: &[f64], x_l: &mut [f64]) {
        for i in 0..self.n {
            for c in self.c0..NS {
                x_l[i * NS + c] = rl[self.sm(c, i)];
            }
        }
    }

    /// x: Δx = A⁺(r_λx − B̃y + δ_c q) and λ_x = q + ŵν.
    fn recover_x(
        &mut self,
        nlp: &impl Layout<NS, NL>,
        kkt: &KktMatrix<NS, NL>,
        r_l: &[f64],
        (t, nu_v): (f64, f64),
        x_w: &mut [f64],
        x_l: &mut [f64],
    ) {
        if self.c0 == 0 {
            // x is kept: R and the node blocks gave Δx and λ_x.
            return;
        }
        let n = self.n;
        let x_n = if self.pos[n][X] == usize::MAX {
            0.0
        } else {
            self.y_tmp[n][self.pos[n][X]]
        };
        for i in 0..n {
            let sl = &self.slots[i];
            let y = &self.y_tmp[i];
            let by: f64 = (0..sl.len()).map(|p| kkt.b[i][X][sl[p]] * y[p]).sum();
            self.xv[i] = r_l[i * NS + X] - by - self.d[n * n + i] * x_n - kkt.j_t[i][X] * t
                + kkt.delta_c * self.xq[i];
            x_l[i * NS + X] = self.xq[i] + self.x.null[i] * nu_v;
        }
        self.x.pinv_mul(&self.xv, &mut self.xe);
        for (e, &k) in self.x.nodes.iter().enumerate() {
            x_w[nlp.idx(k, X)] = self.xe[e];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;
    use crate::method::direct::kkt::Inertia;
    use crate::method::direct::nlp::Nlp;
    use nalgebra::{DMatrix, DVector};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A random system on `nlp`'s structure, with node blocks of both signs
    /// (AᵀA − I/2), or positive definite ones (AᵀA + I/2) when `definite`.
    /// x's rows of W are zero unless the problem has a cone (whose barrier
    /// terms couple x and z: then x is kept, not eliminated).
    fn random_system<const NS: usize, const NL: usize>(
        nlp: &impl Layout<NS, NL>,
        rng: &mut ChaCha8Rng,
        definite: bool,
    ) -> KktMatrix<NS, NL> {
        let shift = if definite { -0.5 } else { 0.5 };
        let mut k = KktMatrix::zeros(nlp);
        for w in &mut k.w {
            let a: [[f64; NL]; NL] =
                std::array::from_fn(|_| std::array::from_fn(|_| rng.gen_range(-1.0..1.0)));
            for r in 0..NL {
                for c in 0..NL {
                    w[r][c] = (0..NL).map(|q| a[r][q] * a[c][q]).sum::<f64>()
                        - if r == c { shift } else { 0.0 };
                }
            }
        }
        for h in &mut k.h_t {
            *h = std::array::from_fn(|_| rng.gen_range(-0.3..0.3));
        }
        k.h_tt = 5.0;
        for b in &mut k.b {
            *b = std::array::from_fn(|_| std::array::from_fn(|_| rng.gen_range(-1.0..1.0)));
        }
        for j in &mut k.j_t {
            *j = std::array::from_fn(|_| rng.gen_range(-1.0..1.0));
        }
        // x enters P2 linearly, through its own defects alone: no Hessian,
        // no t̂_f cross term, no other defect depends on it (x_N, when free,
        // keeps its Hessian: the soft terminal term's). With a cone, x's
        // rows of W carry its barrier terms.
        let cone = !nlp.eliminates_x();
        for node in 0..nlp.n() {
            if cone {
                continue;
            }
            for r in 0..NL {
                k.w[node][X][r] = 0.0;
                k.w[node][r][X] = 0.0;
            }
            k.h_t[node][X] = 0.0;
            for c in 0..NS {
                k.b[node][c][X] = 0.0;
            }
        }
        k.delta_c = if definite { 1e-2 } else { 1e-9 };
        k
    }

    /// The structured solve equals a dense LU solve of the same matrix, on the
    /// global mesh (both dense factorizations of R) and on hp meshes (the
    /// banded factorization, and dense Bunch–Kaufman), with uneven intervals.
    #[test]
    fn structured_solve_matches_a_dense_solve() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        // (N, intervals, definite node blocks and δ_c = 1e-2, x_N free,
        // a cone: x kept in R).
        let cases = [
            (6, 1, false, false, false),
            (6, 1, false, false, true),
            (9, 3, false, false, true),
            (9, 3, true, true, true),
            (20, 1, false, true, true),
            (13, 4, false, false, true),
            (9, 3, false, false, false),
            (6, 1, true, false, false),
            (9, 3, true, true, false),
            (7, 1, false, true, false),
            (20, 1, false, false, false),
            (8, 2, false, false, false),
            (13, 4, false, true, false),
            (13, 4, true, false, false),
            (30, 5, false, false, false),
        ];
        for ((nodes, intervals, definite, soft, cone), path) in cases.into_iter().flat_map(|c| {
            let first = if c.1 > 1 {
                ReducedPath::Banded
            } else {
                ReducedPath::Unpivoted
            };
            [(c, first), (c, ReducedPath::BunchKaufman)]
        }) {
            let mut s = Scenario::paper();
            s.discretization.nodes = nodes;
            s.discretization.intervals = intervals;
            if cone {
                s.constraints.cone_half_angle_deg = Some(30.0);
            }
            let mut sv = crate::SolverSettings::default();
            if soft {
                sv.terminal_lateral_weight = 1.0;
            }
            let nlp = Nlp::new(&s, &sv);
            let kkt = random_system(&nlp, &mut rng, definite);
            let mut solver = KktSolver::new(&nlp);
            assert_eq!(
                crate::method::direct::kkt::Layout::eliminates_x(&nlp),
                !cone,
                "x is kept exactly where a cone is"
            );
            if path == ReducedPath::BunchKaufman {
                solver.set_growth_max(0.0);
            }
            check_against_dense(&nlp, &kkt, &mut solver, &mut rng, path, (nodes, intervals));
        }
    }

    /// Factor `kkt` with `solver`, and check the inertia against the
    /// eigenvalues of the dense K and a solve against a dense LU solve.
    fn check_against_dense<const NS: usize, const NL: usize>(
        nlp: &impl Layout<NS, NL>,
        kkt: &KktMatrix<NS, NL>,
        solver: &mut KktSolver<NS, NL>,
        rng: &mut ChaCha8Rng,
        path: ReducedPath,
        (nodes, intervals): (usize, usize),
    ) {
        let mut inertia = Inertia::default();
        for k in 0..=nlp.n() {
            inertia = inertia + solver.factor_node(k, &kkt.w[k], 0.0);
        }
        inertia = inertia + solver.factor_reduced(kkt);
        assert_eq!(solver.reduced_path(), path, "{nodes}/{intervals}");
        let (nv, nc) = (nlp.n_var(), nlp.n_con());
        // Dense K over the free variables and the multipliers, column by column.
        let free: Vec<usize> = (0..nv).filter(|&j| !nlp.is_fixed(j)).collect();
        let dim = free.len() + nc;
        let mut dense = DMatrix::zeros(dim, dim);
        let (mut yw, mut yl) = (vec![0.0; nv], vec![0.0; nc]);
        for col in 0..dim {
            let (mut xw, mut xl) = (vec![0.0; nv], vec![0.0; nc]);
            if col < free.len() {
                xw[free[col]] = 1.0;
            } else {
                xl[col - free.len()] = 1.0;
            }
            kkt.multiply(nlp, &xw, &xl, &mut yw, &mut yl);
            for (r, &j) in free.iter().enumerate() {
                dense[(r, col)] = yw[j];
            }
            for r in 0..nc {
                dense[(free.len() + r, col)] = yl[r];
            }
        }
        assert!(
            (&dense - dense.transpose()).amax() < 1e-12,
            "K is symmetric"
        );
        // The inertia agrees with the eigenvalues of the dense matrix.
        let eig = dense.clone().symmetric_eigenvalues();
        let want_inertia = Inertia {
            positive: eig.iter().filter(|&&e| e > 0.0).count(),
            negative: eig.iter().filter(|&&e| e < 0.0).count(),
            zero: 0,
        };
        assert_eq!(inertia, want_inertia, "{nodes}/{intervals}");
        let rhs = DVector::from_fn(dim, |_, _| rng.gen_range(-1.0..1.0));
        let want = dense.clone().lu().solve(&rhs).unwrap();
        let mut rw = vec![0.0; nv];
        for (r, &j) in free.iter().enumerate() {
            rw[j] = rhs[r];
        }
        let rl: Vec<f64> = (0..nc).map(|r| rhs[free.len() + r]).collect();
        let (mut xw, mut xl) = (vec![0.0; nv], vec![0.0; nc]);
        solver.solve(nlp, kkt, &rw, &rl, &mut xw, &mut xl);
        let scale = want.amax();
        for (r, &j) in free.iter().enumerate() {
            assert!(
                (xw[j] - want[r]).abs() < 1e-8 * scale,
                "{nodes}/{intervals} w {j}"
            );
        }
        for r in 0..nc {
            assert!((xl[r] - want[free.len() + r]).abs() < 1e-8 * scale, "λ {r}");
        }
    }

    const NS6: usize = crate::problem::six_dof::NX;
    /// The 6-DoF node: 16 states, 3 controls and two thrust slacks.
    const NL6: usize = NS6 + crate::problem::six_dof::NU + 2;

    /// The 6-DoF transcription's shape (issue 38), for the solve alone:
    /// node 0's states fixed, node N's controls and the landing's fixed
    /// slots (the model's own, through the seam) fixed, the slacks fixed.
    struct SixDofShape {
        mesh: crate::collocation::mesh::Mesh,
        d_cols: Vec<Vec<(usize, f64)>>,
        fixed: Vec<bool>,
        eliminate: bool,
    }

    impl SixDofShape {
        fn new(nodes: usize, intervals: usize, eliminate: bool) -> Self {
            use crate::problem::model::Dynamics;
            let mesh = crate::collocation::mesh::Mesh::uniform(nodes, intervals);
            let n = mesh.n;
            let d_cols = mesh.d_columns();
            let s = Scenario::paper();
            let model = crate::problem::six_dof::SixDof::new(&s.vehicle, &s.environment);
            let mut fixed = vec![false; (n + 1) * NL6 + 1];
            for k in 0..=n {
                for slot in 0..NL6 {
                    // The landing fixes all of node N's controls and the
                    // model's landing slots of its states.
                    let landing = slot >= NS6 || model.terminal_fixed(&s.terminal, slot).is_some();
                    fixed[k * NL6 + slot] =
                        (k == 0 && slot < NS6) || (k == n && landing) || slot >= NL6 - 2;
                }
            }
            SixDofShape {
                mesh,
                d_cols,
                fixed,
                eliminate,
            }
        }
    }

    impl Layout<NS6, NL6> for SixDofShape {
        fn n(&self) -> usize {
            self.mesh.n
        }
        fn idx(&self, k: usize, s: usize) -> usize {
            k * NL6 + s
        }
        fn tf_idx(&self) -> usize {
            (self.mesh.n + 1) * NL6
        }
        fn n_var(&self) -> usize {
            self.tf_idx() + 1
        }
        fn n_con(&self) -> usize {
            self.mesh.n * NS6
        }
        fn is_fixed(&self, j: usize) -> bool {
            self.fixed[j]
        }
        fn mesh(&self) -> &crate::collocation::mesh::Mesh {
            &self.mesh
        }
        fn d_cols(&self) -> &[Vec<(usize, f64)>] {
            &self.d_cols
        }
        fn eliminates_x(&self) -> bool {
            self.eliminate
        }
    }

    /// The same structured solve at the 6-DoF model's sizes (16 states with
    /// defects, 21 slots per node, 8 landing slots fixed): it equals a
    /// dense solve and counts the inertia on the global mesh (both dense
    /// factorizations of R) and on hp meshes (banded and Bunch–Kaufman),
    /// with x eliminated and kept.
    #[test]
    fn structured_solve_matches_a_dense_solve_at_six_dof_sizes() {
        let mut rng = ChaCha8Rng::seed_from_u64(38);
        let cases = [
            (6, 1, false, true),
            (6, 1, true, false),
            (20, 1, false, true),
            (9, 3, false, true),
            (9, 3, true, false),
            (12, 4, false, false),
        ];
        for ((nodes, intervals, definite, eliminate), path) in cases.into_iter().flat_map(|c| {
            let first = if c.1 > 1 {
                ReducedPath::Banded
            } else {
                ReducedPath::Unpivoted
            };
            [(c, first), (c, ReducedPath::BunchKaufman)]
        }) {
            let shape = SixDofShape::new(nodes, intervals, eliminate);
            let kkt = random_system(&shape, &mut rng, definite);
            let mut solver = KktSolver::new(&shape);
            if path == ReducedPath::BunchKaufman {
                solver.set_growth_max(0.0);
            }
            check_against_dense(
                &shape,
                &kkt,
                &mut solver,
                &mut rng,
                path,
                (nodes, intervals),
            );
        }
    }
}
