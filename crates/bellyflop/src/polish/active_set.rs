//! A dense dual active-set method for the polish's small, strictly convex
//! QPs (Goldfarb & Idnani, "A numerically stable dual method for solving
//! strictly convex quadratic programs", Math. Prog. 27, 1983):
//!
//!   min ½·xᵀ·diag(p)·x + qᵀx   s.t.   A·x = b,   G·x ≤ h,   p > 0.
//!
//! It starts at the unconstrained minimum and adds one violated row at a
//! time, dropping a row whose multiplier would turn negative, so that the
//! iterate is always dual feasible and the last one is also primal
//! feasible. Its factors are J = L⁻ᵀ·Q and the triangle R of L⁻¹·N = Q·[R; 0]
//! (L·Lᵀ the Hessian, N the active rows' normals), each updated by Givens
//! rotations in O(n²) per change of the active set.
//!
//! Why it, beside the interior point ([`crate::polish::qp`]): a polish QP
//! has ~75 variables and ~500 rows of which a few tens end active. The
//! interior point factors a 75-square matrix 12–33 times per QP; this
//! method changes its active set about as many times as rows end active,
//! each at the cost of a few Givens sweeps, and its answer meets its
//! active rows to rounding with exact multipliers. A failure (cycling at
//! its cap, a row set it finds infeasible) is reported, and the polish then
//! solves the same QP by the interior point.

use crate::polish::qp::{
    dense, dense_block, scaled, validate, Answer, Problem, QpError, Row, Status,
};

/// A row is violated when c·x − b < −VIOLATION·(1 + |b|) (rows scaled to
/// a unit ∞-norm).
const VIOLATION: f64 = 1e-11;

/// A new row is linearly dependent on the active ones when the part of
/// J·c outside their span, ‖d₂‖, is below this fraction of ‖d‖.
const DEPENDENT: f64 = 1e-12;

/// A row with more terms than this is multiplied in dense form
/// ([`State::directions`]).
const DENSE_ROW: usize = 16;

/// Active-set changes allowed per variable and row (a guard against
/// cycling under rounding; exact arithmetic needs at most one add per row
/// between drops).
const CHANGES_PER_ROW: usize = 4;

/// One row of the problem in the method's form c·x ≥ β: c = σ·(row), β =
/// σ·rhs, σ = −1 for G·x ≤ h and ±1 for an equality (the sign that makes
/// it violated, or met, when it is added).
#[derive(Debug, Clone, Copy)]
struct Normal {
    /// Index into the equalities then the inequalities.
    row: usize,
    sign: f64,
}

/// The method's state: the iterate, the factors and the active set.
struct State {
    n: usize,
    /// The equalities then the inequalities, scaled.
    rows: Vec<Row>,
    equalities: usize,
    x: Vec<f64>,
    /// J (n × n, column-major).
    j: Vec<f64>,
    /// R (upper triangular in its first q columns, column-major n × n).
    r: Vec<f64>,
    active: Vec<Normal>,
    /// Whether each row is active.
    is_active: Vec<bool>,
    /// The multipliers of the active rows, u ≥ 0 for the inequalities.
    u: Vec<f64>,
    changes: usize,
    // Work vectors.
    d: Vec<f64>,
    z: Vec<f64>,
    step: Vec<f64>,
    /// A dense row, scattered.
    dense: Vec<f64>,
}

impl State {
    /// The state at the unconstrained minimum x = −H⁻¹·q, H = diag(p) plus
    /// the dense block: J = L⁻ᵀ for H = L·Lᵀ. None when H is not
    /// numerically positive definite.
    fn new(
        p: &[f64],
        dense: Option<&[f64]>,
        q: &[f64],
        eq: Vec<Row>,
        le: Vec<Row>,
    ) -> Option<Self> {
        let n = p.len();
        let mut j = vec![0.0; n * n];
        let x = match dense_block(dense) {
            None => {
                for i in 0..n {
                    j[i + i * n] = 1.0 / p[i].sqrt();
                }
                q.iter().zip(p).map(|(q, p)| -q / p).collect()
            }
            Some((block, nd)) => {
                // H, column-major, its lower triangle.
                let mut l = vec![0.0; n * n];
                for i in 0..n {
                    l[i * n + i] = p[i];
                }
                for c in 0..nd {
                    for r in c..nd {
                        l[c * n + r] += block[r * nd + c];
                    }
                }
                if !dense::cholesky(&mut l, n) {
                    return None;
                }
                let mut column = vec![0.0; n];
                for c in 0..n {
                    column.fill(0.0);
                    column[c] = 1.0;
                    dense::forward(&l, n, &mut column);
                    // Column c of L⁻¹ is row c of J = L⁻ᵀ.
                    for (k, v) in column.iter().enumerate() {
                        j[c + k * n] = *v;
                    }
                }
                let mut x: Vec<f64> = q.iter().map(|v| -v).collect();
                dense::forward(&l, n, &mut x);
                dense::backward(&l, n, &mut x);
                x
            }
        };
        let (equalities, total) = (eq.len(), eq.len() + le.len());
        Some(State {
            n,
            rows: eq.into_iter().chain(le).collect(),
            equalities,
            x,
            j,
            r: vec![0.0; n * n],
            active: Vec::with_capacity(n),
            is_active: vec![false; total],
            u: Vec::with_capacity(n + 1),
            changes: 0,
            d: vec![0.0; n],
            z: vec![0.0; n],
            step: vec![0.0; n],
            dense: vec![0.0; n],
        })
    }

    /// c·x − β of a normal at x.
    fn slack(&self, c: Normal) -> f64 {
        let (terms, rhs) = &self.rows[c.row];
        c.sign * (terms.iter().map(|&(k, v)| v * self.x[k]).sum::<f64>() - rhs)
    }

    /// d = Jᵀ·c, z = J₂·d₂ (the primal direction) and r = R⁻¹·d₁ (the
    /// active multipliers' rate of change, in `step`); returns ‖d₂‖ and ‖d‖.
    fn directions(&mut self, c: Normal) -> (f64, f64) {
        let (n, q) = (self.n, self.active.len());
        let terms = &self.rows[c.row].0;
        if terms.len() > DENSE_ROW {
            // A dense row (the terminal conditions'): scattered once, each
            // dᵢ a contiguous dot product, which vectorizes where the
            // gathers of the sparse form do not.
            self.dense.fill(0.0);
            for &(k, v) in terms {
                self.dense[k] += c.sign * v;
            }
            for (i, d) in self.d.iter_mut().enumerate() {
                let col = &self.j[i * n..(i + 1) * n];
                *d = col.iter().zip(&self.dense).map(|(j, c)| j * c).sum();
            }
        } else {
            for (i, d) in self.d.iter_mut().enumerate() {
                let col = &self.j[i * n..(i + 1) * n];
                *d = c.sign * terms.iter().map(|&(k, v)| v * col[k]).sum::<f64>();
            }
        }
        self.z.fill(0.0);
        for i in q..n {
            let di = self.d[i];
            if di != 0.0 {
                let col = &self.j[i * n..(i + 1) * n];
                self.z.iter_mut().zip(col).for_each(|(z, j)| *z += di * j);
            }
        }
        // Back substitution R·r = d₁.
        for i in (0..q).rev() {
            let mut v = self.d[i];
            for k in i + 1..q {
                v -= self.r[i + k * n] * self.step[k];
            }
            self.step[i] = v / self.r[i + i * n];
        }
        let outside = self.d[q..].iter().map(|v| v * v).sum::<f64>().sqrt();
        let all = self.d.iter().map(|v| v * v).sum::<f64>().sqrt();
        (outside, all)
    }

    /// Rotate columns a and b of J by (c, s).
    fn rotate_j(&mut self, a: usize, b: usize, c: f64, s: f64) {
        let n = self.n;
        for k in 0..n {
            let (ja, jb) = (self.j[k + a * n], self.j[k + b * n]);
            self.j[k + a * n] = c * ja + s * jb;
            self.j[k + b * n] = -s * ja + c * jb;
        }
    }

    /// Add the normal whose d = Jᵀ·c was computed last: zero d below its
    /// position q by rotations of J's columns, and make d₁ R's column q.
    fn add(&mut self, c: Normal) {
        let (n, q) = (self.n, self.active.len());
        for i in (q + 1..n).rev() {
            let (a, b) = (self.d[i - 1], self.d[i]);
            if b == 0.0 {
                continue;
            }
            let h = a.hypot(b);
            let (cs, sn) = (a / h, b / h);
            self.d[i - 1] = h;
            self.d[i] = 0.0;
            self.rotate_j(i - 1, i, cs, sn);
        }
        for i in 0..=q {
            self.r[i + q * n] = self.d[i];
        }
        self.active.push(c);
        self.is_active[c.row] = true;
        self.changes += 1;
    }

    /// Drop the active row at position k: shift R's columns left and
    /// restore its triangle by rotations of its rows (and J's columns).
    fn drop(&mut self, k: usize) {
        let (n, q) = (self.n, self.active.len());
        for col in k..q - 1 {
            for i in 0..=col + 1 {
                self.r[i + col * n] = self.r[i + (col + 1) * n];
            }
        }
        for i in 0..q {
            self.r[i + (q - 1) * n] = 0.0;
        }
        for col in k..q - 1 {
            let (a, b) = (self.r[col + col * n], self.r[col + 1 + col * n]);
            if b == 0.0 {
                continue;
            }
            let h = a.hypot(b);
            let (cs, sn) = (a / h, b / h);
            for l in col..q - 1 {
                let (ra, rb) = (self.r[col + l * n], self.r[col + 1 + l * n]);
                self.r[col + l * n] = cs * ra + sn * rb;
                self.r[col + 1 + l * n] = -sn * ra + cs * rb;
            }
            self.rotate_j(col, col + 1, cs, sn);
        }
        let gone = self.active.remove(k);
        self.is_active[gone.row] = false;
        self.u.remove(k);
        self.changes += 1;
    }

    /// Make the normal `c` (violated by `slack` ≤ 0) active, dropping the
    /// rows that block it (Goldfarb–Idnani's step 2).
    fn enforce(&mut self, c: Normal, mut slack: f64, limit: usize) -> Result<(), QpError> {
        // The multiplier of c, last in u while it is being added.
        self.u.push(0.0);
        loop {
            if self.changes > limit {
                return Err(QpError::NotConverged {
                    iterations: self.changes as u32,
                    residual: -slack,
                });
            }
            let q = self.active.len();
            let (outside, all) = self.directions(c);
            // The dual step length: the first active inequality whose
            // multiplier reaches zero.
            let mut partial = (f64::INFINITY, usize::MAX);
            for k in 0..q {
                if self.active[k].row >= self.equalities && self.step[k] > 0.0 {
                    let t = self.u[k] / self.step[k];
                    if t < partial.0 {
                        partial = (t, k);
                    }
                }
            }
            let dependent = outside <= DEPENDENT * all;
            let full = if dependent {
                f64::INFINITY
            } else {
                // zᵀc = ‖d₂‖².
                -slack / (outside * outside)
            };
            let t = full.min(partial.0);
            if !t.is_finite() {
                return Err(QpError::Infeasible {
                    row: c.row,
                    residual: -slack,
                });
            }
            for k in 0..q {
                self.u[k] -= t * self.step[k];
            }
            self.u[q] += t;
            if !dependent {
                for (x, z) in self.x.iter_mut().zip(&self.z) {
                    *x += t * z;
                }
                slack += t * outside * outside;
            }
            if full <= partial.0 {
                self.add(c);
                return Ok(());
            }
            self.u[partial.1] = 0.0;
            self.drop(partial.1);
        }
    }

    /// The inactive inequality most violated at x, and its slack.
    fn most_violated(&self) -> Option<(Normal, f64)> {
        let mut worst: Option<(Normal, f64)> = None;
        for row in self.equalities..self.rows.len() {
            if self.is_active[row] {
                continue;
            }
            let c = Normal { row, sign: -1.0 };
            let s = self.slack(c);
            let rhs = self.rows[row].1;
            if s < -VIOLATION * (1.0 + rhs.abs()) && worst.is_none_or(|(_, w)| s < w) {
                worst = Some((c, s));
            }
        }
        worst
    }
}

/// Solve one QP (module docs). Rows are scaled to a unit ∞-norm first;
/// the multipliers come back for the rows as given.
pub fn solve(problem: &Problem) -> Result<Answer, QpError> {
    Solver::new(problem).map(|s| s.answer())
}

/// A solved QP that takes more inequality rows. The method keeps its
/// iterate dual feasible, so a solved state stays so when rows are added:
/// continuing from it costs only the changes the new rows bring, where
/// solving the grown QP anew repeats every change (the polish asks for the
/// same QP again with rows at a step's moved extrema).
pub struct Solver {
    state: State,
    eq_scale: Vec<f64>,
    le_scale: Vec<f64>,
    /// The cap on the active set's changes.
    limit: usize,
}

impl Solver {
    /// Solve `problem` (module docs).
    pub fn new(problem: &Problem) -> Result<Self, QpError> {
        validate(problem)?;
        if problem.p.iter().any(|&p| p <= 0.0) {
            return Err(QpError::NotStrictlyConvex);
        }
        let (eq, eq_scale) = scaled(problem.eq);
        let (le, le_scale) = scaled(problem.le);
        let n = problem.p.len();
        let limit = CHANGES_PER_ROW * (n + eq.len() + le.len()) + 100;
        let equalities = eq.len();
        let mut state = State::new(problem.p, problem.dense, problem.q, eq, le)
            .ok_or(QpError::NotStrictlyConvex)?;
        for row in 0..equalities {
            let rhs = state.rows[row].1;
            let plain = Normal { row, sign: 1.0 };
            let s = state.slack(plain);
            let c = Normal {
                row,
                sign: if s > 0.0 { -1.0 } else { 1.0 },
            };
            let (outside, all) = state.directions(c);
            if outside <= DEPENDENT * all {
                // Dependent on the equalities before it: met, or inconsistent.
                if s.abs() > VIOLATION * (1.0 + rhs.abs()) * 1e3 {
                    return Err(QpError::Infeasible { row, residual: s });
                }
                continue;
            }
            state.enforce(c, -s.abs(), limit)?;
        }
        let mut solver = Solver {
            state,
            eq_scale,
            le_scale,
            limit,
        };
        solver.finish()?;
        Ok(solver)
    }

    /// Add inequality rows G·x ≤ h (after the problem's own, in the
    /// answer's `z`) and solve again from the last answer.
    pub fn add(&mut self, le: &[Row]) -> Result<(), QpError> {
        let n = self.state.n;
        validate(&Problem {
            dense: None,
            p: &vec![1.0; n],
            q: &vec![0.0; n],
            eq: &[],
            le,
        })?;
        let (le, scale) = scaled(le);
        self.limit += CHANGES_PER_ROW * le.len();
        self.state
            .is_active
            .extend(std::iter::repeat_n(false, le.len()));
        self.state.rows.extend(le);
        self.le_scale.extend(scale);
        self.finish()
    }

    /// Add the most violated inequality until none is.
    fn finish(&mut self) -> Result<(), QpError> {
        while let Some((c, s)) = self.state.most_violated() {
            self.state.enforce(c, s, self.limit)?;
        }
        Ok(())
    }

    /// The point x + Δ on the same active set after the equality rows
    /// `moved` (row, change of its right-hand side, as given) shift: Δ the
    /// least ½·Δᵀ·H·Δ that keeps every active row met with those rows
    /// moved, from the factors in hand, Δ = J₁·R⁻ᵀ·β (since Nᵀ·J = [Rᵀ 0]
    /// and J₁ = H⁻¹·N·R⁻¹), in O(n·q) where a new solve costs O(n²) per
    /// change of the active set. The active inequalities are held as
    /// equalities and their multipliers not checked: x + Δ is feasible, not
    /// necessarily the moved QP's minimum. None where it breaks an inactive
    /// row. (A second-order correction that reuses the step's factors,
    /// Nocedal & Wright §18.3.)
    pub fn moved(&self, moved: &[(usize, f64)]) -> Option<Vec<f64>> {
        let st = &self.state;
        let (n, q) = (st.n, st.active.len());
        // β_k = c_k·Δ: what meets row k exactly, moved or not.
        let beta: Vec<f64> = st
            .active
            .iter()
            .map(|c| {
                let shift = moved
                    .iter()
                    .filter(|(row, _)| *row == c.row && c.row < st.equalities)
                    .map(|(row, change)| c.sign * change / self.eq_scale[*row])
                    .sum::<f64>();
                shift - st.slack(*c)
            })
            .collect();
        // Rᵀ·v = β (R upper triangular, column-major).
        let mut v = vec![0.0; q];
        for i in 0..q {
            let mut w = beta[i];
            for (k, vk) in v.iter().enumerate().take(i) {
                w -= st.r[k + i * n] * vk;
            }
            v[i] = w / st.r[i + i * n];
        }
        let mut x = st.x.clone();
        for (i, vi) in v.iter().enumerate() {
            let col = &st.j[i * n..(i + 1) * n];
            x.iter_mut().zip(col).for_each(|(x, j)| *x += vi * j);
        }
        if !x.iter().all(|v| v.is_finite()) {
            return None;
        }
        let breaks = (st.equalities..st.rows.len()).any(|row| {
            let (terms, rhs) = &st.rows[row];
            let value: f64 = terms.iter().map(|&(k, a)| a * x[k]).sum();
            !st.is_active[row] && value - rhs > VIOLATION * (1.0 + rhs.abs())
        });
        (!breaks).then_some(x)
    }

    /// The active set's changes so far.
    pub fn changes(&self) -> u32 {
        self.state.changes as u32
    }

    /// The answer: x, the multipliers, and the active set's changes so far.
    pub fn answer(&self) -> Answer {
        let equalities = self.state.equalities;
        let mut y = vec![0.0; equalities];
        let mut z = vec![0.0; self.le_scale.len()];
        for (c, u) in self.state.active.iter().zip(&self.state.u) {
            if c.row < equalities {
                // Lagrangian −u·σ·(a·x − b) here, +y·(a·x − b) in Answer's.
                y[c.row] = -c.sign * u / self.eq_scale[c.row];
            } else {
                let k = c.row - equalities;
                z[k] = u / self.le_scale[k];
            }
        }
        Answer {
            x: self.state.x.clone(),
            y,
            z,
            iterations: self.state.changes as u32,
            status: Status::Solved,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The same known answer as the interior point's test: a clamped
    /// separable QP, then with Σx = 0.5 on top.
    #[test]
    fn a_box_qp_gives_its_clamped_answer() {
        let c: [f64; 4] = [0.3, 2.0, -3.0, -0.2];
        let p = [1.0; 4];
        let q: Vec<f64> = c.iter().map(|c| -c).collect();
        let le: Vec<Row> = (0..4)
            .flat_map(|i| [(vec![(i, 1.0)], 1.0), (vec![(i, -1.0)], 1.0)])
            .collect();
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
            assert!((x - w).abs() < 1e-12, "{:?}", a.x);
        }
        assert!((a.y[0] - -0.2).abs() < 1e-12, "{:?}", a.y);
        // x₁ ≤ 1 holds with multiplier c₁ − y − 1 = 2 + 0.2 − 1.
        assert!((a.z[2] - 1.2).abs() < 1e-12, "{:?}", a.z);
    }

    /// With a dense curvature block (the polish's Newton mode), random
    /// feasible QPs meet their KKT conditions (stationarity with the block)
    /// and agree with the interior point, which takes the same block.
    #[test]
    fn a_dense_block_gives_the_interior_points_answer() {
        let mut rng = ChaCha8Rng::seed_from_u64(35);
        for case in 0..100 {
            let n = rng.gen_range(3..30);
            let nd = rng.gen_range(1..=n);
            // B = CᵀC + 0.01·I on the first nd variables, and its mirror.
            let c: Vec<f64> = (0..nd * nd).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let mut block = vec![0.0; nd * nd];
            for r in 0..nd {
                for k in 0..nd {
                    block[r * nd + k] = (0..nd).map(|l| c[l * nd + r] * c[l * nd + k]).sum();
                }
                block[r * nd + r] += 0.01;
            }
            let p = vec![1e-3; n];
            let q: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let eq: Vec<Row> = vec![((0..n).map(|i| (i, 1.0)).collect(), 0.1)];
            let mut le: Vec<Row> = Vec::new();
            for i in 0..n {
                le.push((vec![(i, 1.0)], 0.3));
                le.push((vec![(i, -1.0)], 0.3));
            }
            let problem = Problem {
                dense: Some(&block),
                p: &p,
                q: &q,
                eq: &eq,
                le: &le,
            };
            let ours = solve(&problem).unwrap_or_else(|e| panic!("case {case}: {e}"));
            let theirs = crate::polish::qp::solve(&problem).unwrap();
            let mut grad: Vec<f64> = (0..n).map(|i| p[i] * ours.x[i] + q[i]).collect();
            for r in 0..nd {
                grad[r] += (0..nd).map(|k| block[r * nd + k] * ours.x[k]).sum::<f64>();
            }
            for ((terms, b), z) in le.iter().zip(&ours.z) {
                let v: f64 = terms.iter().map(|&(c, a)| a * ours.x[c]).sum();
                assert!(v <= b + 1e-9, "case {case}: {v} > {b}");
                assert!(
                    *z >= 0.0 && (*z == 0.0 || (v - b).abs() < 1e-9),
                    "case {case}"
                );
                for &(c, a) in terms {
                    grad[c] += z * a;
                }
            }
            for &(c, a) in &eq[0].0 {
                grad[c] += ours.y[0] * a;
            }
            for (i, g) in grad.iter().enumerate() {
                assert!(g.abs() < 1e-9, "case {case}: stationarity {g} at {i}");
            }
            // The KKT conditions above prove ours optimal; the interior
            // point, whose x is looser (its active rows stop about gap/z
            // inside their bounds, its flat directions to its residual over
            // their curvature), reaches the same objective to its tolerance,
            // never a lower one.
            let objective = |x: &[f64]| {
                let mut v: f64 = (0..n).map(|i| 0.5 * p[i] * x[i] * x[i] + q[i] * x[i]).sum();
                for r in 0..nd {
                    for k in 0..nd {
                        v += 0.5 * x[r] * block[r * nd + k] * x[k];
                    }
                }
                v
            };
            let (a, b) = (objective(&ours.x), objective(&theirs.x));
            assert!(
                a <= b + 1e-9 && b - a < 1e-6 * (1.0 + b.abs()),
                "case {case}: {a} vs {b}"
            );
        }
    }

    /// A dense block that is not positive definite is an error, not a
    /// wrong answer.
    #[test]
    fn an_indefinite_dense_block_is_an_error() {
        let block = [1.0, 0.0, 0.0, -2.0];
        let problem = Problem {
            dense: Some(&block),
            p: &[1e-3, 1e-3],
            q: &[0.0, 1.0],
            eq: &[],
            le: &[],
        };
        assert_eq!(solve(&problem).unwrap_err(), QpError::NotStrictlyConvex);
    }

    /// Random feasible QPs of the polish's shape against the interior
    /// point: the same x and multipliers, every row met, the KKT
    /// conditions to rounding.
    #[test]
    fn random_qps_agree_with_the_interior_point() {
        let mut rng = ChaCha8Rng::seed_from_u64(36);
        let mut compared = 0;
        for case in 0..200 {
            let n = rng.gen_range(2..40);
            let p: Vec<f64> = (0..n)
                .map(|_| 10f64.powf(rng.gen_range(-4.0..2.0f64)))
                .collect();
            let q: Vec<f64> = (0..n).map(|_| rng.gen_range(-10.0..10.0)).collect();
            // A feasible point x0 and rows through or around it.
            let x0: Vec<f64> = (0..n).map(|_| rng.gen_range(-0.5..0.5)).collect();
            let row = |rng: &mut ChaCha8Rng| -> Vec<(usize, f64)> {
                let k = rng.gen_range(1..=n.min(6));
                let mut terms: Vec<(usize, f64)> = (0..k)
                    .map(|_| {
                        (
                            rng.gen_range(0..n),
                            rng.gen_range(-1.0..1.0) * 10f64.powi(rng.gen_range(-2..4)),
                        )
                    })
                    .collect();
                terms.sort_by_key(|t| t.0);
                terms.dedup_by_key(|t| t.0);
                terms
            };
            let at = |terms: &[(usize, f64)]| terms.iter().map(|&(c, v)| v * x0[c]).sum::<f64>();
            let eq: Vec<Row> = (0..rng.gen_range(0..n.min(5)))
                .map(|_| {
                    let t = row(&mut rng);
                    let b = at(&t);
                    (t, b)
                })
                .collect();
            let mut le: Vec<Row> = (0..rng.gen_range(0..4 * n))
                .map(|_| {
                    let t = row(&mut rng);
                    let b = at(&t) + rng.gen_range(0.0..1.0f64).powi(3);
                    (t, b)
                })
                .collect();
            // A duplicate row now and then, as the grid and the extrema give.
            if !le.is_empty() && rng.gen_bool(0.5) {
                let dup = le[0].clone();
                le.push(dup);
            }
            for i in 0..n {
                le.push((vec![(i, 1.0)], 1.0));
                le.push((vec![(i, -1.0)], 1.0));
            }
            let problem = Problem {
                dense: None,
                p: &p,
                q: &q,
                eq: &eq,
                le: &le,
            };
            let ours = solve(&problem).unwrap_or_else(|e| panic!("case {case}: {e}"));
            // Feasible and stationary to rounding.
            for (terms, b) in &eq {
                let v: f64 = terms.iter().map(|&(c, a)| a * ours.x[c]).sum();
                assert!((v - b).abs() < 1e-9 * (1.0 + b.abs()), "case {case}");
            }
            let mut grad: Vec<f64> = (0..n).map(|i| p[i] * ours.x[i] + q[i]).collect();
            for ((terms, b), z) in le.iter().zip(&ours.z) {
                let v: f64 = terms.iter().map(|&(c, a)| a * ours.x[c]).sum();
                assert!(v <= b + 1e-9 * (1.0 + b.abs()), "case {case}: {v} > {b}");
                assert!(*z >= 0.0);
                for &(c, a) in terms {
                    grad[c] += z * a;
                }
            }
            for ((terms, _), y) in eq.iter().zip(&ours.y) {
                for &(c, a) in terms {
                    grad[c] += y * a;
                }
            }
            let size = 1.0 + q.iter().map(|v| v.abs()).fold(0.0, f64::max);
            for g in grad {
                assert!(g.abs() < 1e-8 * size, "case {case}: stationarity {g}");
            }
            // Complementary: a row with a multiplier is at its bound.
            for ((terms, b), z) in le.iter().zip(&ours.z) {
                let v: f64 = terms.iter().map(|&(c, a)| a * ours.x[c]).sum();
                let size = terms.iter().map(|(_, a)| a.abs()).fold(0.0, f64::max);
                assert!(
                    *z == 0.0 || (b - v) < 1e-9 * (size + b.abs()),
                    "case {case}"
                );
            }
            // And no worse than the interior point's answer, where it has
            // one (its factorization fails to rounding on a few of these).
            if let Ok(ip) = crate::polish::qp::solve(&problem) {
                let objective = |x: &[f64]| {
                    (0..n)
                        .map(|i| 0.5 * p[i] * x[i] * x[i] + q[i] * x[i])
                        .sum::<f64>()
                };
                let (a, b) = (objective(&ours.x), objective(&ip.x));
                assert!(a <= b + 1e-7 * (1.0 + b.abs()), "case {case}: {a} > {b}");
                compared += 1;
            }
        }
        assert!(compared > 150, "{compared}");
    }

    /// A QP solved on part of its inequalities and then given the rest
    /// ([`Solver::add`]) ends at the answer of the whole QP solved anew:
    /// the same x and multipliers (the answer is unique), in fewer changes
    /// than the new solve's.
    #[test]
    fn adding_rows_continues_to_the_grown_qps_answer() {
        let mut rng = ChaCha8Rng::seed_from_u64(37);
        let (mut fewer, mut cases) = (0, 0);
        for case in 0..100 {
            let n = rng.gen_range(3..30);
            let p: Vec<f64> = (0..n)
                .map(|_| 10f64.powf(rng.gen_range(-3.0..1.0f64)))
                .collect();
            let q: Vec<f64> = (0..n).map(|_| rng.gen_range(-10.0..10.0)).collect();
            let x0: Vec<f64> = (0..n).map(|_| rng.gen_range(-0.5..0.5)).collect();
            let mut row = |slack: f64| -> Row {
                let terms: Vec<(usize, f64)> = (0..n)
                    .filter(|_| rng.gen_bool(0.3))
                    .collect::<Vec<_>>()
                    .into_iter()
                    .map(|c| (c, rng.gen_range(-1.0..1.0)))
                    .collect();
                let b = terms.iter().map(|&(c, v)| v * x0[c]).sum::<f64>() + slack;
                (terms, b)
            };
            let eq: Vec<Row> = (0..n / 4).map(|_| row(0.0)).collect();
            let le: Vec<Row> = (0..3 * n).map(|k| row(0.01 * k as f64)).collect();
            let split = le.len() / 2;
            let whole = Problem {
                dense: None,
                p: &p,
                q: &q,
                eq: &eq,
                le: &le,
            };
            let anew = solve(&whole).unwrap_or_else(|e| panic!("case {case}: {e}"));
            let mut solver = Solver::new(&Problem {
                dense: None,
                le: &le[..split],
                ..whole
            })
            .unwrap();
            let before = solver.changes();
            solver.add(&le[split..]).unwrap();
            let grown = solver.answer();
            for (a, b) in grown.x.iter().zip(&anew.x) {
                assert!((a - b).abs() < 1e-9 * (1.0 + b.abs()), "case {case}");
            }
            for (a, b) in grown
                .y
                .iter()
                .zip(&anew.y)
                .chain(grown.z.iter().zip(&anew.z))
            {
                assert!(
                    (a - b).abs() < 1e-7 * (1.0 + b.abs()),
                    "case {case}: {a} {b}"
                );
            }
            assert_eq!(grown.z.len(), le.len());
            cases += 1;
            fewer += usize::from(grown.iterations - before < anew.iterations);
        }
        assert!(fewer > cases / 2, "{fewer} of {cases}");
    }

    /// [`Solver::moved`]: with two equalities shifted, the point meets
    /// them, keeps every active row, breaks none, and its Δ is the least
    /// in H's norm among the steps that do (H-orthogonal to the rows' null
    /// space), on random QPs.
    #[test]
    fn moving_the_equalities_keeps_the_active_set_met_at_least_norm() {
        let mut rng = ChaCha8Rng::seed_from_u64(18);
        let mut checked = 0;
        for _ in 0..40 {
            let n = rng.gen_range(6..20);
            let p: Vec<f64> = (0..n).map(|_| rng.gen_range(0.5..2.0)).collect();
            let q: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let row = |rng: &mut ChaCha8Rng| -> Vec<(usize, f64)> {
                (0..n).map(|k| (k, rng.gen_range(-1.0..1.0))).collect()
            };
            let eq: Vec<Row> = (0..2)
                .map(|_| (row(&mut rng), rng.gen_range(-0.5..0.5)))
                .collect();
            let le: Vec<Row> = (0..3 * n)
                .map(|_| (row(&mut rng), rng.gen_range(0.0..0.3)))
                .collect();
            let problem = Problem {
                dense: None,
                p: &p,
                q: &q,
                eq: &eq,
                le: &le,
            };
            let Ok(solver) = Solver::new(&problem) else {
                continue;
            };
            let x0 = solver.answer().x;
            let moved = [(0, 1e-3), (1, -2e-3)];
            let Some(x) = solver.moved(&moved) else {
                continue;
            };
            checked += 1;
            let value =
                |(terms, _): &Row, x: &[f64]| terms.iter().map(|&(k, a)| a * x[k]).sum::<f64>();
            // The moved equalities, and the active inequalities, met.
            for (k, &(_, change)) in moved.iter().enumerate() {
                assert!((value(&eq[k], &x) - eq[k].1 - change).abs() < 1e-10);
            }
            let z = solver.answer().z;
            for (r, z) in le.iter().zip(&z) {
                let v = value(r, &x);
                assert!(v <= r.1 + 1e-9, "a row broken: {v} > {}", r.1);
                if *z > 0.0 {
                    assert!(
                        (v - r.1).abs() < 1e-10,
                        "an active row left: {v} vs {}",
                        r.1
                    );
                }
            }
            // Δ is H-orthogonal to every step that keeps those rows:
            // the least ½·Δᵀ·H·Δ among the points that meet them.
            let delta: Vec<f64> = x.iter().zip(&x0).map(|(a, b)| a - b).collect();
            let held: Vec<&Row> = eq
                .iter()
                .chain(le.iter().zip(&z).filter(|(_, z)| **z > 0.0).map(|(r, _)| r))
                .collect();
            for _ in 0..5 {
                // A random step projected onto the rows' null space by
                // least squares (Gram–Schmidt on the rows).
                let mut basis: Vec<Vec<f64>> = Vec::new();
                for r in &held {
                    let mut a = vec![0.0; n];
                    for &(k, v) in &r.0 {
                        a[k] = v;
                    }
                    for b in &basis {
                        let d: f64 = a.iter().zip(b).map(|(a, b)| a * b).sum();
                        a.iter_mut().zip(b).for_each(|(a, b)| *a -= d * b);
                    }
                    let norm = a.iter().map(|v| v * v).sum::<f64>().sqrt();
                    if norm > 1e-9 {
                        basis.push(a.iter().map(|v| v / norm).collect());
                    }
                }
                let mut w: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
                for b in &basis {
                    let d: f64 = w.iter().zip(b).map(|(a, b)| a * b).sum();
                    w.iter_mut().zip(b).for_each(|(a, b)| *a -= d * b);
                }
                let inner: f64 = (0..n).map(|i| delta[i] * p[i] * w[i]).sum();
                assert!(inner.abs() < 1e-9, "Δᵀ·H·w = {inner}");
            }
        }
        assert!(checked >= 10, "{checked} cases checked");
    }

    #[test]
    fn an_infeasible_qp_is_an_error() {
        let le: Vec<Row> = vec![(vec![(0, 1.0)], -1.0), (vec![(0, -1.0)], -1.0)];
        let e = solve(&Problem {
            dense: None,
            p: &[1.0],
            q: &[0.0],
            eq: &[],
            le: &le,
        });
        assert!(matches!(e, Err(QpError::Infeasible { .. })), "{e:?}");
    }
}
