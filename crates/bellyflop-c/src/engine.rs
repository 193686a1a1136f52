//! The safe side of the C API: a problem, a solver around the library's
//! warm-started [`Planner`], the budgets of each call, and the copy of an
//! answer into caller-owned nodes. Everything here is plain Rust; the FFI
//! layer (`ffi`) only checks pointers and converts.

use std::time::{Duration, Instant};

use bellyflop::guidance::planner::{Planner, DIRECT_REPLAN_ITERATIONS};
use bellyflop::input::scenario::InitialState;
use bellyflop::method::observer::{Iteration, Observer};
use bellyflop::{Case, InputError, Method, Solution, Status};

use crate::error::Failure;
use crate::types::{bf_error, bf_method, bf_node, bf_settings, bf_state};

/// Longest wall-clock budget of a call \[s\] (a day): a flight loop's is
/// milliseconds, and a longer one is as good as none.
pub const BF_MAX_TIME_BUDGET_S: f64 = 86_400.0;

/// A landing problem: the scenario and the solver settings of a case.
#[derive(Debug, Clone)]
pub struct Problem {
    pub case: Case,
}

impl Problem {
    /// The paper's case (the shipped `scenarios/paper.toml`).
    pub fn paper() -> Problem {
        Problem {
            case: Case::paper(),
        }
    }

    /// A problem from a scenario file's text, parsed and validated; a
    /// 6-DoF one is refused ([`Problem::planar`]).
    pub fn from_toml_str(text: &str) -> Result<Problem, Failure> {
        Problem::planar(Case::from_toml_str(text)?)
    }

    /// A problem from a scenario file, read, parsed and validated; a 6-DoF
    /// one is refused ([`Problem::planar`]).
    pub fn from_file(path: &std::path::Path) -> Result<Problem, Failure> {
        Problem::planar(Case::from_file(path)?)
    }

    /// The problem of a planar case: the C API solves and re-plans only the
    /// planar model, so a 6-DoF case (`model = "6dof"`) is
    /// [`InputError::ModelUnavailable`] (`BF_ERROR_INVALID_INPUT`).
    fn planar(case: Case) -> Result<Problem, Failure> {
        case.scenario.require_planar("the C API")?;
        Ok(Problem { case })
    }

    /// Replace the initial state. A state out of range is refused (the
    /// error names the field) and the problem keeps its old one.
    pub fn set_initial_state(&mut self, state: &bf_state) -> Result<(), Failure> {
        let mut s = self.case.scenario.clone();
        s.initial = initial_state(state);
        s.validate()?;
        self.case.scenario = s;
        Ok(())
    }

    /// The initial state, in the C units.
    pub fn initial_state(&self) -> bf_state {
        c_state(&self.case.scenario.initial)
    }

    /// Nodes of a solution: N + 1.
    pub fn node_count(&self) -> usize {
        self.case.scenario.discretization.nodes + 1
    }
}

/// A C state as the scenario's initial state (degrees for the angles).
pub fn initial_state(s: &bf_state) -> InitialState {
    InitialState {
        x_m: s.x_m,
        z_m: s.z_m,
        vx_mps: s.vx_mps,
        vz_mps: s.vz_mps,
        theta_deg: s.theta_rad.to_degrees(),
        pitch_rate_degps: s.pitch_rate_radps.to_degrees(),
        mass_kg: s.mass_kg,
        gimbal_deg: s.gimbal_rad.to_degrees(),
        ..Default::default()
    }
}

/// The defaults of `bf_settings_default`: the problem's method and budgets,
/// guidance's re-plan budget, no wall-clock budget.
pub fn default_settings() -> bf_settings {
    bf_settings {
        method: bf_method::FromProblem as i32,
        solve_max_iterations: 0,
        replan_max_iterations: 0,
        time_budget_s: 0.0,
    }
}

/// Settings checked: the method one of `bf_method`'s, the wall-clock budget
/// finite within [0, [`BF_MAX_TIME_BUDGET_S`]].
#[derive(Debug, Clone, Copy)]
struct Checked {
    method: Method,
    solve_max_iterations: usize,
    replan_max_iterations: usize,
    time_budget: Option<Duration>,
}

fn check_settings(s: &bf_settings, problem: &Problem) -> Result<Checked, Failure> {
    let method = match s.method {
        0 => problem.case.solver.method,
        1 => Method::Direct,
        2 => Method::Scvx,
        m => {
            return Err(Failure::invalid(format!(
                "settings.method = {m} is out of range: allowed 0 (BF_METHOD_FROM_PROBLEM), 1 (BF_METHOD_DIRECT) or 2 (BF_METHOD_SCVX)"
            )))
        }
    };
    let t = s.time_budget_s;
    if !(0.0..=BF_MAX_TIME_BUDGET_S).contains(&t) {
        return Err(InputError::OutOfRange {
            field: "settings.time_budget_s".into(),
            value: t,
            allowed: format!("[0, {BF_MAX_TIME_BUDGET_S}] s (0: no budget)"),
        }
        .into());
    }
    Ok(Checked {
        method,
        solve_max_iterations: s.solve_max_iterations as usize,
        replan_max_iterations: s.replan_max_iterations as usize,
        time_budget: (t > 0.0).then(|| Duration::from_secs_f64(t)),
    })
}

/// An observer that ends a solve once a wall-clock instant has passed.
struct Deadline {
    at: Option<Instant>,
}

impl Deadline {
    fn after(budget: Option<Duration>) -> Deadline {
        Deadline {
            at: budget.and_then(|b| Instant::now().checked_add(b)),
        }
    }
}

impl Observer for Deadline {
    fn iteration(&mut self, _: Iteration<'_>) {}
    fn deadline_passed(&mut self) -> bool {
        self.at.is_some_and(|at| Instant::now() >= at)
    }
}

/// A flight loop's solver: the library's [`Planner`] (its plan and its
/// method's warm-start state), the budgets, and the flight time at which
/// the current plan starts.
#[derive(Debug)]
pub struct FlightSolver {
    planner: Planner,
    settings: Checked,
    /// The problem's own iteration budgets, for the 0 settings.
    problem_direct_max_iterations: usize,
    problem_scvx_max_iterations: usize,
    /// Flight time of the current plan's first node \[s\]: 0 after
    /// `bf_solve`, the measurement's time after an adopted re-plan.
    plan_start_s: f64,
    node_count: usize,
    /// The last answer, whose storage each re-plan reuses: after
    /// `solve` (which also prepares the re-plans' storage) a direct
    /// re-plan allocates nothing (issue 27).
    answer: Solution,
}

/// What a solve returned, with whether it became the plan.
pub struct Answer<'a> {
    pub solution: &'a Solution,
    pub adopted: bool,
}

impl FlightSolver {
    /// A solver for `problem` with `settings`.
    pub fn new(problem: &Problem, settings: &bf_settings) -> Result<FlightSolver, Failure> {
        let settings = check_settings(settings, problem)?;
        let case = &problem.case;
        let mut planner = Planner::new(case.scenario.clone(), case.solver.clone());
        planner.method = settings.method;
        let mut solver = FlightSolver {
            planner,
            settings,
            problem_direct_max_iterations: case.solver.direct.max_iterations,
            problem_scvx_max_iterations: case.solver.max_iterations,
            plan_start_s: 0.0,
            node_count: problem.node_count(),
            answer: Solution::empty(settings.method),
        };
        solver.prepare();
        Ok(solver)
    }

    /// The setup: the storage of every later solve and re-plan (the
    /// method's NLPs and workspaces, the answer's history), with room for
    /// both budgets, so that `solve` and `replan` allocate nothing on
    /// their converging paths (issue 27).
    fn prepare(&mut self) {
        self.set_budget(true);
        let replan_iterations = self.planner.direct_max_iterations;
        self.set_budget(false);
        let cold_iterations = self.planner.settings.direct.max_iterations;
        let p = &mut self.planner;
        p.settings.direct.max_iterations = cold_iterations.max(replan_iterations);
        p.direct_max_iterations = replan_iterations;
        p.prepare(&mut self.answer);
    }

    /// Nodes of an answer: N + 1.
    pub fn node_count(&self) -> usize {
        self.node_count
    }

    /// Set the method's iteration budgets for a cold solve (`replan`
    /// false) or a re-plan: the settings', or where they are 0 the
    /// problem's (cold) and guidance's (direct re-plan).
    fn set_budget(&mut self, replan: bool) {
        let s = &self.settings;
        let budget = if replan {
            s.replan_max_iterations
        } else {
            s.solve_max_iterations
        };
        let pick = |default: usize| if budget == 0 { default } else { budget };
        let p = &mut self.planner;
        p.settings.direct.max_iterations = pick(self.problem_direct_max_iterations);
        p.direct_max_iterations = pick(DIRECT_REPLAN_ITERATIONS);
        p.settings.max_iterations = pick(self.problem_scvx_max_iterations);
    }

    /// Cold solve from the problem's initial state, as the planner's first
    /// plan; the plan then starts at flight time 0.
    pub fn solve(&mut self) -> Answer<'_> {
        self.set_budget(false);
        self.planner.clear_plan();
        let mut deadline = Deadline::after(self.settings.time_budget);
        self.planner.cold_into(&mut deadline, &mut self.answer);
        let adopted = self.answer.status == Status::Solved;
        if adopted {
            self.plan_start_s = 0.0;
        }
        Answer {
            solution: &self.answer,
            adopted,
        }
    }

    /// Re-plan from `measured` at flight time `t_now_s`, warm-started from
    /// the current plan (a cold solve when there is none).
    pub fn replan(&mut self, measured: &bf_state, t_now_s: f64) -> Result<Answer<'_>, Failure> {
        let elapsed_s = self.elapsed_s(t_now_s)?;
        self.set_budget(true);
        let mut deadline = Deadline::after(self.settings.time_budget);
        let state = initial_state(measured);
        self.planner
            .replan_into(&state, elapsed_s, &mut deadline, &mut self.answer)
            .map_err(|e| Failure::from(e).context("measured_state"))?;
        let adopted = self.answer.status == Status::Solved;
        if adopted {
            self.plan_start_s = t_now_s;
        }
        Ok(Answer {
            solution: &self.answer,
            adopted,
        })
    }

    /// Time since the current plan's start \[s\]; `t_now_s` must be finite
    /// and not before that start.
    fn elapsed_s(&self, t_now_s: f64) -> Result<f64, Failure> {
        if !(t_now_s.is_finite() && t_now_s >= self.plan_start_s) {
            return Err(InputError::OutOfRange {
                field: "t_now_s".into(),
                value: t_now_s,
                allowed: format!(
                    "[{}, ∞) s: finite, not before the current plan's start",
                    self.plan_start_s
                ),
            }
            .into());
        }
        Ok(t_now_s - self.plan_start_s)
    }

    /// The current plan's state at flight time `t_now_s` (held at its ends).
    pub fn plan_state_at(&self, t_now_s: f64) -> Result<bf_state, Failure> {
        let elapsed_s = self.elapsed_s(t_now_s)?;
        let plan = self.planner.plan.as_ref().ok_or_else(Failure::no_plan)?;
        let x = plan.state_at(elapsed_s);
        let c = bellyflop::guidance::planner::initial_state(&x);
        Ok(c_state(&c))
    }

    /// The current plan's thrust-per-mass σ \[N/kg\] and nozzle angle δ
    /// \[rad\] to fly at flight time `t_now_s` (PCHIP between the nodes, as
    /// guidance flies a plan).
    pub fn plan_controls_at(&self, t_now_s: f64) -> Result<(f64, f64), Failure> {
        let elapsed_s = self.elapsed_s(t_now_s)?;
        let plan = self.planner.plan.as_ref().ok_or_else(Failure::no_plan)?;
        Ok(plan.flight_controls_at(elapsed_s))
    }

    /// Flight time of the current plan's first node \[s\].
    pub fn plan_start_s(&self) -> f64 {
        self.plan_start_s
    }
}

/// A scenario state in the C units.
fn c_state(i: &InitialState) -> bf_state {
    bf_state {
        x_m: i.x_m,
        z_m: i.z_m,
        vx_mps: i.vx_mps,
        vz_mps: i.vz_mps,
        theta_rad: i.theta_deg.to_radians(),
        pitch_rate_radps: i.pitch_rate_degps.to_radians(),
        mass_kg: i.mass_kg,
        gimbal_rad: i.gimbal_deg.to_radians(),
    }
}

/// Check that `capacity` nodes hold an answer of `needed`.
pub fn check_capacity(capacity: usize, needed: usize) -> Result<(), Failure> {
    if capacity < needed {
        return Err(Failure {
            code: bf_error::BufferTooSmall,
            message: format!(
                "solution.node_capacity = {capacity} is out of range: allowed at least {needed} (N + 1 nodes of this problem)"
            ),
        });
    }
    Ok(())
}

/// Node `k` of `sol`.
pub fn node(sol: &Solution, k: usize) -> bf_node {
    bf_node {
        t_s: sol.t_s[k],
        state: bf_state {
            x_m: sol.x_m[k],
            z_m: sol.z_m[k],
            vx_mps: sol.vx_mps[k],
            vz_mps: sol.vz_mps[k],
            theta_rad: sol.theta_rad[k],
            pitch_rate_radps: sol.pitch_rate_radps[k],
            mass_kg: sol.mass_kg[k],
            gimbal_rad: sol.delta_rad[k],
        },
        thrust_n: sol.thrust_n[k],
        gimbal_rate_radps: sol.gimbal_rate_radps[k],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bellyflop::input::scenario::PAPER_TOML;

    /// A 6-DoF scenario is refused as invalid input, the message naming
    /// the model and the C API, rather than solved as planar.
    #[test]
    fn a_six_dof_problem_is_refused() {
        let text = PAPER_TOML.replacen(
            "name = \"paper\"\n",
            "name = \"paper\"\nmodel = \"6dof\"\n",
            1,
        );
        assert!(text.contains("model = \"6dof\""));
        let e = Problem::from_toml_str(&text).unwrap_err();
        assert_eq!(e.code, bf_error::InvalidInput);
        assert!(
            e.message
                .contains("model = \"6dof\" is not yet available in the C API"),
            "{}",
            e.message
        );
        assert!(Problem::from_toml_str(PAPER_TOML).is_ok());
    }
}
