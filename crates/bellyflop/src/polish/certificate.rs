//! The Pontryagin certificate of a polished answer: the thrust's
//! switching function S_T along the flight ([`crate::polish::adjoint`]),
//! arc by arc, against the arc structure the polish flew.
//!
//! The minimum principle wants T = T_max where S_T < 0, T = T_min where
//! S_T > 0, and a switch between them where S_T crosses zero. Per thrust
//! arc (the polish's segments of one kind, merged) the certificate gives
//! the least and largest S_T along it, and at each switch |S_T|, all
//! scaled by the largest |S_T| of the flight. It holds when no bound arc
//! has S_T of the wrong sign beyond [`TOLERANCE`] of that scale. A free
//! (cubic) thrust arc is a singular arc of the answer, where S_T ≡ 0;
//! the cubic meets that only in the mean (the polish is stationary in its
//! coefficients), so its largest |S_T| is given, not judged.
//!
//! The costates leave out the multipliers of the path rows (the ground,
//! the dry mass): where those are active the certificate is not
//! evaluated, and says so.
//!
//! The published certificate also carries S_T = ∂H/∂T and S_δ = ∂H/∂δ
//! themselves, sampled along the flight, each scaled by its own largest
//! |·| ([`samples`]), for the viewer to draw.

use crate::polish::adjoint::Switching;
use crate::polish::arcs::ArcKind;
use crate::polish::shooting::Layout;
use crate::solution::{Optimality, SwitchingSamples, ThrustArc, ThrustArcKind};

/// A bound arc's S_T may have the wrong sign by this fraction of the
/// flight's largest |S_T| (the polish stops at 0.05 kg of predicted gain,
/// and the costates come from its last QP's multipliers).
pub const TOLERANCE: f64 = 0.02;

/// The certificate of the switching functions `sw` over the segments of
/// `layout`, with the thrust's upper bound `max_thrust_n`; `path_active`
/// when a path row carries a multiplier.
pub fn certify(
    layout: &Layout,
    sw: &Switching,
    max_thrust_n: f64,
    path_active: bool,
) -> Optimality {
    let scale = sw.thrust.iter().map(|v| v.abs()).fold(0.0, f64::max);
    let scaled = |v: f64| if scale > 0.0 { v / scale } else { 0.0 };
    let mut arcs: Vec<ThrustArc> = Vec::new();
    for (k, (&j, &t)) in sw.segment.iter().zip(&sw.t_s).enumerate() {
        let kind = match layout.segments[j].thrust {
            ArcKind::Bound(v) if v == max_thrust_n => ThrustArcKind::Upper,
            ArcKind::Bound(_) => ThrustArcKind::Lower,
            ArcKind::Free => ThrustArcKind::Free,
        };
        let s = scaled(sw.thrust[k]);
        match arcs.last_mut() {
            Some(a) if a.kind == kind => {
                a.t_end_s = t;
                a.switching_min = a.switching_min.min(s);
                a.switching_max = a.switching_max.max(s);
            }
            _ => {
                if let Some(a) = arcs.last_mut() {
                    a.t_end_s = t;
                }
                arcs.push(ThrustArc {
                    t_start_s: t,
                    t_end_s: t,
                    kind,
                    switching_min: s,
                    switching_max: s,
                    switching_at_start: s,
                })
            }
        }
    }
    let wrong = |a: &ThrustArc| match a.kind {
        ThrustArcKind::Upper => a.switching_max > TOLERANCE,
        ThrustArcKind::Lower => a.switching_min < -TOLERANCE,
        ThrustArcKind::Free => false,
    };
    let contradicted = arcs.iter().filter(|a| wrong(a)).count();
    Optimality {
        evaluated: !path_active,
        holds: !path_active && contradicted == 0,
        // The polish's to say ([`crate::polish`]).
        converged: true,
        contradicted_arcs: contradicted,
        switching_scale: scale,
        thrust_arcs: arcs,
        multipliers: [0.0; 6],
        path_multiplier: 0.0,
        // The published answer's only ([`samples`]).
        switching: None,
    }
}

/// The samples of `sw` as the JSON gives them: S_T and S_δ each divided by
/// its largest |·| over the flight (0 where that is 0). Takes `sw`, and
/// scales its arrays in place: the published answer's switching functions
/// are not needed after.
pub fn samples(sw: Switching) -> SwitchingSamples {
    let Switching {
        t_s,
        mut thrust,
        mut delta,
        ..
    } = sw;
    let thrust_scale = scale_in_place(&mut thrust);
    let delta_scale = scale_in_place(&mut delta);
    SwitchingSamples {
        t_s,
        thrust,
        delta,
        thrust_scale,
        delta_scale,
    }
}

/// Divide `v` by its largest |·|, which it returns (left as it is where
/// that is 0).
fn scale_in_place(v: &mut [f64]) -> f64 {
    let scale = v.iter().map(|x| x.abs()).fold(0.0, f64::max);
    if scale > 0.0 {
        v.iter_mut().for_each(|x| *x /= scale);
    }
    scale
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;
    use crate::input::settings::SolverSettings;
    use crate::method::observer::Silent;

    /// The paper's case, polished: its samples line up, run from 0 to t_f,
    /// are scaled to a largest |S_T| of 1, and S_T has the sign the
    /// minimum principle wants inside every bound arc.
    #[test]
    fn the_published_samples_keep_the_sign_rule() {
        let sol = crate::solve(&Scenario::paper(), &SolverSettings::default(), &mut Silent)
            .expect("a planar scenario");
        let o = sol.optimality.expect("the paper's case is polished");
        let sw = o
            .switching
            .expect("the published certificate has its samples");
        let n = sw.t_s.len();
        assert!(n > 100, "{n} samples");
        assert_eq!(sw.thrust.len(), n);
        assert_eq!(sw.delta.len(), n);
        assert_eq!(sw.t_s[0], 0.0);
        assert!((sw.t_s[n - 1] - sol.tf_s).abs() <= 1e-9 * sol.tf_s);
        assert!(sw.t_s.windows(2).all(|w| w[1] > w[0]), "t_s increases");
        let largest = |v: &[f64]| v.iter().map(|x| x.abs()).fold(0.0, f64::max);
        assert_eq!(largest(&sw.thrust), 1.0);
        assert_eq!(largest(&sw.delta), 1.0);
        assert_eq!(sw.thrust_scale, o.switching_scale);
        assert!(sw.delta_scale > 0.0);
        let mut judged = 0;
        for a in &o.thrust_arcs {
            let inside = (0..n).filter(|&k| sw.t_s[k] > a.t_start_s && sw.t_s[k] < a.t_end_s);
            for k in inside {
                let s = sw.thrust[k];
                match a.kind {
                    ThrustArcKind::Upper => assert!(s <= TOLERANCE, "T_max at {}: {s}", sw.t_s[k]),
                    ThrustArcKind::Lower => assert!(s >= -TOLERANCE, "T_min at {}: {s}", sw.t_s[k]),
                    ThrustArcKind::Free => continue,
                }
                judged += 1;
            }
        }
        assert!(judged > n / 2, "{judged} of {n} samples on bound arcs");
    }
}
