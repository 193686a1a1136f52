//! The 6-DoF model's derivatives at one collocation point ([`Differentiable`]
//! for [`SixDof`]), term by term and by the chain rule on small parts.
//!
//! f is the sum of the terms of [`crate::problem::six_dof`]; each is
//! differentiated over its own inputs only. The two terms that share the
//! rotation R(q), the thrust's acceleration (T/m)·R·d(δ) and the drag's
//! angular acceleration (l/(k_t·m))·A·Rᵀ·D(V), are products of three factors
//! with disjoint inputs: R over q (4), a vector over δ or V, and a scalar over
//! (T, m) or m. Each factor is differentiated once by small dual numbers,
//! and the product's Jacobian and weighted Hessian are assembled from them
//! here (`product_term`): the 8-direction duals that did it before spent
//! most of their time moving 0.6 kB numbers (some 10 % of a solve in
//! `memmove`, measured by `perf` on 30 seeded states). q̇ is bilinear plus a
//! cubic pull, and its derivatives are written out (`quaternion_rate_term`).
//! The test `six_dof_terms_give_the_whole_derivatives` (module
//! `derivatives`) checks all of it against the whole-f dual path, to 1e-12.

#![allow(clippy::needless_range_loop)] // Dense block algebra indexes several arrays by one index.

use num_dual::Dual2SVec64;

use super::derivatives::{
    add_term, path_row_derivatives, Differentiable, PointDerivatives, RowDerivatives,
};
use crate::problem::six_dof::{self as six, su, sx, SixDof, NX};

/// The most inputs of one term.
const MAX_INPUTS: usize = 9;

/// A scalar and its gradient and Hessian over K inputs (a second-order dual
/// number unpacked into plain arrays).
#[derive(Debug, Clone, Copy)]
struct Small<const K: usize> {
    v: f64,
    g: [f64; K],
    h: [[f64; K]; K],
}

impl<const K: usize> Small<K> {
    fn of(d: &Dual2SVec64<K>) -> Self {
        let mut s = Small {
            v: d.re,
            g: [0.0; K],
            h: [[0.0; K]; K],
        };
        if let Some(g) = &d.v1.0 {
            s.g = std::array::from_fn(|a| g[a]);
        }
        if let Some(h) = &d.v2.0 {
            s.h = std::array::from_fn(|a| std::array::from_fn(|b| 0.5 * (h[(a, b)] + h[(b, a)])));
        }
        s
    }

    /// Σ_i c_i·x_i.
    fn combine<const R: usize>(c: [f64; R], x: [&Small<K>; R]) -> Self {
        let mut s = Small {
            v: 0.0,
            g: [0.0; K],
            h: [[0.0; K]; K],
        };
        for (ci, xi) in c.iter().zip(x) {
            s.v += ci * xi.v;
            for a in 0..K {
                s.g[a] += ci * xi.g[a];
                for b in 0..K {
                    s.h[a][b] += ci * xi.h[a][b];
                }
            }
        }
        s
    }
}

/// One term's values f_c (R rows), Jacobian over its local inputs, and
/// weighted Hessian Σ_c μ_c ∇²f_c, in physical units, before scaling.
struct Local<const R: usize> {
    slots: [usize; MAX_INPUTS],
    n: usize,
    f: [f64; R],
    jac: [[f64; MAX_INPUTS]; R],
    hess: [[f64; MAX_INPUTS]; MAX_INPUTS],
}

impl<const R: usize> Local<R> {
    fn new(slots: &[usize]) -> Self {
        let mut s = [0; MAX_INPUTS];
        s[..slots.len()].copy_from_slice(slots);
        Local {
            slots: s,
            n: slots.len(),
            f: [0.0; R],
            jac: [[0.0; MAX_INPUTS]; R],
            hess: [[0.0; MAX_INPUTS]; MAX_INPUTS],
        }
    }

    /// Adds the term into the rows `rows` of `out`, scaled (module docs of
    /// `derivatives`): the Hessian's lower triangle, mirrored, so that it
    /// stays symmetric to the last bit.
    fn add_into<const NS: usize, const NL: usize>(
        &self,
        rows: [usize; R],
        scale: &[f64; NL],
        out: &mut PointDerivatives<NS, NL>,
    ) {
        let slots = &self.slots[..self.n];
        for (i, &c) in rows.iter().enumerate() {
            let inv = 1.0 / scale[c];
            out.f[c] += self.f[i] * inv;
            for (a, &s) in slots.iter().enumerate() {
                out.jac[c][s] += self.jac[i][a] * scale[s] * inv;
            }
        }
        for (a, &s) in slots.iter().enumerate() {
            for (b, &r) in slots.iter().enumerate().take(a + 1) {
                let v = self.hess[a][b] * scale[s] * scale[r];
                out.hess[s][r] += v;
                if r != s {
                    out.hess[r][s] += v;
                }
            }
        }
    }
}

/// The term f_i = s(z)·Σ_k B_ik(q)·g_k(y) (i < 3) over the inputs (q, y, z)
/// of disjoint slots, with the row weights μ: its values, Jacobian and
/// Σ_i μ_i ∇²f_i, by the product rule on the factors' own derivatives.
fn product_term<const K: usize, const Z: usize>(
    b: &[[Small<4>; 3]; 3],
    g: &[Small<K>; 3],
    s: &Small<Z>,
    mu: [f64; 3],
    slots: &[usize],
) -> Local<3> {
    let (oy, oz) = (4, 4 + K);
    let mut t = Local::<3>::new(slots);
    // u_i = Σ_k B_ik·g_k, and its gradient in q and y.
    let mut u = [0.0; 3];
    for i in 0..3 {
        for k in 0..3 {
            u[i] += b[i][k].v * g[k].v;
            for a in 0..4 {
                t.jac[i][a] += b[i][k].g[a] * g[k].v;
            }
            for c in 0..K {
                t.jac[i][oy + c] += b[i][k].v * g[k].g[c];
            }
        }
    }
    // ψ = μᵀu and its gradient, before s scales u's rows.
    let psi: f64 = (0..3).map(|i| mu[i] * u[i]).sum();
    let mut grad_psi = [0.0; MAX_INPUTS];
    for i in 0..3 {
        for a in 0..oz {
            grad_psi[a] += mu[i] * t.jac[i][a];
        }
    }
    for i in 0..3 {
        t.f[i] = s.v * u[i];
        for a in 0..oz {
            t.jac[i][a] *= s.v;
        }
        for c in 0..Z {
            t.jac[i][oz + c] = s.g[c] * u[i];
        }
    }
    // ∇²ψ from w_k = Σ_i μ_i·B_ik: qq Σ_k g_k·∇²w_k, yy Σ_k w_k·∇²g_k,
    // qy Σ_k ∇w_k ⊗ ∇g_k; then ∇²(s·ψ) = s·∇²ψ + ∇s ⊗ ∇ψ + ∇ψ ⊗ ∇s + ψ·∇²s.
    let w: [Small<4>; 3] =
        std::array::from_fn(|k| Small::combine(mu, [&b[0][k], &b[1][k], &b[2][k]]));
    let h = &mut t.hess;
    for k in 0..3 {
        for a in 0..4 {
            for a2 in 0..4 {
                h[a][a2] += g[k].v * w[k].h[a][a2];
            }
            for c in 0..K {
                let v = w[k].g[a] * g[k].g[c];
                h[oy + c][a] += v;
                h[a][oy + c] += v;
            }
        }
        for c in 0..K {
            for c2 in 0..K {
                h[oy + c][oy + c2] += w[k].v * g[k].h[c][c2];
            }
        }
    }
    for a in 0..oz {
        for a2 in 0..oz {
            h[a][a2] *= s.v;
        }
        for c in 0..Z {
            let v = grad_psi[a] * s.g[c];
            h[a][oz + c] = v;
            h[oz + c][a] = v;
        }
    }
    for c in 0..Z {
        for c2 in 0..Z {
            h[oz + c][oz + c2] = psi * s.h[c][c2];
        }
    }
    t
}

/// q̇ = ½·q ⊗ (0, ω) + κ·(1 − |q|²)·q over (q, ω), with the row weights μ:
/// q ⊗ (0, ω) = Σ_jk C_ijk·q_j·ω_k is bilinear, and the pull p_i =
/// κ·(1 − n²)·q_i has ∂p_i/∂q_j = κ·((1 − n²)·δ_ij − 2·q_i·q_j) and
/// Σ_i μ_i·∂²p_i/∂q_j∂q_l = −2κ·(μ_j·q_l + μ_l·q_j + (μ·q)·δ_jl).
fn quaternion_rate_term(
    kappa: f64,
    q: [f64; 4],
    w: [f64; 3],
    mu: [f64; 4],
    slots: &[usize],
) -> Local<4> {
    let mut t = Local::<4>::new(slots);
    let n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    let pull = kappa * (1.0 - n2);
    for &(i, j, k, c) in &six::QUATERNION_PRODUCT {
        t.f[i] += 0.5 * c * q[j] * w[k];
        t.jac[i][j] += 0.5 * c * w[k];
        t.jac[i][4 + k] += 0.5 * c * q[j];
        t.hess[j][4 + k] += 0.5 * c * mu[i];
        t.hess[4 + k][j] += 0.5 * c * mu[i];
    }
    let mu_q: f64 = (0..4).map(|i| mu[i] * q[i]).sum();
    for i in 0..4 {
        t.f[i] += pull * q[i];
        for j in 0..4 {
            t.jac[i][j] += -2.0 * kappa * q[i] * q[j] + if i == j { pull } else { 0.0 };
            t.hess[i][j] +=
                -2.0 * kappa * (mu[i] * q[j] + mu[j] * q[i] + if i == j { mu_q } else { 0.0 });
        }
    }
    t
}

/// The row weights μ_c = λ_c/scale_c of the rows `rows`.
fn weights<const R: usize, const NL: usize>(
    lambda: &[f64],
    scale: &[f64; NL],
    rows: [usize; R],
) -> [f64; R] {
    std::array::from_fn(|i| lambda[rows[i]] / scale[rows[i]])
}

/// Adds a linear term f_c += coef·p_s.
fn add_linear<const NS: usize, const NL: usize>(
    p: &[f64; NL],
    scale: &[f64; NL],
    c: usize,
    s: usize,
    coef: f64,
    out: &mut PointDerivatives<NS, NL>,
) {
    out.f[c] += coef * p[s] / scale[c];
    out.jac[c][s] += coef * scale[s] / scale[c];
}

/// The 6-DoF model, term by term (module docs).
impl Differentiable for SixDof {
    fn point_derivatives<const NS: usize, const NL: usize>(
        &self,
        p: &[f64; NL],
        scale: &[f64; NL],
        lambda: &[f64],
        _linear: &[(usize, usize, f64)],
        out: &mut PointDerivatives<NS, NL>,
    ) {
        const {
            assert!(NS == NX && NL >= NX + six::NU);
        }
        // In place (an array literal is built on the stack and copied).
        out.f.fill(0.0);
        out.jac.as_flattened_mut().fill(0.0);
        out.hess.as_flattened_mut().fill(0.0);
        let (v, q, w, m) = (
            [sx::VX, sx::VY, sx::VZ],
            [sx::Q, sx::Q + 1, sx::Q + 2, sx::Q + 3],
            [sx::W, sx::W + 1, sx::W + 2],
            sx::M,
        );
        let (delta, t, chi) = (
            [sx::DELTA, sx::DELTA + 1],
            NX + su::T,
            [NX + su::CHI, NX + su::CHI + 1],
        );
        // ṙ = V, δ̇ = χ and ṁ = −T/(I_sp·g0): linear.
        for i in 0..3 {
            add_linear(p, scale, sx::X + i, v[i], 1.0, out);
        }
        for i in 0..2 {
            add_linear(p, scale, delta[i], chi[i], 1.0, out);
        }
        add_linear(p, scale, m, t, self.planar.alpha_spm, out);
        // R(q), d(δ) and D(V), each differentiated once over its own inputs.
        let qd: [Dual2SVec64<4>; 4] =
            std::array::from_fn(|a| Dual2SVec64::from_re(p[q[a]]).derivative(a));
        let r4 = six::rotation(qd);
        let r: [[Small<4>; 3]; 3] =
            std::array::from_fn(|i| std::array::from_fn(|j| Small::of(&r4[i][j])));
        let d2: [Dual2SVec64<2>; 2] =
            std::array::from_fn(|a| Dual2SVec64::from_re(p[delta[a]]).derivative(a));
        let dir = six::thrust_direction(d2[0], d2[1]).map(|d| Small::of(&d));
        let v3: [Dual2SVec64<3>; 3] =
            std::array::from_fn(|a| Dual2SVec64::from_re(p[v[a]]).derivative(a));
        let drag = six::drag_force(self, v3).map(|d| Small::of(&d));
        let mass = p[m];
        // V̇ ∋ (T/m)·R·d.
        let s = Small {
            v: p[t] / mass,
            g: [1.0 / mass, -p[t] / (mass * mass)],
            h: [
                [0.0, -1.0 / (mass * mass)],
                [-1.0 / (mass * mass), 2.0 * p[t] / (mass * mass * mass)],
            ],
        };
        let slots = [q[0], q[1], q[2], q[3], delta[0], delta[1], t, m];
        product_term(&r, &dir, &s, weights(lambda, scale, v), &slots).add_into(v, scale, out);
        add_term(
            p,
            scale,
            lambda,
            [v[0], v[1], v[2], m],
            v,
            |x| six::drag_acceleration(self, [x[0], x[1], x[2]], x[3]),
            out,
        );
        out.f[sx::VZ] -= self.planar.g0_mps2 / scale[sx::VZ];
        // ω̇: the thrust's, the drag's and the gyroscopic terms.
        add_term(
            p,
            scale,
            lambda,
            [delta[0], delta[1], t, m],
            w,
            |x| six::thrust_angular_acceleration(self, [x[0], x[1]], x[2], x[3]),
            out,
        );
        // The drag's: (l/(k_t·m))·A·Rᵀ·D with A·x = e_z × x = (−x_y, x_x, 0).
        let zero = Small {
            v: 0.0,
            g: [0.0; 4],
            h: [[0.0; 4]; 4],
        };
        let neg = |x: &Small<4>| Small::combine([-1.0], [x]);
        let a_rt = [
            std::array::from_fn(|k| neg(&r[k][1])),
            std::array::from_fn(|k| r[k][0]),
            [zero; 3],
        ];
        let l = (self.planar.cp_m - self.planar.cg_m) / self.planar.inertia_per_mass_m2;
        let s = Small {
            v: l / mass,
            g: [-l / (mass * mass)],
            h: [[2.0 * l / (mass * mass * mass)]],
        };
        let slots = [q[0], q[1], q[2], q[3], v[0], v[1], v[2], m];
        product_term(&a_rt, &drag, &s, weights(lambda, scale, w), &slots).add_into(w, scale, out);
        add_term(
            p,
            scale,
            lambda,
            [w[0], w[1], w[2], m],
            w,
            |x| six::gyroscopic_angular_acceleration(self, [x[0], x[1], x[2]], x[3]),
            out,
        );
        // q̇.
        let slots = [q[0], q[1], q[2], q[3], w[0], w[1], w[2]];
        quaternion_rate_term(
            self.norm_gain_per_s,
            q.map(|s| p[s]),
            w.map(|s| p[s]),
            weights(lambda, scale, q),
            &slots,
        )
        .add_into(q, scale, out);
    }

    fn path_row_derivatives<const NL: usize>(
        &self,
        p: &[f64; NL],
        scale: &[f64; NL],
        out: &mut [RowDerivatives<NL>],
    ) {
        path_row_derivatives::<Self, NL, 4>(self, p, scale, out)
    }
}
