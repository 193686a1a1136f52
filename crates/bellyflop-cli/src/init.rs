//! `bellyflop init [FILE]`: a commented scenario TOML with every parameter,
//! its unit and its allowed range, filled with the paper's case
//! (`--model 6dof`: as a 6-DoF scenario, with the out-of-plane fields at 0).
//!
//! The values come from [`Scenario::paper`] through serde, so every field of
//! the scenario is written, in full precision (`{:?}` of f64 is the shortest
//! text that reads back to the same number). The comments come from [`DOCS`];
//! a unit test checks that its ranges agree with the library's validation.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use bellyflop::input::scenario::ModelKind;
use bellyflop::Case;
use serde_json::Value;

use crate::exit;

/// Arguments of `bellyflop init`.
#[derive(clap::Args)]
pub struct InitArgs {
    /// Where to write the scenario; stdout when omitted.
    file: Option<PathBuf>,
    /// Overwrite FILE if it exists.
    #[arg(long)]
    force: bool,
    /// The scenario's model: `planar` (the paper's problem) or `6dof`
    /// (with the out-of-plane fields, each at 0).
    #[arg(long, value_enum, default_value = "planar")]
    model: InitModel,
}

/// The models `init --model` writes (the scenario's `model` key).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum InitModel {
    Planar,
    #[value(name = "6dof")]
    SixDof,
}

/// The paper's case as a scenario of `model`.
pub fn paper_case(model: InitModel) -> Case {
    let mut case = Case::paper();
    case.scenario.model = match model {
        InitModel::Planar => ModelKind::Planar,
        InitModel::SixDof => ModelKind::SixDof,
    };
    case
}

/// Run `bellyflop init`: exit 0 on success, 2 (bad input) if FILE exists
/// (without `--force`) or its directory does not, 1 if it cannot be written.
pub fn run(args: &InitArgs) -> ExitCode {
    let text = template(&paper_case(args.model));
    let Some(path) = &args.file else {
        out!("{text}");
        return ExitCode::SUCCESS;
    };
    if path.exists() && !args.force {
        errln!(
            "error: {} exists; pass --force to overwrite it",
            path.display()
        );
        return ExitCode::from(exit::BAD_INPUT);
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !dir.is_dir() {
            errln!(
                "error: cannot write {}: the directory {} does not exist (create it first)",
                path.display(),
                dir.display()
            );
            return ExitCode::from(exit::BAD_INPUT);
        }
    }
    match crate::files::write_file(path, text) {
        Ok(()) => {
            errln!("wrote {}", path.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            errln!("error: {e}");
            ExitCode::from(exit::OUTPUT)
        }
    }
}

/// What values a field accepts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Allowed {
    /// A real number in an interval; `lo_open`/`hi_open` exclude the ends.
    Real {
        lo: f64,
        hi: f64,
        lo_open: bool,
        hi_open: bool,
    },
    /// An integer from `lo` to `hi` inclusive.
    Count { lo: u64, hi: u64 },
    /// One of these strings.
    Choice(&'static [&'static str]),
    /// Any text.
    Text,
    /// `true` or `false`.
    Flag,
}

/// The documentation of one scenario field.
#[derive(Debug, Clone, Copy)]
pub struct Doc {
    /// TOML table (`""` for the top level).
    pub table: &'static str,
    pub key: &'static str,
    /// Unit, or `""` for a pure number.
    pub unit: &'static str,
    pub allowed: Allowed,
    /// What it is, and any condition that involves other fields.
    pub text: &'static str,
}

const fn real(lo: f64, hi: f64, lo_open: bool, hi_open: bool) -> Allowed {
    Allowed::Real {
        lo,
        hi,
        lo_open,
        hi_open,
    }
}
/// `[lo, hi]`
const fn closed(lo: f64, hi: f64) -> Allowed {
    real(lo, hi, false, false)
}
/// `(lo, hi]`
const fn open_closed(lo: f64, hi: f64) -> Allowed {
    real(lo, hi, true, false)
}
/// `(lo, hi)`
const fn open(lo: f64, hi: f64) -> Allowed {
    real(lo, hi, true, true)
}
/// `[lo, hi)`
const fn closed_open(lo: f64, hi: f64) -> Allowed {
    real(lo, hi, false, true)
}

const MASS: Allowed = closed(1.0, 1e7);
const LENGTH: Allowed = closed(0.01, 1000.0);
const POS_X: Allowed = closed(-1e5, 1e5);
const POS_Z: Allowed = closed(0.0, 1e5);
const SPEED: Allowed = closed(-1e4, 1e4);
const THETA: Allowed = closed(-180.0, 180.0);
const PITCH_RATE: Allowed = closed(-360.0, 360.0);
const TOLERANCE: Allowed = open(0.0, 1.0);
const TRUST_RADIUS: Allowed = open_closed(0.0, 1e6);
const RHO: Allowed = closed_open(0.0, 1.0);
const FACTOR: Allowed = open_closed(1.0, 100.0);

/// The accepted values of `model`.
pub const MODELS: &[&str] = &["planar", "6dof"];

/// The accepted values of `solver.method`.
pub const METHODS: &[&str] = &["direct", "scvx"];

/// The accepted values of `solver.direct.mu_strategy`.
pub const MU_STRATEGIES: &[&str] = &["monotone", "adaptive"];

/// The accepted values of `solver.formulation`.
pub const FORMULATIONS: &[&str] = &["exact", "paper", "vector"];

macro_rules! doc {
    ($table:literal, $key:literal, $unit:literal, $allowed:expr, $text:literal) => {
        Doc {
            table: $table,
            key: $key,
            unit: $unit,
            allowed: $allowed,
            text: $text,
        }
    };
}

/// Every scenario field, in the order of the written file.
pub const DOCS: &[Doc] = &[
    doc!("", "name", "", Allowed::Text, "Name of the case, printed in the summary."),
    doc!("", "model", "", Allowed::Choice(MODELS),
        "The model: \"planar\" (the default when left out) is the paper's problem in the x-z plane; \"6dof\" is the 6-DoF model (issue 38), which also reads the out-of-plane fields of [initial] and environment.wind_y_mps (each 6-DoF only, default 0). `bellyflop solve` solves both (\"6dof\" by the library's pipeline::six_dof::solve); sweep, sim and montecarlo take only \"planar\"."),
    // Vehicle (paper Table 1).
    doc!("vehicle", "dry_mass_kg", "kg", MASS,
        "Dry mass m_dry: the final mass must stay at or above it (Eq. 4). Below initial.mass_kg."),
    doc!("vehicle", "length_m", "m", LENGTH, "Body length l_s."),
    doc!("vehicle", "radius_m", "m", LENGTH, "Body radius r_s."),
    doc!("vehicle", "cg_m", "m", LENGTH,
        "Centre of mass l_cg, measured along the body from the engine gimbal. Between 0.092*length_m and 0.908*length_m: the pitch inertia (Eq. 22) is that of a body spread over its whole length."),
    doc!("vehicle", "cp_m", "m", LENGTH,
        "Centre of pressure l_cp, measured like l_cg. At most length_m."),
    doc!("vehicle", "max_thrust_n", "N", closed(1.0, 1e9), "Maximum thrust T_max."),
    doc!("vehicle", "min_thrust_n", "N", closed(0.0, 1e9),
        "Minimum thrust T_min: the engine cannot throttle below it (Eq. 5). At most max_thrust_n."),
    doc!("vehicle", "isp_s", "s", closed(1.0, 1000.0), "Specific impulse I_sp."),
    doc!("vehicle", "max_gimbal_deg", "deg", closed_open(0.1, 90.0),
        "Maximum nozzle (gimbal) angle delta_max."),
    doc!("vehicle", "max_gimbal_rate_degps", "deg/s", closed(0.1, 360.0),
        "Maximum nozzle angle rate chi_max."),
    doc!("vehicle", "drag_coefficient_kgpm", "kg/m", closed(0.0, 1e5),
        "Lumped drag coefficient C_LD = rho*c_D*A/2 (Eq. 2); 0 is vacuum. The paper omits it; its case uses 1.2*m0*g0/85^2 = 195.52."),
    // Environment.
    doc!("environment", "g0_mps2", "m/s^2", closed(1e-3, 100.0),
        "Gravitational acceleration g0, also used in I_sp*g0."),
    doc!("environment", "wind_x_mps", "m/s", closed(-100.0, 100.0),
        "Steady horizontal wind W, positive along +x: drag acts on the air-relative velocity (Vx - W, Vz). 0 is the paper's still air."),
    doc!("environment", "wind_y_mps", "m/s", closed(-100.0, 100.0),
        "6-DoF only, default 0. Steady cross wind along +y: drag acts on the air-relative velocity V - (wind_x_mps, wind_y_mps, 0)."),
    // Initial state (Eq. 4).
    doc!("initial", "x_m", "m", POS_X, "Downrange position x of the CG at ignition."),
    doc!("initial", "z_m", "m", POS_Z,
        "Altitude z of the CG at ignition. Above terminal.z_m."),
    doc!("initial", "vx_mps", "m/s", SPEED, "Horizontal velocity Vx."),
    doc!("initial", "vz_mps", "m/s", SPEED, "Vertical velocity Vz (negative: descending)."),
    doc!("initial", "theta_deg", "deg", THETA,
        "Pitch theta from the vertical; 90 is belly-first (horizontal)."),
    doc!("initial", "pitch_rate_degps", "deg/s", PITCH_RATE, "Pitch rate w."),
    doc!("initial", "mass_kg", "kg", MASS, "Mass m0 at ignition. Above vehicle.dry_mass_kg."),
    doc!("initial", "gimbal_deg", "deg", open(-90.0, 90.0),
        "Nozzle angle delta at ignition. |delta| at most vehicle.max_gimbal_deg."),
    doc!("initial", "y_m", "m", POS_X, "6-DoF only, default 0. Cross-range position y of the CG at ignition."),
    doc!("initial", "vy_mps", "m/s", SPEED, "6-DoF only, default 0. Cross-range velocity Vy."),
    doc!("initial", "yaw_deg", "deg", THETA,
        "6-DoF only, default 0. Yaw psi about the vertical z axis, applied after the pitch: the attitude is q = q_yaw(psi about z) * q_pitch(theta about -y) * q_roll(phi about e_z)."),
    doc!("initial", "roll_deg", "deg", THETA,
        "6-DoF only, default 0. Roll phi about the vehicle axis e_z (toward the nose), applied before the pitch."),
    doc!("initial", "body_rate_x_degps", "deg/s", PITCH_RATE,
        "6-DoF only, default 0. Body rate omega_x about the body axis e_x ((cos theta, 0, sin theta) in the plane); the body rates are (omega_x, -pitch_rate_degps, omega_z)."),
    doc!("initial", "roll_rate_degps", "deg/s", PITCH_RATE,
        "6-DoF only, default 0. Roll rate omega_z about the vehicle axis e_z; nothing torques it, so it is conserved."),
    doc!("initial", "gimbal2_deg", "deg", open(-90.0, 90.0),
        "6-DoF only, default 0. Second nozzle angle delta2 at ignition, tilting the thrust out of the pitch plane. |delta2| at most vehicle.max_gimbal_deg."),
    // Terminal state (Eq. 4); the final mass is free above m_dry.
    doc!("terminal", "x_m", "m", POS_X, "Downrange position of the CG at touchdown (the landing point)."),
    doc!("terminal", "z_m", "m", POS_Z, "Altitude of the CG at touchdown. Below initial.z_m."),
    doc!("terminal", "vx_mps", "m/s", SPEED, "Horizontal velocity at touchdown."),
    doc!("terminal", "vz_mps", "m/s", SPEED, "Vertical velocity at touchdown."),
    doc!("terminal", "theta_deg", "deg", THETA, "Pitch at touchdown; 0 is upright."),
    doc!("terminal", "pitch_rate_degps", "deg/s", PITCH_RATE, "Pitch rate at touchdown."),
    // Discretization (Section 3.2).
    doc!("discretization", "nodes", "", Allowed::Count { lo: 4, hi: 200 },
        "Number of LGR collocation points N (the paper uses 20); at most 100 on the global mesh (intervals = 1)."),
    doc!("discretization", "intervals", "", Allowed::Count { lo: 1, hi: 50 },
        "LGR mesh intervals M, at most N/2 (1, the default, is the paper's global mesh; more make each subproblem cheaper but SCvx slower to converge)."),
    doc!("discretization", "tf_guess_s", "s", open(0.0, f64::INFINITY),
        "Optional. Final time t_f of the straight-line initial guess (t_f itself is optimized). Left out, it is derived from the state: the time to stop the descent at T_max against gravity and drag, plus the spare altitude flown at the initial descent rate. A guess above 1000 is clamped to 1000 with a warning."),
    doc!("discretization", "final_mass_guess_kg", "kg", open(0.0, f64::INFINITY),
        "Optional. Final mass of the straight-line initial guess. Left out, it is derived from the state: initial.mass_kg less the propellant the mean thrust (T_min + T_max)/2 burns in the derived t_f. A guess outside [vehicle.dry_mass_kg, initial.mass_kg] is clamped into it with a warning."),
    // Operational path constraints (issue 37), every one optional.
    doc!("constraints", "cone_half_angle_deg", "deg", closed(1.0, 89.0),
        "Approach cone about the pad: half-angle gamma from the vertical, |x - x_f| <= (z - z_f)*tan(gamma). The initial state must lie inside it."),
    doc!("constraints", "max_pitch_rate_degps", "deg/s", open_closed(0.0, 360.0),
        "Pitch-rate limit: |w| <= w_max."),
    doc!("constraints", "max_tilt_deg", "deg", closed(0.0, 90.0),
        "Tilt limit theta_max: |theta| <= theta_max below tilt_below_m above the pad (the limit opens by 1 deg per metre above it). Together with tilt_below_m."),
    doc!("constraints", "tilt_below_m", "m", closed(0.0, 1e5),
        "Height above the pad below which the tilt limit holds. Together with max_tilt_deg."),
    doc!("constraints", "final_descent_m", "m", closed(0.0, 1e5),
        "Vertical final descent: the height above the pad below which |Vx| <= final_descent_lateral_mps (the limit opens by 1 m/s per metre above it). Together with final_descent_lateral_mps."),
    doc!("constraints", "final_descent_lateral_mps", "m/s", closed(0.0, 100.0),
        "Largest lateral speed |Vx| in the final descent. Together with final_descent_m."),
    doc!("solver", "method", "", Allowed::Choice(METHODS),
        "Solution method: \"direct\" is the interior-point method on the nonlinear program P2 (default; 2-3x faster than CasADi + IPOPT on the dispersed benchmark, see BENCHMARKS.md); \"scvx\" is the paper's successive convexification."),
    doc!("solver.direct", "tolerance", "scaled", TOLERANCE,
        "Convergence: the scaled optimality error (IPOPT's E_0: primal and dual infeasibility, complementarity) below this."),
    doc!("solver.direct", "max_iterations", "", Allowed::Count { lo: 1, hi: 10_000 },
        "Interior-point iteration limit; past it the status is not_converged."),
    doc!("solver.direct", "mu_init", "", open_closed(0.0, 10.0),
        "Initial barrier parameter mu_0."),
    doc!("solver.direct", "coarse_nodes", "", Allowed::Count { lo: 0, hi: 100 },
        "Coarse-to-fine start: solve first on a global mesh of this many points, then start the scenario's mesh from that answer; 0 starts from the straight line."),
    doc!("solver.direct", "coarse_tolerance", "scaled", TOLERANCE,
        "Tolerance of the coarse start's solve: it only places the fine solve near its optimum."),
    doc!("solver.direct", "mu_strategy", "", Allowed::Choice(MU_STRATEGIES),
        "How the barrier parameter falls: \"monotone\" (Fiacco-McCormick, IPOPT's default) or \"adaptive\" (Mehrotra's probing rule each iteration, falling back to monotone when the optimality error stalls)."),
    // SCvx (Section 3.4; trust region of Mao, Szmuk and Acikmese 2016).
    doc!("solver", "formulation", "", Allowed::Choice(FORMULATIONS),
        "Thrust direction: \"exact\" keeps theta + delta in the dynamics (default); \"paper\" is the paper's P4 with the lossless cone and Eq. 27; \"vector\" is the paper's controls with the thrust held on the nozzle axis."),
    doc!("solver", "relaxed_first_iterations", "", Allowed::Count { lo: 0, hi: 10_000 },
        "Exact formulation only: iterations given first to the paper's relaxation, whose answer is kept only if it passes every physical check; 0 solves the exact form directly."),
    doc!("solver", "max_iterations", "", Allowed::Count { lo: 1, hi: 10_000 },
        "SCvx iteration limit; past it the status is not_converged."),
    doc!("solver", "step_tolerance", "scaled", TOLERANCE,
        "Convergence: scaled step max|dz| below this."),
    doc!("solver", "defect_tolerance", "scaled", TOLERANCE,
        "Convergence: largest nonlinear collocation defect (Eq. 24) below this."),
    doc!("solver", "virtual_control_tolerance", "scaled", TOLERANCE,
        "Convergence: largest virtual control below this."),
    doc!("solver", "virtual_control_weight", "", closed(1.0, 1e5),
        "Exact-penalty weight lambda on the 1-norm of the virtual control. Above about 1e6 the subproblems fail."),
    doc!("solver", "proximal_weight", "", closed(0.0, 1e6),
        "Weight of the proximal term w*|dz|^2 of each subproblem; 0 is off."),
    doc!("solver", "trust_region_initial", "scaled", TRUST_RADIUS,
        "Initial trust-region radius (infinity norm). Within [trust_region_min, trust_region_max]. The relaxed first phase of \"exact\" starts at 0.6."),
    doc!("solver", "trust_region_min", "scaled", TRUST_RADIUS,
        "Smallest trust-region radius before the iteration stops."),
    doc!("solver", "trust_region_max", "scaled", TRUST_RADIUS, "Largest trust-region radius."),
    doc!("solver", "rho0", "", RHO,
        "Acceptance ratio below which a step is rejected. rho0 < rho1 < rho2."),
    doc!("solver", "rho1", "", RHO, "Acceptance ratio below which the radius shrinks."),
    doc!("solver", "rho2", "", RHO, "Acceptance ratio at or above which the radius grows."),
    doc!("solver", "shrink", "", FACTOR, "Radius shrink factor (when rho < rho1)."),
    doc!("solver", "grow", "", FACTOR, "Radius growth factor (when rho >= rho2)."),
    doc!("solver", "second_order_correction", "", Allowed::Flag,
        "Judge a poor candidate (rho < rho1) after a minimum-norm correction of its linearization error (Nocedal & Wright 15.6); without it the penalty merit rejects good steps for their second-order defects and SCvx stops short of the optimum."),
    doc!("solver", "relaxation_gap_tolerance", "", TOLERANCE,
        "Largest accepted relaxation gap max(1 - |T|/sigma) of a returned solution."),
    doc!("solver", "thrust_margin_frac", "", closed_open(0.0, 0.5),
        "Soft thrust margin mu: throttle outside [(1+mu)*T_min, (1-mu)*T_max] is allowed up to the engine's bounds, at a cost (closed-loop plans keep range for feedback this way); 0 is off."),
    doc!("solver", "thrust_margin_weight", "", open_closed(0.0, 1e12),
        "Cost of the soft thrust margin's use per node and unit of scaled sigma."),
    doc!("solver", "terminal_lateral_weight", "", closed(0.0, 1e12),
        "Soft terminal x and Vx: a miss costs this per unit of scaled miss; 0 keeps them hard (Eq. 4)."),
    doc!("solver", "polish", "", Allowed::Flag,
        "Polish a solved collocation answer into controls that fly: per thrust arc a bound or a cubic, cubic nozzle angles, free durations, made to land and fuel-optimal by single shooting with exact sensitivities; the JSON publishes them as controls_flown. false (--fast) returns the raw collocation answer."),
    doc!("solver", "polish_repairs", "", Allowed::Count { lo: 0, hi: 10 },
        "Polishes on repaired arcs, at most: where the polished answer's switching function (its Pontryagin certificate, JSON optimality) contradicts a thrust arc, a short arc of the other bound is seeded there and the polish runs again, while each gains mass. 0 keeps the first structure: faster, and kilograms more fuel on some states."),
    doc!("solver", "polish_hessian", "", Allowed::Flag,
        "The polish's Newton mode: near the answer its QPs take the Lagrangian's exact Hessian through the integrator's steps (eigenvalues' magnitudes) beside the proximal term. Off by default: on 46 seeded envelope states it ends a median 0.16 kg short of the fine reference instead of 0.30, at about twice the time (BENCHMARKS.md, issue 35)."),
    doc!("solver", "landing_position_tolerance_m", "m", closed(1e-3, 1e6),
        "Largest landing position error |(x, z)(t_f) - (x_f, z_f)| of a solved answer when its controls (the flown ones when polished; else PCHIP through the nodes) are re-integrated by DOP853; beyond it the status is inaccurate (exit 9). Polished answers land within micrometres; the raw paper's case (--fast) lands 0.81 m off at N = 20; 1e6 turns the check off."),
    doc!("solver", "landing_velocity_tolerance_mps", "m/s", closed(1e-3, 1e4),
        "Largest landing velocity error |(Vx, Vz)(t_f) - (Vx_f, Vz_f)| of a solved answer, re-integrated as above. The raw paper's case (--fast) lands 0.32 m/s off at N = 20; 1e4 turns the check off."),
    // Mesh refinement (issue 16).
    doc!("solver.refinement", "tolerance", "", closed(0.0, 0.1),
        "Refine the mesh until every interval's relative error (its state polynomials against an integration of the dynamics with its controls) is at most this; 0, the default, solves on the scenario's mesh alone. --mesh-tolerance on the command line."),
    doc!("solver.refinement", "max_passes", "", Allowed::Count { lo: 1, hi: 20 },
        "Refinement passes, the first solve included."),
    doc!("solver.refinement", "min_points", "", Allowed::Count { lo: 2, hi: 20 },
        "Points of each interval that a split makes."),
    doc!("solver.refinement", "max_points", "", Allowed::Count { lo: 2, hi: 20 },
        "Most points of an interval before it is split instead of raised; at least min_points."),
    doc!("solver.refinement", "max_total_points", "", Allowed::Count { lo: 4, hi: 200 },
        "Refinement stops before a mesh of more collocation points than this."),
];

/// Order and headings of the TOML tables.
const TABLES: &[(&str, &str)] = &[
    ("", ""),
    ("vehicle", "Vehicle (paper Table 1)."),
    ("environment", "Planet."),
    ("initial", "State at ignition of the landing burn (Eq. 4)."),
    (
        "terminal",
        "State at touchdown (Eq. 4). The final mass is free above vehicle.dry_mass_kg.",
    ),
    ("discretization", "LGR collocation (Section 3.2)."),
    ("constraints", "Operational path constraints (issue 37), each optional and off when left out, as in the paper's case. Each holds along the whole flight, in continuous time. Uncomment a limit (and the [constraints] line) to switch it on; the values written are the recommended ones. The altitude-triggered limits are smoothed by a softplus of width 1 m (see `problem::constraints`)."),
    (
        "solver",
        "Solver settings: the method, then successive convexification (Section 3.4). Optional: a missing key takes its default.",
    ),
    (
        "solver.direct",
        "The direct method: a primal-dual interior-point filter line search on P2 (Wachter & Biegler 2006). Optional.",
    ),
    (
        "solver.refinement",
        "hp mesh refinement to a tolerance, with interval breaks at the control switches. Optional; off unless tolerance > 0.",
    ),
];

/// A range bound written like the validation messages: `1e7`, `100`, `0`.
fn bound(x: f64) -> String {
    if x != 0.0 && (x.abs() >= 1e4 || x.abs() < 1e-3) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// The allowed values as text, e.g. `(0, 1e7]`.
pub fn allowed_text(d: &Doc) -> String {
    match d.allowed {
        Allowed::Real {
            lo,
            hi,
            lo_open,
            hi_open,
        } => format!(
            "{}{}, {}{}",
            if lo_open { '(' } else { '[' },
            bound(lo),
            bound(hi),
            if hi_open { ')' } else { ']' }
        ),
        Allowed::Count { lo, hi } => format!("an integer from {lo} to {hi}"),
        Allowed::Choice(c) => c
            .iter()
            .map(|s| format!("\"{s}\""))
            .collect::<Vec<_>>()
            .join(", "),
        Allowed::Text => "any text".into(),
        Allowed::Flag => "true or false".into(),
    }
}

/// A serde value as a TOML literal that reads back to the same value.
fn literal(v: &Value) -> String {
    match v {
        Value::Number(n) => match (n.as_u64(), n.as_i64(), n.as_f64()) {
            (Some(u), _, _) if !n.is_f64() => u.to_string(),
            (_, Some(i), _) if !n.is_f64() => i.to_string(),
            // `{:?}` keeps a `.0` on whole numbers (TOML floats need it, or
            // an exponent) and is the shortest round-tripping text.
            (_, _, Some(f)) => format!("{f:?}"),
            _ => n.to_string(),
        },
        // A JSON string is a valid TOML basic string.
        Value::String(_) | Value::Bool(_) => v.to_string(),
        other => panic!("no TOML literal for {other}"),
    }
}

/// Wrap `text` into `# `-comment lines of at most ~88 characters.
fn comment(out: &mut String, text: &str) {
    let mut line = String::from("#");
    for word in text.split_whitespace() {
        if line.len() + 1 + word.len() > 88 && line.len() > 1 {
            out.push_str(&line);
            out.push('\n');
            line = String::from("#");
        }
        line.push(' ');
        line.push_str(word);
    }
    out.push_str(&line);
    out.push('\n');
}

/// Fields written commented out: optional, and derived from the state when
/// left out (issue 29), so that a copy of the file whose state is edited
/// does not carry the paper's guesses to a state they do not fit.
pub const COMMENTED: &[(&str, &str)] = &[
    ("discretization", "tf_guess_s"),
    ("discretization", "final_mass_guess_kg"),
];

/// Write one `key = value` with its comment (`# key = value` for the
/// [`COMMENTED`] fields).
fn entry(out: &mut String, table: &str, key: &str, value: &Value, commented: bool) {
    match DOCS.iter().find(|d| d.table == table && d.key == key) {
        Some(d) => {
            comment(out, d.text);
            let unit = match d.unit {
                "" => String::new(),
                "scaled" => "Unit: none (scaled). ".into(),
                u => format!("Unit: {u}. "),
            };
            comment(out, &format!("{unit}Allowed: {}.", allowed_text(d)));
        }
        None => comment(out, "(undocumented field)"),
    }
    let hash = if commented || COMMENTED.contains(&(table, key)) {
        "# "
    } else {
        ""
    };
    let _ = writeln!(out, "{hash}{key} = {}", literal(value));
}

/// The commented TOML text of a scenario: every field, with its unit and
/// allowed range (a 6-DoF scenario's out-of-plane fields too, at 0 when
/// they are).
pub fn template(case: &Case) -> String {
    let v = serde_json::to_value(case).expect("a Case serializes");
    let Value::Object(mut top) = v else {
        panic!("a Scenario serializes to an object")
    };
    let six_dof = case.scenario.model == ModelKind::SixDof;
    if six_dof {
        // Serde leaves them out at 0; a 6-DoF file shows them all.
        for (field, value) in case.scenario.out_of_plane() {
            if let Some((table, key)) = field.split_once('.') {
                if let Some(Value::Object(t)) = top.get_mut(table) {
                    t.entry(key).or_insert(value.into());
                }
            }
        }
    }
    // Without constraints, the table is written with the recommended
    // limits, commented out.
    let no_constraints = case.scenario.constraints.is_empty();
    if no_constraints {
        let recommended = bellyflop::input::scenario::Constraints::recommended();
        top.insert(
            "constraints".into(),
            serde_json::to_value(recommended).expect("serializes"),
        );
    }
    let mut out = String::new();
    if six_dof {
        out.push_str(
            "# bellyflop scenario, written by `bellyflop init --model 6dof`: the paper's case\n\
             # (Chen, Ma, Wang, Su, Mathematics 2023, 11, 288) as a 6-DoF scenario, its\n\
             # out-of-plane fields at 0. Solve it with `bellyflop solve --scenario FILE` (the\n\
             # direct method, then the 6-DoF polish). A [solver] setting that only the planar\n\
             # model reads is refused at a value other than its default.\n\
             # Every value is checked against the range given; units are in the key names\n\
             # and comments. Ranges: [a, b] includes both ends, (a, b) excludes them.\n",
        );
    } else {
        out.push_str(
            "# bellyflop scenario, written by `bellyflop init`: the paper's case\n\
             # (Chen, Ma, Wang, Su, Mathematics 2023, 11, 288).\n\
             # Solve it with `bellyflop solve --scenario FILE`. Every value is checked against\n\
             # the range given before solving; units are in the key names and comments.\n\
             # Ranges: [a, b] includes both ends, (a, b) excludes them.\n",
        );
    }
    // Tables in TABLES' order, then any others; a table's own sub-tables
    // (e.g. [solver.direct]) follow it.
    let mut order: Vec<String> = TABLES.iter().map(|(t, _)| t.to_string()).collect();
    for (k, v) in &top {
        if v.is_object() && !order.contains(k) {
            order.push(k.clone());
        }
    }
    let mut tables: Vec<(String, &serde_json::Map<String, Value>)> = Vec::new();
    for name in &order {
        if name.is_empty() {
            tables.push((String::new(), &top));
            continue;
        }
        let Some(Value::Object(m)) = top.get(name) else {
            continue;
        };
        tables.push((name.clone(), m));
        for (k, v) in m {
            if let Value::Object(sub) = v {
                tables.push((format!("{name}.{k}"), sub));
            }
        }
    }
    for (table, map) in tables {
        let table = table.as_str();
        let heading = TABLES.iter().find(|(t, _)| *t == table).map(|(_, h)| *h);
        let fields: Vec<(&String, &Value)> = map.iter().filter(|(_, v)| !v.is_object()).collect();
        out.push('\n');
        let commented = no_constraints && table == "constraints";
        if !table.is_empty() {
            comment(&mut out, heading.unwrap_or("(undocumented table)"));
            let hash = if commented { "# " } else { "" };
            let _ = writeln!(out, "{hash}[{table}]");
        }
        // Documented keys in the order of DOCS, then any others.
        let mut ordered: Vec<(&String, &Value)> = Vec::new();
        for d in DOCS.iter().filter(|d| d.table == table) {
            if let Some(f) = fields.iter().find(|(k, _)| k.as_str() == d.key) {
                ordered.push(*f);
            }
        }
        for f in &fields {
            if !ordered.iter().any(|(k, _)| k == &f.0) {
                ordered.push(*f);
            }
        }
        for (k, v) in ordered {
            entry(&mut out, table, k, v, commented);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use bellyflop::{InputError, Scenario};

    /// Whether `table.key` is read only by the 6-DoF model (the library's
    /// [`Scenario::out_of_plane`] fields).
    fn six_dof_only(table: &str, key: &str) -> bool {
        Scenario::paper()
            .out_of_plane()
            .iter()
            .any(|(field, _)| *field == format!("{table}.{key}"))
    }

    /// The paper's case with `table.key` set to `value`, as a 6-DoF case
    /// when the field is 6-DoF only.
    fn with_field(table: &str, key: &str, value: Value) -> Result<Case, String> {
        let model = if six_dof_only(table, key) {
            InitModel::SixDof
        } else {
            InitModel::Planar
        };
        let mut v = serde_json::to_value(paper_case(model)).unwrap();
        let mut t = &mut v;
        for part in table.split('.').filter(|p| !p.is_empty()) {
            t = &mut t[part];
        }
        t[key] = value;
        serde_json::from_value::<Case>(v).map_err(|e| e.to_string())
    }

    /// The template is the paper's case with its two guesses commented out:
    /// as written it reads back as the paper's case with the guesses derived
    /// from the state, and with them uncommented exactly as the paper's case.
    #[test]
    fn template_reads_back_as_the_paper_case() {
        let text = template(&Case::paper());
        assert!(!text.contains("undocumented"), "{text}");
        let s = Case::from_toml_str(&text).expect("the template is valid");
        let mut expected = Case::paper();
        let derived = bellyflop::input::guess::derive(&expected.scenario);
        let d = &mut expected.scenario.discretization;
        (d.tf_guess_s, d.final_mass_guess_kg) = (derived.tf_s, derived.final_mass_kg);
        assert_eq!(s, expected);
        assert!(s.warnings.is_empty());
        let mut uncommented = text.clone();
        for (_, key) in COMMENTED {
            let from = format!("\n# {key} = ");
            assert_eq!(uncommented.matches(&from).count(), 1, "{key}");
            uncommented = uncommented.replace(&from, &format!("\n{key} = "));
        }
        assert_eq!(
            Case::from_toml_str(&uncommented).expect("valid"),
            Case::paper()
        );
        // Every key is written once, each with its comment above it (the
        // constraints commented out); the 6-DoF ones are not written.
        assert!(!text.contains("\nmodel = "), "{text}");
        for d in DOCS
            .iter()
            .filter(|d| !six_dof_only(d.table, d.key) && d.key != "model")
        {
            let hash = if d.table == "constraints" { "# " } else { "" };
            let line = format!("\n{hash}{} = ", d.key);
            assert!(uncommented.contains(&line), "{} missing", d.key);
        }
    }

    /// The commented `[constraints]` table, uncommented, is the paper's
    /// case with the recommended limits; a case that has constraints
    /// writes them as they are, and reads back.
    #[test]
    fn the_constraints_table_uncommented_switches_the_recommended_limits_on() {
        let text = template(&Case::paper());
        let mut on = text.replace("\n# [constraints]\n", "\n[constraints]\n");
        for d in DOCS.iter().filter(|d| d.table == "constraints") {
            on = on.replace(&format!("\n# {} = ", d.key), &format!("\n{} = ", d.key));
        }
        let read = Case::from_toml_str(&on).expect("valid");
        let recommended = bellyflop::input::scenario::Constraints::recommended();
        assert_eq!(read.scenario.constraints, recommended);
        let mut case = Case::paper();
        case.scenario.constraints = recommended;
        let written = template(&case);
        assert!(written.contains("\n[constraints]\n"), "{written}");
        assert_eq!(
            Case::from_toml_str(&written).unwrap().scenario.constraints,
            case.scenario.constraints
        );
    }

    /// `init --model 6dof` writes a 6-DoF scenario: it reads back valid
    /// and 6-DoF, with every out-of-plane field written (at 0, with its
    /// comment: meaning, unit, range), and the fields, edited, read back.
    #[test]
    fn the_six_dof_template_reads_back_as_a_six_dof_case() {
        let text = template(&paper_case(InitModel::SixDof));
        assert!(!text.contains("undocumented"), "{text}");
        assert!(text.contains("\nmodel = \"6dof\"\n"), "{text}");
        let read = Case::from_toml_str(&text).expect("the 6-DoF template is valid");
        assert_eq!(read.scenario.model, ModelKind::SixDof);
        assert!(read.scenario.out_of_plane().iter().all(|(_, v)| *v == 0.0));
        for (field, _) in read.scenario.out_of_plane() {
            let (_, key) = field.split_once('.').unwrap();
            let line = format!("\n{key} = 0.0\n");
            assert_eq!(text.matches(&line).count(), 1, "{field}:\n{text}");
            let doc = DOCS
                .iter()
                .find(|d| format!("{}.{}", d.table, d.key) == field)
                .unwrap_or_else(|| panic!("{field} is undocumented"));
            // Its comment: the `#` lines right above it.
            let before = &text[..text.find(&line).unwrap()];
            let comment: Vec<&str> = before
                .lines()
                .rev()
                .take_while(|l| l.starts_with('#'))
                .collect();
            let comment = comment.into_iter().rev().collect::<Vec<_>>().join(" ");
            assert!(comment.contains("6-DoF only, default 0"), "{field}");
            assert!(
                comment.contains(&format!("Allowed: {}.", allowed_text(doc))),
                "{field}: {comment}"
            );
        }
        // The fields, set, are read back.
        let edited = text
            .replace("\nyaw_deg = 0.0\n", "\nyaw_deg = 30.0\n")
            .replace("\ngimbal2_deg = 0.0\n", "\ngimbal2_deg = -5.0\n")
            .replace("\nwind_y_mps = 0.0\n", "\nwind_y_mps = 3.0\n");
        let read = Case::from_toml_str(&edited).expect("valid");
        let i = &read.scenario.initial;
        assert_eq!((i.yaw_deg, i.gimbal2_deg), (30.0, -5.0));
        assert_eq!(read.scenario.environment.wind_y_mps, 3.0);
        // The planar template is untouched by the 6-DoF documentation.
        assert_eq!(
            template(&paper_case(InitModel::Planar)),
            template(&Case::paper())
        );
    }

    #[test]
    fn every_documented_field_exists() {
        let mut case = paper_case(InitModel::SixDof);
        case.scenario.constraints = bellyflop::input::scenario::Constraints::recommended();
        let (i, e) = (&mut case.scenario.initial, &mut case.scenario.environment);
        (i.y_m, i.vy_mps, i.yaw_deg, i.roll_deg) = (1.0, 1.0, 1.0, 1.0);
        (i.body_rate_x_degps, i.roll_rate_degps, i.gimbal2_deg) = (1.0, 1.0, 1.0);
        e.wind_y_mps = 1.0;
        let v = serde_json::to_value(case).unwrap();
        for d in DOCS {
            let mut field = &v;
            for part in d.table.split('.').filter(|p| !p.is_empty()) {
                field = &field[part];
            }
            let field = &field[d.key];
            assert!(
                !field.is_null(),
                "{}.{} is not a scenario field",
                d.table,
                d.key
            );
        }
    }

    /// The documented ranges are the validated ones: just outside is rejected
    /// with an out-of-range error naming the field; at the end (or just
    /// inside an open end) no range error is raised.
    #[test]
    fn documented_ranges_match_validation() {
        for d in DOCS {
            let name = if d.table.is_empty() {
                d.key.to_string()
            } else {
                format!("{}.{}", d.table, d.key)
            };
            let check = |value: Value, inside: bool| {
                // ±inf has no JSON number (serde_json writes null); the
                // validation of non-finite values is tested in bellyflop.
                if value.is_null() {
                    return;
                }
                let s = with_field(d.table, d.key, value.clone())
                    .unwrap_or_else(|e| panic!("{name} = {value}: {e}"));
                match s.validate() {
                    Err(InputError::OutOfRange { field, .. }) => {
                        assert!(!inside, "{name} = {value} rejected as out of range");
                        assert_eq!(field, name);
                    }
                    Ok(()) | Err(InputError::Inconsistent { .. }) => {
                        assert!(inside, "{name} = {value} accepted");
                    }
                    Err(e) => panic!("{name} = {value}: {e}"),
                }
            };
            match d.allowed {
                Allowed::Real {
                    lo,
                    hi,
                    lo_open,
                    hi_open,
                } => {
                    let (lo_in, lo_out) = if lo_open {
                        (lo.next_up(), lo)
                    } else {
                        (lo, lo.next_down())
                    };
                    let (hi_in, hi_out) = if hi_open {
                        (hi.next_down(), hi)
                    } else {
                        (hi, hi.next_up())
                    };
                    check(lo_in.into(), true);
                    check(lo_out.into(), false);
                    check(hi_in.into(), true);
                    check(hi_out.into(), false);
                }
                Allowed::Count { lo, hi } => {
                    check(lo.into(), true);
                    check(hi.into(), true);
                    if lo > 0 {
                        check((lo - 1).into(), false);
                    }
                    check((hi + 1).into(), false);
                }
                Allowed::Choice(choices) => {
                    for c in choices {
                        assert!(with_field(d.table, d.key, (*c).into()).is_ok(), "{c}");
                    }
                    assert!(with_field(d.table, d.key, "nonsense".into()).is_err());
                }
                Allowed::Flag => {
                    check(true.into(), true);
                    check(false.into(), true);
                    assert!(with_field(d.table, d.key, "nonsense".into()).is_err());
                }
                Allowed::Text => {}
            }
        }
    }
}
