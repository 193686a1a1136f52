//! The seam between a vehicle model and the rooms that use it (issue 38):
//! what a transcription needs to know of a model, designed against both
//! models that the crate has, the planar P2 form of the paper
//! ([`crate::problem::dynamics`], Eq. 8) and its lift to 3-D
//! ([`crate::problem::six_dof`]).
//!
//! A model is a state x ∈ ℝ^NX and a control u ∈ ℝ^NU with
//! - ẋ = f(x, u), generic over the dual-number type ([`Dynamics::rhs`]), so
//!   that one code path gives values and exact derivatives;
//! - the inputs of (x, u) that enter f nonlinearly ([`Dynamics::NONLINEAR`]):
//!   a transcription differentiates only these, and adds the linear ones
//!   (ẋ = V, θ̇ = w, δ̇ = χ) by hand;
//! - box bounds on each state and control, and nonlinear path rows
//!   g(x, u) ≤ 0 beyond the boxes (the gimbal's cone and the rate's disc in
//!   3-D; none in the plane, where |δ| ≤ δ_max and |χ| ≤ χ_max are boxes);
//! - the landing: the slots fixed at t_f (in 3-D, the body axis vertical
//!   and up is q1 = q2 = 0: [`SixDof`]'s `terminal_fixed`, so no terminal
//!   rows are needed);
//! - a field table, one entry per state and control (name, unit, meaning),
//!   from which the outputs are to take their names;
//! - the slots that every method treats specially: the altitude (the
//!   ground), the mass (the objective) and the thrust.
//!
//! The vector layout is (x, u) concatenated: input `i < NX` is state `i`,
//! input `NX + j` is control `j`. The direct method's node slots
//! ([`crate::method::direct::nlp::slot`]) already follow it.
//!
//! Sizes are associated constants, not type parameters: a room that needs
//! arrays of a model's size takes them as const parameters and checks them
//! against the model's constants ([`check_sizes`]), so that the planar
//! paths stay monomorphised over fixed arrays and bit-identical.

use num_dual::{Dual64, DualNum};

use crate::input::scenario::TerminalState;
use crate::problem::dynamics::{self, ix, Model};
use crate::problem::six_dof::{self, su, sx, SixDof};

/// One component of a model's state or control vector: the names that the
/// JSON, the CSV and Python are to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Field {
    /// The output name, with its unit as suffix (`vz_mps`).
    pub name: &'static str,
    /// The SI unit.
    pub unit: &'static str,
    /// What it is, in a few words.
    pub meaning: &'static str,
}

const fn field(name: &'static str, unit: &'static str, meaning: &'static str) -> Field {
    Field {
        name,
        unit,
        meaning,
    }
}

/// A vehicle model as the transcriptions see it (module docs).
pub trait Dynamics {
    /// Number of states.
    const NX: usize;
    /// Number of controls.
    const NU: usize;
    /// The state's field table, NX entries.
    const STATE: &'static [Field];
    /// The control's field table, NU entries.
    const CONTROL: &'static [Field];
    /// The inputs of (x, u) that enter f nonlinearly, ascending.
    const NONLINEAR: &'static [usize];
    /// The state slot of the altitude above the pad's plane, z \[m\].
    const ALTITUDE: usize;
    /// The state slot of the mass \[kg\].
    const MASS: usize;
    /// The control slot of the thrust magnitude \[N\].
    const THRUST: usize;
    /// Number of path rows g(x, u) ≤ 0 beyond the boxes.
    const PATH_ROWS: usize;
    /// The inputs of (x, u) that each path row depends on (PATH_ROWS
    /// lists), so that a transcription holds a row at a node only where one
    /// of them is free. Every path row is convex, and holds strictly at
    /// zero inputs (g < 0 there): a start is brought inside a row by
    /// scaling its inputs toward zero.
    const PATH_ROW_INPUTS: &'static [&'static [usize]];

    /// ẋ = f(x, u) into `dx` (x: NX, u: NU, dx: NX).
    fn rhs<D: DualNum<Primitive = f64> + Copy>(&self, x: &[D], u: &[D], dx: &mut [D]);

    /// The box (lo, hi) of state `i`, physical units (±∞ where free).
    fn state_box(&self, i: usize) -> (f64, f64);

    /// The box (lo, hi) of control `j`, physical units.
    fn control_box(&self, j: usize) -> (f64, f64);

    /// The path rows g(x, u) ≤ 0, each of order one at its limit.
    fn path_rows<D: DualNum<Primitive = f64> + Copy>(&self, x: &[D], u: &[D], g: &mut [D]);

    /// The value that the landing fixes state `i` to, if it does.
    fn terminal_fixed(&self, target: &TerminalState, i: usize) -> Option<f64>;

    /// f and its Jacobian ∂f/∂(x, u), row-major NX × (NX + NU), by one
    /// forward-mode dual pass per input. A room that needs it fast
    /// specialises (the planar model has hand-written Jacobians).
    fn jacobian(&self, x: &[f64], u: &[f64], f: &mut [f64], jac: &mut [f64]) {
        let (nx, nu) = (Self::NX, Self::NU);
        let mut xd: Vec<Dual64> = x.iter().map(|&v| Dual64::from_re(v)).collect();
        let mut ud: Vec<Dual64> = u.iter().map(|&v| Dual64::from_re(v)).collect();
        let mut out = vec![Dual64::from_re(0.0); nx];
        for c in 0..nx + nu {
            let seed = |d: &mut Dual64, on: bool| d.eps = if on { 1.0 } else { 0.0 };
            xd.iter_mut().enumerate().for_each(|(i, d)| seed(d, i == c));
            ud.iter_mut()
                .enumerate()
                .for_each(|(j, d)| seed(d, nx + j == c));
            self.rhs(&xd, &ud, &mut out);
            for r in 0..nx {
                jac[r * (nx + nu) + c] = out[r].eps;
            }
        }
        for r in 0..nx {
            f[r] = out[r].re;
        }
    }
}

/// Checks at compile time (on monomorphisation) that a room's array sizes
/// are the model's: `const { check_sizes::<M, NX, NU>() }`.
pub const fn check_sizes<M: Dynamics, const NX: usize, const NU: usize>() {
    assert!(
        M::NX == NX && M::NU == NU,
        "array sizes differ from the model's"
    );
}

// ---------------------------------------------------------------------------
// The planar model, P2 (Eq. 8)
// ---------------------------------------------------------------------------

/// The planar state's fields: the names of the solution's node arrays
/// ([`crate::solution::STATE_COLUMN_NAMES`] is built from them).
pub const PLANAR_STATE: [Field; dynamics::NX] = [
    field("x_m", "m", "downrange position"),
    field("z_m", "m", "altitude"),
    field("vx_mps", "m/s", "downrange velocity"),
    field("vz_mps", "m/s", "vertical velocity"),
    field("theta_rad", "rad", "pitch from the vertical"),
    field("pitch_rate_radps", "rad/s", "pitch rate"),
    field("mass_kg", "kg", "mass"),
    field("delta_rad", "rad", "gimbal angle δ"),
];

const PLANAR_CONTROL: [Field; 2] = [
    field("thrust_n", "N", "thrust"),
    field("gimbal_rate_radps", "rad/s", "gimbal rate χ = δ̇"),
];

/// The planar model in the augmented form P2 (Eq. 8): state (x, z, Vx, Vz,
/// θ, w, m, δ) ([`ix`], with m in ω's slot), control (T, χ).
impl Dynamics for Model {
    const NX: usize = dynamics::NX;
    const NU: usize = 2;
    const STATE: &'static [Field] = &PLANAR_STATE;
    const CONTROL: &'static [Field] = &PLANAR_CONTROL;
    const NONLINEAR: &'static [usize] = &[ix::VX, ix::VZ, ix::THETA, ix::M, ix::DELTA, 8];
    const ALTITUDE: usize = ix::Z;
    const MASS: usize = ix::M;
    const THRUST: usize = 0;
    const PATH_ROWS: usize = 0;
    const PATH_ROW_INPUTS: &'static [&'static [usize]] = &[];

    fn rhs<D: DualNum<Primitive = f64> + Copy>(&self, x: &[D], u: &[D], dx: &mut [D]) {
        let s: [D; 8] = std::array::from_fn(|i| x[i]);
        dx[..8].copy_from_slice(&dynamics::rhs_augmented(self, &s, u[0], u[1]));
    }

    fn state_box(&self, i: usize) -> (f64, f64) {
        match i {
            ix::M => (self.dry_mass_kg, f64::INFINITY),
            ix::DELTA => (-self.max_gimbal_rad, self.max_gimbal_rad),
            _ => (f64::NEG_INFINITY, f64::INFINITY),
        }
    }

    fn control_box(&self, j: usize) -> (f64, f64) {
        match j {
            0 => (self.min_thrust_n, self.max_thrust_n),
            _ => (-self.max_gimbal_rate_radps, self.max_gimbal_rate_radps),
        }
    }

    fn path_rows<D: DualNum<Primitive = f64> + Copy>(&self, _: &[D], _: &[D], _: &mut [D]) {}

    fn terminal_fixed(&self, t: &TerminalState, i: usize) -> Option<f64> {
        match i {
            ix::X => Some(t.x_m),
            ix::Z => Some(t.z_m),
            ix::VX => Some(t.vx_mps),
            ix::VZ => Some(t.vz_mps),
            ix::THETA => Some(t.theta_deg.to_radians()),
            ix::W => Some(t.pitch_rate_degps.to_radians()),
            _ => None,
        }
    }
}

// ---------------------------------------------------------------------------
// The 6-DoF model
// ---------------------------------------------------------------------------

const SIX_DOF_STATE: [Field; six_dof::NX] = [
    field("x_m", "m", "downrange position"),
    field("y_m", "m", "cross-range position"),
    field("z_m", "m", "altitude"),
    field("vx_mps", "m/s", "downrange velocity"),
    field("vy_mps", "m/s", "cross-range velocity"),
    field("vz_mps", "m/s", "vertical velocity"),
    field(
        "q0",
        "1",
        "attitude quaternion, scalar part (body to inertial)",
    ),
    field("q1", "1", "attitude quaternion, x part"),
    field("q2", "1", "attitude quaternion, y part"),
    field("q3", "1", "attitude quaternion, z part"),
    field("wx_radps", "rad/s", "body rate about the body x axis"),
    field("wy_radps", "rad/s", "body rate about the body y axis"),
    field("wz_radps", "rad/s", "roll rate, about the body axis"),
    field("mass_kg", "kg", "mass"),
    field(
        "delta1_rad",
        "rad",
        "gimbal angle δ1, in the body x–z plane",
    ),
    field("delta2_rad", "rad", "gimbal angle δ2, out of that plane"),
];

const SIX_DOF_CONTROL: [Field; six_dof::NU] = [
    field("thrust_n", "N", "thrust"),
    field("gimbal_rate1_radps", "rad/s", "χ1 = δ̇1"),
    field("gimbal_rate2_radps", "rad/s", "χ2 = δ̇2"),
];

/// The 6-DoF model ([`six_dof`]): the nozzle held in a cone of δ_max about
/// the body axis (its angle from it, arccos(cos δ1·cos δ2), at most δ_max)
/// and the gimbal rate in a disc of χ_max, each row scaled to order one; the landing at the planar target (y = V_y = 0), at rest,
/// with the body axis vertical and up (R₁₃ = R₂₃ = 0, R₃₃ > 0), the pitch
/// and yaw rates zero and the roll free.
impl Dynamics for SixDof {
    const NX: usize = six_dof::NX;
    const NU: usize = six_dof::NU;
    const STATE: &'static [Field] = &SIX_DOF_STATE;
    const CONTROL: &'static [Field] = &SIX_DOF_CONTROL;
    const NONLINEAR: &'static [usize] = &[
        sx::VX,
        sx::VY,
        sx::VZ,
        sx::Q,
        sx::Q + 1,
        sx::Q + 2,
        sx::Q + 3,
        sx::W,
        sx::W + 1,
        sx::W + 2,
        sx::M,
        sx::DELTA,
        sx::DELTA + 1,
        six_dof::NX + su::T,
    ];
    const ALTITUDE: usize = sx::Z;
    const MASS: usize = sx::M;
    const THRUST: usize = su::T;
    const PATH_ROWS: usize = 2;
    const PATH_ROW_INPUTS: &'static [&'static [usize]] = &[
        &[sx::DELTA, sx::DELTA + 1],
        &[six_dof::NX + su::CHI, six_dof::NX + su::CHI + 1],
    ];

    fn rhs<D: DualNum<Primitive = f64> + Copy>(&self, x: &[D], u: &[D], dx: &mut [D]) {
        let s: [D; six_dof::NX] = std::array::from_fn(|i| x[i]);
        let c: [D; six_dof::NU] = std::array::from_fn(|j| u[j]);
        dx[..six_dof::NX].copy_from_slice(&six_dof::rhs(self, &s, &c));
    }

    fn state_box(&self, i: usize) -> (f64, f64) {
        let p = &self.planar;
        match i {
            sx::M => (p.dry_mass_kg, f64::INFINITY),
            // The boxes that the cone lies in.
            i if i == sx::DELTA || i == sx::DELTA + 1 => (-p.max_gimbal_rad, p.max_gimbal_rad),
            _ => (f64::NEG_INFINITY, f64::INFINITY),
        }
    }

    fn control_box(&self, j: usize) -> (f64, f64) {
        let p = &self.planar;
        match j {
            su::T => (p.min_thrust_n, p.max_thrust_n),
            _ => (-p.max_gimbal_rate_radps, p.max_gimbal_rate_radps),
        }
    }

    /// g₀ = (cos δ_max − cos δ1·cos δ2)/(1 − cos δ_max) (the nozzle's
    /// angle from the body axis, the third component of
    /// [`six_dof::thrust_direction`]) and g₁ = (χ1² + χ2²)/χ_max² − 1. In
    /// the plane (δ2 = 0) g₀ ≤ 0 is |δ1| ≤ δ_max.
    fn path_rows<D: DualNum<Primitive = f64> + Copy>(&self, x: &[D], u: &[D], g: &mut [D]) {
        let p = &self.planar;
        let (d1, d2) = (x[sx::DELTA], x[sx::DELTA + 1]);
        let (c1, c2) = (u[su::CHI], u[su::CHI + 1]);
        let cos_max = p.max_gimbal_rad.cos();
        g[0] = (-(d1.cos() * d2.cos()) + cos_max) / (1.0 - cos_max);
        g[1] = (c1 * c1 + c2 * c2) / (p.max_gimbal_rate_radps * p.max_gimbal_rate_radps) - 1.0;
    }

    fn terminal_fixed(&self, t: &TerminalState, i: usize) -> Option<f64> {
        match i {
            sx::X => Some(t.x_m),
            sx::Y => Some(0.0),
            sx::Z => Some(t.z_m),
            sx::VX => Some(t.vx_mps),
            sx::VY => Some(0.0),
            sx::VZ => Some(t.vz_mps),
            // The body axis vertical and up (above).
            i if i == sx::Q + 1 || i == sx::Q + 2 => Some(0.0),
            // Pitch and yaw rates; the roll rate ω_z is free.
            i if i == sx::W || i == sx::W + 1 => Some(0.0),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;

    fn planar() -> Model {
        let s = Scenario::paper();
        Model::new(&s.vehicle, &s.environment)
    }

    fn six_dof() -> SixDof {
        let s = Scenario::paper();
        let mut m = SixDof::new(&s.vehicle, &s.environment);
        m.wind_mps = [3.0, -2.0, 0.5];
        m
    }

    /// A seeded point of (x, u) of order the envelope's, by a small LCG.
    fn point<M: Dynamics>(seed: u64, base: &[f64]) -> Vec<f64> {
        let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
        base.iter()
            .map(|&b| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let r = (state >> 11) as f64 / (1u64 << 53) as f64;
                b * (1.0 + 0.2 * (r - 0.5)) + 0.05 * (r - 0.5)
            })
            .take(M::NX + M::NU)
            .collect()
    }

    fn planar_base() -> Vec<f64> {
        vec![
            -50.0, 400.0, 10.0, -80.0, 1.2, -0.2, 110_000.0, 0.1, 6.0e6, 0.05,
        ]
    }

    fn six_dof_base() -> Vec<f64> {
        vec![
            -50.0, 30.0, 400.0, 10.0, -4.0, -80.0, 0.8, 0.1, -0.55, 0.05, 0.02, -0.2, 0.03,
            110_000.0, 0.1, -0.05, 6.0e6, 0.05, -0.04,
        ]
    }

    /// The trait's Jacobian against central differences of its rhs.
    fn jacobian_matches_differences<M: Dynamics>(m: &M, base: &[f64]) {
        let n = M::NX + M::NU;
        for seed in 0..5 {
            let p = point::<M>(seed, base);
            let (x, u) = p.split_at(M::NX);
            let mut f = vec![0.0; M::NX];
            let mut jac = vec![0.0; M::NX * n];
            m.jacobian(x, u, &mut f, &mut jac);
            let eval = |p: &[f64]| {
                let mut out = vec![0.0; M::NX];
                m.rhs(&p[..M::NX], &p[M::NX..], &mut out);
                out
            };
            for (a, b) in f.iter().zip(eval(&p)) {
                assert!((a - b).abs() <= 1e-14 * b.abs(), "{a} against {b}");
            }
            for c in 0..n {
                let h = 1e-6 * p[c].abs().max(1e-2);
                let (mut up, mut dn) = (p.clone(), p.clone());
                up[c] += h;
                dn[c] -= h;
                let (fu, fd) = (eval(&up), eval(&dn));
                for r in 0..M::NX {
                    let fdv = (fu[r] - fd[r]) / (2.0 * h);
                    let scale = 1.0 + jac[r * n + c].abs();
                    assert!(
                        (fdv - jac[r * n + c]).abs() < 1e-6 * scale,
                        "{}: ∂f{r}/∂{c} = {} against {fdv}",
                        M::STATE[r].name,
                        jac[r * n + c]
                    );
                }
            }
        }
    }

    /// f is affine in every input outside NONLINEAR: its Jacobian does not
    /// move when that input does.
    fn nonlinear_inputs_are_complete<M: Dynamics>(m: &M, base: &[f64]) {
        let n = M::NX + M::NU;
        let p = point::<M>(7, base);
        let jac_at = |p: &[f64]| {
            let (mut f, mut jac) = (vec![0.0; M::NX], vec![0.0; M::NX * n]);
            m.jacobian(&p[..M::NX], &p[M::NX..], &mut f, &mut jac);
            jac
        };
        let j0 = jac_at(&p);
        for c in (0..n).filter(|c| !M::NONLINEAR.contains(c)) {
            let mut q = p.clone();
            q[c] += 0.5 * (1.0 + q[c].abs());
            let j1 = jac_at(&q);
            for (a, b) in j0.iter().zip(&j1) {
                assert!((a - b).abs() <= 1e-12 * (1.0 + a.abs()), "input {c}");
            }
        }
        // And each listed input does move it somewhere.
        for &c in M::NONLINEAR {
            let mut q = p.clone();
            q[c] += 0.1 * (1.0 + q[c].abs());
            let j1 = jac_at(&q);
            assert!(j0.iter().zip(&j1).any(|(a, b)| a != b), "input {c}");
        }
    }

    /// Each path row depends on the inputs that PATH_ROW_INPUTS lists and
    /// on no other (a row held where none of them is free would be a
    /// constant; one held where an unlisted input moves would be missed),
    /// and holds strictly at zero inputs, where a start is pushed.
    fn path_row_inputs_are_exact<M: Dynamics>(m: &M, base: &[f64]) {
        let n = M::NX + M::NU;
        assert_eq!(M::PATH_ROW_INPUTS.len(), M::PATH_ROWS);
        let rows = |p: &[f64]| {
            let mut g = vec![0.0; M::PATH_ROWS];
            m.path_rows(&p[..M::NX], &p[M::NX..], &mut g);
            g
        };
        let p = point::<M>(11, base);
        let g0 = rows(&p);
        for c in 0..n {
            let mut q = p.clone();
            q[c] += 0.05 * (1.0 + q[c].abs());
            let g1 = rows(&q);
            for (r, inputs) in M::PATH_ROW_INPUTS.iter().enumerate() {
                assert_eq!(g0[r] != g1[r], inputs.contains(&c), "row {r}, input {c}");
            }
        }
        let mut zero = p.clone();
        for &c in M::PATH_ROW_INPUTS.iter().flat_map(|r| r.iter()) {
            zero[c] = 0.0;
        }
        assert!(rows(&zero).iter().all(|&g| g < 0.0));
    }

    fn tables_are_whole<M: Dynamics>() {
        assert_eq!(M::STATE.len(), M::NX);
        assert_eq!(M::CONTROL.len(), M::NU);
        let mut names: Vec<_> = M::STATE.iter().chain(M::CONTROL).map(|f| f.name).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), M::NX + M::NU, "names are unique");
        assert!(M::NONLINEAR.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(M::STATE[M::ALTITUDE].name, "z_m");
        assert_eq!(M::STATE[M::MASS].name, "mass_kg");
        assert_eq!(M::CONTROL[M::THRUST].name, "thrust_n");
    }

    #[test]
    fn both_models_have_exact_jacobians() {
        jacobian_matches_differences(&planar(), &planar_base());
        jacobian_matches_differences(&six_dof(), &six_dof_base());
    }

    #[test]
    fn both_models_name_their_nonlinear_inputs() {
        nonlinear_inputs_are_complete(&planar(), &planar_base());
        nonlinear_inputs_are_complete(&six_dof(), &six_dof_base());
    }

    #[test]
    fn both_models_name_their_path_rows_inputs() {
        path_row_inputs_are_exact(&planar(), &planar_base());
        path_row_inputs_are_exact(&six_dof(), &six_dof_base());
    }

    #[test]
    fn both_field_tables_are_whole() {
        tables_are_whole::<Model>();
        tables_are_whole::<SixDof>();
    }

    /// The planar model through the trait is the planar rhs, and the 6-DoF
    /// model through the trait on a planar state is it too (the special
    /// case), with the same bounds.
    #[test]
    fn the_planar_model_is_a_special_case_through_the_seam() {
        let (p, s) = (
            planar(),
            SixDof::new(&Scenario::paper().vehicle, &Scenario::paper().environment),
        );
        for seed in 0..20 {
            let v = point::<Model>(seed, &planar_base());
            let mut fp = [0.0; 8];
            p.rhs(&v[..8], &v[8..], &mut fp);
            let y: [f64; 8] = std::array::from_fn(|i| v[i]);
            assert_eq!(fp, dynamics::rhs_augmented(&p, &y, v[8], v[9]));
            let mut f6 = [0.0; six_dof::NX];
            s.rhs(&six_dof::planar_state(&y), &[v[8], v[9], 0.0], &mut f6);
            let lifted = six_dof::planar_state(&y);
            // Rates of the planar slots: the positions, velocities, pitch
            // rate, mass and gimbal.
            let pairs = [
                (ix::X, sx::X),
                (ix::Z, sx::Z),
                (ix::VX, sx::VX),
                (ix::VZ, sx::VZ),
                (ix::M, sx::M),
                (ix::DELTA, sx::DELTA),
            ];
            for (a, b) in pairs {
                assert!(
                    (fp[a] - f6[b]).abs() <= 1e-9 * (1.0 + fp[a].abs()),
                    "slot {a}"
                );
            }
            assert!((fp[ix::W] + f6[sx::W + 1]).abs() <= 1e-9 * (1.0 + fp[ix::W].abs()));
            assert_eq!(f6[sx::Y], 0.0);
            assert_eq!(lifted[sx::Y], 0.0);
        }
        for i in 0..8 {
            let j = [
                sx::X,
                sx::Z,
                sx::VX,
                sx::VZ,
                sx::Q,
                sx::W + 1,
                sx::M,
                sx::DELTA,
            ][i];
            if i != ix::THETA && i != ix::W {
                assert_eq!(p.state_box(i), s.state_box(j), "state {i}");
            }
        }
        assert_eq!(p.control_box(0), s.control_box(su::T));
        assert_eq!(p.control_box(1), s.control_box(su::CHI));
    }

    #[test]
    fn the_gimbal_rows_bound_a_cone_and_a_disc() {
        let m = six_dof();
        let d = m.planar.max_gimbal_rad;
        let c = m.planar.max_gimbal_rate_radps;
        let mut x = vec![0.0; six_dof::NX];
        let u = [6.0e6, c * 0.6, c * 0.8];
        let mut g = [1.0; 2];
        // On the cone: the thrust direction δ_max from the body axis.
        for d1 in [0.0, 0.5 * d, -0.9 * d, d] {
            let d2 = (d.cos() / f64::cos(d1)).clamp(-1.0, 1.0).acos();
            x[sx::DELTA] = d1;
            x[sx::DELTA + 1] = d2;
            let dir = six_dof::thrust_direction(d1, d2);
            assert!((dir[2].acos() - d).abs() < 1e-9);
            m.path_rows(&x, &u, &mut g);
            assert!(g[0].abs() < 1e-9 && g[1].abs() < 1e-12, "{g:?}");
        }
        // Inside it and outside it (the boxes' corner).
        x[sx::DELTA] = 0.5 * d;
        x[sx::DELTA + 1] = 0.5 * d;
        m.path_rows(&x, &u, &mut g);
        assert!(g[0] < 0.0);
        x[sx::DELTA] = d;
        x[sx::DELTA + 1] = d;
        m.path_rows(&x, &u, &mut g);
        assert!(g[0] > 0.0);
    }

    /// The body axis R(q)e_z, from the rotation's third column.
    fn body_axis(q: [f64; 4]) -> [f64; 3] {
        let [q0, q1, q2, q3] = q;
        let n2 = q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3;
        [
            2.0 * (q1 * q3 + q0 * q2) / n2,
            2.0 * (q2 * q3 - q0 * q1) / n2,
            (q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3) / n2,
        ]
    }

    /// The landing's fixed slots q1 = q2 = 0 are "the body axis vertical and
    /// up", with the roll free: every quaternion that holds them has the
    /// axis up, seeded quaternions with the axis up hold them, and the
    /// upside-down attitude does not.
    #[test]
    fn the_landing_fixes_upright_and_refuses_upside_down() {
        let m = six_dof();
        let target = Scenario::paper().terminal;
        let fixed = |i: usize| m.terminal_fixed(&target, i);
        assert_eq!((fixed(sx::Q + 1), fixed(sx::Q + 2)), (Some(0.0), Some(0.0)));
        assert_eq!((fixed(sx::Q), fixed(sx::Q + 3)), (None, None));
        for k in 0..50 {
            // Any roll (or yaw) about the vertical, any norm.
            let (a, n) = (0.37 * k as f64 - 9.0, 0.9 + 0.004 * k as f64);
            let axis = body_axis([n * (a / 2.0).cos(), 0.0, 0.0, n * (a / 2.0).sin()]);
            assert!(axis[0].abs() < 1e-15 && axis[1].abs() < 1e-15);
            assert!((axis[2] - 1.0).abs() < 1e-15);
        }
        // Upside down: the axis is vertical (R13 = R23 = 0) but down, and q1
        // is not 0.
        let q = [0.0, 1.0, 0.0, 0.0];
        assert_eq!(body_axis(q), [0.0, 0.0, -1.0]);
        assert_ne!(q[1], 0.0);
        // Tilted by 10° in pitch: q2 is sin 5°, not 0.
        let t = 10f64.to_radians();
        let axis = body_axis([(t / 2.0).cos(), 0.0, (t / 2.0).sin(), 0.0]);
        assert!((axis[0] - t.sin()).abs() < 1e-15);
        // The landing fixes the pitch and yaw rates, not the roll rate.
        assert_eq!(fixed(sx::W + 2), None);
        assert_eq!(fixed(sx::W), Some(0.0));
        assert_eq!(fixed(sx::Y), Some(0.0));
    }
}
