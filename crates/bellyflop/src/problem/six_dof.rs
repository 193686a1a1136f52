//! The 6-DoF model (issue 38): the paper's planar equations (Eq. 1–3 with
//! the gimbal of Eq. 8) lifted to 3-D, so that the planar problem is an
//! exact special case ([`planar_state`]).
//!
//! Not yet behind the model seam: this is the second model in hand, against
//! which the seam's trait is to be designed.
//!
//! # State and control
//!
//! State (16, [`sx`]): position r = (x, y, z) \[m\] (z up), velocity V \[m/s\],
//! a unit quaternion q = (q0, q1, q2, q3) (scalar first) from the body to the
//! inertial frame, body rates ω \[rad/s\], mass m \[kg\], and the gimbal's two
//! angles (δ1, δ2) \[rad\]. Control (3, [`su`]): thrust T \[N\] and the gimbal
//! rates (χ1, χ2) \[rad/s\].
//!
//! The body frame: e_z along the vehicle's axis toward the nose; in the
//! planar special case, e_x = (cos θ, 0, sin θ) and e_y = ŷ, so that the
//! planar pitch θ is a rotation by θ about −ŷ, q = (cos θ/2, 0, −sin θ/2, 0),
//! and ω = (0, −w, 0).
//!
//! # Equations
//!
//! With R = R(q/|q|) and the thrust direction in the body frame
//! d = (−sin δ1·cos δ2, −sin δ2, cos δ1·cos δ2) (planar: δ2 = 0, δ1 = δ):
//!
//! - ṙ = V;
//! - m·V̇ = T·R·d + D − m·g·ẑ, the drag D = −C_LD·‖V_a‖·V_a on the
//!   air-relative velocity V_a = V − W (Eq. 2, a 3-D wind W);
//! - q̇ = ½·q ⊗ (0, ω) + κ·(1 − |q|²)·q: the kinematics, and a term that
//!   pulls |q| back to 1 (it vanishes on |q| = 1; issue 38 measured that
//!   imposing |q|² = 1 at every collocation node over-determines the
//!   problem, while a term like this converges);
//! - J·ω̇ = τ − ω × (J·ω), J = m·diag(k_t, k_t, k_r), k_t = (6r² + l²)/12 and
//!   k_r = r²/2 (the paper's transverse inertia, Eq. 3, and a cylinder's roll
//!   inertia); as in Eq. (3), J̇·ω is not counted;
//! - the torque in the body frame τ = (−l_cg·e_z) × (T·d) +
//!   ((l_cp − l_cg)·e_z) × (Rᵀ·D): the thrust at the engine, l_cg behind
//!   the centre of mass, and the drag at the centre of pressure (Eq. 3's
//!   −(D_x cos θ + D_z sin θ)(l_cp − l_cg) in the plane);
//! - ṁ = −T/(I_sp·g0); δ̇ = χ.
//!
//! **Roll.** Both torque arms lie along e_z, so neither the one gimballed
//! engine nor the drag has a roll moment, and with J's two equal transverse
//! entries the gyroscopic term has none either: the roll rate ω_z is
//! conserved. The model has no roll control (an RCS would add one).

use num_dual::DualNum;

use crate::input::scenario::{Environment, InitialState, Vehicle};
use crate::problem::dynamics::Model;

mod jacobian;
pub use jacobian::{jacobian, QUATERNION_PRODUCT};

/// Number of states.
pub const NX: usize = 16;
/// Number of controls.
pub const NU: usize = 3;

/// State indices.
pub mod sx {
    pub const X: usize = 0;
    pub const Y: usize = 1;
    pub const Z: usize = 2;
    pub const VX: usize = 3;
    pub const VY: usize = 4;
    pub const VZ: usize = 5;
    /// q0 (scalar), then q1..q3 at Q + 1..Q + 3.
    pub const Q: usize = 6;
    /// ω_x, then ω_y, ω_z.
    pub const W: usize = 10;
    pub const M: usize = 13;
    /// δ1, then δ2.
    pub const DELTA: usize = 14;
}

/// Control indices.
pub mod su {
    pub const T: usize = 0;
    /// χ1, then χ2.
    pub const CHI: usize = 1;
}

/// How fast |q| is pulled back to 1 by default, κ \[1/s\]: slow beside
/// the flip (~5 s), so that it does not stiffen the dynamics.
pub const NORM_GAIN_PER_S: f64 = 1.0;

/// The constants of the 6-DoF model: the planar model's, a roll inertia
/// and a 3-D wind.
#[derive(Debug, Clone, PartialEq)]
pub struct SixDof {
    pub planar: Model,
    /// k_r = r²/2 \[m²\].
    pub roll_inertia_per_mass_m2: f64,
    /// Steady wind W [m/s].
    pub wind_mps: [f64; 3],
    /// κ in q̇'s pull toward |q| = 1 \[1/s\].
    pub norm_gain_per_s: f64,
}

impl SixDof {
    /// The vehicle of a scenario; the wind W = (wind_x_mps, wind_y_mps, 0).
    pub fn new(v: &Vehicle, env: &Environment) -> Self {
        SixDof {
            planar: Model::new(v, env),
            roll_inertia_per_mass_m2: 0.5 * v.radius_m * v.radius_m,
            wind_mps: [env.wind_x_mps, env.wind_y_mps, 0.0],
            norm_gain_per_s: NORM_GAIN_PER_S,
        }
    }
}

fn cross<D: DualNum<Primitive = f64> + Copy>(a: [D; 3], b: [D; 3]) -> [D; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// R(q/|q|), the rotation from the body to the inertial frame.
pub fn rotation<D: DualNum<Primitive = f64> + Copy>(q: [D; 4]) -> [[D; 3]; 3] {
    let n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    let s = n2.recip() * 2.0;
    let [w, x, y, z] = q;
    let one = D::one();
    [
        [
            one - s * (y * y + z * z),
            s * (x * y - w * z),
            s * (x * z + w * y),
        ],
        [
            s * (x * y + w * z),
            one - s * (x * x + z * z),
            s * (y * z - w * x),
        ],
        [
            s * (x * z - w * y),
            s * (y * z + w * x),
            one - s * (x * x + y * y),
        ],
    ]
}

fn apply<D: DualNum<Primitive = f64> + Copy>(r: &[[D; 3]; 3], v: [D; 3]) -> [D; 3] {
    std::array::from_fn(|i| r[i][0] * v[0] + r[i][1] * v[1] + r[i][2] * v[2])
}

fn apply_transposed<D: DualNum<Primitive = f64> + Copy>(r: &[[D; 3]; 3], v: [D; 3]) -> [D; 3] {
    std::array::from_fn(|i| r[0][i] * v[0] + r[1][i] * v[1] + r[2][i] * v[2])
}

/// The thrust direction in the body frame, d(δ1, δ2).
pub fn thrust_direction<D: DualNum<Primitive = f64> + Copy>(d1: D, d2: D) -> [D; 3] {
    let (s1, c1) = d1.sin_cos();
    let (s2, c2) = d2.sin_cos();
    [-(s1 * c2), -s2, c1 * c2]
}

/// The drag force D = −C_LD·‖V_a‖·V_a on the air-relative velocity
/// V_a = V − W (Eq. 2, with the planar model's smoothing of ‖·‖).
pub fn drag_force<D: DualNum<Primitive = f64> + Copy>(model: &SixDof, v: [D; 3]) -> [D; 3] {
    let va: [D; 3] = std::array::from_fn(|i| v[i] - model.wind_mps[i]);
    let speed = (va[0] * va[0] + va[1] * va[1] + va[2] * va[2] + 1e-12).sqrt();
    std::array::from_fn(|i| va[i] * speed * (-model.planar.c_ld_kgpm))
}

/// The inertia J = m·(k_t, k_t, k_r) (module equations).
fn inertia<D: DualNum<Primitive = f64> + Copy>(model: &SixDof, m: D) -> [D; 3] {
    let kt = model.planar.inertia_per_mass_m2;
    [m * kt, m * kt, m * model.roll_inertia_per_mass_m2]
}

/// The terms of f whose sum is [`rhs`], each a function of a few inputs
/// only, so that a transcription can differentiate each over its own
/// inputs (`collocation::derivatives`, the 6-DoF's `Differentiable`): the
/// thrust's acceleration T·R·d/m (q, δ, T, m).
pub fn thrust_acceleration<D: DualNum<Primitive = f64> + Copy>(
    q: [D; 4],
    delta: [D; 2],
    thrust: D,
    m: D,
) -> [D; 3] {
    let d = thrust_direction(delta[0], delta[1]);
    thrust_acceleration_from(&rotation(q), d, thrust, m)
}

/// [`thrust_acceleration`] from R and d, evaluated apart (a transcription
/// differentiates R once per point for two terms).
pub fn thrust_acceleration_from<D: DualNum<Primitive = f64> + Copy>(
    r: &[[D; 3]; 3],
    d: [D; 3],
    thrust: D,
    m: D,
) -> [D; 3] {
    let f = apply(r, std::array::from_fn(|i| d[i] * thrust));
    std::array::from_fn(|i| f[i] / m)
}

/// The drag's acceleration D/m (V, m).
pub fn drag_acceleration<D: DualNum<Primitive = f64> + Copy>(
    model: &SixDof,
    v: [D; 3],
    m: D,
) -> [D; 3] {
    let drag = drag_force(model, v);
    std::array::from_fn(|i| drag[i] / m)
}

/// The thrust's angular acceleration J⁻¹·((−l_cg·e_z) × (T·d)) (δ, T, m).
pub fn thrust_angular_acceleration<D: DualNum<Primitive = f64> + Copy>(
    model: &SixDof,
    delta: [D; 2],
    thrust: D,
    m: D,
) -> [D; 3] {
    let d = thrust_direction(delta[0], delta[1]);
    let arm = [D::zero(), D::zero(), D::from(-model.planar.cg_m)];
    let tau = cross(arm, std::array::from_fn(|i| d[i] * thrust));
    let j = inertia(model, m);
    std::array::from_fn(|i| tau[i] / j[i])
}

/// The drag's angular acceleration J⁻¹·(((l_cp − l_cg)·e_z) × (Rᵀ·D))
/// (V, q, m).
pub fn drag_angular_acceleration<D: DualNum<Primitive = f64> + Copy>(
    model: &SixDof,
    v: [D; 3],
    q: [D; 4],
    m: D,
) -> [D; 3] {
    drag_angular_acceleration_from(model, &rotation(q), drag_force(model, v), m)
}

/// [`drag_angular_acceleration`] from R and the drag D, evaluated apart.
pub fn drag_angular_acceleration_from<D: DualNum<Primitive = f64> + Copy>(
    model: &SixDof,
    r: &[[D; 3]; 3],
    drag: [D; 3],
    m: D,
) -> [D; 3] {
    let p = &model.planar;
    let arm = [D::zero(), D::zero(), D::from(p.cp_m - p.cg_m)];
    let tau = cross(arm, apply_transposed(r, drag));
    let j = inertia(model, m);
    std::array::from_fn(|i| tau[i] / j[i])
}

/// The gyroscopic angular acceleration −J⁻¹·(ω × J·ω) (ω, m).
pub fn gyroscopic_angular_acceleration<D: DualNum<Primitive = f64> + Copy>(
    model: &SixDof,
    w: [D; 3],
    m: D,
) -> [D; 3] {
    let j = inertia(model, m);
    let gyro = cross(w, std::array::from_fn(|i| j[i] * w[i]));
    std::array::from_fn(|i| -gyro[i] / j[i])
}

/// q̇ = ½·q ⊗ (0, ω) + κ·(1 − |q|²)·q (q, ω).
pub fn quaternion_rate<D: DualNum<Primitive = f64> + Copy>(
    model: &SixDof,
    q: [D; 4],
    w: [D; 3],
) -> [D; 4] {
    let n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    let pull = (D::one() - n2) * model.norm_gain_per_s;
    let qw = [
        -(q[1] * w[0] + q[2] * w[1] + q[3] * w[2]),
        q[0] * w[0] + q[2] * w[2] - q[3] * w[1],
        q[0] * w[1] + q[3] * w[0] - q[1] * w[2],
        q[0] * w[2] + q[1] * w[1] - q[2] * w[0],
    ];
    std::array::from_fn(|i| qw[i] * 0.5 + q[i] * pull)
}

/// ẋ for state `s` ([`sx`]) and control `u` ([`su`]) (module equations):
/// the sum of the terms above, with ṙ = V, the gravity, ṁ = −T/(I_sp·g0)
/// and δ̇ = χ.
pub fn rhs<D: DualNum<Primitive = f64> + Copy>(
    model: &SixDof,
    s: &[D; NX],
    u: &[D; NU],
) -> [D; NX] {
    let p = &model.planar;
    let v = [s[sx::VX], s[sx::VY], s[sx::VZ]];
    let q = [s[sx::Q], s[sx::Q + 1], s[sx::Q + 2], s[sx::Q + 3]];
    let w = [s[sx::W], s[sx::W + 1], s[sx::W + 2]];
    let delta = [s[sx::DELTA], s[sx::DELTA + 1]];
    let (m, thrust) = (s[sx::M], u[su::T]);
    let a_thrust = thrust_acceleration(q, delta, thrust, m);
    let a_drag = drag_acceleration(model, v, m);
    let w_thrust = thrust_angular_acceleration(model, delta, thrust, m);
    let w_drag = drag_angular_acceleration(model, v, q, m);
    let w_gyro = gyroscopic_angular_acceleration(model, w, m);
    let q_dot = quaternion_rate(model, q, w);
    let mut out = [D::zero(); NX];
    for i in 0..3 {
        out[sx::X + i] = v[i];
        out[sx::VX + i] = a_thrust[i] + a_drag[i];
        out[sx::W + i] = w_thrust[i] + w_drag[i] + w_gyro[i];
    }
    out[sx::VZ] -= p.g0_mps2;
    out[sx::Q..sx::Q + 4].copy_from_slice(&q_dot);
    out[sx::M] = thrust * p.alpha_spm;
    out[sx::DELTA] = u[su::CHI];
    out[sx::DELTA + 1] = u[su::CHI + 1];
    out
}

/// The 6-DoF state of a planar state (x, z, Vx, Vz, θ, w, m, δ): y = V_y = 0,
/// q = (cos θ/2, 0, −sin θ/2, 0), ω = (0, −w, 0), δ1 = δ, δ2 = 0.
pub fn planar_state(y: &[f64; 8]) -> [f64; NX] {
    let (x, z, vx, vz, theta, w, m, delta) = (y[0], y[1], y[2], y[3], y[4], y[5], y[6], y[7]);
    let mut s = [0.0; NX];
    s[sx::X] = x;
    s[sx::Z] = z;
    s[sx::VX] = vx;
    s[sx::VZ] = vz;
    s[sx::Q] = (0.5 * theta).cos();
    s[sx::Q + 2] = -(0.5 * theta).sin();
    s[sx::W + 1] = -w;
    s[sx::M] = m;
    s[sx::DELTA] = delta;
    s
}

/// q_a ⊗ q_b, the Hamilton product of two scalar-first quaternions.
fn quaternion_product(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// The attitude q (body to inertial, scalar first) of pitch θ, yaw ψ and
/// roll φ \[rad\]: q = q_yaw(ψ about z) ⊗ q_pitch(θ about −y) ⊗ q_roll(φ
/// about e_z), as `attitude` of `bench/reference/nlp_6dof.py`. At ψ = φ = 0
/// it is [`planar_state`]'s (cos θ/2, 0, −sin θ/2, 0).
pub fn attitude(theta_rad: f64, yaw_rad: f64, roll_rad: f64) -> [f64; 4] {
    let (ct, st) = ((0.5 * theta_rad).cos(), (0.5 * theta_rad).sin());
    let (cy, sy) = ((0.5 * yaw_rad).cos(), (0.5 * yaw_rad).sin());
    let (cr, sr) = ((0.5 * roll_rad).cos(), (0.5 * roll_rad).sin());
    let yaw = [cy, 0.0, 0.0, sy];
    let pitch = [ct, 0.0, -st, 0.0];
    let roll = [cr, 0.0, 0.0, sr];
    quaternion_product(quaternion_product(yaw, pitch), roll)
}

/// The 6-DoF start of a scenario's initial state, in SI units and radians:
/// its planar state through [`planar_state`], then the out-of-plane fields,
/// as `start_state` of `bench/reference/nlp_6dof.py`:
///
/// - r = (x, y, z), V = (V_x, V_y, V_z);
/// - q = [`attitude`](θ, ψ, φ): q_yaw(ψ about z) ⊗ q_pitch(θ about −y) ⊗
///   q_roll(φ about e_z), from `theta_deg`, `yaw_deg`, `roll_deg`;
/// - ω = (ω_x, −w, ω_z): `body_rate_x_degps`, the planar pitch rate w
///   (`pitch_rate_degps`) about −e_y, `roll_rate_degps`;
/// - m = `mass_kg`, δ1 = `gimbal_deg`, δ2 = `gimbal2_deg`.
///
/// With every out-of-plane field 0 it is `planar_state(&i.state_si())`.
pub fn start_state(i: &InitialState) -> [f64; NX] {
    let mut s = planar_state(&i.state_si());
    s[sx::Y] = i.y_m;
    s[sx::VY] = i.vy_mps;
    let q = attitude(
        i.theta_deg.to_radians(),
        i.yaw_deg.to_radians(),
        i.roll_deg.to_radians(),
    );
    s[sx::Q..sx::Q + 4].copy_from_slice(&q);
    s[sx::W] = i.body_rate_x_degps.to_radians();
    s[sx::W + 2] = i.roll_rate_degps.to_radians();
    s[sx::DELTA + 1] = i.gimbal2_deg.to_radians();
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;
    use crate::problem::dynamics::rhs_physical;
    use num_dual::DualSVec64;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The whole-f reference for [`jacobian`]: one forward-mode pass of
    /// NX + NU-direction dual numbers through [`rhs`].
    fn jacobian_by_duals(
        model: &SixDof,
        s: &[f64; NX],
        u: &[f64; NU],
    ) -> ([f64; NX], [[f64; NX + NU]; NX]) {
        type D = DualSVec64<{ NX + NU }>;
        let sd: [D; NX] = std::array::from_fn(|i| D::from_re(s[i]).derivative(i));
        let ud: [D; NU] = std::array::from_fn(|j| D::from_re(u[j]).derivative(NX + j));
        let out = rhs(model, &sd, &ud);
        let mut f = [0.0; NX];
        let mut jac = [[0.0; NX + NU]; NX];
        for (r, o) in out.iter().enumerate() {
            f[r] = o.re;
            if let Some(eps) = &o.eps.0 {
                for c in 0..NX + NU {
                    jac[r][c] = eps[c];
                }
            }
        }
        (f, jac)
    }

    fn paper() -> SixDof {
        let s = Scenario::paper();
        SixDof::new(&s.vehicle, &s.environment)
    }

    /// With every out-of-plane field at 0, the scenario's 6-DoF start is
    /// the planar start mapped by [`planar_state`], bit for bit.
    #[test]
    fn a_planar_start_is_the_planar_state() {
        let mut i = Scenario::paper().initial;
        (i.x_m, i.vx_mps, i.theta_deg) = (120.0, -12.0, 75.0);
        (i.pitch_rate_degps, i.gimbal_deg) = (4.0, 3.0);
        assert_eq!(start_state(&i), planar_state(&i.state_si()));
        assert_eq!(
            start_state(&Scenario::paper().initial),
            planar_state(&Scenario::paper().initial.state_si())
        );
    }

    /// The start out of the plane against `start_state` of the Python
    /// reference, from bench/reference:
    ///
    /// ```text
    /// # the paper's file with x_m = 120, vx_mps = -12, theta_deg = 75,
    /// # pitch_rate_degps = 4, gimbal_deg = 3, as /tmp/s.toml
    /// .venv/bin/python -c "import math; from nlp_reference import load_scenario;
    ///   from nlp_6dof import start_state; r = math.radians;
    ///   s = start_state(load_scenario('/tmp/s.toml'), y=-35.0, vy=6.5,
    ///     psi=r(30.0), phi=r(-50.0), rates=(r(2.5), 0.0, r(-7.0)));
    ///   print(', '.join(repr(float(x)) for x in s))"
    /// ```
    ///
    /// The reference has no second gimbal angle (its s[15] is 0): here
    /// δ2 = gimbal2_deg = 4°.
    #[test]
    fn an_out_of_plane_start_matches_the_python_reference() {
        let mut i = Scenario::paper().initial;
        (i.x_m, i.vx_mps, i.theta_deg) = (120.0, -12.0, 75.0);
        (i.pitch_rate_degps, i.gimbal_deg) = (4.0, 3.0);
        (i.y_m, i.vy_mps, i.yaw_deg, i.roll_deg) = (-35.0, 6.5, 30.0, -50.0);
        (i.body_rate_x_degps, i.roll_rate_degps) = (2.5, -7.0);
        i.gimbal2_deg = 4.0;
        let reference: [f64; NX] = [
            120.0,
            -35.0,
            600.0,
            -12.0,
            6.5,
            -85.0,
            0.781300520396941,
            0.3913043038218774,
            -0.46633830987729874,
            -0.1377643617875451,
            0.04363323129985824,
            -0.06981317007977318,
            -0.12217304763960307,
            120000.0,
            0.05235987755982989,
            0.0,
        ];
        let mut want = reference;
        want[sx::DELTA + 1] = 4f64.to_radians();
        let got = start_state(&i);
        for k in 0..NX {
            assert!(
                (got[k] - want[k]).abs() <= 1e-15 * want[k].abs().max(1.0),
                "state {k}: {} against the reference's {}",
                got[k],
                want[k]
            );
        }
        let norm: f64 = got[sx::Q..sx::Q + 4].iter().map(|q| q * q).sum();
        assert!((norm - 1.0).abs() < 1e-15);
    }

    /// The cross wind of the environment is the model's W_y.
    #[test]
    fn the_model_takes_both_winds() {
        let mut s = Scenario::paper();
        (s.environment.wind_x_mps, s.environment.wind_y_mps) = (7.0, -4.0);
        let six = SixDof::new(&s.vehicle, &s.environment);
        assert_eq!(six.wind_mps, [7.0, -4.0, 0.0]);
    }

    /// A state of the paper's envelope's scales, out of the plane: unit q.
    fn random_state(rng: &mut ChaCha8Rng) -> [f64; NX] {
        let mut s = [0.0; NX];
        for i in 0..3 {
            s[sx::X + i] = rng.gen_range(-300.0..300.0);
            s[sx::VX + i] = rng.gen_range(-90.0..90.0);
            s[sx::W + i] = rng.gen_range(-0.5..0.5);
        }
        s[sx::Z] = rng.gen_range(10.0..800.0);
        let q: [f64; 4] = std::array::from_fn(|_| rng.gen_range(-1.0..1.0));
        let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
        for i in 0..4 {
            s[sx::Q + i] = q[i] / n;
        }
        s[sx::M] = rng.gen_range(90_000.0..120_000.0);
        s[sx::DELTA] = rng.gen_range(-0.3..0.3);
        s[sx::DELTA + 1] = rng.gen_range(-0.3..0.3);
        s
    }

    fn random_control(rng: &mut ChaCha8Rng) -> [f64; NU] {
        [
            rng.gen_range(0.88e6..2.21e6),
            rng.gen_range(-0.3..0.3),
            rng.gen_range(-0.3..0.3),
        ]
    }

    /// The planar model is the special case y = V_y = 0, attitude in the
    /// x–z plane, δ2 = 0: the 6-DoF derivative is the planar one (Eq. 1–3,
    /// δ̇ = χ) mapped through [`planar_state`]'s chain rule, and nothing
    /// leaves the plane. With a wind along x too.
    #[test]
    fn the_planar_model_is_a_special_case() {
        let mut rng = ChaCha8Rng::seed_from_u64(38);
        let mut scenario = Scenario::paper();
        scenario.environment.wind_x_mps = 7.0;
        let six = SixDof::new(&scenario.vehicle, &scenario.environment);
        for _ in 0..200 {
            let y: [f64; 8] = [
                rng.gen_range(-300.0..300.0),
                rng.gen_range(10.0..800.0),
                rng.gen_range(-60.0..60.0),
                rng.gen_range(-90.0..0.0),
                rng.gen_range(-3.0..3.0),
                rng.gen_range(-0.6..0.6),
                rng.gen_range(90_000.0..120_000.0),
                rng.gen_range(-0.35..0.35),
            ];
            let (thrust, chi) = (rng.gen_range(0.88e6..2.21e6), rng.gen_range(-0.3..0.3));
            let p = rhs_physical(
                &six.planar,
                &[y[0], y[1], y[2], y[3], y[4], y[5], y[6]],
                thrust,
                y[7],
            );
            let f = rhs(&six, &planar_state(&y), &[thrust, chi, 0.0]);
            let half = 0.5 * y[4];
            let mut want = [0.0; NX];
            want[sx::X] = p[0];
            want[sx::Z] = p[1];
            want[sx::VX] = p[2];
            want[sx::VZ] = p[3];
            want[sx::Q] = -0.5 * half.sin() * p[4];
            want[sx::Q + 2] = -0.5 * half.cos() * p[4];
            want[sx::W + 1] = -p[5];
            want[sx::M] = p[6];
            want[sx::DELTA] = chi;
            for i in 0..NX {
                let scale = want[i].abs().max(1e-3);
                assert!(
                    (f[i] - want[i]).abs() <= 1e-10 * scale,
                    "slot {i}: {} against {} at {y:?}",
                    f[i],
                    want[i]
                );
            }
        }
    }

    /// The dual-number Jacobian against central differences, out of the
    /// plane.
    #[test]
    fn jacobian_matches_finite_differences() {
        let model = paper();
        let mut rng = ChaCha8Rng::seed_from_u64(39);
        for _ in 0..20 {
            let (s, u) = (random_state(&mut rng), random_control(&mut rng));
            let (f, jac) = jacobian(&model, &s, &u);
            let plain = rhs(&model, &s, &u);
            for r in 0..NX {
                assert!((f[r] - plain[r]).abs() <= 1e-14 * plain[r].abs().max(1.0));
            }
            for c in 0..NX + NU {
                let (mut sp, mut sm, mut up, mut um) = (s, s, u, u);
                let h = 1e-6
                    * if c < NX {
                        s[c].abs().max(1.0)
                    } else {
                        u[c - NX].abs().max(1.0)
                    };
                if c < NX {
                    sp[c] += h;
                    sm[c] -= h;
                } else {
                    up[c - NX] += h;
                    um[c - NX] -= h;
                }
                let (fp, fm) = (rhs(&model, &sp, &up), rhs(&model, &sm, &um));
                for r in 0..NX {
                    let fd = (fp[r] - fm[r]) / (2.0 * h);
                    let tol = 1e-6 * (jac[r][c].abs() + fd.abs()).max(1e-6);
                    // Central differences of O(1e3) values at h ~ 1e-6·|s|
                    // carry ~1e-9 of rounding: an absolute floor for the
                    // entries that are zero.
                    let tol = tol.max(1e-8);
                    assert!(
                        (jac[r][c] - fd).abs() <= tol,
                        "∂f{r}/∂{c}: {} against {fd}",
                        jac[r][c]
                    );
                }
            }
        }
    }

    /// The term-by-term Jacobian is the whole-f dual pass's, to rounding,
    /// in and out of the plane, and its f is [`rhs`]'s exactly.
    #[test]
    fn the_closed_form_jacobian_is_the_dual_one() {
        let model = paper();
        let mut rng = ChaCha8Rng::seed_from_u64(41);
        for _ in 0..50 {
            let (s, u) = (random_state(&mut rng), random_control(&mut rng));
            let (f, jac) = jacobian(&model, &s, &u);
            let (f_ref, jac_ref) = jacobian_by_duals(&model, &s, &u);
            assert_eq!(f, rhs(&model, &s, &u));
            for r in 0..NX {
                assert!((f[r] - f_ref[r]).abs() <= 1e-14 * f_ref[r].abs().max(1.0));
                let size = jac_ref[r].iter().fold(1.0_f64, |a, v| a.max(v.abs()));
                for c in 0..NX + NU {
                    assert!(
                        (jac[r][c] - jac_ref[r][c]).abs() <= 1e-12 * size,
                        "∂f{r}/∂{c}: {} against {}",
                        jac[r][c],
                        jac_ref[r][c]
                    );
                }
            }
        }
    }

    /// Neither the engine nor the drag has a roll moment: ω̇_z = 0.
    #[test]
    fn the_roll_rate_is_conserved() {
        let model = paper();
        let mut rng = ChaCha8Rng::seed_from_u64(40);
        for _ in 0..200 {
            let (s, u) = (random_state(&mut rng), random_control(&mut rng));
            let f = rhs(&model, &s, &u);
            let scale = f[sx::W].abs() + f[sx::W + 1].abs();
            assert!(
                f[sx::W + 2].abs() <= 1e-14 * scale.max(1.0),
                "{}",
                f[sx::W + 2]
            );
        }
    }

    /// A state turned about the vertical by ψ (position, velocity and the
    /// attitude, q → q_ψ ⊗ q; body rates, mass and gimbal unchanged) has
    /// the derivative turned likewise, in still air.
    #[test]
    fn turning_about_the_vertical_turns_the_derivative() {
        let model = paper();
        let mut rng = ChaCha8Rng::seed_from_u64(41);
        for _ in 0..50 {
            let (s, u) = (random_state(&mut rng), random_control(&mut rng));
            let psi: f64 = rng.gen_range(-3.0..3.0);
            let (sn, cs) = psi.sin_cos();
            let turn = |v: [f64; 3]| [cs * v[0] - sn * v[1], sn * v[0] + cs * v[1], v[2]];
            // q_ψ ⊗ q with q_ψ = (cos ψ/2, 0, 0, sin ψ/2).
            let (a, b) = ((0.5 * psi).cos(), (0.5 * psi).sin());
            let turn_q = |q: [f64; 4]| {
                [
                    a * q[0] - b * q[3],
                    a * q[1] - b * q[2],
                    a * q[2] + b * q[1],
                    a * q[3] + b * q[0],
                ]
            };
            let turn_state = |s: &[f64; NX]| {
                let mut t = *s;
                for base in [sx::X, sx::VX] {
                    let v = turn([s[base], s[base + 1], s[base + 2]]);
                    t[base..base + 3].copy_from_slice(&v);
                }
                let q = turn_q([s[sx::Q], s[sx::Q + 1], s[sx::Q + 2], s[sx::Q + 3]]);
                t[sx::Q..sx::Q + 4].copy_from_slice(&q);
                t
            };
            let f = rhs(&model, &s, &u);
            let g = rhs(&model, &turn_state(&s), &u);
            let want = turn_state(&f);
            for i in 0..NX {
                let scale = want[i].abs().max(1.0);
                assert!(
                    (g[i] - want[i]).abs() <= 1e-9 * scale,
                    "slot {i}: {} against {}",
                    g[i],
                    want[i]
                );
            }
        }
    }

    /// Flown by RK4 at 10 ms for 10 s under varying controls (the body
    /// rates reach 2.3 rad/s), the kinematics alone (κ = 0) keep |q| = 1 to
    /// 1e-11; the pull, evaluated at RK4's stages (whose |q| is off by
    /// O(h²ω²)), moves it by 4e-10, still far below any tolerance. Started
    /// at |q| = 1.01, the pull brings it back to 1 (to 1e-6 in 10 s:
    /// e^{−2κt}), where the kinematics alone keep it at 1.01. The pull is
    /// for the collocation, whose nodes cannot all be held at |q| = 1.
    #[test]
    fn the_quaternion_keeps_its_norm() {
        let fly = |model: &SixDof, mut s: [f64; NX]| {
            let mut rng = ChaCha8Rng::seed_from_u64(43);
            let h = 0.01;
            for _ in 0..1000 {
                let u = random_control(&mut rng);
                let k1 = rhs(model, &s, &u);
                let at = |k: &[f64; NX], c: f64| std::array::from_fn(|i| s[i] + c * k[i]);
                let k2 = rhs(model, &at(&k1, 0.5 * h), &u);
                let k3 = rhs(model, &at(&k2, 0.5 * h), &u);
                let k4 = rhs(model, &at(&k3, h), &u);
                for i in 0..NX {
                    s[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
                }
            }
            s
        };
        let drift =
            |s: &[f64; NX]| ((0..4).map(|i| s[sx::Q + i].powi(2)).sum::<f64>().sqrt() - 1.0).abs();
        let pulled = paper();
        let free = SixDof {
            norm_gain_per_s: 0.0,
            ..paper()
        };
        let mut s = random_state(&mut ChaCha8Rng::seed_from_u64(42));
        s[sx::W..sx::W + 3].copy_from_slice(&[0.3, -0.2, 0.1]);
        let (with, without) = (drift(&fly(&pulled, s)), drift(&fly(&free, s)));
        assert!(
            without < 1e-11 && with < 1e-9,
            "{with:e}, {without:e} without the pull"
        );
        let mut off = s;
        for i in 0..4 {
            off[sx::Q + i] *= 1.01;
        }
        let (with, without) = (drift(&fly(&pulled, off)), drift(&fly(&free, off)));
        assert!(with < 1e-6, "{with:e}");
        assert!((without - 0.01).abs() < 1e-9, "{without:e}");
    }
}
