//! The dense factorizations of the KKT solve: faer's Bunch–Kaufman LBLᵀ
//! ([`Lblt`], for the node blocks' fallback and R's), its unpivoted LDLᵀ
//! of R with a growth test ([`Ldlt`]), and a small unpivoted LDLᵀ inverse
//! of a node block on the stack; each reports the inertia that it finds.

#![allow(clippy::needless_range_loop)] // Dense block algebra indexes several arrays by one index.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::{lblt, ldlt};
use faer::perm::PermRef;
use faer::{ColMut, ColRef, MatMut, MatRef, Par};

use super::Inertia;

impl Inertia {
    /// Count a 1×1 pivot d of a factorization whose largest pivot is about
    /// `scale`: zero below [`ZERO_PIVOT`]·scale (or not finite).
    pub(super) fn count_pivot(&mut self, d: f64, scale: f64) {
        if d.abs() <= ZERO_PIVOT * scale || !d.is_finite() {
            self.zero += 1;
        } else if d > 0.0 {
            self.positive += 1;
        } else {
            self.negative += 1;
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
pub(super) const ZERO_PIVOT: f64 = 1e-30;

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
pub(super) struct Lblt {
    pub(super) a: Vec<f64>,
    sub: Vec<f64>,
    perm: Vec<usize>,
    perm_inv: Vec<usize>,
    buf: MemBuffer,
}

impl Lblt {
    pub(super) fn new(dim: usize, rhs: usize) -> Self {
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

    /// Back to the state of [`Lblt::new`] (faer's scratch is not read
    /// before it is written, so it stays).
    pub(super) fn reset(&mut self) {
        self.a.fill(0.0);
        self.sub.fill(0.0);
        self.perm.fill(0);
        self.perm_inv.fill(0);
    }

    /// Factor the lower triangle of `a` (column-major); returns the inertia.
    pub(super) fn factor(&mut self, n: usize) -> Inertia {
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
    pub(super) fn solve(&mut self, n: usize, x: &mut [f64], k: usize) {
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

/// R's LDLᵀ without pivoting, in place: the work space of its growth test.
pub(super) struct Ldlt {
    /// Per row: Σ_j R_ij², then Σ_j L_ij² |D_j|.
    row_norm: Vec<f64>,
    row_growth: Vec<f64>,
    buf: MemBuffer,
}

impl Ldlt {
    pub(super) fn new(rd: usize) -> Self {
        let req = ldlt::factor::cholesky_in_place_scratch::<f64>(rd, Par::Seq, Default::default())
            .or(ldlt::solve::solve_in_place_scratch::<f64>(rd, 1, Par::Seq));
        Ldlt {
            row_norm: vec![0.0; rd],
            row_growth: vec![0.0; rd],
            buf: MemBuffer::new(req),
        }
    }

    /// Back to the state of [`Ldlt::new`].
    pub(super) fn reset(&mut self) {
        self.row_norm.fill(0.0);
        self.row_growth.fill(0.0);
    }

    /// Factor R in place (`a`: its lower triangle, rd square, column-major),
    /// into L (unit, strictly lower) and D (the diagonal); its inertia, or
    /// None (and `a` spoilt) when a pivot is zero or the growth exceeds
    /// `growth_max`.
    pub(super) fn factor(&mut self, a: &mut [f64], rd: usize, growth_max: f64) -> Option<Inertia> {
        let (row_norm, row_growth) = (&mut self.row_norm[..rd], &mut self.row_growth[..rd]);
        row_norm.iter_mut().for_each(|v| *v = 0.0);
        row_growth.iter_mut().for_each(|v| *v = 0.0);
        for c in 0..rd {
            let col = &a[c * rd + c..(c + 1) * rd];
            for (m, v) in row_norm[c..].iter_mut().zip(col) {
                *m += v * v;
            }
            // The diagonal entry is in both sums. Four partial sums, so
            // that the loop vectorizes (one scalar sum was latency-bound:
            // with the loop above, as long as faer's factorization of a
            // 6-DoF R); the norms only gauge the growth.
            let mut part = [0.0f64; 4];
            let chunks = col.chunks_exact(4);
            let rest: f64 = chunks.remainder().iter().map(|v| v * v).sum();
            for v in chunks {
                for (p, x) in part.iter_mut().zip(v) {
                    *p += x * x;
                }
            }
            let col_sq = part[0] + part[1] + part[2] + part[3] + rest;
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
    pub(super) fn solve(a: &[f64], x: &mut [f64]) {
        Ldlt::solve_cols(a, x, 1);
    }

    /// Solve R X = B in place for `k` right-hand sides (`x`: B, column-major).
    pub(super) fn solve_cols(a: &[f64], x: &mut [f64], k: usize) {
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
pub(super) fn small_ldlt_inverse<const NL: usize>(
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::method::direct::kkt::GROWTH_MAX;

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
}
