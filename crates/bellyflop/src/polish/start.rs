//! The polish's starting point, from a collocation answer: its segments
//! and its parameters. A segment ends wherever an arc of the thrust or of
//! the gimbal rate χ ends (so that a kink of δ, where χ leaves ±χ_max, can
//! sit on a free segment boundary), and none is longer than
//! [`MAX_SEGMENT_S`]. (Holding χ on its bound over the χ arcs, δ linear
//! there, was tried and lost up to 180 kg on 10 envelope states: the N = 20
//! rate arcs are too coarse to impose; BENCHMARKS.md, issue 25.) The
//! parameters are
//! (each segment's duration, and the shifted-Legendre projections of δ and
//! of a free T).

use crate::collocation::control_profile::Profile;
use crate::collocation::interpolation::{Interpolant, Interpolation};
use crate::flown::legendre;
use crate::polish::arcs::{arcs, Arc, ArcKind};
use crate::polish::shooting::{Layout, Segment, NC, STEP_S};
use crate::problem::dynamics::Model;
use crate::solution::Solution;

/// Longest segment at the start \[s\]: one cubic of δ (and of a free T) per
/// segment. It bounds how closely the flown controls can follow the
/// optimum, not only the collocation's answer: at 1.5 s the polish converged
/// (its certificate holding) up to 10 kg short of IPOPT's 20 × 8 optimum,
/// and at 0.75 s the median gap over 42 seeded envelope states fell from
/// −1.91 to −0.65 kg at 1.3× the time (`bench/accurate.py`, BENCHMARKS.md).
pub const MAX_SEGMENT_S: f64 = 0.75;

/// The longest segment of the polish's second try, where the first (at
/// [`MAX_SEGMENT_S`]) fails: on 3 of 300 seeded states (`bench/safety.py`)
/// the finer start, 50–120 m off the pad, did not land within the
/// iteration cap, and this one did.
pub const FALLBACK_SEGMENT_S: f64 = 1.5;

/// Shortest duration a segment may shrink to \[s\] (an arc that the
/// collocation placed but the optimum does not want nearly vanishes).
pub const MIN_DURATION_S: f64 = 1e-3;

/// The 4-point Gauss–Legendre rule on [0, 1]: (node, weight).
const GAUSS4: [(f64, f64); 4] = [
    (0.069_431_844_202_973_7, 0.173_927_422_568_726_9),
    (0.330_009_478_207_571_9, 0.326_072_577_431_273_1),
    (0.669_990_521_792_428_1, 0.326_072_577_431_273_1),
    (0.930_568_155_797_026_3, 0.173_927_422_568_726_9),
];

/// The longest duration a segment of initial duration `d` may grow to \[s\].
pub fn longest(d: f64) -> f64 {
    (1.6 * d).max(d + 0.3)
}

/// Segments of at most `max_segment_s` and initial parameters from a
/// solved collocation answer.
pub fn start(model: &Model, sol: &Solution, max_segment_s: f64) -> (Layout, Vec<f64>) {
    let (lo, hi) = (model.min_thrust_n, model.max_thrust_n);
    let chi = model.max_gimbal_rate_radps;
    let thrust = arcs(&sol.t_s, &sol.mesh.points, &sol.thrust_n, lo, hi);
    let rate = arcs(
        &sol.t_s,
        &sol.mesh.points,
        &sol.gimbal_rate_radps,
        -chi,
        chi,
    );
    let delta = Interpolant::new(Interpolation::Pchip, &sol.t_s, &sol.delta_rad);
    let profile = Profile::new(&sol.t_s, &sol.mesh.points, &sol.thrust_n, lo, hi);
    from_arcs(
        &merge(&thrust, &rate),
        |t| delta.eval(t),
        |t| profile.at(t),
        0.0,
        max_segment_s,
    )
}

/// Segments and initial parameters for the thrust arcs `arcs` (each cut
/// into segments of at most `max_segment_s`), with δ(t) and a free
/// T(t) projected onto each segment's cubics. Each duration may grow to
/// [`longest`] of its start, and at least to `room_s`.
pub fn from_arcs(
    arcs: &[Arc],
    delta: impl Fn(f64) -> f64,
    thrust: impl Fn(f64) -> f64,
    room_s: f64,
    max_segment_s: f64,
) -> (Layout, Vec<f64>) {
    let spans = cut(arcs, max_segment_s);
    let segments: Vec<Segment> = spans
        .iter()
        .map(|&(t0, t1, thrust)| {
            let d_max_s = longest(t1 - t0).max(room_s);
            Segment {
                thrust,
                steps: (d_max_s / STEP_S).ceil() as usize,
                d_min_s: MIN_DURATION_S,
                d_max_s,
            }
        })
        .collect();
    let layout = Layout::new(segments);
    let mut p = vec![0.0; layout.len];
    for (j, &(t0, t1, _)) in spans.iter().enumerate() {
        p[layout.duration(j)] = t1 - t0;
        let at = layout.delta(j);
        p[at..at + NC].copy_from_slice(&project(&delta, t0, t1));
        if let Some(at) = layout.thrust(j) {
            p[at..at + NC].copy_from_slice(&project(&thrust, t0, t1));
        }
    }
    (layout, p)
}

/// The thrust's arcs cut at every boundary of the rate's too, each span
/// with the thrust's kind on it.
pub fn merge(thrust: &[Arc], rate: &[Arc]) -> Vec<Arc> {
    let mut cuts: Vec<f64> = thrust
        .iter()
        .chain(rate)
        .flat_map(|a| [a.t_start_s, a.t_end_s])
        .collect();
    cuts.sort_by(f64::total_cmp);
    cuts.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    let kind_at = |arcs: &[Arc], t: f64| {
        arcs.iter()
            .find(|a| t < a.t_end_s)
            .or(arcs.last())
            .map_or(ArcKind::Free, |a| a.kind)
    };
    cuts.windows(2)
        .map(|w| {
            let mid = 0.5 * (w[0] + w[1]);
            Arc {
                t_start_s: w[0],
                t_end_s: w[1],
                kind: kind_at(thrust, mid),
            }
        })
        .collect()
}

/// The arcs cut into segments of at most `max_segment_s`, equal within an
/// arc: (t_start, t_end, kind).
fn cut(arcs: &[Arc], max_segment_s: f64) -> Vec<(f64, f64, ArcKind)> {
    let mut out = Vec::new();
    for a in arcs {
        let len = a.t_end_s - a.t_start_s;
        let k = (len / max_segment_s).ceil().max(1.0) as usize;
        for i in 0..k {
            let t0 = a.t_start_s + len * i as f64 / k as f64;
            let t1 = a.t_start_s + len * (i + 1) as f64 / k as f64;
            out.push((t0, t1, a.kind));
        }
    }
    out
}

/// The L² projection of f on [t0, t1] onto P̃_0..P̃_3:
/// c_k = (2k + 1)·∫₀¹ f·P̃_k ds, by 4-point Gauss (exact for cubics).
fn project(f: impl Fn(f64) -> f64, t0: f64, t1: f64) -> [f64; NC] {
    let mut c = [0.0; NC];
    for &(s, w) in &GAUSS4 {
        let v = f(t0 + s * (t1 - t0));
        for (k, pk) in legendre(s).iter().enumerate() {
            c[k] += (2 * k + 1) as f64 * w * v * pk;
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_projection_reproduces_a_cubic() {
        let f = |t: f64| 1.0 - 2.0 * t + 0.5 * t * t * t;
        let c = project(f, 1.0, 3.0);
        for &s in &[0.0, 0.25, 0.6, 1.0] {
            let v: f64 = c.iter().zip(legendre(s)).map(|(c, p)| c * p).sum();
            assert!((v - f(1.0 + 2.0 * s)).abs() < 1e-12);
        }
    }

    #[test]
    fn long_arcs_are_cut_into_equal_segments() {
        let arcs = [
            Arc {
                t_start_s: 0.0,
                t_end_s: 4.0,
                kind: ArcKind::Bound(1.0),
            },
            Arc {
                t_start_s: 4.0,
                t_end_s: 4.5,
                kind: ArcKind::Free,
            },
        ];
        let s = cut(&arcs[..], 1.5);
        assert_eq!(s.len(), 4);
        assert!((s[2].1 - 4.0).abs() < 1e-15 && s[3] == (4.0, 4.5, ArcKind::Free));
    }
}
