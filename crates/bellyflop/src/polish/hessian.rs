//! The Hessian of the polish's Lagrangian in its parameters p, exact to
//! rounding through the RK4 steps of the shot ([`crate::polish::shooting`]).
//!
//! The Lagrangian of the end, Λ(p) = λ_fᵀ·y(t_f; p) + const, with λ_f =
//! ∂Λ/∂y(t_f) (the objective −m_f/M and the terminal rows at their QP
//! multipliers, as in [`crate::polish::adjoint`]). One RK4 step of a
//! segment with duration d, in its normalized time s with step h,
//!
//!   y' = y + (h/6)·(K₁ + 2K₂ + 2K₃ + K₄),   K_i = d·f(Y_i, T(s_i), δ(s_i)),
//!   Y₁ = y,  Y₂ = y + (h/2)·K₁,  Y₃ = y + (h/2)·K₂,  Y₄ = y + h·K₃,
//!
//! is linear in (y, K) except for the four stage equations. With κ_i =
//! ∂Λ/∂K_i, from λ' = ∂Λ/∂y' backwards (G_i = d·∂f/∂y at stage i),
//!
//!   κ₄ = (h/6)·λ',  κ₃ = (h/3)·λ' + h·G₄ᵀκ₄,  κ₂ = (h/3)·λ' + (h/2)·G₃ᵀκ₃,
//!   κ₁ = (h/6)·λ' + (h/2)·G₂ᵀκ₂,   λ = λ' + Σ G_iᵀκ_i,
//!
//! the Hessian is the sum over every stage of every step of
//!
//!   Z_iᵀ · ∇²_{(Y, T, δ, d)} [d·κ_iᵀ f(Y, T, δ)] · Z_i,
//!
//! Z_i = ∂(Y_i, T(s_i), δ(s_i), d)/∂p the stage's forward sensitivities
//! (the reduced Hessian of the step written as a multiple-shooting problem
//! in its stages: every other equation is linear). f's second derivatives
//! are written out in the seven variables (Vx, Vz, θ, w, m, T, δ) on which
//! f depends ([`weighted_rhs_hessian`]); the sum is taken per
//! segment in its local variables (its start state and its own
//! parameters) and mapped to p once per segment.

use crate::flown::legendre;
use crate::polish::shooting::{self, Layout, Local, SegmentControls, NC, ND};
use crate::problem::dynamics::{rhs_physical_jacobian, weighted_rhs_hessian, Model};

/// The rows of the state in the stage's variables (Vx, Vz, θ, w, m).
const STATE_ROWS: [usize; 5] = [2, 3, 4, 5, 6];

/// ∇²Λ(p) (`layout.len` square, row-major, symmetric) for λ(t_f) =
/// `lambda_f` (module docs).
pub fn hessian(
    model: &Model,
    layout: &Layout,
    y0: [f64; 7],
    p: &[f64],
    lambda_f: [f64; 7],
) -> Vec<f64> {
    let kappa = stage_multipliers(model, layout, y0, p, lambda_f);
    let len = layout.len;
    let mut h = vec![0.0; len * len];
    // ∂y(start of the current segment)/∂p, 7 rows of len.
    let mut a = vec![0.0; 7 * len];
    let mut y = y0;
    let mut at_step = 0;
    for (j, seg) in layout.segments.iter().enumerate() {
        let o = layout.offset[j];
        let cols = 7 + seg.params();
        let controls = SegmentControls::new(layout, p, j);
        let mut local = [[0.0; ND]; ND];
        let (end, yv) = shooting::segment_sensitivity(
            model,
            y,
            &controls,
            cols,
            seg.steps,
            |_, _| (),
            |step, i, ys, yvs, s| {
                let kappa = &kappa[at_step + step][i];
                accumulate(model, &controls, ys, yvs, s, kappa, cols, &mut local);
            },
        );
        at_step += seg.steps;
        map_to_p(&local, cols, &a, o, &mut h);
        y = end;
        a = shooting::chained(&yv, &a, o, seg.params());
    }
    // The two triangles agree to rounding; make them agree exactly.
    for r in 0..len {
        for c in 0..r {
            let v = 0.5 * (h[r * len + c] + h[c * len + r]);
            h[r * len + c] = v;
            h[c * len + r] = v;
        }
    }
    h
}

/// A positive definite matrix from the symmetric `h` (n², row-major): its
/// eigenvectors with the eigenvalues' magnitudes, at least `floor`
/// (Nocedal & Wright §3.4, a modified Newton step: a direction of negative
/// curvature is still weighted by how fast the model bends along it). By
/// faer's symmetric eigendecomposition, sequential; None if it fails.
pub fn convexified(h: &[f64], floor: f64) -> Option<Vec<f64>> {
    spectral(h, |l| l.abs().max(floor))
}

/// A positive definite matrix from the symmetric `h`: its eigenvalues
/// below `floor` raised to it (a direction of negative curvature is left
/// to the proximal weight and the merit rather than weighted by its
/// magnitude, which makes Newton crawl along it; the 6-DoF polish).
pub fn clipped(h: &[f64], floor: f64) -> Option<Vec<f64>> {
    spectral(h, |l| l.max(floor))
}

/// U·g(Λ)·Uᵀ of the symmetric `h` = U·Λ·Uᵀ, for g ≥ 0.
fn spectral(h: &[f64], g: impl Fn(f64) -> f64) -> Option<Vec<f64>> {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::evd::{self_adjoint_evd, self_adjoint_evd_scratch, ComputeEigenvectors};
    use faer::{Mat, Par};
    let n = (h.len() as f64).sqrt().round() as usize;
    let a = Mat::from_fn(n, n, |r, c| h[r * n + c]);
    let mut s = faer::diag::Diag::<f64>::zeros(n);
    let mut u = Mat::<f64>::zeros(n, n);
    let req =
        self_adjoint_evd_scratch::<f64>(n, ComputeEigenvectors::Yes, Par::Seq, Default::default());
    let mut buf = MemBuffer::new(req);
    self_adjoint_evd(
        a.as_ref(),
        s.as_mut(),
        Some(u.as_mut()),
        Par::Seq,
        MemStack::new(&mut buf),
        Default::default(),
    )
    .ok()?;
    // U·g(Λ)·Uᵀ as (U·g(Λ)^½)·(U·g(Λ)^½)ᵀ.
    let w = Mat::from_fn(n, n, |r, k| u[(r, k)] * g(s[k]).sqrt());
    let mut product = Mat::<f64>::zeros(n, n);
    faer::linalg::matmul::matmul(
        product.as_mut(),
        faer::Accum::Replace,
        w.as_ref(),
        w.as_ref().transpose(),
        1.0,
        Par::Seq,
    );
    let mut out = vec![0.0; n * n];
    for r in 0..n {
        for c in 0..n {
            out[r * n + c] = product[(r, c)];
        }
    }
    out.iter().all(|v| v.is_finite()).then_some(out)
}

/// Add one stage's term Zᵀ·∇²(d·κᵀf)·Z (module docs) to the segment's
/// local Hessian, Z from the stage state's local derivatives `yv`.
#[allow(clippy::too_many_arguments)]
fn accumulate(
    model: &Model,
    controls: &SegmentControls,
    y: &[f64; 7],
    yv: &Local,
    s: f64,
    kappa: &[f64; 7],
    cols: usize,
    local: &mut [[f64; ND]; ND],
) {
    debug_assert!(cols <= ND);
    let (t, delta) = controls.at(s);
    let (g, w) = weighted_rhs_hessian(model, y, t, delta, kappa);
    // W̃ over (Vx, Vz, θ, w, m, T, δ, d): d·∇²φ, and ∇φ against d.
    let d = controls.d;
    let mut wt = [[0.0; 8]; 8];
    for r in 0..7 {
        for c in 0..7 {
            wt[r][c] = d * w[r][c];
        }
        wt[r][7] = g[r];
        wt[7][r] = g[r];
    }
    // Z: 8 rows of the local columns.
    let basis = legendre(s);
    let mut z = [[0.0; ND]; 8];
    for (row, &i) in STATE_ROWS.iter().enumerate() {
        z[row][..cols].copy_from_slice(&yv[i][..cols]);
    }
    if controls.thrust.is_err() {
        for (k, b) in basis.iter().enumerate() {
            z[5][8 + NC + k] = *b;
        }
    }
    for (k, b) in basis.iter().enumerate() {
        z[6][8 + k] = *b;
    }
    z[7][7] = 1.0;
    // P = W̃·Z, then local += Zᵀ·P, on all ND columns (those past `cols`
    // are zero): fixed lengths, which the compiler vectorizes.
    let mut pz = [[0.0; ND]; 8];
    for (pr, wr) in pz.iter_mut().zip(&wt) {
        for (v, zm) in wr.iter().zip(&z).filter(|(v, _)| **v != 0.0) {
            for (p, z) in pr.iter_mut().zip(zm) {
                *p += v * z;
            }
        }
    }
    for (zm, pm) in z.iter().zip(&pz) {
        for (lr, v) in local.iter_mut().zip(zm).filter(|(_, v)| **v != 0.0) {
            for (l, p) in lr.iter_mut().zip(pm) {
                *l += v * p;
            }
        }
    }
}

/// H += Āᵀ·L·Ā for a segment's local Hessian L over (its start state, its
/// own parameters at offset `o`), Ā = [A; I], A = ∂y(start)/∂p.
fn map_to_p(local: &[[f64; ND]; ND], cols: usize, a: &[f64], o: usize, h: &mut [f64]) {
    let len = a.len() / 7;
    // B = L·Ā, cols rows of len.
    let mut b = vec![0.0; cols * len];
    for r in 0..cols {
        let row = &mut b[r * len..(r + 1) * len];
        for c in 0..7 {
            let v = local[r][c];
            if v != 0.0 {
                for (b, a) in row.iter_mut().zip(&a[c * len..(c + 1) * len]) {
                    *b += v * a;
                }
            }
        }
        for c in 7..cols {
            row[o + c - 7] += local[r][c];
        }
    }
    for r in 0..cols {
        let row = &b[r * len..(r + 1) * len];
        if r < 7 {
            for i in 0..len {
                let v = a[r * len + i];
                if v != 0.0 {
                    for (h, b) in h[i * len..(i + 1) * len].iter_mut().zip(row) {
                        *h += v * b;
                    }
                }
            }
        } else {
            let i = o + r - 7;
            for (h, b) in h[i * len..(i + 1) * len].iter_mut().zip(row) {
                *h += b;
            }
        }
    }
}

/// κ_i = ∂Λ/∂K_i of every stage of every step (module docs), in the
/// steps' order.
fn stage_multipliers(
    model: &Model,
    layout: &Layout,
    y0: [f64; 7],
    p: &[f64],
    lambda_f: [f64; 7],
) -> Vec<[[f64; 7]; 4]> {
    // Forward: the state at the start of every step.
    let mut starts: Vec<(usize, f64, [f64; 7])> = Vec::new();
    let mut y = y0;
    for (j, seg) in layout.segments.iter().enumerate() {
        let controls = SegmentControls::new(layout, p, j);
        let hs = 1.0 / seg.steps as f64;
        for step in 0..seg.steps {
            let s = step as f64 * hs;
            starts.push((j, s, y));
            shooting::rk4_step(
                model,
                &mut y,
                controls.d,
                &controls.delta,
                &controls.thrust,
                s,
                hs,
            );
        }
    }
    let mut kappa = vec![[[0.0; 7]; 4]; starts.len()];
    let mut lambda = lambda_f;
    for (k, &(j, s, y)) in starts.iter().enumerate().rev() {
        let controls = SegmentControls::new(layout, p, j);
        let hs = 1.0 / layout.segments[j].steps as f64;
        let g = stage_jacobians(model, &controls, &y, s, hs);
        let tr = |g: &[[f64; 7]; 7], v: &[f64; 7]| -> [f64; 7] {
            std::array::from_fn(|c| (0..7).map(|r| g[r][c] * v[r]).sum())
        };
        let mut kap = [[0.0; 7]; 4];
        kap[3] = lambda.map(|l| l * hs / 6.0);
        let g4 = tr(&g[3], &kap[3]);
        kap[2] = std::array::from_fn(|i| lambda[i] * hs / 3.0 + hs * g4[i]);
        let g3 = tr(&g[2], &kap[2]);
        kap[1] = std::array::from_fn(|i| lambda[i] * hs / 3.0 + 0.5 * hs * g3[i]);
        let g2 = tr(&g[1], &kap[1]);
        kap[0] = std::array::from_fn(|i| lambda[i] * hs / 6.0 + 0.5 * hs * g2[i]);
        let g1 = tr(&g[0], &kap[0]);
        for i in 0..7 {
            lambda[i] += g1[i] + g2[i] + g3[i] + g4[i];
        }
        kappa[k] = kap;
    }
    kappa
}

/// G_i = d·∂f/∂y at the four stages of the RK4 step from y at s.
fn stage_jacobians(
    model: &Model,
    controls: &SegmentControls,
    y: &[f64; 7],
    s: f64,
    hs: f64,
) -> [[[f64; 7]; 7]; 4] {
    let d = controls.d;
    let mut out = [[[0.0; 7]; 7]; 4];
    let mut k = [0.0; 7];
    for (i, (c, ds)) in [(0.0, 0.0), (0.5, 0.5), (0.5, 0.5), (1.0, 1.0)]
        .into_iter()
        .enumerate()
    {
        let yi: [f64; 7] = std::array::from_fn(|r| y[r] + c * hs * k[r]);
        let (t, delta) = controls.at(s + ds * hs);
        let (f, jac) = rhs_physical_jacobian(model, &yi, t, delta);
        k = f.map(|v| v * d);
        for r in 0..7 {
            for col in 0..7 {
                out[i][r][col] = d * jac[r][col];
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;
    use crate::polish::shooting::{fixture, sensitivity};

    /// [`convexified`] keeps a positive definite matrix and its
    /// eigenvectors, flips a negative eigenvalue, and raises a zero one to
    /// the floor.
    #[test]
    fn convexified_flips_the_negative_curvature() {
        // Eigenvalues 3 and −1 on (1, 1)/√2 and (1, −1)/√2.
        let h = [1.0, 2.0, 2.0, 1.0];
        let c = convexified(&h, 1e-8).unwrap();
        // 3 and +1 on the same vectors: [[2, 1], [1, 2]].
        for (a, b) in c.iter().zip([2.0, 1.0, 1.0, 2.0]) {
            assert!((a - b).abs() < 1e-12, "{c:?}");
        }
        let pd = [4.0, 1.0, 1.0, 3.0];
        for (a, b) in convexified(&pd, 1e-8).unwrap().iter().zip(pd) {
            assert!((a - b).abs() < 1e-12);
        }
        let zero = convexified(&[0.0; 4], 0.5).unwrap();
        assert!((zero[0] - 0.5).abs() < 1e-15 && zero[1].abs() < 1e-15);
    }

    /// [`clipped`] raises a negative eigenvalue to the floor on the same
    /// eigenvector and keeps a positive one.
    #[test]
    fn clipped_raises_the_negative_curvature_to_the_floor() {
        // Eigenvalues 3 and −1 on (1, 1)/√2 and (1, −1)/√2.
        let c = clipped(&[1.0, 2.0, 2.0, 1.0], 0.5).unwrap();
        // 3 and 0.5 on the same vectors: [[1.75, 1.25], [1.25, 1.75]].
        for (a, b) in c.iter().zip([1.75, 1.25, 1.25, 1.75]) {
            assert!((a - b).abs() < 1e-12, "{c:?}");
        }
    }

    /// ∇Λ(p) = λ_fᵀ·∂y(t_f)/∂p from the forward sensitivities.
    fn gradient(model: &Model, layout: &Layout, y0: [f64; 7], p: &[f64], l: &[f64; 7]) -> Vec<f64> {
        let sens = sensitivity(model, layout, y0, p);
        (0..layout.len)
            .map(|c| (0..7).map(|i| l[i] * sens.d(i, c)).sum())
            .collect()
    }

    /// The Hessian matches central finite differences of the exact
    /// gradient, column by column, on a layout with bound and free thrust.
    #[test]
    fn the_hessian_matches_finite_differences_of_the_gradient() {
        let s = Scenario::paper();
        let model = Model::new(&s.vehicle, &s.environment);
        let (layout, p, t) = fixture::varied(&model);
        let y0 = fixture::Y0;
        let l = [0.3, -0.2, 0.1, 0.5, 20.0, -3.0, -1e-3];
        let h = hessian(&model, &layout, y0, &p, l);
        let n = layout.len;
        // Compare in scaled parameters, so that every entry is of one size:
        // 0.1 for durations and δ, 1e5 N for T.
        let size: Vec<f64> = (0..n)
            .map(|c| if (t..t + NC).contains(&c) { 1e5 } else { 0.1 })
            .collect();
        let mut largest = 0.0f64;
        let mut worst = 0.0f64;
        for c in 0..n {
            let e = 1e-5 * size[c];
            let (mut a, mut b) = (p.clone(), p.clone());
            a[c] += e;
            b[c] -= e;
            let ga = gradient(&model, &layout, y0, &a, &l);
            let gb = gradient(&model, &layout, y0, &b, &l);
            for r in 0..n {
                let fd = (ga[r] - gb[r]) / (2.0 * e) * size[r] * size[c];
                let exact = h[r * n + c] * size[r] * size[c];
                largest = largest.max(exact.abs());
                worst = worst.max((fd - exact).abs());
            }
        }
        assert!(largest > 0.1, "a Hessian of size {largest}");
        assert!(
            worst <= 1e-6 * largest,
            "finite differences differ by {worst:e}, the Hessian's largest entry {largest:e}"
        );
    }
}
