//! The geometry of the path plot: the vehicle's outline and thrust at one
//! time, the times to draw it at, equal axis scales, and clipping.

use std::ops::Range;

use crate::sample::Dense;

/// Linear interpolation of a sampled column at time `t` (clamped).
fn at(t_s: &[f64], col: &[f64], t: f64) -> f64 {
    let i = t_s.partition_point(|&s| s < t);
    if i == 0 {
        return col[0];
    }
    if i >= t_s.len() {
        return col[col.len() - 1];
    }
    let (t0, t1) = (t_s[i - 1], t_s[i]);
    let w = if t1 > t0 { (t - t0) / (t1 - t0) } else { 1.0 };
    col[i - 1] + w * (col[i] - col[i - 1])
}

/// The vehicle at one time, in the x–z plane.
pub(super) struct Pose {
    pub(super) cg: (f64, f64),
    /// Corners of the body rectangle (closed: first repeated).
    pub(super) body: Vec<(f64, f64)>,
    /// Nose cap: a triangle on the top end, so the nose is told from the engine.
    pub(super) nose: Vec<(f64, f64)>,
    /// Thrust line from the nozzle along the exhaust, length ∝ T.
    pub(super) flame: [(f64, f64); 2],
}

/// The body axis (engine → nose) is (−sin θ, cos θ): the thrust force
/// T·(−sin(θ+δ), cos(θ+δ)) of the dynamics points along it when δ = 0. The
/// exhaust leaves the nozzle the opposite way, (sin(θ+δ), −cos(θ+δ)).
pub(super) fn pose(
    v: &bellyflop::input::scenario::Vehicle,
    s: &Sample,
    flame_at_max_m: f64,
) -> Pose {
    let (x, z) = (s.x, s.z);
    let a = (-s.theta.sin(), s.theta.cos());
    let n = (a.1, -a.0);
    let r = v.radius_m;
    let engine = (x - v.cg_m * a.0, z - v.cg_m * a.1);
    let top = v.length_m - v.cg_m;
    let cap = (2.0 * r).min(0.3 * v.length_m);
    let shoulder = (x + (top - cap) * a.0, z + (top - cap) * a.1);
    let tip = (x + top * a.0, z + top * a.1);
    let corner = |p: (f64, f64), sign: f64| (p.0 + sign * r * n.0, p.1 + sign * r * n.1);
    let body = vec![
        corner(engine, 1.0),
        corner(shoulder, 1.0),
        corner(shoulder, -1.0),
        corner(engine, -1.0),
        corner(engine, 1.0),
    ];
    let nose = vec![corner(shoulder, 1.0), tip, corner(shoulder, -1.0)];
    let phi = s.theta + s.delta;
    let len = flame_at_max_m * (s.thrust / v.max_thrust_n).max(0.0);
    let flame = [
        engine,
        (engine.0 + len * phi.sin(), engine.1 - len * phi.cos()),
    ];
    Pose {
        cg: (x, z),
        body,
        nose,
        flame,
    }
}

/// The trajectory at one time.
pub(super) struct Sample {
    pub(super) t: f64,
    pub(super) x: f64,
    pub(super) z: f64,
    pub(super) theta: f64,
    pub(super) delta: f64,
    pub(super) thrust: f64,
}

pub(super) fn sample(d: &Dense, t: f64) -> Sample {
    Sample {
        t,
        x: at(&d.t_s, &d.x_m, t),
        z: at(&d.t_s, &d.z_m, t),
        theta: at(&d.t_s, &d.theta_rad, t),
        delta: at(&d.t_s, &d.delta_rad, t),
        thrust: at(&d.t_s, &d.thrust_n, t),
    }
}

/// Regular times 0, Δ, 2Δ, … and t_f (the last regular time is dropped if
/// it is within Δ/3 of t_f).
pub(super) fn regular_times(t0: f64, tf: f64, step: f64) -> Vec<f64> {
    let mut ts = Vec::new();
    let mut k = (t0 / step).ceil();
    while k * step < tf - step / 3.0 {
        ts.push(k * step);
        k += 1.0;
    }
    ts.push(tf);
    ts
}

/// Ranges with equal metres per pixel on both axes that contain `bbox`,
/// for a plotting area of `px` pixels.
pub(super) fn equal_ranges(
    bbox: (Range<f64>, Range<f64>),
    px: (u32, u32),
) -> (Range<f64>, Range<f64>) {
    let (xr, zr) = bbox;
    let (w, h) = (px.0.max(1) as f64, px.1.max(1) as f64);
    let s = ((xr.end - xr.start) / w).max((zr.end - zr.start) / h);
    let (xc, zc) = (0.5 * (xr.start + xr.end), 0.5 * (zr.start + zr.end));
    (
        (xc - 0.5 * s * w)..(xc + 0.5 * s * w),
        (zc - 0.5 * s * h)..(zc + 0.5 * s * h),
    )
}

/// The part of segment p–q inside the box `xr` × `zr` (Liang–Barsky), if any.
fn clip_segment(
    p: (f64, f64),
    q: (f64, f64),
    xr: &Range<f64>,
    zr: &Range<f64>,
) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dz) = (q.0 - p.0, q.1 - p.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (den, num) in [
        (-dx, p.0 - xr.start),
        (dx, xr.end - p.0),
        (-dz, p.1 - zr.start),
        (dz, zr.end - p.1),
    ] {
        if den == 0.0 {
            if num < 0.0 {
                return None;
            }
        } else {
            let r = num / den;
            if den < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    (t0 <= t1).then_some((
        (p.0 + t0 * dx, p.1 + t0 * dz),
        (p.0 + t1 * dx, p.1 + t1 * dz),
    ))
}

/// The pieces of a polyline inside the box: plotters would squash points
/// outside the ranges onto the border instead of cutting the line there.
pub(super) fn clip_polyline(
    points: &[(f64, f64)],
    xr: &Range<f64>,
    zr: &Range<f64>,
) -> Vec<Vec<(f64, f64)>> {
    let mut pieces: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut open = false;
    for w in points.windows(2) {
        match clip_segment(w[0], w[1], xr, zr) {
            Some((a, b)) => {
                let continues = open && a == w[0];
                if !continues {
                    pieces.push(vec![a]);
                }
                pieces.last_mut().expect("a piece was pushed").push(b);
                open = b == w[1];
            }
            None => open = false,
        }
    }
    pieces
}

pub(super) fn inside(q: &(f64, f64), xr: &Range<f64>, zr: &Range<f64>) -> bool {
    xr.contains(&q.0) && zr.contains(&q.1)
}
