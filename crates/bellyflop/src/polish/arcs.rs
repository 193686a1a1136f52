//! The arc structure of a control in a collocation answer: where it rides
//! a bound (T on T_min or T_max, χ = δ̇ on ±χ_max) and where it is free,
//! with the switch times between arcs on opposite bounds placed by impulse.
//!
//! Point i of the LGR quadrature owns the cell [c_i, c_i + w_i] (its
//! weight, mapped to time; the cells partition [0, t_f]). Points within
//! [`crate::collocation::control_profile::ON_BOUND`] of a bound are on it ([`activity`]). Runs of points with
//! the same activity make arcs over their cells, except:
//!
//! - a single interior point between runs on *opposite* bounds is a
//!   switch: the first bound holds for the fraction f = (v − post)/(pre −
//!   post) of its cell, which keeps its impulse v·w_i;
//! - a single interior point between runs on the *same* bound, or at an end
//!   next to a bound run, is absorbed into that bound's arc.

use crate::collocation::control_profile::{self, activity, Activity};

/// What a control is on one arc.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ArcKind {
    /// Held on this bound (T \[N\], χ [rad/s]).
    Bound(f64),
    /// Free between the bounds (a polynomial of the polish).
    Free,
}

/// One arc of a control.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arc {
    pub t_start_s: f64,
    pub t_end_s: f64,
    pub kind: ArcKind,
}

/// The arcs of the control `values` (one per collocation point, N) on the mesh
/// with node times `t_s` (N + 1) and `interval_points` points per interval,
/// within [lo, hi]. The arcs cover [t_s\[0\], t_s\[N\]] in order; adjacent
/// arcs differ in kind.
pub fn arcs(t_s: &[f64], interval_points: &[usize], values: &[f64], lo: f64, hi: f64) -> Vec<Arc> {
    let n = t_s.len() - 1;
    let cells = cells(t_s, interval_points);
    let act: Vec<Activity> = values[..n].iter().map(|&v| activity(v, lo, hi)).collect();
    let bound = |a: Activity| match a {
        Activity::Lower => ArcKind::Bound(lo),
        Activity::Upper => ArcKind::Bound(hi),
        Activity::Interior => ArcKind::Free,
    };
    // Runs of equal activity: (activity, first point, one past the last).
    let mut runs: Vec<(Activity, usize, usize)> = Vec::new();
    for (i, &a) in act.iter().enumerate() {
        match runs.last_mut() {
            Some(r) if r.0 == a => r.2 = i + 1,
            _ => runs.push((a, i, i + 1)),
        }
    }
    let mut arcs: Vec<Arc> = Vec::new();
    let cell_end = |i: usize| if i + 1 < n { cells[i + 1] } else { t_s[n] };
    for (r, &(a, first, past)) in runs.iter().enumerate() {
        let (t0, t1) = (cells[first], cell_end(past - 1));
        let single = past - first == 1 && a == Activity::Interior;
        let pre = (r > 0).then(|| runs[r - 1].0);
        let post = runs.get(r + 1).map(|x| x.0);
        let bounded = |x: Option<Activity>| x.filter(|&x| x != Activity::Interior);
        let kind = match (single, bounded(pre), bounded(post)) {
            (true, Some(p), Some(q)) if p != q => {
                // A switch inside the cell, by impulse.
                let (vp, vq) = (bound_value(p, lo, hi), bound_value(q, lo, hi));
                let f = ((values[first] - vq) / (vp - vq)).clamp(0.0, 1.0);
                let at = t0 + f * (t1 - t0);
                push(&mut arcs, t0, at, bound(p));
                push(&mut arcs, at, t1, bound(q));
                continue;
            }
            (true, Some(p), Some(q)) if p == q => bound(p),
            (true, Some(p), None) if post.is_none() => bound(p),
            (true, None, Some(q)) if pre.is_none() => bound(q),
            _ => bound(a),
        };
        push(&mut arcs, t0, t1, kind);
    }
    arcs
}

fn bound_value(a: Activity, lo: f64, hi: f64) -> f64 {
    if a == Activity::Lower {
        lo
    } else {
        hi
    }
}

/// Append [t0, t1] of `kind`, merged into the last arc when of the same kind.
fn push(arcs: &mut Vec<Arc>, t0: f64, t1: f64, kind: ArcKind) {
    match arcs.last_mut() {
        Some(last) if last.kind == kind => last.t_end_s = t1,
        _ => arcs.push(Arc {
            t_start_s: t0,
            t_end_s: t1,
            kind,
        }),
    }
    arcs.retain(|a| a.t_end_s > a.t_start_s);
}

/// The start of every point's quadrature cell (module docs).
fn cells(t_s: &[f64], interval_points: &[usize]) -> Vec<f64> {
    control_profile::cells(t_s, interval_points).0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collocation::radau::Lgr;

    /// A known bang–bang control, T = hi on [0, 3), lo on [3, 7), hi after,
    /// sampled as a collocation would report it: each point's value is its
    /// cell's mean (its impulse over its weight). The arcs come back with
    /// the switches at 3 s and 7 s, to the cells' resolution of impulse.
    #[test]
    fn a_bang_bang_control_gives_its_arcs_and_switch_times() {
        let (lo, hi, tf) = (1.0, 3.0, 10.0);
        let n = 20;
        let lgr = Lgr::new(n);
        let t_s: Vec<f64> = (0..=n).map(|k| lgr.time_s(k, tf)).collect();
        let c = cells(&t_s, &[]);
        let truth = |t: f64| if (3.0..7.0).contains(&t) { lo } else { hi };
        let values: Vec<f64> = (0..n)
            .map(|i| {
                let (a, b) = (c[i], if i + 1 < n { c[i + 1] } else { tf });
                // Mean of the bang–bang control over the cell, exactly.
                let m = 400;
                (0..m)
                    .map(|j| truth(a + (j as f64 + 0.5) * (b - a) / m as f64))
                    .sum::<f64>()
                    / m as f64
            })
            .collect();
        let arcs = arcs(&t_s, &[], &values, lo, hi);
        let kinds: Vec<ArcKind> = arcs.iter().map(|a| a.kind).collect();
        assert_eq!(
            kinds,
            vec![ArcKind::Bound(hi), ArcKind::Bound(lo), ArcKind::Bound(hi)]
        );
        assert!((arcs[0].t_end_s - 3.0).abs() < 0.01, "{:?}", arcs);
        assert!((arcs[1].t_end_s - 7.0).abs() < 0.01, "{:?}", arcs);
        assert_eq!(arcs[0].t_start_s, 0.0);
        assert_eq!(arcs[2].t_end_s, tf);
    }

    #[test]
    fn an_interior_run_is_a_free_arc() {
        let (lo, hi) = (1.0, 3.0);
        let t_s: Vec<f64> = (0..=6).map(|k| k as f64).collect();
        let values = [3.0, 3.0, 2.0, 2.2, 1.8, 1.0];
        let arcs = arcs(&t_s, &[1, 1, 1, 1, 1, 1], &values, lo, hi);
        let kinds: Vec<ArcKind> = arcs.iter().map(|a| a.kind).collect();
        assert_eq!(
            kinds,
            vec![ArcKind::Bound(hi), ArcKind::Free, ArcKind::Bound(lo)]
        );
        assert_eq!((arcs[1].t_start_s, arcs[1].t_end_s), (2.0, 5.0));
    }
}
