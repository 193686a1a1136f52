//! f's Jacobian ∂f/∂(s, u) in closed form, term by term (the module
//! equations of [`super`]), for the 6-DoF polish's variational equations,
//! which need it at every RK4 stage.
//!
//! One forward-mode pass of 19-direction dual numbers through the whole
//! right-hand side did it before: 7 µs a call, 38 % of a polish (`perf` on
//! 8 seeded states, half of it in `memmove` of the 0.2 kB numbers). Here
//! the three nonlinear factors are differentiated apart, each over its own
//! few inputs by scalar dual numbers (R over q, 4 passes; d over δ, 2; the
//! drag D over V, 3), and the products are assembled by hand:
//!
//! - V̇ = (T/m)·R·d + D/m − g·ẑ;
//! - ω̇ = (c_T·T·(d₁, −d₀, 0) + c_D·(−b₁, b₀, 0))/m + e·(ω₁ω₂, −ω₀ω₂, 0),
//!   b = Rᵀ·D, c_T = l_cg/k_t, c_D = (l_cp − l_cg)/k_t, e = (k_t − k_r)/k_t
//!   (J = m·diag(k_t, k_t, k_r): the gyroscopic term has no m);
//! - q̇ = ½·Σ_jk C_ijk·q_j·ω_k + κ·(1 − |q|²)·q_i ([`QUATERNION_PRODUCT`]);
//! - ṙ = V, ṁ = α·T, δ̇ = χ, linear.
//!
//! f itself is [`super::rhs`]'s, so that a shot's states do not depend on
//! which derivatives it also carries. The tests check the Jacobian against
//! the whole-f dual pass to 1e-12 and against central differences.

#![allow(clippy::needless_range_loop)] // Dense block algebra indexes several arrays by one index.

use num_dual::Dual64;

use super::{drag_force, rhs, rotation, su, sx, thrust_direction, SixDof, NU, NX};

/// q ⊗ (0, ω) = Σ_jk C_ijk·q_j·ω_k, as (i, j, k, C_ijk): the quaternion
/// product of [`super::quaternion_rate`], written out.
pub const QUATERNION_PRODUCT: [(usize, usize, usize, f64); 12] = [
    (0, 1, 0, -1.0),
    (0, 2, 1, -1.0),
    (0, 3, 2, -1.0),
    (1, 0, 0, 1.0),
    (1, 2, 2, 1.0),
    (1, 3, 1, -1.0),
    (2, 0, 1, 1.0),
    (2, 3, 0, 1.0),
    (2, 1, 2, -1.0),
    (3, 0, 2, 1.0),
    (3, 1, 1, 1.0),
    (3, 2, 0, -1.0),
];

/// The values of `g` at `x` and its derivatives along each of x's K axes,
/// by K passes of scalar dual numbers: (g(x), ∂g/∂x_a for each a).
fn partials<const K: usize, const R: usize>(
    x: [f64; K],
    g: impl Fn([Dual64; K]) -> [Dual64; R],
) -> ([f64; R], [[f64; R]; K]) {
    let mut value = [0.0; R];
    let d = std::array::from_fn(|a| {
        let out = g(std::array::from_fn(|b| {
            Dual64::new(x[b], if a == b { 1.0 } else { 0.0 })
        }));
        value = out.map(|o| o.re);
        out.map(|o| o.eps)
    });
    (value, d)
}

/// [`rhs`] and its Jacobian against (state, control), row-major by state
/// row (module docs).
pub fn jacobian(model: &SixDof, s: &[f64; NX], u: &[f64; NU]) -> ([f64; NX], [[f64; NX + NU]; NX]) {
    let f = rhs(model, s, u);
    let p = &model.planar;
    let mut jac = [[0.0; NX + NU]; NX];
    let (col_t, col_chi) = (NX + su::T, NX + su::CHI);
    // ṙ = V, δ̇ = χ, ṁ = α·T.
    for i in 0..3 {
        jac[sx::X + i][sx::VX + i] = 1.0;
    }
    for j in 0..2 {
        jac[sx::DELTA + j][col_chi + j] = 1.0;
    }
    jac[sx::M][col_t] = p.alpha_spm;
    // The factors and their partials: R(q) as 9 entries, d(δ), D(V).
    let q: [f64; 4] = std::array::from_fn(|a| s[sx::Q + a]);
    let (r, dr) = partials(q, |q| {
        let r = rotation(q);
        std::array::from_fn(|e| r[e / 3][e % 3])
    });
    let (d, dd) = partials([s[sx::DELTA], s[sx::DELTA + 1]], |x| {
        thrust_direction(x[0], x[1])
    });
    let v = [s[sx::VX], s[sx::VY], s[sx::VZ]];
    let (drag, ddrag) = partials(v, |v| drag_force(model, v));
    let (m, thrust) = (s[sx::M], u[su::T]);
    let inv_m = 1.0 / m;
    let at = |r: &[f64; 9], i: usize, k: usize| r[3 * i + k];
    // V̇ = (T/m)·R·d + D/m − g·ẑ.
    for i in 0..3 {
        let rd: f64 = (0..3).map(|k| at(&r, i, k) * d[k]).sum();
        let row = &mut jac[sx::VX + i];
        for a in 0..4 {
            row[sx::Q + a] = thrust * inv_m * (0..3).map(|k| at(&dr[a], i, k) * d[k]).sum::<f64>();
        }
        for c in 0..2 {
            row[sx::DELTA + c] =
                thrust * inv_m * (0..3).map(|k| at(&r, i, k) * dd[c][k]).sum::<f64>();
        }
        for c in 0..3 {
            row[sx::VX + c] = ddrag[c][i] * inv_m;
        }
        row[col_t] = rd * inv_m;
        row[sx::M] = -(thrust * rd + drag[i]) * inv_m * inv_m;
    }
    // ω̇'s thrust and drag moments, over the transverse axes 0 and 1: the
    // moment's components (c_T·T·d₁ − c_D·b₁, −c_T·T·d₀ + c_D·b₀)/m.
    let kt = p.inertia_per_mass_m2;
    let (c_t, c_d) = (p.cg_m / kt, (p.cp_m - p.cg_m) / kt);
    let b: [f64; 3] = std::array::from_fn(|i| (0..3).map(|k| at(&r, k, i) * drag[k]).sum());
    for (row, other, sign) in [(0, 1, 1.0), (1, 0, -1.0)] {
        let jr = &mut jac[sx::W + row];
        let moment = sign * (c_t * thrust * d[other] - c_d * b[other]);
        for c in 0..2 {
            jr[sx::DELTA + c] = sign * c_t * thrust * dd[c][other] * inv_m;
        }
        jr[col_t] = sign * c_t * d[other] * inv_m;
        for a in 0..4 {
            let db: f64 = (0..3).map(|k| at(&dr[a], k, other) * drag[k]).sum();
            jr[sx::Q + a] = -sign * c_d * db * inv_m;
        }
        for c in 0..3 {
            let db: f64 = (0..3).map(|k| at(&r, k, other) * ddrag[c][k]).sum();
            jr[sx::VX + c] = -sign * c_d * db * inv_m;
        }
        jr[sx::M] = -moment * inv_m * inv_m;
    }
    // The gyroscopic term e·(ω₁ω₂, −ω₀ω₂, 0).
    let e = (kt - model.roll_inertia_per_mass_m2) / kt;
    let w = [s[sx::W], s[sx::W + 1], s[sx::W + 2]];
    jac[sx::W][sx::W + 1] += e * w[2];
    jac[sx::W][sx::W + 2] += e * w[1];
    jac[sx::W + 1][sx::W] += -e * w[2];
    jac[sx::W + 1][sx::W + 2] += -e * w[0];
    // q̇.
    let kappa = model.norm_gain_per_s;
    let n2: f64 = q.iter().map(|v| v * v).sum();
    for &(i, j, k, c) in &QUATERNION_PRODUCT {
        jac[sx::Q + i][sx::Q + j] += 0.5 * c * w[k];
        jac[sx::Q + i][sx::W + k] += 0.5 * c * q[j];
    }
    for i in 0..4 {
        for j in 0..4 {
            let pull = if i == j { kappa * (1.0 - n2) } else { 0.0 };
            jac[sx::Q + i][sx::Q + j] += pull - 2.0 * kappa * q[i] * q[j];
        }
    }
    (f, jac)
}
