//! The result of a solve: status, trajectory in physical units, checks and history.

use crate::flown::FlownControls;
use serde::Serialize;

use crate::collocation::mesh::Mesh;
use crate::collocation::plan::Plan;
use crate::collocation::trajectory::Trajectory;
use crate::input::mesh_layout::MeshLayout;
use crate::input::settings::{Formulation, Method};
use crate::problem::dynamics::{self, ix, Model};
use crate::problem::feasibility::Certificate;

/// How a solve ended. Each variant has its own exit code.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Converged, dynamics met, and the physical checks pass.
    Solved,
    /// Converged, but the relaxation is not tight or the thrust points backwards.
    NonPhysical,
    /// No trajectory exists. From [`crate::solve`] only with a certificate
    /// ([`crate::problem::feasibility`], in `certificate`), computed before
    /// solving, or (the approach cone's) after the methods found no
    /// trajectory that holds the operational limits. The methods on
    /// their own ([`crate::method::scvx::solve`], [`crate::method::direct::solve`], the
    /// closed loop's re-plans) also report a local infeasibility this way —
    /// a point that still needs virtual control, or a failed feasibility
    /// restoration — which [`crate::solve`] reports as `not_converged`.
    Infeasible,
    /// Iteration or trust-region limit reached; the best iterate is returned.
    NotConverged,
    /// The conic solver failed on every attempt.
    SolverFailed,
    /// Converged and passes the checks, but its controls, re-integrated,
    /// miss the target by more than the scenario's landing tolerances
    /// ([`crate::verify::accuracy`]; set by [`crate::solve`] only).
    Inaccurate,
}

impl Status {
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Solved => "solved",
            Status::NonPhysical => "non_physical",
            Status::Infeasible => "infeasible",
            Status::NotConverged => "not_converged",
            Status::SolverFailed => "solver_failed",
            Status::Inaccurate => "inaccurate",
        }
    }

    /// Process exit code: 0 solved, 3 infeasible, 4 not converged,
    /// 5 non-physical, 6 solver failure, 9 inaccurate (2 is bad input, before
    /// any solve; `sim` uses 7 and 8).
    pub fn exit_code(self) -> i32 {
        match self {
            Status::Solved => 0,
            Status::Infeasible => 3,
            Status::NotConverged => 4,
            Status::NonPhysical => 5,
            Status::SolverFailed => 6,
            Status::Inaccurate => 9,
        }
    }
}

/// One SCvx iteration, as recorded by the driver loop.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IterationRecord {
    pub iteration: usize,
    /// Penalized nonlinear cost J of the candidate (scaled).
    pub cost: f64,
    /// Final mass of the candidate \[kg\].
    pub final_mass_kg: f64,
    /// ‖Δẑ‖∞ of the candidate against the reference (scaled).
    pub step: f64,
    /// Largest virtual control or buffer of the candidate (scaled).
    pub virtual_control: f64,
    /// Largest nonlinear collocation defect of the candidate (scaled).
    pub defect: f64,
    /// Trust-region radius the subproblem was solved with.
    pub trust_radius: f64,
    /// Acceptance ratio ρ = actual / predicted decrease of J.
    pub rho: f64,
    pub accepted: bool,
    /// Whether the candidate is the second-order correction of the
    /// subproblem's answer (`solver.second_order_correction`).
    pub corrected: bool,
    pub ipm_iterations: u32,
    pub ms: f64,
}

/// One interior-point iteration, as recorded by the driver.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DirectIteration {
    pub iteration: usize,
    /// Collocation points N of the mesh the iteration ran on (the coarse
    /// start's mesh, or the scenario's).
    pub mesh_nodes: usize,
    /// Final mass of the iterate \[kg\] (the objective).
    pub final_mass_kg: f64,
    /// Largest |defect| (scaled).
    pub primal_infeasibility: f64,
    /// Largest |∇L| (scaled, divided by IPOPT's s_d).
    pub dual_infeasibility: f64,
    /// Barrier parameter μ.
    pub mu: f64,
    /// Primal step length α.
    pub step: f64,
    /// Largest regularization δ_w of a node block (0: none needed).
    pub inertia_correction: f64,
    /// Backtracking trials of the line search.
    pub line_search_trials: usize,
    /// Whether the step came from the feasibility restoration.
    pub restoration: bool,
    pub ms: f64,
}

/// One iteration of the polish ([`crate::polish`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PolishIteration {
    pub iteration: usize,
    /// Final mass of the shot at the iterate \[kg\].
    pub final_mass_kg: f64,
    /// Σ|r̂| of the scaled terminal residual at the iterate (1 ↔ 1 m).
    pub residual: f64,
    /// Its path violation (ground \[m\] or dry mass \[kg\]).
    pub path_violation: f64,
    /// The mass the QP's step would gain, to first order \[kg\].
    pub predicted_gain_kg: f64,
    /// Actual over predicted decrease of the merit (NaN, JSON null, on the
    /// last iteration, which stops before judging a step).
    pub rho: f64,
    pub accepted: bool,
    /// The proximal weight ε of the QP.
    pub proximal_weight: f64,
    pub qp_iterations: u32,
    /// Σ|r̂| of the landing residual of the QP's step itself, flown, before
    /// the second-order correction that a poor step gets (the QP's
    /// linearization puts it at zero: the rest is the landing's second
    /// order). NaN (JSON null) where no step was judged.
    pub step_residual: f64,
}

/// One arc structure the polish flew: the collocation's, then each
/// repaired one ([`crate::polish::repair`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PolishStructure {
    /// Thrust segments (bound or free) of the structure.
    pub segments: usize,
    /// The polish's iterations on it.
    pub iterations: usize,
    /// Its answer's final mass \[kg\] (None: the polish failed on it).
    pub final_mass_kg: Option<f64>,
    /// Bound arcs its certificate found contradicted.
    pub contradicted_arcs: Option<usize>,
    /// Whether it is the published answer.
    pub kept: bool,
}

/// The polish's own account: its iterations, the QPs' iterations (the
/// active-set method's changes of its active set, or the interior point's
/// iterations where it solved), and its time (JSON `polish`).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct PolishReport {
    /// Iterations over every run (the first, and a repair's).
    pub iterations: usize,
    /// Polishes on repaired arcs ([`crate::polish::repair`]).
    pub repairs: usize,
    /// Every structure flown, in order.
    pub structures: Vec<PolishStructure>,
    pub qp_iterations: u32,
    pub time_ms: f64,
    pub history: Vec<PolishIteration>,
}

/// What the thrust does on one arc of a polished answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ThrustArcKind {
    /// T = T_max.
    Upper,
    /// T = T_min.
    Lower,
    /// A cubic between the bounds.
    Free,
}

/// One thrust arc of a polished answer and its switching function S_T
/// along it, scaled by the flight's largest |S_T|
/// ([`crate::polish::certificate`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ThrustArc {
    pub t_start_s: f64,
    pub t_end_s: f64,
    pub kind: ThrustArcKind,
    pub switching_min: f64,
    pub switching_max: f64,
    /// S_T at the arc's start (at a switch from another arc, ≈ 0 at an
    /// optimum).
    pub switching_at_start: f64,
}

/// The Pontryagin certificate of a polished answer (JSON `optimality`;
/// [`crate::polish::certificate`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Optimality {
    /// False where the ground or the dry mass is active (the costates
    /// leave their multipliers out).
    pub evaluated: bool,
    /// Evaluated, converged, and no bound arc's S_T has the wrong sign.
    pub holds: bool,
    /// The polish stopped on its tolerances (the terminal residual, the
    /// path and the QP's predicted gain of mass below theirs), not at its
    /// iteration cap: a first-order loop that creeps to its cap with the
    /// right signs can still be kilograms short (measured on the seeded
    /// envelope, BENCHMARKS.md), so the certificate does not hold there.
    pub converged: bool,
    /// Bound arcs whose S_T has the wrong sign.
    pub contradicted_arcs: usize,
    /// The flight's largest |S_T| (per newton, scaled by the mass scale).
    pub switching_scale: f64,
    pub thrust_arcs: Vec<ThrustArc>,
    /// The terminal multipliers μ of the polish's last QP (x, z, Vx, Vz,
    /// θ, w; in its scaled residuals), which give λ(t_f).
    pub multipliers: [f64; 6],
    /// The largest multiplier of its path rows.
    pub path_multiplier: f64,
    /// S_T and S_δ sampled along the flight. Only the published
    /// certificate carries them (JSON `optimality.switching`); the
    /// certificates of the structures the polish flew and set aside do not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub switching: Option<SwitchingSamples>,
}

/// The switching functions of a polished answer at the start of every RK4
/// step of its shot and at t_f ([`crate::polish::adjoint`]), each divided
/// by its own largest |·| over the flight (its scale, given).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct SwitchingSamples {
    /// The samples' times \[s\], from 0 to t_f.
    pub t_s: Vec<f64>,
    /// S_T = ∂H/∂T over `thrust_scale`. The minimum principle wants
    /// T = T_max where S_T < 0 and T = T_min where S_T > 0.
    pub thrust: Vec<f64>,
    /// S_δ = ∂H/∂δ over `delta_scale` (λ̇_δ = −S_δ).
    pub delta: Vec<f64>,
    /// The flight's largest |S_T| (as [`Optimality::switching_scale`]).
    pub thrust_scale: f64,
    /// The flight's largest |S_δ| (per radian, scaled by the mass scale).
    pub delta_scale: f64,
}

/// The iterations of a solve, in order: SCvx's or the direct method's (a
/// solve runs one method; each list is empty for the other).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct History {
    /// SCvx iterations (JSON `history`, always present).
    #[serde(rename = "history")]
    pub scvx: Vec<IterationRecord>,
    /// Interior-point iterations (JSON `direct_history`, when there are any).
    #[serde(rename = "direct_history", skip_serializing_if = "Vec::is_empty")]
    pub direct: Vec<DirectIteration>,
}

impl History {
    /// The iterations of one direct solve.
    pub fn direct(direct: Vec<DirectIteration>) -> Self {
        History {
            scvx: Vec::new(),
            direct,
        }
    }

    /// The iterations of one SCvx solve.
    pub fn scvx(scvx: Vec<IterationRecord>) -> Self {
        History {
            scvx,
            direct: Vec::new(),
        }
    }

    /// Number of iterations.
    pub fn len(&self) -> usize {
        self.scvx.len() + self.direct.len()
    }

    /// No iterations.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// `later`'s iterations after these, every record numbered 1, 2, … in
    /// order (each phase of a solve numbers its own from 1).
    pub fn append(&mut self, later: History) {
        self.scvx.extend(later.scvx);
        self.direct.extend(later.direct);
        for (k, h) in self.scvx.iter_mut().enumerate() {
            h.iteration = k + 1;
        }
        for (k, h) in self.direct.iter_mut().enumerate() {
            h.iteration = k + 1;
        }
    }
}

/// How far a returned path may dip below the landing altitude at a node and
/// still be `solved` \[m\]: 1 mm, a thousandth of the paper's re-integrated
/// landing error (0.8 m). The ground bound z ≥ z_f holds only to the
/// subproblem's tolerances: a 0 tolerance (1 µm before) called a path
/// 1.5 µm under the pad `non_physical`.
pub const GROUND_TOLERANCE_M: f64 = 1e-3;

/// The names of [`Solution::state_columns`], in the same order (the JSON's
/// keys of those arrays).
pub const STATE_COLUMN_NAMES: [&str; 8] = {
    let fields = crate::problem::model::PLANAR_STATE;
    let mut names = [""; 8];
    let mut i = 0;
    while i < 8 {
        names[i] = fields[i].name;
        i += 1;
    }
    names
};

/// Checks of the returned trajectory against the nonlinear problem. A
/// polished answer's are its own ([`crate::polish::publish`]): no
/// relaxation, the thrust along the nozzle, its flown thrust's bound
/// violation, and as `max_defect` how far its shot and its published
/// flight part at t_f.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Checks {
    /// max over nodes of 1 − ‖(Txm, Tzm)‖/σ (0 when the cone is tight).
    pub relaxation_gap: f64,
    /// min over nodes of the cosine between the thrust and the nozzle axis
    /// (1 = along the nozzle, < 0 = pointing backwards).
    pub thrust_alignment_min: f64,
    /// Largest thrust-bound violation max(T_min − T, T − T_max, 0) over
    /// every reported thrust ([`node_thrust_n`]) \[N\].
    pub thrust_bound_violation_n: f64,
    /// Largest nonlinear collocation defect (scaled by each state's scale).
    pub max_defect: f64,
    /// Largest virtual control of the last subproblem (scaled).
    pub virtual_control: f64,
    /// min over nodes of z − z_f \[m\]; negative means below the landing altitude.
    pub min_altitude_margin_m: f64,
}

impl Checks {
    pub fn thrust_backwards(&self) -> bool {
        self.thrust_alignment_min < 0.0
    }
}

/// What the flight of an answer reaches: the path constraints along it,
/// in continuous time ([`crate::verify::path`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PathReport {
    /// min over [0, t_f] of z(t) − z_f \[m\] (≈ 0 at the touchdown).
    pub min_clearance_m: f64,
    /// min over [0, t_f − 1 s] of z(t) − z_f \[m\]: how close the flight
    /// comes to the ground before its last second.
    pub min_clearance_before_last_second_m: f64,
    /// When z(t) − z_f is lowest below the floor, if it is \[s\].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ground_contact_t_s: Option<f64>,
    pub thrust_min_n: f64,
    pub thrust_max_n: f64,
    /// max |δ| \[rad\].
    pub gimbal_max_rad: f64,
    /// max |χ| [rad/s].
    pub gimbal_rate_max_radps: f64,
    pub final_mass_kg: f64,
    /// The operational constraints of the scenario (issue 37), each at its
    /// worst along the flight; empty without any.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub limits: Vec<LimitReport>,
}

/// Evidence of which operational limits rule a state out, when the solve
/// found no trajectory that holds them (issue 37;
/// [`crate::pipeline::evidence`]). Not a proof that none exists: the
/// status stays `not_converged`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LimitEvidence {
    /// Whether the same state without its limits was solved (the method's
    /// raw answer, on the same mesh).
    pub unconstrained_solved: bool,
    /// That answer's final mass \[kg\] (when solved).
    pub unconstrained_final_mass_kg: Option<f64>,
    /// Each limit that the unconstrained answer breaks, at its worst along
    /// its nodes and between them (`worst` > 0, in the limit's unit), and
    /// when: where the limit cuts the optimum away.
    pub broken: Vec<LimitReport>,
    /// With several limits, each one alone: whether the state with that
    /// limit alone was solved (raw answer).
    pub alone: Vec<LimitAlone>,
}

/// One limit alone on a state that all of them together leave unsolved.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LimitAlone {
    pub limit: crate::problem::constraints::Limit,
    pub solved: bool,
}

/// One operational constraint along a flight: the largest value of its
/// rows g(y) ≤ 0 ([`crate::problem::constraints`]), and when.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LimitReport {
    pub limit: crate::problem::constraints::Limit,
    /// max over [0, t_f] of g, in the limit's unit (≤ 0: held; ≈ 0:
    /// active).
    pub worst: f64,
    /// When it is largest \[s\].
    pub t_s: f64,
    /// The scale of its rows, against which [`crate::verify::path`]'s
    /// tolerance is relative.
    pub scale: f64,
}

/// A solved (or best-effort) landing trajectory in physical units.
///
/// Node arrays have N+1 entries at the LGR points (time t = (τ+1)·t_f/2).
/// Controls live on the N collocation points; their value at t_f repeats the
/// last collocation point (the thrust: its σ, within the bounds, see
/// [`node_thrust_n`]).
#[derive(Debug, Clone, Serialize)]
pub struct Solution {
    pub status: Status,
    /// Why the status is not `solved`, or empty.
    pub message: String,
    /// The formulation whose iterate was returned. With the exact formulation's
    /// relaxed first phase this is `paper` when that phase's answer passed
    /// every physical check.
    pub formulation: Formulation,
    pub nodes: usize,
    /// LGR mesh intervals (1: the paper's global mesh).
    pub intervals: usize,
    /// The mesh solved on: its breaks in τ and points per interval
    /// ([`Solution::mesh`] rebuilds it). In JSON `mesh_layout`, since the
    /// CLI's `mesh` key holds the per-interval error estimate
    /// ([`crate::output::report::add_mesh_json`]).
    #[serde(rename = "mesh_layout")]
    pub mesh: MeshLayout,
    pub tf_s: f64,
    pub final_mass_kg: f64,
    pub fuel_kg: f64,
    pub iterations: usize,
    pub solve_time_ms: f64,
    pub t_s: Vec<f64>,
    pub x_m: Vec<f64>,
    pub z_m: Vec<f64>,
    pub vx_mps: Vec<f64>,
    pub vz_mps: Vec<f64>,
    pub theta_rad: Vec<f64>,
    pub pitch_rate_radps: Vec<f64>,
    pub mass_kg: Vec<f64>,
    pub delta_rad: Vec<f64>,
    pub thrust_n: Vec<f64>,
    pub gimbal_rate_radps: Vec<f64>,
    pub checks: Checks,
    /// The method that produced the answer.
    pub method: Method,
    /// Every iteration, in order (JSON `history` and `direct_history`).
    #[serde(flatten)]
    pub history: History,
    /// The passes of hp mesh refinement, when it ran ([`crate::refine`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refinement: Option<Refinement>,
    /// The controls as flown, when the answer was polished
    /// ([`crate::polish`]): the landing check integrates these, and the
    /// node arrays sample their trajectory.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub controls_flown: Option<FlownControls>,
    /// The polish's iterations, when it ran and its answer was published.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub polish: Option<PolishReport>,
    /// The Pontryagin certificate of a polished answer.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub optimality: Option<Optimality>,
    /// The path constraints along the flight, in continuous time, of a
    /// `solved` or `inaccurate` answer ([`crate::verify::path`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub path: Option<PathReport>,
    /// Where the operational limits cut, when no trajectory that holds
    /// them was found (`not_converged` with limits: [`LimitEvidence`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub limit_evidence: Option<LimitEvidence>,
    /// Why no trajectory exists, the proof behind an `infeasible` answer
    /// ([`crate::problem::feasibility`]); its message is the answer's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub certificate: Option<Certificate>,
    /// The LCvx trajectory itself, for warm starts and re-propagation.
    #[serde(skip)]
    pub trajectory: Trajectory,
}

/// Thrust \[N\] at the N + 1 nodes, as [`Solution::thrust_n`] reports it:
/// σ·m at the N collocation points; at t_f, where LGR has no control, the
/// last point's σ times the final mass, kept within [T_min, T_max]. (σ held
/// alone would leave the engine's range: the mass falls after the last
/// point, so a σ at T_min/m gave 2,209,399 N against T_min = 2,210,000 N.)
pub fn node_thrust_n(model: &Model, form: Formulation, t: &Trajectory) -> Vec<f64> {
    node_thrusts(model, form, t).collect()
}

/// The values of [`node_thrust_n`], in node order.
fn node_thrusts<'a>(
    model: &Model,
    form: Formulation,
    t: &'a Trajectory,
) -> impl Iterator<Item = f64> + 'a {
    let n = t.u.len();
    let si = dynamics::sigma_index(form);
    let (lo, hi) = (model.min_thrust_n, model.max_thrust_n);
    (0..=n).map(move |k| {
        let thrust = t.u[k.min(n - 1)][si] * t.x[k][ix::OMEGA].exp();
        if k == n {
            thrust.clamp(lo, hi)
        } else {
            thrust
        }
    })
}

/// `v` emptied and refilled from `values`, in its own storage.
fn refill_with(v: &mut Vec<f64>, values: impl Iterator<Item = f64>) {
    v.clear();
    v.extend(values);
}

/// How a method's solve ended: its name, status and reason, the checks of
/// its trajectory, its iterations and its time.
#[derive(Debug, Clone)]
pub struct SolveOutcome {
    pub method: Method,
    pub status: Status,
    /// Why the status is not `solved`, or empty.
    pub message: String,
    pub checks: Checks,
    pub history: History,
    pub solve_time_ms: f64,
}

impl Solution {
    /// The answer of a solve: `t` on `mesh` in the formulation `form`, its
    /// node arrays in physical units, and how the method ended.
    pub fn new(
        mesh: &Mesh,
        model: &Model,
        form: Formulation,
        t: Trajectory,
        mut outcome: SolveOutcome,
    ) -> Self {
        let mut sol = Solution::empty(outcome.method);
        sol.trajectory = t;
        sol.history = std::mem::take(&mut outcome.history);
        sol.refill(mesh, model, form, outcome);
        sol
    }

    /// An answer with no nodes, to be filled by [`Solution::refill`].
    pub fn empty(method: Method) -> Self {
        Solution {
            status: Status::NotConverged,
            message: String::new(),
            formulation: Formulation::Exact,
            nodes: 0,
            intervals: 0,
            mesh: MeshLayout {
                breaks_tau: Vec::new(),
                points: Vec::new(),
            },
            tf_s: 0.0,
            final_mass_kg: 0.0,
            fuel_kg: 0.0,
            iterations: 0,
            solve_time_ms: 0.0,
            t_s: Vec::new(),
            x_m: Vec::new(),
            z_m: Vec::new(),
            vx_mps: Vec::new(),
            vz_mps: Vec::new(),
            theta_rad: Vec::new(),
            pitch_rate_radps: Vec::new(),
            mass_kg: Vec::new(),
            delta_rad: Vec::new(),
            thrust_n: Vec::new(),
            gimbal_rate_radps: Vec::new(),
            checks: Checks {
                relaxation_gap: 0.0,
                thrust_alignment_min: 0.0,
                thrust_bound_violation_n: 0.0,
                max_defect: 0.0,
                virtual_control: 0.0,
                min_altitude_margin_m: 0.0,
            },
            method,
            history: History::default(),
            refinement: None,
            controls_flown: None,
            polish: None,
            optimality: None,
            path: None,
            limit_evidence: None,
            certificate: None,
            trajectory: Trajectory {
                x: Vec::new(),
                u: Vec::new(),
                tf_s: 0.0,
            },
        }
    }

    /// Fill every field from `self.trajectory` and `self.history`, which
    /// the caller has set (the history of `outcome` is not read), `mesh`,
    /// `model`, `form` and `outcome`: the node arrays in physical units, in
    /// the vectors' own storage (a re-plan's answer allocates nothing once
    /// they have their size).
    pub fn refill(&mut self, mesh: &Mesh, model: &Model, form: Formulation, outcome: SolveOutcome) {
        let n = mesh.n;
        let t = &self.trajectory;
        let chi = dynamics::control_dim(form) - 1;
        refill_with(&mut self.t_s, (0..=n).map(|k| mesh.time_s(k, t.tf_s)));
        for (v, c) in [
            (&mut self.x_m, ix::X),
            (&mut self.z_m, ix::Z),
            (&mut self.vx_mps, ix::VX),
            (&mut self.vz_mps, ix::VZ),
            (&mut self.theta_rad, ix::THETA),
            (&mut self.pitch_rate_radps, ix::W),
            (&mut self.delta_rad, ix::DELTA),
        ] {
            refill_with(v, t.x.iter().map(|x| x[c]));
        }
        refill_with(&mut self.mass_kg, t.x.iter().map(|x| x[ix::OMEGA].exp()));
        refill_with(&mut self.thrust_n, node_thrusts(model, form, t));
        refill_with(
            &mut self.gimbal_rate_radps,
            (0..=n).map(|k| t.u[k.min(n - 1)][chi]),
        );
        if !mesh.has_layout(&self.mesh) {
            self.mesh = mesh.layout();
        }
        self.status = outcome.status;
        self.message = outcome.message;
        self.formulation = form;
        self.nodes = n;
        self.intervals = mesh.intervals.len();
        self.tf_s = t.tf_s;
        self.final_mass_kg = self.mass_kg[n];
        self.fuel_kg = self.mass_kg[0] - self.final_mass_kg;
        self.iterations = self.history.len();
        self.solve_time_ms = outcome.solve_time_ms;
        self.checks = outcome.checks;
        self.method = outcome.method;
        self.refinement = None;
        self.controls_flown = None;
        self.path = None;
        self.certificate = None;
    }

    /// This answer as a plan to fly: its trajectory, mesh and formulation,
    /// and σ = T/m and δ through its nodes.
    pub fn plan(&self) -> Plan {
        let sigma: Vec<f64> = self.node_sigma().collect();
        Plan::new(
            self.trajectory.clone(),
            self.mesh(),
            self.formulation,
            &self.t_s,
            &sigma,
            &self.delta_rad,
        )
    }

    /// [`Self::plan`] into `plan`, in its own storage.
    pub fn refill_plan(&self, plan: &mut Plan) {
        plan.refill(
            &self.trajectory,
            &self.mesh,
            self.formulation,
            &self.t_s,
            self.node_sigma(),
            &self.delta_rad,
        );
    }

    /// Thrust per mass σ = T/m \[N/kg\] at the nodes, which a plan flies.
    fn node_sigma(&self) -> impl Iterator<Item = f64> + '_ {
        self.thrust_n.iter().zip(&self.mass_kg).map(|(t, m)| t / m)
    }

    /// A name for the formulation that produced this answer, given the one
    /// requested: "exact (via the paper's relaxation)" when the exact
    /// formulation's relaxed first phase answered.
    pub fn formulation_label(&self, requested: Formulation) -> String {
        match (requested, self.formulation) {
            (Formulation::Exact, Formulation::Paper) => "exact (via the paper's relaxation)".into(),
            (_, f) => format!("{f:?}").to_lowercase(),
        }
    }

    /// The mesh the solution was solved on (its node arrays live on
    /// [`Mesh::nodes`] of it).
    ///
    /// # Panics
    /// Panics if `mesh` was edited into an invalid layout; every solve
    /// fills it from its transcription's mesh.
    pub fn mesh(&self) -> Mesh {
        Mesh::from_layout(&self.mesh)
    }

    /// The node arrays of the 8 states of P2, in its order: x, z, Vx, Vz,
    /// θ, w, m, δ (named by [`STATE_COLUMN_NAMES`]).
    pub fn state_columns(&self) -> [&[f64]; 8] {
        [
            &self.x_m,
            &self.z_m,
            &self.vx_mps,
            &self.vz_mps,
            &self.theta_rad,
            &self.pitch_rate_radps,
            &self.mass_kg,
            &self.delta_rad,
        ]
    }

    /// One JSON object with the status, scalars, node arrays, checks and history.
    pub fn to_json(&self) -> serde_json::Value {
        let mut v = serde_json::to_value(self).expect("a Solution serializes");
        v["status"] = self.status.as_str().into();
        v["method"] = self.method.as_str().into();
        v
    }
}

/// The relative error of a solution on one mesh interval ([`crate::verify::mesh_error`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IntervalError {
    /// Index of the interval, its collocation points n_k and its span \[s\].
    pub interval: usize,
    pub points: usize,
    pub t_start_s: f64,
    pub t_end_s: f64,
    /// e_k ([`crate::verify::mesh_error`]), and the state where it is largest.
    pub relative_error: f64,
    pub worst_state: &'static str,
}

/// One pass: the mesh, the answer's status and cost, and the error estimate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Pass {
    /// 1 for the first solve.
    pub pass: usize,
    pub mesh: MeshLayout,
    /// N = Σ n_k.
    pub nodes: usize,
    pub status: Status,
    pub iterations: usize,
    pub solve_time_ms: f64,
    pub final_mass_kg: f64,
    /// The events detected on this pass's answer \[s\]: where T, χ or δ
    /// reaches or leaves a bound ([`crate::refine::events`]).
    pub events_s: Vec<f64>,
    /// e_k of each interval, and their maximum.
    pub intervals: Vec<IntervalError>,
    pub max_relative_error: f64,
}

/// Why the refinement stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stop {
    /// max_k e_k ≤ the tolerance.
    ToleranceMet,
    /// The next mesh would have more than `max_total_points`, or the budget
    /// left no room for a change (the next mesh was the last one).
    PointLimit,
    /// `max_passes` passes were solved.
    PassLimit,
    /// A pass's answer was not `solved`; the last solved one is returned
    /// (or the first pass's, whatever its status).
    SolveFailed,
    /// The error could not be estimated (the integration failed).
    EstimateFailed,
}

impl Stop {
    /// Why refinement stopped, in the settings' words.
    pub fn describe(&self) -> &'static str {
        match self {
            Stop::ToleranceMet => "tolerance met",
            Stop::PointLimit => {
                "stopped: the next mesh would exceed solver.refinement.max_total_points"
            }
            Stop::PassLimit => "stopped: solver.refinement.max_passes reached",
            Stop::SolveFailed => "stopped: a pass did not solve; the last solved pass is returned",
            Stop::EstimateFailed => "stopped: the mesh error could not be estimated",
        }
    }
}

/// The record of a refinement, carried by its [`Solution`] ([`crate::refine`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Refinement {
    pub tolerance: f64,
    pub stop: Stop,
    pub passes: Vec<Pass>,
    /// The time of every pass, estimates and mesh building included \[ms\].
    pub total_time_ms: f64,
}
