//! One convex subproblem of the polish, solved by Clarabel (a QP).
//!
//! In the scaled step Δp̂ (p = p_ref + S·Δp̂, S = [`Scales`]) and the
//! terminal slacks ν⁺, ν⁻ ≥ 0:
//!
//!   min  −(∂m_f/∂p·S·Δp̂)/M + w·Σ(ν⁺ + ν⁻) + ½·ε·‖Δp̂‖²
//!   s.t. R⁻¹·(r + J·S·Δp̂) = ν⁺ − ν⁻          (the six terminal conditions, linearized)
//!        the linear constraints of p, exactly  ([`linear_rows`])
//!        |Δp̂_i| ≤ Δ                            (the trust region)
//!
//! with r = y(t_f) − y_f on (x, z, Vx, Vz, θ, w), R its scales
//! ([`RESIDUAL_SCALE`]), M = [`MASS_SCALE_KG`]. The constraints that are
//! linear in p hold exactly at every accepted point: T within its bounds and
//! |δ| ≤ δ_max at [`GRID`] points of every segment, |dδ/ds| ≤ χ_max·d_j
//! there (the gimbal rate, linear in (δ's coefficients, d_j)), δ continuous
//! across segments and δ(0) = δ_0, and every duration within its bounds.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, SolverStatus, SupportedConeT};

use crate::flown::{critical_points, legendre, legendre_slope};
use crate::polish::shooting::{Layout, NC};
use crate::problem::dynamics::Model;

/// Points per segment at which the bounds of T, δ and χ are imposed
/// (s = 0, 1/(GRID − 1), …, 1).
pub const GRID: usize = 11;

/// Scale of the residuals of x, z \[m\], Vx, Vz [m/s], θ \[rad\], w [rad/s].
pub const RESIDUAL_SCALE: [f64; 6] = [1.0, 1.0, 1.0, 1.0, 1e-2, 1e-2];

/// Scale of the final mass in the objective \[kg\].
pub const MASS_SCALE_KG: f64 = 1000.0;

/// Weight of the terminal slacks (exact penalty; far above the multipliers
/// of the terminal conditions in these scales).
pub const SLACK_WEIGHT: f64 = 100.0;

/// Weight ε of the proximal term (it keeps the QP strictly convex on the
/// flat directions of the coefficients).
pub const PROXIMAL_WEIGHT: f64 = 1e-6;

/// Scales of p: durations in 0.5 s, δ coefficients in δ_max, T coefficients
/// in T_max − T_min.
#[derive(Debug, Clone, PartialEq)]
pub struct Scales(pub Vec<f64>);

impl Scales {
    pub fn new(layout: &Layout, model: &Model) -> Self {
        let mut s = vec![0.0; layout.len];
        for j in 0..layout.segments.len() {
            s[layout.duration(j)] = 0.5;
            for k in 0..NC {
                s[layout.delta(j) + k] = model.max_gimbal_rad;
            }
            if let Some(t) = layout.thrust(j) {
                for k in 0..NC {
                    s[t + k] = model.max_thrust_n - model.min_thrust_n;
                }
            }
        }
        Scales(s)
    }
}

/// Linear rows in the scaled step: Σ coef·Δp̂ (=, ≤) rhs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Rows {
    pub eq: Vec<(Vec<(usize, f64)>, f64)>,
    pub le: Vec<(Vec<(usize, f64)>, f64)>,
}

/// How far inside its bounds a control is held, as a fraction of the
/// bound's scale (T_max − T_min, δ_max, χ_max): a QP solution meets its
/// rows only to Clarabel's tolerances, so the rows stand this far inside
/// and the answer is within its bounds to rounding. (At 1e-7, χ ended
/// 1e-7 to 3.4e-7 of χ_max beyond it on 3 of 300 seeded states,
/// `bench/safety.py`; at 1e-6, on none.)
pub const BOUND_MARGIN: f64 = 1e-6;

/// The constraints that are linear in p (module docs), at the point `p`:
/// each bound at the [`GRID`] points of every segment and at the current
/// interior extrema of its polynomial ([`critical_points`]), within
/// [`BOUND_MARGIN`] of it.
pub fn linear_rows(
    layout: &Layout,
    model: &Model,
    scales: &Scales,
    p: &[f64],
    delta0: f64,
) -> Rows {
    let sc = &scales.0;
    let mut rows = Rows::default();
    let poly = |at: usize, basis: &[f64; NC]| -> (Vec<(usize, f64)>, f64) {
        let terms = (0..NC).map(|k| (at + k, basis[k] * sc[at + k])).collect();
        let value = (0..NC).map(|k| basis[k] * p[at + k]).sum();
        (terms, value)
    };
    let dmax = model.max_gimbal_rad * (1.0 - BOUND_MARGIN);
    let chimax = model.max_gimbal_rate_radps * (1.0 - BOUND_MARGIN);
    let margin_t = BOUND_MARGIN * (model.max_thrust_n - model.min_thrust_n);
    let (tlo, thi) = (model.min_thrust_n + margin_t, model.max_thrust_n - margin_t);
    let last = layout.segments.len() - 1;
    let grid = (0..GRID).map(|g| g as f64 / (GRID - 1) as f64);
    for (j, seg) in layout.segments.iter().enumerate() {
        let (dj, aj) = (layout.duration(j), layout.delta(j));
        let (delta_extrema, rate_extremum) = critical_points(&p[aj..aj + NC]);
        // δ(0) of the first segment is δ_0, fixed by an equality.
        let first = usize::from(j == 0);
        for s in grid.clone().skip(first).chain(delta_extrema) {
            if s.is_finite() {
                let (terms, v) = poly(aj, &legendre(s));
                rows.le.push((terms.clone(), dmax - v));
                rows.le.push((negate(&terms), dmax + v));
            }
        }
        for s in grid.clone().chain([rate_extremum]) {
            if !s.is_finite() {
                continue;
            }
            // ±dδ/ds − χ_max·d ≤ 0.
            let (mut terms, v) = poly(aj, &legendre_slope(s));
            let d = p[dj];
            let mut neg = negate(&terms);
            terms.push((dj, -chimax * sc[dj]));
            neg.push((dj, -chimax * sc[dj]));
            rows.le.push((terms, chimax * d - v));
            rows.le.push((neg, chimax * d + v));
        }
        if let Some(at) = layout.thrust(j) {
            let (thrust_extrema, _) = critical_points(&p[at..at + NC]);
            for s in grid.clone().chain(thrust_extrema) {
                if s.is_finite() {
                    let (terms, v) = poly(at, &legendre(s));
                    rows.le.push((terms.clone(), thi - v));
                    rows.le.push((negate(&terms), v - tlo));
                }
            }
        }
        rows.le.push((vec![(dj, sc[dj])], seg.d_max_s - p[dj]));
        rows.le.push((vec![(dj, -sc[dj])], p[dj] - seg.d_min_s));
        if j == 0 {
            let (terms, v) = poly(aj, &legendre(0.0));
            rows.eq.push((terms, delta0 - v));
        }
        if j < last {
            let (mut terms, v1) = poly(aj, &legendre(1.0));
            let (next, v0) = poly(layout.delta(j + 1), &legendre(0.0));
            terms.extend(negate(&next));
            rows.eq.push((terms, v0 - v1));
        }
    }
    rows
}

fn negate(terms: &[(usize, f64)]) -> Vec<(usize, f64)> {
    terms.iter().map(|&(c, v)| (c, -v)).collect()
}

/// The linearized terminal conditions: rows of R⁻¹·J·S and R⁻¹·r.
#[derive(Debug, Clone, PartialEq)]
pub struct Terminal {
    pub jacobian: [Vec<f64>; 6],
    pub residual: [f64; 6],
}

/// What one QP asks for.
#[derive(Debug, Clone, PartialEq)]
pub struct Qp<'a> {
    pub rows: &'a Rows,
    /// None: a projection onto the linear constraints (no terminal rows, no
    /// mass objective).
    pub terminal: Option<&'a Terminal>,
    /// ∂(m_f/M)/∂Δp̂.
    pub mass_gradient: &'a [f64],
    pub trust_radius: f64,
    /// The weight ε of the proximal term ½·ε·‖Δp̂‖².
    pub proximal_weight: f64,
    /// The path rows a·Δp̂ − ν ≤ b ([`crate::polish::ground::rows`]),
    /// sharing one slack ν ≥ 0 weighted [`SLACK_WEIGHT`].
    pub path: &'a [(Vec<(usize, f64)>, f64)],
}

/// The QP's answer: the scaled step and the slacks' sum (scaled).
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    pub dp: Vec<f64>,
    pub slack: f64,
    pub iterations: u32,
}

/// Solve one QP with Clarabel. An error names Clarabel's status.
pub fn solve(qp: &Qp, n: usize) -> Result<Step, String> {
    let with_terminal = qp.terminal.is_some();
    let path_slack = n + if with_terminal { 12 } else { 0 };
    let nv = path_slack + usize::from(!qp.path.is_empty());
    // Objective.
    let mut q = vec![SLACK_WEIGHT; nv];
    for (q, g) in q.iter_mut().zip(qp.mass_gradient).take(n) {
        *q = if with_terminal { -g } else { 0.0 };
    }
    let p = objective_matrix(qp, n, nv);
    // Constraints: zero cone first, then the nonnegative cone.
    let (mut ar, mut ac, mut av, mut b) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut row = 0;
    let mut put = |terms: &[(usize, f64)], rhs: f64, row: &mut usize| {
        for &(c, v) in terms {
            ar.push(*row);
            ac.push(c);
            av.push(v);
        }
        b.push(rhs);
        *row += 1;
    };
    for (terms, rhs) in &qp.rows.eq {
        put(terms, *rhs, &mut row);
    }
    if let Some(t) = qp.terminal {
        for i in 0..6 {
            let mut terms: Vec<(usize, f64)> = t.jacobian[i]
                .iter()
                .enumerate()
                .filter(|(_, v)| **v != 0.0)
                .map(|(c, &v)| (c, v))
                .collect();
            terms.push((n + i, -1.0));
            terms.push((n + 6 + i, 1.0));
            put(&terms, -t.residual[i], &mut row);
        }
    }
    let n_eq = row;
    // A row that no step within the trust box can reach is left out: it
    // changes nothing in the answer, and most of the grid's rows are far
    // from their bounds (Σ|a_i|·Δ < b: the row holds on the whole box).
    for (terms, rhs) in &qp.rows.le {
        let reach: f64 = terms.iter().map(|(_, v)| v.abs()).sum::<f64>() * qp.trust_radius;
        if reach >= *rhs {
            put(terms, *rhs, &mut row);
        }
    }
    for (terms, rhs) in qp.path {
        let mut terms = terms.clone();
        terms.push((path_slack, -1.0));
        put(&terms, *rhs, &mut row);
    }
    for i in 0..n {
        put(&[(i, 1.0)], qp.trust_radius, &mut row);
        put(&[(i, -1.0)], qp.trust_radius, &mut row);
    }
    for i in n..nv {
        put(&[(i, -1.0)], 0.0, &mut row);
    }
    let a = CscMatrix::new_from_triplets(row, nv, ar, ac, av);
    let cones = [
        SupportedConeT::ZeroConeT(n_eq),
        SupportedConeT::NonnegativeConeT(row - n_eq),
    ];
    // Fewer and looser refinement steps of the KKT solves than Clarabel's
    // defaults (10 steps to 1e-13): the step is judged by the shot itself,
    // and refinement was a quarter of the polish's time. On 5 states
    // (valgrind --tool=callgrind, whole `bellyflop solve`): 8.5 % fewer
    // instructions, the same final masses to 0.6 kg.
    let settings = DefaultSettings {
        verbose: false,
        iterative_refinement_reltol: 1e-10,
        iterative_refinement_abstol: 1e-10,
        iterative_refinement_max_iter: 3,
        ..DefaultSettings::default()
    };
    let mut solver = DefaultSolver::new(&p, &q, &a, &b, &cones, settings)
        .map_err(|e| format!("Clarabel setup failed: {e}"))?;
    solver.solve();
    let sol = &solver.solution;
    match sol.status {
        // Insufficient progress still leaves Clarabel's best iterate; the
        // caller judges every step by the shot itself (the ratio test, or
        // the residual for the projection and the corrections).
        SolverStatus::Solved | SolverStatus::AlmostSolved | SolverStatus::InsufficientProgress
            if sol.x.iter().all(|v| v.is_finite()) =>
        {
            Ok(Step {
                dp: sol.x[..n].to_vec(),
                slack: sol.x[n..path_slack].iter().sum(),
                iterations: sol.iterations,
            })
        }
        other => Err(format!("Clarabel status {other:?}")),
    }
}

/// ½·ε·‖Δp̂‖² in Clarabel's CSC form (zero on the slacks).
fn objective_matrix(qp: &Qp, n: usize, nv: usize) -> CscMatrix<f64> {
    let diagonal: Vec<usize> = (0..n).collect();
    CscMatrix::new_from_triplets(
        nv,
        nv,
        diagonal.clone(),
        diagonal,
        vec![qp.proximal_weight; n],
    )
}
