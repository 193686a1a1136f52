//! Warm re-planning: solve again from a new measured state, using the previous
//! plan — shifted in time and resampled on the mesh — as the SCvx reference.
//!
//! After `elapsed_s` along a plan of duration t_f, the remaining time is
//! t_f − elapsed_s. The new mesh's node τ' ∈ [−1, 1] maps to the old plan's
//! time t = elapsed_s + (τ' + 1)/2·(t_f − elapsed_s); the reference takes the
//! old plan's state and control interpolants there (the piecewise polynomials
//! of [`crate::collocation::mesh::Mesh`]), with the first node replaced by the measured state. By
//! Bellman's principle the old plan's tail is optimal from its own state, so
//! from a state near the plan the reference is nearly optimal. A re-plan
//! therefore solves the exact formulation directly (the relaxed first phase
//! of a cold solve exists only to find that basin from a straight line), with
//! a proximal term: without it the linear-cost subproblem jumps between
//! vertices on the singular arcs and the trust region binds for 15–20
//! iterations ([`WARM_PROXIMAL_WEIGHT`]).

use crate::collocation::plan::Plan;
use crate::input::error::InputError;
use crate::input::scenario::{InitialState, Scenario};
use crate::input::settings::{Method, SolverSettings};
use crate::method::observer::Observer;
use crate::method::{self, Replan, Solver, Start};
use crate::pipeline;
use crate::problem::dynamics::{ix, NX};
use crate::problem::{constraints, feasibility};
use crate::solution::{Solution, Status};
use crate::verify::path::LIMIT_TOLERANCE;

/// Proximal weight of a warm re-plan's subproblems
/// ([`crate::input::settings::SolverSettings::proximal_weight`]). Measured with
/// examples/replan (nominal state 0.5 s along the plan, exact form directly):
/// at N = 10, 20 and 40 it takes 4, 2 and 3 iterations with 0.01, against
/// 16, 15 and 19 with 0, 15, 13 and 20 with 0.003, and 3, 4 and 6 with 0.03.
pub const WARM_PROXIMAL_WEIGHT: f64 = 0.01;

/// A planner that keeps its last plan and its method's warm-start state
/// (SCvx's conic solvers) between solves.
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
    /// The solver of `solver_method`, made anew when `method` changes.
    solver: Box<dyn Solver>,
    solver_method: Method,
    /// A plan's storage, kept while there is no plan ([`Self::clear_plan`],
    /// [`Self::prepare`]), for the next one to fill.
    spare_plan: Option<Plan>,
}

impl Planner {
    /// `scenario` and `settings` must have passed validation.
    pub fn new(scenario: Scenario, settings: SolverSettings) -> Planner {
        Planner {
            method: settings.method,
            solver: method::solver(settings.method),
            solver_method: settings.method,
            scenario,
            settings,
            plan: None,
            spare_plan: None,
            warm_relaxed_iterations: 0,
            warm_proximal_weight: WARM_PROXIMAL_WEIGHT,
            direct_max_iterations: DIRECT_REPLAN_ITERATIONS,
        }
    }

    /// Cold solve from the straight line with the planner's method; a
    /// solved answer becomes the plan.
    pub fn cold(&mut self, observer: &mut dyn Observer) -> Solution {
        let mut out = Solution::empty(self.method);
        self.cold_into(observer, &mut out);
        out
    }

    /// [`Self::cold`] into `out`, in its own storage and the plan's: with
    /// the direct method, after [`Self::prepare`], a cold solve that
    /// converges allocates nothing.
    pub fn cold_into(&mut self, observer: &mut dyn Observer, out: &mut Solution) {
        self.use_method();
        let Planner {
            scenario,
            settings,
            solver,
            ..
        } = self;
        solver.solve_into(scenario, settings, Start::StraightLine, observer, out);
        hold_limits_at_nodes(&self.scenario, out);
        infeasible_only_with_proof(&self.scenario, out);
        self.adopt_into(out);
    }

    /// Make the planner's method's solver if the method changed.
    fn use_method(&mut self) {
        if self.solver_method != self.method {
            self.solver = method::solver(self.method);
            self.solver_method = self.method;
        }
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
        let mut out = Solution::empty(self.method);
        self.replan_into(state, elapsed_s, observer, &mut out)?;
        Ok(out)
    }

    /// [`Self::replan`] into `out`, in its own storage and the plan's: with
    /// the direct method, once `out` and the plan have their sizes (after
    /// [`Self::prepare`], or a first re-plan of the same mesh), a re-plan
    /// that converges allocates nothing (issue 27). On an error `out` is
    /// left as it was.
    pub fn replan_into(
        &mut self,
        state: &InitialState,
        elapsed_s: f64,
        observer: &mut dyn Observer,
        out: &mut Solution,
    ) -> Result<(), InputError> {
        // The re-plan's scenario is the cold one with this start and these
        // guesses, set in place (no copy) and restored after.
        let d = &self.scenario.discretization;
        let saved = (
            self.scenario.initial.clone(),
            d.tf_guess_s,
            d.final_mass_guess_kg,
        );
        let result = self.replan_in_place(state, elapsed_s, observer, out);
        let (initial, tf_guess_s, final_mass_guess_kg) = saved;
        self.scenario.initial = initial;
        self.scenario.discretization.tf_guess_s = tf_guess_s;
        self.scenario.discretization.final_mass_guess_kg = final_mass_guess_kg;
        result
    }

    /// [`Self::replan_into`] on `self.scenario`, which it changes.
    fn replan_in_place(
        &mut self,
        state: &InitialState,
        elapsed_s: f64,
        observer: &mut dyn Observer,
        out: &mut Solution,
    ) -> Result<(), InputError> {
        let s = &mut self.scenario;
        let fallback_kg = s.discretization.final_mass_guess_kg;
        s.initial = state.clone();
        if let Some(plan) = &self.plan {
            s.discretization.tf_guess_s = (plan.tf_s() - elapsed_s).max(0.05 * plan.tf_s());
        }
        s.discretization.final_mass_guess_kg = final_mass_guess(
            self.plan.as_ref(),
            elapsed_s,
            state.mass_kg,
            s.vehicle.dry_mass_kg,
            fallback_kg,
        );
        s.validate()?;
        self.settings.validate()?;
        self.use_method();
        let Planner {
            scenario,
            settings,
            plan,
            solver,
            ..
        } = self;
        let Some(current) = plan.as_ref() else {
            *out = solver.solve(scenario, settings, Start::StraightLine, observer);
            hold_limits_at_nodes(&self.scenario, out);
            infeasible_only_with_proof(&self.scenario, out);
            self.adopt_into(out);
            return Ok(());
        };
        let replan = Replan {
            plan: current,
            elapsed_s,
            relaxed_iterations: self.warm_relaxed_iterations,
            proximal_weight: self.warm_proximal_weight,
            direct_max_iterations: self.direct_max_iterations,
        };
        solver.solve_into(scenario, settings, Start::Replan(replan), observer, out);
        hold_limits_at_nodes(&self.scenario, out);
        infeasible_only_with_proof(&self.scenario, out);
        self.adopt_into(out);
        Ok(())
    }

    /// Make, now, what cold solves and re-plans need, so that with the
    /// direct method neither allocates into `out` from the first one on:
    /// the method's storage for the scenario's mesh, with room for the cold
    /// budget of the planner's settings and for `direct_max_iterations`,
    /// and room for `out`'s iteration history. For a flight loop's setup.
    pub fn prepare(&mut self, out: &mut Solution) {
        self.use_method();
        let replan = self.direct_max_iterations;
        self.solver.prepare(&self.scenario, &self.settings, replan);
        // An answer and a plan of the mesh's sizes: the straight line,
        // which no solve has iterated on (`out` is overwritten by the next).
        *out = method::guess_answer(
            &self.scenario,
            &self.settings,
            Status::NotConverged,
            "no solve yet: the straight-line guess".into(),
            0.0,
        );
        if self.plan.is_none() && self.spare_plan.is_none() {
            self.spare_plan = Some(out.plan());
        }
        let cold = self.settings.direct.max_iterations;
        out.history.direct.reserve(cold.max(replan));
    }

    /// Make `sol` the plan (in the old plan's storage, or the spare's) if
    /// it is solved; the old plan stays otherwise.
    fn adopt_into(&mut self, sol: &Solution) {
        if sol.status != Status::Solved {
            return;
        }
        if self.plan.is_none() {
            self.plan = self.spare_plan.take();
        }
        match &mut self.plan {
            Some(plan) => sol.refill_plan(plan),
            None => self.plan = Some(sol.plan()),
        }
    }

    /// Forget the plan (the next solve starts from none), keeping its
    /// storage for the next.
    pub fn clear_plan(&mut self) {
        if let Some(plan) = self.plan.take() {
            self.spare_plan = Some(plan);
        }
    }
}

/// A method's `solved` answer, which the planner adopts, must hold every
/// operational limit of the scenario at its nodes. Both methods hold them
/// there (issue 37); this is the guard that no answer outside them is
/// flown: one outside a limit at a node after the first by more than the
/// path check's tolerance ([`LIMIT_TOLERANCE`] of the row's scale) is
/// `non_physical`, with where, and the old plan stays. Allocates only on
/// that failure.
fn hold_limits_at_nodes(scenario: &Scenario, out: &mut Solution) {
    if out.status != Status::Solved {
        return;
    }
    // Node 0 is the measured state, which the plan cannot change (a plan
    // interpolant between nodes can be a little outside a limit that its
    // nodes hold); the cold solve's own was certified by the pipeline.
    let planned = out.trajectory.x.get(1..).unwrap_or_default();
    if let Some(mut e) = constraints::worst_at_nodes(scenario, planned, LIMIT_TOLERANCE) {
        e.node += 1;
        out.status = Status::NonPhysical;
        out.message = format!(
            "the {} answer breaks {} at node {} by {:.4} {}, beyond the planner's tolerance",
            out.method.as_str(),
            e.limit.describe(),
            e.node,
            e.excess,
            e.limit.unit()
        );
    }
}

/// A method that stops locally infeasible has found no trajectory, which
/// is not a proof that none exists: the answer is `infeasible` only with a
/// certificate ([`feasibility::certify`], its message), and otherwise
/// `not_converged` with the method's reason, as the pipeline's step 2
/// words it ([`pipeline::not_proven`]). Allocates only then.
fn infeasible_only_with_proof(scenario: &Scenario, out: &mut Solution) {
    if out.status != Status::Infeasible {
        return;
    }
    match feasibility::certify(scenario) {
        Some(certificate) => {
            out.message = certificate.to_string();
            out.certificate = Some(certificate);
        }
        None => pipeline::not_proven(scenario, out),
    }
}

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
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::method::observer::Silent;

    /// The planner's last guard: a method's `solved` answer outside a limit
    /// at a node after the first is `non_physical`, and says which limit
    /// and where. Every method holds every limit at its nodes today, so
    /// the answer here is one solved without the limit, checked against a
    /// scenario with an 11° cone that it leaves.
    #[test]
    fn an_answer_outside_a_limit_at_a_node_is_not_physical() {
        let direct = SolverSettings {
            method: Method::Direct,
            polish: false,
            ..SolverSettings::default()
        };
        let mut sol =
            crate::solve(&Scenario::paper(), &direct, &mut Silent).expect("a planar scenario");
        sol.status = Status::Solved;
        let mut coned = Scenario::paper();
        hold_limits_at_nodes(&coned, &mut sol);
        assert_eq!(sol.status, Status::Solved, "no limit, nothing to break");
        coned.constraints.cone_half_angle_deg = Some(11.0);
        hold_limits_at_nodes(&coned, &mut sol);
        assert_eq!(sol.status, Status::NonPhysical);
        assert!(
            sol.message.contains("the approach cone") && sol.message.contains("at node"),
            "{}",
            sol.message
        );
    }
    /// A method that stops locally infeasible gives `not_converged` from
    /// the planner, as from the pipeline; `infeasible` needs a certificate.
    /// A 10° cone about the pad holds the paper's initial state but not its
    /// flip (IPOPT: infeasible too, without a proof); 100 m up at the
    /// paper's speed the stopping bound proves it.
    #[test]
    fn the_planner_claims_infeasible_only_with_a_certificate() {
        let direct = SolverSettings {
            method: Method::Direct,
            ..SolverSettings::default()
        };
        let mut coned = Scenario::paper();
        coned.constraints.cone_half_angle_deg = Some(10.0);
        let sol = Planner::new(coned, direct.clone()).cold(&mut Silent);
        assert_eq!(sol.status, Status::NotConverged, "{}", sol.message);
        assert!(
            sol.message.contains("locally infeasible"),
            "{}",
            sol.message
        );
        let mut low = Scenario::paper();
        low.initial.z_m = 100.0;
        let sol = Planner::new(low, direct).cold(&mut Silent);
        assert_eq!(sol.status, Status::Infeasible, "{}", sol.message);
        assert!(
            sol.message.contains("vertical stopping bound"),
            "{}",
            sol.message
        );
    }
}
