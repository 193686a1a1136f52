//! One convex subproblem of the polish, a QP solved by our dense active-set
//! method ([`crate::polish::active_set`]), or where it fails by our dense
//! interior point ([`crate::polish::qp`]).
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

use crate::flown::{critical_points, legendre, legendre_slope};
use crate::polish::qp::Row;
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

/// The slacks' curvature: a slack ν weighs w·ν + ½·γ·ν², so that the QP is
/// strictly convex, as the active-set method needs
/// ([`crate::polish::active_set`]). Its effect on a multiplier is γ·ν, below
/// 1e-5 of w for every slack the polish sees (ν ≤ 10).
pub const SLACK_CURVATURE: f64 = 1e-4;

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
/// rows only to its solver's tolerances, so the rows stand this far inside
/// and the answer is within its bounds to rounding. (At 1e-7, χ ended
/// 1e-7 to 3.4e-7 of χ_max beyond it on 3 of 300 seeded states,
/// `bench/safety.py`; at 1e-6, on none.)
pub const BOUND_MARGIN: f64 = 1e-6;

/// The gimbal rate's rows stand this many times [`BOUND_MARGIN`] inside
/// their bound (1e-4 of χ_max, 0.002°/s). Where the rate rides its bound
/// through the flip, each step moves the slope's extremum, and the
/// active-set QP puts the rows exactly on their bounds: the shifted
/// extremum then bulged past χ_max by up to 4e-5 of it on 6 of 300 seeded
/// states (`bench/safety.py`), and those answers failed their checks.
pub const RATE_MARGIN_FACTOR: f64 = 100.0;

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
    bound_rows(layout, model, scales, p, delta0, BOUND_MARGIN, None)
}

/// [`linear_rows`] with the bounds `margin` inside (0: the bounds
/// themselves), and with rows also at the interior extrema of the
/// polynomials of `also` (a step from p whose extrema moved).
pub fn bound_rows(
    layout: &Layout,
    model: &Model,
    scales: &Scales,
    p: &[f64],
    delta0: f64,
    margin: f64,
    also: Option<&[f64]>,
) -> Rows {
    let sc = &scales.0;
    // The interior extrema of the polynomial at `at`, of p and of `also`.
    let extrema = |at: usize| {
        let (mut values, mut slopes) = (Vec::new(), Vec::new());
        for q in std::iter::once(p).chain(also) {
            let (v, r) = critical_points(&q[at..at + NC]);
            values.extend(v);
            slopes.push(r);
        }
        (values, slopes)
    };
    let mut rows = Rows::default();
    let poly = |at: usize, basis: &[f64; NC]| -> (Vec<(usize, f64)>, f64) {
        let terms = (0..NC).map(|k| (at + k, basis[k] * sc[at + k])).collect();
        let value = (0..NC).map(|k| basis[k] * p[at + k]).sum();
        (terms, value)
    };
    let dmax = model.max_gimbal_rad * (1.0 - margin);
    let chimax = model.max_gimbal_rate_radps * (1.0 - RATE_MARGIN_FACTOR * margin);
    let margin_t = margin * (model.max_thrust_n - model.min_thrust_n);
    let (tlo, thi) = (model.min_thrust_n + margin_t, model.max_thrust_n - margin_t);
    let last = layout.segments.len() - 1;
    let grid = (0..GRID).map(|g| g as f64 / (GRID - 1) as f64);
    for (j, seg) in layout.segments.iter().enumerate() {
        let (dj, aj) = (layout.duration(j), layout.delta(j));
        let (delta_extrema, rate_extrema) = extrema(aj);
        // δ(0) of the first segment is δ_0, fixed by an equality.
        let first = usize::from(j == 0);
        for s in grid.clone().skip(first).chain(delta_extrema) {
            if s.is_finite() {
                let (terms, v) = poly(aj, &legendre(s));
                rows.le.push((terms.clone(), dmax - v));
                rows.le.push((negate(&terms), dmax + v));
            }
        }
        for s in grid.clone().chain(rate_extrema) {
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
            let (thrust_extrema, _) = extrema(at);
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
    /// The multipliers of the six terminal rows (zero without them), in
    /// the QP's convention: its Lagrangian adds λᵀ·(r̂ + J·S·Δp̂ − ν⁺ + ν⁻).
    pub multipliers: [f64; 6],
    /// The largest multiplier of the path rows (0: none active).
    pub path_multiplier: f64,
    pub slack: f64,
    pub iterations: u32,
}

/// Solve one QP with the dense interior point ([`crate::polish::qp`]).
/// An error says why it failed.
pub fn solve(qp: &Qp, n: usize) -> Result<Step, String> {
    let with_terminal = qp.terminal.is_some();
    let path_slack = n + if with_terminal { 12 } else { 0 };
    let nv = path_slack + usize::from(!qp.path.is_empty());
    let mut q = vec![SLACK_WEIGHT; nv];
    for (q, g) in q.iter_mut().zip(qp.mass_gradient).take(n) {
        *q = if with_terminal { -g } else { 0.0 };
    }
    let mut diagonal = vec![SLACK_CURVATURE; nv];
    diagonal[..n].fill(qp.proximal_weight);
    let mut eq: Vec<Row> = qp.rows.eq.clone();
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
            eq.push((terms, -t.residual[i]));
        }
    }
    // A row that no step within the trust box can reach is left out: it
    // changes nothing in the answer, and most of the grid's rows are far
    // from their bounds (Σ|a_i|·Δ < b: the row holds on the whole box).
    let mut le: Vec<Row> = qp
        .rows
        .le
        .iter()
        .filter(|(terms, rhs)| {
            terms.iter().map(|(_, v)| v.abs()).sum::<f64>() * qp.trust_radius >= *rhs
        })
        .cloned()
        .collect();
    let path_rows = le.len()..le.len() + qp.path.len();
    for (terms, rhs) in qp.path {
        let mut terms = terms.clone();
        terms.push((path_slack, -1.0));
        le.push((terms, *rhs));
    }
    for i in 0..n {
        le.push((vec![(i, 1.0)], qp.trust_radius));
        le.push((vec![(i, -1.0)], qp.trust_radius));
    }
    for i in n..nv {
        le.push((vec![(i, -1.0)], 0.0));
    }
    let problem = crate::polish::qp::Problem {
        p: &diagonal,
        q: &q,
        eq: &eq,
        le: &le,
    };
    // The active-set method first; the interior point where it fails.
    let answer = crate::polish::active_set::solve(&problem)
        .or_else(|_| crate::polish::qp::solve(&problem))
        .map_err(|e| e.to_string())?;
    let at = qp.rows.eq.len();
    let multipliers = std::array::from_fn(|i| if with_terminal { answer.y[at + i] } else { 0.0 });
    Ok(Step {
        multipliers,
        path_multiplier: answer.z[path_rows].iter().copied().fold(0.0, f64::max),
        slack: answer.x[n..path_slack].iter().sum(),
        dp: answer.x[..n].to_vec(),
        iterations: answer.iterations,
    })
}
