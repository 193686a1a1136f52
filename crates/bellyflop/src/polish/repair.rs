//! Repair of the thrust's arc structure from its switching function
//! ([`crate::polish::adjoint`]): where S_T contradicts a bound arc (T_max
//! with S_T > 0, T_min with S_T < 0, beyond a tolerance), a short arc of
//! the other bound is inserted where it contradicts it most, [`SEED_S`]
//! long, and the polish then lets it grow (Agamawi, Hager & Rao's
//! bang–bang refinement, with the switching function read along the flown
//! answer rather than from collocation). A seed barely moves the flight,
//! so the polish starts where the first one ended; switching the whole
//! contradicted stretch at once was tried and started metres to a
//! kilometre off the pad, from where the polish found worse optima. The
//! new arcs keep every segment boundary of the old layout.

use crate::polish::adjoint::Switching;
use crate::polish::arcs::{Arc, ArcKind};
use crate::polish::shooting::Layout;

/// The length of an inserted arc at the start \[s\].
pub const SEED_S: f64 = 0.02;

/// The repaired thrust arcs, or None where S_T contradicts no bound arc
/// beyond `tolerance` of the flight's largest |S_T| (module docs). The
/// arcs cover [0, t_f] in order.
pub fn repaired(
    layout: &Layout,
    p: &[f64],
    sw: &Switching,
    (min_thrust_n, max_thrust_n): (f64, f64),
    tolerance: f64,
) -> Option<Vec<Arc>> {
    let n = sw.t_s.len();
    let scale = sw.thrust.iter().map(|v| v.abs()).fold(0.0, f64::max);
    if n < 2 || scale <= 0.0 {
        return None;
    }
    // Segment bounds in time.
    let mut ends = Vec::with_capacity(layout.segments.len());
    let mut t = 0.0;
    for j in 0..layout.segments.len() {
        t += p[layout.duration(j)];
        ends.push(t);
    }
    let start_of = |j: usize| if j == 0 { 0.0 } else { ends[j - 1] };
    let other = |kind: ArcKind| match kind {
        ArcKind::Bound(v) if v == max_thrust_n => Some(ArcKind::Bound(min_thrust_n)),
        ArcKind::Bound(v) if v == min_thrust_n => Some(ArcKind::Bound(max_thrust_n)),
        _ => None,
    };
    // How far S_T at point k contradicts its segment's bound.
    let wrong = |k: usize| {
        let s = sw.thrust[k] / scale;
        match layout.segments[sw.segment[k]].thrust {
            ArcKind::Bound(v) if v == max_thrust_n => s,
            ArcKind::Bound(v) if v == min_thrust_n => -s,
            ArcKind::Bound(_) | ArcKind::Free => f64::NEG_INFINITY,
        }
    };
    // The most contradicted point of every maximal run of bound segments
    // of one kind.
    let mut seeds: Vec<(usize, f64)> = Vec::new();
    let mut k = 0;
    while k < n - 1 {
        let kind = layout.segments[sw.segment[k]].thrust;
        let first = k;
        while k < n - 1 && layout.segments[sw.segment[k]].thrust == kind {
            k += 1;
        }
        let worst = (first..k).max_by(|&a, &b| wrong(a).total_cmp(&wrong(b)));
        if let Some(w) = worst.filter(|&w| wrong(w) > tolerance) {
            seeds.push((sw.segment[w], sw.t_s[w]));
        }
    }
    if seeds.is_empty() {
        return None;
    }
    let mut arcs = Vec::new();
    for (j, seg) in layout.segments.iter().enumerate() {
        let (t0, t1) = (start_of(j), ends[j]);
        match seeds.iter().find(|s| s.0 == j).zip(other(seg.thrust)) {
            Some((&(_, at), flip)) if t1 - t0 > 2.0 * SEED_S => {
                let a = at.clamp(t0 + 0.5 * SEED_S, t1 - 1.5 * SEED_S);
                for (s, e, kind) in [
                    (t0, a, seg.thrust),
                    (a, a + SEED_S, flip),
                    (a + SEED_S, t1, seg.thrust),
                ] {
                    arcs.push(Arc {
                        t_start_s: s,
                        t_end_s: e,
                        kind,
                    });
                }
            }
            _ => arcs.push(Arc {
                t_start_s: t0,
                t_end_s: t1,
                kind: seg.thrust,
            }),
        }
    }
    Some(arcs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::polish::shooting::Segment;

    fn layout(kinds: &[ArcKind]) -> Layout {
        Layout::new(
            kinds
                .iter()
                .map(|&thrust| Segment {
                    thrust,
                    steps: 10,
                    d_min_s: 0.0,
                    d_max_s: 10.0,
                })
                .collect(),
        )
    }

    /// A T_min arc over [0, 4] whose S_T is most negative at 2.5: a
    /// T_max seed [`SEED_S`] long is inserted there, the rest keeps its
    /// kind and its boundaries; a consistent S_T asks for nothing.
    #[test]
    fn a_contradicted_arc_gets_a_seed_of_the_other_bound() {
        let (lo, hi) = (1.0, 3.0);
        let l = layout(&[ArcKind::Bound(lo), ArcKind::Bound(lo)]);
        let mut p = vec![0.0; l.len];
        p[l.duration(0)] = 2.0;
        p[l.duration(1)] = 2.0;
        let t_s: Vec<f64> = (0..=40).map(|k| k as f64 * 0.1).collect();
        let thrust: Vec<f64> = t_s
            .iter()
            .map(|&t| (t - 2.5).abs().min(1.0) - 0.5)
            .collect();
        let sw = Switching {
            segment: t_s.iter().map(|&t| usize::from(t >= 2.0).min(1)).collect(),
            thrust_n: vec![lo; t_s.len()],
            delta: vec![0.0; t_s.len()],
            t_s,
            thrust,
        };
        let arcs = repaired(&l, &p, &sw, (lo, hi), 0.02).expect("a repair");
        let spans: Vec<(f64, f64, ArcKind)> = arcs
            .iter()
            .map(|a| (a.t_start_s, a.t_end_s, a.kind))
            .collect();
        assert_eq!(spans.len(), 4, "{spans:?}");
        assert_eq!(spans[0], (0.0, 2.0, ArcKind::Bound(lo)));
        assert_eq!(spans[2].2, ArcKind::Bound(hi));
        assert!((spans[2].0 - 2.5).abs() < 1e-9, "{spans:?}");
        assert!((spans[2].1 - spans[2].0 - SEED_S).abs() < 1e-12);
        assert_eq!(spans[3].2, ArcKind::Bound(lo));
        assert_eq!(spans[3].1, 4.0);
        let ok = Switching {
            thrust: vec![0.5; sw.t_s.len()],
            ..sw.clone()
        };
        assert!(repaired(&l, &p, &ok, (lo, hi), 0.02).is_none());
    }
}
