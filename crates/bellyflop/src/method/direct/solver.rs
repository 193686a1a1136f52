//! The direct method behind the [`Solver`] seam: a cold solve from the
//! straight line, a pass on a new mesh warm from the last answer (primal–dual
//! with its multipliers), and a re-plan from the shifted plan.

use crate::collocation::plan::shifted_reference_into;
use crate::collocation::trajectory::Trajectory;
use crate::input::mesh_layout::MeshLayout;
use crate::input::scenario::Scenario;
use crate::input::settings::{Formulation, Method, SolverSettings};
use crate::method::direct::cold::{ColdWork, MeshKey};
use crate::method::direct::nlp::{Duals, Nlp};
use crate::method::direct::Storage;
use crate::method::direct::{self, Start as DirectStart};
use crate::method::observer::Observer;
use crate::method::{Replan, Solver, Start};
use crate::problem::dynamics::{ix, NX};
use crate::solution::{Solution, Status};

/// μ_0 of a primal–dual warm pass. Measured on the paper's case and 20
/// envelope states (refined to 1e-6): warm passes took a median of 25
/// interior-point iterations from the primal start at μ_0 = 1e-4, 19 from
/// the primal–dual start at 1e-6, 14 at 1e-8 (the same meshes and optima:
/// 34 % less time in all) and 11 at 1e-9 (no faster in all, and one state
/// took another mesh path).
pub const WARM_PD_MU: f64 = 1e-8;

/// How far below the plan's predicted final mass a warm direct re-plan may
/// land before a cold solve is tried as well \[kg\]. Successive re-plans of
/// a dispersed landing differ by up to ~150 kg; a warm start that slid into
/// a worse basin lost 1,036 kg (1000-run campaign, seed 2, run 815, which
/// then crashed 7 m off the pad).
pub const BASIN_TOLERANCE_KG: f64 = 300.0;

/// The direct method, with the multipliers of its last answer and the
/// storage of its last re-plan.
#[derive(Debug, Default)]
pub struct DirectSolver {
    last: Option<Kept>,
    replan: Option<ReplanWork>,
    cold: Option<ColdWork>,
}

/// What a re-plan leaves for the next one of the same discretization: its
/// NLP (refreshed with the next scenario, [`Nlp::refresh`]) and its Newton
/// system's storage (reset, [`Storage::reuse_for`]), so that a re-plan
/// builds neither (issue 27: no allocation in a flight loop's re-plan).
#[derive(Debug)]
struct ReplanWork {
    mesh: MeshKey,
    nlp: Nlp,
    storage: Storage,
    /// The shifted plan on the mesh, and as the NLP's start point.
    guess: Trajectory,
    w0: Vec<f64>,
}

/// An answer's NLP and multipliers, and what identifies that answer.
#[derive(Debug)]
struct Kept {
    mesh: MeshLayout,
    final_mass_kg: f64,
    nlp: Nlp,
    duals: Duals,
}

impl DirectSolver {
    fn keep(&mut self, sol: &Solution, nlp: Nlp, duals: Duals) {
        self.last = Some(Kept {
            mesh: sol.mesh.clone(),
            final_mass_kg: sol.final_mass_kg,
            nlp,
            duals,
        });
    }

    /// The kept NLP and multipliers, if they are `prev`'s: the last
    /// answer's, or the last cold solve's in storage.
    fn duals_of(&self, prev: &Solution) -> Option<(&Nlp, &Duals)> {
        let same = |mass_kg: f64| mass_kg.to_bits() == prev.final_mass_kg.to_bits();
        let kept = self
            .last
            .as_ref()
            .filter(|k| k.mesh == prev.mesh && same(k.final_mass_kg))
            .map(|k| (&k.nlp, &k.duals));
        kept.or_else(|| {
            self.cold
                .as_ref()
                .filter(|c| {
                    c.nlp.mesh.has_layout(&prev.mesh) && c.final_mass_kg().is_some_and(same)
                })
                .map(|c| (&c.nlp, &c.duals))
        })
    }

    /// The last cold solve's storage, refreshed for `s` when it fits; else
    /// new storage.
    fn cold_work(&mut self, s: &Scenario, settings: &SolverSettings) -> ColdWork {
        match self.cold.take() {
            Some(mut w) if w.fits(s, settings) => {
                w.refresh(s, settings);
                w
            }
            _ => ColdWork::new(s, settings),
        }
    }
}

impl Solver for DirectSolver {
    fn solve(
        &mut self,
        scenario: &Scenario,
        settings: &SolverSettings,
        start: Start<'_>,
        observer: &mut dyn Observer,
    ) -> Solution {
        match start {
            Start::StraightLine => {
                let (sol, nlp, duals) = direct::solve_keeping_duals(scenario, settings, observer);
                self.keep(&sol, nlp, duals);
                sol
            }
            Start::Answer(prev) => {
                let (sol, nlp, duals) = self.on_new_mesh(prev, scenario, settings, observer);
                self.keep(&sol, nlp, duals);
                sol
            }
            Start::Replan(replan) => {
                let mut out = Solution::empty(Method::Direct);
                self.solve_into(
                    scenario,
                    settings,
                    Start::Replan(replan),
                    observer,
                    &mut out,
                );
                out
            }
        }
    }

    /// Build the cold solve's and the re-plans' NLPs and storage for
    /// `scenario`'s mesh now, with room for the cold budget of `settings`
    /// and for `direct_replan_iterations`, so that neither a cold solve nor
    /// a re-plan into an answer of the right size allocates later.
    fn prepare(
        &mut self,
        scenario: &Scenario,
        settings: &SolverSettings,
        direct_replan_iterations: usize,
    ) {
        let mut cold = self.cold_work(scenario, settings);
        cold.reserve(settings.direct.max_iterations);
        self.cold = Some(cold);
        let sv = replan_settings(settings, direct_replan_iterations);
        let mut work = self.replan_work(scenario, &sv);
        work.reserve(direct_replan_iterations);
        self.replan = Some(work);
    }

    /// A re-plan and a cold solve write into `out`'s storage, with the last
    /// such solve's NLPs and solver storage: none of it allocates once the
    /// sizes are set (issue 27). A pass on a new mesh is
    /// [`Solver::solve`]'s.
    fn solve_into(
        &mut self,
        scenario: &Scenario,
        settings: &SolverSettings,
        start: Start<'_>,
        observer: &mut dyn Observer,
        out: &mut Solution,
    ) {
        match start {
            Start::Replan(replan) => {
                self.last = None;
                self.replan_into(scenario, settings, &replan, observer, out);
            }
            Start::StraightLine => {
                let mut work = self.cold_work(scenario, settings);
                work.solve_into(scenario, settings, observer, out);
                // The multipliers of this answer are the cold storage's.
                self.last = None;
                self.cold = Some(work);
            }
            other => *out = self.solve(scenario, settings, other, observer),
        }
    }
}

impl DirectSolver {
    /// One pass on `to`'s mesh, warm from `prev` (an answer on another
    /// mesh): primal–dual from the multipliers of `prev`'s NLP when this
    /// solver produced it, at μ_0 = [`WARM_PD_MU`]; primal only at
    /// [`direct::WARM_MU`] otherwise, or when the primal–dual start fails.
    fn on_new_mesh(
        &self,
        prev: &Solution,
        to: &Scenario,
        settings: &SolverSettings,
        observer: &mut dyn Observer,
    ) -> (Solution, Nlp, Duals) {
        let nlp = Nlp::new(to, settings);
        let w0 = nlp.interpolate_from(prev);
        let mut warm = settings.clone();
        let primal_dual = self.duals_of(prev).map(|(from, duals)| {
            let duals = nlp.interpolate_duals_from(from, duals);
            warm.direct.mu_init = WARM_PD_MU;
            let start = DirectStart::PrimalDual(&w0, &duals);
            direct::solve_from_start(&warm, &nlp, start, observer)
        });
        let (sol, duals) = match primal_dual {
            Some((sol, duals)) if sol.status == Status::Solved => (sol, duals),
            tried => {
                // The primal start, with the failed attempt's work counted.
                warm.direct.mu_init = direct::WARM_MU;
                let start = DirectStart::Primal(&w0, None);
                let (mut sol, duals) = direct::solve_from_start(&warm, &nlp, start, observer);
                if let Some((failed, _)) = tried {
                    sol.iterations += failed.iterations;
                    sol.solve_time_ms += failed.solve_time_ms;
                }
                (sol, duals)
            }
        };
        (sol, nlp, duals)
    }
}

impl DirectSolver {
    /// The last re-plan's NLP and storage, refreshed for `s` when it has
    /// the same discretization; else new ones.
    fn replan_work(&mut self, s: &Scenario, sv: &SolverSettings) -> ReplanWork {
        let d = &s.discretization;
        match self.replan.take() {
            Some(mut w) if w.mesh.matches(d) => {
                w.nlp.refresh(s, sv);
                w.storage = w.storage.reuse_for(&w.nlp);
                w
            }
            _ => {
                let nlp = Nlp::new(s, sv);
                ReplanWork {
                    mesh: MeshKey::of(d),
                    storage: Storage::new(&nlp),
                    nlp,
                    guess: Trajectory {
                        x: Vec::new(),
                        u: Vec::new(),
                        tf_s: 0.0,
                    },
                    w0: Vec::new(),
                }
            }
        }
    }

    /// A direct re-plan into `out`: the interior-point method from the
    /// shifted plan (its states and controls on the new mesh,
    /// [`shifted_reference`](crate::collocation::plan::shifted_reference)), at μ_0 = [`direct::WARM_MU`], within
    /// [`Replan::direct_max_iterations`]; a cold solve too when the warm
    /// one lands far below the plan's prediction.
    fn replan_into(
        &mut self,
        s: &Scenario,
        settings: &SolverSettings,
        replan: &Replan<'_>,
        observer: &mut dyn Observer,
        out: &mut Solution,
    ) {
        let sv = replan_settings(settings, replan.direct_max_iterations);
        let work = self.replan_work(s, &sv);
        self.replan = Some(warm_replan(s, &sv, replan, work, observer, out));
        // By Bellman's principle the new optimum is near the plan's own
        // prediction (the final-mass guess); far below it, the warm start
        // has slid into another basin. Solve cold too and keep the better.
        let expected_kg = s.discretization.final_mass_guess_kg;
        if out.status == Status::Solved && out.final_mass_kg >= expected_kg - BASIN_TOLERANCE_KG {
            return;
        }
        let warm = std::mem::replace(out, Solution::empty(Method::Direct));
        *out = with_cold(s, &sv, warm, observer);
    }
}

/// A direct re-plan's settings: the exact formulation, μ_0 =
/// [`direct::WARM_MU`] and the re-plan's iteration budget.
fn replan_settings(settings: &SolverSettings, max_iterations: usize) -> SolverSettings {
    let mut sv = settings.clone();
    sv.formulation = Formulation::Exact;
    sv.direct.mu_init = direct::WARM_MU;
    sv.direct.max_iterations = max_iterations;
    sv
}

impl ReplanWork {
    /// Room for a re-plan of up to `max_iterations` iterations.
    fn reserve(&mut self, max_iterations: usize) {
        let n = self.nlp.n;
        self.guess
            .x
            .reserve((n + 1).saturating_sub(self.guess.x.len()));
        self.guess.u.reserve(n.saturating_sub(self.guess.u.len()));
        self.w0
            .reserve(self.nlp.n_var().saturating_sub(self.w0.len()));
        self.storage.reserve(&self.nlp, max_iterations);
    }
}

/// The warm solve of a re-plan into `out`, on `work`'s NLP (refreshed for
/// `s`) and in its storage; the work comes back for the next re-plan.
fn warm_replan(
    s: &Scenario,
    sv: &SolverSettings,
    replan: &Replan<'_>,
    work: ReplanWork,
    observer: &mut dyn Observer,
    out: &mut Solution,
) -> ReplanWork {
    let ReplanWork {
        nlp,
        storage,
        mut guess,
        mut w0,
        ..
    } = work;
    let (plan, elapsed_s) = (replan.plan, replan.elapsed_s);
    let mut x0 = s.initial.state_si();
    x0[ix::OMEGA] = s.initial.mass_kg.ln();
    shifted_reference_into(plan, elapsed_s, &nlp.mesh, &x0, sv.formulation, &mut guess);
    blend_offset(&mut guess, &plan.state_at(elapsed_s), &nlp.mesh.nodes);
    nlp.from_trajectory_into(&guess, &mut w0);
    let start = DirectStart::Primal(&w0, None);
    let storage = direct::solve_into(sv, &nlp, start, observer, storage, out);
    ReplanWork {
        nlp,
        storage,
        guess,
        w0,
        ..work
    }
}

/// The better of a warm re-plan that slid into another basin and a cold
/// solve, with both solves' iterations and time.
fn with_cold(
    s: &Scenario,
    sv: &SolverSettings,
    warm: Solution,
    observer: &mut dyn Observer,
) -> Solution {
    let cold = direct::solve(s, sv, observer);
    let better = cold.status == Status::Solved
        && (warm.status != Status::Solved || cold.final_mass_kg > warm.final_mass_kg);
    // Both solves' iterations, warm first, in the history and the count.
    let mut history = warm.history.clone();
    history.append(cold.history.clone());
    let (mut sol, other) = if better { (cold, warm) } else { (warm, cold) };
    sol.iterations += other.iterations;
    sol.solve_time_ms += other.solve_time_ms;
    sol.history = history;
    sol
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::dynamics::NU_MAX;

    /// A node array of an answer.
    type Column = fn(&Solution) -> &Vec<f64>;

    /// The same status, iteration count, t_f and `columns`, bit for bit.
    fn assert_same_answer(a: &Solution, b: &Solution, columns: [Column; 3], what: &str) {
        assert_eq!(a.status, b.status, "{what}");
        assert_eq!(a.iterations, b.iterations, "{what}");
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for column in columns {
            assert_eq!(bits(column(a)), bits(column(b)), "{what}");
        }
        assert_eq!(a.tf_s.to_bits(), b.tf_s.to_bits(), "{what}");
    }

    /// A re-plan that reuses the last one's NLP and Newton storage gives
    /// the answer of one that builds them afresh, bit for bit, along a
    /// sequence of re-plans from perturbed states (and after a mesh change,
    /// which must not reuse them).
    #[test]
    fn reused_replan_storage_gives_the_fresh_answer_bit_for_bit() {
        use crate::method::observer::Silent;
        let base = Scenario::paper();
        let settings = SolverSettings::default();
        let cold = direct::solve(&base, &settings, &mut Silent);
        assert_eq!(cold.status, Status::Solved);
        let plan = cold.plan();
        let mut reused = DirectSolver::default();
        for (k, nodes) in [(1, 20), (2, 20), (3, 16), (4, 20), (5, 20)] {
            let elapsed_s = 0.4 * k as f64;
            let x = plan.state_at(elapsed_s);
            let mut s = base.clone();
            s.initial = crate::guidance::planner::initial_state(&x);
            s.initial.x_m += 3.0 * k as f64;
            s.initial.vz_mps -= 0.5 * k as f64;
            s.discretization.nodes = nodes;
            s.discretization.tf_guess_s = plan.tf_s() - elapsed_s;
            let replan = Replan {
                plan: &plan,
                elapsed_s,
                relaxed_iterations: 0,
                proximal_weight: 0.0,
                direct_max_iterations: 40,
            };
            let a = reused.solve(&s, &settings, Start::Replan(replan), &mut Silent);
            let b =
                DirectSolver::default().solve(&s, &settings, Start::Replan(replan), &mut Silent);
            let columns: [Column; 3] = [|s| &s.mass_kg, |s| &s.x_m, |s| &s.thrust_n];
            assert_same_answer(&a, &b, columns, &format!("re-plan {k}"));
        }
    }

    /// Cold solves into one solver's kept storage (and one answer's) give
    /// the answers of [`direct::solve`], which builds everything afresh,
    /// bit for bit: from several initial states, after a mesh change, and
    /// with the coarse phase off.
    #[test]
    fn reused_cold_storage_gives_the_fresh_answer_bit_for_bit() {
        use crate::method::observer::Silent;
        let mut reused = DirectSolver::default();
        let mut out = Solution::empty(Method::Direct);
        for (k, nodes, coarse) in [(0, 20, 8), (1, 20, 8), (2, 16, 8), (3, 16, 0), (4, 20, 8)] {
            let mut s = Scenario::paper();
            s.initial.x_m += 15.0 * k as f64;
            s.initial.vz_mps += 2.0 * k as f64;
            s.discretization.nodes = nodes;
            let mut settings = SolverSettings::default();
            settings.direct.coarse_nodes = coarse;
            reused.solve_into(&s, &settings, Start::StraightLine, &mut Silent, &mut out);
            let fresh = direct::solve(&s, &settings, &mut Silent);
            assert_eq!(
                out.history.direct.len(),
                fresh.history.direct.len(),
                "solve {k}"
            );
            let columns: [Column; 3] = [|s| &s.mass_kg, |s| &s.z_m, |s| &s.thrust_n];
            assert_same_answer(&out, &fresh, columns, &format!("solve {k}"));
        }
    }

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
