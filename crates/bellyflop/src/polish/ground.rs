//! The ground and the dry mass along the polish's shot: the path
//! constraints that are not linear in p.
//!
//! The ground is z(t) ≥ z_f on [0, t_f]. The shot ([`crate::polish::shooting::Track`])
//! gives z and Vz after every RK4 step; between two steps z is the cubic
//! Hermite interpolant of (z, Vz) at both ends,
//!
//!   H(s) = h₀₀(s)·z₀ + h₁₀(s)·h·V₀ + h₀₁(s)·z₁ + h₁₁(s)·h·V₁,  s ∈ [0, 1],
//!
//! (error O(h⁴): ~1e-7 m at the polish's 0.05 s steps). The constrained
//! points are where z is lowest locally: every interior minimum of H below
//! both ends, every step's end lower than both its neighbours, and every
//! step's end below z_f, but the last (t_f, where the terminal conditions
//! put z = z_f). In the last step, a minimum less than
//! [`GROUND_MARGIN_M`] below z(t_f) is left to the terminal conditions: it
//! sits next to t_f, where z = z_f and Vz = 0 make it z_f to second order,
//! and its row beside the terminal row of z is degenerate (the QP then
//! split their multipliers arbitrarily, both at the slack's weight, and the
//! certificate could not be evaluated; measured on the paper's case).
//! Between two local minima z is monotone, so z ≥ z_f at
//! these points is z ≥ z_f along the whole shot. A step that makes a new
//! minimum below z_f elsewhere is judged by the merit, which counts v(p)
//! over every point, and the polish then watches the step ends where it
//! went through ([`below`]): their rows join the QP's. At an interior minimum H' = 0, so its gradient against p is the
//! Hermite weights on the ends' gradients (the envelope theorem) plus
//! ∂H/∂h·∂h/∂d_j, with h = d_j/steps.
//!
//! With the dry mass, m(t_f) ≥ m_dry (m falls monotonically, so this is
//! the whole path), they form one ℓ∞ violation
//!
//!   v(p) = max(0, max_k (z_f − z_k) \[m\], m_dry − m(t_f) \[kg\]),
//!
//! which the polish's merit weighs and its QP linearizes, with one slack.

use crate::polish::shooting::{Layout, Sensitivity, Track};

/// How far above z_f the QP's rows hold the ground's points \[m\]: the
/// rows are linearizations, met to the QP's tolerances, and a point that
/// touches the ground at the optimum would otherwise end a few µm below
/// it (second-order terms). 10 µm keeps the shot above z_f.
pub const GROUND_MARGIN_M: f64 = 1e-5;
use crate::verify::path::{hermite_basis as basis, hermite_minimum};

/// Row k of a flat gradient matrix of `len` columns.
fn row(v: &[f64], k: usize, len: usize) -> &[f64] {
    &v[k * len..(k + 1) * len]
}

/// The ground's points of a track: `visit` is called with each (value of
/// z \[m\], its gradient against p when the sensitivities are given).
/// The ends of the steps in `watch` (sorted) are points too.
fn points(
    track: &Track,
    layout: &Layout,
    z_f: f64,
    watch: &[usize],
    sens: Option<&Sensitivity>,
    mut visit: impl FnMut(f64, Option<&[f64]>),
) {
    let len = layout.len;
    let last = track.len() - 1;
    let mut buffer = vec![0.0; if sens.is_some() { len } else { 0 }];
    for k in 1..=last {
        let (z0, v0, z1, v1, h) = (
            track.z_m[k - 1],
            track.vz_mps[k - 1],
            track.z_m[k],
            track.vz_mps[k],
            track.h_s[k],
        );
        let minimum = hermite_minimum(z0, v0, z1, v1, h)
            .filter(|&(_, value)| k < last || z1 - value > GROUND_MARGIN_M);
        if let Some((s, value)) = minimum {
            match sens {
                Some(sens) => {
                    let w = basis(s);
                    buffer.fill(0.0);
                    let parts = [
                        (w[0], row(&sens.dz, k - 1, len)),
                        (w[1] * h, row(&sens.dvz, k - 1, len)),
                        (w[2], row(&sens.dz, k, len)),
                        (w[3] * h, row(&sens.dvz, k, len)),
                    ];
                    for (weight, g) in parts {
                        for (b, g) in buffer.iter_mut().zip(g) {
                            *b += weight * g;
                        }
                    }
                    let j = track.segment[k];
                    buffer[layout.duration(j)] +=
                        (w[1] * v0 + w[3] * v1) / layout.segments[j].steps as f64;
                    visit(value, Some(&buffer));
                }
                None => visit(value, None),
            }
        }
        let z = &track.z_m;
        let local_minimum = k < last && z[k] <= z[k - 1] && z[k] <= z[k + 1];
        // A watched step puts both its ends in (its lowest point may be
        // inside it, or the step may end at t_f).
        let watched = watch.binary_search(&k).is_ok() || watch.binary_search(&(k + 1)).is_ok();
        if k < last && (local_minimum || z[k] < z_f || watched) {
            visit(z[k], sens.map(|s| row(&s.dz, k, len)));
        }
    }
}

/// v(p) of the module docs, from a shot's track and final mass.
pub fn violation(track: &Track, layout: &Layout, z_f: f64, mass_kg: f64, dry_kg: f64) -> f64 {
    let mut v = (dry_kg - mass_kg).max(0.0);
    points(track, layout, z_f, &[], None, |z, _| v = v.max(z_f - z));
    v
}

/// The steps k (1..=K) of a track where it goes through the ground: per
/// dip below z_f, the step that holds its lowest point (a step end, or a
/// Hermite minimum inside the step).
pub fn below(track: &Track, z_f: f64) -> Vec<usize> {
    let mut out = Vec::new();
    // The lowest point of the current dip: (z, step).
    let mut dip: Option<(f64, usize)> = None;
    for k in 1..track.len() {
        let (z0, v0, z1, v1) = (
            track.z_m[k - 1],
            track.vz_mps[k - 1],
            track.z_m[k],
            track.vz_mps[k],
        );
        let inner = hermite_minimum(z0, v0, z1, v1, track.h_s[k]).map_or(z1, |(_, z)| z.min(z1));
        if inner < z_f {
            match &mut dip {
                Some((low, step)) if inner < *low => (*low, *step) = (inner, k),
                Some(_) => {}
                None => dip = Some((inner, k)),
            }
        }
        if z1 >= z_f {
            out.extend(dip.take().map(|(_, k)| k));
        }
    }
    out.extend(dip.map(|(_, k)| k));
    out
}

/// The linearized path rows in the scaled step: a·Δp̂ − ν ≤ b, with
/// a = −(∂z/∂p)·S and b = z − z_f − [`GROUND_MARGIN_M`] (the dry mass
/// likewise, without a margin), for the points
/// within reach of their bound in one step of the trust region
/// (Σ|a_i|·Δ ≥ b); the others hold on the whole region. The step ends in
/// `watch` (sorted: where an earlier step went through the ground) are
/// points too, besides the local minima.
pub fn rows(
    sens: &Sensitivity,
    layout: &Layout,
    scales: &[f64],
    (z_f, dry_kg): (f64, f64),
    trust_radius: f64,
    watch: &[usize],
) -> Vec<(Vec<(usize, f64)>, f64)> {
    let mut rows = Vec::new();
    let mut keep = |gradient: &mut dyn Iterator<Item = f64>, rhs: f64| {
        let terms: Vec<(usize, f64)> = gradient
            .zip(scales)
            .enumerate()
            .map(|(c, (g, s))| (c, -g * s))
            .filter(|(_, v)| *v != 0.0)
            .collect();
        let reach: f64 = terms.iter().map(|(_, v)| v.abs()).sum::<f64>() * trust_radius;
        if reach >= rhs {
            rows.push((terms, rhs));
        }
    };
    points(&sens.track, layout, z_f, watch, Some(sens), |z, g| {
        if let Some(g) = g {
            keep(&mut g.iter().copied(), z - z_f - GROUND_MARGIN_M);
        }
    });
    let mass = sens.final_state[6];
    keep(&mut (0..layout.len).map(|c| sens.d(6, c)), mass - dry_kg);
    rows
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;
    use crate::polish::shooting::{self, fixture};
    use crate::problem::dynamics::Model;

    /// A cubic z(t) is its own Hermite interpolant: the minimum found is
    /// the cubic's.
    #[test]
    fn the_hermite_minimum_of_a_cubic_is_its_minimum() {
        // z(t) = (t − 0.3)² − 0.01 + 0.5·(t − 0.3)³ on [0, 1] (h = 1).
        let z = |t: f64| (t - 0.3).powi(2) - 0.01 + 0.5 * (t - 0.3).powi(3);
        let v = |t: f64| 2.0 * (t - 0.3) + 1.5 * (t - 0.3).powi(2);
        let (s, m) = hermite_minimum(z(0.0), v(0.0), z(1.0), v(1.0), 1.0).unwrap();
        assert!(
            (s - 0.3).abs() < 1e-12 && (m + 0.01).abs() < 1e-12,
            "{s} {m}"
        );
        // Over h = 2 s, the same shape in s.
        let (s, m) = hermite_minimum(z(0.0), v(0.0) / 2.0, z(1.0), v(1.0) / 2.0, 2.0).unwrap();
        assert!((s - 0.3).abs() < 1e-12 && (m + 0.01).abs() < 1e-12);
        // A monotone step has none.
        assert!(hermite_minimum(1.0, -1.0, 0.0, -1.0, 1.0).is_none());
    }

    /// The lowest point of a shot that dips and climbs again, and its
    /// gradient against every parameter, by central finite differences
    /// of the shot (the minimum of a smooth dip is smooth in p).
    #[test]
    fn the_lowest_point_and_its_gradient_match_finite_differences() {
        let s = Scenario::paper();
        let model = Model::new(&s.vehicle, &s.environment);
        // Upright, falling at 20 m/s from 40 m: full thrust for 1.2 s,
        // then a free arc at ~0.7·T_max stops the fall near 22 m, inside
        // it, and climbs; a low arc follows.
        let (layout, p, t) = fixture::dip(&model);
        let y0 = [0.0, 40.0, 1.0, -20.0, 0.0, 0.0, 100_000.0];
        let lowest = |p: &[f64]| {
            let (_, track) = shooting::shoot_track(&model, &layout, y0, p);
            let mut low = f64::INFINITY;
            points(&track, &layout, 0.0, &[], None, |z, _| low = low.min(z));
            low
        };
        let sens = shooting::sensitivity(&model, &layout, y0, &p);
        let mut best: (f64, Vec<f64>) = (f64::INFINITY, vec![]);
        points(&sens.track, &layout, 0.0, &[], Some(&sens), |z, g| {
            if z < best.0 {
                best = (z, g.unwrap().to_vec());
            }
        });
        assert!(
            best.0 > 0.0 && best.0 < 30.0,
            "a dip above the ground: {}",
            best.0
        );
        assert!((best.0 - lowest(&p)).abs() < 1e-12);
        for c in 0..layout.len {
            let size = if (t..t + 4).contains(&c) { 1e5 } else { 0.1 };
            let h = 1e-5 * p[c].abs().max(size);
            let (mut a, mut b) = (p.clone(), p.clone());
            a[c] += h;
            b[c] -= h;
            let fd = (lowest(&a) - lowest(&b)) / (2.0 * h);
            let scale = fd.abs().max(best.1[c].abs()).max(1e-6);
            assert!(
                (fd - best.1[c]).abs() <= 1e-4 * scale,
                "∂z_min/∂p{c}: {} vs fd {fd}",
                best.1[c]
            );
        }
    }
}
