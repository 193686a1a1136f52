//! Range checks for every scenario field.
//!
//! Validation runs in two passes:
//!
//! 1. every numeric field is checked on its own against a fixed range
//!    ([`InputError::OutOfRange`]); NaN and ±inf are always rejected, so the
//!    second pass only ever compares finite numbers;
//! 2. fields that must agree with each other are compared
//!    ([`InputError::Inconsistent`]), e.g. T_min ≤ T_max or m_dry < m0.
//!
//! The ranges are deliberately generous: they reject numbers that cannot
//! describe a rocket landing (or would break the numerics), not merely
//! unusual vehicles. The paper's case (Chen, Ma, Wang, Su 2023, Table 1 and
//! Section 4) sits well inside every range.
use crate::input::error::InputError;
use crate::input::mesh_layout::MeshLayout;
use crate::input::range::{check_all, count_in_range, in_range, Range};
use crate::input::scenario::{
    Constraints, Discretization, Environment, InitialState, ModelKind, Scenario, TerminalState,
    Vehicle,
};
use crate::input::settings::SolverSettings;

// ---------------------------------------------------------------------------
// Vehicle (paper Table 1). Bounds cover anything from a small test hopper to
// vehicles well beyond Super Heavy (≈ 5e6 kg fuelled, ≈ 7.5e7 N thrust).
// ---------------------------------------------------------------------------

/// Masses (dry mass, initial mass, final-mass guess): at least 1 kg (a
/// subnormal mass, 5e-324 kg, broke the subproblem: exit 6), and at most
/// 1e7 kg, about twice the fuelled mass of the largest rocket ever flown.
const MASS: Range = Range::closed(1.0, 1e7, "kg");
/// Body length, radius and the cg/cp stations: at least 1 cm (a zero lever
/// arm or radius makes the pitch dynamics degenerate; 1e-300 m broke the
/// subproblem), at most 1 km.
const LENGTH: Range = Range::closed(0.01, 1000.0, "m");
/// Maximum thrust: at least 1 N (a zero T_max leaves no control at all, and
/// 5e-324 N broke the subproblem), at most 1e9 N, over ten times any engine
/// cluster built.
const MAX_THRUST: Range = Range::closed(1.0, 1e9, "N");
/// Minimum thrust: may be 0 (a deep-throttling engine, no lower bound in
/// Eq. 5), same upper bound as T_max.
const MIN_THRUST: Range = Range::closed(0.0, 1e9, "N");
/// Specific impulse: at least 1 s (the mass-flow equation ṁ = −T/(I_sp·g0)
/// divides by it, and below 1e-6 s it broke the subproblem; cold gas is
/// ≈ 70 s), at most 1000 s, above any chemical engine (≈ 465 s).
const ISP: Range = Range::closed(1.0, 1000.0, "s");
/// Maximum gimbal angle δ_max: at least 0.1° (a smaller limit cannot steer,
/// and a subnormal one became 0 rad and broke the subproblem's bounds) and
/// below 90°, where the nozzle would point sideways.
const MAX_GIMBAL: Range = Range::closed_open(0.1, 90.0, "deg");
/// Maximum gimbal rate χ_max: at least 0.1 deg/s (as for δ_max), at most one
/// turn per second.
const GIMBAL_RATE: Range = Range::closed(0.1, 360.0, "deg/s");
/// Lumped drag coefficient C_LD = ½·ρ·c_D·A: zero (vacuum) is allowed; 1e5
/// kg/m is ~500 times the paper's 195.52 kg/m.
const DRAG: Range = Range::closed(0.0, 1e5, "kg/m");

// ---------------------------------------------------------------------------
// Environment.
// ---------------------------------------------------------------------------

/// g0: at least 1e-3 m/s² (I_sp·g0 is a divisor, and below 1e-6 it broke the
/// subproblem; a 10-km asteroid has ≈ 3e-3), at most 100 m/s² (Jupiter ≈ 25).
const G0: Range = Range::closed(1e-3, 100.0, "m/s^2");
/// Steady wind: |W| ≤ 100 m/s, above any wind a vehicle lands in (along
/// x, and the 6-DoF model's cross wind along y).
const WIND: Range = Range::closed(-100.0, 100.0, "m/s");

// ---------------------------------------------------------------------------
// Boundary conditions (paper Section 4, Eq. 4). A landing burn starts at most
// a few km up and downrange, so 100 km and 10 km/s are far outside any case
// the method is meant for, but still well-scaled numbers.
// ---------------------------------------------------------------------------

/// Downrange position x: |x| ≤ 1e5 m.
const POS_X: Range = Range::closed(-1e5, 1e5, "m");
/// Altitude z: the ground is z = 0, so 0 ≤ z ≤ 1e5 m (the Kármán line).
const POS_Z: Range = Range::closed(0.0, 1e5, "m");
/// Velocity components: |v| ≤ 1e4 m/s, above orbital speed.
const SPEED: Range = Range::closed(-1e4, 1e4, "m/s");
/// Pitch θ from the vertical: one full turn, −180° to 180°.
const THETA: Range = Range::closed(-180.0, 180.0, "deg");
/// Pitch rate ω: |ω| ≤ 360 deg/s, one turn per second.
const PITCH_RATE: Range = Range::closed(-360.0, 360.0, "deg/s");
/// Initial gimbal δ(t0): strictly within ±90° (then also within ±δ_max,
/// checked as a consistency condition). The 6-DoF model's second gimbal
/// angle δ2 the same.
const GIMBAL: Range = Range::open(-90.0, 90.0, "deg");
/// The 6-DoF model's cross-range position y: like x, |y| ≤ 1e5 m.
const POS_Y: Range = POS_X;
/// The 6-DoF model's yaw ψ and roll φ: one full turn, −180° to 180°.
const YAW_ROLL: Range = Range::closed(-180.0, 180.0, "deg");
/// The 6-DoF model's body rates ω_x and ω_z (roll): like the pitch rate,
/// at most one turn per second.
const BODY_RATE: Range = PITCH_RATE;

// ---------------------------------------------------------------------------
// Discretization (paper Section 3.2).
// ---------------------------------------------------------------------------

/// LGR collocation points N: at least 4 so the polynomial can represent the
/// flip (the paper uses 20), at most 200 over several intervals (a refined
/// mesh, or a fine reference such as 20 × 8; each interval is at most
/// `INTERVAL_POINTS`).
pub const NODES: (usize, usize) = (4, 200);
/// N of the global mesh (one interval): at most 100, beyond which its dense
/// differentiation matrix is ill-conditioned and the subproblem is large.
const GLOBAL_NODES_MAX: usize = 100;
/// LGR mesh intervals M (further limited to N/2).
pub const INTERVALS: (usize, usize) = (1, 50);
// ---------------------------------------------------------------------------
// The arguments of a call rather than fields of a file: the CLI's flags and
// the Python package's keyword arguments (`nodes` and `intervals` are the
// two above).
// ---------------------------------------------------------------------------

/// Landings in one campaign (`montecarlo --runs`, `montecarlo(runs)`).
pub const RUNS: (u64, u64) = (1, 1_000_000);
/// A campaign's seed (`--seed`, `seed=`): any 64-bit unsigned integer.
pub const SEED: (u64, u64) = (0, u64::MAX);
/// A run's index in its campaign (`sim --run`, `sim(run=)`): any 64-bit
/// unsigned integer.
pub const RUN: (u64, u64) = (0, u64::MAX);
/// Worker threads (`--threads`, `threads=`; 0: one per core). A campaign
/// uses at most one per run, so a larger count costs nothing.
pub const THREADS: (u64, u64) = (0, 1_000_000);

/// LGR points n_k of one interval of an explicit mesh: at least 2, as the
/// uniform split's M ≤ N/2 demands, at most the cap on N.
const INTERVAL_POINTS: (usize, usize) = (2, 100);
/// Narrowest interval of an explicit mesh, in τ (whose span is 2): the rows
/// (2/h_k)·D^(k) of Eq. 24 grow as 1/h_k, and a width such as 1e-300 would
/// overflow them to ±inf. 1e-6 is far below any useful refinement of at
/// most 100 points.
const MESH_WIDTH_MIN: f64 = 1e-6;
/// Final-time guess t_f: positive, at most 1000 s (a landing burn lasts tens
/// of seconds; the paper's is about 12 s). A scenario file's guess above
/// 1000 s is clamped to it when read ([`crate::input::guess::resolve`]), so
/// only a zero, negative or non-finite one reaches this check from a file.
const TF_GUESS: Range = Range::open_closed(0.0, 1000.0, "s");

// ---------------------------------------------------------------------------
// SCvx settings (paper Section 3.4; trust-region rule of Mao, Szmuk and
// Açıkmeşe 2016).
// ---------------------------------------------------------------------------

/// Iteration limit: at least one iteration, at most 10000.
const MAX_ITERATIONS: (usize, usize) = (1, 10_000);
/// Polishes on repaired arcs (`solver.polish_repairs`).
pub const POLISH_REPAIRS: (usize, usize) = (0, 10);
/// Iterations of the relaxed first phase: 0 (off) to 10000.
const RELAXED_FIRST_ITERATIONS: (usize, usize) = (0, 10_000);
/// Convergence tolerances on scaled quantities, and the accepted relaxation
/// gap 1 − ‖T‖/σ: strictly between 0 (never reached in floating point) and 1
/// (no accuracy at all).
const TOLERANCE: Range = Range::open(0.0, 1.0, "");
/// Initial barrier parameter of the direct method.
const MU_INIT: Range = Range::open_closed(0.0, 10.0, "");
/// Exact-penalty weight λ on the virtual control: 1 to 1e5. Measured with
/// `bellyflop solve` on the paper's case in all three formulations (relaxed
/// first phase on and off): 1 to 1e6 solve; 3e6 and 1e7 fail in some
/// formulation (infeasible, non_physical, not_converged), and from 1e8 on
/// Clarabel fails on every try (exit 6). 1e5 keeps a factor 10 of margin;
/// below 1 the penalty is too weak to remove the virtual control.
const VC_WEIGHT: Range = Range::closed(1.0, 1e5, "");
/// Weight of the soft thrust margin: positive, at most 1e12, past which the
/// subproblem cost is dominated by round-off.
const WEIGHT: Range = Range::open_closed(0.0, 1e12, "");
/// Proximal weight on the scaled step: zero (off) up to 1e6.
const PROXIMAL_WEIGHT: Range = Range::closed(0.0, 1e6, "");
/// Trust-region radii on the scaled variables (O(1)): positive, at most 1e6.
const TRUST_RADIUS: Range = Range::open_closed(0.0, 1e6, "");
/// Acceptance-ratio thresholds ρ0 < ρ1 < ρ2: Mao et al. require them in
/// [0, 1) (ρ0 = 0 is the common choice); their order is checked separately.
const RHO: Range = Range::closed_open(0.0, 1.0, "");
/// Soft thrust margin μ: 0 (off) up to, not including, 0.5, where
/// (1−μ)·T_max would fall to half the engine.
const MARGIN: Range = Range::closed_open(0.0, 0.5, "");
/// Weight of a soft constraint that may be off: 0 (off) to 1e12.
const SOFT_WEIGHT: Range = Range::closed(0.0, 1e12, "");
/// Landing position tolerance of a `solved` answer: at least 1 mm (the
/// ground tolerance; the re-integration itself is accurate to ~1e-6 m, but
/// no collocation answer lands closer), at most 1e6 m, which turns the check off.
const LANDING_POSITION_TOLERANCE: Range = Range::closed(1e-3, 1e6, "m");
/// Landing velocity tolerance: at least 1 mm/s, at most 1e4 m/s (off).
const LANDING_VELOCITY_TOLERANCE: Range = Range::closed(1e-3, 1e4, "m/s");
/// Trust-region shrink and grow factors: strictly above 1 (else the radius
/// does not change), at most 100.
const FACTOR: Range = Range::open_closed(1.0, 100.0, "");
/// Mesh refinement's tolerance on the relative interval error: 0 (off) to
/// 0.1 (a coarser target is no refinement).
const REFINEMENT_TOLERANCE: Range = Range::closed(0.0, 0.1, "");
/// Refinement passes, the first solve included.
const REFINEMENT_PASSES: (usize, usize) = (1, 20);
/// Points of an interval that refinement makes: n_min and n_max of the ph
/// rule (within an explicit mesh's [`INTERVAL_POINTS`]).
const REFINEMENT_POINTS: (usize, usize) = (2, 20);

// ---------------------------------------------------------------------------
// Operational constraints (issue 37), each optional.
// ---------------------------------------------------------------------------

/// Approach cone half-angle from the vertical: at least 1° (a needle would
/// leave no room to steer), at most 89° (90° is the ground itself).
const CONE_HALF_ANGLE: Range = Range::closed(1.0, 89.0, "deg");
/// Pitch-rate limit: above 0, at most one turn per second.
const MAX_PITCH_RATE: Range = Range::open_closed(0.0, 360.0, "deg/s");
/// Tilt limit: 0 (upright) to 90° (belly-first).
const MAX_TILT: Range = Range::closed(0.0, 90.0, "deg");
/// Heights above the pad of the altitude-triggered limits: the ground to
/// the largest altitude of [`POS_Z`].
const TRIGGER_HEIGHT: Range = Range::closed(0.0, 1e5, "m");
/// Lateral-speed limit of the final descent: 0 to 100 m/s.
const LATERAL_SPEED: Range = Range::closed(0.0, 100.0, "m/s");

/// Check every field of a scenario against its allowed range, then check that
/// related fields agree with each other.
pub fn scenario(s: &Scenario) -> Result<(), InputError> {
    name(&s.name)?;
    vehicle(&s.vehicle)?;
    environment(&s.environment)?;
    initial(&s.initial)?;
    terminal(&s.terminal)?;
    discretization(&s.discretization)?;
    constraints(&s.constraints)?;
    consistency(s)
}

/// Constraint ranges: see [`CONE_HALF_ANGLE`], [`MAX_PITCH_RATE`],
/// [`MAX_TILT`], [`TRIGGER_HEIGHT`], [`LATERAL_SPEED`]; the limits given as
/// a pair (a bound and its altitude) must be given together.
fn constraints(c: &Constraints) -> Result<(), InputError> {
    let rows = [
        (
            "constraints.cone_half_angle_deg",
            c.cone_half_angle_deg,
            CONE_HALF_ANGLE,
        ),
        (
            "constraints.max_pitch_rate_degps",
            c.max_pitch_rate_degps,
            MAX_PITCH_RATE,
        ),
        ("constraints.max_tilt_deg", c.max_tilt_deg, MAX_TILT),
        ("constraints.tilt_below_m", c.tilt_below_m, TRIGGER_HEIGHT),
        (
            "constraints.final_descent_m",
            c.final_descent_m,
            TRIGGER_HEIGHT,
        ),
        (
            "constraints.final_descent_lateral_mps",
            c.final_descent_lateral_mps,
            LATERAL_SPEED,
        ),
    ];
    for (field, value, range) in rows {
        if let Some(v) = value {
            range.check(field, v)?;
        }
    }
    let pairs = [
        (
            ("constraints.max_tilt_deg", c.max_tilt_deg),
            ("constraints.tilt_below_m", c.tilt_below_m),
        ),
        (
            (
                "constraints.final_descent_lateral_mps",
                c.final_descent_lateral_mps,
            ),
            ("constraints.final_descent_m", c.final_descent_m),
        ),
    ];
    for ((a, va), (b, vb)) in pairs {
        let (given, missing, value) = match (va, vb) {
            (Some(v), None) => (a, b, v),
            (None, Some(v)) => (b, a, v),
            _ => continue,
        };
        return Err(InputError::Inconsistent {
            field: given.into(),
            value,
            reason: format!("must be given together with {missing}"),
        });
    }
    Ok(())
}

/// The name labels outputs, so it must contain a non-blank character.
fn name(name: &str) -> Result<(), InputError> {
    if name.trim().is_empty() {
        return Err(InputError::Empty {
            field: "name".into(),
        });
    }
    Ok(())
}

/// Vehicle ranges: see [`MASS`], [`LENGTH`], [`MAX_THRUST`], [`MIN_THRUST`],
/// [`ISP`], [`MAX_GIMBAL`], [`GIMBAL_RATE`], [`DRAG`].
fn vehicle(v: &Vehicle) -> Result<(), InputError> {
    check_all(&[
        ("vehicle.dry_mass_kg", v.dry_mass_kg, MASS),
        ("vehicle.length_m", v.length_m, LENGTH),
        ("vehicle.radius_m", v.radius_m, LENGTH),
        ("vehicle.cg_m", v.cg_m, LENGTH),
        ("vehicle.cp_m", v.cp_m, LENGTH),
        ("vehicle.max_thrust_n", v.max_thrust_n, MAX_THRUST),
        ("vehicle.min_thrust_n", v.min_thrust_n, MIN_THRUST),
        ("vehicle.isp_s", v.isp_s, ISP),
        ("vehicle.max_gimbal_deg", v.max_gimbal_deg, MAX_GIMBAL),
        (
            "vehicle.max_gimbal_rate_degps",
            v.max_gimbal_rate_degps,
            GIMBAL_RATE,
        ),
        (
            "vehicle.drag_coefficient_kgpm",
            v.drag_coefficient_kgpm,
            DRAG,
        ),
    ])
}

/// Environment ranges: see [`G0`], [`WIND`].
fn environment(e: &Environment) -> Result<(), InputError> {
    check_all(&[
        ("environment.g0_mps2", e.g0_mps2, G0),
        ("environment.wind_x_mps", e.wind_x_mps, WIND),
        ("environment.wind_y_mps", e.wind_y_mps, WIND),
    ])
}

/// Initial-state ranges: see [`POS_X`], [`POS_Z`], [`SPEED`], [`THETA`],
/// [`PITCH_RATE`], [`MASS`], [`GIMBAL`]; the 6-DoF fields [`POS_Y`],
/// [`SPEED`], [`YAW_ROLL`], [`BODY_RATE`], [`GIMBAL`].
fn initial(i: &InitialState) -> Result<(), InputError> {
    check_all(&[
        ("initial.x_m", i.x_m, POS_X),
        ("initial.z_m", i.z_m, POS_Z),
        ("initial.vx_mps", i.vx_mps, SPEED),
        ("initial.vz_mps", i.vz_mps, SPEED),
        ("initial.theta_deg", i.theta_deg, THETA),
        ("initial.pitch_rate_degps", i.pitch_rate_degps, PITCH_RATE),
        ("initial.mass_kg", i.mass_kg, MASS),
        ("initial.gimbal_deg", i.gimbal_deg, GIMBAL),
        ("initial.y_m", i.y_m, POS_Y),
        ("initial.vy_mps", i.vy_mps, SPEED),
        ("initial.yaw_deg", i.yaw_deg, YAW_ROLL),
        ("initial.roll_deg", i.roll_deg, YAW_ROLL),
        ("initial.body_rate_x_degps", i.body_rate_x_degps, BODY_RATE),
        ("initial.roll_rate_degps", i.roll_rate_degps, BODY_RATE),
        ("initial.gimbal2_deg", i.gimbal2_deg, GIMBAL),
    ])
}

/// A planar scenario's out-of-plane fields ([`Scenario::out_of_plane`])
/// must all be 0: the planar model would ignore them, so a nonzero one is
/// [`InputError::Inconsistent`], naming it and `model = "6dof"`.
fn model_fields(s: &Scenario) -> Result<(), InputError> {
    if s.model != ModelKind::Planar {
        return Ok(());
    }
    match s.out_of_plane().into_iter().find(|(_, v)| *v != 0.0) {
        Some((field, value)) => Err(InputError::Inconsistent {
            field: field.into(),
            value,
            reason: "needs model = \"6dof\" (a top-level key of the scenario): only the 6-DoF model reads the out-of-plane fields, and the planar model (the default) would ignore it".into(),
        }),
        None => Ok(()),
    }
}

/// Terminal-state ranges: the same as the initial state's (touchdown at
/// z ≥ 0 is covered by [`POS_Z`]).
fn terminal(t: &TerminalState) -> Result<(), InputError> {
    check_all(&[
        ("terminal.x_m", t.x_m, POS_X),
        ("terminal.z_m", t.z_m, POS_Z),
        ("terminal.vx_mps", t.vx_mps, SPEED),
        ("terminal.vz_mps", t.vz_mps, SPEED),
        ("terminal.theta_deg", t.theta_deg, THETA),
        ("terminal.pitch_rate_degps", t.pitch_rate_degps, PITCH_RATE),
    ])
}

/// Discretization ranges: see [`NODES`], [`TF_GUESS`], [`MASS`]; an
/// explicit mesh ([`mesh_layout`]) must also agree with the counts: N = Σ n_k
/// and M = its number of intervals.
fn discretization(d: &Discretization) -> Result<(), InputError> {
    count_in_range("discretization.nodes", d.nodes, NODES)?;
    count_in_range("discretization.intervals", d.intervals, INTERVALS)?;
    if d.intervals == 1 && d.nodes > GLOBAL_NODES_MAX {
        return Err(InputError::Inconsistent {
            field: "discretization.nodes".into(),
            value: d.nodes as f64,
            reason: format!(
                "must be at most {GLOBAL_NODES_MAX} on the global mesh (discretization.intervals = 1); up to {} over several intervals",
                NODES.1
            ),
        });
    }
    if let Some(mesh) = &d.mesh {
        mesh_layout("discretization.mesh", mesh)?;
        let (total, m) = (mesh.nodes(), mesh.intervals());
        if !(NODES.0..=NODES.1).contains(&total) {
            return Err(InputError::OutOfRange {
                field: "discretization.mesh.points".into(),
                value: total as f64,
                allowed: format!(
                    "a sum of {} to {} points (the range of discretization.nodes)",
                    NODES.0, NODES.1
                ),
            });
        }
        let checks: [Check<'_>; 2] = [
            (
                d.nodes == total,
                "discretization.nodes",
                d.nodes as f64,
                &|| {
                    format!(
                    "must equal the sum of discretization.mesh.points, {total} (N counts the mesh's points)"
                )
                },
            ),
            (
                d.intervals == m,
                "discretization.intervals",
                d.intervals as f64,
                &|| {
                    format!(
                    "must equal the number of intervals of discretization.mesh, {m} (the entries of its points)"
                )
                },
            ),
        ];
        first_inconsistency(checks)?;
    }
    if d.intervals > d.nodes / 2 {
        return Err(InputError::Inconsistent {
            field: "discretization.intervals".into(),
            value: d.intervals as f64,
            reason: format!(
                "each interval needs at least 2 of the N = {} collocation points, so at most {} intervals",
                d.nodes,
                d.nodes / 2
            ),
        });
    }
    check_all(&[
        ("discretization.tf_guess_s", d.tf_guess_s, TF_GUESS),
        (
            "discretization.final_mass_guess_kg",
            d.final_mass_guess_kg,
            MASS,
        ),
    ])
}

/// An explicit mesh's shape (`field` names it, e.g. `discretization.mesh`):
/// M = points.len() in [`INTERVALS`], M + 1 breaks, each finite in [−1, 1],
/// the first −1 and the last +1, each at least [`MESH_WIDTH_MIN`] above the
/// one before (strictly increasing), and [`INTERVAL_POINTS`] per interval.
pub(crate) fn mesh_layout(field: &str, mesh: &MeshLayout) -> Result<(), InputError> {
    let m = mesh.points.len();
    if !(INTERVALS.0..=INTERVALS.1).contains(&m) {
        return Err(InputError::OutOfRange {
            field: format!("{field}.points"),
            value: m as f64,
            allowed: format!(
                "{} to {} entries, one per interval",
                INTERVALS.0, INTERVALS.1
            ),
        });
    }
    let breaks = &mesh.breaks_tau;
    if breaks.len() != m + 1 {
        return Err(InputError::Inconsistent {
            field: format!("{field}.breaks_tau"),
            value: breaks.len() as f64,
            reason: format!(
                "has {} entries, but the M = {m} intervals of {field}.points need M + 1 = {} breaks",
                breaks.len(),
                m + 1
            ),
        });
    }
    for (k, &b) in breaks.iter().enumerate() {
        in_range(
            &format!("{field}.breaks_tau[{k}]"),
            b,
            -1.0,
            1.0,
            false,
            false,
            "",
        )?;
    }
    for (k, want) in [(0, -1.0), (m, 1.0)] {
        if breaks[k] != want {
            return Err(InputError::Inconsistent {
                field: format!("{field}.breaks_tau[{k}]"),
                value: breaks[k],
                reason: format!(
                    "the {} break must be {want}: the intervals cover τ ∈ [-1, 1]",
                    if k == 0 { "first" } else { "last" }
                ),
            });
        }
    }
    for k in 0..m {
        if breaks[k + 1] - breaks[k] < MESH_WIDTH_MIN {
            return Err(InputError::Inconsistent {
                field: format!("{field}.breaks_tau[{}]", k + 1),
                value: breaks[k + 1],
                reason: format!(
                    "must exceed {field}.breaks_tau[{k}] = {} by at least {MESH_WIDTH_MIN:e} (breaks strictly increase, and a narrower interval overflows its differentiation rows 2/h_k)",
                    breaks[k]
                ),
            });
        }
    }
    for (k, &p) in mesh.points.iter().enumerate() {
        count_in_range(&format!("{field}.points[{k}]"), p, INTERVAL_POINTS)?;
    }
    Ok(())
}

/// Solver ranges: see `MAX_ITERATIONS`, `TOLERANCE`, `WEIGHT`,
/// `TRUST_RADIUS`, `RHO`, `FACTOR`.
/// Every solver setting against its range, and the trust-region rule's
/// ordering (ρ0 < ρ1 < ρ2, r_min ≤ r_initial ≤ r_max).
pub fn solver(s: &SolverSettings) -> Result<(), InputError> {
    count_in_range("solver.max_iterations", s.max_iterations, MAX_ITERATIONS)?;
    count_in_range("solver.polish_repairs", s.polish_repairs, POLISH_REPAIRS)?;
    count_in_range(
        "solver.direct.max_iterations",
        s.direct.max_iterations,
        MAX_ITERATIONS,
    )?;
    count_in_range(
        "solver.direct.coarse_nodes",
        s.direct.coarse_nodes,
        (0, 100),
    )?;
    check_all(&[
        ("solver.direct.tolerance", s.direct.tolerance, TOLERANCE),
        (
            "solver.direct.coarse_tolerance",
            s.direct.coarse_tolerance,
            TOLERANCE,
        ),
        ("solver.direct.mu_init", s.direct.mu_init, MU_INIT),
    ])?;
    count_in_range(
        "solver.relaxed_first_iterations",
        s.relaxed_first_iterations,
        RELAXED_FIRST_ITERATIONS,
    )?;
    check_all(&[
        ("solver.step_tolerance", s.step_tolerance, TOLERANCE),
        ("solver.defect_tolerance", s.defect_tolerance, TOLERANCE),
        (
            "solver.virtual_control_tolerance",
            s.virtual_control_tolerance,
            TOLERANCE,
        ),
        (
            "solver.virtual_control_weight",
            s.virtual_control_weight,
            VC_WEIGHT,
        ),
        ("solver.proximal_weight", s.proximal_weight, PROXIMAL_WEIGHT),
        (
            "solver.trust_region_initial",
            s.trust_region_initial,
            TRUST_RADIUS,
        ),
        ("solver.trust_region_min", s.trust_region_min, TRUST_RADIUS),
        ("solver.trust_region_max", s.trust_region_max, TRUST_RADIUS),
        ("solver.rho0", s.rho0, RHO),
        ("solver.rho1", s.rho1, RHO),
        ("solver.rho2", s.rho2, RHO),
        ("solver.shrink", s.shrink, FACTOR),
        ("solver.grow", s.grow, FACTOR),
        (
            "solver.relaxation_gap_tolerance",
            s.relaxation_gap_tolerance,
            TOLERANCE,
        ),
        ("solver.thrust_margin_frac", s.thrust_margin_frac, MARGIN),
        (
            "solver.thrust_margin_weight",
            s.thrust_margin_weight,
            WEIGHT,
        ),
        (
            "solver.terminal_lateral_weight",
            s.terminal_lateral_weight,
            SOFT_WEIGHT,
        ),
        (
            "solver.landing_position_tolerance_m",
            s.landing_position_tolerance_m,
            LANDING_POSITION_TOLERANCE,
        ),
        (
            "solver.landing_velocity_tolerance_mps",
            s.landing_velocity_tolerance_mps,
            LANDING_VELOCITY_TOLERANCE,
        ),
        (
            "solver.refinement.tolerance",
            s.refinement.tolerance,
            REFINEMENT_TOLERANCE,
        ),
    ])?;
    let r = &s.refinement;
    count_in_range(
        "solver.refinement.max_passes",
        r.max_passes,
        REFINEMENT_PASSES,
    )?;
    count_in_range(
        "solver.refinement.min_points",
        r.min_points,
        REFINEMENT_POINTS,
    )?;
    count_in_range(
        "solver.refinement.max_points",
        r.max_points,
        REFINEMENT_POINTS,
    )?;
    count_in_range(
        "solver.refinement.max_total_points",
        r.max_total_points,
        NODES,
    )?;
    if r.min_points > r.max_points {
        return Err(InputError::Inconsistent {
            field: "solver.refinement.max_points".into(),
            value: r.max_points as f64,
            reason: format!(
                "must be at least solver.refinement.min_points = {}",
                r.min_points
            ),
        });
    }
    solver_consistency(s)
}

/// The trust-region update rule of Mao, Szmuk and Açıkmeşe (2016):
/// ρ0 < ρ1 < ρ2 and r_min ≤ r_initial ≤ r_max.
fn solver_consistency(sv: &SolverSettings) -> Result<(), InputError> {
    let checks: [Check<'_>; 4] = [
        (sv.rho0 < sv.rho1, "solver.rho1", sv.rho1, &|| {
            format!("must be greater than solver.rho0 = {}", sv.rho0)
        }),
        (sv.rho1 < sv.rho2, "solver.rho2", sv.rho2, &|| {
            format!("must be greater than solver.rho1 = {}", sv.rho1)
        }),
        (
            sv.trust_region_min <= sv.trust_region_initial,
            "solver.trust_region_initial",
            sv.trust_region_initial,
            &|| {
                format!(
                    "must be at least solver.trust_region_min = {}",
                    sv.trust_region_min
                )
            },
        ),
        (
            sv.trust_region_initial <= sv.trust_region_max,
            "solver.trust_region_initial",
            sv.trust_region_initial,
            &|| {
                format!(
                    "must be at most solver.trust_region_max = {}",
                    sv.trust_region_max
                )
            },
        ),
    ];
    first_inconsistency(checks)
}

/// Cross-field conditions. All values are finite here (the range pass ran
/// first). Sources:
/// - T_min ≤ T_max: the throttle interval of Eq. 5 must not be empty;
/// - m_dry < m0: Eq. 4 requires the final mass above m_dry, and the vehicle
///   must carry some propellant; the final-mass guess lies in [m_dry, m0]
///   (a scenario file's positive guess outside it is clamped into it when
///   read, [`crate::input::guess::resolve`]);
/// - l_cp ≤ l_s: measured along the body from the gimbal, it lies on the
///   body; l_cg within [`CG_FRACTION_MIN`]·l_s of either end (see there);
/// - |δ(t0)| ≤ δ_max: the initial state must satisfy the gimbal bound (and
///   |δ2(t0)| ≤ δ_max, the 6-DoF model's second angle);
/// - z(t0) > z(t_f): the burn starts above the landing point;
/// - a planar scenario has no out-of-plane field ([`model_fields`]).
fn consistency(s: &Scenario) -> Result<(), InputError> {
    model_fields(s)?;
    let v = &s.vehicle;
    let i = &s.initial;
    let t = &s.terminal;
    let d = &s.discretization;
    let (cg_lo, cg_hi) = (
        CG_FRACTION_MIN * v.length_m,
        (1.0 - CG_FRACTION_MIN) * v.length_m,
    );

    let checks: [Check<'_>; 8] = [
        (
            v.min_thrust_n <= v.max_thrust_n,
            "vehicle.min_thrust_n",
            v.min_thrust_n,
            &|| {
                format!(
                    "must not exceed vehicle.max_thrust_n = {} N",
                    v.max_thrust_n
                )
            },
        ),
        (
            v.dry_mass_kg < i.mass_kg,
            "vehicle.dry_mass_kg",
            v.dry_mass_kg,
            &|| {
                format!(
                    "dry mass {} kg must be below initial.mass_kg = {} kg (no propellant left)",
                    v.dry_mass_kg, i.mass_kg
                )
            },
        ),
        (
            v.dry_mass_kg <= d.final_mass_guess_kg && d.final_mass_guess_kg <= i.mass_kg,
            "discretization.final_mass_guess_kg",
            d.final_mass_guess_kg,
            &|| {
                format!(
                    "must lie in [vehicle.dry_mass_kg, initial.mass_kg] = [{}, {}] kg",
                    v.dry_mass_kg, i.mass_kg
                )
            },
        ),
        (
            (cg_lo..=cg_hi).contains(&v.cg_m),
            "vehicle.cg_m",
            v.cg_m,
            &|| {
                format!(
                "must lie in [{cg_lo:.4}, {cg_hi:.4}] m (between {CG_FRACTION_MIN:.3} and {:.3} of vehicle.length_m = {} m): the pitch inertia of Eq. 22 is that of a body spread over its whole length, which no mass distribution with its centre of mass nearer an end has",
                1.0 - CG_FRACTION_MIN,
                v.length_m
            )
            },
        ),
        (v.cp_m <= v.length_m, "vehicle.cp_m", v.cp_m, &|| {
            format!(
                "centre of pressure lies beyond the body: vehicle.length_m = {} m",
                v.length_m
            )
        }),
        (
            i.gimbal_deg.abs() <= v.max_gimbal_deg,
            "initial.gimbal_deg",
            i.gimbal_deg,
            &|| {
                format!(
                    "|gimbal| must not exceed vehicle.max_gimbal_deg = {} deg",
                    v.max_gimbal_deg
                )
            },
        ),
        (
            i.gimbal2_deg.abs() <= v.max_gimbal_deg,
            "initial.gimbal2_deg",
            i.gimbal2_deg,
            &|| {
                format!(
                    "|gimbal2| must not exceed vehicle.max_gimbal_deg = {} deg",
                    v.max_gimbal_deg
                )
            },
        ),
        (i.z_m > t.z_m, "initial.z_m", i.z_m, &|| {
            format!(
                "must be above terminal.z_m = {} m (the burn starts above the landing point)",
                t.z_m
            )
        }),
    ];
    first_inconsistency(checks)
}

/// A cross-field check: whether it holds, the field, its value, and the
/// reason, written only when it fails (validation runs in every re-plan,
/// which must not allocate).
type Check<'a> = (bool, &'a str, f64, &'a dyn Fn() -> String);

/// The first failed cross-field check of (holds, field, value, reason), as
/// [`InputError::Inconsistent`].
fn first_inconsistency<const N: usize>(checks: [Check<'_>; N]) -> Result<(), InputError> {
    match checks.into_iter().find(|(ok, ..)| !ok) {
        Some((_, field, value, reason)) => Err(InputError::Inconsistent {
            field: field.into(),
            value,
            reason: reason(),
        }),
        None => Ok(()),
    }
}

/// Nearest the centre of mass may come to either end of the body, as a
/// fraction of its length: (1 − √(2/3))/2 ≈ 0.092. The model's pitch inertia
/// per unit mass (6r² + l²)/12 (Eq. 22) has the axial spread l²/12 of a
/// uniform body, and a mass distribution on [0, l] with mean l_cg has a
/// spread of at most l_cg·(l − l_cg) (the Bhatia–Davis inequality), so
/// l_cg·(l − l_cg) ≥ l²/12. Past it the model is not a rigid body: on the
/// paper's case l_cg = l_s gave a `solved` plan whose re-flown path ended
/// 1.1 km below the pad.
pub const CG_FRACTION_MIN: f64 = 0.091_751_709_536_136_98;

/// [`solver`] as a method.
impl SolverSettings {
    /// Check every field against its allowed range.
    pub fn validate(&self) -> Result<(), InputError> {
        solver(self)
    }
}

/// [`scenario`] as a method.
impl Scenario {
    /// Check every field against its allowed range.
    pub fn validate(&self) -> Result<(), InputError> {
        scenario(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::range::fmt_bound;

    #[test]
    fn bounds_print_readably() {
        assert_eq!(fmt_bound(1e7), "1e7");
        assert_eq!(fmt_bound(-1e5), "-1e5");
        assert_eq!(fmt_bound(1000.0), "1000");
        assert_eq!(fmt_bound(0.0), "0");
        assert_eq!(fmt_bound(1.0), "1");
    }

    #[test]
    fn in_range_respects_open_and_closed_ends() {
        assert!(in_range("f", 0.0, 0.0, 1.0, false, false, "m").is_ok());
        assert!(in_range("f", 0.0, 0.0, 1.0, true, false, "m").is_err());
        assert!(in_range("f", 1.0, 0.0, 1.0, false, false, "m").is_ok());
        assert!(in_range("f", 1.0, 0.0, 1.0, false, true, "m").is_err());
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert!(in_range("f", bad, f64::MIN, f64::MAX, false, false, "").is_err());
        }
        let err = in_range("vehicle.dry_mass_kg", -1.0, 0.0, 1e7, true, false, "kg").unwrap_err();
        assert_eq!(
            err.to_string(),
            "vehicle.dry_mass_kg = -1 is out of range: allowed (0, 1e7] kg"
        );
    }

    /// The paper's scenario on an explicit mesh of `breaks` and `points`,
    /// with N and M set to agree with it.
    fn on_mesh(breaks: &[f64], points: &[usize]) -> Scenario {
        let mut s = Scenario::paper();
        let d = &mut s.discretization;
        d.nodes = points.iter().sum();
        d.intervals = points.len();
        d.mesh = Some(MeshLayout {
            breaks_tau: breaks.to_vec(),
            points: points.to_vec(),
        });
        s
    }

    /// The field of a rejected scenario, and whether it was out of range
    /// (else inconsistent); the message names the field.
    fn rejected(s: &Scenario) -> (String, bool) {
        let e = scenario(s).expect_err("must be rejected");
        let text = e.to_string();
        match e {
            InputError::OutOfRange { field, .. } => {
                assert!(text.starts_with(&field), "{text}");
                (field, true)
            }
            InputError::Inconsistent { field, .. } => {
                assert!(text.starts_with(&field), "{text}");
                (field, false)
            }
            other => panic!("unexpected {other:?}"),
        }
    }

    #[test]
    fn a_consistent_explicit_mesh_validates() {
        assert_eq!(
            scenario(&on_mesh(&[-1.0, -0.7, 0.1, 1.0], &[4, 9, 7])),
            Ok(())
        );
        // The uniform layout, spelled out.
        let u = crate::input::mesh_layout::MeshLayout::uniform(20, 4);
        assert_eq!(scenario(&on_mesh(&u.breaks_tau, &u.points)), Ok(()));
    }

    #[test]
    fn mesh_interval_count_outside_1_to_50_is_out_of_range() {
        let mut s = on_mesh(&[-1.0], &[]);
        (s.discretization.nodes, s.discretization.intervals) = (20, 1);
        let (f, range) = rejected(&s);
        assert_eq!((f.as_str(), range), ("discretization.mesh.points", true));
        let breaks: Vec<f64> = (0..=51).map(|k| -1.0 + 2.0 * k as f64 / 51.0).collect();
        let mut s = on_mesh(&breaks, &[2; 51]);
        (s.discretization.nodes, s.discretization.intervals) = (100, 50);
        let (f, range) = rejected(&s);
        assert_eq!((f.as_str(), range), ("discretization.mesh.points", true));
    }

    #[test]
    fn mesh_break_count_must_be_one_more_than_intervals() {
        for breaks in [&[-1.0, 1.0][..], &[-1.0, -0.5, 0.0, 0.5, 1.0]] {
            let (f, range) = rejected(&on_mesh(breaks, &[5, 5, 5]));
            assert_eq!(
                (f.as_str(), range),
                ("discretization.mesh.breaks_tau", false)
            );
        }
    }

    #[test]
    fn non_finite_or_outside_breaks_are_out_of_range() {
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1.5, -3.0] {
            let (f, range) = rejected(&on_mesh(&[-1.0, bad, 1.0], &[5, 5]));
            assert_eq!(
                (f.as_str(), range),
                ("discretization.mesh.breaks_tau[1]", true),
                "{bad}"
            );
        }
        let e = scenario(&on_mesh(&[-1.0, 1.5, 1.0], &[5, 5])).unwrap_err();
        assert_eq!(
            e.to_string(),
            "discretization.mesh.breaks_tau[1] = 1.5 is out of range: allowed [-1, 1]"
        );
    }

    #[test]
    fn breaks_must_start_at_minus_one_and_end_at_one() {
        let (f, range) = rejected(&on_mesh(&[-0.9, 0.0, 1.0], &[5, 5]));
        assert_eq!(
            (f.as_str(), range),
            ("discretization.mesh.breaks_tau[0]", false)
        );
        let (f, range) = rejected(&on_mesh(&[-1.0, 0.0, 0.99], &[5, 5]));
        assert_eq!(
            (f.as_str(), range),
            ("discretization.mesh.breaks_tau[2]", false)
        );
    }

    #[test]
    fn breaks_must_strictly_increase_by_the_minimum_width() {
        for breaks in [
            [-1.0, 0.2, 0.2, 1.0],
            [-1.0, 0.3, 0.2, 1.0],
            [-1.0, 0.2, 0.2 + 1e-9, 1.0],
        ] {
            let (f, range) = rejected(&on_mesh(&breaks, &[5, 5, 5]));
            assert_eq!(
                (f.as_str(), range),
                ("discretization.mesh.breaks_tau[2]", false),
                "{breaks:?}"
            );
        }
        let (f, _) = rejected(&on_mesh(&[-1.0, -1.0, 1.0], &[5, 5]));
        assert_eq!(f, "discretization.mesh.breaks_tau[1]");
    }

    #[test]
    fn interval_points_outside_2_to_100_are_out_of_range() {
        for p in [0, 1, 101] {
            let mut s = on_mesh(&[-1.0, 0.0, 1.0], &[5, p]);
            s.discretization.nodes = 20;
            let (f, range) = rejected(&s);
            assert_eq!(
                (f.as_str(), range),
                ("discretization.mesh.points[1]", true),
                "{p}"
            );
        }
    }

    #[test]
    fn mesh_point_total_outside_the_node_range_is_out_of_range() {
        for points in [&[3][..], &[100, 100, 2]] {
            let breaks: Vec<f64> =
                crate::input::mesh_layout::MeshLayout::uniform(10, points.len()).breaks_tau;
            let mut s = on_mesh(&breaks, points);
            s.discretization.nodes = 20;
            let (f, range) = rejected(&s);
            assert_eq!((f.as_str(), range), ("discretization.mesh.points", true));
        }
    }

    #[test]
    fn nodes_and_intervals_must_agree_with_the_mesh() {
        let mut s = on_mesh(&[-1.0, 0.0, 1.0], &[6, 6]);
        s.discretization.nodes = 13;
        let (f, range) = rejected(&s);
        assert_eq!((f.as_str(), range), ("discretization.nodes", false));
        let mut s = on_mesh(&[-1.0, 0.0, 1.0], &[6, 6]);
        s.discretization.intervals = 1;
        let (f, range) = rejected(&s);
        assert_eq!((f.as_str(), range), ("discretization.intervals", false));
        assert!(scenario(&s)
            .unwrap_err()
            .to_string()
            .contains("must equal the number of intervals of discretization.mesh, 2"));
    }
}
