//! Whether an answer respects its path constraints along the whole flight,
//! in continuous time: what `solved` claims besides the landing.
//!
//! - **Ground:** z(t) ≥ z_f on [0, t_f], the first contact at t_f. The
//!   answer's controls are integrated again (DOP853 at 1e-10, its steps at
//!   most [`STEP_S`], the flown controls of a polished answer, else those of
//!   the landing check), and between two accepted steps z is the cubic
//!   Hermite interpolant of (z, Vz) at both (error O(h⁴), ~1e-7 m at
//!   0.05 s); its interior minima count. The floor is the lower of z_f and
//!   z(t_f), less [`GROUND_TOLERANCE_M`]: nothing before the touchdown is
//!   lower than the touchdown itself.
//! - **Controls:** T ∈ [T_min, T_max], |δ| ≤ δ_max, |χ| ≤ χ_max, exactly
//!   over every piece of the flown controls (each cubic by its ends and
//!   its interior extrema, [`crate::flown::Signal::range`]); for an
//!   unpolished answer, over its node values (the landing check's PCHIP
//!   does not overshoot them). Each within [`CONTROL_TOLERANCE`] of its
//!   bound's scale (T_max − T_min, δ_max, χ_max).
//! - **Mass:** m(t_f) ≥ m_dry (m falls monotonically).
//! - **Operational constraints** (issue 37, [`crate::problem::constraints`]):
//!   each row g(y) ≤ 0 at every step of the integration, then at 1/4, 1/2
//!   and 3/4 of each step, where x, z and θ are the cubic Hermite
//!   interpolants of (x, Vx), (z, Vz), (θ, w) and Vx, w are linear (their
//!   error O(h²·ÿ)/8: the steps are at most [`LIMIT_STEP_S`] when the
//!   scenario has constraints). Each within [`LIMIT_TOLERANCE`] of its
//!   rows' scale.

use crate::input::scenario::Scenario;
use crate::problem::constraints::{self, Row};
use crate::problem::dynamics::ix;
use crate::problem::dynamics::Model;
use crate::solution::{LimitReport, PathReport, Solution, Status, GROUND_TOLERANCE_M};
use crate::verify::ode::{Dop853, IntegrationError};
use crate::verify::propagate::{self, Options};

/// Largest step of the ground check's integration \[s\].
pub const STEP_S: f64 = 0.05;

/// Largest step of the integration when the scenario has operational
/// constraints \[s\]: their states are interpolated between steps.
pub const LIMIT_STEP_S: f64 = 0.01;

/// How far an operational constraint's row may stand above 0, as a
/// fraction of its scale ([`crate::problem::constraints::Row::scale`]):
/// 1 mm in the cone (the ground's [`GROUND_TOLERANCE_M`]), 0.03°/s at a
/// 30°/s pitch-rate limit, 2 mm/s at a 2 m/s lateral limit. The polish's
/// RK4 at 0.05 s and this check's DOP853 differ by ~1e-4 of the scale
/// (measured: 2.9e-4 m/s in Vx on the paper's case), so a tighter
/// tolerance would judge the integrators, not the answer.
pub const LIMIT_TOLERANCE: f64 = 1e-3;

/// How far a control may stand beyond its bound, as a fraction of the
/// bound's scale: rounding.
pub const CONTROL_TOLERANCE: f64 = 1e-9;

/// The cubic Hermite basis (h₀₀, h₁₀, h₀₁, h₁₁) at s ∈ [0, 1].
pub fn hermite_basis(s: f64) -> [f64; 4] {
    let (s2, s3) = (s * s, s * s * s);
    [
        2.0 * s3 - 3.0 * s2 + 1.0,
        s3 - 2.0 * s2 + s,
        -2.0 * s3 + 3.0 * s2,
        s3 - s2,
    ]
}

/// The interior minimum of the cubic Hermite interpolant
/// H(s) = h₀₀·z0 + h₁₀·h·v0 + h₀₁·z1 + h₁₁·h·v1 through (z0, v0) and
/// (z1, v1) over a step of h seconds, when it lies below both ends:
/// (s, H(s)).
pub fn hermite_minimum(z0: f64, v0: f64, z1: f64, v1: f64, h: f64) -> Option<(f64, f64)> {
    // H'(s) = a·s² + b·s + c.
    let a = 6.0 * z0 + 3.0 * h * v0 - 6.0 * z1 + 3.0 * h * v1;
    let b = -6.0 * z0 - 4.0 * h * v0 + 6.0 * z1 - 2.0 * h * v1;
    let c = h * v0;
    let value = |s: f64| {
        let w = hermite_basis(s);
        w[0] * z0 + w[1] * h * v0 + w[2] * z1 + w[3] * h * v1
    };
    let mut roots = [f64::NAN; 2];
    if a.abs() <= 1e-14 * (b.abs() + c.abs()) {
        if b != 0.0 {
            roots[0] = -c / b;
        }
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc >= 0.0 {
            // The numerically stable pair of roots.
            let q = -0.5 * (b + b.signum() * disc.sqrt());
            roots = [q / a, if q != 0.0 { c / q } else { f64::NAN }];
        }
    }
    roots
        .into_iter()
        .filter(|&s| s > 0.0 && s < 1.0 && 2.0 * a * s + b > 0.0)
        .map(|s| (s, value(s)))
        .filter(|&(_, v)| v < z0.min(z1))
        .min_by(|x, y| x.1.total_cmp(&y.1))
}

/// Measure the answer's flight (module docs).
pub fn measure(scenario: &Scenario, sol: &Solution) -> Result<PathReport, IntegrationError> {
    let rows = constraints::rows(scenario);
    let options = Options {
        integrator: Dop853 {
            h_max: if rows.is_empty() {
                STEP_S
            } else {
                LIMIT_STEP_S
            },
            ..Dop853::default()
        },
        ..Options::default()
    };
    let p = propagate::propagate(scenario, sol, &options)?;
    let limits = limit_reports(&rows, &p.t_s, &p.states);
    let z_f = scenario.terminal.z_m;
    let tf = *p.t_s.last().unwrap_or(&0.0);
    let end = p.final_state();
    let floor = z_f.min(end[1]) - GROUND_TOLERANCE_M;
    let mut lowest = (f64::INFINITY, 0.0);
    let mut before_last_second = f64::INFINITY;
    let mut visit = |t: f64, z: f64| {
        if z < lowest.0 {
            lowest = (z, t);
        }
        if t <= tf - 1.0 {
            before_last_second = before_last_second.min(z - z_f);
        }
    };
    for k in 0..p.t_s.len() {
        let (t1, y1) = (p.t_s[k], p.states[k]);
        visit(t1, y1[1]);
        if k > 0 {
            let (t0, y0) = (p.t_s[k - 1], p.states[k - 1]);
            let h = t1 - t0;
            if h > 0.0 {
                if let Some((s, z)) = hermite_minimum(y0[1], y0[3], y1[1], y1[3], h) {
                    visit(t0 + s * h, z);
                }
            }
        }
    }
    let (thrust, gimbal, rate) = control_ranges(sol);
    Ok(PathReport {
        min_clearance_m: lowest.0 - z_f,
        min_clearance_before_last_second_m: before_last_second,
        ground_contact_t_s: (lowest.0 < floor).then_some(lowest.1),
        thrust_min_n: thrust.0,
        thrust_max_n: thrust.1,
        gimbal_max_rad: gimbal,
        gimbal_rate_max_radps: rate,
        final_mass_kg: end[6],
        limits,
    })
}

/// Each limit's worst row value along a track of states at times `t_s`,
/// at each state and at 1/4, 1/2 and 3/4 between two (module docs).
pub fn limit_reports(rows: &[Row], t_s: &[f64], states: &[[f64; 7]]) -> Vec<LimitReport> {
    let mut out: Vec<LimitReport> = Vec::new();
    let mut visit = |t: f64, y: &[f64; 7]| {
        for r in rows {
            let g = r.value(y);
            match out.iter_mut().find(|l| l.limit == r.limit) {
                Some(l) if g > l.worst || l.worst.is_nan() => (l.worst, l.t_s) = (g, t),
                Some(_) => {}
                None => out.push(LimitReport {
                    limit: r.limit,
                    worst: g,
                    t_s: t,
                    scale: r.scale(),
                }),
            }
        }
    };
    for k in 0..t_s.len() {
        visit(t_s[k], &states[k]);
        if k == 0 {
            continue;
        }
        let (y0, y1, h) = (&states[k - 1], &states[k], t_s[k] - t_s[k - 1]);
        if h <= 0.0 {
            continue;
        }
        for s in [0.25, 0.5, 0.75] {
            let w = hermite_basis(s);
            let cubic = |p: usize, v: usize| {
                w[0] * y0[p] + w[1] * h * y0[v] + w[2] * y1[p] + w[3] * h * y1[v]
            };
            let mut y = [0.0; 7];
            for i in 0..7 {
                y[i] = (1.0 - s) * y0[i] + s * y1[i];
            }
            y[ix::X] = cubic(ix::X, ix::VX);
            y[ix::Z] = cubic(ix::Z, ix::VZ);
            y[ix::THETA] = cubic(ix::THETA, ix::W);
            visit(t_s[k - 1] + s * h, &y);
        }
    }
    out
}

/// ((T min, T max), max |δ|, max |χ|) of the answer's controls.
fn control_ranges(sol: &Solution) -> ((f64, f64), f64, f64) {
    let abs_max = |(lo, hi): (f64, f64)| lo.abs().max(hi.abs());
    let merge = |a: (f64, f64), b: (f64, f64)| (a.0.min(b.0), a.1.max(b.1));
    let empty = (f64::INFINITY, f64::NEG_INFINITY);
    match &sol.controls_flown {
        Some(flown) => flown.pieces.iter().fold(
            (empty, 0.0_f64, 0.0_f64),
            |(thrust, gimbal, rate), piece| {
                let d = piece.t_end_s - piece.t_start_s;
                let slope = piece.delta_rad.slope_range();
                let chi = if d > 0.0 { abs_max(slope) / d } else { 0.0 };
                (
                    merge(thrust, piece.thrust_n.range()),
                    gimbal.max(abs_max(piece.delta_rad.range())),
                    rate.max(chi),
                )
            },
        ),
        None => {
            let range = |v: &[f64]| v.iter().fold(empty, |r, &x| merge(r, (x, x)));
            (
                range(&sol.thrust_n),
                abs_max(range(&sol.delta_rad)),
                abs_max(range(&sol.gimbal_rate_radps)),
            )
        }
    }
}

/// The constraints that the report breaks, each a sentence naming the
/// constraint, the value and the bound; empty when the path holds.
pub fn violations(report: &PathReport, model: &Model) -> Vec<String> {
    // Written so that a NaN breaks each bound.
    let at_most = |value: f64, limit: f64| value <= limit;
    let mut out = Vec::new();
    if let Some(t) = report.ground_contact_t_s {
        out.push(format!(
            "the flight goes {:.3} m below the landing altitude at t = {t:.2} s, before its touchdown",
            -report.min_clearance_m
        ));
    }
    let t_tol = CONTROL_TOLERANCE * (model.max_thrust_n - model.min_thrust_n);
    if !at_most(model.min_thrust_n - t_tol, report.thrust_min_n) {
        out.push(format!(
            "the thrust falls to {:.1} N, below T_min = {:.1} N",
            report.thrust_min_n, model.min_thrust_n
        ));
    }
    if !at_most(report.thrust_max_n, model.max_thrust_n + t_tol) {
        out.push(format!(
            "the thrust reaches {:.1} N, above T_max = {:.1} N",
            report.thrust_max_n, model.max_thrust_n
        ));
    }
    let dmax = model.max_gimbal_rad;
    if !at_most(report.gimbal_max_rad, dmax * (1.0 + CONTROL_TOLERANCE)) {
        out.push(format!(
            "the gimbal angle reaches {:.4}°, beyond δ_max = {:.4}° by {:.1e} of it",
            report.gimbal_max_rad.to_degrees(),
            dmax.to_degrees(),
            report.gimbal_max_rad / dmax - 1.0
        ));
    }
    let chimax = model.max_gimbal_rate_radps;
    if !at_most(
        report.gimbal_rate_max_radps,
        chimax * (1.0 + CONTROL_TOLERANCE),
    ) {
        out.push(format!(
            "the gimbal rate reaches {:.4}°/s, beyond χ_max = {:.4}°/s by {:.1e} of it",
            report.gimbal_rate_max_radps.to_degrees(),
            chimax.to_degrees(),
            report.gimbal_rate_max_radps / chimax - 1.0
        ));
    }
    for l in &report.limits {
        if !at_most(l.worst, LIMIT_TOLERANCE * l.scale) {
            out.push(format!(
                "the flight breaks {} by {:.3e} {} at t = {:.2} s",
                l.limit.describe(),
                l.worst,
                l.limit.unit(),
                l.t_s
            ));
        }
    }
    if !at_most(model.dry_mass_kg, report.final_mass_kg) {
        out.push(format!(
            "the final mass {:.1} kg is below the dry mass {:.1} kg",
            report.final_mass_kg, model.dry_mass_kg
        ));
    }
    out
}

/// Measure the path of a `solved` or `inaccurate` answer into
/// [`Solution::path`], and demote a `solved` one that breaks a path
/// constraint to `inaccurate`, naming each (or that it could not be
/// measured). Other statuses are left alone.
pub fn check(scenario: &Scenario, sol: &mut Solution) {
    if !matches!(sol.status, Status::Solved | Status::Inaccurate) {
        return;
    }
    let model = Model::new(&scenario.vehicle, &scenario.environment);
    let broken = match measure(scenario, sol) {
        Ok(report) => {
            let broken = violations(&report, &model);
            sol.path = Some(report);
            broken
        }
        Err(e) => vec![format!(
            "the path could not be measured by re-integration ({e})"
        )],
    };
    if sol.status == Status::Solved && !broken.is_empty() {
        sol.status = Status::Inaccurate;
        sol.message = format!(
            "the answer breaks a path constraint along its flight: {}",
            broken.join("; ")
        );
    }
}
