//! The polish: the controls as they will be flown, made to land and to be
//! fuel-optimal by single shooting (issue 25, design (b)).
//!
//! A collocation answer meets the dynamics only at its nodes; its controls,
//! flown, miss the pad by metres on much of the envelope. The polish
//! re-parameterizes the controls exactly as they are published
//! ([`crate::flown`]): per segment a bound or a cubic of T, a cubic of δ,
//! and a free duration. The segments come from the thrust's arcs in the
//! collocation answer ([`arcs`], [`start`]). It then solves
//!
//!   max m(t_f)  s.t.  y(t_f) = y_f on (x, z, Vx, Vz, θ, w)  (Eq. 4),
//!   T_min ≤ T ≤ T_max, |δ| ≤ δ_max, |δ̇| ≤ χ_max (at a grid and at each
//!   polynomial's interior extrema, so along the whole flight),
//!   δ(0) = δ_0, δ continuous,
//!   z(t) ≥ z_f along the shot and m(t_f) ≥ m_dry ([`ground`]),
//!
//! with y(t_f) from an accurate fixed-step integration ([`shooting`]) and
//! its exact sensitivities, by successive convexification: each step a
//! small QP in a trust region ([`subproblem`]), judged by an exact-penalty
//! merit. The landing error of the answer is then the integrator's error,
//! by construction, and the durations cannot exploit a discretization: the
//! integration resolves every segment to [`shooting::STEP_S`].

pub mod active_set;
pub mod adjoint;
pub mod arcs;
pub mod certificate;
pub mod ground;
pub mod hessian;
pub mod limits;
pub mod publish;
pub mod qp;
pub mod repair;
pub mod shooting;
pub mod six_dof;
pub mod start;
pub mod subproblem;

use crate::flown::{Basis, FlownControls, Piece, Signal};
use crate::input::scenario::Scenario;
use crate::polish::arcs::ArcKind;
use crate::polish::shooting::{Layout, NC};
use crate::polish::subproblem::{
    linear_rows, Qp, Scales, Solved, Terminal, MASS_SCALE_KG, RESIDUAL_SCALE, SLACK_WEIGHT,
};
use crate::problem::constraints::{self, Limit, Row};
use crate::problem::dynamics::Model;
use crate::solution::{Optimality, PolishIteration, PolishReport, PolishStructure, Solution};

/// Iteration limit of the polish.
pub const MAX_ITERATIONS: usize = 30;

/// Converged when the scaled terminal residual Σ|r̂| is below this (1 mm
/// in position, 10 µrad in pitch) ...
pub const RESIDUAL_TOLERANCE: f64 = 1e-3;

/// ... and the QP's step would gain less than this in final mass \[kg\].
pub const MASS_TOLERANCE_KG: f64 = 0.05;

/// The largest path violation of a polished shot, ground \[m\] or dry mass
/// \[kg\]: a tenth of what the check allows
/// ([`crate::solution::GROUND_TOLERANCE_M`]). Where the optimum touches the
/// ground, the rows' linearization leaves the shot a few µm below it
/// (up to 1.1e-5 m on 2 of 300 seeded states, `bench/safety.py`), which
/// the iteration does not remove.
pub const PATH_TOLERANCE: f64 = 0.1 * crate::solution::GROUND_TOLERANCE_M;

/// The landing corrections at the end stop below this Σ|r̂| (0.1 µm).
pub const CORRECTED_RESIDUAL: f64 = 1e-7;

/// The proximal weight ε of the QPs, a Levenberg–Marquardt parameter: its
/// first value and bounds. It grows ×4 on a poor step (ratio below
/// [`RHO_SHRINK`]) and halves on a very good one (above [`RHO_GROW`]). A
/// scalar ε, rather than an ∞-norm box, lets the step follow the gradient
/// of the mass in the terminal conditions' null space instead of jumping to
/// a corner of the box.
const PROXIMAL_INITIAL: f64 = 0.3;
const PROXIMAL_MIN: f64 = 1e-3;
/// The weight of the minimum-norm corrections (any ε > 0 gives the same
/// step; 1 keeps the QP's objective, and so its tolerances, of order one).
const CORRECTION_WEIGHT: f64 = 1.0;
const PROXIMAL_MAX: f64 = 1e8;
/// A box on every step, |Δp̂_i| ≤ BOX (scaled): a safeguard, and what
/// lets the QP leave out the rows no step can reach.
const BOX: f64 = 0.5;
const RHO_SHRINK: f64 = 0.25;
const RHO_GROW: f64 = 0.75;

/// The residual below which the merit stops counting it (Σ|r̂|; 10 µm):
/// the final corrections ([`correct`]) remove what is left, and below it the
/// iteration's steps leave an O(Δ²) residual of their own that the exact
/// penalty would weigh against the mass and so stall the iteration.
const DEAD_BAND: f64 = 1e-5;

/// The exact penalty ν·max(0, Σ|r̂| − [`DEAD_BAND`]) at weight ν.
fn penalty(weight: f64, residual: f64) -> f64 {
    weight * (residual - DEAD_BAND).max(0.0)
}

/// The merit's weight ν of the landing residual: at least this ...
const MERIT_WEIGHT_MIN: f64 = 1e-2;
/// ... and this many times the largest terminal multiplier seen in the
/// run, never decreasing (an exact penalty needs ν > ‖μ‖∞: Nocedal &
/// Wright, §18.3), and at most the QPs' slack weight. With ν at the slack
/// weight itself (100, 2000 times the multipliers of the seeded envelope),
/// a step that gained 0.3 kg was rejected for a 10 µm residual that the
/// next step removes, and the loop crept to its cap.
const MERIT_WEIGHT_FACTOR: f64 = 10.0;

/// The merit's weight after a QP with terminal multipliers μ.
fn merit_weight(weight: f64, multipliers: &[f64; 6]) -> f64 {
    let largest = multipliers.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    weight
        .max(MERIT_WEIGHT_FACTOR * largest)
        .clamp(MERIT_WEIGHT_MIN, SLACK_WEIGHT)
}

/// Why a polish failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PolishError {
    #[error("the polish's QP failed at iteration {iteration}: {reason}")]
    Subproblem { iteration: usize, reason: String },
    #[error("the polish stopped after {iterations} iterations with the shot {position_m:.3} m and {velocity_mps:.3} m/s from the target")]
    NotLanded {
        iterations: usize,
        position_m: f64,
        velocity_mps: f64,
    },
    #[error("the shot left the finite numbers (the controls drove the state to infinity)")]
    NonFinite,
    #[error("the polish stopped after {iterations} iterations with {by}")]
    Path {
        iterations: usize,
        /// The path violation v(p) ([`ground::violation`], [`limits::violation`]).
        violation: f64,
        by: PathBreach,
    },
}

/// What a shot that keeps no path breaks most.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PathBreach {
    /// The ground (or the dry mass), by `depth` m (kg).
    Ground { depth: f64 },
    /// An operational limit, its row's value `value` in its unit
    /// ([`Limit::unit`]) above its bound.
    Limit { limit: Limit, value: f64 },
}

impl std::fmt::Display for PathBreach {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PathBreach::Ground { depth } => write!(
                f,
                "its path {depth:.3e} m below the ground (or kg below the dry mass)"
            ),
            PathBreach::Limit { limit, value } => write!(
                f,
                "{} broken along its path by {value:.3e} {}",
                limit.describe(),
                limit.unit()
            ),
        }
    }
}

/// A polished answer.
#[derive(Debug, Clone, PartialEq)]
pub struct Polished {
    pub controls: FlownControls,
    /// The shot's (x, z, Vx, Vz, θ, w, m) at t_f.
    pub final_state: [f64; 7],
    /// Its iterations, the QPs' and its time.
    pub report: PolishReport,
    /// The Pontryagin certificate ([`certificate`]).
    pub optimality: Optimality,
}

/// The polish's settings (`[solver]` in a scenario).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Options {
    /// Polishes on repaired arcs after the first, at most
    /// (`solver.polish_repairs`).
    pub max_repairs: usize,
    /// The Newton mode near the answer (the polish's `Newton`,
    /// `solver.polish_hessian`).
    pub hessian: bool,
}

/// What stays fixed during a polish.
#[derive(Clone)]
struct Problem {
    model: Model,
    layout: Layout,
    scales: Scales,
    y0: [f64; 7],
    delta0: f64,
    target: [f64; 6],
    dry_mass_kg: f64,
    /// The operational constraints' rows (issue 37; empty without any).
    limits: Vec<Row>,
    /// The Newton mode ([`Newton`], `solver.polish_hessian`).
    hessian: bool,
}

/// A shot's end, its path violation ([`ground::violation`]) and the steps
/// where it goes through the ground ([`ground::below`]).
#[derive(Debug, Clone)]
struct Shot {
    y: [f64; 7],
    path: f64,
    below: Vec<usize>,
}

impl Problem {
    fn z_f(&self) -> f64 {
        self.target[1]
    }

    /// The path rows at the sensitivities `sens`, the step ends in `watch`
    /// among them.
    fn path_rows(
        &self,
        sens: &shooting::Sensitivity,
        watch: &[usize],
    ) -> Vec<(Vec<(usize, f64)>, f64)> {
        let mut rows = ground::rows(
            sens,
            &self.layout,
            &self.scales.0,
            (self.z_f(), self.dry_mass_kg),
            BOX,
            watch,
        );
        rows.extend(limits::rows(sens, &self.limits, &self.scales.0, BOX));
        rows
    }

    /// y(t_f), its sensitivities and those of the track's z, Vz and rows.
    fn sensitivity(&self, p: &[f64]) -> shooting::Sensitivity {
        shooting::sensitivity_with(&self.model, &self.layout, self.y0, p, &self.limits)
    }

    fn shot_of(&self, sens: &shooting::Sensitivity) -> Shot {
        self.shot_from(sens.final_state, &sens.track)
    }

    fn shot_from(&self, y: [f64; 7], track: &shooting::Track) -> Shot {
        Shot {
            y,
            path: ground::violation(track, &self.layout, self.z_f(), y[6], self.dry_mass_kg)
                .max(limits::violation(track, &self.limits)),
            below: ground::below(track, self.z_f()),
        }
    }

    /// What the shot of p breaks most along its path ([`PathBreach`]).
    fn breach(&self, p: &[f64]) -> PathBreach {
        let (y, track) = shooting::shoot_track(&self.model, &self.layout, self.y0, p);
        let depth = ground::violation(&track, &self.layout, self.z_f(), y[6], self.dry_mass_kg);
        match limits::worst(&track, &self.limits) {
            Some((limit, value)) if limits::violation(&track, &self.limits) > depth => {
                PathBreach::Limit { limit, value }
            }
            _ => PathBreach::Ground { depth },
        }
    }

    /// r̂ = R⁻¹·(y(t_f) − y_f).
    fn residual(&self, y: &[f64; 7]) -> [f64; 6] {
        std::array::from_fn(|i| (y[i] - self.target[i]) / RESIDUAL_SCALE[i])
    }

    fn shoot(&self, p: &[f64]) -> Result<Shot, PolishError> {
        let (y, track) = shooting::shoot_track(&self.model, &self.layout, self.y0, p);
        if y.iter().all(|v| v.is_finite()) && track.z_m.iter().all(|v| v.is_finite()) {
            Ok(self.shot_from(y, &track))
        } else {
            Err(PolishError::NonFinite)
        }
    }

    /// The Lagrangian's Hessian in the scaled step, S·∇²Λ·S, at p with the
    /// multipliers of the last QP (Λ as in [`switching`]).
    fn curvature(&self, p: &[f64], last: &Multipliers) -> Vec<f64> {
        let mut h = hessian::hessian(&self.model, &self.layout, self.y0, p, lambda_f(last));
        let s = &self.scales.0;
        let n = s.len();
        for r in 0..n {
            for c in 0..n {
                h[r * n + c] *= s[r] * s[c];
            }
        }
        h
    }

    /// p + S·Δp̂.
    fn moved(&self, p: &[f64], dp: &[f64]) -> Vec<f64> {
        p.iter()
            .zip(dp)
            .zip(&self.scales.0)
            .map(|((p, d), s)| p + s * d)
            .collect()
    }
}

/// Polish a `solved` collocation answer of `scenario` (module docs):
/// polish on the collocation's arcs, certify ([`certificate`]), and while
/// the switching function contradicts an arc, polish again on the repaired
/// arcs ([`repair`]), keeping the heavier answer that lands (at most
/// `options.max_repairs` times, and only while each gains).
pub fn polish(
    scenario: &Scenario,
    sol: &Solution,
    options: Options,
) -> Result<Polished, PolishError> {
    let max_repairs = options.max_repairs;
    let clock = std::time::Instant::now();
    let model = Model::new(&scenario.vehicle, &scenario.environment);
    let s0 = scenario.initial.state_si();
    let limits = constraints::rows(scenario);
    let (layout, p) = start::start(&model, sol, start::MAX_SEGMENT_S);
    let layout = limits::resolved(layout, &limits);
    let scales = Scales::new(&layout, &model);
    let problem = Problem {
        target: scenario.terminal.state_si(),
        y0: [s0[0], s0[1], s0[2], s0[3], s0[4], s0[5], s0[6]],
        delta0: s0[7],
        dry_mass_kg: model.dry_mass_kg,
        limits,
        model,
        layout,
        scales,
        hessian: options.hessian,
    };
    let mut report = PolishReport::default();
    let mut best = match run(&problem, &p, &mut report) {
        Ok(first) => first,
        // The coarser start ([`start::FALLBACK_SEGMENT_S`]).
        Err(_) => {
            let (layout, p) = start::start(&problem.model, sol, start::FALLBACK_SEGMENT_S);
            let layout = limits::resolved(layout, &problem.limits);
            let scales = Scales::new(&layout, &problem.model);
            let coarse = Problem {
                layout,
                scales,
                ..problem.clone()
            };
            run(&coarse, &p, &mut report)?
        }
    };
    // Index of the published structure in the report.
    let mut kept = report.structures.len() - 1;
    while best.optimality.contradicted_arcs > 0 && report.repairs < max_repairs {
        let Some(other) = repaired(&problem, &best, &mut report) else {
            break;
        };
        report.repairs += 1;
        match other {
            Some(other) if other.shot.y[6] > best.shot.y[6] => {
                best = other;
                kept = report.structures.len() - 1;
            }
            _ => break,
        }
    }
    if let Some(s) = report.structures.get_mut(kept) {
        s.kept = true;
    }
    report.time_ms = clock.elapsed().as_secs_f64() * 1e3;
    let mut optimality = best.optimality;
    // Moved, not copied: the kept run's switching functions end here.
    optimality.switching = Some(certificate::samples(best.switching));
    Ok(Polished {
        controls: flown(&best.problem.layout, &best.p),
        final_state: best.shot.y,
        optimality,
        report,
    })
}

/// One polish on one arc structure: its problem, answer, shot and
/// certificate.
struct Run {
    problem: Problem,
    p: Vec<f64>,
    shot: Shot,
    optimality: Optimality,
    /// The switching functions the certificate judged.
    switching: adjoint::Switching,
}

/// Polish from p on `problem`'s segments: project, iterate, and check
/// that the shot lands and keeps its path.
fn run(problem: &Problem, p: &[f64], report: &mut PolishReport) -> Result<Run, PolishError> {
    let before = report.iterations;
    let outcome = run_on(problem, p, report);
    report.structures.push(PolishStructure {
        segments: problem.layout.segments.len(),
        iterations: report.iterations - before,
        final_mass_kg: outcome.as_ref().ok().map(|r| r.shot.y[6]),
        contradicted_arcs: outcome
            .as_ref()
            .ok()
            .map(|r| r.optimality.contradicted_arcs),
        kept: false,
    });
    outcome
}

/// [`run`]'s work.
fn run_on(problem: &Problem, p: &[f64], report: &mut PolishReport) -> Result<Run, PolishError> {
    let mut p = project(problem, p, &mut report.qp_iterations)?;
    let (iterations, shot, last, converged) = iterate(problem, &mut p, report)?;
    let (y, t) = (&shot.y, &problem.target);
    if problem.residual(y).iter().map(|r| r.abs()).sum::<f64>() > 10.0 * RESIDUAL_TOLERANCE {
        return Err(PolishError::NotLanded {
            iterations,
            position_m: (y[0] - t[0]).hypot(y[1] - t[1]),
            velocity_mps: (y[2] - t[2]).hypot(y[3] - t[3]),
        });
    }
    if shot.path > PATH_TOLERANCE {
        return Err(PolishError::Path {
            iterations,
            violation: shot.path,
            by: problem.breach(&p),
        });
    }
    let switching = switching(problem, &p, &last);
    let optimality = certify(problem, &switching, &last, converged);
    Ok(Run {
        problem: problem.clone(),
        p,
        shot,
        optimality,
        switching,
    })
}

/// The polish on the arcs that the switching function of `first` asks
/// for ([`repair`]), from its flown controls: None when it asks for
/// nothing, Some(None) when the polish fails there.
fn repaired(problem: &Problem, first: &Run, report: &mut PolishReport) -> Option<Option<Run>> {
    let model = &problem.model;
    let arcs = repair::repaired(
        &first.problem.layout,
        &first.p,
        &first.switching,
        (model.min_thrust_n, model.max_thrust_n),
        certificate::TOLERANCE,
    )?;
    let controls = flown(&first.problem.layout, &first.p);
    let at = |t: f64| controls.at(t).unwrap_or((f64::NAN, f64::NAN, f64::NAN));
    // Room for a seed to grow into an arc.
    let (layout, p) = start::from_arcs(
        &arcs,
        |t| at(t).1,
        |t| at(t).0,
        start::MAX_SEGMENT_S,
        start::MAX_SEGMENT_S,
    );
    let layout = limits::resolved(layout, &problem.limits);
    let scales = Scales::new(&layout, model);
    let next = Problem {
        layout,
        scales,
        ..problem.clone()
    };
    Some(run(&next, &p, report).ok())
}

/// The nearest point to `p` that meets the linear constraints exactly (the
/// projections of the start need not be continuous in δ or within bounds).
fn project(problem: &Problem, p: &[f64], qp_iterations: &mut u32) -> Result<Vec<f64>, PolishError> {
    let rows = linear_rows(
        &problem.layout,
        &problem.model,
        &problem.scales,
        p,
        problem.delta0,
    );
    let zeros = vec![0.0; p.len()];
    let qp = Qp {
        rows: &rows,
        terminal: None,
        mass_gradient: &zeros,
        trust_radius: 1e3,
        proximal_weight: 1.0,
        hessian: None,
        path: &[],
    };
    let step = subproblem::solve(&qp, p.len())
        .map_err(|reason| PolishError::Subproblem {
            iteration: 0,
            reason,
        })?
        .step;
    *qp_iterations += step.iterations;
    Ok(problem.moved(p, &step.dp))
}

/// The SCvx iteration: linearize the shot at p, solve the QP with the
/// proximal weight, accept or reject by the merit's actual against
/// predicted decrease; then the landing corrections ([`correct`]).
/// Returns the iterations, the shot at the last p, the last QP's
/// multipliers, and whether the loop stopped on its tolerances (not at its
/// cap or its weight's limit).
fn iterate(
    problem: &Problem,
    p: &mut Vec<f64>,
    report: &mut PolishReport,
) -> Result<(usize, Shot, Multipliers, bool), PolishError> {
    let PolishReport {
        qp_iterations,
        history,
        iterations: total,
        ..
    } = report;
    let qp_iterations = &mut *qp_iterations;
    let (mut weight, mut floor) = (PROXIMAL_INITIAL, PROXIMAL_MIN);
    let mut sens = problem.sensitivity(p);
    let mut watch: Vec<usize> = Vec::new();
    let mut iteration = 0;
    let mut last = Multipliers::default();
    let mut converged = false;
    let mut nu = MERIT_WEIGHT_MIN;
    let mut newton = Newton::new(problem.hessian);
    while iteration < MAX_ITERATIONS {
        iteration += 1;
        let shot = problem.shot_of(&sens);
        let y = shot.y;
        if !y.iter().all(|v| v.is_finite()) {
            return Err(PolishError::NonFinite);
        }
        let (terminal, gradient) = linearize(problem, &sens);
        let path = problem.path_rows(&sens, &watch);
        let before_qp = *qp_iterations;
        let residual: f64 = problem.residual(&y).iter().map(|r| r.abs()).sum();
        newton.update(
            problem,
            p,
            (residual, shot.path),
            &last,
            (&mut weight, &mut floor),
        );
        let ask = Linearized {
            terminal: &terminal,
            gradient: &gradient,
            weight,
            hessian: newton.matrix(),
            path: &path,
        };
        let tries = 2 * usize::from(residual < NEAR_RESIDUAL);
        let solved = bounded_step(problem, p, &ask, tries, qp_iterations)
            .map_err(|reason| PolishError::Subproblem { iteration, reason })?;
        let step = &solved.step;
        last = Multipliers {
            terminal: step.multipliers,
            path: step.path_multiplier,
        };
        nu = merit_weight(nu, &step.multipliers);
        let merit = Merit::at(residual, shot.path, nu, &step.multipliers);
        let phi = merit.value(problem, &shot);
        let gain: f64 = gradient.iter().zip(&step.dp).map(|(g, d)| g * d).sum();
        let model = MeritModel {
            shot: &shot,
            terminal: &terminal,
            path: &path,
            curvature: newton.matrix(),
        };
        let predicted = phi - model.merit(gain, &merit, &step.dp);
        history.push(PolishIteration {
            iteration: *total + iteration,
            final_mass_kg: y[6],
            residual,
            path_violation: shot.path,
            predicted_gain_kg: gain * MASS_SCALE_KG,
            rho: f64::NAN,
            accepted: false,
            proximal_weight: weight,
            qp_iterations: *qp_iterations - before_qp,
            step_residual: f64::NAN,
        });
        if at_tolerances(problem, p, residual, shot.path, gain, predicted) {
            converged = true;
            break;
        }
        let candidate = problem.moved(p, &step.dp);
        let Judged {
            point: candidate,
            actual,
            shot: tried,
            step_residual,
        } = judge(
            problem,
            (&terminal, &solved),
            p,
            candidate,
            (phi, &merit),
            predicted,
            qp_iterations,
        );
        let rho = actual / predicted.max(f64::MIN_POSITIVE);
        judged(history, rho, *qp_iterations - before_qp, step_residual);
        if rho > 0.0 {
            *p = candidate;
            sens = problem.sensitivity(p);
            newton.moved();
        } else if watch_new(&mut watch, tried.as_ref().map_or(&[][..], |s| &s.below))
            && violates(&problem.path_rows(&sens, &watch), &step.dp)
        {
            // The step went through the ground where no row was, and the
            // rows there, linearized, see it: the same QP again with them,
            // at the same weight. (Where they do not, that QP's answer is
            // this step again: measured, a whole iteration repeated.)
            continue;
        }
        (weight, floor) = next_weight(weight, floor, rho, newton.least_weight());
        if weight > PROXIMAL_MAX {
            break;
        }
    }
    let shot = corrected(problem, &sens, &watch, p, qp_iterations);
    *total += iteration;
    Ok((iteration, shot, last, converged))
}

/// The last iteration's entry completed with its step's verdict: the ratio
/// ρ, the QPs' changes and the step's own landing residual.
fn judged(history: &mut [PolishIteration], rho: f64, qp_iterations: u32, step_residual: f64) {
    if let Some(last) = history.last_mut() {
        last.rho = rho;
        last.accepted = rho > 0.0;
        last.qp_iterations = qp_iterations;
        last.step_residual = step_residual;
    }
}

/// The landing corrections ([`correct`]) from p, linearized at its
/// sensitivities `sens` with the path rows of the watched steps.
fn corrected(
    problem: &Problem,
    sens: &shooting::Sensitivity,
    watch: &[usize],
    p: &mut Vec<f64>,
    qp_iterations: &mut u32,
) -> Shot {
    let (terminal, _) = linearize(problem, sens);
    let path = problem.path_rows(sens, watch);
    correct(
        problem,
        &terminal,
        &path,
        p,
        problem.shot_of(sens),
        qp_iterations,
    )
}

/// Whether the iteration stops at p: the landing residual, the path
/// violation and the QP's predicted gain (scaled) under their tolerances,
/// and p within its bounds between the extrema, or out of them where no
/// step that the merit can accept takes it back (the model predicts no
/// decrease): the corrections after the loop do it. Without that clause the
/// loop rejected steps to its cap, its ratio −1e302 as the predicted
/// decrease went to zero (measured on the envelope).
fn at_tolerances(
    problem: &Problem,
    p: &[f64],
    residual: f64,
    path: f64,
    gain: f64,
    predicted: f64,
) -> bool {
    residual < RESIDUAL_TOLERANCE
        && path <= PATH_TOLERANCE
        && gain * MASS_SCALE_KG < MASS_TOLERANCE_KG
        && (within_bounds(problem, p) || predicted <= 0.0)
}

/// The multipliers of the last QP of the iteration: its terminal rows',
/// and the largest of its path rows'.
#[derive(Debug, Clone, Copy, Default)]
struct Multipliers {
    terminal: [f64; 6],
    path: f64,
}

/// A path multiplier above this (in the QP's scaled merit, where the
/// mass gains 1 per tonne) counts as an active path row.
const ACTIVE_PATH_MULTIPLIER: f64 = 1e-6;

/// The switching functions along the shot of p ([`adjoint`]) with λ(t_f)
/// = ∂Λ/∂y(t_f), Λ = −m_f/M + Σ μ_i·(y_i − y_f,i)/R_i at the last QP's
/// multipliers.
fn switching(problem: &Problem, p: &[f64], last: &Multipliers) -> adjoint::Switching {
    adjoint::switching(
        &problem.model,
        &problem.layout,
        problem.y0,
        p,
        lambda_f(last),
    )
}

/// λ(t_f) = ∂Λ/∂y(t_f), Λ = −m_f/M + Σ μ_i·(y_i − y_f,i)/R_i.
fn lambda_f(last: &Multipliers) -> [f64; 7] {
    let mut lambda_f = [0.0; 7];
    for i in 0..6 {
        lambda_f[i] = last.terminal[i] / RESIDUAL_SCALE[i];
    }
    lambda_f[6] = -1.0 / MASS_SCALE_KG;
    lambda_f
}

/// The merit that judges a step: the exact penalty ν·Σ|r̂| of the landing
/// residual, or the augmented Lagrangian yᵀr̂ + (ρ/2)·‖r̂‖² at the QP's
/// terminal multipliers y; both with −m_f/M and the path violation.
#[derive(Debug, Clone, Copy)]
enum Merit {
    Exact(f64),
    Augmented { y: [f64; 6], rho: f64 },
}

/// The augmented Lagrangian's weight ρ (scaled: ρ/2·‖r̂‖² with r̂ in
/// metres and the merit in tonnes). On the 46 envelope states of
/// BENCHMARKS.md (issue 35) ρ = 30 ends a median 0.25 kg short of the fine
/// reference and ρ = 100 0.27, against 0.30 with the exact penalty alone.
const AUGMENTED_WEIGHT: f64 = 30.0;

impl Merit {
    /// The merit near the landing (Σ|r̂| below [`NEAR_RESIDUAL`], no path
    /// violation): the augmented Lagrangian at the QP's multipliers y,
    /// whose change along a step is the Lagrangian's, to second order, so
    /// that the landing's second-order residual, which the next step
    /// removes, is weighed by y and not by the exact penalty's ν > 10·|y|
    /// (BENCHMARKS.md, issue 35: that residual is 10²–10⁴ times the
    /// iterate's). Farther out, the exact penalty at ν.
    fn at(residual: f64, path: f64, nu: f64, y: &[f64; 6]) -> Self {
        if residual < NEAR_RESIDUAL && path <= PATH_TOLERANCE {
            Merit::Augmented {
                y: *y,
                rho: AUGMENTED_WEIGHT,
            }
        } else {
            Merit::Exact(nu)
        }
    }

    /// The landing's term at the scaled residual r̂.
    fn landing(&self, r: &[f64; 6]) -> f64 {
        match self {
            Merit::Exact(nu) => penalty(*nu, r.iter().map(|v| v.abs()).sum()),
            Merit::Augmented { y, rho } => {
                (0..6).map(|i| y[i] * r[i] + 0.5 * rho * r[i] * r[i]).sum()
            }
        }
    }

    /// The merit of a shot.
    fn value(&self, problem: &Problem, shot: &Shot) -> f64 {
        -shot.y[6] / MASS_SCALE_KG
            + self.landing(&problem.residual(&shot.y))
            + SLACK_WEIGHT * shot.path
    }
}

/// The QP's model of the merit at a step from the shot: the mass gained
/// to first order, the curvature's term (in the Newton mode), the
/// linearized landing residual and path violation.
struct MeritModel<'a> {
    shot: &'a Shot,
    terminal: &'a Terminal,
    path: &'a [(Vec<(usize, f64)>, f64)],
    curvature: Option<&'a [f64]>,
}

impl MeritModel<'_> {
    /// The merit predicted after the step Δp̂ that gains `gain` (scaled).
    fn merit(&self, gain: f64, merit: &Merit, dp: &[f64]) -> f64 {
        let quadratic = self.curvature.map_or(0.0, |h| 0.5 * quadratic_form(h, dp));
        let landing = match merit {
            Merit::Exact(nu) => penalty(*nu, linear_residual(self.terminal, dp)),
            Merit::Augmented { .. } => merit.landing(&linear_residuals(self.terminal, dp)),
        };
        -self.shot.y[6] / MASS_SCALE_KG - gain
            + quadratic
            + landing
            + SLACK_WEIGHT * linear_path(self.shot.path, self.path, dp)
    }
}

/// The proximal weight with which the Newton mode starts, and its least.
const NEWTON_PROXIMAL_INITIAL: f64 = 1e-2;
const NEWTON_PROXIMAL_MIN: f64 = 1e-6;
/// The least eigenvalue of the QPs' curvature in the Newton mode
/// ([`hessian::convexified`]).
const EIGENVALUE_FLOOR: f64 = 1e-8;

/// The Newton mode of [`iterate`] (`solver.polish_hessian`): once the shot
/// is near, the QPs' curvature is the Lagrangian's Hessian at the current
/// point and the last QP's multipliers ([`hessian`]), made positive
/// definite by its eigenvalues' magnitudes, beside the proximal weight,
/// which then starts again from [`NEWTON_PROXIMAL_INITIAL`].
struct Newton {
    enabled: bool,
    started: bool,
    matrix: Option<Vec<f64>>,
}

impl Newton {
    fn new(enabled: bool) -> Self {
        Newton {
            enabled,
            started: false,
            matrix: None,
        }
    }

    /// At p with the shot's (residual, path violation): start the mode
    /// when near, and compute the curvature where p moved.
    fn update(
        &mut self,
        problem: &Problem,
        p: &[f64],
        (residual, path): (f64, f64),
        last: &Multipliers,
        (weight, floor): (&mut f64, &mut f64),
    ) {
        if !self.enabled || residual >= NEAR_RESIDUAL || path > PATH_TOLERANCE {
            return;
        }
        if !self.started {
            self.started = true;
            *weight = NEWTON_PROXIMAL_INITIAL;
            *floor = NEWTON_PROXIMAL_MIN;
        }
        if self.matrix.is_none() {
            self.matrix = hessian::convexified(&problem.curvature(p, last), EIGENVALUE_FLOOR);
        }
    }

    /// The QPs' curvature, where the mode is on.
    fn matrix(&self) -> Option<&[f64]> {
        self.matrix.as_deref()
    }

    /// p moved: its curvature is computed again at the next iteration.
    fn moved(&mut self) {
        self.matrix = None;
    }

    /// The least proximal weight.
    fn least_weight(&self) -> f64 {
        if self.started {
            NEWTON_PROXIMAL_MIN
        } else {
            PROXIMAL_MIN
        }
    }
}

/// xᵀ·H·x for a square H (row-major).
fn quadratic_form(h: &[f64], x: &[f64]) -> f64 {
    let n = x.len();
    (0..n)
        .map(|r| x[r] * (0..n).map(|c| h[r * n + c] * x[c]).sum::<f64>())
        .sum()
}

/// The certificate ([`certificate`]) of the switching functions `sw`,
/// made with the last QP's multipliers; it does not hold where the loop
/// did not converge (`converged`), whatever the signs say.
fn certify(
    problem: &Problem,
    sw: &adjoint::Switching,
    last: &Multipliers,
    converged: bool,
) -> Optimality {
    let mut o = certificate::certify(
        &problem.layout,
        sw,
        problem.model.max_thrust_n,
        last.path > ACTIVE_PATH_MULTIPLIER,
    );
    o.multipliers = last.terminal;
    o.path_multiplier = last.path;
    o.converged = converged;
    o.holds &= converged;
    o
}

/// Whether p meets the bounds that are linear in it (not the QPs' margin
/// inside them) at its own grid and extrema ([`subproblem::bound_rows`]),
/// to rounding. An accepted step meets the rows
/// of the point it was taken from; the extrema of its polynomials move with
/// it, and a bound can be exceeded between the old extrema (by up to 1.4e-4
/// of χ_max on the seeded envelope, `bench/safety.py`) until a step from
/// the new point takes it back.
fn within_bounds(problem: &Problem, p: &[f64]) -> bool {
    let rows = subproblem::bound_rows(
        &problem.layout,
        &problem.model,
        &problem.scales,
        p,
        problem.delta0,
        0.0,
        None,
    );
    rows.le.iter().all(|(terms, rhs)| {
        let size = terms.iter().map(|(_, a)| a.abs()).fold(0.0, f64::max);
        *rhs >= -1e-9 * size
    })
}

/// Add the steps of `below` to the sorted `watch`; whether any was new.
fn watch_new(watch: &mut Vec<usize>, below: &[usize]) -> bool {
    let before = watch.len();
    for &k in below {
        if let Err(at) = watch.binary_search(&k) {
            watch.insert(at, k);
        }
    }
    watch.len() > before
}

/// Whether the step Δp̂ violates a path row a·Δp̂ ≤ b.
fn violates(rows: &[(Vec<(usize, f64)>, f64)], dp: &[f64]) -> bool {
    rows.iter()
        .any(|(terms, b)| terms.iter().map(|&(c, a)| a * dp[c]).sum::<f64>() > *b)
}

/// r̂ + J·Δp̂, each row.
fn linear_residuals(terminal: &Terminal, dp: &[f64]) -> [f64; 6] {
    std::array::from_fn(|i| {
        terminal.residual[i]
            + terminal.jacobian[i]
                .iter()
                .zip(dp)
                .map(|(a, d)| a * d)
                .sum::<f64>()
    })
}

/// Σ|r̂ + J·Δp̂|: the linearized residual from the step itself, not the
/// QP's slacks (below ~1e-6 the QP's tolerances, not the model, set those).
fn linear_residual(terminal: &Terminal, dp: &[f64]) -> f64 {
    (0..6)
        .map(|i| {
            let change: f64 = terminal.jacobian[i]
                .iter()
                .zip(dp)
                .map(|(a, d)| a * d)
                .sum();
            (terminal.residual[i] + change).abs()
        })
        .sum()
}

/// The path violation linearized along the step: max(0, a·Δp̂ − b) over
/// the QP's path rows, and at least the part of today's violation that no
/// row carries (the rows leave out points out of reach).
fn linear_path(current: f64, rows: &[(Vec<(usize, f64)>, f64)], dp: &[f64]) -> f64 {
    let worst = rows
        .iter()
        .map(|(terms, b)| terms.iter().map(|&(c, a)| a * dp[c]).sum::<f64>() - b)
        .fold(0.0, f64::max);
    if rows.is_empty() {
        current
    } else {
        worst
    }
}

/// What a QP of the polish asks at p besides its linear rows: the
/// linearized terminal rows, the mass gradient (zero for a correction),
/// the proximal weight ε and the path rows.
struct Linearized<'a> {
    terminal: &'a Terminal,
    gradient: &'a [f64],
    weight: f64,
    /// The Lagrangian's Hessian in Δp̂ ([`hessian`]), or None.
    hessian: Option<&'a [f64]>,
    path: &'a [(Vec<(usize, f64)>, f64)],
}

/// One QP at p on the bound rows `rows`.
fn qp(
    p: &[f64],
    rows: &subproblem::Rows,
    ask: &Linearized,
    qp_iterations: &mut u32,
) -> Result<subproblem::Solved, String> {
    let solved = subproblem::solve(
        &Qp {
            rows,
            terminal: Some(ask.terminal),
            mass_gradient: ask.gradient,
            trust_radius: BOX,
            proximal_weight: ask.weight,
            hessian: ask.hessian,
            path: ask.path,
        },
        p.len(),
    )?;
    *qp_iterations += solved.step.iterations;
    Ok(solved)
}

/// The proximal weight after a step judged `rho` at `weight`, and the
/// floor below which it does not halve: twice the last weight whose step
/// was rejected, decaying by [`FLOOR_DECAY`] per accepted step. Without
/// the floor, a creeping loop cycled accept (halve), reject (×4), accept:
/// one QP and one shot in three were thrown away (the polish's history on
/// the seeded envelope).
fn next_weight(weight: f64, floor: f64, rho: f64, least: f64) -> (f64, f64) {
    if rho < RHO_SHRINK {
        let floor = if rho <= 0.0 { 2.0 * weight } else { floor };
        (weight * 4.0, floor)
    } else {
        let floor = (floor * FLOOR_DECAY).max(least);
        let weight = if rho > RHO_GROW {
            (weight / 2.0).max(floor)
        } else {
            weight
        };
        (weight, floor)
    }
}

/// The decay per accepted step of [`next_weight`]'s floor.
const FLOOR_DECAY: f64 = 0.8;

/// The residual Σ|r̂| (1 cm) below which the iteration is near the end:
/// its steps keep their bounds at their own extrema ([`bounded_step`];
/// there the last accepted point is the answer, while farther out a
/// step's bulge is taken back by the next); and, with no path violation,
/// the merit is the augmented Lagrangian ([`Merit::at`]) and the Newton
/// mode starts ([`Newton`]: farther out the Lagrangian's Hessian, at
/// multipliers of a landing not yet met, is a poor model).
const NEAR_RESIDUAL: f64 = 1e-2;

/// The QP's step at p ([`qp`]); and while the step's polynomials leave
/// their bounds between the rows (their extrema moved with it), at most
/// `tries` times, the same QP with rows at the step's extrema too,
/// continued from its answer ([`subproblem::Solved::add`]). The
/// active-set method puts an active row exactly on its bound, so a step
/// that ends on a bound at a grid point bulges past it between the points
/// unless the new extrema carry rows.
fn bounded_step(
    problem: &Problem,
    p: &[f64],
    ask: &Linearized,
    tries: usize,
    qp_iterations: &mut u32,
) -> Result<subproblem::Solved, String> {
    let mut rows = subproblem::bound_rows(
        &problem.layout,
        &problem.model,
        &problem.scales,
        p,
        problem.delta0,
        subproblem::BOUND_MARGIN,
        None,
    );
    let mut solved = qp(p, &rows, ask, qp_iterations)?;
    for _ in 0..tries {
        let candidate = problem.moved(p, &solved.step.dp);
        if within_bounds(problem, &candidate) {
            break;
        }
        let extra = subproblem::extrema_rows(
            &problem.layout,
            &problem.model,
            &problem.scales,
            p,
            (subproblem::BOUND_MARGIN, problem.delta0),
            &candidate,
        );
        if solved.add(&extra) {
            *qp_iterations += solved.step.iterations;
        } else {
            rows.le.extend(extra);
            solved = qp(p, &rows, ask, qp_iterations)?;
        }
    }
    Ok(solved)
}

/// The landing corrections: chord steps (the Jacobian at the last
/// linearization, the residual at the current point) of minimum norm
/// within the linear constraints and the path rows of the last
/// linearization, while they shrink the residual without a path
/// violation, until it is below [`CORRECTED_RESIDUAL`] and p within its
/// bounds at its own extrema (at most six, each with one retry at the
/// extrema of its step, [`bounded_step`]).
/// They cost one shot each, no sensitivity. Returns the shot at the
/// corrected p.
fn correct(
    problem: &Problem,
    terminal: &Terminal,
    path: &[(Vec<(usize, f64)>, f64)],
    p: &mut Vec<f64>,
    mut shot: Shot,
    qp_iterations: &mut u32,
) -> Shot {
    let size = |y: &[f64; 7]| problem.residual(y).iter().map(|r| r.abs()).sum::<f64>();
    let zeros = vec![0.0; p.len()];
    for _ in 0..6 {
        if size(&shot.y) < CORRECTED_RESIDUAL && within_bounds(problem, p) {
            break;
        }
        let chord = Terminal {
            jacobian: terminal.jacobian.clone(),
            residual: problem.residual(&shot.y),
        };
        let ask = Linearized {
            terminal: &chord,
            gradient: &zeros,
            weight: CORRECTION_WEIGHT,
            hessian: None,
            path,
        };
        // A candidate out of its bounds: the same correction again with
        // rows at its extrema too.
        let Ok(Solved { step, .. }) = bounded_step(problem, p, &ask, 1, qp_iterations) else {
            break;
        };
        let candidate = problem.moved(p, &step.dp);
        // A correction may not take p out of its bounds (its rows are at p,
        // and the extrema move with the step); one that takes it back in
        // may leave a residual up to the iteration's tolerance, which the
        // next corrections reduce.
        let (inside, lands_inside) = (
            within_bounds(problem, p),
            within_bounds(problem, &candidate),
        );
        match problem.shoot(&candidate) {
            Ok(next)
                if next.path <= shot.path.max(PATH_TOLERANCE)
                    && ((size(&next.y) < size(&shot.y) && (lands_inside || !inside))
                        || (lands_inside
                            && !inside
                            && size(&next.y) <= size(&shot.y).max(RESIDUAL_TOLERANCE))) =>
            {
                *p = candidate;
                shot = next;
            }
            _ => break,
        }
    }
    shot
}

/// The candidate and its actual decrease of the merit. A poor candidate
/// (ratio below [`RHO_SHRINK`]) gets a second-order correction first
/// (Nocedal & Wright §15.6): the minimum-norm step that removes its own
/// terminal residual along the Jacobian at p, within the linear
/// constraints: on the step's own active set from its QP's factors
/// ([`Solved::corrected`]), else by a second QP (in a benchmark of 46
/// states, 470 of 573 corrections came from the factors; the total time
/// on 300 states fell by a third). Without it the exact penalty rejects
/// good steps for their O(Δ²) residual (the Maratos effect) and the radius
/// shrinks to nothing.
/// The merit of either counts its path violation, from its own shot,
/// which comes back too (None where the shot failed).
fn judge(
    problem: &Problem,
    (terminal, solved): (&Terminal, &subproblem::Solved),
    p: &[f64],
    candidate: Vec<f64>,
    (phi, merit): (f64, &Merit),
    predicted: f64,
    qp_iterations: &mut u32,
) -> Judged {
    let decrease = |q: &[f64]| match problem.shoot(q) {
        Ok(shot) => (phi - merit.value(problem, &shot), Some(shot)),
        Err(_) => (f64::NEG_INFINITY, None),
    };
    let (actual, shot) = decrease(&candidate);
    let Some(shot) = shot else {
        return Judged::new(candidate, actual, None, f64::NAN);
    };
    let step_residual: f64 = problem.residual(&shot.y).iter().map(|r| r.abs()).sum();
    if actual >= RHO_SHRINK * predicted {
        return Judged::new(candidate, actual, Some(shot), step_residual);
    }
    let residual = problem.residual(&shot.y);
    let corrected = match solved.corrected(&residual) {
        // The step's own active set, moved: no new QP.
        Some(dp) => problem.moved(p, &dp),
        None => {
            let zeros = vec![0.0; p.len()];
            let correction = Terminal {
                jacobian: terminal.jacobian.clone(),
                residual,
            };
            let ask = Linearized {
                terminal: &correction,
                gradient: &zeros,
                weight: CORRECTION_WEIGHT,
                hessian: None,
                path: &[],
            };
            let Ok(Solved { step, .. }) = bounded_step(problem, &candidate, &ask, 0, qp_iterations)
            else {
                return Judged::new(candidate, actual, Some(shot), step_residual);
            };
            problem.moved(&candidate, &step.dp)
        }
    };
    match decrease(&corrected) {
        (better, Some(other)) if better > actual => {
            Judged::new(corrected, better, Some(other), step_residual)
        }
        _ => Judged::new(candidate, actual, Some(shot), step_residual),
    }
}

/// [`judge`]'s verdict: the point (the candidate or its correction), its
/// actual decrease of the merit, its shot (None where it failed), and the
/// landing residual Σ|r̂| of the QP's step itself, before any correction.
struct Judged {
    point: Vec<f64>,
    actual: f64,
    shot: Option<Shot>,
    step_residual: f64,
}

impl Judged {
    fn new(point: Vec<f64>, actual: f64, shot: Option<Shot>, step_residual: f64) -> Self {
        Judged {
            point,
            actual,
            shot,
            step_residual,
        }
    }
}

/// The QP's terminal rows R⁻¹·J·S and R⁻¹·r, and ∂(m_f/M)/∂Δp̂.
fn linearize(problem: &Problem, sens: &shooting::Sensitivity) -> (Terminal, Vec<f64>) {
    let s = &problem.scales.0;
    let jacobian = std::array::from_fn(|i| {
        (0..s.len())
            .map(|c| sens.d(i, c) * s[c] / RESIDUAL_SCALE[i])
            .collect()
    });
    let gradient = (0..s.len())
        .map(|c| sens.d(6, c) * s[c] / MASS_SCALE_KG)
        .collect();
    let terminal = Terminal {
        jacobian,
        residual: problem.residual(&sens.final_state),
    };
    (terminal, gradient)
}

/// The published form of the parameters p.
fn flown(layout: &Layout, p: &[f64]) -> FlownControls {
    let poly = |at: usize| Signal::Polynomial {
        basis: Basis::ShiftedLegendre,
        coefficients: p[at..at + NC].to_vec(),
    };
    let mut t = 0.0;
    let pieces = layout
        .segments
        .iter()
        .enumerate()
        .map(|(j, seg)| {
            let d = p[layout.duration(j)];
            let piece = Piece {
                t_start_s: t,
                t_end_s: t + d,
                thrust_n: match seg.thrust {
                    ArcKind::Bound(value) => Signal::Bound { value },
                    ArcKind::Free => {
                        poly(layout.thrust(j).expect("a free thrust has coefficients"))
                    }
                },
                delta_rad: poly(layout.delta(j)),
            };
            t += d;
            piece
        })
        .collect();
    FlownControls { pieces }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A polish that ends off its path says what it breaks: the ground
    /// (or the dry mass), or the operational limit by name and unit.
    #[test]
    fn a_path_error_names_what_the_path_breaks() {
        let ground = PolishError::Path {
            iterations: 30,
            violation: 0.5,
            by: PathBreach::Ground { depth: 0.5 },
        };
        assert_eq!(
            ground.to_string(),
            "the polish stopped after 30 iterations with its path 5.000e-1 m below the ground (or kg below the dry mass)"
        );
        let cone = PolishError::Path {
            iterations: 30,
            violation: 1.648,
            by: PathBreach::Limit {
                limit: Limit::Cone,
                value: 1.648,
            },
        };
        assert_eq!(
            cone.to_string(),
            "the polish stopped after 30 iterations with the approach cone broken along its path by 1.648e0 m"
        );
    }
}
