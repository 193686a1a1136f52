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

use crate::polish::adjoint::Switching;
use crate::polish::arcs::ArcKind;
use crate::polish::shooting::Layout;
use crate::solution::{Optimality, ThrustArc, ThrustArcKind};

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
    }
}
