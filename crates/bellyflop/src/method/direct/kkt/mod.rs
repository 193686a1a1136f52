//! The Newton (KKT) system of the direct method, solved by eliminating the
//! per-node blocks and factoring the defect Schur complement.
//!
//! With y the free variables of the nodes, t = t̂_f and λ the defect
//! multipliers, the system is
//!
//! ```text
//! [ W    h_t   J_yᵀ ] [y]   [r_y]
//! [ h_tᵀ h_tt  j_tᵀ ] [t] = [r_t]
//! [ J_y  j_t   −δ_c ] [λ]   [r_λ]
//! ```
//!
//! W (the Hessian of the Lagrangian plus the barrier terms) is block-diagonal
//! per node, and J_y is D ⊗ I on the states plus one 8×12 block per
//! collocation point. The positions x_1 … x_{N−1} and their defects are
//! first eliminated exactly ([`XElimination`]: x is linear, with zero rows
//! of W), leaving one row ν of their defects. Each block W_k (at most 12
//! square, symmetric, possibly indefinite) is factored and inverted (an
//! unpivoted LDLᵀ with a growth test, Bunch–Kaufman as fallback); the
//! reduced system
//!
//! ```text
//! R = [ h_tt − h_tᵀ W⁻¹ h_t    gᵀ ]     g = j_t − J_y W⁻¹ h_t
//!     [ g                    −S  ]     S = δ_c I + J_y W⁻¹ J_yᵀ
//! ```
//!
//! over the kept multipliers, ν and t̂_f (7N + 2 square, dense on the global
//! mesh) is factored densely on the global mesh, and block by block over the
//! intervals on an hp mesh, where it is block-tridiagonal with a border of
//! two ([`banded`]). By Sylvester's law of inertia, In(K) =
//! Σ_k In(W_k) + In(R) + (N − 1, N − 1, 0) (the eliminated pairs): the
//! factorization reports the inertia that the interior-point method checks
//! (n positive and m negative eigenvalues for a descent direction), exactly
//! as a sparse LDLᵀ of K would, without its fill-in.
//!
//! R is first factored by faer's LDLᵀ without pivoting, which took 60 µs
//! at n = 161 where its Bunch–Kaufman LBLᵀ took 160 µs (a microbench of
//! faer 0.24 on one core of this machine, before x's elimination). R is indefinite (most W_k are, so S is too), so
//! no pivot order is guaranteed stable: the factors are kept only when their
//! growth max_i Σ_j L_ij² |D_j| / ‖R_i·‖₂ (at most 1 for a definite matrix)
//! is at most [`GROWTH_MAX`], and R is factored by Bunch–Kaufman otherwise.
//! Measured on 90 seeded envelope states at N = 20 and 40 (6,811
//! factorizations), the unpivoted inertia always equalled Bunch–Kaufman's;
//! the growth's median was 60–80 and its maximum 3.5e6.
//!
//! S's blocks are Σ_k D_ik D_jk Q_k + D_ik R_k + D_jk R_kᵀ + T_k (with
//! Q = E M Eᵀ, R = E M Bᵀ, T = B M Bᵀ, M = W_k⁻¹, E the state selection), so
//! forming it costs 64·N³ multiply-adds on the global mesh instead of a
//! sparse factorization's fill-in. Everything is allocated in
//! [`KktSolver::new`]; factoring and solving allocate nothing.

#![allow(clippy::needless_range_loop)] // Dense block algebra indexes several arrays by one index.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::{lblt, ldlt};
use faer::linalg::matmul::matmul;
use faer::perm::PermRef;
use faer::reborrow::ReborrowMut;
use faer::{Accum, ColMut, ColRef, MatMut, MatRef, Par};

use nalgebra::DMatrix;

use crate::method::direct::nlp::{slot, Nlp, NL, NS};

mod banded;

/// An 8×8 block over the states.
type Block8 = [[f64; NS]; NS];

/// The blocks of one Newton system (scaled units), set by the caller.
#[derive(Debug, Clone)]
pub struct KktMatrix {
    /// Per node: W_k over the local slots (only the free ones are read).
    pub w: Vec<[[f64; NL]; NL]>,
    /// Per node: ∂²L/∂t̂∂ŵ_k.
    pub h_t: Vec<[f64; NL]>,
    pub h_tt: f64,
    /// Per collocation point: the non-D part of ∂defect/∂ŵ_local, −(t_f/2)·∂F/∂ŵ.
    pub b: Vec<[[f64; NL]; NS]>,
    /// Per collocation point: ∂defect/∂t̂.
    pub j_t: Vec<[f64; NS]>,
    /// Dual regularization δ_c ≥ 0.
    pub delta_c: f64,
}

impl KktMatrix {
    /// A zero system for `nlp`.
    pub fn zeros(nlp: &Nlp) -> Self {
        KktMatrix {
            w: vec![[[0.0; NL]; NL]; nlp.n + 1],
            h_t: vec![[0.0; NL]; nlp.n + 1],
            h_tt: 0.0,
            b: vec![[[0.0; NL]; NS]; nlp.n],
            j_t: vec![[0.0; NS]; nlp.n],
            delta_c: 0.0,
        }
    }

    /// The upper triangle of K as triplets (row, column, value) over the
    /// free variables (full-vector order, t̂_f last) and then the
    /// multipliers: the matrix a general sparse LDLᵀ would factor. Returns
    /// the number of free variables, the dimension and the triplets.
    #[allow(clippy::type_complexity)]
    pub fn upper_triplets(&self, nlp: &Nlp) -> (usize, usize, Vec<usize>, Vec<usize>, Vec<f64>) {
        let nv = nlp.n_var();
        let mut index = vec![usize::MAX; nv];
        let mut nf = 0;
        for (j, ix) in index.iter_mut().enumerate() {
            if !nlp.is_fixed(j) {
                *ix = nf;
                nf += 1;
            }
        }
        let dim = nf + nlp.n_con();
        let (mut ri, mut ci, mut vv) = (Vec::new(), Vec::new(), Vec::new());
        let mut push = |r: usize, c: usize, v: f64| {
            ri.push(r.min(c));
            ci.push(r.max(c));
            vv.push(v);
        };
        let tf = index[nlp.tf_idx()];
        for k in 0..=nlp.n {
            for r in 0..NL {
                let jr = index[nlp.idx(k, r)];
                if jr == usize::MAX {
                    continue;
                }
                for c in r..NL {
                    let jc = index[nlp.idx(k, c)];
                    if jc != usize::MAX {
                        push(jr, jc, self.w[k][r][c]);
                    }
                }
                push(jr, tf, self.h_t[k][r]);
            }
        }
        push(tf, tf, self.h_tt);
        for i in 0..nlp.n {
            let (first, row) = nlp.mesh.d_row(i);
            for c in 0..NS {
                let l = nf + i * NS + c;
                // D and B may both touch the point's own state: sum them.
                let mut entries: Vec<(usize, f64)> = Vec::new();
                for (j, d) in row.iter().enumerate() {
                    entries.push((nlp.idx(first + j, c), *d));
                }
                for s in 0..NL {
                    entries.push((nlp.idx(i, s), self.b[i][c][s]));
                }
                entries.sort_by_key(|e| e.0);
                let mut last: Option<(usize, f64)> = None;
                for (j, v) in entries
                    .into_iter()
                    .chain(std::iter::once((usize::MAX, 0.0)))
                {
                    match last {
                        Some((lj, lv)) if lj == j => last = Some((lj, lv + v)),
                        Some((lj, lv)) => {
                            if index[lj] != usize::MAX {
                                push(index[lj], l, lv);
                            }
                            last = (j != usize::MAX).then_some((j, v));
                        }
                        None => last = Some((j, v)),
                    }
                }
                push(tf, l, self.j_t[i][c]);
                push(l, l, -self.delta_c);
            }
        }
        (nf, dim, ri, ci, vv)
    }

    /// y ← K·x over the full vector layout (fixed slots of x_w are read as
    /// zero, and y_w's are zero), for the residuals of iterative refinement
    /// and the tests. Fixed slots are masked once, so that the products run
    /// without a test per entry (they were 9 % of a solve at N = 20).
    pub fn multiply(&self, nlp: &Nlp, x_w: &[f64], x_l: &[f64], y_w: &mut [f64], y_l: &mut [f64]) {
        let n = nlp.n;
        let tf = nlp.tf_idx();
        let free = |j: usize| !nlp.is_fixed(j);
        let masked = |j: usize| if free(j) { x_w[j] } else { 0.0 };
        let t = masked(tf);
        y_w.iter_mut().for_each(|v| *v = 0.0);
        let mut y_t = self.h_tt * t;
        for k in 0..=n {
            let xk: [f64; NL] = std::array::from_fn(|s| masked(nlp.idx(k, s)));
            for r in 0..NL {
                let acc: f64 = self.w[k][r].iter().zip(&xk).map(|(w, x)| w * x).sum();
                y_w[nlp.idx(k, r)] = acc + self.h_t[k][r] * t;
                y_t += self.h_t[k][r] * xk[r];
            }
        }
        // Jacobian rows and their transposes.
        for i in 0..n {
            let (first, row) = nlp.mesh.d_row(i);
            let xi: [f64; NL] = std::array::from_fn(|s| masked(nlp.idx(i, s)));
            let li = &x_l[i * NS..(i + 1) * NS];
            for c in 0..NS {
                let mut acc = self.j_t[i][c] * t - self.delta_c * li[c];
                for (j, d) in row.iter().enumerate() {
                    let col = nlp.idx(first + j, c);
                    acc += d * masked(col);
                    y_w[col] += d * li[c];
                }
                acc += self.b[i][c]
                    .iter()
                    .zip(&xi)
                    .map(|(b, x)| b * x)
                    .sum::<f64>();
                y_l[i * NS + c] = acc;
                y_t += self.j_t[i][c] * li[c];
            }
            for s in 0..NL {
                let bt: f64 = (0..NS).map(|c| self.b[i][c][s] * li[c]).sum();
                y_w[nlp.idx(i, s)] += bt;
            }
        }
        y_w[tf] = y_t;
        for (j, y) in y_w.iter_mut().enumerate() {
            if !free(j) {
                *y = 0.0;
            }
        }
    }
}

/// The inertia of a factored matrix: positive, negative and zero eigenvalues.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Inertia {
    pub positive: usize,
    pub negative: usize,
    pub zero: usize,
}

impl Inertia {
    /// Count a 1×1 pivot d of a factorization whose largest pivot is about
    /// `scale`: zero below [`ZERO_PIVOT`]·scale (or not finite).
    fn count_pivot(&mut self, d: f64, scale: f64) {
        if d.abs() <= ZERO_PIVOT * scale || !d.is_finite() {
            self.zero += 1;
        } else if d > 0.0 {
            self.positive += 1;
        } else {
            self.negative += 1;
        }
    }
}

impl std::ops::Add for Inertia {
    type Output = Inertia;
    fn add(self, o: Inertia) -> Inertia {
        Inertia {
            positive: self.positive + o.positive,
            negative: self.negative + o.negative,
            zero: self.zero + o.zero,
        }
    }
}

/// Pivots below this fraction of the largest are counted as zero. Only
/// (numerically) exact singularity: the static regularization of the free
/// linear variables puts entries of order 1e11 into S next to genuine
/// pivots of order 1e-3, so a threshold near machine precision calls
/// regular systems singular (measured: 1e-13 forced δ_w ≈ 1e-2 at every
/// iteration near the paper's optimum, and 500 iterations without
/// convergence instead of 31). Near-singular systems show up in the
/// residual of iterative refinement instead.
const ZERO_PIVOT: f64 = 1e-30;

/// Inertia of B in an LBLᵀ factorization: `diag` and `sub` are B's diagonal
/// and subdiagonal (a nonzero `sub[i]` pairs i and i + 1 in a 2×2 block).
fn lblt_inertia(diag: impl Fn(usize) -> f64, sub: &[f64], n: usize) -> Inertia {
    let scale = (0..n)
        .map(|i| diag(i).abs().max(sub[i].abs()))
        .fold(0.0f64, f64::max)
        .max(f64::MIN_POSITIVE);
    let mut inertia = Inertia::default();
    let mut i = 0;
    while i < n {
        if i + 1 < n && sub[i] != 0.0 {
            let (a, b, c) = (diag(i), sub[i], diag(i + 1));
            let det = a * c - b * b;
            // The block's smaller eigenvalue is about det / (its larger),
            // which is what the threshold compares; det against scale²
            // called a block singular that pairs a barrier term of 1e13
            // (a soft margin's slack at its bound) with a pivot of order 1.
            let big = a.abs().max(c.abs()).max(b.abs());
            if det.abs() <= ZERO_PIVOT * scale * big || !det.is_finite() {
                inertia.zero += 2;
            } else if det < 0.0 {
                inertia.positive += 1;
                inertia.negative += 1;
            } else if a + c > 0.0 {
                inertia.positive += 2;
            } else {
                inertia.negative += 2;
            }
            i += 2;
        } else {
            inertia.count_pivot(diag(i), scale);
            i += 1;
        }
    }
    inertia
}

/// A dense symmetric matrix and its Bunch–Kaufman factors, with the storage
/// to factor and solve in place.
struct Lblt {
    a: Vec<f64>,
    sub: Vec<f64>,
    perm: Vec<usize>,
    perm_inv: Vec<usize>,
    buf: MemBuffer,
}

impl Lblt {
    fn new(dim: usize, rhs: usize) -> Self {
        let req = lblt::factor::cholesky_in_place_scratch::<usize, f64>(
            dim,
            Par::Seq,
            Default::default(),
        )
        .or(lblt::solve::solve_in_place_scratch::<usize, f64>(
            dim,
            rhs,
            Par::Seq,
        ));
        Lblt {
            a: vec![0.0; dim * dim],
            sub: vec![0.0; dim],
            perm: vec![0; dim],
            perm_inv: vec![0; dim],
            buf: MemBuffer::new(req),
        }
    }

    /// Factor the lower triangle of `a` (column-major); returns the inertia.
    fn factor(&mut self, n: usize) -> Inertia {
        // faer writes the subdiagonal of 2×2 pivots only.
        self.sub[..n].iter_mut().for_each(|v| *v = 0.0);
        let am = MatMut::from_column_major_slice_mut(&mut self.a[..n * n], n, n);
        let sub = ColMut::from_slice_mut(&mut self.sub[..n]).as_diagonal_mut();
        lblt::factor::cholesky_in_place(
            am,
            sub,
            &mut self.perm[..n],
            &mut self.perm_inv[..n],
            Par::Seq,
            MemStack::new(&mut self.buf),
            Default::default(),
        );
        let a = &self.a;
        lblt_inertia(|i| a[i * n + i], &self.sub[..n], n)
    }

    /// Solve with the factors of an n×n matrix; `x` is n × k, column-major.
    fn solve(&mut self, n: usize, x: &mut [f64], k: usize) {
        let l = MatRef::from_column_major_slice(&self.a[..n * n], n, n);
        let sub = ColRef::from_slice(&self.sub[..n]).as_diagonal();
        let perm = PermRef::new_checked(&self.perm[..n], &self.perm_inv[..n], n);
        let rhs = MatMut::from_column_major_slice_mut(x, n, k);
        lblt::solve::solve_in_place(
            l,
            l.diagonal(),
            sub,
            perm,
            rhs,
            Par::Seq,
            MemStack::new(&mut self.buf),
        );
    }
}

/// How R was factored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReducedPath {
    /// LDLᵀ without pivoting, its growth at most [`GROWTH_MAX`].
    Unpivoted,
    /// Bunch–Kaufman LBLᵀ, when the unpivoted factorization meets a zero
    /// pivot or grows.
    BunchKaufman,
    /// On an hp mesh: block by block over the intervals ([`banded`]), each
    /// block's unpivoted LDLᵀ within [`GROWTH_MAX`]; Bunch–Kaufman on the
    /// whole of R otherwise.
    Banded,
}

/// The largest growth of an unpivoted LDLᵀ of R that is kept: a backward
/// error of about 1e-10·|R|, which the refinement removes.
pub const GROWTH_MAX: f64 = 1e6;

/// R's LDLᵀ without pivoting, in place: the work space of its growth test.
struct Ldlt {
    /// Per row: Σ_j R_ij², then Σ_j L_ij² |D_j|.
    row_norm: Vec<f64>,
    row_growth: Vec<f64>,
    buf: MemBuffer,
}

impl Ldlt {
    fn new(rd: usize) -> Self {
        let req = ldlt::factor::cholesky_in_place_scratch::<f64>(rd, Par::Seq, Default::default())
            .or(ldlt::solve::solve_in_place_scratch::<f64>(rd, 1, Par::Seq));
        Ldlt {
            row_norm: vec![0.0; rd],
            row_growth: vec![0.0; rd],
            buf: MemBuffer::new(req),
        }
    }

    /// Factor R in place (`a`: its lower triangle, rd square, column-major),
    /// into L (unit, strictly lower) and D (the diagonal); its inertia, or
    /// None (and `a` spoilt) when a pivot is zero or the growth exceeds
    /// `growth_max`.
    fn factor(&mut self, a: &mut [f64], rd: usize, growth_max: f64) -> Option<Inertia> {
        let (row_norm, row_growth) = (&mut self.row_norm[..rd], &mut self.row_growth[..rd]);
        row_norm.iter_mut().for_each(|v| *v = 0.0);
        row_growth.iter_mut().for_each(|v| *v = 0.0);
        for c in 0..rd {
            let col = &a[c * rd + c..(c + 1) * rd];
            let mut col_sq = 0.0;
            for (m, v) in row_norm[c..].iter_mut().zip(col) {
                *m += v * v;
                col_sq += v * v;
            }
            // The diagonal entry is in both sums.
            row_norm[c] += col_sq - col[0] * col[0];
        }
        ldlt::factor::cholesky_in_place(
            MatMut::from_column_major_slice_mut(a, rd, rd),
            Default::default(),
            Par::Seq,
            MemStack::new(&mut self.buf),
            Default::default(),
        )
        .ok()?;
        let mut scale = 0.0f64;
        for j in 0..rd {
            let dj = a[j * rd + j].abs();
            scale = scale.max(dj);
            row_growth[j] += dj;
            for (g, v) in row_growth[j + 1..]
                .iter_mut()
                .zip(&a[j * rd + j + 1..(j + 1) * rd])
            {
                *g += v * v * dj;
            }
        }
        let growth = row_growth
            .iter()
            .zip(row_norm.iter())
            .map(|(g, m)| g / m.sqrt().max(f64::MIN_POSITIVE))
            .fold(0.0, f64::max);
        if growth.is_nan() || growth > growth_max {
            return None;
        }
        let mut inertia = Inertia::default();
        for i in 0..rd {
            inertia.count_pivot(a[i * rd + i], scale);
        }
        Some(inertia)
    }

    /// Solve R x = b in place (`x` holds b) with the factors in `a`.
    fn solve(a: &[f64], x: &mut [f64]) {
        Ldlt::solve_cols(a, x, 1);
    }

    /// Solve R X = B in place for `k` right-hand sides (`x`: B, column-major).
    fn solve_cols(a: &[f64], x: &mut [f64], k: usize) {
        let rd = x.len() / k;
        let l = MatRef::from_column_major_slice(&a[..rd * rd], rd, rd);
        // The solve needs no scratch (faer's `solve_in_place_scratch` is empty).
        ldlt::solve::solve_in_place(
            l,
            l.diagonal(),
            MatMut::from_column_major_slice_mut(x, rd, k),
            Par::Seq,
            MemStack::new(&mut []),
        );
    }
}

/// M = A⁻¹ of a node block A (b ≤ NL square, symmetric) by an unpivoted
/// LDLᵀ on the stack, and A's inertia; None (M spoilt) when a pivot is zero
/// or the growth max_i Σ_j L_ij² |d_j| / ‖A_i·‖₂ exceeds `growth_max`, for
/// the Bunch–Kaufman fallback. faer's LBLᵀ and its solve against I took
/// 16,000 instructions per 11-square block (callgrind), 11 % of a solve at
/// N = 20; this takes about 3,000.
fn small_ldlt_inverse(
    a: &[[f64; NL]; NL],
    b: usize,
    growth_max: f64,
    m: &mut [[f64; NL]; NL],
) -> Option<Inertia> {
    let mut l = [[0.0; NL]; NL];
    let mut d = [0.0; NL];
    let mut scale = 0.0f64;
    for j in 0..b {
        let mut dj = a[j][j];
        for k in 0..j {
            dj -= l[j][k] * l[j][k] * d[k];
        }
        if dj == 0.0 || !dj.is_finite() {
            return None;
        }
        d[j] = dj;
        scale = scale.max(dj.abs());
        for i in j + 1..b {
            let mut v = a[i][j];
            for k in 0..j {
                v -= l[i][k] * l[j][k] * d[k];
            }
            l[i][j] = v / dj;
        }
    }
    for i in 0..b {
        let norm = (0..b).map(|j| a[i][j] * a[i][j]).sum::<f64>().sqrt();
        let grown = (0..i).map(|j| l[i][j] * l[i][j] * d[j].abs()).sum::<f64>() + d[i].abs();
        if grown.is_nan() || grown > growth_max * norm.max(f64::MIN_POSITIVE) {
            return None;
        }
    }
    let mut inertia = Inertia::default();
    for &dj in &d[..b] {
        inertia.count_pivot(dj, scale);
    }
    if inertia.zero > 0 {
        return Some(inertia);
    }
    // X = L⁻¹ (unit lower triangular), then M = Xᵀ D⁻¹ X.
    let mut x = [[0.0; NL]; NL];
    for c in 0..b {
        x[c][c] = 1.0;
        for i in c + 1..b {
            x[i][c] = -(c..i).map(|k| l[i][k] * x[k][c]).sum::<f64>();
        }
    }
    for p in 0..b {
        for q in p..b {
            let v = (q..b).map(|k| x[k][p] * x[k][q] / d[k]).sum::<f64>();
            m[p][q] = v;
            m[q][p] = v;
        }
    }
    Some(inertia)
}

/// Kept states per collocation point in R: z, Vx, Vz, θ, w, m, δ (x's
/// defects are eliminated, [`XElimination`]).
const NR: usize = NS - 1;

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
struct XElimination {
    /// Per node: whether x is eliminated (free and k < N).
    at: Vec<bool>,
    /// The eliminated nodes, in order.
    nodes: Vec<usize>,
    /// A⁺ = (AᵀA)⁻¹Aᵀ, (N − 1) × N, row-major (row e: node nodes[e]).
    pinv: Vec<f64>,
    /// ŵ, N.
    null: Vec<f64>,
    /// ŵᵀ D_{·N}: the coefficient of x_N in ν's row when x_N is free.
    null_d_last: f64,
}

impl XElimination {
    fn new(nlp: &Nlp, d: &[f64]) -> Self {
        let n = nlp.n;
        let at: Vec<bool> = (0..=n)
            .map(|k| k < n && !nlp.is_fixed(nlp.idx(k, slot::X)))
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
    fn pinv_mul(&self, v: &[f64], y: &mut [f64]) {
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
    fn pinv_t_mul(&self, r: &[f64], q: &mut [f64]) {
        let n = q.len();
        q.iter_mut().for_each(|v| *v = 0.0);
        for (e, re) in r.iter().enumerate() {
            for (qi, p) in q.iter_mut().zip(&self.pinv[e * n..(e + 1) * n]) {
                *qi += p * re;
            }
        }
    }
}

/// Storage and factors of the structured KKT solve.
pub struct KktSolver {
    n: usize,
    /// Per node: the free local slots in the node block (x excluded where
    /// eliminated), in order, and each slot's position (usize::MAX: none).
    slots: Vec<Vec<usize>>,
    pos: Vec<[usize; NL]>,
    /// The elimination of x and its defects.
    x: XElimination,
    /// Per node: M_k = (W_k + δ I)⁻¹ over the block's slots (row-major, NL×NL).
    m_inv: Vec<[[f64; NL]; NL]>,
    /// The node blocks' factorization (≤ NL square).
    node: Lblt,
    /// R, (7N + 2) square: the kept multipliers (state-major), ν, then t̂_f.
    reduced: Lblt,
    /// R's LDLᵀ without pivoting, and the largest growth kept.
    unpivoted: Ldlt,
    /// On an hp mesh, R's block-tridiagonal factorization.
    banded: Option<banded::Banded>,
    /// Per node: M_k over the kept states (zero where a state is fixed).
    q: Vec<[[f64; NR]; NR]>,
    /// Per node k: the rows i with D_ik ≠ 0, as a range (lo, hi).
    col_rows: Vec<(usize, usize)>,
    growth_max: f64,
    /// Which factorization of R the solves use.
    path: ReducedPath,
    /// Per node: the right-hand side of its block and ỹ.
    r_tmp: Vec<[f64; NL]>,
    y_tmp: Vec<[f64; NL]>,
    /// Per node: ν's row over the block's slots, e_k, and M_k e_k.
    e: Vec<[f64; NL]>,
    me: Vec<[f64; NL]>,
    /// R's right-hand side; the kept states' values state-major over the
    /// nodes ((N + 1) each); x's work vectors (N and N − 1).
    rhs: Vec<f64>,
    by_state: Vec<f64>,
    xq: Vec<f64>,
    xv: Vec<f64>,
    xe: Vec<f64>,
    /// ν's couplings with the kept multipliers, S_{ν·}.
    s_nu: Vec<f64>,
    /// The dense N × (N+1) differentiation matrix, column-major.
    d: Vec<f64>,
    /// D again, row-major (row i is D_i·), for contiguous row access.
    d_rows: Vec<f64>,
    /// R_i[c2][c] by (c2, c), contiguous in i.
    rt: Vec<f64>,
    /// P = (I ⊗ D)·blockdiag(Q) over the kept states: 7N × 7(N+1), column-major.
    p: Vec<f64>,
    /// Per collocation point: R_k = E M Bᵀ and T_k = B M Bᵀ.
    cross: Vec<(Block8, Block8)>,
}

impl KktSolver {
    pub fn new(nlp: &Nlp) -> Self {
        let n = nlp.n;
        let mut d = vec![0.0; n * (n + 1)];
        let mut d_rows = vec![0.0; n * (n + 1)];
        for (k, col) in nlp.d_cols.iter().enumerate() {
            for &(i, v) in col {
                d[k * n + i] = v;
                d_rows[i * (n + 1) + k] = v;
            }
        }
        let x = XElimination::new(nlp, &d);
        let slots: Vec<Vec<usize>> = (0..=n)
            .map(|k| {
                (0..NL)
                    .filter(|&s| !(nlp.is_fixed(nlp.idx(k, s)) || s == slot::X && x.at[k]))
                    .collect()
            })
            .collect();
        let pos = slots
            .iter()
            .map(|sl| {
                let mut pos = [usize::MAX; NL];
                for (p, &s) in sl.iter().enumerate() {
                    pos[s] = p;
                }
                pos
            })
            .collect();
        let ne = x.nodes.len();
        let rd = NR * n + 2;
        let col_rows = nlp
            .d_cols
            .iter()
            .map(|col| {
                let lo = col.iter().map(|&(i, _)| i).min().unwrap_or(0);
                let hi = col.iter().map(|&(i, _)| i + 1).max().unwrap_or(0);
                (lo, hi.max(lo))
            })
            .collect();
        KktSolver {
            n,
            slots,
            pos,
            x,
            m_inv: vec![[[0.0; NL]; NL]; n + 1],
            node: Lblt::new(NL, NL),
            reduced: Lblt::new(rd, 1),
            unpivoted: Ldlt::new(rd),
            banded: (nlp.mesh.intervals.len() > 1).then(|| banded::Banded::new(&nlp.mesh)),
            q: vec![[[0.0; NR]; NR]; n + 1],
            col_rows,
            growth_max: GROWTH_MAX,
            path: ReducedPath::BunchKaufman,
            r_tmp: vec![[0.0; NL]; n + 1],
            y_tmp: vec![[0.0; NL]; n + 1],
            e: vec![[0.0; NL]; n + 1],
            me: vec![[0.0; NL]; n + 1],
            rhs: vec![0.0; rd],
            by_state: vec![0.0; NR * (n + 1)],
            xq: vec![0.0; n],
            xv: vec![0.0; n],
            xe: vec![0.0; ne],
            s_nu: vec![0.0; NR * n],
            d,
            d_rows,
            rt: vec![0.0; NS * NS * n],
            p: vec![0.0; NR * n * NR * (n + 1)],
            cross: vec![([[0.0; NS]; NS], [[0.0; NS]; NS]); n],
        }
    }

    /// The kept multipliers and ν: R without t̂_f.
    fn dim(&self) -> usize {
        NR * self.n + 1
    }

    /// Whether slot `s` of node `k` is eliminated from the node blocks (the
    /// free positions x_1 … x_{N−1}): their rows of W and h_t must be zero,
    /// and the solve neither reads nor regularizes them.
    pub fn eliminates(&self, k: usize, s: usize) -> bool {
        s == slot::X && self.x.at[k]
    }

    /// Number of variables of node k's block.
    pub fn node_size(&self, k: usize) -> usize {
        self.slots[k].len()
    }

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
        let mut x = [0.0; NL * NL];
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
    pub fn factor_reduced(&mut self, kkt: &KktMatrix) -> Inertia {
        let rd = self.dim() + 1;
        if let Some(mut banded) = self.banded.take() {
            let (s_nunu, a) = self.node_terms(kkt, false);
            let terms = banded::Terms {
                d: &self.d,
                q: &self.q,
                cross: &self.cross,
                s_nu: &self.s_nu,
                g: &self.rhs,
                s_nunu,
                a,
                delta_c: kkt.delta_c,
            };
            let inertia = banded.factor(&terms, self.growth_max);
            self.banded = Some(banded);
            if let Some(inertia) = inertia {
                self.path = ReducedPath::Banded;
                return inertia + self.eliminated_inertia();
            }
        }
        self.form_reduced(kkt);
        if let Some(inertia) =
            self.unpivoted
                .factor(&mut self.reduced.a[..rd * rd], rd, self.growth_max)
        {
            self.path = ReducedPath::Unpivoted;
            return inertia + self.eliminated_inertia();
        }
        self.form_reduced(kkt);
        self.path = ReducedPath::BunchKaufman;
        self.reduced.factor(rd) + self.eliminated_inertia()
    }

    /// The inertia of the eliminated pairs (x_k, its part of λ_x): N − 1
    /// positive and N − 1 negative eigenvalues.
    fn eliminated_inertia(&self) -> Inertia {
        let ne = self.x.nodes.len();
        Inertia {
            positive: ne,
            negative: ne,
            zero: 0,
        }
    }

    /// Form R's lower triangle in `reduced.a`, and g in `rhs`.
    ///
    /// Inside R the kept multipliers are ordered state-major (λ of state c at
    /// point i is row (c − 1)·N + i), so that the D ⊗ I part of S,
    /// S^{cc2} = D·diag(Q_k(c, c2))·Dᵀ, is seven dense products P_{c2}·Dᵀ
    /// (faer's SIMD matmul) instead of a scattered 49·N³ loop, which took
    /// 56 % of a solve at N = 40 (perf). ν's row is formed like any other
    /// constraint's, from its per-node coefficients e_k.
    fn form_reduced(&mut self, kkt: &KktMatrix) {
        let (s_nunu, a) = self.node_terms(kkt, true);
        self.assemble_dense(kkt, s_nunu, a);
    }

    /// What R is made of, node by node: g (in `rhs`), ν's couplings S_{ν·}
    /// (in `s_nu`), the kept states' Q_k, the cross terms R_k and T_k, e_k
    /// and M_k e_k, and (for the dense path, `dense`) P; returns S_νν and
    /// R's t̂_f diagonal h_tt − h_tᵀ W⁻¹ h_t.
    fn node_terms(&mut self, kkt: &KktMatrix, dense: bool) -> (f64, f64) {
        let n = self.n;
        let nn = n + 1;
        let pdim = NR * n;
        let nu = pdim;
        let sm = |c: usize, i: usize| (c - 1) * n + i;
        let mut g = std::mem::take(&mut self.rhs);
        for i in 0..n {
            for c in 1..NS {
                g[sm(c, i)] = kkt.j_t[i][c];
            }
        }
        g[nu] = (0..n).map(|i| self.x.null[i] * kkt.j_t[i][slot::X]).sum();
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
            let state = |p: usize| (sl[p] >= 1 && sl[p] < NS).then_some(sl[p]);
            // ν's row over the block: ŵ_k·(x's defect row at k) and, at node
            // N, x_N's column of D.
            let mut e = [0.0; NL];
            for p in 0..b {
                e[p] = if k < n {
                    self.x.null[k] * kkt.b[k][slot::X][sl[p]]
                } else if sl[p] == slot::X {
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
            *qk = [[0.0; NR]; NR];
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
                    qk[c - 1][c2 - 1] = mpq;
                    if dense {
                        let base = ((c2 - 1) * nn + k) * pdim + sm(c, 0);
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
            let mut gm = [[0.0; NS]; NL];
            for p in 0..b {
                for row in 1..NS {
                    gm[p][row] = (0..b).map(|q| m[p][q] * bk[row][sl[q]]).sum();
                }
            }
            let mut rm = [[0.0; NS]; NS];
            for p in 0..b {
                if let Some(c) = state(p) {
                    rm[c] = gm[p];
                }
            }
            let mut tm = [[0.0; NS]; NS];
            for c in 1..NS {
                for c2 in 1..NS {
                    tm[c][c2] = (0..b).map(|p| bk[c][sl[p]] * gm[p][c2]).sum();
                }
                g[sm(c, k)] -= (0..b).map(|p| bk[c][sl[p]] * u[p]).sum::<f64>();
                self.s_nu[sm(c, k)] += (0..b).map(|p| bk[c][sl[p]] * me[p]).sum::<f64>();
            }
            self.cross[k] = (rm, tm);
        }
        self.rhs = g;
        (s_nunu, a)
    }

    /// R's lower triangle in `reduced.a` from the node terms, and g's t̂_f
    /// column.
    fn assemble_dense(&mut self, kkt: &KktMatrix, s_nunu: f64, a: f64) {
        let n = self.n;
        let dim = self.dim();
        let rd = dim + 1;
        let nn = n + 1;
        let pdim = NR * n;
        let nu = pdim;
        let sm = |c: usize, i: usize| (c - 1) * n + i;
        let g = &self.rhs;
        // −S = −Σ_k (d_k d_kᵀ) ⊗ Q_k by seven products, into R's leading
        // block; only the blocks on and below the diagonal (c ≥ c2) are
        // formed, since the factorization reads the lower triangle alone.
        {
            let mut r = MatMut::from_column_major_slice_mut(&mut self.reduced.a[..rd * rd], rd, rd);
            let pm = MatRef::from_column_major_slice(&self.p, pdim, NR * nn);
            let d = MatRef::from_column_major_slice(&self.d, n, nn);
            for c2 in 1..NS {
                let rows = sm(c2, 0);
                matmul(
                    r.rb_mut().submatrix_mut(rows, rows, pdim - rows, n),
                    Accum::Replace,
                    pm.subcols((c2 - 1) * nn, nn).subrows(rows, pdim - rows),
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
        for c2 in 1..NS {
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
        r[nu * rd + nu] = -s_nunu;
        for c in 0..dim {
            r[c * rd + c] -= kkt.delta_c;
            r[c * rd + dim] = g[c];
        }
        r[dim * rd + dim] = a;
    }

    /// Set the largest growth of an unpivoted LDLᵀ that is kept, of R and of
    /// the node blocks (0: always Bunch–Kaufman).
    pub fn set_growth_max(&mut self, growth_max: f64) {
        self.growth_max = growth_max;
    }

    /// The factorization of R that the last [`Self::factor_reduced`] used.
    pub fn reduced_path(&self) -> ReducedPath {
        self.path
    }

    /// Solve K [x_w; x_l] = [r_w; r_l] with the current factors (full layout;
    /// fixed slots of x_w are zero).
    pub fn solve(
        &mut self,
        nlp: &Nlp,
        kkt: &KktMatrix,
        r_w: &[f64],
        r_l: &[f64],
        x_w: &mut [f64],
        x_l: &mut [f64],
    ) {
        let n = self.n;
        let nn = n + 1;
        let dim = self.dim();
        let nu = dim - 1;
        let tf = nlp.tf_idx();
        let sm = |c: usize, i: usize| (c - 1) * n + i;
        // x: q = A⁺ᵀ r_x, λ_x's part in range(A); B̃ᵀq leaves the right-hand side.
        for (e, &k) in self.x.nodes.iter().enumerate() {
            self.xe[e] = r_w[nlp.idx(k, slot::X)];
        }
        self.x.pinv_t_mul(&self.xe, &mut self.xq);
        let q = &self.xq;
        let mut rt = r_w[tf] - (0..n).map(|i| kkt.j_t[i][slot::X] * q[i]).sum::<f64>();
        // Per node: r_k (less B̃ᵀq), ỹ = M r_k, r̃_t = r_t − h_tᵀ ỹ, and ỹ by state.
        for k in 0..=n {
            let sl = &self.slots[k];
            let mut r = [0.0; NL];
            for (p, &s) in sl.iter().enumerate() {
                r[p] = r_w[nlp.idx(k, s)]
                    - if k < n {
                        kkt.b[k][slot::X][s] * q[k]
                    } else if s == slot::X {
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
            for c in 1..NS {
                let p = self.pos[k][c];
                self.by_state[(c - 1) * nn + k] = if p == usize::MAX { 0.0 } else { y[p] };
            }
            self.r_tmp[k] = r;
            self.y_tmp[k] = y;
        }
        // R's right-hand side: r_λ − J ỹ over the kept rows, ŵᵀr_λx − eᵀỹ, r̃_t.
        let mut rl = std::mem::take(&mut self.rhs);
        for i in 0..n {
            for c in 1..NS {
                let y = &self.y_tmp[i];
                let sl = &self.slots[i];
                rl[sm(c, i)] = r_l[i * NS + c]
                    - (0..sl.len())
                        .map(|p| kkt.b[i][c][sl[p]] * y[p])
                        .sum::<f64>();
            }
        }
        for c in 1..NS {
            // r −= D ỹ_c, one contiguous axpy per node.
            let yc = &self.by_state[(c - 1) * nn..c * nn];
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
            .map(|i| self.x.null[i] * r_l[i * NS + slot::X])
            .sum::<f64>()
            - (0..=n)
                .map(|k| {
                    let (e, y) = (&self.e[k], &self.y_tmp[k]);
                    (0..self.slots[k].len()).map(|p| e[p] * y[p]).sum::<f64>()
                })
                .sum::<f64>();
        rl[dim] = rt;
        match self.path {
            ReducedPath::Unpivoted => {
                Ldlt::solve(&self.reduced.a[..(dim + 1) * (dim + 1)], &mut rl[..dim + 1])
            }
            ReducedPath::BunchKaufman => self.reduced.solve(dim + 1, &mut rl, 1),
            ReducedPath::Banded => self
                .banded
                .as_mut()
                .expect("the banded path has its factors")
                .solve(&mut rl[..dim + 1]),
        }
        let t = rl[dim];
        let nu_v = rl[nu];
        // y_k = M_k (r_k − h_t t − J_kᵀ λ − e_k ν), with J_kᵀλ's D part as
        // one contiguous dot product per kept state.
        x_w.iter_mut().for_each(|v| *v = 0.0);
        x_w[tf] = t;
        for k in 0..=n {
            let sl = &self.slots[k];
            let mut r = self.r_tmp[k];
            let (lo, hi) = self.col_rows[k];
            let d_col = &self.d[k * n + lo..k * n + hi];
            for (p, &s) in sl.iter().enumerate() {
                r[p] -= kkt.h_t[k][s] * t + self.e[k][p] * nu_v;
                if (1..NS).contains(&s) {
                    let lam = &rl[sm(s, lo)..sm(s, hi)];
                    r[p] -= d_col.iter().zip(lam).map(|(d, l)| d * l).sum::<f64>();
                }
                if k < n {
                    r[p] -= (1..NS).map(|c| kkt.b[k][c][s] * rl[sm(c, k)]).sum::<f64>();
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
        for i in 0..n {
            for c in 1..NS {
                x_l[i * NS + c] = rl[sm(c, i)];
            }
        }
        // x: Δx = A⁺(r_λx − B̃y + δ_c q) and λ_x = q + ŵν.
        let x_n = if self.pos[n][slot::X] == usize::MAX {
            0.0
        } else {
            self.y_tmp[n][self.pos[n][slot::X]]
        };
        for i in 0..n {
            let sl = &self.slots[i];
            let y = &self.y_tmp[i];
            let by: f64 = (0..sl.len()).map(|p| kkt.b[i][slot::X][sl[p]] * y[p]).sum();
            self.xv[i] =
                r_l[i * NS + slot::X] - by - self.d[n * n + i] * x_n - kkt.j_t[i][slot::X] * t
                    + kkt.delta_c * self.xq[i];
            x_l[i * NS + slot::X] = self.xq[i] + self.x.null[i] * nu_v;
        }
        self.x.pinv_mul(&self.xv, &mut self.xe);
        for (e, &k) in self.x.nodes.iter().enumerate() {
            x_w[nlp.idx(k, slot::X)] = self.xe[e];
        }
        self.rhs = rl;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;
    use nalgebra::{DMatrix, DVector};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A random system on `nlp`'s structure, with node blocks of both signs
    /// (AᵀA − I/2), or positive definite ones (AᵀA + I/2) when `definite`.
    fn random_system(nlp: &Nlp, rng: &mut ChaCha8Rng, definite: bool) -> KktMatrix {
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
        // keeps its Hessian: the soft terminal term's).
        for node in 0..nlp.n {
            for r in 0..NL {
                k.w[node][slot::X][r] = 0.0;
                k.w[node][r][slot::X] = 0.0;
            }
            k.h_t[node][slot::X] = 0.0;
            for c in 0..NS {
                k.b[node][c][slot::X] = 0.0;
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
        // (N, intervals, definite node blocks and δ_c = 1e-2, x_N free).
        let cases = [
            (6, 1, false, false),
            (9, 3, false, false),
            (6, 1, true, false),
            (9, 3, true, true),
            (7, 1, false, true),
            (20, 1, false, false),
            (8, 2, false, false),
            (13, 4, false, true),
            (13, 4, true, false),
            (30, 5, false, false),
        ];
        for ((nodes, intervals, definite, soft), path) in cases.into_iter().flat_map(|c| {
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
            let mut sv = crate::SolverSettings::default();
            if soft {
                sv.terminal_lateral_weight = 1.0;
            }
            let nlp = Nlp::new(&s, &sv);
            let kkt = random_system(&nlp, &mut rng, definite);
            let mut solver = KktSolver::new(&nlp);
            if path == ReducedPath::BunchKaufman {
                solver.set_growth_max(0.0);
            }
            let mut inertia = Inertia::default();
            for k in 0..=nlp.n {
                inertia = inertia + solver.factor_node(k, &kkt.w[k], 0.0);
            }
            inertia = inertia + solver.factor_reduced(&kkt);
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
                kkt.multiply(&nlp, &xw, &xl, &mut yw, &mut yl);
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
            solver.solve(&nlp, &kkt, &rw, &rl, &mut xw, &mut xl);
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
    }

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

    /// The unpivoted LDLᵀ declines a zero pivot and a large growth, and
    /// counts the inertia of what it keeps.
    #[test]
    fn unpivoted_ldlt_declines_zero_pivots_and_growth() {
        // Column-major lower triangles of 2×2 matrices.
        let mut f = Ldlt::new(2);
        assert!(f.factor(&mut [0.0, 1.0, 0.0, 0.0], 2, GROWTH_MAX).is_none());
        // [[1e-9, 1], [1, 1]]: L₂₁ = 1e9, growth ≈ 2e9.
        assert!(f
            .factor(&mut [1e-9, 1.0, 0.0, 1.0], 2, GROWTH_MAX)
            .is_none());
        // [[2, 1], [1, −3]]: one positive, one negative eigenvalue.
        let mut a = [2.0, 1.0, 0.0, -3.0];
        let i = f.factor(&mut a, 2, GROWTH_MAX).expect("kept");
        assert_eq!((i.positive, i.negative, i.zero), (1, 1, 0));
        let mut x: [f64; 2] = [1.0, 2.0];
        Ldlt::solve(&a, &mut x);
        // [[2, 1], [1, −3]]⁻¹ [1, 2] = [5/7, −3/7].
        assert!((x[0] - 5.0 / 7.0).abs() < 1e-15 && (x[1] + 3.0 / 7.0).abs() < 1e-15);
    }

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
