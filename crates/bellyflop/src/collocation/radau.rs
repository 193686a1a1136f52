//! Legendre–Gauss–Radau (LGR) pseudospectral machinery on τ ∈ [−1, 1].
//!
//! The time interval t ∈ [0, t_f] is mapped to τ ∈ [−1, 1] by
//! t = (τ + 1)·t_f/2, so dt/dτ = t_f/2.
//!
//! With N collocation points the discretisation uses N + 1 nodes:
//!
//! * τ_1 = −1, τ_2 < … < τ_N: the N (standard, non-flipped) LGR points: −1 together
//!   with the N − 1 roots of (P_{N−1}(τ) + P_N(τ))/(1 + τ), which are the zeros
//!   of the Jacobi polynomial P^{(0,1)}_{N−1}(τ);
//! * τ_{N+1} = +1: a non-collocated node carrying the final state.
//!
//! The state is approximated by the degree-N Lagrange polynomial through the
//! N + 1 nodes, X(τ) ≈ Σ_{j=1}^{N+1} X_j ℓ_j(τ). Differentiating it at the
//! collocation points gives the N×(N+1) LGR differentiation matrix
//! D_ij = ℓ̇_j(τ_i), and the dynamics ẋ = f(x, u) become the collocation
//! constraints of the paper's Eq. 24,
//!
//! ```text
//! Σ_{j=1}^{N+1} D_ij X_j − (t_f/2) f(X_i, U_i) = 0,   i = 1, …, N.
//! ```
//!
//! Integral costs use the LGR quadrature
//! ∫_{0}^{t_f} g dt ≈ (t_f/2) Σ_{i=1}^{N} w_i g(X_i, U_i), exact for polynomials
//! of degree ≤ 2N − 2 in τ.
//!
//! In code all indices are zero-based: collocation points are `0..n`, and
//! `nodes[n] = 1.0` is the final, non-collocated node.

use nalgebra::{DMatrix, SymmetricEigen};

/// LGR nodes, quadrature weights, differentiation matrix and barycentric
/// interpolation weights for `n` collocation points.
#[derive(Debug, Clone, PartialEq)]
pub struct Lgr {
    /// Number of collocation points N.
    pub n: usize,
    /// N + 1 points, strictly increasing: the N LGR collocation points
    /// τ_1 = −1, …, τ_N, followed by the non-collocated τ_{N+1} = +1.
    pub nodes: Vec<f64>,
    /// N LGR quadrature weights: w_1 = 2/N², w_i = (1 − τ_i)/(N² P_{N−1}(τ_i)²).
    /// They sum to 2 and integrate polynomials of degree ≤ 2N − 2 exactly.
    pub weights: Vec<f64>,
    /// N×(N+1) differentiation matrix, row-major: `diff[i * (n + 1) + j]` is
    /// D_ij = ℓ̇_j(τ_i), the derivative of the j-th Lagrange basis polynomial on
    /// the N + 1 nodes evaluated at collocation point i (Eq. 24).
    pub diff: Vec<f64>,
    /// Barycentric weights b_j ∝ 1/Π_{k≠j}(τ_j − τ_k) of the N + 1 nodes
    /// (normalised so that max |b_j| = 1).
    pub bary: Vec<f64>,
    /// Barycentric weights of the N collocation points only (the interpolant
    /// of the controls), normalised so that max |b_j| = 1.
    pub control_bary: Vec<f64>,
}

impl Lgr {
    /// Build the LGR discretisation with `n ≥ 1` collocation points.
    ///
    /// Interior nodes come from the Golub–Welsch eigenvalue problem for the
    /// Jacobi (α, β) = (0, 1) recurrence, polished by Newton steps on
    /// P_{N−1} + P_N. The differentiation matrix uses the barycentric formula
    /// D_ij = (b_j/b_i)/(τ_i − τ_j) for i ≠ j and the negative-sum trick
    /// D_ii = −Σ_{j≠i} D_ij (so that D annihilates constants to rounding).
    ///
    /// # Panics
    /// Panics if `n == 0`.
    pub fn new(n: usize) -> Lgr {
        assert!(n >= 1, "LGR needs at least one collocation point");
        let mut nodes = Vec::with_capacity(n + 1);
        nodes.push(-1.0);
        nodes.extend(interior_lgr_points(n));
        nodes.push(1.0);

        let nf = n as f64;
        let n2 = nf * nf;
        let weights: Vec<f64> = nodes[..n]
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                if i == 0 {
                    2.0 / n2
                } else {
                    let (p_nm1, _, _, _) = legendre_pair(n, t);
                    (1.0 - t) / (n2 * p_nm1 * p_nm1)
                }
            })
            .collect();

        let bary = barycentric_weights(&nodes);
        let control_bary = barycentric_weights(&nodes[..n]);

        let m = n + 1;
        let mut diff = vec![0.0; n * m];
        for i in 0..n {
            let row = &mut diff[i * m..(i + 1) * m];
            let mut diag = 0.0;
            for j in 0..m {
                if j != i {
                    let dij = (bary[j] / bary[i]) / (nodes[i] - nodes[j]);
                    row[j] = dij;
                    diag -= dij;
                }
            }
            row[i] = diag;
        }

        Lgr {
            n,
            nodes,
            weights,
            diff,
            bary,
            control_bary,
        }
    }

    /// Entry D_ij of the differentiation matrix (`i < n`, `j ≤ n`).
    #[inline]
    pub fn d(&self, i: usize, j: usize) -> f64 {
        debug_assert!(i < self.n && j <= self.n);
        self.diff[i * (self.n + 1) + j]
    }

    /// Physical time of node `k` (`k ≤ n`): t_k = (τ_k + 1)·t_f/2.
    #[inline]
    pub fn time_s(&self, k: usize, tf_s: f64) -> f64 {
        (self.nodes[k] + 1.0) * tf_s / 2.0
    }

    /// Evaluate the degree-N state interpolant X(τ) = Σ_{j=1}^{N+1} X_j ℓ_j(τ)
    /// through the N + 1 node values `values` at `tau`.
    pub fn interpolate_states(&self, values: &[f64], tau: f64) -> f64 {
        assert_eq!(values.len(), self.n + 1, "need N + 1 state values");
        interpolate(&self.nodes, &self.bary, values, tau)
    }

    /// Evaluate the degree-(N−1) control interpolant through the N
    /// collocation-point values `values` at `tau` (extrapolated on
    /// (τ_N, 1]).
    pub fn interpolate_controls(&self, values: &[f64], tau: f64) -> f64 {
        assert_eq!(values.len(), self.n, "need N control values");
        interpolate(&self.nodes[..self.n], &self.control_bary, values, tau)
    }
}

/// Barycentric weights b_j = 1/Π_{k≠j}(x_j − x_k) of distinct `points`, up to
/// a common positive factor chosen so that max |b_j| = 1.
///
/// The products are accumulated as sums of logarithms, so they neither
/// overflow nor underflow for many points.
pub fn barycentric_weights(points: &[f64]) -> Vec<f64> {
    let m = points.len();
    let mut log_mag = vec![0.0; m];
    let mut neg = vec![false; m];
    for j in 0..m {
        let mut s = 0.0;
        let mut sign_neg = false;
        for k in 0..m {
            if k != j {
                let diff = points[j] - points[k];
                s -= diff.abs().ln();
                sign_neg ^= diff < 0.0;
            }
        }
        log_mag[j] = s;
        neg[j] = sign_neg;
    }
    let max = log_mag.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    log_mag
        .iter()
        .zip(&neg)
        .map(|(&l, &ng)| {
            let b = (l - max).exp();
            if ng {
                -b
            } else {
                b
            }
        })
        .collect()
}

/// Barycentric formula of the second kind,
/// p(τ) = Σ_j [b_j/(τ − τ_j)] v_j / Σ_j [b_j/(τ − τ_j)],
/// evaluating the polynomial of degree < `points.len()` that takes `values`
/// at `points`. Returns the node value exactly when `tau` equals a node.
pub fn interpolate(points: &[f64], bary: &[f64], values: &[f64], tau: f64) -> f64 {
    assert_eq!(points.len(), values.len());
    interpolate_by(points, bary, |j| values[j], tau)
}

/// [`interpolate`] with the value at point j given by `value(j)`: the same
/// sums in the same order, for callers that would otherwise gather the
/// values into a buffer (no allocation in a re-plan).
pub fn interpolate_by(points: &[f64], bary: &[f64], value: impl Fn(usize) -> f64, tau: f64) -> f64 {
    assert_eq!(points.len(), bary.len());
    let mut num = 0.0;
    let mut den = 0.0;
    for (j, (&x, &b)) in points.iter().zip(bary).enumerate() {
        let dx = tau - x;
        if dx == 0.0 {
            return value(j);
        }
        let c = b / dx;
        num += c * value(j);
        den += c;
    }
    num / den
}

/// Legendre values and derivatives at `x`: (P_{n−1}, P_n, P'_{n−1}, P'_n),
/// by the three-term recurrence (k+1)P_{k+1} = (2k+1)xP_k − kP_{k−1}.
fn legendre_pair(n: usize, x: f64) -> (f64, f64, f64, f64) {
    // (p0, p1) = (P_{k-1}, P_k), (d0, d1) their derivatives; start at k = 0.
    let (mut p0, mut p1) = (0.0, 1.0);
    let (mut d0, mut d1) = (0.0, 0.0);
    for k in 0..n {
        let kf = k as f64;
        let p2 = ((2.0 * kf + 1.0) * x * p1 - kf * p0) / (kf + 1.0);
        let d2 = ((2.0 * kf + 1.0) * (p1 + x * d1) - kf * d0) / (kf + 1.0);
        p0 = p1;
        p1 = p2;
        d0 = d1;
        d1 = d2;
    }
    (p0, p1, d0, d1)
}

/// The N − 1 interior LGR points: zeros of P^{(0,1)}_{N−1}, ascending.
///
/// Golub–Welsch: the zeros are the eigenvalues of the symmetric tridiagonal
/// Jacobi matrix with diagonal a_k = 1/((2k+1)(2k+3)) and off-diagonal
/// b_k = √(k(k+1))/(2k+1), k ≥ 1. Each eigenvalue is then polished by Newton
/// iterations on P_{N−1} + P_N (which has the same interior zeros).
fn interior_lgr_points(n: usize) -> Vec<f64> {
    let m = n - 1;
    if m == 0 {
        return Vec::new();
    }
    let mut jac = DMatrix::<f64>::zeros(m, m);
    for k in 0..m {
        let kf = k as f64;
        jac[(k, k)] = 1.0 / ((2.0 * kf + 1.0) * (2.0 * kf + 3.0));
        if k >= 1 {
            let off = (kf * (kf + 1.0)).sqrt() / (2.0 * kf + 1.0);
            jac[(k, k - 1)] = off;
            jac[(k - 1, k)] = off;
        }
    }
    let mut roots: Vec<f64> = SymmetricEigen::new(jac)
        .eigenvalues
        .iter()
        .copied()
        .collect();
    for r in roots.iter_mut() {
        let mut x = *r;
        for _ in 0..4 {
            let (p_nm1, p_n, d_nm1, d_n) = legendre_pair(n, x);
            let step = (p_nm1 + p_n) / (d_nm1 + d_n);
            // Guard: the eigenvalues are already accurate; only accept small
            // corrections that keep the point inside (−1, 1).
            if !step.is_finite() || step.abs() > 1e-8 || !(-1.0..1.0).contains(&(x - step)) {
                break;
            }
            x -= step;
            if step.abs() <= f64::EPSILON * x.abs().max(1e-3) {
                break;
            }
        }
        *r = x;
    }
    roots.sort_by(f64::total_cmp);
    roots
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Deterministic xorshift64* uniform numbers in [lo, hi).
    struct Rng(u64);
    impl Rng {
        fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            let u = (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64;
            lo + (hi - lo) * u
        }
    }

    fn horner(coef: &[f64], x: f64) -> f64 {
        coef.iter().rev().fold(0.0, |acc, &c| acc * x + c)
    }

    #[test]
    fn n5_nodes_match_reference() {
        let lgr = Lgr::new(5);
        let expected = [-1.0, -0.720480, -0.167181, 0.446314, 0.885792, 1.0];
        assert_eq!(lgr.nodes.len(), 6);
        for (a, b) in lgr.nodes.iter().zip(expected) {
            assert!((a - b).abs() < 1e-6, "node {a} vs {b}");
        }
    }

    #[test]
    fn small_n_closed_forms() {
        // N = 1: nodes {−1, 1}, w = 2, D = [−1/2, 1/2].
        let l1 = Lgr::new(1);
        assert_eq!(l1.nodes, vec![-1.0, 1.0]);
        assert!((l1.weights[0] - 2.0).abs() < 1e-15);
        assert!((l1.d(0, 0) + 0.5).abs() < 1e-15 && (l1.d(0, 1) - 0.5).abs() < 1e-15);
        // N = 2: interior root of (3τ − 1)(τ + 1)/2 is 1/3; weights 1/2, 3/2.
        let l2 = Lgr::new(2);
        assert!((l2.nodes[1] - 1.0 / 3.0).abs() < 1e-15);
        assert!((l2.weights[0] - 0.5).abs() < 1e-15);
        assert!((l2.weights[1] - 1.5).abs() < 1e-14);
    }

    #[test]
    fn nodes_ordered_with_endpoints() {
        for n in 1..=100 {
            let lgr = Lgr::new(n);
            assert_eq!(lgr.nodes.len(), n + 1);
            assert_eq!(lgr.nodes[0], -1.0);
            assert_eq!(lgr.nodes[n], 1.0);
            assert!(
                lgr.nodes.windows(2).all(|w| w[0] < w[1]),
                "N={n} not increasing"
            );
            assert!(lgr.nodes[..n].iter().all(|&t| t < 1.0));
            assert_eq!(lgr.weights.len(), n);
            assert_eq!(lgr.diff.len(), n * (n + 1));
            assert_eq!(lgr.bary.len(), n + 1);
            assert_eq!(lgr.control_bary.len(), n);
        }
    }

    #[test]
    fn nodes_are_roots_of_legendre_sum() {
        for n in [4, 10, 37, 100] {
            let lgr = Lgr::new(n);
            for &t in &lgr.nodes[..n] {
                let (p_nm1, p_n, d_nm1, d_n) = legendre_pair(n, t);
                // |f| relative to |f'|·eps bounds the root error.
                assert!(
                    (p_nm1 + p_n).abs() <= 1e-13 * (d_nm1 + d_n).abs().max(1.0),
                    "N={n}, τ={t}"
                );
            }
        }
    }

    #[test]
    fn weights_sum_to_two_and_positive() {
        for n in 4..=100 {
            let lgr = Lgr::new(n);
            assert!(lgr.weights.iter().all(|&w| w > 0.0));
            let s: f64 = lgr.weights.iter().sum();
            assert!((s - 2.0).abs() < 1e-14 * n as f64, "N={n}: sum {s}");
        }
    }

    #[test]
    fn quadrature_exact_to_degree_2n_minus_2() {
        for n in [4, 5, 7, 10, 20, 40, 60, 100] {
            let lgr = Lgr::new(n);
            let mut degrees: Vec<usize> = vec![0, 1, 2, 3, n, 2 * n - 3, 2 * n - 2];
            degrees.sort_unstable();
            degrees.dedup();
            for k in degrees {
                let exact = if k % 2 == 0 {
                    2.0 / (k as f64 + 1.0)
                } else {
                    0.0
                };
                let (q, scale) =
                    lgr.nodes[..n]
                        .iter()
                        .zip(&lgr.weights)
                        .fold((0.0, 0.0), |(q, s), (&t, &w)| {
                            let v = w * t.powi(k as i32);
                            (q + v, s + v.abs())
                        });
                assert!(
                    (q - exact).abs() <= 1e-10 * exact.abs().max(scale),
                    "N={n}, degree {k}: {q} vs {exact}"
                );
            }
            // Degree 2N − 1 is NOT integrated exactly (the error is visible
            // for small N; it decays like 4^{−N}): the check has teeth.
            if n <= 10 {
                let k = 2 * n - 1;
                let q: f64 = lgr.nodes[..n]
                    .iter()
                    .zip(&lgr.weights)
                    .map(|(&t, &w)| w * t.powi(k as i32))
                    .sum();
                assert!(q.abs() > 1e-6, "N={n}: degree {k} unexpectedly exact");
            }
        }
    }

    #[test]
    fn diff_matrix_exact_on_monomials() {
        for n in [4, 5, 10, 20, 40, 60, 100] {
            let lgr = Lgr::new(n);
            for m in 0..=n {
                let x: Vec<f64> = lgr.nodes.iter().map(|&t| t.powi(m as i32)).collect();
                // max |d/dτ τ^m| on [−1, 1] is m.
                let scale = (m as f64).max(1.0);
                for i in 0..n {
                    let dx: f64 = (0..=n).map(|j| lgr.d(i, j) * x[j]).sum();
                    let t = lgr.nodes[i];
                    let exact = if m == 0 {
                        0.0
                    } else {
                        m as f64 * t.powi(m as i32 - 1)
                    };
                    assert!(
                        (dx - exact).abs() <= 1e-10 * scale,
                        "N={n}, m={m}, i={i}: {dx} vs {exact}"
                    );
                }
            }
        }
    }

    #[test]
    fn diff_matrix_not_exact_beyond_degree_n() {
        let n = 10;
        let lgr = Lgr::new(n);
        let m = n + 1;
        let worst = (0..n)
            .map(|i| {
                let dx: f64 = (0..=n)
                    .map(|j| lgr.d(i, j) * lgr.nodes[j].powi(m as i32))
                    .sum();
                (dx - m as f64 * lgr.nodes[i].powi(m as i32 - 1)).abs()
            })
            .fold(0.0, f64::max);
        assert!(worst > 1e-6);
    }

    #[test]
    fn state_interpolation_reproduces_degree_n() {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        for n in [4, 5, 10, 20, 40, 60, 100] {
            let lgr = Lgr::new(n);
            let coef: Vec<f64> = (0..=n).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let scale: f64 = coef.iter().map(|c| c.abs()).sum();
            let values: Vec<f64> = lgr.nodes.iter().map(|&t| horner(&coef, t)).collect();
            for k in 0..=n {
                assert_eq!(lgr.interpolate_states(&values, lgr.nodes[k]), values[k]);
            }
            for _ in 0..50 {
                let tau = rng.uniform(-1.0, 1.0);
                let p = lgr.interpolate_states(&values, tau);
                let exact = horner(&coef, tau);
                assert!(
                    (p - exact).abs() <= 1e-11 * scale,
                    "N={n}, τ={tau}: {p} vs {exact}"
                );
            }
        }
    }

    #[test]
    fn control_interpolation_reproduces_degree_n_minus_1() {
        let mut rng = Rng(0xD1B5_4A32_D192_ED03);
        for n in [4, 5, 10, 20, 40, 60, 100] {
            let lgr = Lgr::new(n);
            let coef: Vec<f64> = (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let scale: f64 = coef.iter().map(|c| c.abs()).sum();
            let values: Vec<f64> = lgr.nodes[..n].iter().map(|&t| horner(&coef, t)).collect();
            let mut taus: Vec<f64> = (0..50).map(|_| rng.uniform(-1.0, 1.0)).collect();
            taus.push(1.0); // extrapolation to the final node
            for tau in taus {
                let p = lgr.interpolate_controls(&values, tau);
                let exact = horner(&coef, tau);
                assert!(
                    (p - exact).abs() <= 1e-11 * scale,
                    "N={n}, τ={tau}: {p} vs {exact}"
                );
            }
            // τ^N is NOT reproduced: its interpolant is τ^N − ω(τ) with
            // ω(τ) = Π_i (τ − τ_i), so at τ = 1 it equals 1 − ω(1).
            if n <= 10 {
                let vals_n: Vec<f64> = lgr.nodes[..n].iter().map(|&t| t.powi(n as i32)).collect();
                let omega1: f64 = lgr.nodes[..n].iter().map(|&t| 1.0 - t).product();
                assert!(omega1 > 1e-6);
                let p1 = lgr.interpolate_controls(&vals_n, 1.0);
                assert!((p1 - (1.0 - omega1)).abs() < 1e-12, "N={n}: {p1}");
            }
        }
    }

    #[test]
    fn time_mapping() {
        let lgr = Lgr::new(6);
        assert_eq!(lgr.time_s(0, 12.0), 0.0);
        assert_eq!(lgr.time_s(6, 12.0), 12.0);
        let t2 = lgr.time_s(2, 12.0);
        assert!((t2 - (lgr.nodes[2] + 1.0) * 6.0).abs() < 1e-15);
    }

    #[test]
    fn barycentric_weights_equispaced_three_points() {
        // Points {−1, 0, 1}: b ∝ (1/2, −1, 1/2), normalised to max |b| = 1.
        let b = barycentric_weights(&[-1.0, 0.0, 1.0]);
        assert!((b[0] - 0.5).abs() < 1e-15);
        assert!((b[1] + 1.0).abs() < 1e-15);
        assert!((b[2] - 0.5).abs() < 1e-15);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        #[test]
        fn diff_rows_sum_to_zero(n in 4usize..=100) {
            let lgr = Lgr::new(n);
            let tol = 1e-9 * (n * n) as f64;
            for i in 0..n {
                let s: f64 = (0..=n).map(|j| lgr.d(i, j)).sum();
                prop_assert!(s.abs() <= tol, "N={}, row {}: {}", n, i, s);
            }
        }
    }
}
