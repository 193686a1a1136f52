//! How an SCvx run ends: the tests that stop the iteration (convergence, a
//! stalled minimum-violation search, a collapsed trust region, the
//! iteration limit), the status and message each gives, and the physical
//! checks that a `solved` answer must still pass.

use super::step::Candidate;
use crate::collocation::trajectory::Trajectory;
use crate::input::settings::SolverSettings;
use crate::method::scvx::transcription::Transcription;
use crate::problem::dynamics::{ix, NX};
use crate::solution::{Checks, IterationRecord, Status, GROUND_TOLERANCE_M};

/// A status and the message that explains it (empty when solved).
pub(super) type Outcome = (Status, String);

/// A converged virtual control at least this large (scaled) is a certificate
/// that the nonlinear constraints cannot be met; below it, and above the
/// tolerance, the answer is only "not converged".
pub const INFEASIBLE_VIRTUAL_CONTROL: f64 = 1e-4;

/// How far a `solved` thrust may leave [T_min, T_max], as a fraction of
/// T_max (2.2 N on the paper's case). The bounds are linearized in ω (Eq. 28),
/// which costs T_min·Δω²/2 below T_min, and held with penalized buffers up
/// to the virtual-control tolerance: measured 4e-5 N with T_min = T_max.
pub const THRUST_TOLERANCE_FRAC: f64 = 1e-6;

/// Iterations over which [`stalled`] judges progress.
const STALL_WINDOW: usize = 8;
/// Relative merit decrease over the window below which the search has stalled.
const STALL_DECREASE: f64 = 0.02;
/// Virtual control (scaled) that the stalled iterates must all still need.
const STALL_VIRTUAL_CONTROL: f64 = 1e-2;

/// Below this many collocation points an `infeasible` answer says only that
/// no trajectory was found on the mesh: the paper's case is `infeasible` at
/// N = 4 (the smallest accepted) and solved from N = 5 on.
pub const COARSE_MESH_NODES: usize = 10;

const STATE_NAMES: [&str; NX] = [
    "x (horizontal position)",
    "z (altitude)",
    "Vx (horizontal velocity)",
    "Vz (vertical velocity)",
    "theta (pitch)",
    "w (pitch rate)",
    "omega = ln m (mass)",
    "delta (nozzle angle)",
];

/// Converged: the step (or the predicted decrease) is negligible, and the
/// candidate meets the nonlinear collocation defects — unless it still
/// needs so much virtual control that no step can fix it. `j_ref` is the
/// reference's merit.
pub(super) fn converged(c: &Candidate, j_ref: f64, settings: &SolverSettings) -> bool {
    (c.step <= settings.step_tolerance || c.predicted.abs() <= 1e-10 * (1.0 + j_ref.abs()))
        && (c.merit.defect_max <= settings.defect_tolerance
            || c.sub.virtual_control >= INFEASIBLE_VIRTUAL_CONTROL)
}

/// The outcome of a converged run whose last subproblem needed virtual
/// control `vc`, at the (accepted) `reference`.
pub(super) fn at_convergence(
    tr: &Transcription,
    reference: &Trajectory,
    vc: f64,
    settings: &SolverSettings,
) -> Outcome {
    if vc <= settings.virtual_control_tolerance {
        (Status::Solved, String::new())
    } else if vc >= INFEASIBLE_VIRTUAL_CONTROL {
        (Status::Infeasible, infeasibility_reason(tr, reference, vc))
    } else {
        (
            Status::NotConverged,
            format!(
                "the step converged but the virtual control {vc:.2e} is above the tolerance {:.1e}",
                settings.virtual_control_tolerance
            ),
        )
    }
}

/// A search that keeps needing large virtual control while its merit
/// barely moves has settled on a minimum of the constraint violation:
/// `infeasible`, if the `history` shows it. `vc` is the last candidate's
/// virtual control.
pub(super) fn at_stall(
    tr: &Transcription,
    reference: &Trajectory,
    vc: f64,
    history: &[IterationRecord],
) -> Option<Outcome> {
    stalled(history).map(|reason| {
        (
            Status::Infeasible,
            format!("{}; {reason}", infeasibility_reason(tr, reference, vc)),
        )
    })
}

/// The outcome when the trust region has shrunk below its minimum: no
/// step, however short, lowers the merit, so the reference is a stationary
/// point of it. It is a solution if it is feasible (`reference_vc` being
/// the virtual control of the subproblem that produced it).
pub(super) fn at_collapse(
    tr: &Transcription,
    reference: &Trajectory,
    reference_vc: f64,
    settings: &SolverSettings,
) -> Outcome {
    let feasible = tr.merit(reference).defect_max <= settings.defect_tolerance
        && reference_vc <= settings.virtual_control_tolerance;
    if feasible {
        (Status::Solved, String::new())
    } else {
        (
            Status::NotConverged,
            format!(
                "trust region shrank below {:.1e} without convergence; best iterate returned",
                settings.trust_region_min
            ),
        )
    }
}

/// The outcome when the iteration limit is reached first.
pub(super) fn at_iteration_limit(settings: &SolverSettings) -> Outcome {
    (
        Status::NotConverged,
        format!(
            "no convergence in {} iterations; best iterate returned",
            settings.max_iterations
        ),
    )
}

/// A `solved` outcome stays so only if the answer is physical by its
/// `checks`: a tight lossless relaxation, above the ground, the thrust
/// within its bounds and out of the nozzle. Other outcomes pass unchanged.
pub(super) fn physical(
    tr: &Transcription,
    (status, message): Outcome,
    checks: &Checks,
    settings: &SolverSettings,
) -> Outcome {
    if status != Status::Solved {
        return (status, message);
    }
    if checks.relaxation_gap > settings.relaxation_gap_tolerance {
        (
            Status::NonPhysical,
            format!(
                "lossless relaxation not tight: max(1 - |T|/sigma) = {:.3e} > {:.1e}",
                checks.relaxation_gap, settings.relaxation_gap_tolerance
            ),
        )
    } else if checks.min_altitude_margin_m < -GROUND_TOLERANCE_M {
        (
            Status::NonPhysical,
            format!(
                "the trajectory passes {:.3e} m below the landing altitude (more than the {GROUND_TOLERANCE_M} m tolerance)",
                -checks.min_altitude_margin_m
            ),
        )
    } else if checks.thrust_bound_violation_n > THRUST_TOLERANCE_FRAC * tr.model.max_thrust_n {
        (
            Status::NonPhysical,
            format!(
                "the thrust leaves [T_min, T_max] by {:.3e} N (more than {THRUST_TOLERANCE_FRAC:.0e} of T_max)",
                checks.thrust_bound_violation_n
            ),
        )
    } else if checks.thrust_backwards() {
        (
            Status::NonPhysical,
            format!(
                "thrust points backwards out of the nozzle (min cosine {:.3})",
                checks.thrust_alignment_min
            ),
        )
    } else {
        (status, message)
    }
}

/// Detect a stalled minimum-violation search: over the last [`STALL_WINDOW`]
/// iterations every candidate needed virtual control ≥ [`STALL_VIRTUAL_CONTROL`]
/// and the merit fell by less than [`STALL_DECREASE`] (relative).
fn stalled(history: &[IterationRecord]) -> Option<String> {
    if history.len() <= STALL_WINDOW {
        return None;
    }
    let window = &history[history.len() - STALL_WINDOW - 1..];
    if window
        .iter()
        .any(|h| h.virtual_control < STALL_VIRTUAL_CONTROL)
    {
        return None;
    }
    let accepted: Vec<f64> = window
        .iter()
        .filter(|h| h.accepted)
        .map(|h| h.cost)
        .collect();
    let (first, last) = (accepted.first()?, accepted.last()?);
    let decrease = (first - last) / first.abs().max(1e-12);
    (decrease < STALL_DECREASE).then(|| {
        format!(
            "over the last {STALL_WINDOW} iterations the merit fell by only {:.2}% while the virtual control stayed above {STALL_VIRTUAL_CONTROL:.0e}",
            100.0 * decrease
        )
    })
}

/// Explain why a stationary point with virtual control is infeasible.
fn infeasibility_reason(tr: &Transcription, t: &Trajectory, vc: f64) -> String {
    let d = tr.defects(t);
    let (mut worst, mut node, mut comp) = (0.0, 0, 0);
    for (i, row) in d.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            if v.abs() > worst {
                (worst, node, comp) = (v.abs(), i, c);
            }
        }
    }
    let n = tr.layout.n;
    let claim = if n < COARSE_MESH_NODES {
        format!(
            "no trajectory was found on this mesh of N = {n} collocation points, which may be too coarse: try more nodes (discretization.nodes or --nodes, e.g. 20)"
        )
    } else {
        "SCvx found no trajectory that meets the dynamics and boundary conditions".to_string()
    };
    let mut reason = format!(
        "{claim}: SCvx settled with virtual control {vc:.2e} (scaled); the largest violation is in the {} equation at t = {:.2} s",
        STATE_NAMES[comp],
        tr.mesh.time_s(node, t.tf_s)
    );
    let mf = t.x[n][ix::OMEGA].exp();
    if mf <= tr.model.dry_mass_kg * (1.0 + 1e-6) {
        reason += &format!(
            "; the propellant runs out (final mass at the dry mass {:.0} kg)",
            tr.model.dry_mass_kg
        );
    }
    let si = tr.sigma_index();
    let at_max = (0..n)
        .filter(|&i| t.u[i][si] * t.x[i][ix::OMEGA].exp() >= tr.model.max_thrust_n * (1.0 - 1e-3))
        .count();
    if at_max * 2 >= n {
        reason += &format!("; thrust is at T_max at {at_max} of {n} nodes");
    }
    reason
}
