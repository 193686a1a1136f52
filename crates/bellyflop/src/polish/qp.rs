//! A dense primal–dual interior point for the polish's small QPs
//! (Mehrotra's predictor–corrector; Nocedal & Wright, §16.6):
//!
//!   min ½·xᵀ·diag(p)·x + qᵀx   s.t.   A·x = b,   G·x + s = h,  s ≥ 0,
//!
//! with a few tens of variables, a few equality rows and a few hundred
//! sparse inequality rows (bounds at grid points, the trust box, the
//! slacks' signs). Each iteration eliminates s and the inequality duals z,
//!
//!   H·Δx + Aᵀ·Δy = r₁,   A·Δx = r₂,   H = diag(p) + Gᵀ·(Z/S)·G,
//!
//! forms H from the rows' sparse outer products, factors it and the Schur
//! complement A·H⁻¹·Aᵀ by a dense Cholesky, and solves the predictor and
//! the corrector with the same factors. Every row is scaled to a unit
//! ∞-norm first (the thrust rows come in newtons).
//!
//! Why not Clarabel, which solved these before: it is a general conic
//! solver for large sparse problems, and each polish QP is a new problem,
//! so every solve paid its setup (equilibration, AMD ordering, a symbolic
//! and a numeric sparse LDLᵀ of a ~560-square KKT matrix, refinement): 78 %
//! of the instructions of a whole default solve of the paper's case
//! (callgrind, BENCHMARKS.md, issue 35). Here H is 62-square and dense.

/// A sparse row Σ coef·x_c and its right-hand side.
pub type Row = (Vec<(usize, f64)>, f64);

/// One QP (module docs).
#[derive(Debug, Clone, Copy)]
pub struct Problem<'a> {
    /// The diagonal of P, ≥ 0 (its length is the number of variables).
    pub p: &'a [f64],
    /// A dense symmetric block added to P on the first nd variables
    /// (row-major, nd² entries): the polish's Lagrangian Hessian.
    pub dense: Option<&'a [f64]>,
    pub q: &'a [f64],
    /// A·x = b.
    pub eq: &'a [Row],
    /// G·x ≤ h.
    pub le: &'a [Row],
}

/// Converged when the scaled residuals of A·x = b, G·x + s = h and the
/// stationarity are below this, ...
pub const TOLERANCE: f64 = 1e-9;

/// ... and the mean complementarity sᵀz/m below this: an active row is
/// then within GAP/z of its bound, z its multiplier (up to the slacks'
/// weight, 100), and an inactive one's multiplier is of order GAP. Asking
/// for less drives z/s of the active rows past 1e15, where H's Cholesky
/// factorization fails to rounding (measured on the paper's case).
pub const GAP_TOLERANCE: f64 = 1e-8;

/// The iterate is still returned, as almost solved, when the loop ends
/// with its residuals below this. The polish judges every step by its own
/// shot and the bounds at the step's own extrema, so a step from a looser
/// answer is safe; 1e-6 left one of 300 seeded states (`bench/safety.py`)
/// without a step at 3.4e-6.
pub const LOOSE_TOLERANCE: f64 = 1e-5;

/// Iteration limit.
pub const MAX_ITERATIONS: u32 = 60;

/// The fraction of the way to the boundary that a step may go.
const STEP_TO_BOUNDARY: f64 = 0.995;

/// Added to H's diagonal: H is positive definite whenever every variable
/// has a bound or p > 0, as in the polish; this only keeps a variable with
/// neither from stopping the factorization. Absolute, not relative to H's
/// largest entry: near the answer z/s of an active row grows past 1e10,
/// and a relative shift then spoils the step of every other variable
/// (measured: the dual residual stalled at 1e-5 to 1e-1). Where rounding
/// still stops the factorization (z/s spans 20 orders of magnitude), the
/// shift grows ×100 up to [`MAX_REGULARIZATION`], and iterative refinement
/// takes the step back to the unshifted equations.
const REGULARIZATION: f64 = 1e-12;
const MAX_REGULARIZATION: f64 = 1e-4;

/// Iterative refinement steps of a Newton solve with a grown shift, at
/// most, while the equations' residual is above this fraction of their
/// right-hand side's size.
const REFINEMENT_STEPS: usize = 3;
const REFINEMENT_TOLERANCE: f64 = 1e-10;

/// How a solve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Within [`TOLERANCE`].
    Solved,
    /// Within [`LOOSE_TOLERANCE`] where the iteration limit or a failed
    /// factorization stopped it.
    AlmostSolved,
}

/// The answer: x, the multipliers y of A·x = b and z ≥ 0 of G·x ≤ h (of
/// the rows as given, unscaled), and the iterations.
#[derive(Debug, Clone, PartialEq)]
pub struct Answer {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub z: Vec<f64>,
    pub iterations: u32,
    pub status: Status,
}

/// Why a solve failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum QpError {
    #[error("the QP did not converge in {iterations} iterations (scaled residual {residual:.2e}; its factorization may have failed to rounding)")]
    NotConverged { iterations: u32, residual: f64 },
    #[error("the QP's reduced matrix is not positive definite at iteration {iteration}")]
    Factorization { iteration: u32 },
    #[error("the QP's iterate left the finite numbers at iteration {iteration}")]
    NonFinite { iteration: u32 },
    #[error("a row of the QP names variable {column}, but it has {n}")]
    Column { column: usize, n: usize },
    #[error("the QP's data are not finite")]
    Data,
    #[error("the QP's rows are inconsistent: row {row} stays {residual:.2e} from its bound")]
    Infeasible { row: usize, residual: f64 },
    #[error("the QP's Hessian is not positive definite")]
    NotStrictlyConvex,
}

/// A dense block and its side nd (nd² entries; None if absent).
pub(crate) fn dense_block(dense: Option<&[f64]>) -> Option<(&[f64], usize)> {
    dense.map(|d| (d, (d.len() as f64).sqrt().round() as usize))
}

/// out += D·x on the dense block's variables.
fn add_dense_times(dense: Option<&[f64]>, x: &[f64], out: &mut [f64]) {
    if let Some((d, nd)) = dense_block(dense) {
        for (r, o) in out.iter_mut().enumerate().take(nd) {
            *o += dense::dot(&d[r * nd..(r + 1) * nd], &x[..nd]);
        }
    }
}

/// The rows scaled to a unit ∞-norm: (rows, their scales).
pub(crate) fn scaled(rows: &[Row]) -> (Vec<Row>, Vec<f64>) {
    rows.iter()
        .map(|(terms, rhs)| {
            let r = terms.iter().map(|(_, v)| v.abs()).fold(0.0, f64::max);
            let r = if r > 0.0 { r } else { 1.0 };
            let row = (terms.iter().map(|&(c, v)| (c, v / r)).collect(), rhs / r);
            (row, r)
        })
        .unzip()
}

/// y = M·x over sparse rows.
fn rows_times(rows: &[Row], x: &[f64], y: &mut [f64]) {
    for (yk, (terms, _)) in y.iter_mut().zip(rows) {
        *yk = terms.iter().map(|&(c, v)| v * x[c]).sum();
    }
}

/// out += Mᵀ·w over sparse rows.
fn add_rows_transposed(rows: &[Row], w: &[f64], out: &mut [f64]) {
    for (wk, (terms, _)) in w.iter().zip(rows) {
        for &(c, v) in terms {
            out[c] += v * wk;
        }
    }
}

fn norm_inf(v: &[f64]) -> f64 {
    v.iter().map(|x| x.abs()).fold(0.0, f64::max)
}

/// The largest α ≤ 1 with v + α·dv ≥ 0.
fn step_to_boundary(v: &[f64], dv: &[f64]) -> f64 {
    v.iter()
        .zip(dv)
        .filter(|(_, d)| **d < 0.0)
        .map(|(v, d)| -v / d)
        .fold(1.0, f64::min)
}

/// Rows with z/s above this are kept in the Schur complement rather than
/// eliminated into H ([`Factors`]).
const KEEP_WEIGHT: f64 = 1e4;

/// Rows of more terms than this enter H through a dense copy
/// ([`Factors::add_long_row`]).
const LONG_ROW: usize = 16;

/// The factors of one Newton matrix (column-major). The inequality rows
/// split by their weight w = z/s: those below [`KEEP_WEIGHT`] and the
/// bounds of one variable are eliminated into H = diag(p) + shift·I +
/// Σ w_k·g_k·g_kᵀ; the other rows of several terms (nearly active, whose w
/// grows past 1e15 near the answer, where their outer products leave H's
/// factorization to rounding) stay as rows of M = [A; G_kept] with
/// −D = −diag(0, s/z) on their diagonal. (A bound's weight only adds to a
/// diagonal entry, which rounding does not spoil; kept, it would leave a
/// variable such as a slack with no curvature in H at all.)
///
///   H·dx + Mᵀ·λ = r₁,   M·dx − D·λ = r₂,
///
/// solved with L·Lᵀ = H, V = L⁻¹·Mᵀ and the Cholesky factor of
/// Vᵀ·V + D (positive definite while A has full rank).
struct Factors {
    n: usize,
    me: usize,
    /// The diagonal shift of the last factorization.
    shift: f64,
    /// The inequality rows kept in M, and their D = s/z.
    kept: Vec<usize>,
    d: Vec<f64>,
    h: Vec<f64>,
    v: Vec<f64>,
    schur: Vec<f64>,
    /// A long row's dense copy.
    row: Vec<f64>,
}

impl Factors {
    fn new(n: usize, me: usize) -> Self {
        Factors {
            n,
            me,
            shift: 0.0,
            kept: Vec::new(),
            d: Vec::new(),
            h: vec![0.0; n * n],
            v: Vec::new(),
            schur: Vec::new(),
            row: Vec::new(),
        }
    }

    /// H += w·g·gᵀ for a row of many terms (the polish's ground and mass
    /// rows, dense in the parameters), through a dense copy of g over its
    /// span of columns, so that each column of H's lower triangle takes one
    /// contiguous update that the compiler vectorizes. The same products
    /// in the same order as the sparse loop (plus zeros), so the same H;
    /// the sparse loop's scattered pairs were 45 % of a 6-DoF polish
    /// (`perf`, ~280 rows of 83 terms, 30 factorizations a QP).
    fn add_long_row(&mut self, terms: &[(usize, f64)], w: f64) {
        let n = self.n;
        let lo = terms.iter().map(|t| t.0).min().unwrap_or(0);
        let hi = terms.iter().map(|t| t.0 + 1).max().unwrap_or(0);
        self.row.clear();
        self.row.resize(hi - lo, 0.0);
        for &(c, a) in terms {
            self.row[c - lo] += a;
        }
        for (i, &a) in self.row.iter().enumerate() {
            let wa = w * a;
            if wa != 0.0 {
                let c = lo + i;
                self.h[c * n + c..c * n + hi]
                    .iter_mut()
                    .zip(&self.row[i..])
                    .for_each(|(h, b)| *h += wa * b);
            }
        }
    }

    /// The rows of M in order: A's, then the kept rows of G.
    fn m_rows<'a>(&'a self, eq: &'a [Row], le: &'a [Row]) -> impl Iterator<Item = &'a Row> {
        eq.iter().chain(self.kept.iter().map(move |&k| &le[k]))
    }

    /// Factor the Newton matrix for the weights w = z/s (module docs);
    /// false when H or the Schur complement is not numerically positive
    /// definite.
    fn factor(
        &mut self,
        p: &[f64],
        dense: Option<&[f64]>,
        eq: &[Row],
        le: &[Row],
        w: &[f64],
        shift: f64,
    ) -> bool {
        let n = self.n;
        self.shift = shift;
        self.kept.clear();
        self.d.clear();
        self.h.fill(0.0);
        for (i, pi) in p.iter().enumerate() {
            self.h[i * n + i] = *pi + shift;
        }
        if let Some(block) = dense_block(dense) {
            let nd = block.1;
            for c in 0..nd {
                for r in c..nd {
                    self.h[c * n + r] += block.0[r * nd + c];
                }
            }
        }
        for (k, ((terms, _), &wk)) in le.iter().zip(w).enumerate() {
            if wk > KEEP_WEIGHT && terms.len() > 1 {
                self.kept.push(k);
                self.d.push(1.0 / wk);
                continue;
            }
            if terms.len() > LONG_ROW {
                self.add_long_row(terms, wk);
                continue;
            }
            for &(c, a) in terms {
                let wa = wk * a;
                // The lower triangle only (the factorization reads no other).
                for &(r, b) in terms {
                    if r >= c {
                        self.h[c * n + r] += wa * b;
                    }
                }
            }
        }
        if !dense::cholesky(&mut self.h, n) {
            return false;
        }
        let rows = self.me + self.kept.len();
        let mut v = std::mem::take(&mut self.v);
        v.clear();
        v.resize(n * rows, 0.0);
        for (col, (terms, _)) in v.chunks_exact_mut(n).zip(self.m_rows(eq, le)) {
            for &(c, a) in terms {
                col[c] += a;
            }
            dense::forward(&self.h, n, col);
        }
        self.v = v;
        self.schur.clear();
        self.schur.resize(rows * rows, 0.0);
        for k in 0..rows {
            for l in k..rows {
                self.schur[k * rows + l] =
                    dense::dot(&self.v[k * n..(k + 1) * n], &self.v[l * n..(l + 1) * n]);
            }
        }
        for (j, d) in self.d.iter().enumerate() {
            let at = self.me + j;
            self.schur[at * rows + at] += d;
        }
        dense::cholesky(&mut self.schur, rows)
    }

    /// Solve H·dx + Mᵀ·λ = r₁, M·dx − D·λ = r₂ (dx holds r₁, λ holds r₂):
    /// with u = L⁻¹·r₁, (Vᵀ·V + D)·λ = Vᵀ·u − r₂ and dx = L⁻ᵀ·(u − V·λ).
    fn solve(&self, dx: &mut [f64], lambda: &mut [f64]) {
        let n = self.n;
        let rows = lambda.len();
        dense::forward(&self.h, n, dx);
        for (y, col) in lambda.iter_mut().zip(self.v.chunks_exact(n)) {
            *y = dense::dot(col, dx) - *y;
        }
        if rows > 0 {
            dense::forward(&self.schur, rows, lambda);
            dense::backward(&self.schur, rows, lambda);
        }
        for (y, col) in lambda.iter().zip(self.v.chunks_exact(n)) {
            dx.iter_mut().zip(col).for_each(|(x, v)| *x -= v * y);
        }
        dense::backward(&self.h, n, dx);
    }
}

/// Cholesky factorization and triangular solves of small dense matrices
/// (column-major, the lower triangle). Ours rather than faer's: at the
/// polish's sizes (H 62-square, the Schur complement 16) faer's recursive
/// blocked kernels spent about 280,000 instructions per factorization and
/// 20,000 per solve (callgrind, the paper's case), two to three times these
/// plain column loops, which the compiler vectorizes.
pub(crate) mod dense {
    /// L·Lᵀ = A in place (left-looking); false at a pivot ≤ 0 or not finite.
    pub fn cholesky(a: &mut [f64], n: usize) -> bool {
        for j in 0..n {
            for k in 0..j {
                let ljk = a[k * n + j];
                if ljk != 0.0 {
                    let (left, right) = a.split_at_mut(j * n);
                    let src = &left[k * n + j..(k + 1) * n];
                    right[j..n]
                        .iter_mut()
                        .zip(src)
                        .for_each(|(x, l)| *x -= l * ljk);
                }
            }
            let d = a[j * n + j];
            if d <= 0.0 || !d.is_finite() {
                return false;
            }
            let d = d.sqrt();
            a[j * n + j..(j + 1) * n].iter_mut().for_each(|x| *x /= d);
        }
        true
    }

    /// x ← L⁻¹·x.
    pub fn forward(l: &[f64], n: usize, x: &mut [f64]) {
        for j in 0..n {
            let xj = x[j] / l[j * n + j];
            x[j] = xj;
            if xj != 0.0 {
                x[j + 1..n]
                    .iter_mut()
                    .zip(&l[j * n + j + 1..(j + 1) * n])
                    .for_each(|(x, l)| *x -= l * xj);
            }
        }
    }

    /// x ← L⁻ᵀ·x.
    pub fn backward(l: &[f64], n: usize, x: &mut [f64]) {
        for j in (0..n).rev() {
            let s = dot(&l[j * n + j + 1..(j + 1) * n], &x[j + 1..n]);
            x[j] = (x[j] - s) / l[j * n + j];
        }
    }

    pub fn dot(a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(a, b)| a * b).sum()
    }
}

/// The residuals of an iterate.
struct Residuals {
    /// diag(p)·x + q + Aᵀ·y + Gᵀ·z.
    dual: Vec<f64>,
    /// A·x − b.
    eq: Vec<f64>,
    /// G·x + s − h.
    le: Vec<f64>,
}

impl Residuals {
    fn largest(&self) -> f64 {
        norm_inf(&self.dual)
            .max(norm_inf(&self.eq))
            .max(norm_inf(&self.le))
    }
}

/// The iterate (x, y, s, z) of the scaled problem.
#[derive(Clone)]
struct Iterate {
    x: Vec<f64>,
    y: Vec<f64>,
    s: Vec<f64>,
    z: Vec<f64>,
}

struct Scaled<'a> {
    p: &'a [f64],
    dense: Option<&'a [f64]>,
    q: &'a [f64],
    eq: Vec<Row>,
    le: Vec<Row>,
}

impl Scaled<'_> {
    fn residuals(&self, it: &Iterate) -> Residuals {
        let n = self.p.len();
        let mut dual: Vec<f64> = (0..n).map(|i| self.p[i] * it.x[i] + self.q[i]).collect();
        add_dense_times(self.dense, &it.x, &mut dual);
        add_rows_transposed(&self.eq, &it.y, &mut dual);
        add_rows_transposed(&self.le, &it.z, &mut dual);
        let mut eq = vec![0.0; self.eq.len()];
        rows_times(&self.eq, &it.x, &mut eq);
        for (r, (_, b)) in eq.iter_mut().zip(&self.eq) {
            *r -= b;
        }
        let mut le = vec![0.0; self.le.len()];
        rows_times(&self.le, &it.x, &mut le);
        for ((r, (_, h)), s) in le.iter_mut().zip(&self.le).zip(&it.s) {
            *r += s - h;
        }
        Residuals { dual, eq, le }
    }

    /// The Newton step (dx, dy, ds, dz) of the residuals (r_d, r_p, r_i,
    /// r_c): P·dx + Aᵀ·dy + Gᵀ·dz = −r_d, A·dx = −r_p, G·dx + ds = −r_i,
    /// z∘ds + s∘dz = −r_c; where the factorization needed more than the
    /// least shift, then [`REFINEMENT_STEPS`] of iterative refinement
    /// against these equations, which the shift leaves inexact.
    fn step(&self, factors: &mut Factors, it: &Iterate, r: &Residuals, rc: &[f64]) -> Direction {
        let mut d = self.reduced_step(factors, it, r, rc);
        let refinements = if factors.shift > REGULARIZATION {
            REFINEMENT_STEPS
        } else {
            0
        };
        for _ in 0..refinements {
            let (e, ec) = self.newton_residual(it, r, rc, &d);
            let size = e.largest().max(norm_inf(&ec));
            if size <= REFINEMENT_TOLERANCE * (1.0 + r.largest().max(norm_inf(rc))) {
                break;
            }
            let c = self.reduced_step(factors, it, &e, &ec);
            d.add(&c);
        }
        d
    }

    /// The residuals of the Newton equations at the direction d (zero for
    /// an exact solve), in the form the equations take them.
    fn newton_residual(
        &self,
        it: &Iterate,
        r: &Residuals,
        rc: &[f64],
        d: &Direction,
    ) -> (Residuals, Vec<f64>) {
        let n = self.p.len();
        let mut dual: Vec<f64> = (0..n).map(|i| self.p[i] * d.x[i] + r.dual[i]).collect();
        add_dense_times(self.dense, &d.x, &mut dual);
        add_rows_transposed(&self.eq, &d.y, &mut dual);
        add_rows_transposed(&self.le, &d.z, &mut dual);
        let mut eq = vec![0.0; self.eq.len()];
        rows_times(&self.eq, &d.x, &mut eq);
        eq.iter_mut().zip(&r.eq).for_each(|(e, r)| *e += r);
        let mut le = vec![0.0; self.le.len()];
        rows_times(&self.le, &d.x, &mut le);
        for ((e, ds), r) in le.iter_mut().zip(&d.s).zip(&r.le) {
            *e += ds + r;
        }
        let c = (0..le.len())
            .map(|k| it.z[k] * d.s[k] + it.s[k] * d.z[k] + rc[k])
            .collect();
        (Residuals { dual, eq, le }, c)
    }

    /// The Newton step by elimination of ds and dz (module docs).
    fn reduced_step(
        &self,
        factors: &mut Factors,
        it: &Iterate,
        res: &Residuals,
        rc: &[f64],
    ) -> Direction {
        // With t = (z∘r_i − r_c)/s, dz = t + (z/s)∘G·dx: r₁ = −r_d − Gᵀ·t
        // over the eliminated rows, r₂ = (−r_p, −D·t over the kept rows).
        let mi = it.s.len();
        let t: Vec<f64> = (0..mi)
            .map(|k| (it.z[k] * res.le[k] - rc[k]) / it.s[k])
            .collect();
        let mut dx: Vec<f64> = res.dual.iter().map(|v| -v).collect();
        let mut kept = vec![false; mi];
        for &k in &factors.kept {
            kept[k] = true;
        }
        for (k, (terms, _)) in self.le.iter().enumerate() {
            if !kept[k] {
                for &(c, a) in terms {
                    dx[c] -= a * t[k];
                }
            }
        }
        let mut lambda: Vec<f64> = res.eq.iter().map(|v| -v).collect();
        lambda.extend(factors.kept.iter().zip(&factors.d).map(|(&k, d)| -d * t[k]));
        factors.solve(&mut dx, &mut lambda);
        // ds = −r_i − G·dx; dz = λ on the kept rows, t + w∘G·dx on the others.
        let mut ds = vec![0.0; mi];
        rows_times(&self.le, &dx, &mut ds);
        let mut dz: Vec<f64> = (0..mi).map(|k| t[k] + it.z[k] / it.s[k] * ds[k]).collect();
        for (d, r) in ds.iter_mut().zip(&res.le) {
            *d = -r - *d;
        }
        let me = self.eq.len();
        for (j, &k) in factors.kept.iter().enumerate() {
            dz[k] = lambda[me + j];
        }
        lambda.truncate(me);
        Direction {
            x: dx,
            y: lambda,
            s: ds,
            z: dz,
        }
    }
}

/// A Newton direction.
struct Direction {
    x: Vec<f64>,
    y: Vec<f64>,
    s: Vec<f64>,
    z: Vec<f64>,
}

impl Direction {
    /// self += c (a refinement's correction solves for minus the residual
    /// of self).
    fn add(&mut self, c: &Direction) {
        for (a, b) in [
            (&mut self.x, &c.x),
            (&mut self.y, &c.y),
            (&mut self.s, &c.s),
            (&mut self.z, &c.z),
        ] {
            a.iter_mut().zip(b).for_each(|(a, b)| *a += b);
        }
    }
}

/// Solve one QP (module docs).
pub fn solve(problem: &Problem) -> Result<Answer, QpError> {
    validate(problem)?;
    let n = problem.p.len();
    let (eq, eq_scale) = scaled(problem.eq);
    let (le, le_scale) = scaled(problem.le);
    let qp = Scaled {
        p: problem.p,
        dense: problem.dense,
        q: problem.q,
        eq,
        le,
    };
    let (me, mi) = (qp.eq.len(), qp.le.len());
    let mut factors = Factors::new(n, me);
    let mut it = start(&qp, &mut factors)?;
    let mut iterations = 0;
    // The iterate with the smallest residual so far: rounding can spoil the
    // last steps (z/s of the active rows past 1e15), and the best is kept.
    let mut best: Option<(f64, Iterate)> = None;
    loop {
        let res = qp.residuals(&it);
        let gap = if mi > 0 {
            it.s.iter().zip(&it.z).map(|(s, z)| s * z).sum::<f64>() / mi as f64
        } else {
            0.0
        };
        let size = res.largest().max(gap * TOLERANCE / GAP_TOLERANCE);
        if !size.is_finite() {
            return Err(QpError::NonFinite {
                iteration: iterations,
            });
        }
        if best.as_ref().is_none_or(|(b, _)| size < *b) {
            best = Some((size, it.clone()));
        }
        if size < TOLERANCE || iterations == MAX_ITERATIONS {
            break;
        }
        iterations += 1;
        let w: Vec<f64> = it.z.iter().zip(&it.s).map(|(z, s)| z / s).collect();
        if !factor(&mut factors, &qp, &w) {
            break;
        }
        // Predictor: r_c = s∘z.
        let rc: Vec<f64> = it.s.iter().zip(&it.z).map(|(s, z)| s * z).collect();
        let affine = qp.step(&mut factors, &it, &res, &rc);
        let alpha = step_to_boundary(&it.s, &affine.s).min(step_to_boundary(&it.z, &affine.z));
        let gap_affine = (0..mi)
            .map(|k| (it.s[k] + alpha * affine.s[k]) * (it.z[k] + alpha * affine.z[k]))
            .sum::<f64>()
            / mi.max(1) as f64;
        let sigma = (gap_affine / gap.max(f64::MIN_POSITIVE)).powi(3).min(1.0);
        // Corrector: r_c = s∘z + ds∘dz − σμ.
        let rc: Vec<f64> = (0..mi)
            .map(|k| rc[k] + affine.s[k] * affine.z[k] - sigma * gap)
            .collect();
        let d = qp.step(&mut factors, &it, &res, &rc);
        let alpha = (STEP_TO_BOUNDARY
            * step_to_boundary(&it.s, &d.s).min(step_to_boundary(&it.z, &d.z)))
        .min(1.0);
        let axpy = |v: &mut Vec<f64>, d: &[f64]| {
            v.iter_mut().zip(d).for_each(|(v, d)| *v += alpha * d);
        };
        axpy(&mut it.x, &d.x);
        axpy(&mut it.y, &d.y);
        axpy(&mut it.s, &d.s);
        axpy(&mut it.z, &d.z);
    }
    let (size, it) = best.expect("the loop looks at one iterate at least");
    let status = if size < TOLERANCE {
        Status::Solved
    } else if size < LOOSE_TOLERANCE {
        Status::AlmostSolved
    } else {
        return Err(QpError::NotConverged {
            iterations,
            residual: size,
        });
    };
    Ok(Answer {
        x: it.x,
        y: it.y.iter().zip(&eq_scale).map(|(y, r)| y / r).collect(),
        z: it.z.iter().zip(&le_scale).map(|(z, r)| z / r).collect(),
        iterations,
        status,
    })
}

/// Check that the data are finite and every row names a variable.
pub(crate) fn validate(problem: &Problem) -> Result<(), QpError> {
    let n = problem.p.len();
    let finite = |rows: &[Row]| {
        rows.iter()
            .all(|(t, b)| b.is_finite() && t.iter().all(|(_, v)| v.is_finite()))
    };
    if problem.q.len() != n
        || !problem.p.iter().chain(problem.q).all(|v| v.is_finite())
        || !finite(problem.eq)
        || !finite(problem.le)
        || problem.dense.is_some_and(|d| {
            dense_block(Some(d)).is_none_or(|(_, nd)| nd * nd != d.len() || nd > n)
                || !d.iter().all(|v| v.is_finite())
        })
    {
        return Err(QpError::Data);
    }
    if let Some(&(column, _)) = problem
        .eq
        .iter()
        .chain(problem.le)
        .flat_map(|(t, _)| t)
        .find(|(c, _)| *c >= n)
    {
        return Err(QpError::Column { column, n });
    }
    Ok(())
}

/// Factor the Newton matrix with weights `w`, the shift growing from
/// [`REGULARIZATION`] while the factorization fails; false when it fails
/// at [`MAX_REGULARIZATION`].
fn factor(factors: &mut Factors, qp: &Scaled, w: &[f64]) -> bool {
    let mut shift = REGULARIZATION;
    while shift <= MAX_REGULARIZATION {
        if factors.factor(qp.p, qp.dense, &qp.eq, &qp.le, w, shift) {
            return true;
        }
        shift *= 100.0;
    }
    false
}

/// The starting point: x and y of the equality-constrained least squares
/// min ½xᵀPx + qᵀx + ½‖G·x − h‖² s.t. A·x = b (Vandenberghe's, CVXOPT's
/// coneqp), s = h − G·x and z = G·x − h, each shifted into the positive
/// orthant.
fn start(qp: &Scaled, factors: &mut Factors) -> Result<Iterate, QpError> {
    let (n, mi) = (qp.p.len(), qp.le.len());
    if !factor(factors, qp, &vec![1.0; mi]) {
        return Err(QpError::Factorization { iteration: 0 });
    }
    let mut x: Vec<f64> = qp.q.iter().map(|v| -v).collect();
    let h: Vec<f64> = qp.le.iter().map(|(_, h)| *h).collect();
    add_rows_transposed(&qp.le, &h, &mut x);
    let mut y: Vec<f64> = qp.eq.iter().map(|(_, b)| *b).collect();
    factors.solve(&mut x, &mut y);
    let mut gx = vec![0.0; mi];
    rows_times(&qp.le, &x, &mut gx);
    let shift = |v: Vec<f64>| {
        let lowest = v.iter().copied().fold(f64::INFINITY, f64::min);
        let by = if lowest > 0.0 { 0.0 } else { 1.0 - lowest };
        v.into_iter().map(|v| v + by).collect::<Vec<f64>>()
    };
    let s = shift((0..mi).map(|k| h[k] - gx[k]).collect());
    let z = shift((0..mi).map(|k| gx[k] - h[k]).collect());
    debug_assert_eq!(x.len(), n);
    Ok(Iterate { x, y, s, z })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A box-constrained separable QP with a known answer:
    /// min Σ ½x_i² − c_i·x_i, |x_i| ≤ 1 → x_i = clamp(c_i, −1, 1), and
    /// Σ x_i = 0.5 on top moves every free x by the same multiplier.
    #[test]
    fn a_box_qp_gives_its_clamped_answer() {
        let c: [f64; 4] = [0.3, 2.0, -3.0, -0.2];
        let p = [1.0; 4];
        let q: Vec<f64> = c.iter().map(|c| -c).collect();
        let le: Vec<Row> = (0..4)
            .flat_map(|i| [(vec![(i, 1.0)], 1.0), (vec![(i, -1.0)], 1.0)])
            .collect();
        let a = solve(&Problem {
            dense: None,
            p: &p,
            q: &q,
            eq: &[],
            le: &le,
        })
        .unwrap();
        assert_eq!(a.status, Status::Solved);
        for (x, c) in a.x.iter().zip(c) {
            assert!((x - c.clamp(-1.0, 1.0)).abs() < 1e-8, "{:?}", a.x);
        }
        // With Σx = 0.5: x_i = clamp(c_i − y, −1, 1), y such that Σ = 0.5.
        // Free are 0 and 3: 0.3 − y − 0.2 − y + 1 − 1 = 0.5 → y = −0.2.
        let eq = [((0..4).map(|i| (i, 1.0)).collect(), 0.5)];
        let a = solve(&Problem {
            dense: None,
            p: &p,
            q: &q,
            eq: &eq,
            le: &le,
        })
        .unwrap();
        let want = [0.5, 1.0, -1.0, 0.0];
        for (x, w) in a.x.iter().zip(want) {
            assert!((x - w).abs() < 1e-8, "{:?}", a.x);
        }
        assert!((a.y[0] - -0.2).abs() < 1e-8, "{:?}", a.y);
    }

    /// Random feasible QPs of the polish's shape (a proximal diagonal, LP
    /// slacks, sparse rows of mixed scales, a box) against Clarabel: the
    /// same objective within our stopping gap, and every row met.
    #[test]
    fn random_qps_agree_with_clarabel() {
        let mut rng = ChaCha8Rng::seed_from_u64(35);
        for case in 0..40 {
            let n = rng.gen_range(3..30);
            let slacks = rng.gen_range(0..4);
            let nv = n + slacks;
            let p: Vec<f64> = (0..nv)
                .map(|i| {
                    if i < n {
                        10f64.powf(rng.gen_range(-3.0..2.0f64))
                    } else {
                        0.0
                    }
                })
                .collect();
            let q: Vec<f64> = (0..nv)
                .map(|i| {
                    if i < n {
                        rng.gen_range(-1.0..1.0)
                    } else {
                        10.0
                    }
                })
                .collect();
            // x₀ inside the box is feasible for every row by construction.
            let x0: Vec<f64> = (0..n).map(|_| rng.gen_range(-0.3..0.3)).collect();
            let mut eq = Vec::new();
            for k in 0..rng.gen_range(0..4.min(n)) {
                let mut terms: Vec<(usize, f64)> = Vec::new();
                for c in 0..n {
                    if c != k && rng.gen_bool(0.5) {
                        terms.push((c, rng.gen_range(-2.0..2.0)));
                    }
                }
                terms.push((k, 1.0));
                let b = terms.iter().map(|&(c, v)| v * x0[c]).sum();
                eq.push((terms, b));
            }
            let mut le = Vec::new();
            for _ in 0..rng.gen_range(0..80) {
                let scale = 10f64.powf(rng.gen_range(-2.0..6.0f64));
                let terms: Vec<(usize, f64)> = (0..rng.gen_range(1..5))
                    .map(|_| (rng.gen_range(0..n), scale * rng.gen_range(-1.0..1.0)))
                    .collect();
                let v: f64 = terms.iter().map(|&(c, a)| a * x0[c]).sum();
                le.push((terms, v + scale * rng.gen_range(0.0..0.5)));
            }
            // Slack rows: a·x − ν ≤ b with ν ≥ 0 (so always feasible).
            for s in 0..slacks {
                let terms = vec![(rng.gen_range(0..n), 1.0), (n + s, -1.0)];
                le.push((terms, rng.gen_range(-0.5..0.5)));
                le.push((vec![(n + s, -1.0)], 0.0));
            }
            for i in 0..n {
                le.push((vec![(i, 1.0)], 0.5));
                le.push((vec![(i, -1.0)], 0.5));
            }
            let ours = solve(&Problem {
                dense: None,
                p: &p,
                q: &q,
                eq: &eq,
                le: &le,
            })
            .unwrap_or_else(|e| panic!("case {case}: {e}"));
            let theirs = clarabel_solve(&p, &q, &eq, &le);
            let objective = |x: &[f64]| {
                (0..nv)
                    .map(|i| 0.5 * p[i] * x[i] * x[i] + q[i] * x[i])
                    .sum::<f64>()
            };
            // Ours stops at a mean complementarity of GAP_TOLERANCE, which
            // bounds its objective's excess over the optimum by m·GAP.
            let (a, b) = (objective(&ours.x), objective(&theirs));
            let gap = le.len() as f64 * GAP_TOLERANCE;
            assert!(
                (a - b).abs() < 1e-8 * (1.0 + b.abs()) + gap,
                "case {case}: ours {a}, Clarabel {b}"
            );
            // Primal feasibility of the rows as given, and z ≥ 0.
            for (terms, h) in &le {
                let v: f64 = terms.iter().map(|&(c, a)| a * ours.x[c]).sum();
                let r = terms.iter().map(|(_, a)| a.abs()).fold(0.0, f64::max);
                assert!(v - h <= 1e-8 * r, "case {case}: row violated by {}", v - h);
            }
            assert!(ours.z.iter().all(|z| *z >= 0.0));
        }
    }

    fn clarabel_solve(p: &[f64], q: &[f64], eq: &[Row], le: &[Row]) -> Vec<f64> {
        use clarabel::algebra::CscMatrix;
        use clarabel::solver::{
            DefaultSettings, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
        };
        let nv = p.len();
        let diag: Vec<usize> = (0..nv).collect();
        let pm = CscMatrix::new_from_triplets(nv, nv, diag.clone(), diag, p.to_vec());
        let (mut r, mut c, mut v, mut b) = (vec![], vec![], vec![], vec![]);
        for (k, (terms, rhs)) in eq.iter().chain(le).enumerate() {
            for &(col, a) in terms {
                r.push(k);
                c.push(col);
                v.push(a);
            }
            b.push(*rhs);
        }
        let m = eq.len() + le.len();
        let a = CscMatrix::new_from_triplets(m, nv, r, c, v);
        let cones = [
            SupportedConeT::ZeroConeT(eq.len()),
            SupportedConeT::NonnegativeConeT(le.len()),
        ];
        let settings = DefaultSettings {
            verbose: false,
            ..DefaultSettings::default()
        };
        let mut solver = DefaultSolver::new(&pm, q, &a, &b, &cones, settings).unwrap();
        solver.solve();
        assert_eq!(solver.solution.status, SolverStatus::Solved);
        solver.solution.x.clone()
    }

    #[test]
    fn bad_data_is_an_error_not_a_panic() {
        let p = [1.0];
        let q = [f64::NAN];
        assert_eq!(
            solve(&Problem {
                dense: None,
                p: &p,
                q: &q,
                eq: &[],
                le: &[]
            }),
            Err(QpError::Data)
        );
        let q = [0.0];
        let le = [(vec![(3, 1.0)], 1.0)];
        assert_eq!(
            solve(&Problem {
                dense: None,
                p: &p,
                q: &q,
                eq: &[],
                le: &le
            }),
            Err(QpError::Column { column: 3, n: 1 })
        );
    }
}
