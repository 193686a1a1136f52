//! The operational constraints (issue 37) along the polish's shot: each
//! smooth row g(y) ≤ 0 of [`crate::problem::constraints`] at the points of
//! the track ([`crate::polish::shooting::Track`], every RK4 step's end).
//!
//! Between two step ends g is smooth, so where g peaks (a step end k at
//! least as high as both neighbours, inside one segment) its peak is taken
//! from the parabola through g_{k−1}, g_k, g_{k+1} at equal spacing:
//!
//!   g* = g_k + a²/(8c),   a = g_{k+1} − g_{k−1},   c = 2g_k − g_{k−1} − g_{k+1},
//!
//! (error O(h³·g‴) against the true peak), with its gradient
//! ∂g* = ∂g_k + (a/4c)·∂a − (a²/8c²)·∂c. Every step end within
//! [`ACTIVE`] of its bound is a point too, so that an arc along the bound
//! is held at every step. The last point (t_f) is the terminal
//! conditions' (the cone's apex is the pad).
//!
//! Values join the ground's violation v(p) ([`crate::polish::ground`]) in
//! metres: g over the row's scale, times [`UNIT_M`], so that the polish's
//! path tolerance ([`crate::polish::PATH_TOLERANCE`], a tenth of the
//! ground check's) is a tenth of the flight check's
//! ([`crate::verify::path::LIMIT_TOLERANCE`]) on every row too.

use crate::polish::shooting::{Layout, Sensitivity, Track};
use crate::problem::constraints::{Limit, Row};

/// The metres of v(p) per unit of g/scale: the ground check's tolerance
/// over the limits'.
pub const UNIT_M: f64 = crate::solution::GROUND_TOLERANCE_M / crate::verify::path::LIMIT_TOLERANCE;

/// How far below its bound (relative to its scale) a step end is held as
/// a point of the QP, besides the peaks.
pub const ACTIVE: f64 = 1e-3;

/// The QP's rows hold each point this far inside its bound (relative): a
/// linearization met to the QP's tolerances would otherwise leave an
/// active point a little outside (second-order terms), as
/// [`crate::polish::ground::GROUND_MARGIN_M`] does for the ground, and the
/// RK4 steps' own error (~1e-4 of the scale against DOP853) would show in
/// the flight check. A tenth of its tolerance.
pub const MARGIN: f64 = 1e-4;

/// How many times finer the RK4 steps are when a row is triggered by the
/// altitude: its softplus turns over σ = 1 m, 0.1 s at 10 m/s, where g''
/// reaches S·ż²/(4σ) (25 m/s³ in the final descent's row): at the 0.05 s
/// steps the parabola through three step ends missed the peak by 3e-3 m/s
/// against the flight check (measured on the paper's case with a 1 m/s
/// limit below 50 m); at 0.01 s, by O(h³·g‴) ≈ 1e-5.
pub const TRIGGERED_REFINEMENT: usize = 5;

/// The layout with [`TRIGGERED_REFINEMENT`] times the steps in every
/// segment when a row is altitude-triggered, else as it is.
pub fn resolved(mut layout: Layout, rows: &[Row]) -> Layout {
    if rows.iter().any(|r| !r.is_affine()) {
        for s in &mut layout.segments {
            s.steps *= TRIGGERED_REFINEMENT;
        }
    }
    layout
}

/// A point of one row: its value (the parabola's peak or the step end's)
/// and the weights of g at k−1, k, k+1 in its first-order change.
struct Point {
    k: usize,
    value: f64,
    weights: [f64; 3],
}

/// The points of row `r` on a track (module docs).
fn points(track: &Track, row: &Row, mut visit: impl FnMut(Point)) {
    let n = track.len();
    if n < 3 {
        return;
    }
    let g: Vec<f64> = track.states.iter().map(|y| row.value(y)).collect();
    let near = -ACTIVE * row.scale();
    for k in 1..n - 1 {
        let peak = g[k] >= g[k - 1] && g[k] >= g[k + 1];
        let even = track.segment[k] == track.segment[k + 1]
            && (track.h_s[k] - track.h_s[k + 1]).abs() <= 1e-12 * track.h_s[k];
        let c = 2.0 * g[k] - g[k - 1] - g[k + 1];
        if peak && even && c > 0.0 {
            let a = g[k + 1] - g[k - 1];
            // ∂g* = ∂g_k + (a/4c)(∂g_{k+1} − ∂g_{k−1}) − (a²/8c²)(2∂g_k − ∂g_{k−1} − ∂g_{k+1}).
            let (u, v) = (a / (4.0 * c), a * a / (8.0 * c * c));
            visit(Point {
                k,
                value: g[k] + a * a / (8.0 * c),
                weights: [v - u, 1.0 - 2.0 * v, u + v],
            });
        } else if peak || g[k] > near {
            visit(Point {
                k,
                value: g[k],
                weights: [0.0, 1.0, 0.0],
            });
        }
    }
}

/// The largest value of the rows along a track, in v's metres (0 when
/// every row holds).
pub fn violation(track: &Track, rows: &[Row]) -> f64 {
    let mut v = 0.0f64;
    for row in rows {
        points(track, row, |p| v = v.max(p.value / row.scale() * UNIT_M));
    }
    v
}

/// The row that the track breaks most by [`violation`]'s measure: its
/// limit and its value g there, in the row's unit ([`Limit::unit`]); None
/// when every row holds (the messages name it).
pub fn worst(track: &Track, rows: &[Row]) -> Option<(Limit, f64)> {
    let mut most: Option<(f64, Limit, f64)> = None;
    for row in rows {
        points(track, row, |p| {
            let v = p.value / row.scale() * UNIT_M;
            if v > 0.0 && most.is_none_or(|(m, _, _)| v > m) {
                most = Some((v, row.limit, p.value));
            }
        });
    }
    most.map(|(_, limit, g)| (limit, g))
}

/// The linearized rows a·Δp̂ − ν ≤ b in the scaled step, in v's metres:
/// a = (∂g*/∂p)·S·UNIT_M/scale, b = −(g* + MARGIN·scale)·UNIT_M/scale, for
/// the points within reach of their bound in one step of the trust region
/// (Σ|a_i|·Δ ≥ b), as [`crate::polish::ground::rows`].
pub fn rows(
    sens: &Sensitivity,
    rows: &[Row],
    scales: &[f64],
    trust_radius: f64,
) -> Vec<(Vec<(usize, f64)>, f64)> {
    let len = scales.len();
    let mut out = Vec::new();
    for (r, row) in rows.iter().enumerate() {
        let unit = UNIT_M / row.scale();
        points(&sens.track, row, |p| {
            let rhs = -(p.value + MARGIN * row.scale()) * unit;
            let mut gradient = vec![0.0; len];
            for (i, w) in p.weights.iter().enumerate().filter(|(_, w)| **w != 0.0) {
                let at = ((p.k + i - 1) * rows.len() + r) * len;
                for (g, d) in gradient.iter_mut().zip(&sens.dlimits[at..at + len]) {
                    *g += w * d;
                }
            }
            let terms: Vec<(usize, f64)> = gradient
                .iter()
                .zip(scales)
                .enumerate()
                .map(|(c, (g, s))| (c, g * s * unit))
                .filter(|(_, v)| *v != 0.0)
                .collect();
            let reach: f64 = terms.iter().map(|(_, v)| v.abs()).sum::<f64>() * trust_radius;
            if reach >= rhs {
                out.push((terms, rhs));
            }
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;
    use crate::polish::shooting::{self, fixture};
    use crate::problem::constraints::{self, Constraints};
    use crate::problem::dynamics::Model;

    /// [`worst`] names the row that sets [`violation`]: a tight pitch-rate
    /// limit on a pitching shot is broken, and its rate there is the
    /// violation in its own unit; with loose limits no row is named.
    #[test]
    fn the_worst_row_is_the_one_that_sets_the_violation() {
        let mut s = Scenario::paper();
        let model = Model::new(&s.vehicle, &s.environment);
        let (layout, p, _) = fixture::dip(&model);
        let y0 = [0.0, 40.0, 3.0, -20.0, 0.1, 0.08, 100_000.0];
        let (_, track) = shooting::shoot_track(&model, &layout, y0, &p);
        let peak_rate = track.states.iter().map(|y| y[5].abs()).fold(0.0, f64::max);
        for (bound_degps, broken) in [(0.5 * peak_rate.to_degrees(), true), (1e3, false)] {
            s.constraints = Constraints {
                max_pitch_rate_degps: Some(bound_degps),
                ..Constraints::default()
            };
            let rows = constraints::rows(&s);
            let v = violation(&track, &rows);
            match worst(&track, &rows) {
                Some((limit, g)) => {
                    assert!(broken, "a row named with loose limits: {limit:?}");
                    assert_eq!(limit, constraints::Limit::PitchRate);
                    let scale = rows[0].scale();
                    assert!(
                        (g / scale * UNIT_M - v).abs() <= 1e-12 * v,
                        "{g} against {v}"
                    );
                    // The broken side's value: the peak rate over the bound
                    // (the peak interpolated between step ends, near theirs).
                    let over = peak_rate - bound_degps.to_radians();
                    assert!((g - over).abs() <= 0.05 * over, "{g} against {over}");
                }
                None => assert!(!broken && v == 0.0, "no row named, violation {v}"),
            }
        }
    }

    /// The peak of each row along a shot, and its gradient against every
    /// parameter, by central finite differences of the shot.
    #[test]
    fn the_peaks_and_their_gradients_match_finite_differences() {
        let mut s = Scenario::paper();
        s.terminal.x_m = 5.0;
        s.constraints = Constraints {
            cone_half_angle_deg: Some(20.0),
            max_pitch_rate_degps: Some(5.0),
            max_tilt_deg: Some(3.0),
            tilt_below_m: Some(30.0),
            final_descent_m: Some(30.0),
            final_descent_lateral_mps: Some(0.5),
        };
        let all = constraints::rows(&s);
        let model = Model::new(&s.vehicle, &s.environment);
        let (layout, p, t) = fixture::dip(&model);
        // Tilted, drifting and pitching, 40 m up.
        let y0 = [0.0, 40.0, 3.0, -20.0, 0.1, 0.08, 100_000.0];
        let sens = shooting::sensitivity_with(&model, &layout, y0, &p, &all);
        let mut tested = 0;
        for (r, row) in all.iter().enumerate() {
            let highest = |p: &[f64]| {
                let (_, track) = shooting::shoot_track(&model, &layout, y0, p);
                let mut best = (f64::NEG_INFINITY, 0);
                points(&track, row, |q| {
                    if q.value > best.0 {
                        best = (q.value, q.k);
                    }
                });
                best
            };
            let (value, k) = highest(&p);
            if k == 0 {
                continue; // a row monotone along the shot and far from its bound: no point
            }
            tested += 1;
            let mut gradient = vec![0.0; layout.len];
            let mut found = false;
            points(&sens.track, row, |q| {
                if q.k == k {
                    found = true;
                    assert!((q.value - value).abs() < 1e-12);
                    for (i, w) in q.weights.iter().enumerate() {
                        let at = ((q.k + i - 1) * all.len() + r) * layout.len;
                        for (g, d) in gradient.iter_mut().zip(&sens.dlimits[at..]) {
                            *g += w * d;
                        }
                    }
                }
            });
            assert!(found, "row {r}");
            for c in 0..layout.len {
                let size = if (t..t + 4).contains(&c) { 1e5 } else { 0.1 };
                let h = 1e-6 * p[c].abs().max(size);
                let (mut a, mut b) = (p.clone(), p.clone());
                a[c] += h;
                b[c] -= h;
                let (ha, ka) = highest(&a);
                let (hb, kb) = highest(&b);
                if ka != k || kb != k {
                    continue; // the peak moved to another step: not smooth there
                }
                let fd = (ha - hb) / (2.0 * h);
                let scale = fd.abs().max(gradient[c].abs()).max(1e-6);
                assert!(
                    (fd - gradient[c]).abs() <= 1e-4 * scale,
                    "row {r} ({:?}) ∂g*/∂p{c}: {} vs fd {fd}",
                    row.limit,
                    gradient[c]
                );
            }
        }
        assert!(tested >= 4, "{tested} rows had a point");
    }
}
