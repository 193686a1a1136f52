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
//! first eliminated exactly (`XElimination`: x is linear, with zero rows
//! of W), leaving one row ν of their defects; except where an operational
//! row involves x (the approach cone, issue 37: its barrier terms give x
//! rows of W), where x stays a state of the node blocks and of R
//! ([`Layout::eliminates_x`]) and ν's row is a placeholder. Each block W_k (at most 12
//! square, symmetric, possibly indefinite) is factored and inverted (an
//! unpivoted LDLᵀ with a growth test, Bunch–Kaufman as fallback); the
//! reduced system
//!
//! ```text
//! R = [ h_tt − h_tᵀ W⁻¹ h_t    gᵀ ]     g = j_t − J_y W⁻¹ h_t
//!     [ g                    −S  ]     S = δ_c I + J_y W⁻¹ J_yᵀ
//! ```
//!
//! over the kept multipliers, ν and t̂_f (7N + 2 square, or 8N + 2 with x
//! kept; dense on the global
//! mesh) is factored densely on the global mesh, and block by block over the
//! intervals on an hp mesh, where it is block-tridiagonal with a border of
//! two (`banded`). By Sylvester's law of inertia, In(K) =
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
//!
//! The sizes are const parameters, NS states with defects and NL local
//! slots per node (8 and 12 in the plane, the defaults), and the
//! transcription is seen through [`Layout`]: the solve is the model seam's
//! (issue 38), with the planar one monomorphised as before.
//!
//! The files: this one holds the system ([`KktMatrix`]) and the solver's
//! storage; `dense` the dense factorizations (Bunch–Kaufman, the unpivoted
//! LDLᵀ with its growth test, the node blocks' small inverse); `elimination`
//! x's exact elimination; `factor` the node blocks and R; `solve` the
//! structured solve; `banded` R on an hp mesh.

#![allow(clippy::needless_range_loop)] // Dense block algebra indexes several arrays by one index.

use crate::collocation::derivatives::Differentiable;
use crate::collocation::mesh::Mesh;
use crate::method::direct::nlp::{Transcription, NL as PLANAR_NL, NS as PLANAR_NS};

mod banded;
mod dense;
mod elimination;
mod factor;
mod solve;

use dense::{Lblt, Ldlt};
use elimination::XElimination;

/// A block over the states (8×8 in the plane).
type StateBlock<const NS: usize> = [[f64; NS]; NS];

/// The state that the solve can eliminate exactly: the first, the downrange
/// position x (linear, ẋ = Vx, with zero rows of W unless a row involves
/// it), in the planar model's layout and the 6-DoF one's alike.
const X: usize = 0;

/// The blocks of one Newton system (scaled units), set by the caller.
#[derive(Debug, Clone)]
pub struct KktMatrix<const NS: usize = PLANAR_NS, const NL: usize = PLANAR_NL> {
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

impl<const NS: usize, const NL: usize> KktMatrix<NS, NL> {
    /// A zero system for `nlp`.
    pub fn zeros(nlp: &impl Layout<NS, NL>) -> Self {
        KktMatrix {
            w: vec![[[0.0; NL]; NL]; nlp.n() + 1],
            h_t: vec![[0.0; NL]; nlp.n() + 1],
            h_tt: 0.0,
            b: vec![[[0.0; NL]; NS]; nlp.n()],
            j_t: vec![[0.0; NS]; nlp.n()],
            delta_c: 0.0,
        }
    }

    /// Back to the state of [`Self::zeros`].
    pub fn reset(&mut self) {
        self.w.fill([[0.0; NL]; NL]);
        self.h_t.fill([0.0; NL]);
        self.h_tt = 0.0;
        self.b.fill([[0.0; NL]; NS]);
        self.j_t.fill([0.0; NS]);
        self.delta_c = 0.0;
    }

    /// The upper triangle of K as triplets (row, column, value) over the
    /// free variables (full-vector order, t̂_f last) and then the
    /// multipliers: the matrix a general sparse LDLᵀ would factor. Returns
    /// the number of free variables, the dimension and the triplets.
    #[allow(clippy::type_complexity)]
    pub fn upper_triplets(
        &self,
        nlp: &impl Layout<NS, NL>,
    ) -> (usize, usize, Vec<usize>, Vec<usize>, Vec<f64>) {
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
        for k in 0..=nlp.n() {
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
        for i in 0..nlp.n() {
            let (first, row) = nlp.mesh().d_row(i);
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
    pub fn multiply(
        &self,
        nlp: &impl Layout<NS, NL>,
        x_w: &[f64],
        x_l: &[f64],
        y_w: &mut [f64],
        y_l: &mut [f64],
    ) {
        let n = nlp.n();
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
            let (first, row) = nlp.mesh().d_row(i);
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

/// How R was factored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReducedPath {
    /// LDLᵀ without pivoting, its growth at most [`GROWTH_MAX`].
    Unpivoted,
    /// Bunch–Kaufman LBLᵀ, when the unpivoted factorization meets a zero
    /// pivot or grows.
    BunchKaufman,
    /// On an hp mesh: block by block over the intervals (`banded`), each
    /// block's unpivoted LDLᵀ within [`GROWTH_MAX`]; Bunch–Kaufman on the
    /// whole of R otherwise.
    Banded,
}

/// The largest growth of an unpivoted LDLᵀ of R that is kept: a backward
/// error of about 1e-10·|R|, which the refinement removes.
pub const GROWTH_MAX: f64 = 1e6;

/// What the structured KKT solve needs of a transcription: its sizes (NS
/// states with defects, NL local slots per node), its layout and mesh,
/// which variables are fixed, and whether x is eliminated.
pub trait Layout<const NS: usize, const NL: usize> {
    /// Collocation points N.
    fn n(&self) -> usize;
    /// Index of slot `s` of node `k` in the full vector.
    fn idx(&self, k: usize, s: usize) -> usize;
    /// Index of t̂_f.
    fn tf_idx(&self) -> usize;
    /// Length of the full vector.
    fn n_var(&self) -> usize;
    /// Number of defects, N·NS.
    fn n_con(&self) -> usize;
    /// Whether variable `j` is fixed.
    fn is_fixed(&self, j: usize) -> bool;
    fn mesh(&self) -> &Mesh;
    /// For each node k: the collocation points i with D_ik ≠ 0 and D_ik.
    fn d_cols(&self) -> &[Vec<(usize, f64)>];
    /// Whether x_1 … x_{N−1} (the first state) and their defects are eliminated
    /// from the system (`XElimination`).
    fn eliminates_x(&self) -> bool;
}

/// A model's transcription ([`Transcription`]). It eliminates x (slot 0:
/// in both models it enters f only through ẋ = Vx, and has no bound)
/// unless an operational row involves x (the planar approach cone, issue
/// 37), whose barrier terms give x rows of W.
impl<M, const NS: usize, const NL: usize> Layout<NS, NL> for Transcription<M, NS, NL>
where
    M: Differentiable,
{
    fn n(&self) -> usize {
        self.n
    }
    fn idx(&self, k: usize, s: usize) -> usize {
        Transcription::idx(self, k, s)
    }
    fn tf_idx(&self) -> usize {
        Transcription::tf_idx(self)
    }
    fn n_var(&self) -> usize {
        Transcription::n_var(self)
    }
    fn n_con(&self) -> usize {
        Transcription::n_con(self)
    }
    fn is_fixed(&self, j: usize) -> bool {
        Transcription::is_fixed(self, j)
    }
    fn mesh(&self) -> &Mesh {
        &self.mesh
    }
    fn d_cols(&self) -> &[Vec<(usize, f64)>] {
        &self.d_cols
    }
    fn eliminates_x(&self) -> bool {
        !self
            .limits
            .iter()
            .any(|r| r.limit == crate::problem::constraints::Limit::Cone)
    }
}

/// Storage and factors of the structured KKT solve.
pub struct KktSolver<const NS: usize = PLANAR_NS, const NL: usize = PLANAR_NL> {
    n: usize,
    /// Per node: the free local slots in the node block (x excluded where
    /// eliminated), in order, and each slot's position (usize::MAX: none).
    slots: Vec<Vec<usize>>,
    pos: Vec<[usize; NL]>,
    /// The elimination of x and its defects (none where x is kept).
    x: XElimination,
    /// The first kept state of R: 1 (z) when x is eliminated, 0 (x) when
    /// it is kept; R keeps states c0 … 7, `nr` = 8 − c0 of them per point.
    c0: usize,
    nr: usize,
    /// Per node: M_k = (W_k + δ I)⁻¹ over the block's slots (row-major, NL×NL).
    m_inv: Vec<[[f64; NL]; NL]>,
    /// The node blocks' factorization (≤ NL square).
    node: Lblt,
    /// R, (nr·N + 2) square: the kept multipliers (state-major), ν, then
    /// t̂_f (ν a placeholder row −1 where x is kept).
    reduced: Lblt,
    /// R's LDLᵀ without pivoting, and the largest growth kept.
    unpivoted: Ldlt,
    /// On an hp mesh, R's block-tridiagonal factorization.
    banded: Option<banded::Banded>,
    /// Per node: M_k over the states, by state (zero where a state is
    /// fixed or not kept).
    q: Vec<StateBlock<NS>>,
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
    /// `R_i[c2][c]` by (c2, c), contiguous in i.
    rt: Vec<f64>,
    /// P = (I ⊗ D)·blockdiag(Q) over the kept states: rN × r(N+1), column-major (r = 7, or 8 with x).
    p: Vec<f64>,
    /// Per collocation point: R_k = E M Bᵀ and T_k = B M Bᵀ.
    cross: Vec<(StateBlock<NS>, StateBlock<NS>)>,
}

impl<const NS: usize, const NL: usize> KktSolver<NS, NL> {
    pub fn new(nlp: &impl Layout<NS, NL>) -> Self {
        let n = nlp.n();
        let mut d = vec![0.0; n * (n + 1)];
        let mut d_rows = vec![0.0; n * (n + 1)];
        for (k, col) in nlp.d_cols().iter().enumerate() {
            for &(i, v) in col {
                d[k * n + i] = v;
                d_rows[i * (n + 1) + k] = v;
            }
        }
        let c0 = usize::from(nlp.eliminates_x());
        let nr = NS - c0;
        let x = XElimination::new(nlp, &d, c0 == 1);
        let slots: Vec<Vec<usize>> = (0..=n)
            .map(|k| {
                (0..NL)
                    .filter(|&s| !(nlp.is_fixed(nlp.idx(k, s)) || s == X && x.at[k]))
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
        let rd = nr * n + 2;
        let col_rows = nlp
            .d_cols()
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
            c0,
            nr,
            m_inv: vec![[[0.0; NL]; NL]; n + 1],
            node: Lblt::new(NL, NL),
            reduced: Lblt::new(rd, 1),
            unpivoted: Ldlt::new(rd),
            banded: (nlp.mesh().intervals.len() > 1).then(|| banded::Banded::new(nlp.mesh(), nr)),
            q: vec![[[0.0; NS]; NS]; n + 1],
            col_rows,
            growth_max: GROWTH_MAX,
            path: ReducedPath::BunchKaufman,
            r_tmp: vec![[0.0; NL]; n + 1],
            y_tmp: vec![[0.0; NL]; n + 1],
            e: vec![[0.0; NL]; n + 1],
            me: vec![[0.0; NL]; n + 1],
            rhs: vec![0.0; rd],
            by_state: vec![0.0; nr * (n + 1)],
            xq: vec![0.0; n],
            xv: vec![0.0; n],
            xe: vec![0.0; ne],
            s_nu: vec![0.0; nr * n],
            d,
            d_rows,
            rt: vec![0.0; NS * NS * n],
            p: vec![0.0; nr * n * nr * (n + 1)],
            cross: vec![([[0.0; NS]; NS], [[0.0; NS]; NS]); n],
        }
    }

    /// Whether this solver's structure is `nlp`'s: the same mesh (D's
    /// columns) and the same fixed variables, the two things [`Self::new`]
    /// builds its structure from. A re-plan of the same problem keeps
    /// both, so it can [`Self::reset`] this solver instead of building one.
    pub fn fits(&self, nlp: &impl Layout<NS, NL>) -> bool {
        let eliminating = self.c0 == 1;
        nlp.n() == self.n
            && nlp.eliminates_x() == eliminating
            && (0..=self.n).all(|k| {
                let free = |s: usize| !(nlp.is_fixed(nlp.idx(k, s)) || s == X && self.x.at[k]);
                (0..NL)
                    .filter(|&s| free(s))
                    .eq(self.slots[k].iter().copied())
                    && self.x.at[k] == (eliminating && k < self.n && !nlp.is_fixed(nlp.idx(k, X)))
            })
            && nlp
                .d_cols()
                .iter()
                .enumerate()
                .all(|(k, col)| col.iter().all(|&(i, v)| self.d[k * self.n + i] == v))
            && self.d.iter().filter(|&&v| v != 0.0).count()
                == nlp.d_cols().iter().map(Vec::len).sum::<usize>()
    }

    /// Back to the state of [`Self::new`] for the same structure: every
    /// factor and work vector zero, the growth limit and the path as new.
    pub fn reset(&mut self) {
        self.m_inv.fill([[0.0; NL]; NL]);
        self.node.reset();
        self.reduced.reset();
        self.unpivoted.reset();
        if let Some(b) = &mut self.banded {
            b.reset();
        }
        self.q.fill([[0.0; NS]; NS]);
        self.growth_max = GROWTH_MAX;
        self.path = ReducedPath::BunchKaufman;
        for v in [&mut self.r_tmp, &mut self.y_tmp, &mut self.e, &mut self.me] {
            v.fill([0.0; NL]);
        }
        for v in [
            &mut self.rhs,
            &mut self.by_state,
            &mut self.xq,
            &mut self.xv,
            &mut self.xe,
            &mut self.s_nu,
            &mut self.rt,
            &mut self.p,
        ] {
            v.fill(0.0);
        }
        self.cross.fill(([[0.0; NS]; NS], [[0.0; NS]; NS]));
    }

    /// The kept multipliers and ν: R without t̂_f.
    fn dim(&self) -> usize {
        self.nr * self.n + 1
    }

    /// R's row of the multiplier of state c ≥ c0 at point i (state-major).
    #[inline]
    fn sm(&self, c: usize, i: usize) -> usize {
        (c - self.c0) * self.n + i
    }

    /// Whether slot `s` of node `k` is eliminated from the node blocks (the
    /// free positions x_1 … x_{N−1}): their rows of W and h_t must be zero,
    /// and the solve neither reads nor regularizes them.
    pub fn eliminates(&self, k: usize, s: usize) -> bool {
        s == X && self.x.at[k]
    }

    /// Number of variables of node k's block.
    pub fn node_size(&self, k: usize) -> usize {
        self.slots[k].len()
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
}
