//! hp mesh refinement to a tolerance (issue 16), after Patterson, Hager &
//! Rao, "A ph mesh refinement method for optimal control", OCAM 2015, with
//! interval breaks at the detected control switches (Agamawi, Hager & Rao
//! 2019).
//!
//! Each pass solves on a mesh, estimates the relative error e_k of every
//! interval ([`crate::verify::mesh_error`]) and stops when max_k e_k ≤ ε. Otherwise
//! the next mesh is built in two steps:
//!
//! 1. **p or h, per interval.** An interval with e_k > ε and n_k points
//!    needs about P_k = ⌈log(e_k/ε) / log n_k⌉ more (the ph rule, §4.1:
//!    the error of an LGR interval falls like n_k^(−p)). If n_k + P_k ≤
//!    `max_points` the degree is raised; otherwise the interval is split
//!    into B = max(2, ⌈(n_k + P_k)/n_min⌉) equal intervals of n_min points.
//!    Within `max_total_points`, the worst intervals are served first; the
//!    others keep their points for this pass.
//! 2. **Breaks at the events** ([`events`]). The thrust T and the gimbal
//!    rate χ are bang-bang on most of a landing, and δ rides its limit on
//!    some: a polynomial across a switch, or across the entry or exit of an
//!    arc on a bound, rings or converges slowly however high its degree. A
//!    switch between the bounds is placed by the impulse of the collocation
//!    point between the two bang arcs; where a signal reaches or leaves a
//!    bound, midway between the two points. In an interval still above the
//!    tolerance, an event next to a break that the previous pass put at an
//!    event of its kind moves that break onto it (the same switch, located
//!    better on the finer mesh); any other splits its interval there (an
//!    arc's end never into an interval narrower than [`MIN_ARC_WIDTH`]). A
//!    switch on a break is where it belongs.
//!
//! Refinement stops at the tolerance, at `max_passes`, or when the point
//! budget leaves no room for a finer mesh ([`Stop`]).
//!
//! Each pass starts from the last one's answer ([`Start::Answer`]): the
//! direct method carries it onto the new mesh by its state and control
//! polynomials and its multipliers by their densities over the quadrature
//! weights, at μ_0 = [`crate::method::direct::solver::WARM_PD_MU`]; SCvx
//! solves each pass cold.

use crate::collocation::control_profile::{activity, Activity};
use crate::collocation::mesh::Mesh;
use crate::input::mesh_layout::MeshLayout;
use crate::input::scenario::Scenario;
use crate::input::settings::{RefinementSettings, SolverSettings};
use crate::method::observer::Observer;
use crate::method::{Solver, Start};
use crate::problem::dynamics::Model;
use crate::solution::{Pass, Refinement, Stop};
use crate::solution::{Solution, Status};
use crate::verify::mesh_error;

/// Solve `scenario` and refine its mesh until every interval's relative
/// error is at most `settings.refinement.tolerance` (which must be > 0).
/// Returns the last accepted pass's answer, with its [`Refinement`] record;
/// its iterations and time count every pass and estimate. Each pass is
/// `solver`'s, the first from the straight line and every later one from
/// the last answer. Like a method alone, it neither certifies nor
/// re-integrates the landing (the caller, [`crate::solve`], does).
pub fn solve(
    solver: &mut dyn Solver,
    scenario: &Scenario,
    settings: &SolverSettings,
    observer: &mut dyn Observer,
) -> Solution {
    let start = std::time::Instant::now();
    let rs = &settings.refinement;
    let model = Model::new(&scenario.vehicle, &scenario.environment);
    let mut current = scenario.clone();
    let mut sol = solver.solve(&current, settings, Start::StraightLine, observer);
    let mut passes = Vec::new();
    let mut iterations = 0;
    let mut event_breaks: Vec<Event> = Vec::new();
    let stop = loop {
        iterations += sol.iterations;
        if sol.status != Status::Solved {
            break Stop::SolveFailed;
        }
        let mesh = sol.mesh();
        let errors = match mesh_error::estimate(&current, &sol) {
            Ok(e) => e,
            Err(_) => break Stop::EstimateFailed,
        };
        let events = events(&sol, &mesh, &model);
        let max_error = errors.iter().map(|e| e.relative_error).fold(0.0, f64::max);
        passes.push(Pass {
            pass: passes.len() + 1,
            mesh: sol.mesh.clone(),
            nodes: sol.nodes,
            status: sol.status,
            iterations: sol.iterations,
            solve_time_ms: sol.solve_time_ms,
            final_mass_kg: sol.final_mass_kg,
            events_s: events
                .iter()
                .map(|e| 0.5 * (e.tau + 1.0) * sol.tf_s)
                .collect(),
            intervals: errors.clone(),
            max_relative_error: max_error,
        });
        observer.pass(passes.last().expect("just pushed"));
        if max_error <= rs.tolerance {
            break Stop::ToleranceMet;
        }
        if passes.len() >= rs.max_passes {
            break Stop::PassLimit;
        }
        let errs: Vec<f64> = errors.iter().map(|e| e.relative_error).collect();
        let (next, placed) = next_layout(&mesh, &errs, &events, &event_breaks, rs);
        if next.nodes() > rs.max_total_points || next == sol.mesh {
            break Stop::PointLimit;
        }
        let mut refined = scenario.clone();
        refined.discretization.nodes = next.nodes();
        refined.discretization.intervals = next.intervals();
        refined.discretization.mesh = Some(next);
        let answer = solver.solve(&refined, settings, Start::Answer(&sol), observer);
        if answer.status != Status::Solved {
            iterations += answer.iterations;
            break Stop::SolveFailed;
        }
        current = refined;
        sol = answer;
        event_breaks = placed;
    };
    sol.iterations = iterations;
    sol.refinement = Some(Refinement {
        tolerance: rs.tolerance,
        stop,
        passes,
        total_time_ms: start.elapsed().as_secs_f64() * 1e3,
    });
    sol.solve_time_ms = start.elapsed().as_secs_f64() * 1e3;
    sol
}

/// The record of a refinement that never solved a pass (its scenario was
/// certified infeasible before any method ran): no passes, stopped as
/// [`Stop::SolveFailed`], with `sol`'s iterations.
pub fn not_started(mut sol: Solution, tolerance: f64, start: std::time::Instant) -> Solution {
    sol.refinement = Some(Refinement {
        tolerance,
        stop: Stop::SolveFailed,
        passes: Vec::new(),
        total_time_ms: start.elapsed().as_secs_f64() * 1e3,
    });
    sol.solve_time_ms = start.elapsed().as_secs_f64() * 1e3;
    sol
}

/// A place where the mesh wants a break: a switch of T or χ between its
/// bounds, or the entry or exit of an arc on a bound.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Event {
    pub tau: f64,
    /// For a switch: the signal (0: T, 1: χ) and whether it is on its upper
    /// bound after the switch.
    pub switch: Option<(usize, bool)>,
}

/// The narrowest interval, in τ, that a break at the end of an arc may
/// leave (1 % of the trajectory): such a break is placed only to half a
/// point spacing, and on the dispersed states the ends of arcs of T, χ and
/// δ near one another otherwise split a few points into ever smaller
/// intervals that took the point budget from the worst ones.
pub const MIN_ARC_WIDTH: f64 = 0.02;

/// The events of a solution, in τ:
///
/// - **switches** of T or χ between its bounds: a run of points on one
///   bound, at most one point off the bounds, then a run on the other. The
///   discrete answer places a switch inside the quadrature cell of that
///   point off the bounds, by its value: over the cell (interval k's cells
///   partition it in order, cell i of width w_i, the point's quadrature
///   weight) the impulse of the value equals that of the first bound for a
///   fraction (v − post)/(pre − post) of the cell and the second after it,
///   so the switch is at cell_lo + w_i·(v − post)/(pre − post); with no
///   point between the runs, at the boundary of their cells. A switch on a
///   break (within 1e-9 in τ) is where it belongs;
/// - the **ends of arcs**: elsewhere, where T, χ or δ changes between a
///   bound and the interior from one point to the next inside an interval,
///   placed midway.
pub fn events(sol: &Solution, mesh: &Mesh, model: &Model) -> Vec<Event> {
    let signals: [(&[f64], f64, f64); 3] = [
        (&sol.thrust_n, model.min_thrust_n, model.max_thrust_n),
        (
            &sol.gimbal_rate_radps,
            -model.max_gimbal_rate_radps,
            model.max_gimbal_rate_radps,
        ),
        (&sol.delta_rad, -model.max_gimbal_rad, model.max_gimbal_rad),
    ];
    let n = mesh.n;
    let mut starts = vec![false; n + 1];
    let mut cell_lo = vec![0.0; n];
    for iv in &mesh.intervals {
        starts[iv.start] = true;
        let mut at = iv.tau_lo;
        let cells = iv.start..iv.start + iv.points;
        for (lo, w) in cell_lo[cells.clone()].iter_mut().zip(&mesh.weights[cells]) {
            *lo = at;
            at += w;
        }
    }
    starts[n] = true;
    let on_break = |tau: f64| {
        mesh.intervals
            .iter()
            .any(|iv| (iv.tau_lo - tau).abs() < 1e-9)
    };
    let mut out: Vec<Event> = Vec::new();
    // Pairs (i, i + 1) that a switch explains.
    let mut covered = vec![false; n];
    for (c, &(v, lo, hi)) in signals.iter().take(2).enumerate() {
        let act: Vec<Activity> = (0..n).map(|i| activity(v[i], lo, hi)).collect();
        for i in 0..n.saturating_sub(1) {
            let pre = act[i];
            if pre == Activity::Interior {
                continue;
            }
            let post = if pre == Activity::Lower {
                Activity::Upper
            } else {
                Activity::Lower
            };
            let (pre_v, post_v) = if pre == Activity::Lower {
                (lo, hi)
            } else {
                (hi, lo)
            };
            let tau = if act[i + 1] == post {
                cell_lo[i] + mesh.weights[i]
            } else if act[i + 1] == Activity::Interior && i + 2 < n && act[i + 2] == post {
                let m = i + 1;
                cell_lo[m] + mesh.weights[m] * (v[m] - post_v) / (pre_v - post_v)
            } else {
                continue;
            };
            let j = if act[i + 1] == post { i + 1 } else { i + 2 };
            // The pairs of the switch, and one on either side: δ touching
            // its limit where χ switches is the same event.
            covered[i.saturating_sub(1)..(j + 1).min(n)]
                .iter_mut()
                .for_each(|x| *x = true);
            if !on_break(tau) {
                out.push(Event {
                    tau,
                    switch: Some((c, post == Activity::Upper)),
                });
            }
        }
    }
    for i in 0..n.saturating_sub(1) {
        if covered[i] || starts[i + 1] {
            continue;
        }
        let changes = signals
            .iter()
            .any(|&(v, lo, hi)| activity(v[i], lo, hi) != activity(v[i + 1], lo, hi));
        if changes {
            out.push(Event {
                tau: 0.5 * (mesh.nodes[i] + mesh.nodes[i + 1]),
                switch: None,
            });
        }
    }
    out.sort_by(|a, b| a.tau.total_cmp(&b.tau));
    out
}

/// The next mesh: the ph rule on each interval, then breaks at the events.
///
/// `event_breaks` are the breaks that the previous pass put at events: an
/// event in an interval next to one of them moves it (the event is the same
/// switch, located better on a finer mesh); any other event splits its
/// interval. Returns the layout and its event breaks.
pub fn next_layout(
    mesh: &Mesh,
    errors: &[f64],
    events: &[Event],
    event_breaks: &[Event],
    rs: &RefinementSettings,
) -> (MeshLayout, Vec<Event>) {
    let pass = NextMesh {
        mesh,
        errors,
        event_breaks,
        rs,
    };
    let claimed: Vec<bool> = (0..mesh.intervals.len())
        .map(|k| events.iter().any(|ev| pass.claims(k, ev)))
        .collect();
    let wish = pass.ph_wish(&claimed);
    let grant = pass.grant(&wish, events);
    let mut segs = pass.segments(&wish, &grant);
    let placed = pass.place_events(events, &mut segs);
    let mut breaks_tau: Vec<f64> = segs.iter().map(|s| s.0).collect();
    breaks_tau.push(1.0);
    breaks_tau[0] = -1.0;
    (
        MeshLayout {
            breaks_tau,
            points: segs.iter().map(|s| s.2).collect(),
        },
        placed,
    )
}

/// Whether two events are of one kind: the same signal's switch, or both
/// an arc's end.
fn same_kind(a: &Event, b: &Event) -> bool {
    a.switch.map(|s| s.0) == b.switch.map(|s| s.0)
}

/// (τ_lo, τ_hi, points) of an interval of the new mesh.
type Segment = (f64, f64, usize);

/// What [`next_layout`] builds the next mesh from: the mesh, its intervals'
/// errors, the previous pass's event breaks and the settings.
struct NextMesh<'a> {
    mesh: &'a Mesh,
    errors: &'a [f64],
    event_breaks: &'a [Event],
    rs: &'a RefinementSettings,
}

impl NextMesh<'_> {
    /// Whether step 2 will place the event `ev` inside interval k (split
    /// there, or move an event break at its end onto it): a switch always;
    /// an arc's end if it leaves no interval narrower than MIN_ARC_WIDTH,
    /// or if an event break of its kind ends the interval.
    fn claims(&self, k: usize, ev: &Event) -> bool {
        let iv = &self.mesh.intervals[k];
        let inside = ev.tau > iv.tau_lo && ev.tau < iv.tau_hi;
        let at_end = |b: f64| {
            self.event_breaks
                .iter()
                .any(|e| same_kind(e, ev) && (e.tau - b).abs() < 1e-12)
        };
        inside
            && self.errors[k] > self.rs.tolerance
            && (ev.switch.is_some()
                || (ev.tau - iv.tau_lo).min(iv.tau_hi - ev.tau) >= MIN_ARC_WIDTH
                || at_end(iv.tau_lo)
                || at_end(iv.tau_hi))
    }

    /// The ph rule's wish per interval: its new point count (a split past
    /// `max_points`).
    fn ph_wish(&self, claimed: &[bool]) -> Vec<usize> {
        let rs = self.rs;
        self.mesh
            .intervals
            .iter()
            .zip(self.errors)
            .enumerate()
            .map(|(k, (iv, &e))| {
                let n = iv.points;
                // An interval with an event placed inside is split there
                // (step 2), not raised or split evenly: its error is the
                // event's. One whose events are too near its ends to place
                // follows the ph rule (it stalled otherwise, its error
                // never falling).
                if e <= rs.tolerance || claimed[k] {
                    return n;
                }
                let raise = ((e / rs.tolerance).ln() / (n.max(2) as f64).ln())
                    .ceil()
                    .max(1.0) as usize;
                n + raise
            })
            .collect()
    }

    /// Which intervals get their wish: within the point budget (less what
    /// the events' splits may take), the worst intervals first; the others
    /// keep their points this pass.
    fn grant(&self, wish: &[usize], events: &[Event]) -> Vec<bool> {
        let (mesh, errors, rs) = (self.mesh, self.errors, self.rs);
        let cost = |k: usize| {
            let (n, want) = (mesh.intervals[k].points, wish[k]);
            let after = if want <= rs.max_points {
                want
            } else {
                want.div_ceil(rs.min_points).max(2) * rs.min_points
            };
            after.saturating_sub(n)
        };
        let reserve = (0..mesh.intervals.len())
            .map(|k| events.iter().filter(|ev| self.claims(k, ev)).count())
            .sum::<usize>()
            * rs.min_points;
        let mut budget = rs.max_total_points.saturating_sub(mesh.n + reserve);
        let mut order: Vec<usize> = (0..wish.len()).collect();
        order.sort_by(|&a, &b| errors[b].total_cmp(&errors[a]));
        let mut grant = vec![false; wish.len()];
        for k in order {
            if errors[k] > rs.tolerance && cost(k) <= budget {
                budget -= cost(k);
                grant[k] = true;
            }
        }
        grant
    }

    /// The intervals after step 1: a granted interval with its wish, raised
    /// or split evenly into intervals of `min_points`; the others as they
    /// are.
    fn segments(&self, wish: &[usize], grant: &[bool]) -> Vec<Segment> {
        let rs = self.rs;
        let mut segs: Vec<Segment> = Vec::new();
        for (k, iv) in self.mesh.intervals.iter().enumerate() {
            let n = iv.points;
            if !grant[k] {
                segs.push((iv.tau_lo, iv.tau_hi, n));
                continue;
            }
            let want = wish[k];
            if want <= rs.max_points {
                segs.push((iv.tau_lo, iv.tau_hi, want));
            } else {
                let b = want.div_ceil(rs.min_points).max(2);
                let h = (iv.tau_hi - iv.tau_lo) / b as f64;
                for j in 0..b {
                    let hi = if j + 1 == b {
                        iv.tau_hi
                    } else {
                        iv.tau_lo + h * (j + 1) as f64
                    };
                    segs.push((iv.tau_lo + h * j as f64, hi, rs.min_points));
                }
            }
        }
        segs
    }

    /// Step 2, the breaks at the events: each event in an interval still
    /// above the tolerance moves an event break of its kind at an end of
    /// its new interval onto it, or splits that interval there. Returns the
    /// event breaks of the new mesh (those placed, then those that no event
    /// claimed, where they are).
    fn place_events(&self, events: &[Event], segs: &mut Vec<Segment>) -> Vec<Event> {
        let (event_breaks, rs) = (self.event_breaks, self.rs);
        let mut moved = vec![false; event_breaks.len()];
        let mut placed = Vec::new();
        for &event in events {
            let tau = event.tau;
            // Only where the old mesh is not yet accurate; and an arc's
            // end, placed only to half a point spacing, never makes an
            // interval narrower than MIN_ARC_WIDTH (a switch, placed by its
            // impulse, may).
            let old = self.mesh.interval_of(tau);
            if self.errors[old] <= rs.tolerance {
                continue;
            }
            let Some(j) = segs.iter().position(|s| tau > s.0 && tau < s.1) else {
                continue;
            };
            let (lo, hi, n) = segs[j];
            // An event break of the same kind (the same signal's switch, or
            // an arc's end) at this interval's either end, not yet moved.
            let near = |b: f64| {
                event_breaks
                    .iter()
                    .enumerate()
                    .find(|&(k, e)| !moved[k] && same_kind(e, &event) && (e.tau - b).abs() < 1e-12)
                    .map(|(k, _)| k)
            };
            if let Some(k) = (j > 0).then(|| near(lo)).flatten() {
                moved[k] = true;
                segs[j - 1].1 = tau;
                segs[j].0 = tau;
            } else if let Some(k) = (j + 1 < segs.len()).then(|| near(hi)).flatten() {
                moved[k] = true;
                segs[j].1 = tau;
                segs[j + 1].0 = tau;
            } else {
                let width = hi - lo;
                if event.switch.is_none() && (tau - lo).min(hi - tau) < MIN_ARC_WIDTH {
                    continue;
                }
                let left = ((n as f64 * (tau - lo) / width).round() as usize).max(rs.min_points);
                let right = ((n as f64 * (hi - tau) / width).round() as usize).max(rs.min_points);
                segs.splice(j..=j, [(lo, tau, left), (tau, hi, right)]);
            }
            placed.push(event);
        }
        // Event breaks that no event claimed stay where they are.
        placed.extend(
            event_breaks
                .iter()
                .zip(&moved)
                .filter(|&(_, &m)| !m)
                .map(|(&b, _)| b),
        );
        placed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(tolerance: f64) -> RefinementSettings {
        RefinementSettings {
            tolerance,
            ..RefinementSettings::default()
        }
    }

    /// The ph rule: an interval within the tolerance is kept, one a little
    /// above it gains ⌈log(e/ε)/log n⌉ points, and one far above it, past
    /// `max_points`, is split into ⌈(n + P)/n_min⌉ intervals of n_min.
    #[test]
    fn ph_rule_raises_the_degree_or_splits() {
        let mesh = Mesh::new(&[-1.0, -0.5, 0.0, 1.0], &[5, 5, 8]);
        let rs = settings(1e-6);
        // 5 points at e = 1e-4: P = ⌈ln 100 / ln 5⌉ = 3 → 8 points.
        // 8 points at e = 1e-1: P = ⌈ln 1e5 / ln 8⌉ = 6 → 14 > 10: split
        // into ⌈14/4⌉ = 4 intervals of 4 points.
        let (next, _) = next_layout(&mesh, &[1e-7, 1e-4, 1e-1], &[], &[], &rs);
        assert_eq!(next.points, vec![5, 8, 4, 4, 4, 4]);
        let want = [-1.0, -0.5, 0.0, 0.25, 0.5, 0.75, 1.0];
        assert_eq!(next.breaks_tau.len(), want.len());
        for (b, w) in next.breaks_tau.iter().zip(want) {
            assert!((b - w).abs() < 1e-15, "{:?}", next.breaks_tau);
        }
    }

    fn switch(tau: f64) -> Event {
        Event {
            tau,
            switch: Some((0, true)),
        }
    }

    /// An event splits its interval, the points shared in proportion; an
    /// event next to a break placed at an event of its kind moves that
    /// break onto it; ordinary breaks, and breaks of another kind, stay; an
    /// interval already within the tolerance is left alone.
    #[test]
    fn events_split_intervals_or_move_their_breaks() {
        let mesh = Mesh::new(&[-1.0, 0.0, 1.0], &[8, 8]);
        let rs = settings(1e-6);
        // 2e-6 on 8 points: the ph rule adds ⌈ln 2 / ln 8⌉ = 1 point, but
        // not to an interval with an event, which is split there instead.
        let e = [2e-6, 2e-6];
        let (next, placed) = next_layout(&mesh, &e, &[switch(-0.5)], &[], &rs);
        assert_eq!(next.breaks_tau, vec![-1.0, -0.5, 0.0, 1.0]);
        assert_eq!(next.points, vec![4, 4, 9]);
        assert_eq!(placed, vec![switch(-0.5)]);
        // τ = 0 is a switch break of the previous pass: it moves.
        let (next, placed) = next_layout(&mesh, &e, &[switch(0.6)], &[switch(0.0)], &rs);
        assert_eq!(next.breaks_tau, vec![-1.0, 0.6, 1.0]);
        assert_eq!(next.points, vec![9, 8]);
        assert_eq!(placed, vec![switch(0.6)]);
        // An ordinary break stays; so does a break of another kind, and an
        // event break that no event claims.
        let (next, _) = next_layout(&mesh, &e, &[switch(0.6)], &[], &rs);
        assert_eq!(next.breaks_tau, vec![-1.0, 0.0, 0.6, 1.0]);
        assert_eq!(next.points, vec![9, 5, 4]);
        let arc = Event {
            tau: 0.0,
            switch: None,
        };
        let (next, placed) = next_layout(&mesh, &e, &[switch(0.6)], &[arc], &rs);
        assert_eq!(next.breaks_tau, vec![-1.0, 0.0, 0.6, 1.0]);
        assert_eq!(placed, vec![switch(0.6), arc]);
        // Within the tolerance on the left: the event there is ignored.
        let (next, placed) = next_layout(&mesh, &[0.0, 2e-6], &[switch(-0.5)], &[], &rs);
        assert_eq!(next.breaks_tau, vec![-1.0, 0.0, 1.0]);
        assert_eq!(next.points, vec![8, 9]);
        assert!(placed.is_empty());
    }

    /// An arc's end too near its interval's break to be placed (closer than
    /// MIN_ARC_WIDTH) leaves the interval to the ph rule: it gains points
    /// (it kept its points and its error, pass after pass, before), and the
    /// point budget is not reserved for it.
    #[test]
    fn an_event_too_near_a_break_leaves_its_interval_to_the_ph_rule() {
        let mesh = Mesh::new(&[-1.0, 0.0, 1.0], &[5, 5]);
        let rs = settings(1e-6);
        let arc_end = Event {
            tau: 0.01,
            switch: None,
        };
        let (next, placed) = next_layout(&mesh, &[1e-7, 1e-4], &[arc_end], &[], &rs);
        // 5 points at 1e-4: ⌈ln 100 / ln 5⌉ = 3 more.
        assert_eq!(next.points, vec![5, 8]);
        assert_eq!(next.breaks_tau, vec![-1.0, 0.0, 1.0]);
        assert!(placed.is_empty(), "{placed:?}");
        // The same event far enough from the break splits the interval.
        let inside = Event {
            tau: 0.5,
            switch: None,
        };
        let (next, _) = next_layout(&mesh, &[1e-7, 1e-4], &[inside], &[], &rs);
        assert_eq!(next.breaks_tau, vec![-1.0, 0.0, 0.5, 1.0]);
    }

    /// A switch inside a quadrature cell is placed by the impulse of the
    /// value there: T_min on points 0–1, a value a quarter of the way up on
    /// point 2, T_max after: the switch is 3/4 into point 2's cell.
    #[test]
    fn a_switch_is_placed_by_the_impulse_of_the_point_between() {
        let s = crate::Scenario::paper();
        let model = Model::new(&s.vehicle, &s.environment);
        let mesh = Mesh::global(6);
        let (lo, hi) = (model.min_thrust_n, model.max_thrust_n);
        let mut sol = crate::method::direct::solve(
            &s,
            &SolverSettings::default(),
            &mut crate::method::observer::Silent,
        );
        sol.thrust_n = vec![lo, lo, lo + 0.25 * (hi - lo), hi, hi, hi, hi];
        sol.gimbal_rate_radps = vec![0.0; 7];
        sol.delta_rad = vec![0.0; 7];
        let ev = events(&sol, &Mesh::global(6), &model);
        let cell_lo = -1.0 + mesh.weights[0] + mesh.weights[1];
        let want = cell_lo + 0.75 * mesh.weights[2];
        assert_eq!(ev.len(), 1, "{ev:?}");
        assert!(
            (ev[0].tau - want).abs() < 1e-14,
            "{} against {want}",
            ev[0].tau
        );
        assert_eq!(ev[0].switch, Some((0, true)));
    }

    /// Issue 16: refined on the paper's case, a break lands within one node
    /// spacing of the thrust switch at 6.0 s (the paper's Fig. 6), the mesh
    /// error falls pass by pass (by more than ten in three passes), and the
    /// re-integrated landing is within 0.1 m and 0.05 m/s.
    #[test]
    fn refinement_breaks_the_mesh_at_the_paper_thrust_switch() {
        let case = crate::Case::paper();
        let mut sv = case.solver.clone();
        sv.refinement.tolerance = 1e-6;
        sv.refinement.max_passes = 3;
        let sol = crate::solve(&case.scenario, &sv, &mut crate::method::observer::Silent)
            .expect("a planar scenario");
        assert_eq!(sol.status, Status::Solved, "{}", sol.message);
        let r = sol.refinement.as_ref().expect("refined");
        assert_eq!(r.passes.len(), 3);
        assert_eq!(r.stop, Stop::PassLimit);
        let errors: Vec<f64> = r.passes.iter().map(|p| p.max_relative_error).collect();
        // Measured: 9.9e-2, 7.1e-4, 1.8e-4 (the first, N = 20 global,
        // with the thrust as flown: control_profile).
        assert!(
            errors[1] < errors[0] && errors[2] < errors[1] && errors[2] < errors[0] / 10.0,
            "{errors:?}"
        );
        let t = &sol.t_s;
        let b = &sol.mesh.breaks_tau;
        let breaks: Vec<f64> = b[1..b.len() - 1]
            .iter()
            .map(|tau| 0.5 * (tau + 1.0) * sol.tf_s)
            .collect();
        let k = t.partition_point(|&x| x < 6.0);
        let spacing = t[k] - t[k - 1];
        assert!(
            breaks.iter().any(|&x| (x - 6.0).abs() <= spacing),
            "no break within {spacing:.3} s of 6.0 s: {breaks:?}"
        );
        let p = crate::verify::propagate::propagate(&case.scenario, &sol, &Default::default())
            .expect("propagates");
        let e = p.landing_error;
        assert!(
            e.position_m <= 0.1 && e.velocity_mps <= 0.05,
            "lands {:.3} m, {:.3} m/s",
            e.position_m,
            e.velocity_mps
        );
    }
}
