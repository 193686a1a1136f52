//! The 6-DoF problem on a mesh ([`crate::problem::six_dof`], issue 38):
//! the generic [`Transcription`] at its sizes, with the model's own
//! scaling and straight-line guess. The solve is the planar one's
//! ([`crate::method::direct::solve_nlp`]).

use crate::collocation::mesh::Mesh;
use crate::input::scenario::TerminalState;
use crate::input::settings::DirectSettings;
use crate::method::direct::driver::NlpResult;
use crate::method::direct::mesh_transfer::interpolate;
use crate::method::direct::nlp::Transcription;
use crate::method::direct::{solve_nlp, WARM_MU};
use crate::method::observer::Observer;
use crate::problem::model::Dynamics;
use crate::problem::six_dof::{self, su, sx, SixDof};
use crate::solution::Status;

/// States of the 6-DoF model at a node.
pub const NS: usize = six_dof::NX;
/// Local slots per node: the states, the controls (T, χ1, χ2) and the two
/// thrust slacks.
pub const NL: usize = six_dof::NX + six_dof::NU + 2;

/// The 6-DoF problem on a mesh.
pub type Nlp6 = Transcription<SixDof, NS, NL>;

/// The least span of an angle's scale \[rad\], as in the plane.
const MIN_ANGLE_RAD: f64 = 0.1;
/// Time scale of t_f = this × altitude drop / initial speed, as in the
/// plane ([`crate::collocation::scaling`]).
const TIME_SCALE_FACTOR: f64 = 1.7;

/// The body axis's tilt from the vertical \[rad\] of the attitude q: the
/// angle of R(q)·e_z from ẑ, R₃₃ = 1 − 2(q1² + q2²) over |q|².
pub fn tilt_rad(q: &[f64]) -> f64 {
    let n2: f64 = q.iter().map(|v| v * v).sum();
    (1.0 - 2.0 * (q[1] * q[1] + q[2] * q[2]) / n2)
        .clamp(-1.0, 1.0)
        .acos()
}

/// The upright attitude nearest to q: its twist about the vertical,
/// (q0, 0, 0, q3)/|·| (the swing–twist split about e_z), which keeps the
/// start's heading and roll; (1, 0, 0, 0) when q has none (upside down).
pub fn upright_of(q: &[f64]) -> [f64; 4] {
    let n = q[0].hypot(q[3]);
    if n < 1e-12 {
        [1.0, 0.0, 0.0, 0.0]
    } else {
        [q[0] / n, 0.0, 0.0, q[3] / n]
    }
}

impl Nlp6 {
    /// The problem of flying `model` from `x0` to the landing `target` on
    /// `mesh`, scaled to order one as the plane is
    /// ([`crate::collocation::scaling::Scaling::new`], with y beside x and
    /// the tilt from the vertical for θ): positions by the largest span,
    /// velocities by the largest speed, ω by the tilt over a quarter of the
    /// time scale, q by 1, m from m_0 by its fuel span, δ by δ_max, T and
    /// its slacks by T_max, χ by χ_max.
    pub fn six_dof(model: SixDof, mesh: Mesh, x0: [f64; NS], target: &TerminalState) -> Self {
        let p = &model.planar;
        let length = (x0[sx::X] - target.x_m)
            .abs()
            .max(x0[sx::Y].abs())
            .max((x0[sx::Z] - target.z_m).abs())
            .max(1.0);
        let v0 = (x0[sx::VX].powi(2) + x0[sx::VY].powi(2) + x0[sx::VZ].powi(2)).sqrt();
        let vf = target.vx_mps.hypot(target.vz_mps);
        let speed = v0.max(vf).max(1.0);
        let drop = (x0[sx::Z] - target.z_m).abs().max(1.0);
        let tf_scale = TIME_SCALE_FACTOR * drop / v0.max((p.g0_mps2 * drop).sqrt());
        let angle = tilt_rad(&x0[sx::Q..sx::Q + 4]).max(MIN_ANGLE_RAD);
        let rate = angle / (0.25 * tf_scale);
        let mut offset = [0.0; NL];
        let mut scale = [1.0; NL];
        for s in [sx::X, sx::Y, sx::Z] {
            scale[s] = length;
        }
        for s in [sx::VX, sx::VY, sx::VZ] {
            scale[s] = speed;
        }
        for s in sx::W..sx::W + 3 {
            scale[s] = rate;
        }
        offset[sx::M] = x0[sx::M];
        scale[sx::M] = x0[sx::M] - p.dry_mass_kg;
        scale[sx::DELTA] = p.max_gimbal_rad;
        scale[sx::DELTA + 1] = p.max_gimbal_rad;
        for s in [NS + su::T, Self::ABOVE, Self::BELOW] {
            scale[s] = p.max_thrust_n;
        }
        scale[NS + su::CHI] = p.max_gimbal_rate_radps;
        scale[NS + su::CHI + 1] = p.max_gimbal_rate_radps;
        let mut nlp = Transcription::empty(model, mesh, target.clone());
        nlp.set_problem((offset, scale, tf_scale), x0, target);
        nlp
    }

    /// The straight-line guess, as the IPOPT reference's
    /// (`bench/reference/nlp_6dof.py`): states linear in τ from x_0 to the
    /// landing (its fixed slots; q to [`upright_of`] the start's, ω and δ
    /// to zero, the mass to `final_mass_kg`), q normalised at each node,
    /// T = (T_min + T_max)/2, χ = 0, t_f = `tf_s`. Scaled.
    pub fn straight_line(&self, tf_s: f64, final_mass_kg: f64) -> Vec<f64> {
        let x0 = &self.x0;
        let mut end = [0.0; NS];
        for (s, e) in end.iter_mut().enumerate() {
            *e = self.model.terminal_fixed(&self.target, s).unwrap_or(0.0);
        }
        let up = upright_of(&x0[sx::Q..sx::Q + 4]);
        end[sx::Q..sx::Q + 4].copy_from_slice(&up);
        end[sx::M] = final_mass_kg;
        let thrust = 0.5 * (self.model.planar.min_thrust_n + self.model.planar.max_thrust_n);
        let mut w = vec![0.0; self.n_var()];
        for (k, &tau) in self.mesh.nodes.iter().enumerate() {
            let a = 0.5 * (tau + 1.0);
            let mut x: [f64; NS] = std::array::from_fn(|s| x0[s] + a * (end[s] - x0[s]));
            let q = &mut x[sx::Q..sx::Q + 4];
            let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
            q.iter_mut().for_each(|v| *v /= n);
            for (s, v) in x.iter().enumerate() {
                w[self.idx(k, s)] = (v - self.offset[s]) / self.scale[s];
            }
            if k < self.n {
                let t = NS + su::T;
                w[self.idx(k, t)] = (thrust - self.offset[t]) / self.scale[t];
            }
        }
        let tf = self.tf_idx();
        w[tf] = tf_s / self.tf_scale;
        w
    }
}

/// The cold solve of a 6-DoF problem, in the planar cold solve's phases
/// ([`crate::method::direct::cold`]): when the mesh has at least twice
/// `settings.coarse_nodes` points, first a global mesh of that many from
/// the straight line to `settings.coarse_tolerance`, then `nlp`'s mesh from
/// its answer at μ_0 = [`WARM_MU`]; from the straight line when there is no
/// coarse phase or its fine phase fails. The iterations of every phase are
/// in the result's history.
pub fn solve_cold(
    nlp: &Nlp6,
    tf_guess_s: f64,
    final_mass_guess_kg: f64,
    settings: &DirectSettings,
    observer: &mut dyn Observer,
) -> NlpResult {
    let straight = |nlp: &Nlp6, settings: &DirectSettings, observer: &mut dyn Observer| {
        let w0 = nlp.straight_line(tf_guess_s, final_mass_guess_kg);
        solve_nlp(nlp, &w0, None, settings, observer)
    };
    let coarse_nodes = settings.coarse_nodes;
    if coarse_nodes < 4 || 2 * coarse_nodes > nlp.n {
        return straight(nlp, settings, observer);
    }
    let coarse = Nlp6::six_dof(
        nlp.model.clone(),
        Mesh::global(coarse_nodes),
        nlp.x0,
        &nlp.target,
    );
    let loose = DirectSettings {
        tolerance: settings.coarse_tolerance,
        ..settings.clone()
    };
    let first = straight(&coarse, &loose, observer);
    let mut history = first.history;
    let left = |history: &Vec<_>| settings.max_iterations.saturating_sub(history.len());
    if first.status == Status::Solved && left(&history) > 0 {
        let fine = DirectSettings {
            mu_init: WARM_MU,
            max_iterations: left(&history),
            ..settings.clone()
        };
        let w0 = interpolate(&coarse, &first.w, nlp);
        let mut r = solve_nlp(nlp, &w0, None, &fine, observer);
        history.append(&mut r.history);
        if r.status == Status::Solved {
            r.history = history;
            return r;
        }
    }
    let rest = DirectSettings {
        max_iterations: left(&history).max(1),
        ..settings.clone()
    };
    let mut r = straight(nlp, &rest, observer);
    history.append(&mut r.history);
    r.history = history;
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;

    /// The upright attitude keeps the heading: a yaw ψ then a pitch θ
    /// (q = q_yaw ⊗ q_pitch) gives back the yaw alone, with the body axis
    /// vertical; the tilt is |θ|.
    #[test]
    fn upright_keeps_the_heading_and_the_tilt_is_the_pitch() {
        let (psi, theta) = (0.3f64, 1.2f64);
        let (cy, sy) = ((psi / 2.0).cos(), (psi / 2.0).sin());
        let (cp, sp) = ((theta / 2.0).cos(), (-theta / 2.0).sin());
        // (cy, 0, 0, sy) ⊗ (cp, 0, sp, 0).
        let q = [cy * cp, -sy * sp, cy * sp, sy * cp];
        assert!((tilt_rad(&q) - theta).abs() < 1e-12);
        let up = upright_of(&q);
        assert!((up[0] - cy).abs() < 1e-12 && (up[3] - sy).abs() < 1e-12);
        assert_eq!((up[1], up[2]), (0.0, 0.0));
        assert_eq!(tilt_rad(&up), 0.0);
        assert_eq!(upright_of(&[0.0, 1.0, 0.0, 0.0]), [1.0, 0.0, 0.0, 0.0]);
    }

    /// A planar start is scaled as the plane scales it (the shared slots:
    /// positions, speeds, t_f, the rate, the mass, δ and the controls).
    #[test]
    fn a_planar_start_is_scaled_as_the_plane() {
        let s = Scenario::paper();
        let planar = crate::method::direct::nlp::Nlp::new(&s, &Default::default());
        let model = SixDof::new(&s.vehicle, &s.environment);
        let x0 = six_dof::planar_state(&planar.x0);
        let nlp = Nlp6::six_dof(model, s.discretization.collocation_mesh(), x0, &s.terminal);
        use crate::method::direct::nlp::slot;
        let pairs = [
            (slot::X, sx::X),
            (slot::Z, sx::Z),
            (slot::VX, sx::VX),
            (slot::VZ, sx::VZ),
            (slot::W, sx::W + 1),
            (slot::M, sx::M),
            (slot::DELTA, sx::DELTA),
            (slot::T, NS + su::T),
            (slot::CHI, NS + su::CHI),
        ];
        for (p, q) in pairs {
            assert!(
                (planar.scale[p] - nlp.scale[q]).abs() <= 1e-12 * planar.scale[p],
                "slot {p}: {} against {}",
                planar.scale[p],
                nlp.scale[q]
            );
            assert_eq!(planar.offset[p], nlp.offset[q]);
        }
        assert_eq!(planar.tf_scale, nlp.tf_scale);
    }
}
