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
/// polynomials of `also` (a step from p whose extrema moved:
/// [`extrema_rows`]).
pub fn bound_rows(
    layout: &Layout,
    model: &Model,
    scales: &Scales,
    p: &[f64],
    delta0: f64,
    margin: f64,
    also: Option<&[f64]>,
) -> Rows {
    let bounds = Bounds::new(model, scales, p, margin, delta0);
    let mut rows = Rows::default();
    let last = layout.segments.len() - 1;
    let grid = || (0..GRID).map(|g| g as f64 / (GRID - 1) as f64);
    for (j, seg) in layout.segments.iter().enumerate() {
        let (dj, aj) = (layout.duration(j), layout.delta(j));
        let (delta_extrema, rate_extrema) = critical_points(&p[aj..aj + NC]);
        // δ(0) of the first segment is δ_0, fixed by an equality.
        let first = usize::from(j == 0);
        bounds.delta(j, aj, grid().skip(first).chain(delta_extrema), &mut rows);
        bounds.rate(aj, dj, grid().chain([rate_extrema]), &mut rows);
        if let Some(at) = layout.thrust(j) {
            let (thrust_extrema, _) = critical_points(&p[at..at + NC]);
            bounds.thrust(at, grid().chain(thrust_extrema), &mut rows);
        }
        rows.le
            .push((vec![(dj, bounds.sc[dj])], seg.d_max_s - p[dj]));
        rows.le
            .push((vec![(dj, -bounds.sc[dj])], p[dj] - seg.d_min_s));
        if j == 0 {
            let (terms, v) = bounds.poly(aj, &legendre(0.0));
            rows.eq.push((terms, delta0 - v));
        }
        if j < last {
            let (mut terms, v1) = bounds.poly(aj, &legendre(1.0));
            let (next, v0) = bounds.poly(layout.delta(j + 1), &legendre(0.0));
            terms.extend(negate(&next));
            rows.eq.push((terms, v0 - v1));
        }
    }
    if let Some(q) = also {
        rows.le
            .extend(extrema_rows(layout, model, scales, p, (margin, delta0), q));
    }
    rows
}

/// The bound rows of T, δ and χ linearized at p, `margin` inside (δ on
/// the first segment as the start δ₀ allows, [`bound_rows`]), at the
/// interior extrema of the polynomials of q (only there: [`bound_rows`]
/// adds the grid).
pub fn extrema_rows(
    layout: &Layout,
    model: &Model,
    scales: &Scales,
    p: &[f64],
    (margin, delta0): (f64, f64),
    q: &[f64],
) -> Vec<(Vec<(usize, f64)>, f64)> {
    let bounds = Bounds::new(model, scales, p, margin, delta0);
    let mut rows = Rows::default();
    for j in 0..layout.segments.len() {
        let (dj, aj) = (layout.duration(j), layout.delta(j));
        let (delta_extrema, rate_extrema) = critical_points(&q[aj..aj + NC]);
        bounds.delta(j, aj, delta_extrema.into_iter(), &mut rows);
        bounds.rate(aj, dj, std::iter::once(rate_extrema), &mut rows);
        if let Some(at) = layout.thrust(j) {
            let (thrust_extrema, _) = critical_points(&q[at..at + NC]);
            bounds.thrust(at, thrust_extrema.into_iter(), &mut rows);
        }
    }
    rows.le
}

/// The bounds of T, δ and χ, `margin` inside, as rows linearized at p.
struct Bounds<'a> {
    sc: &'a [f64],
    p: &'a [f64],
    delta_max: f64,
    /// |δ| on the first segment: `delta_max`, or |δ₀| where δ₀ lies
    /// within the margin of its bound. δ(0) = δ₀ is fixed there, and the
    /// margin's rows next to s = 0 would ask for a slope that the rate
    /// bound forbids: measured, the projection QP of a start at δ_max
    /// (`fuzz/corpus/scenario/gimbal_at_limit.toml`) was inconsistent and
    /// the polish failed.
    first_delta_max: f64,
    rate_max: f64,
    thrust: (f64, f64),
}

impl<'a> Bounds<'a> {
    fn new(model: &Model, scales: &'a Scales, p: &'a [f64], margin: f64, delta0: f64) -> Self {
        let margin_t = margin * (model.max_thrust_n - model.min_thrust_n);
        let delta_max = model.max_gimbal_rad * (1.0 - margin);
        Bounds {
            sc: &scales.0,
            p,
            delta_max,
            first_delta_max: delta_max.max(delta0.abs().min(model.max_gimbal_rad)),
            rate_max: model.max_gimbal_rate_radps * (1.0 - RATE_MARGIN_FACTOR * margin),
            thrust: (model.min_thrust_n + margin_t, model.max_thrust_n - margin_t),
        }
    }

    /// The terms of Σ basis_k·Δp̂_{at+k} (scaled) and Σ basis_k·p_{at+k}.
    fn poly(&self, at: usize, basis: &[f64; NC]) -> (Vec<(usize, f64)>, f64) {
        let terms = (0..NC)
            .map(|k| (at + k, basis[k] * self.sc[at + k]))
            .collect();
        let value = (0..NC).map(|k| basis[k] * self.p[at + k]).sum();
        (terms, value)
    }

    /// |δ(s)| ≤ δ_max on segment j at the finite points s.
    fn delta(&self, j: usize, at: usize, points: impl Iterator<Item = f64>, rows: &mut Rows) {
        let limit = if j == 0 {
            self.first_delta_max
        } else {
            self.delta_max
        };
        for s in points.filter(|s| s.is_finite()) {
            let (terms, v) = self.poly(at, &legendre(s));
            rows.le.push((terms.clone(), limit - v));
            rows.le.push((negate(&terms), limit + v));
        }
    }

    /// ±dδ/ds − χ_max·d ≤ 0 at the finite points s.
    fn rate(&self, at: usize, dj: usize, points: impl Iterator<Item = f64>, rows: &mut Rows) {
        let (chimax, d) = (self.rate_max, self.p[dj]);
        for s in points.filter(|s| s.is_finite()) {
            let (mut terms, v) = self.poly(at, &legendre_slope(s));
            let mut neg = negate(&terms);
            terms.push((dj, -chimax * self.sc[dj]));
            neg.push((dj, -chimax * self.sc[dj]));
            rows.le.push((terms, chimax * d - v));
            rows.le.push((neg, chimax * d + v));
        }
    }

    /// T_min ≤ T(s) ≤ T_max at the finite points s.
    fn thrust(&self, at: usize, points: impl Iterator<Item = f64>, rows: &mut Rows) {
        let (lo, hi) = self.thrust;
        for s in points.filter(|s| s.is_finite()) {
            let (terms, v) = self.poly(at, &legendre(s));
            rows.le.push((terms.clone(), hi - v));
            rows.le.push((negate(&terms), v - lo));
        }
    }
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
    /// The Lagrangian's Hessian in Δp̂ (n², row-major), added to ε·I: the
    /// QP's curvature is then ½·Δp̂ᵀ·(Ĥ + ε·I)·Δp̂, which must be positive
    /// definite. None: the proximal term alone.
    pub hessian: Option<&'a [f64]>,
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

/// Solve one QP: first with the terminal and path rows hard (no slacks:
/// thirteen fewer variables, and the twelve slack bounds the active-set
/// method would otherwise add one by one); where that form is infeasible,
/// or a multiplier of those rows exceeds the slacks' weight (the elastic
/// form would then pay for a slack), the elastic form of the module docs.
/// Where the hard form answers, it is the elastic form's answer exactly:
/// its point with ν = 0 meets the elastic form's KKT conditions (each
/// terminal multiplier within ±w, the path ones summing to at most w), and
/// that QP is strictly convex. An error says why the QP failed.
pub fn solve(qp: &Qp, n: usize) -> Result<Solved, String> {
    if qp.terminal.is_some() {
        if let Ok(solved) = Solved::new(qp, n, Form::Hard) {
            if solved.within {
                return Ok(solved);
            }
        }
    }
    Solved::new(qp, n, Form::Elastic)
}

/// The terminal and path rows with slacks (elastic) or without (hard).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Form {
    Hard,
    Elastic,
}

/// A solved QP ([`solve`]) that may take more bound rows ([`Solved::add`]).
pub struct Solved {
    pub step: Step,
    /// The active-set method's state, where it answered.
    solver: Option<crate::polish::active_set::Solver>,
    form: Form,
    n: usize,
    /// Where the terminal rows start among the equalities.
    terminal_at: usize,
    with_terminal: bool,
    path_rows: std::ops::Range<usize>,
    slacks: std::ops::Range<usize>,
    trust_radius: f64,
    /// Whether the terminal and path multipliers are within the slacks'
    /// weight ([`solve`]).
    within: bool,
}

impl Solved {
    /// [`solve`] in one form.
    fn new(qp: &Qp, n: usize, form: Form) -> Result<Self, String> {
        let elastic = form == Form::Elastic;
        let with_terminal = qp.terminal.is_some();
        let terminal_slacks = if with_terminal && elastic { 12 } else { 0 };
        let path_slack = n + terminal_slacks;
        let nv = path_slack + usize::from(elastic && !qp.path.is_empty());
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
                if elastic {
                    terms.push((n + i, -1.0));
                    terms.push((n + 6 + i, 1.0));
                }
                eq.push((terms, -t.residual[i]));
            }
        }
        let mut le: Vec<Row> = reachable(&qp.rows.le, qp.trust_radius);
        let path_rows = le.len()..le.len() + qp.path.len();
        for (terms, rhs) in qp.path {
            let mut terms = terms.clone();
            if elastic {
                terms.push((path_slack, -1.0));
            }
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
            dense: qp.hessian,
            p: &diagonal,
            q: &q,
            eq: &eq,
            le: &le,
        };
        // The active-set method first; in the elastic form the interior
        // point where it fails (the hard form's failure sends the QP to the
        // elastic one instead).
        let (answer, solver) = match crate::polish::active_set::Solver::new(&problem) {
            Ok(solver) => (solver.answer(), Some(solver)),
            Err(e) if !elastic => return Err(e.to_string()),
            Err(_) => (
                crate::polish::qp::solve(&problem).map_err(|e| e.to_string())?,
                None,
            ),
        };
        let mut solved = Solved {
            step: Step {
                dp: Vec::new(),
                multipliers: [0.0; 6],
                path_multiplier: 0.0,
                slack: 0.0,
                iterations: 0,
            },
            solver,
            form,
            n,
            terminal_at: qp.rows.eq.len(),
            with_terminal,
            path_rows,
            slacks: n..path_slack,
            trust_radius: qp.trust_radius,
            within: false,
        };
        solved.read(&answer, answer.iterations);
        Ok(solved)
    }

    /// The step and the multipliers' check from an answer that took
    /// `iterations` changes.
    fn read(&mut self, answer: &crate::polish::qp::Answer, iterations: u32) {
        let at = self.terminal_at;
        let with_terminal = self.with_terminal;
        let multipliers: [f64; 6] =
            std::array::from_fn(|i| if with_terminal { answer.y[at + i] } else { 0.0 });
        let path = &answer.z[self.path_rows.clone()];
        self.within = multipliers.iter().all(|y| y.abs() <= SLACK_WEIGHT)
            && path.iter().sum::<f64>() <= SLACK_WEIGHT;
        self.step = Step {
            multipliers,
            path_multiplier: path.iter().copied().fold(0.0, f64::max),
            slack: answer.x[self.slacks.clone()].iter().sum(),
            dp: answer.x[..self.n].to_vec(),
            iterations,
        };
    }

    /// The same QP with the bound rows `extra` too (in the step Δp̂),
    /// continued from this answer ([`crate::polish::active_set::Solver`]):
    /// false where it must be solved anew instead (no active-set state, the
    /// grown QP's hard form failed or asks for slacks).
    pub fn add(&mut self, extra: &[Row]) -> bool {
        let Some(solver) = self.solver.as_mut() else {
            return false;
        };
        let before = solver.changes();
        if solver.add(&reachable(extra, self.trust_radius)).is_err() {
            self.solver = None;
            return false;
        }
        let answer = solver.answer();
        self.read(&answer, answer.iterations - before);
        self.within || self.form == Form::Elastic
    }
}

impl Solved {
    /// The step that also removes the terminal residual `residual` (R⁻¹·r̂
    /// of the step's own landing, [`crate::polish`]'s second-order
    /// correction) on this answer's active set, from its factors
    /// ([`crate::polish::active_set::Solver::moved`]): the step Δp̂ + δ with
    /// J·S·δ = −`residual` and every active row kept. None in the elastic
    /// form (a slack would take the shift) or where it breaks a row.
    pub fn corrected(&self, residual: &[f64; 6]) -> Option<Vec<f64>> {
        if self.form != Form::Hard || !self.with_terminal {
            return None;
        }
        let moved: Vec<(usize, f64)> = (0..6)
            .map(|i| (self.terminal_at + i, -residual[i]))
            .collect();
        let x = self.solver.as_ref()?.moved(&moved)?;
        Some(x[..self.n].to_vec())
    }
}

/// The rows that a step within the trust box Δ can reach: a row with
/// Σ|a_i|·Δ < b holds on the whole box and changes nothing in the answer
/// (most of the grid's rows are far from their bounds).
fn reachable(rows: &[Row], trust_radius: f64) -> Vec<Row> {
    rows.iter()
        .filter(|(terms, rhs)| {
            terms.iter().map(|(_, v)| v.abs()).sum::<f64>() * trust_radius >= *rhs
        })
        .cloned()
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A QP of the polish's shape: n steps within a box, a few bound rows,
    /// six dense terminal rows with residual `r`, a path row.
    fn shaped(rng: &mut ChaCha8Rng, n: usize, r: f64) -> (Rows, Terminal, Vec<f64>, Vec<Row>) {
        let mut rows = Rows::default();
        for k in 0..n / 3 {
            rows.le
                .push((vec![(k, 1.0), (k + 1, -0.5)], rng.gen_range(0.0..0.3)));
        }
        rows.eq.push((vec![(0, 1.0), (n - 1, -1.0)], 0.0));
        let jacobian = std::array::from_fn(|_| (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect());
        let residual = std::array::from_fn(|_| r * rng.gen_range(-1.0..1.0));
        let gradient = (0..n).map(|_| rng.gen_range(-0.1..0.1)).collect();
        let path = vec![(
            (0..n).map(|c| (c, rng.gen_range(-1.0..1.0))).collect(),
            0.05,
        )];
        (rows, Terminal { jacobian, residual }, gradient, path)
    }

    /// Where the hard form answers within the slacks' weight, it is the
    /// elastic form's answer (module docs of [`solve`]); where the
    /// linearized landing is out of the box's reach, the elastic form
    /// answers, with slacks.
    #[test]
    fn the_hard_form_is_the_elastic_forms_answer() {
        let mut rng = ChaCha8Rng::seed_from_u64(38);
        let (mut hard, mut elastic) = (0, 0);
        for case in 0..60 {
            let n = rng.gen_range(12..40);
            let r = if case % 2 == 0 { 0.01 } else { 50.0 };
            let (rows, terminal, gradient, path) = shaped(&mut rng, n, r);
            let qp = Qp {
                rows: &rows,
                terminal: Some(&terminal),
                mass_gradient: &gradient,
                trust_radius: 0.5,
                proximal_weight: 0.3,
                hessian: None,
                path: &path,
            };
            let by_elastic = Solved::new(&qp, n, Form::Elastic).unwrap();
            let chosen = solve(&qp, n).unwrap();
            match Solved::new(&qp, n, Form::Hard) {
                Ok(h) if h.within => {
                    hard += 1;
                    assert_eq!(chosen.form, Form::Hard, "case {case}");
                    assert!(by_elastic.step.slack < 1e-9, "case {case}");
                    for (a, b) in h.step.dp.iter().zip(&by_elastic.step.dp) {
                        assert!((a - b).abs() < 1e-8, "case {case}: {a} {b}");
                    }
                    for (a, b) in h.step.multipliers.iter().zip(&by_elastic.step.multipliers) {
                        assert!((a - b).abs() < 1e-6 * (1.0 + b.abs()), "case {case}");
                    }
                }
                _ => {
                    elastic += 1;
                    assert_eq!(chosen.form, Form::Elastic, "case {case}");
                    assert!(by_elastic.step.slack > 1e-6, "case {case}");
                }
            }
        }
        assert!(hard > 20 && elastic > 20, "{hard} {elastic}");
    }
}
