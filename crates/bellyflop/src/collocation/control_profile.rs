//! The controls a vehicle can fly from a collocation answer: T and χ at
//! every instant, within their bounds, with the impulse of every
//! collocation point kept.
//!
//! The collocation knows a control only at its points, and its quadrature
//! gives point i of interval k the cell [c_i, c_i + w_i] (the interval's
//! LGR weights in order, mapped to time: the cells partition the interval).
//! Between the points the profile is, cell by cell:
//!
//! - **on a bound** (within [`ON_BOUND`] of the range): the point's value,
//!   held over its cell;
//! - **a switch**: a point off the bounds between two points on opposite
//!   bounds (across an interval break too). Over the cell the profile takes
//!   the first bound for a fraction f = (v − post)/(pre − post) and the
//!   second after it: the point's impulse v·w_i, with the switch where
//!   [`crate::refine::events`] places it;
//! - **anywhere else** (an interior arc): the polynomial through the
//!   interval's run of such points (degree n_k − 1 on an interval without
//!   bounds), clamped to the bounds.
//!
//! The degree-(n_k − 1) polynomial alone is what the collocation "assumes"
//! between its points, but across a switch it rings out of [T_min, T_max]
//! and cannot be flown; clamped, it loses impulse. On the 101 refined
//! envelope states of `bench/refinement.py` the clamp lost up to 33 kg of
//! propellant against the optimized mass, and states missed the pad by
//! metres where the interval error estimate, computed with the unclamped
//! polynomial, read 1e-4 (issue 16, BENCHMARKS.md "Mesh refinement").
//! Both the landing error
//! ([`crate::verify::propagate`]) and the error estimate ([`crate::verify::mesh_error`])
//! integrate this profile, so that the estimate measures what is flown.

use crate::collocation::radau::{barycentric_weights, interpolate, Lgr};

/// A signal within this fraction of its range of a bound is on that bound
/// (for the profile's holds and for refinement's events alike). A point
/// held over its cell within 1 % of the bound keeps its impulse; holding
/// only within 1e-4 (the polynomial elsewhere) landed fewer of the 101
/// refinement states within 0.1 m, 34 against 37 (BENCHMARKS.md, "Mesh
/// refinement").
pub const ON_BOUND: f64 = 1e-2;

/// Where a signal sits against its bounds at one collocation point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Activity {
    Lower,
    Interior,
    Upper,
}

/// The activity of value `v` against the bounds [lo, hi] ([`ON_BOUND`]).
pub fn activity(v: f64, lo: f64, hi: f64) -> Activity {
    let tol = ON_BOUND * (hi - lo);
    if v <= lo + tol {
        Activity::Lower
    } else if v >= hi - tol {
        Activity::Upper
    } else {
        Activity::Interior
    }
}

/// What the profile is on one quadrature cell.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Piece {
    /// The point's value, held.
    Hold(f64),
    /// `before` until `at_s`, then `after`.
    Switch { at_s: f64, before: f64, after: f64 },
    /// The clamped polynomial of the point's run (an index of
    /// `Profile::polynomials`).
    Polynomial(usize),
}

/// The polynomial of one run of interior points inside an interval: their
/// times and barycentric weights, and their values.
#[derive(Debug, Clone, PartialEq)]
struct RunPolynomial {
    t_s: Vec<f64>,
    bary: Vec<f64>,
    values: Vec<f64>,
}

/// A control between the collocation points of a solution (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    /// Per cell, in time order: its start \[s\] and its piece; the last cell
    /// ends at `end_s`.
    cell_start_s: Vec<f64>,
    pieces: Vec<Piece>,
    end_s: f64,
    polynomials: Vec<RunPolynomial>,
    lo: f64,
    hi: f64,
}

/// The quadrature cell of every collocation point: its start \[s\] (point
/// i of an interval starts at its τ_lo plus the weights before it, mapped
/// to time) and its interval, on the mesh with node times `t_s` (N + 1) and
/// `interval_points` points per interval (Σ = N; empty: one interval).
///
/// # Panics
/// Panics if the points do not add up to N.
pub fn cells(t_s: &[f64], interval_points: &[usize]) -> (Vec<f64>, Vec<usize>) {
    let n = t_s.len() - 1;
    let whole = [n];
    let points = if interval_points.is_empty() {
        &whole[..]
    } else {
        interval_points
    };
    assert_eq!(points.iter().sum::<usize>(), n, "points per interval");
    let mut cell_start_s = Vec::with_capacity(n);
    let mut cell_interval = Vec::with_capacity(n);
    let mut start = 0;
    for (k, &np) in points.iter().enumerate() {
        let (t_lo, t_hi) = (t_s[start], t_s[start + np]);
        let mut at = t_lo;
        for w in &Lgr::new(np).weights {
            cell_start_s.push(at);
            cell_interval.push(k);
            at += 0.5 * (t_hi - t_lo) * w;
        }
        start += np;
    }
    (cell_start_s, cell_interval)
}

impl Profile {
    /// The profile of `values` (one per collocation point) on the mesh
    /// whose node times are `t_s` (N + 1, strictly increasing) and whose
    /// intervals hold `interval_points` points each (Σ = N; empty: one
    /// interval), within [lo, hi].
    ///
    /// # Panics
    /// Panics if the lengths disagree (callers check them first).
    pub fn new(t_s: &[f64], interval_points: &[usize], values: &[f64], lo: f64, hi: f64) -> Self {
        let n = t_s.len() - 1;
        assert!(values.len() >= n, "one value per collocation point");
        let (cell_start_s, cell_interval) = cells(t_s, interval_points);
        let act: Vec<Activity> = values[..n].iter().map(|&v| activity(v, lo, hi)).collect();
        let bound = |a: Activity| match a {
            Activity::Lower => Some(lo),
            Activity::Upper => Some(hi),
            Activity::Interior => None,
        };
        let end_s = t_s[n];
        let mut pieces: Vec<Piece> = (0..n)
            .map(|i| {
                if act[i] != Activity::Interior {
                    return Piece::Hold(values[i].clamp(lo, hi));
                }
                let pre = (i > 0).then(|| bound(act[i - 1])).flatten();
                let post = (i + 1 < n).then(|| bound(act[i + 1])).flatten();
                match (pre, post) {
                    (Some(pre), Some(post)) if pre != post => {
                        let f = ((values[i] - post) / (pre - post)).clamp(0.0, 1.0);
                        let cell_end = cell_start_s.get(i + 1).copied().unwrap_or(end_s);
                        let at_s = cell_start_s[i] + f * (cell_end - cell_start_s[i]);
                        Piece::Switch {
                            at_s,
                            before: pre,
                            after: post,
                        }
                    }
                    _ => Piece::Polynomial(usize::MAX),
                }
            })
            .collect();
        // Each run of interior points inside one interval gets the
        // polynomial through its own points: one through the points on a
        // bound as well would ring across the arc's end.
        let mut polynomials = Vec::new();
        let mut i = 0;
        while i < n {
            if !matches!(pieces[i], Piece::Polynomial(_)) {
                i += 1;
                continue;
            }
            let mut j = i + 1;
            while j < n
                && matches!(pieces[j], Piece::Polynomial(_))
                && cell_interval[j] == cell_interval[i]
            {
                j += 1;
            }
            let tp = t_s[i..j].to_vec();
            polynomials.push(RunPolynomial {
                bary: barycentric_weights(&tp),
                t_s: tp,
                values: values[i..j].to_vec(),
            });
            for piece in &mut pieces[i..j] {
                *piece = Piece::Polynomial(polynomials.len() - 1);
            }
            i = j;
        }
        Profile {
            cell_start_s,
            pieces,
            end_s,
            polynomials,
            lo,
            hi,
        }
    }

    /// The control at time `t` \[s\] (clamped to the mesh's span).
    pub fn at(&self, t: f64) -> f64 {
        let i = self
            .cell_start_s
            .partition_point(|&s| s <= t)
            .saturating_sub(1);
        match self.pieces[i] {
            Piece::Hold(v) => v,
            Piece::Switch {
                at_s,
                before,
                after,
            } => {
                if t < at_s {
                    before
                } else {
                    after
                }
            }
            Piece::Polynomial(run) => {
                let p = &self.polynomials[run];
                interpolate(&p.t_s, &p.bary, &p.values, t).clamp(self.lo, self.hi)
            }
        }
    }

    /// The times inside (t0, t1) where the profile may jump: the starts of
    /// cells that are not inside one interval's polynomial, and the
    /// switches. An integrator stops at them instead of stepping across.
    pub fn jumps_in(&self, t0: f64, t1: f64, out: &mut Vec<f64>) {
        for i in 0..self.pieces.len() {
            let smooth = i > 0
                && matches!(self.pieces[i], Piece::Polynomial(_))
                && self.pieces[i] == self.pieces[i - 1];
            let s = self.cell_start_s[i];
            if !smooth && s > t0 && s < t1 {
                out.push(s);
            }
            if let Piece::Switch { at_s, .. } = self.pieces[i] {
                if at_s > t0 && at_s < t1 {
                    out.push(at_s);
                }
            }
        }
    }

    /// The stops of an integration from t0 to t1 across `profiles`: t0,
    /// their jumps inside (t0, t1) in order, t1. An integrator that steps
    /// from stop to stop never steps across a jump of the controls.
    pub fn stops(t0: f64, t1: f64, profiles: &[&Profile], out: &mut Vec<f64>) {
        out.clear();
        out.push(t0);
        for p in profiles {
            p.jumps_in(t0, t1, out);
        }
        out[1..].sort_by(f64::total_cmp);
        out.push(t1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    impl Profile {
        /// ∫ profile dt over the mesh's span, by the cells (exact for holds and
        /// switches; 8-point LGR on the polynomial cells): the impulse the
        /// profile keeps.
        fn integral(&self) -> f64 {
            let gl = Lgr::new(8);
            let mut sum = 0.0;
            for i in 0..self.pieces.len() {
                let a = self.cell_start_s[i];
                let b = self.cell_start_s.get(i + 1).copied().unwrap_or(self.end_s);
                sum += match self.pieces[i] {
                    Piece::Hold(v) => v * (b - a),
                    Piece::Switch {
                        at_s,
                        before,
                        after,
                    } => before * (at_s - a) + after * (b - at_s),
                    Piece::Polynomial(_) => gl
                        .nodes
                        .iter()
                        .take(gl.n)
                        .zip(&gl.weights)
                        .map(|(&r, &w)| 0.5 * (b - a) * w * self.at(a + 0.5 * (b - a) * (r + 1.0)))
                        .sum(),
                };
            }
            sum
        }
    }

    /// Node times of a uniform hp mesh on [0, tf].
    fn times(points: &[usize], tf: f64) -> Vec<f64> {
        let mesh = crate::collocation::mesh::Mesh::uniform(points.iter().sum(), points.len());
        (0..=mesh.n).map(|k| mesh.time_s(k, tf)).collect()
    }

    /// A switch inside a cell keeps the point's impulse: the profile's
    /// integral equals the collocation's quadrature Σ w_i v_i, and the
    /// switch sits at the fraction (v − post)/(pre − post) of the cell.
    #[test]
    fn a_switch_keeps_the_impulse_of_its_point() {
        let points = [5, 5];
        let t = times(&points, 10.0);
        let (lo, hi) = (1.0, 3.0);
        let v = [1.0, 1.0, 1.0, 1.5, 3.0, 3.0, 3.0, 3.0, 3.0, 3.0];
        let p = Profile::new(&t, &points, &v, lo, hi);
        let lgr = Lgr::new(5);
        let quadrature: f64 = v
            .iter()
            .enumerate()
            .map(|(i, &x)| 2.5 * lgr.weights[i % 5] * x)
            .sum();
        assert!(
            (p.integral() - quadrature).abs() < 1e-12,
            "{} {quadrature}",
            p.integral()
        );
        let cell_lo = 2.5 * (lgr.weights[0] + lgr.weights[1] + lgr.weights[2]);
        // A quarter of the way up: T_min for three quarters of the cell.
        let switch = cell_lo + 0.75 * 2.5 * lgr.weights[3];
        assert_eq!(p.at(switch - 1e-9), lo);
        assert_eq!(p.at(switch + 1e-9), hi);
        let mut jumps = Vec::new();
        p.jumps_in(0.0, 10.0, &mut jumps);
        assert!(
            jumps.iter().any(|&j| (j - switch).abs() < 1e-15),
            "{jumps:?}"
        );
    }

    /// On an interior arc the profile is the interval's polynomial, within
    /// the bounds: a quadratic through five points is reproduced exactly.
    #[test]
    fn an_interior_arc_follows_the_polynomial_within_the_bounds() {
        let points = [5];
        let t = times(&points, 4.0);
        let q = |s: f64| 2.0 + 0.1 * (s - 2.0) * (s - 2.0);
        let v: Vec<f64> = t[..5].iter().map(|&s| q(s)).collect();
        let p = Profile::new(&t, &points, &v, 1.0, 3.0);
        for s in [0.3, 1.7, 2.2, 3.9] {
            assert!((p.at(s) - q(s)).abs() < 1e-12);
        }
        // The same values against bounds that cut the arc: clamped.
        let p = Profile::new(&t, &points, &v, 1.0, 2.05);
        assert!(p.at(3.9) <= 2.05);
    }
}
