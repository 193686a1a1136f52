//! Equations of motion and their exact Jacobians.
//!
//! Three forms of the same planar model (paper Section 2–3.1):
//! - [`rhs_physical`]: Eq. (1)–(3), state (x, z, Vx, Vz, θ, w, m), control (T, δ) — problem P1;
//! - [`rhs_augmented`]: Eq. (8), state adds δ, control (T, χ) — problem P2;
//! - [`rhs_lcvx`]: Eq. (21)–(22), state (x, z, Vx, Vz, θ, w, ω = ln m, δ) with the
//!   controls of a [`Formulation`]: (Txm, Tzm, σ, χ) for the paper's P3, or (σ, χ)
//!   for the exact form, where the thrust direction θ + δ stays in the dynamics.
//!
//! All are generic over [`DualNum`], so one code path gives values (f64) and exact
//! forward-mode Jacobians ([`linearize`]).

use num_dual::{DualNum, DualSVec64};

use crate::input::scenario::{Environment, Vehicle};
use crate::input::settings::Formulation;

/// Number of LCvx states: x, z, Vx, Vz, θ, w, ω, δ.
pub const NX: usize = 8;
/// Largest control dimension (the paper's formulation).
pub const NU_MAX: usize = 4;

/// State indices: the one table of the crate's state vectors. The LCvx
/// state is (x, z, Vx, Vz, θ, w, ω, δ); the physical state of the
/// propagation and of the plant, and the states of the direct method's NLP
/// ([`crate::method::direct::nlp::slot`]), are the same slots with m in
/// ω's place.
pub mod ix {
    pub const X: usize = 0;
    pub const Z: usize = 1;
    pub const VX: usize = 2;
    pub const VZ: usize = 3;
    pub const THETA: usize = 4;
    pub const W: usize = 5;
    /// ω = ln m, in the LCvx state.
    pub const OMEGA: usize = 6;
    /// The mass m \[kg\]: the same slot as [`OMEGA`], in the physical state
    /// of the propagation, the plant and the NLP.
    pub const M: usize = 6;
    pub const DELTA: usize = 7;
}

/// Smoothing speed in ‖V‖ = sqrt(Vx² + Vz² + ε²) [m/s]. It keeps the derivative
/// of the drag finite at V = 0; the drag changes by a relative 1e-12 at 1 m/s.
const SPEED_EPS_MPS: f64 = 1e-6;

/// Constants of the model, derived once from the vehicle (SI units, radians).
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    pub g0_mps2: f64,
    /// α = −1/(I_sp·g0) [s/m] (Eq. 16).
    pub alpha_spm: f64,
    pub c_ld_kgpm: f64,
    /// Steady horizontal wind W [m/s]: drag acts on (Vx − W, Vz).
    pub wind_x_mps: f64,
    /// L_T = −12·l_cg/(6r² + l²) [1/m] (Eq. 22).
    pub l_t_pm: f64,
    /// L_D = −12·(l_cp − l_cg)/(6r² + l²) [1/m] (Eq. 22).
    pub l_d_pm: f64,
    /// J/m = (6r² + l²)/12 \[m²\] (Eq. 3).
    pub inertia_per_mass_m2: f64,
    pub cg_m: f64,
    pub cp_m: f64,
    pub min_thrust_n: f64,
    pub max_thrust_n: f64,
    pub max_gimbal_rad: f64,
    pub max_gimbal_rate_radps: f64,
    pub dry_mass_kg: f64,
}

impl Model {
    pub fn new(v: &Vehicle, env: &Environment) -> Self {
        let k = 6.0 * v.radius_m * v.radius_m + v.length_m * v.length_m;
        Model {
            g0_mps2: env.g0_mps2,
            alpha_spm: -1.0 / (v.isp_s * env.g0_mps2),
            c_ld_kgpm: v.drag_coefficient_kgpm,
            wind_x_mps: env.wind_x_mps,
            l_t_pm: -12.0 * v.cg_m / k,
            l_d_pm: -12.0 * (v.cp_m - v.cg_m) / k,
            inertia_per_mass_m2: k / 12.0,
            cg_m: v.cg_m,
            cp_m: v.cp_m,
            min_thrust_n: v.min_thrust_n,
            max_thrust_n: v.max_thrust_n,
            max_gimbal_rad: v.max_gimbal_deg.to_radians(),
            max_gimbal_rate_radps: v.max_gimbal_rate_degps.to_radians(),
            dry_mass_kg: v.dry_mass_kg,
        }
    }

    /// Drag force (Dx, Dz) = −C_LD·‖V_a‖·V_a \[N\] on the air-relative velocity
    /// V_a = (Vx − W, Vz) (Eq. 2; W = 0 in the paper).
    fn drag<D: DualNum<Primitive = f64> + Copy>(&self, vx: D, vz: D) -> (D, D) {
        let vx = vx - self.wind_x_mps;
        let speed = (vx * vx + vz * vz + SPEED_EPS_MPS * SPEED_EPS_MPS).sqrt();
        let k = speed * (-self.c_ld_kgpm);
        (k * vx, k * vz)
    }
}

/// Control dimension of a formulation.
pub fn control_dim(form: Formulation) -> usize {
    match form {
        Formulation::Paper | Formulation::Vector => 4,
        Formulation::Exact => 2,
    }
}

/// Index of σ = T/m in a control vector of the formulation `form`.
pub fn sigma_index(form: Formulation) -> usize {
    match form {
        Formulation::Paper | Formulation::Vector => 2,
        Formulation::Exact => 0,
    }
}

/// Eq. (1)–(3): ẋ for state (x, z, Vx, Vz, θ, w, m) and control (T \[N\], δ \[rad\]).
pub fn rhs_physical<D: DualNum<Primitive = f64> + Copy>(
    model: &Model,
    s: &[D; 7],
    thrust_n: D,
    delta_rad: D,
) -> [D; 7] {
    let [_, _, vx, vz, theta, w, m] = *s;
    let (dx, dz) = model.drag(vx, vz);
    let (sin_phi, cos_phi) = (theta + delta_rad).sin_cos();
    let (sin_th, cos_th) = theta.sin_cos();
    let inertia = m * model.inertia_per_mass_m2;
    let moment_thrust = -(thrust_n * delta_rad.sin()) * model.cg_m;
    let moment_drag = -(dx * cos_th + dz * sin_th) * (model.cp_m - model.cg_m);
    [
        vx,
        vz,
        (-(thrust_n * sin_phi) + dx) / m,
        (thrust_n * cos_phi + dz) / m - model.g0_mps2,
        w,
        (moment_thrust + moment_drag) / inertia,
        thrust_n * model.alpha_spm,
    ]
}

/// [`rhs_physical`] and its Jacobian against (x, z, Vx, Vz, θ, w, m, T, δ),
/// written out: the shooting's sensitivities step it through every RK4
/// stage, where dual numbers of 16 directions cost 3× as much (measured,
/// `polish::shooting`). Checked against num-dual in the tests.
pub fn rhs_physical_jacobian(
    model: &Model,
    s: &[f64; 7],
    thrust_n: f64,
    delta_rad: f64,
) -> ([f64; 7], [[f64; 9]; 7]) {
    let [_, _, vx, vz, theta, w, m] = *s;
    let vax = vx - model.wind_x_mps;
    let speed = (vax * vax + vz * vz + SPEED_EPS_MPS * SPEED_EPS_MPS).sqrt();
    let c = model.c_ld_kgpm;
    let (dx, dz) = (-c * speed * vax, -c * speed * vz);
    // ∂(Dx, Dz)/∂(Vx, Vz).
    let cross = -c * vax * vz / speed;
    let (dx_vx, dx_vz) = (-c * (speed + vax * vax / speed), cross);
    let (dz_vx, dz_vz) = (cross, -c * (speed + vz * vz / speed));
    let (sin_phi, cos_phi) = (theta + delta_rad).sin_cos();
    let (sin_th, cos_th) = theta.sin_cos();
    let (sin_d, cos_d) = delta_rad.sin_cos();
    let inertia = m * model.inertia_per_mass_m2;
    let arm = model.cp_m - model.cg_m;
    let moment = -(thrust_n * sin_d) * model.cg_m - (dx * cos_th + dz * sin_th) * arm;
    let f = [
        vx,
        vz,
        (-(thrust_n * sin_phi) + dx) / m,
        (thrust_n * cos_phi + dz) / m - model.g0_mps2,
        w,
        moment / inertia,
        thrust_n * model.alpha_spm,
    ];
    let mut jac = [[0.0; 9]; 7];
    jac[0][2] = 1.0;
    jac[1][3] = 1.0;
    jac[2] = [
        0.0,
        0.0,
        dx_vx / m,
        dx_vz / m,
        -thrust_n * cos_phi / m,
        0.0,
        -f[2] / m,
        -sin_phi / m,
        -thrust_n * cos_phi / m,
    ];
    jac[3] = [
        0.0,
        0.0,
        dz_vx / m,
        dz_vz / m,
        -thrust_n * sin_phi / m,
        0.0,
        -(f[3] + model.g0_mps2) / m,
        cos_phi / m,
        -thrust_n * sin_phi / m,
    ];
    jac[4][5] = 1.0;
    jac[5] = [
        0.0,
        0.0,
        -(dx_vx * cos_th + dz_vx * sin_th) * arm / inertia,
        -(dx_vz * cos_th + dz_vz * sin_th) * arm / inertia,
        -(-dx * sin_th + dz * cos_th) * arm / inertia,
        0.0,
        -f[5] / m,
        -sin_d * model.cg_m / inertia,
        -thrust_n * cos_d * model.cg_m / inertia,
    ];
    jac[6][7] = model.alpha_spm;
    (f, jac)
}

/// The gradient and Hessian of φ = κᵀ·f(y, T, δ) ([`rhs_physical`]) in
/// the seven variables on which f depends, (Vx, Vz, θ, w, m, T, δ), for a
/// weight κ on its seven rows (a costate, or an RK4 stage's multiplier:
/// `polish::hessian`), written out. With u = Vx − W_x, v = Vz, S = √(u² +
/// v² + ε²), D = (−c·S·u, −c·S·v), φ = κ₀·Vx + κ₁·Vz + κ₄·w + κ₆·α·T + Q/m
/// where
///
///   Q = κ₂·(−T·sin(θ+δ) + D_x) + κ₃·(T·cos(θ+δ) + D_z)
///       + (κ₅/k)·(−T·sin δ·l_cg − (D_x·cos θ + D_z·sin θ)·(l_cp − l_cg)),
///
/// k the inertia per mass, so that ∂²φ/∂a∂b = Q_ab/m, ∂²φ/∂a∂m = −Q_a/m²
/// and ∂²φ/∂m² = 2Q/m³. Checked against num-dual's second-order dual
/// numbers in the tests.
pub fn weighted_rhs_hessian(
    model: &Model,
    s: &[f64; 7],
    thrust_n: f64,
    delta_rad: f64,
    kappa: &[f64; 7],
) -> ([f64; 7], [[f64; 7]; 7]) {
    let [_, _, vx, vz, theta, _, m] = *s;
    let t = thrust_n;
    let (u, v) = (vx - model.wind_x_mps, vz);
    let speed = (u * u + v * v + SPEED_EPS_MPS * SPEED_EPS_MPS).sqrt();
    let c = model.c_ld_kgpm;
    let (dx, dz) = (-c * speed * u, -c * speed * v);
    let s3 = speed * speed * speed;
    // D_a for a = u (D_x) and a = v (D_z), b the other: first and second
    // derivatives.
    let (dx_u, dx_v) = (-c * (speed + u * u / speed), -c * u * v / speed);
    let (dz_u, dz_v) = (dx_v, -c * (speed + v * v / speed));
    let dx_uu = -c * (3.0 * u / speed - u * u * u / s3);
    let dx_uv = -c * (v / speed - u * u * v / s3);
    let dx_vv = -c * (u / speed - u * v * v / s3);
    let dz_vv = -c * (3.0 * v / speed - v * v * v / s3);
    let dz_uv = -c * (u / speed - v * v * u / s3);
    let dz_uu = -c * (v / speed - v * u * u / s3);
    let (sin_phi, cos_phi) = (theta + delta_rad).sin_cos();
    let (sin_th, cos_th) = theta.sin_cos();
    let (sin_d, cos_d) = delta_rad.sin_cos();
    let arm = model.cp_m - model.cg_m;
    let lcg = model.cg_m;
    let (k2, k3, k5) = (kappa[2], kappa[3], kappa[5] / model.inertia_per_mass_m2);
    let q = k2 * (-t * sin_phi + dx)
        + k3 * (t * cos_phi + dz)
        + k5 * (-t * sin_d * lcg - (dx * cos_th + dz * sin_th) * arm);
    // The drag's weights.
    let a = k2 - k5 * arm * cos_th;
    let b = k3 - k5 * arm * sin_th;
    // Q's gradient and Hessian in (u, v, θ, T, δ).
    let g = [
        a * dx_u + b * dz_u,
        a * dx_v + b * dz_v,
        -k2 * t * cos_phi - k3 * t * sin_phi + k5 * arm * (dx * sin_th - dz * cos_th),
        -k2 * sin_phi + k3 * cos_phi - k5 * lcg * sin_d,
        -k2 * t * cos_phi - k3 * t * sin_phi - k5 * t * lcg * cos_d,
    ];
    let mut h = [[0.0; 5]; 5];
    h[0][0] = a * dx_uu + b * dz_uu;
    h[0][1] = a * dx_uv + b * dz_uv;
    h[1][1] = a * dx_vv + b * dz_vv;
    h[0][2] = k5 * arm * (dx_u * sin_th - dz_u * cos_th);
    h[1][2] = k5 * arm * (dx_v * sin_th - dz_v * cos_th);
    h[2][2] = k2 * t * sin_phi - k3 * t * cos_phi + k5 * arm * (dx * cos_th + dz * sin_th);
    h[2][3] = -k2 * cos_phi - k3 * sin_phi;
    h[2][4] = k2 * t * sin_phi - k3 * t * cos_phi;
    h[3][4] = -k2 * cos_phi - k3 * sin_phi - k5 * lcg * cos_d;
    h[4][4] = k2 * t * sin_phi - k3 * t * cos_phi + k5 * t * lcg * sin_d;
    // φ's variables (Vx, Vz, θ, w, m, T, δ) from Q's (u, v, θ, T, δ).
    const AT: [usize; 5] = [0, 1, 2, 5, 6];
    let mut grad = [0.0; 7];
    let mut hess = [[0.0; 7]; 7];
    for (i, &r) in AT.iter().enumerate() {
        grad[r] = g[i] / m;
        hess[r][4] = -g[i] / (m * m);
        hess[4][r] = hess[r][4];
        for (j, &col) in AT.iter().enumerate().skip(i) {
            hess[r][col] = h[i][j] / m;
            hess[col][r] = hess[r][col];
        }
    }
    grad[0] += kappa[0];
    grad[1] += kappa[1];
    grad[3] = kappa[4];
    grad[4] = -q / (m * m);
    grad[5] += kappa[6] * model.alpha_spm;
    hess[4][4] = 2.0 * q / (m * m * m);
    (grad, hess)
}

/// Eq. (8): the nozzle-rate augmented model of P2, state (x, z, Vx, Vz, θ, w, m, δ),
/// control (T \[N\], χ [rad/s]).
pub fn rhs_augmented<D: DualNum<Primitive = f64> + Copy>(
    model: &Model,
    s: &[D; 8],
    thrust_n: D,
    chi_radps: D,
) -> [D; 8] {
    let p: [D; 7] = [s[0], s[1], s[2], s[3], s[4], s[5], s[6]];
    let f = rhs_physical(model, &p, thrust_n, s[7]);
    [f[0], f[1], f[2], f[3], f[4], f[5], f[6], chi_radps]
}

/// Eq. (21)–(22): LCvx dynamics in (x, z, Vx, Vz, θ, w, ω, δ).
///
/// `u` is (Txm, Tzm, σ, χ) for [`Formulation::Paper`] and (σ, χ) for
/// [`Formulation::Exact`], where (Txm, Tzm) = σ·(sin(θ+δ), cos(θ+δ)).
pub fn rhs_lcvx<D: DualNum<Primitive = f64> + Copy>(
    model: &Model,
    form: Formulation,
    x: &[D; NX],
    u: &[D],
) -> [D; NX] {
    let [_, _, vx, vz, theta, w, omega, delta] = *x;
    let (txm, tzm, sigma, chi) = match form {
        Formulation::Paper | Formulation::Vector => (u[0], u[1], u[2], u[3]),
        Formulation::Exact => {
            let (sin_phi, cos_phi) = (theta + delta).sin_cos();
            (u[0] * sin_phi, u[0] * cos_phi, u[0], u[1])
        }
    };
    let inv_m = (-omega).exp();
    let (dx, dz) = model.drag(vx, vz);
    let (dxm, dzm) = (dx * inv_m, dz * inv_m);
    let (sin_th, cos_th) = theta.sin_cos();
    [
        vx,
        vz,
        -txm + dxm,
        tzm + dzm - model.g0_mps2,
        w,
        sigma * delta.sin() * model.l_t_pm + (dxm * cos_th + dzm * sin_th) * model.l_d_pm,
        sigma * model.alpha_spm,
        chi,
    ]
}

/// Value and Jacobians of [`rhs_lcvx`] at (x, u): f, A = ∂f/∂x, B = ∂f/∂u (Eq. 26).
///
/// B has [`NU_MAX`] columns; only the first `control_dim(form)` are meaningful.
#[derive(Debug, Clone, PartialEq)]
pub struct Linearization {
    pub f: [f64; NX],
    pub a: [[f64; NX]; NX],
    pub b: [[f64; NU_MAX]; NX],
}

/// Exact Jacobians by forward-mode automatic differentiation (num-dual).
pub fn linearize(model: &Model, form: Formulation, x: &[f64; NX], u: &[f64]) -> Linearization {
    type D = DualSVec64<{ NX + NU_MAX }>;
    let nu = control_dim(form);
    let xd: [D; NX] = std::array::from_fn(|i| D::from_re(x[i]).derivative(i));
    let ud: Vec<D> = (0..nu)
        .map(|j| D::from_re(u[j]).derivative(NX + j))
        .collect();
    let out = rhs_lcvx(model, form, &xd, &ud);
    let mut lin = Linearization {
        f: [0.0; NX],
        a: [[0.0; NX]; NX],
        b: [[0.0; NU_MAX]; NX],
    };
    for (r, o) in out.iter().enumerate() {
        lin.f[r] = o.re;
        if let Some(eps) = &o.eps.0 {
            for c in 0..NX {
                lin.a[r][c] = eps[c];
            }
            for c in 0..nu {
                lin.b[r][c] = eps[NX + c];
            }
        }
    }
    lin
}

/// Thrust-per-mass vector (Txm, Tzm) and σ of a control in either formulation.
pub fn thrust_components(form: Formulation, x: &[f64; NX], u: &[f64]) -> (f64, f64, f64) {
    match form {
        Formulation::Paper | Formulation::Vector => (u[0], u[1], u[2]),
        Formulation::Exact => {
            let phi = x[ix::THETA] + x[ix::DELTA];
            (u[0] * phi.sin(), u[0] * phi.cos(), u[0])
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`weighted_rhs_hessian`] against num-dual's second-order dual
    /// numbers on κᵀ·[`rhs_physical`], with a wind, at states in and out of
    /// the flip.
    #[test]
    fn the_weighted_hessian_is_second_order_differentiation() {
        use num_dual::Dual2SVec64;
        type D2 = Dual2SVec64<7>;
        let mut s = crate::input::scenario::Scenario::paper();
        s.environment.wind_x_mps = 7.0;
        let model = Model::new(&s.vehicle, &s.environment);
        let kappa = [0.3, -0.2, 0.7, -1.1, 0.4, 2.5, -1e-3];
        for (y, t, d) in [
            ([5.0, 800.0, 10.0, -80.0, 1.4, -0.1, 110_000.0], 1.6e6, 0.05),
            ([-2.0, 40.0, -3.0, -4.0, 0.02, 0.3, 90_000.0], 2.2e6, -0.2),
        ] {
            let var = |v: f64, i: usize| D2::from_re(v).derivative(i);
            let ys = [
                D2::from_re(y[0]),
                D2::from_re(y[1]),
                var(y[2], 0),
                var(y[3], 1),
                var(y[4], 2),
                var(y[5], 3),
                var(y[6], 4),
            ];
            let f = rhs_physical(&model, &ys, var(t, 5), var(d, 6));
            let mut phi = D2::from_re(0.0);
            for (f, k) in f.iter().zip(&kappa) {
                phi += *f * *k;
            }
            let g = phi.v1.0.unwrap();
            let h = phi.v2.0.unwrap();
            let (grad, hess) = weighted_rhs_hessian(&model, &y, t, d, &kappa);
            for r in 0..7 {
                assert!(
                    (grad[r] - g[r]).abs() <= 1e-12 * g[r].abs().max(1e-9),
                    "∂φ/∂v{r}"
                );
                for c in 0..7 {
                    let want = h[(r, c)];
                    assert!(
                        (hess[r][c] - want).abs() <= 1e-10 * want.abs().max(1e-12),
                        "∂²φ/∂v{r}∂v{c}: {} vs {want}",
                        hess[r][c]
                    );
                }
            }
        }
    }
    use crate::input::scenario::Scenario;

    fn model() -> Model {
        let s = Scenario::paper();
        Model::new(&s.vehicle, &s.environment)
    }

    /// The written-out Jacobian equals num-dual's through
    /// [`rhs_physical`], to rounding, with a wind, at states across the
    /// flight.
    #[test]
    fn the_written_jacobian_is_num_duals() {
        use num_dual::DualSVec64;
        let mut m = model();
        m.wind_x_mps = 3.0;
        let states = [
            (
                [0.0, 500.0, -10.0, -90.0, 1.5, 0.01, 120_000.0],
                1.5e6,
                0.02,
            ),
            ([10.0, 50.0, 4.0, -20.0, -0.3, -0.2, 100_000.0], 2.2e6, -0.3),
            ([0.0, 1.0, 3.0, 0.0, 0.0, 0.0, 90_000.0], 9e5, 0.0),
        ];
        for (y, t, d) in states {
            let (f, jac) = rhs_physical_jacobian(&m, &y, t, d);
            type D = DualSVec64<9>;
            let yd: [D; 7] = std::array::from_fn(|i| D::from_re(y[i]).derivative(i));
            let fd = rhs_physical(
                &m,
                &yd,
                D::from_re(t).derivative(7),
                D::from_re(d).derivative(8),
            );
            for i in 0..7 {
                assert!((f[i] - fd[i].re).abs() <= 1e-12 * f[i].abs().max(1.0));
                let eps = fd[i].eps.0.unwrap_or_default();
                for c in 0..9 {
                    let scale = jac[i][c].abs().max(eps[c].abs()).max(1e-300);
                    assert!(
                        (jac[i][c] - eps[c]).abs() <= 1e-12 * scale,
                        "∂f{i}/∂v{c}: {} vs {}",
                        jac[i][c],
                        eps[c]
                    );
                }
            }
        }
    }

    fn sample_state() -> [f64; NX] {
        [
            80.0,
            450.0,
            -3.0,
            -70.0,
            1.2,
            -0.2,
            120_000f64.ln() - 0.01,
            0.15,
        ]
    }

    #[test]
    fn jacobians_match_central_differences() {
        // Still air (the paper) and a 6-m/s wind.
        for m in [
            model(),
            Model {
                wind_x_mps: 6.0,
                ..model()
            },
        ] {
            jacobians_match_at(&m);
        }
    }

    fn jacobians_match_at(m: &Model) {
        let m = m.clone();
        let x = sample_state();
        for (form, u) in [
            (Formulation::Paper, vec![15.0, 6.0, 16.5, 0.1]),
            (Formulation::Exact, vec![16.5, -0.2]),
        ] {
            let lin = linearize(&m, form, &x, &u);
            let f0 = rhs_lcvx(&m, form, &x, &u);
            assert_eq!(lin.f, f0);
            for c in 0..NX {
                let h = 1e-6 * x[c].abs().max(1.0);
                let (mut xp, mut xm) = (x, x);
                xp[c] += h;
                xm[c] -= h;
                let (fp, fm) = (rhs_lcvx(&m, form, &xp, &u), rhs_lcvx(&m, form, &xm, &u));
                for r in 0..NX {
                    let fd = (fp[r] - fm[r]) / (2.0 * h);
                    assert!(
                        (fd - lin.a[r][c]).abs() <= 1e-6 * (1.0 + fd.abs()),
                        "{form:?} A[{r}][{c}]: AD {} vs FD {fd}",
                        lin.a[r][c]
                    );
                }
            }
            for c in 0..u.len() {
                let h = 1e-6 * u[c].abs().max(1.0);
                let (mut up, mut um) = (u.clone(), u.clone());
                up[c] += h;
                um[c] -= h;
                let (fp, fm) = (rhs_lcvx(&m, form, &x, &up), rhs_lcvx(&m, form, &x, &um));
                for r in 0..NX {
                    let fd = (fp[r] - fm[r]) / (2.0 * h);
                    assert!(
                        (fd - lin.b[r][c]).abs() <= 1e-6 * (1.0 + fd.abs()),
                        "{form:?} B[{r}][{c}]: AD {} vs FD {fd}",
                        lin.b[r][c]
                    );
                }
            }
        }
    }

    #[test]
    fn lcvx_form_equals_physical_form() {
        // Eq. (21) is Eq. (8) rewritten with σ = T/m, ω = ln m: same motion.
        let m = model();
        let x = sample_state();
        let mass = x[ix::OMEGA].exp();
        let thrust = 1.9e6;
        let phys = rhs_augmented(
            &m,
            &[x[0], x[1], x[2], x[3], x[4], x[5], mass, x[7]],
            thrust,
            0.05,
        );
        let lcvx = rhs_lcvx(&m, Formulation::Exact, &x, &[thrust / mass, 0.05]);
        for r in 0..6 {
            assert!(
                (phys[r] - lcvx[r]).abs() < 1e-10 * (1.0 + phys[r].abs()),
                "row {r}"
            );
        }
        // ω̇ = ṁ/m
        assert!((phys[6] / mass - lcvx[6]).abs() < 1e-14);
        assert_eq!(phys[7], lcvx[7]);
        // The paper's controls with the same thrust vector give the same motion.
        let phi = x[4] + x[7];
        let s = thrust / mass;
        let paper = rhs_lcvx(
            &m,
            Formulation::Paper,
            &x,
            &[s * phi.sin(), s * phi.cos(), s, 0.05],
        );
        for r in 0..NX {
            assert!((paper[r] - lcvx[r]).abs() < 1e-12 * (1.0 + lcvx[r].abs()));
        }
    }

    /// Drag acts on the air-relative velocity: a vehicle moving with the
    /// wind feels no horizontal drag, and a wind W at ground velocity V gives
    /// the still-air drag at V − W.
    #[test]
    fn wind_enters_through_the_air_relative_velocity() {
        let still = model();
        let windy = Model {
            wind_x_mps: 5.0,
            ..model()
        };
        let s = [0.0, 100.0, 5.0, -40.0, 0.0, 0.0, 1e5];
        let f = rhs_physical(&windy, &s, 0.0, 0.0);
        let g = rhs_physical(&still, &[0.0, 100.0, 0.0, -40.0, 0.0, 0.0, 1e5], 0.0, 0.0);
        assert_eq!(f[2], 0.0);
        assert_eq!(&f[2..], &g[2..]);
        let f = rhs_physical(&windy, &[0.0, 100.0, -3.0, -40.0, 0.3, 0.0, 1e5], 0.0, 0.0);
        let g = rhs_physical(&still, &[0.0, 100.0, -8.0, -40.0, 0.3, 0.0, 1e5], 0.0, 0.0);
        assert_eq!(&f[2..], &g[2..]);
        assert!(f[2] > 0.0, "a head wind pushes back: {}", f[2]);
    }

    #[test]
    fn free_fall_without_thrust_or_air() {
        let mut v = Scenario::paper().vehicle;
        v.drag_coefficient_kgpm = 0.0;
        let m = Model::new(&v, &Scenario::paper().environment);
        let f = rhs_physical(&m, &[0.0, 100.0, 3.0, -10.0, 0.3, 0.1, 1e5], 0.0, 0.0);
        assert_eq!(f, [3.0, -10.0, 0.0, -9.81, 0.1, 0.0, 0.0]);
    }

    #[test]
    fn inertia_constants_follow_eq_22() {
        let m = model();
        // 6·4.5² + 50² = 2621.5
        assert!((m.l_t_pm - (-12.0 * 20.0 / 2621.5)).abs() < 1e-15);
        assert!((m.l_d_pm - (-12.0 * 2.5 / 2621.5)).abs() < 1e-15);
        assert!((m.alpha_spm + 1.0 / (330.0 * 9.81)).abs() < 1e-18);
    }
}
