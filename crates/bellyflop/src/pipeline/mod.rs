//! The pipeline of a solve: a certificate of infeasibility first, then the
//! method the settings name (on the scenario's mesh, or refined), then the
//! check of the answer against the nonlinear model. Statuses are claims
//! (see [`solve`]).

use crate::input::error::InputError;
use crate::input::scenario::{Case, Scenario};
use crate::input::settings::{Method, SolverSettings};
use crate::method::observer::Observer;
use crate::method::{self, Start};
use crate::polish;
use crate::problem::constraints::{self, Limit};
use crate::problem::feasibility;
use crate::refine;
use crate::solution::{Solution, Status};
use crate::verify::{accuracy, path};

pub mod evidence;
pub mod six_dof;

/// Solve a scenario with the method its settings name
/// (`solver.method`: SCvx or the direct interior-point method), with
/// statuses that are claims:
///
/// 1. a state that [`feasibility::certify`] proves infeasible is
///    `infeasible` at once, its certificate the message, without solving;
/// 2. a method that stops locally infeasible without a certificate gives
///    `not_converged`: no trajectory was found, the method's reason, and that
///    infeasibility is not proven;
/// 3. a `solved` answer is polished into controls that fly
///    ([`polish`], unless `solver.polish = false`), and then if its
///    controls (the flown ones when polished), re-integrated, land beyond
///    the scenario's tolerances ([`accuracy::check`]), or break a path
///    constraint along the flight in continuous time ([`path::check`]:
///    the ground, the thrust, gimbal and gimbal-rate bounds, the dry mass),
///    it is `inaccurate`. A polished answer that fails either gives way to
///    the raw answer, `inaccurate`, with the reason.
///
/// With operational constraints (issue 37: the cone, the tilt limit, the
/// final descent; the pitch-rate bound alone needs no second try), a
/// direct answer that is not `solved` (its polish could not hold a limit
/// along the flight from the raw answer, or the method stopped locally
/// infeasible) is tried again with SCvx, which reaches the limits by
/// another path; its answer is returned when it is `solved` (its `method`
/// says so), both times counted. On issue 15's 150 states this rescues 4
/// of the tilt limit's, 1 of the final descent's and 4 of all four's
/// (BENCHMARKS.md, "Issue 37"). A constrained state left `not_converged`
/// carries where its limits cut ([`evidence`]), its solves counted too.
/// A first answer (of the method the settings name) that found no
/// trajectory with limits is first tried against
/// [`feasibility::certify_limits`] (the approach cone's reachability
/// bound, tens of milliseconds, paid only then): when it proves that no
/// trajectory holds them, the answer is `infeasible` at once, the
/// certificate its message, without the second tries.
///
/// With `solver.refinement.tolerance` > 0 the mesh is refined until every
/// interval's relative error is within it ([`refine::solve`]), and step 3
/// checks the last pass's answer.
///
/// `solve_time_ms` is the method's own time (the certificate's alone when it
/// answers; every pass and its error estimate when refining) plus the
/// polish's; the re-integration of the landing check is not counted. The methods on their own
/// ([`method::Solver`], as the closed loop's re-plans call them) skip all
/// three steps.
///
/// # Errors
///
/// This is the planar pipeline: a 6-DoF scenario (`model = "6dof"`) is
/// refused with [`InputError::ModelUnavailable`] ([`Scenario::require_planar`]),
/// before any work, rather than solved as planar (which would drop its
/// out-of-plane fields and answer another problem). Solve it with
/// [`six_dof::solve`], from [`crate::problem::six_dof::start_state`] of
/// its initial state. A planar scenario is never refused.
pub fn solve(
    scenario: &Scenario,
    settings: &SolverSettings,
    observer: &mut dyn Observer,
) -> Result<Solution, InputError> {
    scenario.require_planar("bellyflop::pipeline::solve (the planar pipeline)")?;
    let mut sol = with_fallback(scenario, settings, observer);
    if evidence::wanted(scenario, &sol) {
        let (found, ms) = evidence::gather(scenario, settings);
        sol.message = format!(
            "no trajectory that holds the operational limits was found ({}): {}",
            evidence::describe(&found),
            sol.message
        );
        sol.solve_time_ms += ms;
        sol.limit_evidence = Some(found);
    }
    Ok(sol)
}

/// A `not_converged` answer with limits that [`feasibility::certify_limits`]
/// proves infeasible becomes `infeasible`, the certificate its message,
/// the certificate's time in its solve time. Returns whether it did.
fn certified_late(scenario: &Scenario, sol: &mut Solution) -> bool {
    let clock = std::time::Instant::now();
    let Some(certificate) = feasibility::certify_limits(scenario) else {
        sol.solve_time_ms += clock.elapsed().as_secs_f64() * 1e3;
        return false;
    };
    sol.status = Status::Infeasible;
    sol.message = format!(
        "{certificate}; the {} method found no trajectory either",
        sol.method.as_str()
    );
    sol.certificate = Some(certificate);
    sol.solve_time_ms += clock.elapsed().as_secs_f64() * 1e3;
    true
}

/// [`solve_with`], SCvx after a direct answer that is not `solved` when
/// the scenario has limits ([`with_scvx`]), and a mesh twice as fine after
/// an answer whose polish could not make it fly ([`with_finer_mesh`]).
fn with_fallback(
    scenario: &Scenario,
    settings: &SolverSettings,
    observer: &mut dyn Observer,
) -> Solution {
    let sol = with_scvx(scenario, settings, observer);
    with_finer_mesh(scenario, settings, observer, sol)
}

/// After an `inaccurate` polished answer (a collocation answer that the
/// polish could not make fly within every constraint, so the raw one,
/// which does not land), the same solve on a uniform mesh of twice the
/// nodes, once, where the scenario's mesh is uniform and twice its nodes
/// are within their range: its answer, with both solves' time, when it is
/// `solved` (its `nodes` say so), else the first answer with the second's
/// time and reason. The
/// raw answer from which the polish starts is then closer to the optimum:
/// on issue 15's 150 states with the approach cone, one of the two
/// `inaccurate` states (box80) is solved so, in 0.9 s at N = 40
/// (BENCHMARKS.md, issue 37).
fn with_finer_mesh(
    scenario: &Scenario,
    settings: &SolverSettings,
    observer: &mut dyn Observer,
    sol: Solution,
) -> Solution {
    let wanted =
        sol.status == Status::Inaccurate && settings.polish && settings.refinement.tolerance == 0.0;
    let Some(finer) = wanted.then(|| finer_mesh(scenario)).flatten() else {
        return sol;
    };
    let nodes = finer.discretization.nodes;
    // A solved answer's message is empty; its `nodes` name the mesh.
    second_try(sol, solve_with(&finer, settings, observer), |reason| {
        format!("on a uniform mesh of {nodes} nodes, not solved either: {reason}")
    })
}

/// The second try `other` of an answer `first` that is not `solved`:
/// `other` when it is solved, else `first` with the reason `why(other's
/// message)` added; either way with the time of both solves.
fn second_try(first: Solution, mut other: Solution, why: impl FnOnce(&str) -> String) -> Solution {
    other.solve_time_ms += first.solve_time_ms;
    if other.status == Status::Solved {
        return other;
    }
    let mut sol = first;
    sol.solve_time_ms = other.solve_time_ms;
    sol.message = format!("{}; {}", sol.message, why(&other.message));
    sol
}

/// The scenario on a uniform mesh of twice its nodes, where its own mesh is
/// uniform and the doubled one valid (at most 100 nodes on the global mesh,
/// 200 over several intervals).
fn finer_mesh(scenario: &Scenario) -> Option<Scenario> {
    if scenario.discretization.mesh.is_some() {
        return None;
    }
    let mut finer = scenario.clone();
    finer.discretization.nodes *= 2;
    finer.validate().ok().map(|()| finer)
}

/// [`solve_with`], and SCvx after a direct answer that is not `solved`
/// when the scenario has limits ([`scvx_may_rescue`]), unless the first
/// answer found no trajectory and [`certified_late`] proves that none
/// exists.
fn with_scvx(
    scenario: &Scenario,
    settings: &SolverSettings,
    observer: &mut dyn Observer,
) -> Solution {
    let mut sol = solve_with(scenario, settings, observer);
    // A proof ends the search before the second tries, which take seconds.
    if evidence::wanted(scenario, &sol) && certified_late(scenario, &mut sol) {
        return sol;
    }
    if sol.status == Status::Solved || !scvx_may_rescue(scenario, settings) {
        return sol;
    }
    // From the direct answer the polish may not reach a limit (it creeps
    // on boundary arcs), or the direct method stopped locally infeasible:
    // SCvx's answer, polished, when that one is solved.
    let scvx = SolverSettings {
        method: Method::Scvx,
        ..settings.clone()
    };
    // A solved answer's `method` says which answered.
    second_try(sol, solve_with(scenario, &scvx, observer), |reason| {
        format!(
            "SCvx, which holds every limit at its nodes, did not give a solved answer either: {reason}"
        )
    })
}

/// Whether the scenario has operational rows other than the pitch-rate
/// bound (which the direct method held on all 150 states measured), and
/// the settings name the direct method, polished, on the scenario's own
/// mesh: then SCvx is the second try.
fn scvx_may_rescue(scenario: &Scenario, settings: &SolverSettings) -> bool {
    settings.method == Method::Direct
        && settings.polish
        && settings.refinement.tolerance == 0.0
        && constraints::rows(scenario)
            .iter()
            .any(|r| r.limit != Limit::PitchRate)
}

/// [`solve`] with the one method that the settings name.
fn solve_with(
    scenario: &Scenario,
    settings: &SolverSettings,
    observer: &mut dyn Observer,
) -> Solution {
    let start = std::time::Instant::now();
    let refining = settings.refinement.tolerance > 0.0;
    let mut sol = match feasibility::certify(scenario) {
        Some(certificate) => {
            let ms = start.elapsed().as_secs_f64() * 1e3;
            let mut sol = method::guess_answer(
                scenario,
                settings,
                Status::Infeasible,
                certificate.to_string(),
                ms,
            );
            sol.certificate = Some(certificate);
            if refining {
                refine::not_started(sol, settings.refinement.tolerance, start)
            } else {
                sol
            }
        }
        None => {
            let mut solver = method::solver(settings.method);
            let mut sol = if refining {
                refine::solve(&mut *solver, scenario, settings, observer)
            } else {
                solver.solve(scenario, settings, Start::StraightLine, observer)
            };
            not_proven(scenario, &mut sol);
            sol
        }
    };
    let raw = (sol.status == Status::Solved && settings.polish).then(|| {
        let raw = sol.clone();
        polish_answer(scenario, settings, &mut sol);
        raw
    });
    check(scenario, settings, &mut sol);
    match raw {
        Some(raw) if sol.controls_flown.is_some() && sol.status != Status::Solved => {
            fall_back(scenario, settings, raw, sol)
        }
        _ => sol,
    }
}

/// Step 3's second half: the landing and the path along the flight.
fn check(scenario: &Scenario, settings: &SolverSettings, sol: &mut Solution) {
    if sol.status == Status::Solved {
        accuracy::check(scenario, settings, sol);
    }
    path::check(scenario, sol);
}

/// A polished answer that fails its checks gives way to the raw answer,
/// judged by the same checks (`inaccurate` unless it passes them all),
/// with the polished answer's failure in its message and the polish's
/// time in its solve time.
fn fall_back(
    scenario: &Scenario,
    settings: &SolverSettings,
    mut raw: Solution,
    polished: Solution,
) -> Solution {
    raw.solve_time_ms = polished.solve_time_ms;
    check(scenario, settings, &mut raw);
    let own = if raw.status == Status::Solved {
        String::new()
    } else {
        format!("; the raw answer itself: {}", raw.message)
    };
    raw.message = format!(
        "the polished answer failed its checks, so this is the raw collocation answer (solver.polish could not make it fly within every constraint): {}{own}",
        polished.message
    );
    raw
}

/// Step 3's first half: the polish of a solved answer ([`polish`]); its
/// time joins `solve_time_ms`. When it fails, the raw collocation answer
/// stays, the landing check judges it as it is, and the polish's failure
/// joins the message (the check names the miss if it demotes the answer).
fn polish_answer(scenario: &Scenario, settings: &SolverSettings, sol: &mut Solution) {
    let clock = std::time::Instant::now();
    let options = polish::Options {
        max_repairs: settings.polish_repairs,
        hessian: settings.polish_hessian,
    };
    let outcome = polish::polish(scenario, sol, options)
        .map_err(|e| e.to_string())
        .and_then(|p| {
            let ms = p.report.time_ms;
            polish::publish::publish(scenario, sol, p)
                .map(|()| ms)
                .map_err(|e| format!("its controls could not be integrated ({e})"))
        });
    match outcome {
        Ok(ms) => sol.solve_time_ms += ms,
        Err(e) => {
            // A failed polish took its time too.
            sol.solve_time_ms += clock.elapsed().as_secs_f64() * 1e3;
            sol.message = format!("the polish failed, so this is the raw collocation answer: {e}")
        }
    }
}

impl Case {
    /// Solve with [`solve`] (the pipeline adds this to the input type, which
    /// does not depend on the pipeline).
    ///
    /// # Errors
    ///
    /// [`InputError::ModelUnavailable`] for a 6-DoF case, as [`solve`].
    pub fn solve(&self, observer: &mut dyn Observer) -> Result<Solution, InputError> {
        solve(&self.scenario, &self.solver, observer)
    }
}

/// Step 2 of [`solve`]: a method's local infeasibility, without a
/// certificate, is `not_converged`, with the method's reason. The closed
/// loop's planner, which checks the certificate after its solve, calls it
/// too.
pub fn not_proven(scenario: &Scenario, sol: &mut Solution) {
    if sol.status == Status::Infeasible {
        sol.status = Status::NotConverged;
        sol.message = format!(
            "no trajectory was found, but infeasibility is not proven ({}); try another discretization.tf_guess_s, the other method (solver.method or --method) or more nodes. The {} method stopped locally infeasible: {}",
            feasibility::not_proven(scenario),
            sol.method.as_str(),
            sol.message
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::method::observer::Silent;

    /// A second try replaces the answer only when it is `solved`; either
    /// way the answer carries both solves' time, and a failed second try
    /// adds its reason to the first answer's.
    #[test]
    fn a_second_try_replaces_the_answer_only_when_solved() {
        let scenario = Scenario::paper();
        let settings = SolverSettings {
            polish: false,
            ..SolverSettings::default()
        };
        let raw = solve_with(&scenario, &settings, &mut Silent);
        let mut first = raw.clone();
        first.status = Status::Inaccurate;
        first.message = "first reason".into();
        first.solve_time_ms = 2.0;
        let mut other = raw.clone();
        other.solve_time_ms = 3.0;
        other.status = Status::Solved;
        other.message.clear();
        let why = |reason: &str| format!("the second: {reason}");
        let kept = second_try(first.clone(), other.clone(), why);
        assert_eq!(kept.status, Status::Solved);
        assert_eq!((kept.message.as_str(), kept.solve_time_ms), ("", 5.0));
        other.status = Status::NotConverged;
        other.message = "second reason".into();
        let kept = second_try(first, other, why);
        assert_eq!(kept.status, Status::Inaccurate);
        assert_eq!(kept.message, "first reason; the second: second reason");
        assert_eq!(kept.solve_time_ms, 5.0);
    }
}
