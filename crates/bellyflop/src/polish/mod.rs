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
//!   T_min ≤ T ≤ T_max, |δ| ≤ δ_max, |δ̇| ≤ χ_max (at a grid), δ(0) = δ_0,
//!   δ continuous,
//!
//! with y(t_f) from an accurate fixed-step integration ([`shooting`]) and
//! its exact sensitivities, by successive convexification: each step a
//! small QP in a trust region ([`subproblem`]), judged by an exact-penalty
//! merit. The landing error of the answer is then the integrator's error,
//! by construction, and the durations cannot exploit a discretization: the
//! integration resolves every segment to [`shooting::STEP_S`].

pub mod arcs;
pub mod publish;
pub mod shooting;
pub mod start;
pub mod subproblem;

use crate::flown::{Basis, FlownControls, Piece, Signal};
use crate::input::scenario::Scenario;
use crate::polish::arcs::ArcKind;
use crate::polish::shooting::{Layout, NC};
use crate::polish::subproblem::{
    linear_rows, Qp, Scales, Terminal, MASS_SCALE_KG, RESIDUAL_SCALE, SLACK_WEIGHT,
};
use crate::problem::dynamics::Model;
use crate::solution::Solution;

/// Iteration limit of the polish.
pub const MAX_ITERATIONS: usize = 30;

/// Converged when the scaled terminal residual Σ|r̂| is below this (1 mm
/// in position, 10 µrad in pitch) ...
pub const RESIDUAL_TOLERANCE: f64 = 1e-3;

/// ... and the QP's step would gain less than this in final mass \[kg\].
pub const MASS_TOLERANCE_KG: f64 = 0.05;

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

/// The exact penalty w·max(0, Σ|r̂| − [`DEAD_BAND`]).
fn penalty(residual: f64) -> f64 {
    SLACK_WEIGHT * (residual - DEAD_BAND).max(0.0)
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
}

/// A polished answer.
#[derive(Debug, Clone, PartialEq)]
pub struct Polished {
    pub controls: FlownControls,
    /// The shot's (x, z, Vx, Vz, θ, w, m) at t_f.
    pub final_state: [f64; 7],
    pub iterations: usize,
    /// Clarabel's iterations over every QP.
    pub qp_iterations: u32,
    pub time_ms: f64,
}

/// What stays fixed during a polish.
struct Problem {
    model: Model,
    layout: Layout,
    scales: Scales,
    y0: [f64; 7],
    delta0: f64,
    target: [f64; 6],
}

impl Problem {
    /// The merit φ = −m_f/M + w·Σ|r̂| at the final state `y`.
    fn merit(&self, y: &[f64; 7]) -> f64 {
        -y[6] / MASS_SCALE_KG + penalty(self.residual(y).iter().map(|r| r.abs()).sum::<f64>())
    }

    /// r̂ = R⁻¹·(y(t_f) − y_f).
    fn residual(&self, y: &[f64; 7]) -> [f64; 6] {
        std::array::from_fn(|i| (y[i] - self.target[i]) / RESIDUAL_SCALE[i])
    }

    fn final_state(&self, p: &[f64]) -> Result<[f64; 7], PolishError> {
        let y = *shooting::shoot(&self.model, &self.layout, self.y0, p)
            .last()
            .ok_or(PolishError::NonFinite)?;
        if y.iter().all(|v| v.is_finite()) {
            Ok(y)
        } else {
            Err(PolishError::NonFinite)
        }
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

/// Polish a `solved` collocation answer of `scenario` (module docs).
pub fn polish(scenario: &Scenario, sol: &Solution) -> Result<Polished, PolishError> {
    let clock = std::time::Instant::now();
    let model = Model::new(&scenario.vehicle, &scenario.environment);
    let s0 = scenario.initial.state_si();
    let (layout, p) = start::start(&model, sol);
    let scales = Scales::new(&layout, &model);
    let problem = Problem {
        target: scenario.terminal.state_si(),
        y0: [s0[0], s0[1], s0[2], s0[3], s0[4], s0[5], s0[6]],
        delta0: s0[7],
        model,
        layout,
        scales,
    };
    let mut qp_iterations = 0;
    let mut p = project(&problem, &p, &mut qp_iterations)?;
    let (iterations, y) = iterate(&problem, &mut p, &mut qp_iterations)?;
    let e = crate::verify::propagate::landing_error(scenario, &y);
    if problem.residual(&y).iter().map(|r| r.abs()).sum::<f64>() > 10.0 * RESIDUAL_TOLERANCE {
        return Err(PolishError::NotLanded {
            iterations,
            position_m: e.position_m,
            velocity_mps: e.velocity_mps,
        });
    }
    Ok(Polished {
        controls: flown(&problem.layout, &p),
        final_state: y,
        iterations,
        qp_iterations,
        time_ms: clock.elapsed().as_secs_f64() * 1e3,
    })
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
    };
    let step = subproblem::solve(&qp, p.len()).map_err(|reason| PolishError::Subproblem {
        iteration: 0,
        reason,
    })?;
    *qp_iterations += step.iterations;
    Ok(problem.moved(p, &step.dp))
}

/// The SCvx iteration: linearize the shot at p, solve the QP with the
/// proximal weight, accept or reject by the merit's actual against
/// predicted decrease; then the landing corrections ([`correct`]).
/// Returns the iterations and the final state at the last p.
fn iterate(
    problem: &Problem,
    p: &mut Vec<f64>,
    qp_iterations: &mut u32,
) -> Result<(usize, [f64; 7]), PolishError> {
    let mut weight = PROXIMAL_INITIAL;
    let mut sens = shooting::sensitivity(&problem.model, &problem.layout, problem.y0, p);
    let mut iteration = 0;
    while iteration < MAX_ITERATIONS {
        iteration += 1;
        let y = sens.final_state;
        if !y.iter().all(|v| v.is_finite()) {
            return Err(PolishError::NonFinite);
        }
        let (terminal, gradient) = linearize(problem, &sens);
        let step = qp(problem, p, &terminal, &gradient, weight, qp_iterations)
            .map_err(|reason| PolishError::Subproblem { iteration, reason })?;
        let phi = problem.merit(&y);
        let gain: f64 = gradient.iter().zip(&step.dp).map(|(g, d)| g * d).sum();
        // The linearized residual from the step itself, not the QP's slacks:
        // below ~1e-6 the QP's tolerances, not the model, set those.
        let linear: f64 = (0..6)
            .map(|i| {
                let change: f64 = terminal.jacobian[i]
                    .iter()
                    .zip(&step.dp)
                    .map(|(a, d)| a * d)
                    .sum();
                (terminal.residual[i] + change).abs()
            })
            .sum();
        let predicted = phi - (-y[6] / MASS_SCALE_KG - gain + penalty(linear));
        let residual: f64 = problem.residual(&y).iter().map(|r| r.abs()).sum();
        if residual < RESIDUAL_TOLERANCE && gain * MASS_SCALE_KG < MASS_TOLERANCE_KG {
            break;
        }
        let candidate = problem.moved(p, &step.dp);
        let (candidate, actual) = judge(
            problem,
            &terminal,
            p,
            candidate,
            phi,
            predicted,
            qp_iterations,
        );
        let rho = actual / predicted.max(f64::MIN_POSITIVE);
        if rho > 0.0 {
            *p = candidate;
            sens = shooting::sensitivity(&problem.model, &problem.layout, problem.y0, p);
        }
        weight = if rho < RHO_SHRINK {
            weight * 4.0
        } else if rho > RHO_GROW {
            (weight / 2.0).max(PROXIMAL_MIN)
        } else {
            weight
        };
        if weight > PROXIMAL_MAX {
            break;
        }
    }
    let (terminal, _) = linearize(problem, &sens);
    let y = correct(problem, &terminal, p, sens.final_state, qp_iterations);
    Ok((iteration, y))
}

/// One QP of the iteration at p.
fn qp(
    problem: &Problem,
    p: &[f64],
    terminal: &Terminal,
    gradient: &[f64],
    weight: f64,
    qp_iterations: &mut u32,
) -> Result<subproblem::Step, String> {
    let rows = linear_rows(
        &problem.layout,
        &problem.model,
        &problem.scales,
        p,
        problem.delta0,
    );
    let step = subproblem::solve(
        &Qp {
            rows: &rows,
            terminal: Some(terminal),
            mass_gradient: gradient,
            trust_radius: BOX,
            proximal_weight: weight,
        },
        p.len(),
    )?;
    *qp_iterations += step.iterations;
    Ok(step)
}

/// The landing corrections: chord steps (the Jacobian at the last
/// linearization, the residual at the current point) of minimum norm
/// within the linear constraints, while they shrink the residual, until
/// it is below [`CORRECTED_RESIDUAL`] (at most three). They cost one shot
/// each, no sensitivity. Returns the final state at the corrected p.
fn correct(
    problem: &Problem,
    terminal: &Terminal,
    p: &mut Vec<f64>,
    mut y: [f64; 7],
    qp_iterations: &mut u32,
) -> [f64; 7] {
    let size = |y: &[f64; 7]| problem.residual(y).iter().map(|r| r.abs()).sum::<f64>();
    let zeros = vec![0.0; p.len()];
    for _ in 0..3 {
        if size(&y) < CORRECTED_RESIDUAL {
            break;
        }
        let chord = Terminal {
            jacobian: terminal.jacobian.clone(),
            residual: problem.residual(&y),
        };
        let Ok(step) = qp(problem, p, &chord, &zeros, CORRECTION_WEIGHT, qp_iterations) else {
            break;
        };
        let candidate = problem.moved(p, &step.dp);
        match problem.final_state(&candidate) {
            Ok(yc) if size(&yc) < size(&y) => {
                *p = candidate;
                y = yc;
            }
            _ => break,
        }
    }
    y
}

/// The candidate and its actual decrease of the merit. A poor candidate
/// (ratio below [`RHO_SHRINK`]) gets a second-order correction first
/// (Nocedal & Wright §15.6): the minimum-norm step that removes its own
/// terminal residual along the Jacobian at p, within the linear
/// constraints. Without it the exact penalty rejects good steps for their
/// O(Δ²) residual (the Maratos effect) and the radius shrinks to nothing.
fn judge(
    problem: &Problem,
    terminal: &Terminal,
    p: &[f64],
    candidate: Vec<f64>,
    phi: f64,
    predicted: f64,
    qp_iterations: &mut u32,
) -> (Vec<f64>, f64) {
    let decrease = |q: &[f64]| match problem.final_state(q) {
        Ok(y) => (phi - problem.merit(&y), Some(y)),
        Err(_) => (f64::NEG_INFINITY, None),
    };
    let (actual, y) = decrease(&candidate);
    let Some(y) = y else {
        return (candidate, actual);
    };
    if actual >= RHO_SHRINK * predicted {
        return (candidate, actual);
    }
    let zeros = vec![0.0; p.len()];
    let correction = Terminal {
        jacobian: terminal.jacobian.clone(),
        residual: problem.residual(&y),
    };
    let Ok(step) = qp(
        problem,
        &candidate,
        &correction,
        &zeros,
        CORRECTION_WEIGHT,
        qp_iterations,
    ) else {
        return (candidate, actual);
    };
    let corrected = problem.moved(&candidate, &step.dp);
    match decrease(&corrected) {
        (better, Some(_)) if better > actual => (corrected, better),
        _ => (candidate, actual),
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
