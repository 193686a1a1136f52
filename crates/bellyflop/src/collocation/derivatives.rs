//! The dynamics' derivatives at one collocation point, in a transcription's
//! scaled units, for any model behind the seam ([`Dynamics`]): the rates
//! F = f/scale, their Jacobian ∂F/∂ŵ over the point's local slots, and the
//! weighted Hessian Σ_c λ_c ∇²F_c that a Newton method's Lagrangian needs.
//!
//! The local slots are (x, u) in the model's layout, then any slots of the
//! transcription's own (the direct method's thrust slacks), which this
//! leaves at zero. Only the model's nonlinear inputs ([`Dynamics::NONLINEAR`],
//! NA of them) are carried by second-order dual numbers over NA directions;
//! the columns of the linear ones (ẋ = V, θ̇ = w, δ̇ = χ) are constant and
//! found once by [`linear_columns`].
//!
//! With value = offset + scale·ŵ per slot, ∂F_c/∂ŵ_s = (∂f_c/∂v_s)·scale_s
//! / scale_c and ∂²F_c/∂ŵ_s∂ŵ_r = (∂²f_c/∂v_s∂v_r)·scale_s·scale_r/scale_c.

#![allow(clippy::needless_range_loop)] // Dense block algebra indexes several arrays by one index.

use num_dual::{Dual2SVec64, Dual64};

use crate::problem::model::Dynamics;

/// F, ∂F/∂ŵ and Σ_c λ_c ∇²F_c at one point, scaled (NS states, NL local
/// slots).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointDerivatives<const NS: usize, const NL: usize> {
    /// F_c = f_c/scale_c (scaled state rates per unit time).
    pub f: [f64; NS],
    /// ∂F_c/∂ŵ_s over the local slots.
    pub jac: [[f64; NL]; NS],
    /// Σ_c λ_c ∇²F_c over the local slots (symmetric to the last bit).
    pub hess: [[f64; NL]; NL],
}

impl<const NS: usize, const NL: usize> Default for PointDerivatives<NS, NL> {
    fn default() -> Self {
        PointDerivatives {
            f: [0.0; NS],
            jac: [[0.0; NL]; NS],
            hess: [[0.0; NL]; NL],
        }
    }
}

/// The nonzero entries (row c, input s, ∂f_c/∂v_s) of f's Jacobian in the
/// inputs outside [`Dynamics::NONLINEAR`], where f is affine, by one dual
/// pass per such input at `p` (any point where f is defined: they are
/// constant), into
/// `entries` (cleared; it allocates only to grow, so that a re-plan's
/// refresh allocates nothing).
pub fn linear_columns<M: Dynamics, const NL: usize>(
    model: &M,
    p: &[f64; NL],
    entries: &mut Vec<(usize, usize, f64)>,
) {
    let (nx, nu) = (M::NX, M::NU);
    let mut out = [Dual64::from_re(0.0); NL];
    entries.clear();
    for s in (0..nx + nu).filter(|s| !M::NONLINEAR.contains(s)) {
        let v: [Dual64; NL] =
            std::array::from_fn(|i| Dual64::new(p[i], if i == s { 1.0 } else { 0.0 }));
        model.rhs(&v[..nx], &v[nx..nx + nu], &mut out[..nx]);
        entries.extend(
            out[..nx]
                .iter()
                .enumerate()
                .filter(|(_, o)| o.eps != 0.0)
                .map(|(c, o)| (c, s, o.eps)),
        );
    }
}

/// F, ∂F/∂ŵ and Σ_c λ_c ∇²F_c at the physical point `p` (its first NX + NU
/// slots are (x, u)), for the row weights `lambda` (NS of them, in the
/// scaled rows' units) and the slots' scales; `linear` from
/// [`linear_columns`]. NA is the number of the model's nonlinear inputs.
pub fn point_derivatives<M: Dynamics, const NS: usize, const NL: usize, const NA: usize>(
    model: &M,
    p: &[f64; NL],
    scale: &[f64; NL],
    lambda: &[f64],
    linear: &[(usize, usize, f64)],
) -> PointDerivatives<NS, NL> {
    const {
        assert!(NS == M::NX && NA == M::NONLINEAR.len() && NL >= M::NX + M::NU);
    }
    let active = M::NONLINEAR;
    let v: [Dual2SVec64<NA>; NL] =
        std::array::from_fn(|s| match active.iter().position(|&a| a == s) {
            Some(a) => Dual2SVec64::from_re(p[s]).derivative(a),
            None => Dual2SVec64::from_re(p[s]),
        });
    let mut f = [Dual2SVec64::<NA>::from_re(0.0); NS];
    model.rhs(&v[..NS], &v[NS..NS + M::NU], &mut f);
    let mut out = PointDerivatives::<NS, NL>::default();
    for (c, fc) in f.iter().enumerate() {
        let inv = 1.0 / scale[c];
        out.f[c] = fc.re * inv;
        if let Some(g) = &fc.v1.0 {
            for (a, &s) in active.iter().enumerate() {
                out.jac[c][s] = g[a] * scale[s] * inv;
            }
        }
        if let Some(h) = &fc.v2.0 {
            let wc = lambda[c] * inv;
            for (a, &s) in active.iter().enumerate() {
                for (b, &r) in active.iter().enumerate().take(a + 1) {
                    // Symmetric to the last bit: the KKT blocks rely on it.
                    let v = wc * 0.5 * (h[(a, b)] + h[(b, a)]) * scale[s] * scale[r];
                    out.hess[s][r] += v;
                    if r != s {
                        out.hess[r][s] += v;
                    }
                }
            }
        }
    }
    for &(c, s, d) in linear {
        out.jac[c][s] = d * scale[s] / scale[c];
    }
    out
}

/// One path row g ≤ 0 of a model at one point, scaled: ĝ (the model's rows
/// are of order one already), ∂ĝ/∂ŵ over the local slots, and the nonzero
/// entries (r, s, ∂²ĝ/∂ŵ_r∂ŵ_s) of its Hessian, both triangles.
#[derive(Debug, Clone, PartialEq)]
pub struct RowDerivatives<const NL: usize> {
    pub value: f64,
    pub grad: [f64; NL],
    pub hess: Vec<(usize, usize, f64)>,
}

impl<const NL: usize> Default for RowDerivatives<NL> {
    fn default() -> Self {
        RowDerivatives {
            value: 0.0,
            grad: [0.0; NL],
            hess: Vec::new(),
        }
    }
}

/// The most path rows a model may have.
pub const MAX_PATH_ROWS: usize = 8;

/// The model's path rows ([`Dynamics::path_rows`]) and their scaled
/// derivatives at the physical point `p`, over second-order duals in the
/// union of the rows' inputs (NP of them), into `out` (PATH_ROWS entries;
/// each Hessian list is refilled in place).
pub fn path_row_derivatives<M: Dynamics, const NL: usize, const NP: usize>(
    model: &M,
    p: &[f64; NL],
    scale: &[f64; NL],
    out: &mut [RowDerivatives<NL>],
) {
    let mut inputs = [0usize; NP];
    let mut count = 0;
    for &s in M::PATH_ROW_INPUTS.iter().flat_map(|r| r.iter()) {
        if !inputs[..count].contains(&s) {
            inputs[count] = s;
            count += 1;
        }
    }
    assert_eq!(count, NP, "NP is the number of the path rows' inputs");
    let v: [Dual2SVec64<NP>; NL] =
        std::array::from_fn(|s| match inputs.iter().position(|&a| a == s) {
            Some(a) => Dual2SVec64::from_re(p[s]).derivative(a),
            None => Dual2SVec64::from_re(p[s]),
        });
    let (nx, nu) = (M::NX, M::NU);
    // On the stack, so that an iteration allocates nothing.
    let mut g = [Dual2SVec64::<NP>::from_re(0.0); MAX_PATH_ROWS];
    let g = &mut g[..M::PATH_ROWS];
    model.path_rows(&v[..nx], &v[nx..nx + nu], g);
    for (row, gr) in out.iter_mut().zip(g.iter()) {
        row.value = gr.re;
        row.grad = [0.0; NL];
        row.hess.clear();
        if let Some(d) = &gr.v1.0 {
            for (a, &s) in inputs.iter().enumerate() {
                row.grad[s] = d[a] * scale[s];
            }
        }
        if let Some(h) = &gr.v2.0 {
            for (a, &s) in inputs.iter().enumerate() {
                for (b, &r) in inputs.iter().enumerate() {
                    let v = 0.5 * (h[(a, b)] + h[(b, a)]) * scale[s] * scale[r];
                    if v != 0.0 {
                        row.hess.push((s, r, v));
                    }
                }
            }
        }
    }
}

/// A model whose transcription the direct method differentiates: the
/// generic helpers above at the model's own counts of nonlinear inputs and
/// path-row inputs (stable Rust cannot size the dual numbers from an
/// associated constant, so each model names them once here).
pub trait Differentiable: Dynamics {
    /// [`point_derivatives`] at the model's count of nonlinear inputs, into
    /// `out` (overwritten: at the 6-DoF sizes it is 6 kB, which a return
    /// by value copied twice per point).
    fn point_derivatives<const NS: usize, const NL: usize>(
        &self,
        p: &[f64; NL],
        scale: &[f64; NL],
        lambda: &[f64],
        linear: &[(usize, usize, f64)],
        out: &mut PointDerivatives<NS, NL>,
    );

    /// [`path_row_derivatives`] at the model's count of path-row inputs.
    fn path_row_derivatives<const NL: usize>(
        &self,
        p: &[f64; NL],
        scale: &[f64; NL],
        out: &mut [RowDerivatives<NL>],
    );
}

impl Differentiable for crate::problem::dynamics::Model {
    fn point_derivatives<const NS: usize, const NL: usize>(
        &self,
        p: &[f64; NL],
        scale: &[f64; NL],
        lambda: &[f64],
        linear: &[(usize, usize, f64)],
        out: &mut PointDerivatives<NS, NL>,
    ) {
        *out = point_derivatives::<Self, NS, NL, 6>(self, p, scale, lambda, linear);
    }

    /// No path rows in the plane (the gimbal's bounds are boxes).
    fn path_row_derivatives<const NL: usize>(
        &self,
        _: &[f64; NL],
        _: &[f64; NL],
        _: &mut [RowDerivatives<NL>],
    ) {
    }
}

/// Adds one term of f to `out`: a function of K of the point's inputs
/// (`inputs`, slots of p) into the state rows `rows`, over second-order
/// duals in those K directions only. A model whose f is a sum of such terms
/// (the 6-DoF model) is differentiated term by term at a cost of about
/// Σ K² per operation instead of NA² over the whole of f.
#[allow(clippy::too_many_arguments)] // The point, its scaling and the term.
pub fn add_term<const NS: usize, const NL: usize, const K: usize, const R: usize>(
    p: &[f64; NL],
    scale: &[f64; NL],
    lambda: &[f64],
    inputs: [usize; K],
    rows: [usize; R],
    term: impl Fn([Dual2SVec64<K>; K]) -> [Dual2SVec64<K>; R],
    out: &mut PointDerivatives<NS, NL>,
) {
    let v: [Dual2SVec64<K>; K] =
        std::array::from_fn(|a| Dual2SVec64::from_re(p[inputs[a]]).derivative(a));
    add_values(scale, lambda, inputs, rows, &term(v), out);
}

/// Adds a term's values, as second-order duals over the K slots `inputs`,
/// into the state rows `rows` of `out` (scaled: module docs).
pub fn add_values<const NS: usize, const NL: usize, const K: usize>(
    scale: &[f64; NL],
    lambda: &[f64],
    inputs: [usize; K],
    rows: impl IntoIterator<Item = usize>,
    values: &[Dual2SVec64<K>],
    out: &mut PointDerivatives<NS, NL>,
) {
    for (fc, c) in values.iter().zip(rows) {
        let inv = 1.0 / scale[c];
        out.f[c] += fc.re * inv;
        if let Some(g) = &fc.v1.0 {
            for (a, &s) in inputs.iter().enumerate() {
                out.jac[c][s] += g[a] * scale[s] * inv;
            }
        }
        if let Some(h) = &fc.v2.0 {
            let wc = lambda[c] * inv;
            for (a, &s) in inputs.iter().enumerate() {
                for (b, &r) in inputs.iter().enumerate().take(a + 1) {
                    let v = wc * 0.5 * (h[(a, b)] + h[(b, a)]) * scale[s] * scale[r];
                    out.hess[s][r] += v;
                    if r != s {
                        out.hess[r][s] += v;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;
    use crate::problem::dynamics::{self, Model};
    use crate::problem::six_dof::{self, sx, SixDof};

    const NX6: usize = six_dof::NX;
    const NL6: usize = six_dof::NX + six_dof::NU;

    fn six_dof() -> SixDof {
        let s = Scenario::paper();
        let mut m = SixDof::new(&s.vehicle, &s.environment);
        m.wind_mps = [4.0, -3.0, 0.0];
        m
    }

    fn point6() -> [f64; NL6] {
        let mut p = [0.0; NL6];
        let y = [-40.0, 300.0, 15.0, -70.0, 0.9, -0.25, 105_000.0, 0.12];
        p[..NX6].copy_from_slice(&six_dof::planar_state(&y));
        p[sx::Y] = 25.0;
        p[sx::VY] = -6.0;
        p[sx::Q + 3] = 0.08;
        p[sx::Q + 1] = -0.05;
        p[sx::W] = 0.03;
        p[sx::W + 2] = 0.02;
        p[sx::DELTA + 1] = -0.07;
        p[NX6] = 5.5e6;
        p[NX6 + 1] = 0.05;
        p[NX6 + 2] = -0.03;
        p
    }

    fn scale6() -> [f64; NL6] {
        let mut s = [1.0; NL6];
        for (i, v) in [
            (sx::X, 100.0),
            (sx::Y, 100.0),
            (sx::Z, 500.0),
            (sx::VX, 50.0),
            (sx::VY, 50.0),
            (sx::VZ, 90.0),
            (sx::M, 1.0e5),
            (sx::W, 0.5),
            (NX6, 6.0e6),
        ] {
            s[i] = v;
        }
        s
    }

    /// F(ŵ) of the 6-DoF model at the scaled point ŵ = p/scale.
    fn scaled_rates(m: &SixDof, w: &[f64; NL6], scale: &[f64; NL6]) -> [f64; NX6] {
        let p: [f64; NL6] = std::array::from_fn(|s| w[s] * scale[s]);
        let mut f = [0.0; NX6];
        m.rhs(&p[..NX6], &p[NX6..], &mut f);
        std::array::from_fn(|c| f[c] / scale[c])
    }

    /// The 6-DoF model's scaled Jacobian, and its weighted Hessian, against
    /// central differences of F and of λᵀ∂F: the generic path is exact for a
    /// model that it was not first written for.
    #[test]
    fn six_dof_point_derivatives_match_differences() {
        let m = six_dof();
        let (p, scale) = (point6(), scale6());
        let lambda: [f64; NX6] =
            std::array::from_fn(|c| 0.3 + 0.1 * c as f64 - 0.07 * (c % 3) as f64);
        let mut linear = Vec::new();
        linear_columns(&m, &p, &mut linear);
        let d = point_derivatives::<SixDof, NX6, NL6, 14>(&m, &p, &scale, &lambda, &linear);
        let w: [f64; NL6] = std::array::from_fn(|s| p[s] / scale[s]);
        let f0 = scaled_rates(&m, &w, &scale);
        for c in 0..NX6 {
            assert!((d.f[c] - f0[c]).abs() <= 1e-13 * (1.0 + f0[c].abs()));
        }
        let h = 1e-6;
        let grad = |w: &[f64; NL6]| -> [f64; NL6] {
            // λᵀ∂F/∂ŵ by the generic path's Jacobian at w.
            let p: [f64; NL6] = std::array::from_fn(|s| w[s] * scale[s]);
            let d = point_derivatives::<SixDof, NX6, NL6, 14>(&m, &p, &scale, &lambda, &linear);
            std::array::from_fn(|s| (0..NX6).map(|c| lambda[c] * d.jac[c][s]).sum())
        };
        for s in 0..NL6 {
            let (mut up, mut dn) = (w, w);
            up[s] += h;
            dn[s] -= h;
            let (fu, fd) = (scaled_rates(&m, &up, &scale), scaled_rates(&m, &dn, &scale));
            for c in 0..NX6 {
                let fdv = (fu[c] - fd[c]) / (2.0 * h);
                let tol = 1e-6 * (1.0 + d.jac[c][s].abs());
                assert!(
                    (fdv - d.jac[c][s]).abs() < tol,
                    "∂F{c}/∂ŵ{s}: {} against {fdv}",
                    d.jac[c][s]
                );
            }
            let (gu, gd) = (grad(&up), grad(&dn));
            for r in 0..NL6 {
                let fdv = (gu[r] - gd[r]) / (2.0 * h);
                let tol = 1e-5 * (1.0 + d.hess[s][r].abs());
                assert!(
                    (fdv - d.hess[s][r]).abs() < tol,
                    "H[{s}][{r}]: {} against {fdv}",
                    d.hess[s][r]
                );
                assert_eq!(d.hess[s][r], d.hess[r][s]);
            }
        }
    }

    /// The 6-DoF model's term-by-term derivatives (its `Differentiable`)
    /// are the whole-f path's, to rounding, at points off the plane.
    #[test]
    fn six_dof_terms_give_the_whole_derivatives() {
        let m = six_dof();
        let scale = scale6();
        let mut linear = Vec::new();
        linear_columns(&m, &point6(), &mut linear);
        for k in 0..5 {
            let mut p = point6();
            for (s, v) in p.iter_mut().enumerate() {
                *v *= 1.0 + 0.05 * ((k * NL6 + s) as f64 * 0.77).sin();
            }
            let lambda: [f64; NX6] = std::array::from_fn(|c| ((k + c) as f64 * 1.3).cos());
            let whole = point_derivatives::<SixDof, NX6, NL6, 14>(&m, &p, &scale, &lambda, &linear);
            let mut split = PointDerivatives::default();
            Differentiable::point_derivatives::<NX6, NL6>(&m, &p, &scale, &lambda, &[], &mut split);
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * (1.0 + a.abs().max(b.abs()));
            for c in 0..NX6 {
                assert!(
                    close(whole.f[c], split.f[c]),
                    "f{c}: {} {}",
                    whole.f[c],
                    split.f[c]
                );
                for s in 0..NL6 {
                    let (a, b) = (whole.jac[c][s], split.jac[c][s]);
                    assert!(close(a, b), "J[{c}][{s}]: {a} {b}");
                }
            }
            for r in 0..NL6 {
                for s in 0..NL6 {
                    let (a, b) = (whole.hess[r][s], split.hess[r][s]);
                    assert!(close(a, b), "H[{r}][{s}]: {a} {b}");
                    assert_eq!(split.hess[r][s], split.hess[s][r]);
                }
            }
        }
    }

    /// The linear columns of both models are the ones their equations say:
    /// ẋ = V and θ̇ = w (ω's quaternion map is bilinear, so nonlinear in
    /// 3-D), δ̇ = χ.
    #[test]
    fn linear_columns_are_the_kinematic_ones() {
        let s = Scenario::paper();
        let planar = Model::new(&s.vehicle, &s.environment);
        let p = [0.0, 100.0, 1.0, -10.0, 0.3, 0.1, 1e5, 0.05, 5e6, 0.01];
        let mut l = Vec::new();
        linear_columns(&planar, &p, &mut l);
        l.sort_by_key(|&(c, s, _)| (c, s));
        use dynamics::ix;
        assert_eq!(l, vec![(ix::THETA, ix::W, 1.0), (ix::DELTA, 9, 1.0)]);
        let mut l6 = Vec::new();
        linear_columns(&six_dof(), &point6(), &mut l6);
        l6.sort_by_key(|&(c, s, _)| (c, s));
        assert_eq!(
            l6,
            vec![(sx::DELTA, NX6 + 1, 1.0), (sx::DELTA + 1, NX6 + 2, 1.0)]
        );
    }
}
