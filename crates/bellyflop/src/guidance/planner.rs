//! Warm re-planning: solve again from a new measured state, using the previous
//! plan — shifted in time and resampled on the mesh — as the SCvx reference.
//!
//! After `elapsed_s` along a plan of duration t_f, the remaining time is
//! t_f − elapsed_s. The new mesh's node τ' ∈ [−1, 1] maps to the old plan's
//! time t = elapsed_s + (τ' + 1)/2·(t_f − elapsed_s); the reference takes the
//! old plan's state and control interpolants there (the piecewise polynomials
//! of [`Mesh`]), with the first node replaced by the measured state. By
//! Bellman's principle the old plan's tail is optimal from its own state, so
//! from a state near the plan the reference is nearly optimal. A re-plan
//! therefore solves the exact formulation directly (the relaxed first phase
//! of a cold solve exists only to find that basin from a straight line), with
//! a proximal term: without it the linear-cost subproblem jumps between
//! vertices on the singular arcs and the trust region binds for 15–20
//! iterations ([`WARM_PROXIMAL_WEIGHT`]).

use crate::collocation::mesh::Mesh;
use crate::input::error::InputError;
use crate::input::scenario::{Formulation, InitialState, Method, Scenario, SolverSettings};
use crate::method::direct;
use crate::method::direct::nlp::Nlp;
use crate::method::scvx::transcription::{Trajectory, Transcription};
use crate::method::scvx::ConicSolver;
use crate::method::scvx::{self, Observer};
use crate::problem::dynamics::{self, ix, NU_MAX, NX};
use crate::solution::Solution;
use crate::verify::propagate::{Interpolant, Interpolation};

/// Trust region of a warm re-plan's first subproblem (scaled ∞-norm); the
/// cold solve's 0.3 also did best from the shifted plan (examples/replan:
/// 0.03 and 0.1 took more iterations, 1 and 3 no fewer).
pub const WARM_TRUST_REGION: f64 = 0.3;

/// Proximal weight of a warm re-plan's subproblems
/// ([`crate::input::scenario::SolverSettings::proximal_weight`]). Measured with
/// examples/replan (nominal state 0.5 s along the plan, exact form directly):
/// at N = 10, 20 and 40 it takes 4, 2 and 3 iterations with 0.01, against
/// 16, 15 and 19 with 0, 15, 13 and 20 with 0.003, and 3, 4 and 6 with 0.03.
pub const WARM_PROXIMAL_WEIGHT: f64 = 0.01;

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
    pub fn from_solution(s: &Solution) -> Plan {
        let sigma: Vec<f64> = s
            .thrust_n
            .iter()
            .zip(&s.mass_kg)
            .map(|(t, m)| t / m)
            .collect();
        Plan {
            trajectory: s.trajectory.clone(),
            mesh: s.mesh(),
            form: s.formulation,
            sigma_pchip: Interpolant::new(Interpolation::Pchip, &s.t_s, &sigma),
            delta_pchip: Interpolant::new(Interpolation::Pchip, &s.t_s, &s.delta_rad),
        }
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
        let mut col = vec![0.0; self.mesh.n + 1];
        std::array::from_fn(|c| {
            for (v, x) in col.iter_mut().zip(&self.trajectory.x) {
                *v = x[c];
            }
            self.mesh.interpolate_states(&col, tau)
        })
    }

    /// Thrust-per-mass components (Txm, Tzm, σ) and gimbal rate χ at `t_s`,
    /// from the control interpolant (held at the last collocation point
    /// beyond it).
    pub fn controls_at(&self, t_s: f64) -> (f64, f64, f64, f64) {
        let n = self.mesh.n;
        let tau = self.tau(t_s).min(self.mesh.nodes[n - 1]);
        let nu = dynamics::control_dim(self.form);
        let t = &self.trajectory;
        let comps: Vec<(f64, f64, f64)> = (0..n)
            .map(|i| dynamics::thrust_components(self.form, &t.x[i], &t.u[i][..nu]))
            .collect();
        let interp = |f: &dyn Fn(usize) -> f64| {
            let v: Vec<f64> = (0..n).map(f).collect();
            self.mesh.interpolate_controls(&v, tau)
        };
        (
            interp(&|i| comps[i].0),
            interp(&|i| comps[i].1),
            interp(&|i| comps[i].2),
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

/// The reference for a re-plan on `tr`: `plan` from `elapsed_s` on, resampled
/// on `tr`'s mesh over the remaining time, in `tr`'s formulation, with the
/// first node set to `tr.x0` (the measured state).
pub fn shifted_reference(plan: &Plan, elapsed_s: f64, tr: &Transcription) -> Trajectory {
    let remaining = (plan.tf_s() - elapsed_s).max(0.05 * plan.tf_s());
    let time = |tau: f64| elapsed_s + 0.5 * (tau + 1.0) * remaining;
    let mut x: Vec<[f64; NX]> = tr
        .mesh
        .nodes
        .iter()
        .map(|&tau| plan.state_at(time(tau)))
        .collect();
    x[0] = tr.x0;
    let u = (0..tr.layout.n)
        .map(|i| {
            let (txm, tzm, sigma, chi) = plan.controls_at(time(tr.mesh.nodes[i]));
            let mut u = [0.0; NU_MAX];
            match tr.form {
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
        })
        .collect();
    Trajectory {
        x,
        u,
        tf_s: remaining,
    }
}

/// A planner that keeps its last plan and its conic solver between solves.
#[derive(Debug)]
pub struct Planner {
    /// The scenario of the cold solve; re-plans replace its initial state.
    pub scenario: Scenario,
    /// The settings of the cold solve and of the re-plans (with the warm
    /// changes below).
    pub settings: SolverSettings,
    pub plan: Option<Plan>,
    /// Iterations of a re-plan's relaxed first phase (the paper's formulation,
    /// kept only if it passes every physical check); 0, the default, solves
    /// the exact formulation directly. The cold solve keeps the scenario's
    /// `solver.relaxed_first_iterations`.
    pub warm_relaxed_iterations: usize,
    /// Proximal weight of a re-plan's subproblems, in place of the scenario's
    /// `solver.proximal_weight` (default [`WARM_PROXIMAL_WEIGHT`]).
    pub warm_proximal_weight: f64,
    /// The method of the cold solve and the re-plans (the scenario's
    /// `solver.method` unless set; guidance sets it from
    /// [`crate::guidance::GuidanceConfig::replan_method`]).
    pub method: Method,
    /// Interior-point iteration budget of a direct re-plan (its deadline).
    pub direct_max_iterations: usize,
    /// One conic solver per subproblem structure (relaxed, exact).
    conics: (ConicSolver, ConicSolver),
}

impl Planner {
    /// `scenario` and `settings` must have passed validation.
    pub fn new(scenario: Scenario, settings: SolverSettings) -> Planner {
        Planner {
            method: settings.method,
            scenario,
            settings,
            plan: None,
            warm_relaxed_iterations: 0,
            warm_proximal_weight: WARM_PROXIMAL_WEIGHT,
            direct_max_iterations: DIRECT_REPLAN_ITERATIONS,
            conics: (ConicSolver::new(), ConicSolver::new()),
        }
    }

    /// Cold solve from the straight line with the planner's method; a
    /// solved answer becomes the plan.
    pub fn cold(&mut self, observer: &mut dyn Observer) -> Solution {
        let sol = self.cold_solve(&self.scenario, observer);
        self.adopt(sol)
    }

    fn cold_solve(&self, s: &Scenario, observer: &mut dyn Observer) -> Solution {
        match self.method {
            Method::Scvx => scvx::solve(s, &self.settings, observer),
            Method::Direct => direct::solve(s, &self.settings, observer),
        }
    }

    /// Make `sol` the plan if it is solved; the old plan stays otherwise.
    fn adopt(&mut self, sol: Solution) -> Solution {
        if sol.status == crate::Status::Solved {
            self.plan = Some(Plan::from_solution(&sol));
        }
        sol
    }

    /// Re-plan from `state`, measured `elapsed_s` after the current plan's
    /// start, warm-started from the shifted plan. Falls back to a cold solve
    /// when there is no plan yet. A solved answer becomes the new plan (and
    /// its start the new time origin); otherwise the old plan is kept.
    ///
    /// Errors only when `state` is outside the validated ranges.
    pub fn replan(
        &mut self,
        state: &InitialState,
        elapsed_s: f64,
        observer: &mut dyn Observer,
    ) -> Result<Solution, InputError> {
        let mut s = self.scenario.clone();
        s.initial = state.clone();
        if let Some(plan) = &self.plan {
            s.discretization.tf_guess_s = (plan.tf_s() - elapsed_s).max(0.05 * plan.tf_s());
        }
        s.discretization.final_mass_guess_kg = final_mass_guess(
            self.plan.as_ref(),
            elapsed_s,
            state.mass_kg,
            s.vehicle.dry_mass_kg,
            s.discretization.final_mass_guess_kg,
        );
        s.validate()?;
        self.settings.validate()?;
        let Some(plan) = &self.plan else {
            let sol = self.cold_solve(&s, observer);
            return Ok(self.adopt(sol));
        };
        if self.method == Method::Direct {
            let sol = self.direct_replan(s, plan, elapsed_s, observer);
            return Ok(self.adopt(sol));
        }
        // SCvx's relaxed-then-exact phases from the shifted plan, each with
        // the warm trust region; `solver.max_iterations` bounds both.
        let mut settings = self.settings.clone();
        settings.proximal_weight = self.warm_proximal_weight;
        let warm =
            |settings: &mut SolverSettings| settings.trust_region_initial = WARM_TRUST_REGION;
        let phases = scvx::Phases {
            relaxed_iterations: self.warm_relaxed_iterations,
            relaxed_tuning: warm,
            exact_tuning: warm,
        };
        let reference = |tr: &Transcription| shifted_reference(plan, elapsed_s, tr);
        let sol = phases.solve(&s, &settings, &reference, &mut self.conics, observer);
        Ok(self.adopt(sol))
    }
}

impl Planner {
    /// A direct re-plan: the interior-point method from the shifted plan
    /// (its states and controls on the new mesh, [`shifted_reference`]), at
    /// μ_0 = [`direct::WARM_MU`], within [`Planner::direct_max_iterations`].
    fn direct_replan(
        &self,
        s: Scenario,
        plan: &Plan,
        elapsed_s: f64,
        observer: &mut dyn Observer,
    ) -> Solution {
        let mut sv = self.settings.clone();
        sv.formulation = Formulation::Exact;
        sv.direct.mu_init = direct::WARM_MU;
        sv.direct.max_iterations = self.direct_max_iterations;
        let nlp = Nlp::new(&s, &sv);
        let tr = Transcription::new(&s, &sv);
        let mut guess = shifted_reference(plan, elapsed_s, &tr);
        blend_offset(&mut guess, &plan.state_at(elapsed_s), &tr.mesh.nodes);
        let w0 = nlp.from_trajectory(&guess);
        let warm = direct::solve_from(&s, &sv, &nlp, &w0, None, observer);
        // By Bellman's principle the new optimum is near the plan's own
        // prediction (the final-mass guess); far below it, the warm start
        // has slid into another basin. Solve cold too and keep the better.
        let expected_kg = s.discretization.final_mass_guess_kg;
        if warm.status == crate::Status::Solved
            && warm.final_mass_kg >= expected_kg - BASIN_TOLERANCE_KG
        {
            return warm;
        }
        let cold = direct::solve(&s, &sv, observer);
        let better = cold.status == crate::Status::Solved
            && (warm.status != crate::Status::Solved || cold.final_mass_kg > warm.final_mass_kg);
        // Both solves' iterations, warm first, in the history and the count.
        let mut history = warm.direct_history.clone();
        history.extend(cold.direct_history.iter().cloned());
        let (mut sol, other) = if better { (cold, warm) } else { (warm, cold) };
        sol.iterations += other.iterations;
        sol.solve_time_ms += other.solve_time_ms;
        for (k, h) in history.iter_mut().enumerate() {
            h.iteration = k + 1;
        }
        sol.direct_history = history;
        sol
    }
}

/// Spread the measured state's offset from the plan over the horizon: node
/// k of `guess` (whose first node is the measured state) moves by
/// e·(1 − τ_k)/2, e = x_0 − `planned_now`, so the start is continuous and
/// the terminal node stays on the plan. Without it the whole offset sits
/// between the first two nodes, where D's row amplifies it: the feedback
/// loops move the pitch rate and the nozzle off the plan, and the first
/// defects of w and δ reached 7 and 5 (scaled), which the interior-point
/// method spent its first 20 iterations on, at step lengths of 0.01–0.4,
/// before settling in a basin 1 t worse (1000-run campaign, seed 2, run 815).
fn blend_offset(guess: &mut Trajectory, planned_now: &[f64; NX], nodes: &[f64]) {
    let e: [f64; NX] = std::array::from_fn(|c| guess.x[0][c] - planned_now[c]);
    for (x, &tau) in guess.x.iter_mut().zip(nodes).skip(1) {
        let weight = 0.5 * (1.0 - tau);
        for c in 0..NX {
            x[c] += weight * e[c];
        }
    }
}

/// How far below the plan's predicted final mass a warm direct re-plan may
/// land before a cold solve is tried as well \[kg\]. Successive re-plans of
/// a dispersed landing differ by up to ~150 kg; a warm start that slid into
/// a worse basin lost 1,036 kg (1000-run campaign, seed 2, run 815, which
/// then crashed 7 m off the pad).
pub const BASIN_TOLERANCE_KG: f64 = 300.0;

/// Interior-point iterations of a direct re-plan by default: a cold solve
/// at N = 10 takes about 25 from the straight line, so a warm one that has
/// not converged in 40 is far from its plan.
pub const DIRECT_REPLAN_ITERATIONS: usize = 40;

/// Final-mass guess \[kg\] for a solve from mass `mass_kg`: that mass less the
/// propellant `plan` still burns after `elapsed_s` (`fallback_kg` without a
/// plan), kept within [m_dry, `mass_kg`]. A fixed guess fails validation once
/// the vehicle is lighter than it (every re-plan was then `bad_state`).
pub fn final_mass_guess(
    plan: Option<&Plan>,
    elapsed_s: f64,
    mass_kg: f64,
    dry_mass_kg: f64,
    fallback_kg: f64,
) -> f64 {
    let guess = match plan {
        Some(p) => {
            let n = p.mesh.n;
            let planned_now = p.state_at(elapsed_s)[ix::OMEGA].exp();
            let planned_final = p.trajectory.x[n][ix::OMEGA].exp();
            mass_kg - (planned_now - planned_final).max(0.0)
        }
        None => fallback_kg,
    };
    // max then min, not clamp: no panic when m_dry > mass (validation
    // rejects that state).
    guess.max(dry_mass_kg).min(mass_kg)
}

/// The measured state as an [`InitialState`] (degrees for the angles).
pub fn initial_state(x: &[f64; NX]) -> InitialState {
    InitialState {
        x_m: x[ix::X],
        z_m: x[ix::Z],
        vx_mps: x[ix::VX],
        vz_mps: x[ix::VZ],
        theta_deg: x[ix::THETA].to_degrees(),
        pitch_rate_degps: x[ix::W].to_degrees(),
        mass_kg: x[ix::OMEGA].exp(),
        gimbal_deg: x[ix::DELTA].to_degrees(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The offset is whole at the first node, gone at the last, and linear
    /// in τ between.
    #[test]
    fn blend_offset_spreads_the_measured_offset_over_the_horizon() {
        let nodes = [-1.0, -0.5, 0.0, 1.0];
        let plan: Vec<[f64; NX]> = (0..4).map(|k| [k as f64; NX]).collect();
        let mut guess = Trajectory {
            x: plan.clone(),
            u: vec![[0.0; NU_MAX]; 3],
            tf_s: 5.0,
        };
        guess.x[0] = [2.0; NX]; // measured: 2 above the plan's 0
        blend_offset(&mut guess, &plan[0], &nodes);
        assert_eq!(guess.x[0], [2.0; NX]);
        assert_eq!(guess.x[1], [1.0 + 0.75 * 2.0; NX]);
        assert_eq!(guess.x[2], [2.0 + 0.5 * 2.0; NX]);
        assert_eq!(guess.x[3], plan[3]);
    }
}
