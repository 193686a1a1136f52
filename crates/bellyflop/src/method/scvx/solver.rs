//! SCvx behind the [`Solver`] seam: a cold solve from the straight line (a
//! pass on a new mesh is solved cold too), and a re-plan from the shifted
//! plan with the conic solvers kept between re-plans.

use crate::collocation::plan::shifted_reference;
use crate::input::scenario::Scenario;
use crate::input::settings::SolverSettings;
use crate::method::observer::Observer;
use crate::method::scvx::transcription::Transcription;
use crate::method::scvx::{self, ConicSolver, Phases};
use crate::method::{Replan, Solver, Start};
use crate::solution::Solution;

/// Trust region of a warm re-plan's first subproblem (scaled ∞-norm); the
/// cold solve's 0.3 also did best from the shifted plan (examples/replan:
/// 0.03 and 0.1 took more iterations, 1 and 3 no fewer).
pub const WARM_TRUST_REGION: f64 = 0.3;

/// SCvx, with one conic solver per subproblem structure (relaxed, exact)
/// kept for its re-plans, so that they skip Clarabel's setup.
#[derive(Debug)]
pub struct ScvxSolver {
    conics: (ConicSolver, ConicSolver),
}

impl Default for ScvxSolver {
    fn default() -> Self {
        ScvxSolver {
            conics: (ConicSolver::new(), ConicSolver::new()),
        }
    }
}

impl Solver for ScvxSolver {
    fn solve(
        &mut self,
        scenario: &Scenario,
        settings: &SolverSettings,
        start: Start<'_>,
        observer: &mut dyn Observer,
    ) -> Solution {
        match start {
            // A cold solve sets up its own conic solvers; SCvx has no use
            // for an answer on another mesh.
            Start::StraightLine | Start::Answer(_) => scvx::solve(scenario, settings, observer),
            Start::Replan(replan) => self.replan(scenario, settings, &replan, observer),
        }
    }
}

impl ScvxSolver {
    /// SCvx's relaxed-then-exact phases from the shifted plan, each with the
    /// warm trust region; `solver.max_iterations` bounds both.
    fn replan(
        &mut self,
        s: &Scenario,
        settings: &SolverSettings,
        replan: &Replan<'_>,
        observer: &mut dyn Observer,
    ) -> Solution {
        let mut settings = settings.clone();
        settings.proximal_weight = replan.proximal_weight;
        let warm =
            |settings: &mut SolverSettings| settings.trust_region_initial = WARM_TRUST_REGION;
        let phases = Phases {
            relaxed_iterations: replan.relaxed_iterations,
            relaxed_tuning: warm,
            exact_tuning: warm,
        };
        let reference = |tr: &Transcription| {
            shifted_reference(replan.plan, replan.elapsed_s, &tr.mesh, &tr.x0, tr.form)
        };
        phases.solve(s, &settings, &reference, &mut self.conics, observer)
    }
}
