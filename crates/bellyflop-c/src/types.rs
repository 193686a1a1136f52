//! The C-facing types: error codes, statuses, methods, the settings of a
//! solver, a vehicle state and one node of a solution. Plain data with a C
//! layout (`#[repr(C)]`); no `unsafe` here.
#![allow(non_camel_case_types)]

use bellyflop::Status;

/// What a call returns. `BF_ERROR_OK` from `bf_solve` or `bf_replan` means
/// the method ran: how it ended is the solution's `status`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum bf_error {
    /// The call did what it says.
    Ok = 0,
    /// A pointer argument was NULL.
    NullPointer = 1,
    /// A number or setting out of its range (NaN included), or two that
    /// contradict each other: `bf_last_error` names the field, its value and
    /// the allowed range.
    InvalidInput = 2,
    /// The TOML text does not parse, or has an unknown or mistyped field
    /// (line and column in `bf_last_error`).
    Parse = 3,
    /// A file could not be read, or is not UTF-8 text.
    Io = 4,
    /// A C string argument is not UTF-8.
    NotUtf8 = 5,
    /// A caller-owned buffer is smaller than the answer (the needed size is
    /// in `bf_last_error`); nothing was solved.
    BufferTooSmall = 6,
    /// A Rust panic was caught at the boundary (a bug in bellyflop: please
    /// report it with `bf_last_error`). Free the solver; its state is not
    /// guaranteed.
    Panic = 7,
}

/// How a solve ended (the library's `Status`). A status is a claim: only
/// `BF_STATUS_SOLVED` is a converged trajectory that meets the dynamics at
/// its collocation nodes and the physical checks, and holds every limit of
/// the problem's `[constraints]` at its nodes (both methods hold them
/// there; an answer outside one would be `BF_STATUS_NON_PHYSICAL` and not
/// adopted). A flight loop's calls do
/// not re-integrate the controls between the nodes (that costs more than a
/// re-plan): on the paper's case at N = 20 they miss the pad by 0.8 m when
/// flown open loop, which the next re-plans correct in closed loop
/// (`bellyflop sim`); `bellyflop solve` re-integrates, polishes and calls
/// an answer that misses `inaccurate`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum bf_status {
    /// Converged, the dynamics met at the nodes, and the physical checks
    /// pass (the flown landing error is not checked: see above).
    Solved = 0,
    /// Converged, but the relaxation is not tight or the thrust points
    /// backwards.
    NonPhysical = 1,
    /// No trajectory exists from this state, by a certificate: the
    /// vertical stopping bound, the propellant bound, or an initial state
    /// outside an operational limit (the message says which).
    Infeasible = 2,
    /// The iteration budget or the wall-clock budget was spent, or the
    /// method stopped locally infeasible (no trajectory was found, which
    /// is not a proof that none exists): the best iterate is returned.
    NotConverged = 3,
    /// The inner solver failed.
    SolverFailed = 4,
    /// Converged, but its controls, re-integrated, miss the target by more
    /// than the landing tolerances (the library's pipeline; `bf_solve` and
    /// `bf_replan` do not re-integrate, so they do not return it).
    Inaccurate = 5,
}

impl From<Status> for bf_status {
    fn from(s: Status) -> Self {
        match s {
            Status::Solved => bf_status::Solved,
            Status::NonPhysical => bf_status::NonPhysical,
            Status::Infeasible => bf_status::Infeasible,
            Status::NotConverged => bf_status::NotConverged,
            Status::SolverFailed => bf_status::SolverFailed,
            Status::Inaccurate => bf_status::Inaccurate,
        }
    }
}

/// The statuses in the order of their codes (`bf_status_str`).
#[cfg(test)]
pub(crate) const STATUSES: [Status; 6] = [
    Status::Solved,
    Status::NonPhysical,
    Status::Infeasible,
    Status::NotConverged,
    Status::SolverFailed,
    Status::Inaccurate,
];

/// The method of a solver (`bf_settings.method`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum bf_method {
    /// The problem's own `solver.method` (the paper's file: direct).
    FromProblem = 0,
    /// The direct interior-point method.
    Direct = 1,
    /// Successive convexification with Clarabel (the paper's method).
    Scvx = 2,
}

/// A solver's settings: its method and the budgets of each call. Get the
/// defaults with `bf_settings_default` and change what you need.
///
/// A call ends at whichever budget it reaches first, with the best iterate
/// and `BF_STATUS_NOT_CONVERGED`. The wall-clock budget is checked after
/// each iteration, so a call may overrun it by one iteration (and the
/// setup before the first).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct bf_settings {
    /// A `bf_method` value.
    pub method: i32,
    /// Iteration budget of `bf_solve` (interior-point iterations for the
    /// direct method, SCvx iterations for SCvx); 0: the problem's own
    /// (`solver.direct.max_iterations` or `solver.max_iterations`).
    pub solve_max_iterations: u32,
    /// Iteration budget of `bf_replan`; 0: guidance's default (40
    /// interior-point iterations, or the problem's SCvx budget). A direct
    /// re-plan that does not solve warm, or lands more than 300 kg below
    /// the plan's predicted final mass, is tried cold as well, each within
    /// this budget (guidance's basin check): up to twice the budget in all.
    /// The wall-clock budget covers the whole call.
    pub replan_max_iterations: u32,
    /// Wall-clock budget of each `bf_solve` or `bf_replan` call \[s\]; 0: none.
    pub time_budget_s: f64,
}

/// A vehicle state in SI units and radians (the collocation state, with the
/// mass in kg rather than its logarithm).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct bf_state {
    /// Horizontal position \[m\].
    pub x_m: f64,
    /// Altitude \[m\].
    pub z_m: f64,
    /// Horizontal velocity \[m/s\].
    pub vx_mps: f64,
    /// Vertical velocity \[m/s\].
    pub vz_mps: f64,
    /// Pitch angle from the vertical \[rad\].
    pub theta_rad: f64,
    /// Pitch rate \[rad/s\].
    pub pitch_rate_radps: f64,
    /// Mass \[kg\].
    pub mass_kg: f64,
    /// Nozzle (gimbal) angle \[rad\].
    pub gimbal_rad: f64,
}

/// One node of a solution: its time from the plan's start, the state, and
/// the controls there (at t_f the last collocation point's, as the
/// library's `Solution` reports them).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct bf_node {
    /// Time from the plan's start \[s\].
    pub t_s: f64,
    pub state: bf_state,
    /// Thrust \[N\].
    pub thrust_n: f64,
    /// Gimbal rate command \[rad/s\].
    pub gimbal_rate_radps: f64,
}

/// The answer of `bf_solve` or `bf_replan`. The caller owns it and its node
/// array: set `nodes` and `node_capacity` (at least
/// `bf_solver_node_count`) before the call; the call fills the rest.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct bf_solution {
    /// Caller-owned array of `node_capacity` nodes (input).
    pub nodes: *mut bf_node,
    /// Length of `nodes` (input).
    pub node_capacity: usize,
    /// Nodes written: N + 1 (output).
    pub node_count: usize,
    /// How the solve ended (output).
    pub status: bf_status,
    /// Iterations of the method (output).
    pub iterations: u32,
    /// Whether this answer became the solver's plan, the warm start of the
    /// next `bf_replan` and what `bf_plan_state_at` reads (output): only a
    /// `BF_STATUS_SOLVED` answer does.
    pub adopted: bool,
    /// Final time t_f \[s\] from the plan's start (output).
    pub tf_s: f64,
    /// Final mass \[kg\] (output).
    pub final_mass_kg: f64,
    /// The method's wall-clock time \[ms\] (output).
    pub solve_time_ms: f64,
}
