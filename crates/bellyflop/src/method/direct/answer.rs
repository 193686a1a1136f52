//! A solve in storage and its answer: the interior-point run from a start,
//! written into a [`Solution`] in its own storage, with the checks of the
//! answer against the nonlinear problem.

use std::time::Instant;

use crate::input::settings::{Method, SolverSettings};
use crate::method::direct::driver::{Driver, Start, Storage};
use crate::method::direct::iterate::inf_norm;
use crate::method::direct::nlp::Nlp;
use crate::method::observer::Observer;
use crate::solution::{History, Solution, SolveOutcome, Status};

/// Checks of a P2 answer against the nonlinear problem: its own defects,
/// the thrust bounds at every reported value and the ground. The thrust is
/// along the nozzle by construction (gap 0, alignment 1).
pub fn checks(nlp: &Nlp, w: &[f64]) -> crate::solution::Checks {
    checks_with(nlp, w, &mut vec![0.0; nlp.n_con()])
}

/// [`checks`] with the defects computed into `c` (the NLP's size).
fn checks_with(nlp: &Nlp, w: &[f64], c: &mut [f64]) -> crate::solution::Checks {
    use crate::method::direct::nlp::slot;
    nlp.defects(w, c);
    let m = &nlp.model;
    let mut bound = 0.0f64;
    for i in 0..nlp.n {
        let t = nlp.thrust_n(w, i);
        bound = bound.max(m.min_thrust_n - t).max(t - m.max_thrust_n);
    }
    let z_f = nlp.target.z_m;
    let min_altitude_margin_m = (0..=nlp.n)
        .map(|k| nlp.physical(slot::Z, w[nlp.idx(k, slot::Z)]) - z_f)
        .fold(f64::INFINITY, f64::min);
    crate::solution::Checks {
        relaxation_gap: 0.0,
        thrust_alignment_min: 1.0,
        thrust_bound_violation_n: bound,
        max_defect: inf_norm(c),
        virtual_control: 0.0,
        min_altitude_margin_m,
    }
}

/// [`super::solve_from_start`] in `storage` (made for `nlp`), the answer written
/// into `out` in its own vectors' storage; the storage comes back, its
/// iterate the last one, for the next solve of the same structure. With
/// storage and an answer of the right sizes, a solve that converges
/// allocates nothing (a re-plan in a flight loop, issue 27).
pub(super) fn solve_into(
    settings: &SolverSettings,
    nlp: &Nlp,
    start_point: Start,
    observer: &mut dyn Observer,
    storage: Storage,
    out: &mut Solution,
) -> Storage {
    out.history.scvx.clear();
    out.history.direct.clear();
    solve_appending(settings, nlp, start_point, observer, storage, out)
}

/// [`solve_into`] with the iterations appended to `out`'s history (a
/// later phase of a cold solve), which the answer's iteration count then
/// counts in all.
pub(super) fn solve_appending(
    settings: &SolverSettings,
    nlp: &Nlp,
    start_point: Start,
    observer: &mut dyn Observer,
    storage: Storage,
    out: &mut Solution,
) -> Storage {
    let start = Instant::now();
    let driver = Driver::with_storage(nlp, &settings.direct, storage);
    let (end, mut storage) = driver.run_in(start_point, observer, &mut out.history.direct);
    let ms = start.elapsed().as_secs_f64() * 1e3;
    let (w, c) = storage.point_and_defects();
    let checks = checks_with(nlp, w, c);
    let (mut status, mut message) = (end.status, end.message);
    if status == Status::Solved
        && checks.min_altitude_margin_m < -crate::solution::GROUND_TOLERANCE_M
    {
        status = Status::NonPhysical;
        message = format!(
            "the trajectory passes {:.3} m below the landing altitude",
            -checks.min_altitude_margin_m
        );
    }
    let outcome = SolveOutcome {
        method: Method::Direct,
        status,
        message,
        checks,
        history: History::default(),
        solve_time_ms: ms,
    };
    nlp.to_trajectory_into(storage.w(), &mut out.trajectory);
    out.refill(&nlp.mesh, &nlp.model, crate::Formulation::Exact, outcome);
    storage
}
