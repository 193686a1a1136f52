//! A previous answer as a function of time, and its tail resampled on a new
//! mesh: the plan that guidance flies and the start of a re-plan.

use crate::collocation::interpolation::{Interpolant, Interpolation};
use crate::collocation::mesh::Mesh;
use crate::collocation::trajectory::Trajectory;
use crate::input::mesh_layout::MeshLayout;
use crate::input::settings::Formulation;
use crate::problem::dynamics::{self, ix, NU_MAX, NX};

/// The previous plan as a function of time: its trajectory, mesh and formulation.
#[derive(Debug, Clone)]
pub struct Plan {
    pub trajectory: Trajectory,
    pub mesh: Mesh,
    pub form: Formulation,
    /// PCHIP through the node values of σ = T/m and of δ, for flying the plan:
    /// monotone, so they do not ring past the thrust bounds around the
    /// bang-bang switch as the degree-(N − 1) control polynomial does (the
    /// landing-precision measurements of `propagate`).
    sigma_pchip: Interpolant,
    delta_pchip: Interpolant,
}

impl Plan {
    /// The plan of `trajectory` on `mesh` in the formulation `form`, flown
    /// with σ = T/m and δ given at the node times `t_s` (PCHIP between).
    pub fn new(
        trajectory: Trajectory,
        mesh: Mesh,
        form: Formulation,
        t_s: &[f64],
        sigma: &[f64],
        delta_rad: &[f64],
    ) -> Plan {
        Plan {
            trajectory,
            mesh,
            form,
            sigma_pchip: Interpolant::new(Interpolation::Pchip, t_s, sigma),
            delta_pchip: Interpolant::new(Interpolation::Pchip, t_s, delta_rad),
        }
    }

    /// [`Plan::new`] in place, in this plan's own storage (a re-plan's
    /// plan allocates nothing once the sizes are set): `trajectory` on the
    /// mesh of `layout` (rebuilt only when it differs), σ and δ at `t_s`.
    #[allow(clippy::too_many_arguments)]
    pub fn refill(
        &mut self,
        trajectory: &Trajectory,
        layout: &MeshLayout,
        form: Formulation,
        t_s: &[f64],
        sigma: impl Iterator<Item = f64>,
        delta_rad: &[f64],
    ) {
        self.trajectory.x.clone_from(&trajectory.x);
        self.trajectory.u.clone_from(&trajectory.u);
        self.trajectory.tf_s = trajectory.tf_s;
        if !self.mesh.has_layout(layout) {
            self.mesh = Mesh::from_layout(layout);
        }
        self.form = form;
        self.sigma_pchip.refill(Interpolation::Pchip, t_s, sigma);
        self.delta_pchip
            .refill(Interpolation::Pchip, t_s, delta_rad.iter().copied());
    }

    /// Thrust-per-mass σ [N/kg] and nozzle angle δ \[rad\] to fly at `t_s`
    /// (PCHIP through the node values, held beyond the ends).
    pub fn flight_controls_at(&self, t_s: f64) -> (f64, f64) {
        let t = t_s.clamp(0.0, self.tf_s());
        (self.sigma_pchip.eval(t), self.delta_pchip.eval(t))
    }

    /// Duration t_f \[s\].
    pub fn tf_s(&self) -> f64 {
        self.trajectory.tf_s
    }

    fn tau(&self, t_s: f64) -> f64 {
        (2.0 * t_s / self.trajectory.tf_s - 1.0).clamp(-1.0, 1.0)
    }

    /// LCvx state (x, z, Vx, Vz, θ, w, ω, δ) at time `t_s`.
    pub fn state_at(&self, t_s: f64) -> [f64; NX] {
        let tau = self.tau(t_s);
        let x = &self.trajectory.x;
        std::array::from_fn(|c| self.mesh.interpolate_states_by(|k| x[k][c], tau))
    }

    /// Thrust-per-mass components (Txm, Tzm, σ) and gimbal rate χ at `t_s`,
    /// from the control interpolant (held at the last collocation point
    /// beyond it).
    pub fn controls_at(&self, t_s: f64) -> (f64, f64, f64, f64) {
        let n = self.mesh.n;
        let tau = self.tau(t_s).min(self.mesh.nodes[n - 1]);
        let nu = dynamics::control_dim(self.form);
        let t = &self.trajectory;
        let comps = |i: usize| dynamics::thrust_components(self.form, &t.x[i], &t.u[i][..nu]);
        let interp = |f: &dyn Fn(usize) -> f64| self.mesh.interpolate_controls_by(f, tau);
        (
            interp(&|i| comps(i).0),
            interp(&|i| comps(i).1),
            interp(&|i| comps(i).2),
            interp(&|i| t.u[i][nu - 1]),
        )
    }

    /// Thrust \[N\] and gimbal rate [rad/s] commanded at `t_s`: σ·m with the
    /// plan's mass there, and χ.
    pub fn command_at(&self, t_s: f64) -> (f64, f64) {
        let x = self.state_at(t_s);
        let (_, _, sigma, chi) = self.controls_at(t_s);
        (sigma * x[ix::OMEGA].exp(), chi)
    }
}

/// The reference for a re-plan on `mesh`: `plan` from `elapsed_s` on,
/// resampled on the mesh over the remaining time, in the formulation
/// `form`, with the first node set to `x0` (the measured state).
pub fn shifted_reference(
    plan: &Plan,
    elapsed_s: f64,
    mesh: &Mesh,
    x0: &[f64; NX],
    form: Formulation,
) -> Trajectory {
    let mut t = Trajectory {
        x: Vec::new(),
        u: Vec::new(),
        tf_s: 0.0,
    };
    shifted_reference_into(plan, elapsed_s, mesh, x0, form, &mut t);
    t
}

/// [`shifted_reference`] into `t`, in its vectors' own storage (a re-plan
/// allocates nothing).
pub fn shifted_reference_into(
    plan: &Plan,
    elapsed_s: f64,
    mesh: &Mesh,
    x0: &[f64; NX],
    form: Formulation,
    t: &mut Trajectory,
) {
    let remaining = (plan.tf_s() - elapsed_s).max(0.05 * plan.tf_s());
    let time = |tau: f64| elapsed_s + 0.5 * (tau + 1.0) * remaining;
    t.x.clear();
    t.x.extend(mesh.nodes.iter().map(|&tau| plan.state_at(time(tau))));
    t.x[0] = *x0;
    t.u.clear();
    t.u.extend((0..mesh.n).map(|i| {
        let (txm, tzm, sigma, chi) = plan.controls_at(time(mesh.nodes[i]));
        let mut u = [0.0; NU_MAX];
        match form {
            Formulation::Exact => {
                u[0] = sigma;
                u[1] = chi;
            }
            Formulation::Paper | Formulation::Vector => {
                u[0] = txm;
                u[1] = tzm;
                u[2] = sigma;
                u[3] = chi;
            }
        }
        u
    }));
    t.tf_s = remaining;
}
