//! The methods that solve a transcribed landing problem, behind one seam:
//!
//! - [`Solver`]: what the pipeline, refinement and guidance call, with a
//!   typed [`Start`]; each method keeps its own warm-start state (SCvx its
//!   conic solvers, the direct method the multipliers of its last answer);
//! - [`solver`]: the one place that chooses a method from the settings;
//! - [`scvx`]: successive convexification of P2 with Clarabel (the paper's);
//! - [`direct`]: a primal–dual interior-point method on the nonlinear
//!   program, with a KKT solve that exploits the collocation's structure;
//! - [`observer`]: the iteration records, as they complete.

pub mod direct;
pub mod observer;
pub mod scvx;

use crate::collocation::plan::Plan;
use crate::input::scenario::Scenario;
use crate::input::settings::{Method, SolverSettings};
use crate::method::observer::Observer;
use crate::solution::Solution;

/// Where a solve starts.
#[derive(Debug, Clone, Copy)]
pub enum Start<'a> {
    /// The straight line between the boundary states, with the scenario's
    /// t_f and final-mass guesses (Section 3.4).
    StraightLine,
    /// A previous answer of the same problem on another mesh (the passes of
    /// mesh refinement). The direct method starts primal–dual from it when
    /// it produced that answer itself; SCvx solves cold.
    Answer(&'a Solution),
    /// A re-plan from a measured state: the previous plan's tail.
    Replan(Replan<'a>),
}

/// A re-plan's start: the previous plan from `elapsed_s` on, and the warm
/// settings that guidance gives each method.
#[derive(Debug, Clone, Copy)]
pub struct Replan<'a> {
    pub plan: &'a Plan,
    /// Time since the plan's start \[s\].
    pub elapsed_s: f64,
    /// SCvx: iterations of the relaxed first phase (0: the exact
    /// formulation directly).
    pub relaxed_iterations: usize,
    /// SCvx: the subproblems' proximal weight, in place of the settings'.
    pub proximal_weight: f64,
    /// The direct method: the interior-point iteration budget.
    pub direct_max_iterations: usize,
}

/// A method that solves a landing problem on the scenario's mesh. It skips
/// the pipeline's certificate and accuracy check ([`crate::solve`]).
pub trait Solver: std::fmt::Debug + Send {
    /// The method's answer for `scenario` from `start`. Its iterations are
    /// reported to `observer` as they complete.
    fn solve(
        &mut self,
        scenario: &Scenario,
        settings: &SolverSettings,
        start: Start<'_>,
        observer: &mut dyn Observer,
    ) -> Solution;

    /// [`Solver::solve`] into `out`, in `out`'s own storage where the
    /// method can: the direct method's re-plans allocate nothing in a
    /// flight loop (issue 27). By default, `out` is replaced.
    fn solve_into(
        &mut self,
        scenario: &Scenario,
        settings: &SolverSettings,
        start: Start<'_>,
        observer: &mut dyn Observer,
        out: &mut Solution,
    ) {
        *out = self.solve(scenario, settings, start, observer);
    }

    /// Make, now, what cold solves and re-plans of `scenario`'s mesh need
    /// (the direct method's NLPs and storage; by default nothing), so that
    /// neither allocates later into an answer of the right size.
    /// `settings` carry the cold budget; `direct_replan_iterations` is a
    /// direct re-plan's.
    fn prepare(
        &mut self,
        _scenario: &Scenario,
        _settings: &SolverSettings,
        _direct_replan_iterations: usize,
    ) {
    }
}

/// The solver of `method`, with no warm-start state yet: the one place that
/// chooses a method.
pub fn solver(method: Method) -> Box<dyn Solver> {
    match method {
        Method::Scvx => Box::new(scvx::solver::ScvxSolver::default()),
        Method::Direct => Box::new(direct::solver::DirectSolver::default()),
    }
}

/// An answer that no method iterated on: the straight-line guess on the
/// scenario's mesh with `status` and `message` (a certified-infeasible
/// scenario's, whose certificate is the message), for the method the
/// settings name.
pub fn guess_answer(
    scenario: &Scenario,
    settings: &SolverSettings,
    status: crate::solution::Status,
    message: String,
    solve_time_ms: f64,
) -> Solution {
    let tr = scvx::transcription::Transcription::new(scenario, settings);
    let d = &scenario.discretization;
    let guess = scvx::straight_line(&tr, d.tf_guess_s, d.final_mass_guess_kg);
    let outcome = crate::solution::SolveOutcome {
        method: settings.method,
        status,
        message,
        checks: tr.checks(&guess, 0.0),
        history: crate::solution::History::default(),
        solve_time_ms,
    };
    Solution::new(&tr.mesh, &tr.model, tr.form, guess, outcome)
}
