//! The operational path constraints of issue 37: an approach cone about the
//! pad, a pitch-rate limit, a tilt limit below an altitude and a vertical
//! final descent. Each is optional in the scenario (`[constraints]`,
//! [`Constraints`]); this module turns the ones switched on into smooth rows
//!
//!   g(y) ≤ 0,   y = (x, z, Vx, Vz, θ, w, m),
//!
//! with their gradient and Hessian, that every method and every check uses:
//! the direct method and SCvx at the LGR nodes, the polish on its
//! integrator's steps, and `verify::path` along the flown path.
//!
//! With Δx = x − x_f and Δz = z − z_f (the pad), the rows are, each |·|
//! written as two rows (+ and −):
//!
//! - **cone** of half-angle γ from the vertical:  ±Δx − tan γ·Δz ≤ 0 \[m\];
//! - **pitch rate**:                              ±w − w_max ≤ 0 [rad/s];
//! - **tilt** below h_t:              ±θ − θ_max − S_θ·sp(Δz − h_t) ≤ 0 \[rad\];
//! - **final descent** below h_d:     ±Vx − v_d − S_v·sp(Δz − h_d) ≤ 0 [m/s].
//!
//! The two altitude-triggered limits ("if Δz ≤ h then …", Szmuk, Reynolds &
//! Açıkmeşe 2020) are made smooth by the softplus of width σ = 1 m,
//! sp(u) = σ·ln(1 + e^{u/σ}): C^∞ for Newton, within σ·ln 2 = 0.69 m of
//! max(u, 0), so a few metres below h the limit is θ_max (v_d) to within
//! 1e-3 of its slope, and above h it opens by S_θ = 1°/m (S_v = 1 m/s per
//! m). Since sp is convex, each triggered row is concave in Δz: its
//! linearization (SCvx's) is tighter than the row, so a linearized step
//! that meets it meets the row.

use serde::{Deserialize, Serialize};

pub use crate::input::scenario::Constraints;
use crate::input::scenario::Scenario;
use crate::problem::dynamics::ix;

/// The softplus width σ of the altitude triggers \[m\].
pub const TRIGGER_WIDTH_M: f64 = 1.0;
/// How fast the tilt limit opens above its altitude, S_θ [rad/m] (1°/m).
pub const TILT_OPENING_RAD_PER_M: f64 = std::f64::consts::PI / 180.0;
/// How fast the final descent's lateral limit opens above its altitude,
/// S_v [(m/s)/m].
pub const LATERAL_OPENING_PER_S: f64 = 1.0;

/// Which limit a row belongs to (the JSON's and the messages' name).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Limit {
    Cone,
    PitchRate,
    Tilt,
    FinalDescent,
}

impl Limit {
    /// A readable name for messages.
    pub fn describe(self) -> &'static str {
        match self {
            Limit::Cone => "the approach cone",
            Limit::PitchRate => "the pitch-rate limit",
            Limit::Tilt => "the tilt limit",
            Limit::FinalDescent => "the final descent's lateral-speed limit",
        }
    }

    /// The unit of its rows' values.
    pub fn unit(self) -> &'static str {
        match self {
            Limit::Cone => "m",
            Limit::PitchRate => "rad/s",
            Limit::Tilt => "rad",
            Limit::FinalDescent => "m/s",
        }
    }
}

/// The shape of one row, ±(state) against a bound.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Shape {
    /// sign·Δx − tan γ·Δz.
    Cone { tan: f64 },
    /// sign·y_i − bound.
    Bound { state: usize, bound: f64 },
    /// sign·y_i − bound − slope·sp(Δz − h).
    Triggered {
        state: usize,
        bound: f64,
        slope: f64,
        h_m: f64,
    },
}

/// One smooth row g(y) ≤ 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    pub limit: Limit,
    /// +1 or −1: which side of the |·|.
    pub sign: f64,
    shape: Shape,
    /// The pad (x_f, z_f) \[m\].
    pad: (f64, f64),
}

/// A row's value, its gradient over y, and its one second derivative
/// ∂²g/∂z² (every other entry of its Hessian is zero).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Eval {
    pub g: f64,
    pub grad: [f64; 7],
    pub d2_dz2: f64,
}

/// sp(u) = σ·ln(1 + e^{u/σ}), with sp′ and sp″, evaluated stably.
pub fn softplus(u: f64) -> (f64, f64, f64) {
    let s = TRIGGER_WIDTH_M;
    let e = (-u.abs() / s).exp();
    let value = u.max(0.0) + s * e.ln_1p();
    // sp′ = logistic(u/σ), sp″ = sp′(1 − sp′)/σ.
    let d1 = if u >= 0.0 {
        1.0 / (1.0 + e)
    } else {
        e / (1.0 + e)
    };
    (value, d1, d1 * (1.0 - d1) / s)
}

impl Row {
    /// g(y), ∇g and ∂²g/∂z².
    pub fn eval(&self, y: &[f64]) -> Eval {
        let mut grad = [0.0; 7];
        let dz = y[ix::Z] - self.pad.1;
        match self.shape {
            Shape::Cone { tan } => {
                grad[ix::X] = self.sign;
                grad[ix::Z] = -tan;
                Eval {
                    g: self.sign * (y[ix::X] - self.pad.0) - tan * dz,
                    grad,
                    d2_dz2: 0.0,
                }
            }
            Shape::Bound { state, bound } => {
                grad[state] = self.sign;
                Eval {
                    g: self.sign * y[state] - bound,
                    grad,
                    d2_dz2: 0.0,
                }
            }
            Shape::Triggered {
                state,
                bound,
                slope,
                h_m,
            } => {
                let (sp, d1, d2) = softplus(dz - h_m);
                grad[state] = self.sign;
                grad[ix::Z] = -slope * d1;
                Eval {
                    g: self.sign * y[state] - bound - slope * sp,
                    grad,
                    d2_dz2: -slope * d2,
                }
            }
        }
    }

    /// g(y) alone.
    pub fn value(&self, y: &[f64]) -> f64 {
        self.eval(y).g
    }

    /// The scale of the row's values, for tolerances and scaling: the
    /// bound, or 1 m for the cone.
    pub fn scale(&self) -> f64 {
        match (self.limit, self.shape) {
            (_, Shape::Cone { .. }) => 1.0,
            (Limit::Tilt, Shape::Triggered { bound, .. }) => bound.max(1f64.to_radians()),
            (_, Shape::Bound { bound, .. } | Shape::Triggered { bound, .. }) => bound.max(0.1),
        }
    }

    /// The state the row bounds on both sides, and its limit B(y) at y
    /// (|y_own| ≤ B(y)), for the bound and triggered rows; None for the
    /// cone (about x_f, not 0).
    pub fn own_and_limit(&self, y: &[f64]) -> Option<(usize, f64)> {
        match self.shape {
            Shape::Cone { .. } => None,
            Shape::Bound { state, .. } | Shape::Triggered { state, .. } => {
                Some((state, self.sign * y[state] - self.value(y)))
            }
        }
    }

    /// For the cone: y moved strictly inside it, by the fraction `push` of
    /// its half-width: |x − x_f| ≤ (1 − push)·tan γ·(z − z_f), with z raised
    /// to at least `min_height_m` above the pad (the cone is empty at the
    /// pad's height). None for the other rows ([`Self::own_and_limit`]).
    pub fn inside_cone(&self, y: &[f64; 7], push: f64, min_height_m: f64) -> Option<[f64; 7]> {
        let Shape::Cone { tan } = self.shape else {
            return None;
        };
        let mut out = *y;
        out[ix::Z] = y[ix::Z].max(self.pad.1 + min_height_m);
        let half = (1.0 - push) * tan * (out[ix::Z] - self.pad.1);
        out[ix::X] = self.pad.0 + (y[ix::X] - self.pad.0).clamp(-half, half);
        Some(out)
    }

    /// Whether the row involves only states that the transcription holds
    /// linearly (no trigger): its linearization is the row.
    pub fn is_affine(&self) -> bool {
        !matches!(self.shape, Shape::Triggered { .. })
    }
}

/// The rows of a scenario's constraints, in a fixed order (cone, pitch
/// rate, tilt, final descent; + before −). Empty for the paper's case.
pub fn rows(s: &Scenario) -> Vec<Row> {
    each_row(s).collect()
}

/// [`rows`] one by one, without allocating (for the flight loop's
/// re-plans, issue 27).
pub fn each_row(s: &Scenario) -> impl Iterator<Item = Row> {
    let c = &s.constraints;
    let pad = (s.terminal.x_m, s.terminal.z_m);
    let cone = c.cone_half_angle_deg.map(|gamma| {
        (
            Limit::Cone,
            Shape::Cone {
                tan: gamma.to_radians().tan(),
            },
        )
    });
    let rate = c.max_pitch_rate_degps.map(|w| {
        (
            Limit::PitchRate,
            Shape::Bound {
                state: ix::W,
                bound: w.to_radians(),
            },
        )
    });
    let tilt = c.max_tilt_deg.zip(c.tilt_below_m).map(|(theta, h)| {
        (
            Limit::Tilt,
            Shape::Triggered {
                state: ix::THETA,
                bound: theta.to_radians(),
                slope: TILT_OPENING_RAD_PER_M,
                h_m: h,
            },
        )
    });
    let descent = c
        .final_descent_m
        .zip(c.final_descent_lateral_mps)
        .map(|(h, v)| {
            (
                Limit::FinalDescent,
                Shape::Triggered {
                    state: ix::VX,
                    bound: v,
                    slope: LATERAL_OPENING_PER_S,
                    h_m: h,
                },
            )
        });
    [cone, rate, tilt, descent]
        .into_iter()
        .flatten()
        .flat_map(move |(limit, shape)| {
            [1.0, -1.0].map(|sign| Row {
                limit,
                sign,
                shape,
                pad,
            })
        })
}

/// A row broken at a node of a collocation answer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeExcess {
    pub limit: Limit,
    /// The node's index (0 … N).
    pub node: usize,
    /// g at the node, in the row's unit ([`Limit::unit`]).
    pub excess: f64,
}

/// The worst row of `s` at the node states `x` (physical, a
/// trajectory's `x`) that exceeds its limit by
/// more than `relative` of its scale ([`Row::scale`]), or None: the check
/// of a raw answer before the planner adopts it (each method holds the rows
/// at its nodes only to its own tolerances, SCvx's linearized). Allocates
/// nothing.
pub fn worst_at_nodes<Y: AsRef<[f64]>>(s: &Scenario, x: &[Y], relative: f64) -> Option<NodeExcess> {
    let mut worst: Option<(f64, NodeExcess)> = None;
    for row in each_row(s) {
        for (node, y) in x.iter().enumerate() {
            let excess = row.value(y.as_ref());
            let over = excess / row.scale() - relative;
            if over > 0.0 && worst.is_none_or(|(w, _)| over > w) {
                let limit = row.limit;
                worst = Some((
                    over,
                    NodeExcess {
                        limit,
                        node,
                        excess,
                    },
                ));
            }
        }
    }
    worst.map(|(_, e)| e)
}

/// The limits that `c` switches on, in the order of [`Limit`].
pub fn limits(c: &Constraints) -> Vec<Limit> {
    let on = [
        (Limit::Cone, c.cone_half_angle_deg.is_some()),
        (Limit::PitchRate, c.max_pitch_rate_degps.is_some()),
        (Limit::Tilt, c.max_tilt_deg.is_some()),
        (Limit::FinalDescent, c.final_descent_m.is_some()),
    ];
    on.into_iter()
        .filter(|&(_, on)| on)
        .map(|(l, _)| l)
        .collect()
}

/// `c` with one limit alone switched on (with its own settings).
pub fn only(c: &Constraints, limit: Limit) -> Constraints {
    let mut one = Constraints::default();
    match limit {
        Limit::Cone => one.cone_half_angle_deg = c.cone_half_angle_deg,
        Limit::PitchRate => one.max_pitch_rate_degps = c.max_pitch_rate_degps,
        Limit::Tilt => {
            one.max_tilt_deg = c.max_tilt_deg;
            one.tilt_below_m = c.tilt_below_m;
        }
        Limit::FinalDescent => {
            one.final_descent_m = c.final_descent_m;
            one.final_descent_lateral_mps = c.final_descent_lateral_mps;
        }
    }
    one
}

/// The worst row of a state: (row index, g), or None without rows.
pub fn worst(rows: &[Row], y: &[f64]) -> Option<(usize, f64)> {
    rows.iter()
        .enumerate()
        .map(|(i, r)| (i, r.value(y)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn constrained() -> Scenario {
        let mut s = Scenario::paper();
        s.constraints = Constraints {
            cone_half_angle_deg: Some(30.0),
            max_pitch_rate_degps: Some(20.0),
            max_tilt_deg: Some(10.0),
            tilt_below_m: Some(100.0),
            final_descent_m: Some(30.0),
            final_descent_lateral_mps: Some(2.0),
        };
        s
    }

    /// Every row's gradient and ∂²/∂z² against central differences, at
    /// states around each trigger's altitude.
    #[test]
    fn row_derivatives_match_finite_differences() {
        let s = constrained();
        let rows = rows(&s);
        assert_eq!(rows.len(), 8);
        for z in [20.0, 29.5, 31.0, 99.0, 100.3, 140.0] {
            let y = [-12.0, z, 3.0, -20.0, 0.2, -0.1, 1e5];
            for r in &rows {
                let e = r.eval(&y);
                for i in 0..7 {
                    let h = 1e-6 * y[i].abs().max(1.0);
                    let (mut a, mut b) = (y, y);
                    a[i] += h;
                    b[i] -= h;
                    let fd = (r.value(&a) - r.value(&b)) / (2.0 * h);
                    assert!((fd - e.grad[i]).abs() < 1e-7, "{r:?} ∂/∂y{i}");
                }
                let h = 1e-4;
                let (mut a, mut b) = (y, y);
                a[ix::Z] += h;
                b[ix::Z] -= h;
                let fd2 = (r.eval(&a).grad[ix::Z] - r.eval(&b).grad[ix::Z]) / (2.0 * h);
                assert!((fd2 - e.d2_dz2).abs() < 1e-7, "{r:?} ∂²/∂z²");
            }
        }
    }

    /// The triggers: a few σ below h the limit is the bound, above h it
    /// opens at its slope; the softplus is within σ·ln 2 of max(u, 0).
    #[test]
    fn the_triggers_hold_below_their_altitude_and_open_above() {
        for u in [-50.0, -5.0, -1.0, 0.0, 1.0, 5.0, 50.0] {
            let (sp, d1, _) = softplus(u);
            assert!(sp >= u.max(0.0) && sp - u.max(0.0) <= TRIGGER_WIDTH_M * 2f64.ln() + 1e-15);
            assert!((0.0..=1.0).contains(&d1));
        }
        let s = constrained();
        let tilt = rows(&s)
            .into_iter()
            .find(|r| r.limit == Limit::Tilt && r.sign > 0.0)
            .unwrap();
        let at = |z: f64, theta_deg: f64| {
            tilt.value(&[0.0, z, 0.0, 0.0, theta_deg.to_radians(), 0.0, 1e5])
        };
        // 10° is the limit 8 m below h; 10.1° breaks it there.
        assert!(at(92.0, 10.0) <= 0.0 && at(92.0, 10.1) > 0.0);
        // 50 m above h, 59° is allowed and 61° is not.
        assert!(at(150.0, 59.0) < 0.0 && at(150.0, 61.0) > 0.0);
    }

    /// `only` keeps one limit with its own settings; `limits` names them.
    #[test]
    fn one_limit_alone() {
        let c = constrained().constraints;
        assert_eq!(
            limits(&c),
            vec![
                Limit::Cone,
                Limit::PitchRate,
                Limit::Tilt,
                Limit::FinalDescent
            ]
        );
        for l in limits(&c) {
            let one = only(&c, l);
            assert_eq!(limits(&one), vec![l]);
            let s = Scenario {
                constraints: one,
                ..constrained()
            };
            assert!(rows(&s).iter().all(|r| r.limit == l));
            assert_eq!(rows(&s).len(), 2);
        }
        assert_eq!(only(&c, Limit::Tilt).tilt_below_m, c.tilt_below_m);
        assert!(limits(&Constraints::default()).is_empty());
    }

    /// The cone's rows: inside, on and outside, about the pad.
    #[test]
    fn the_cone_is_about_the_pad() {
        let mut s = constrained();
        s.terminal.x_m = 10.0;
        let rows: Vec<Row> = rows(&s)
            .into_iter()
            .filter(|r| r.limit == Limit::Cone)
            .collect();
        let tan = 30f64.to_radians().tan();
        let worst_at = |x: f64, z: f64| worst(&rows, &[x, z, 0.0, 0.0, 0.0, 0.0, 1.0]).unwrap().1;
        assert!(worst_at(10.0 + 50.0 * tan - 1e-6, 50.0) < 0.0);
        assert!(worst_at(10.0 - 50.0 * tan - 1e-6, 50.0) > 0.0);
        assert!(worst_at(10.0, 0.0).abs() < 1e-12);
        assert!(
            Scenario::paper().constraints.is_empty() && super::rows(&Scenario::paper()).is_empty()
        );
    }
}
