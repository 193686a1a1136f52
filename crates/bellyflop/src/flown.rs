//! The controls as they are flown: T(t) and δ(t) piece by piece, in a form
//! that anyone can integrate (JSON `controls_flown`).
//!
//! [0, t_f] is cut into pieces [t_start_s, t_end_s]. On each piece the
//! thrust T \[N\] and the nozzle angle δ \[rad\] are each either
//!
//! - a **bound**: a constant (T_min or T_max, or ±δ_max), or
//! - a **polynomial** in the piece's normalized time
//!   s = (t − t_start_s)/(t_end_s − t_start_s) ∈ [0, 1], in the shifted
//!   Legendre basis P̃_k(s) = P_k(2s − 1) (P_0 = 1, P_1 = x,
//!   P_2 = (3x² − 1)/2, P_3 = (5x³ − 3x)/2 with x = 2s − 1):
//!   value(s) = Σ_k c_k·P̃_k(s).
//!
//! T may jump between pieces (a bang–bang switch); δ is continuous. The
//! gimbal rate χ = δ̇ is the derivative of the polynomial,
//! (dδ/ds)/(t_end_s − t_start_s). The landing check
//! ([`crate::verify::propagate::integrate_flown`]) integrates exactly this.

use serde::{Deserialize, Serialize};

/// The polynomial basis of [`Signal::Polynomial`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Basis {
    /// P_k(2s − 1), s ∈ [0, 1] the piece's normalized time (module docs).
    ShiftedLegendre,
}

/// Degree of the polynomials the polish flies (cubic).
pub const DEGREE: usize = 3;

/// One control on one piece.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Signal {
    /// Held on a bound of its range.
    Bound { value: f64 },
    /// Σ_k coefficients\[k\]·P̃_k(s).
    Polynomial {
        basis: Basis,
        coefficients: Vec<f64>,
    },
}

impl Signal {
    /// The signal at normalized time `s` ∈ [0, 1].
    pub fn value(&self, s: f64) -> f64 {
        match self {
            Signal::Bound { value } => *value,
            Signal::Polynomial { coefficients, .. } => {
                let p = legendre(s);
                coefficients.iter().zip(p).map(|(c, p)| c * p).sum()
            }
        }
    }

    /// (min, max) of the signal over its piece, s ∈ [0, 1], exactly: the
    /// ends and the interior extrema ([`critical_points`]).
    pub fn range(&self) -> (f64, f64) {
        let ss: Vec<f64> = match self {
            Signal::Bound { .. } => vec![0.0],
            Signal::Polynomial { coefficients, .. } if coefficients.len() == DEGREE + 1 => {
                let (e, _) = critical_points(coefficients);
                [0.0, 1.0, e[0], e[1]]
                    .into_iter()
                    .filter(|s| s.is_finite())
                    .collect()
            }
            Signal::Polynomial { .. } => vec![f64::NAN],
        };
        fold_range(ss.into_iter().map(|s| self.value(s)))
    }

    /// (min, max) of d(signal)/ds over s ∈ [0, 1], exactly (a quadratic:
    /// its ends and its vertex).
    pub fn slope_range(&self) -> (f64, f64) {
        let ss: Vec<f64> = match self {
            Signal::Bound { .. } => vec![0.0],
            Signal::Polynomial { coefficients, .. } if coefficients.len() == DEGREE + 1 => {
                let (_, v) = critical_points(coefficients);
                [0.0, 1.0, v]
                    .into_iter()
                    .filter(|s| s.is_finite())
                    .collect()
            }
            Signal::Polynomial { .. } => vec![f64::NAN],
        };
        fold_range(ss.into_iter().map(|s| self.slope(s)))
    }

    /// d(signal)/ds at `s` (0 on a bound).
    pub fn slope(&self, s: f64) -> f64 {
        match self {
            Signal::Bound { .. } => 0.0,
            Signal::Polynomial { coefficients, .. } => {
                let d = legendre_slope(s);
                coefficients.iter().zip(d).map(|(c, d)| c * d).sum()
            }
        }
    }
}

/// The interior points s ∈ (0, 1) where a cubic Σ c_k·P̃_k(s) has a zero
/// slope (its interior extrema: NaN where there is none), and the one where
/// its slope does (the extremum of the quadratic slope). A cubic and its
/// slope are bounded on [0, 1] by their values at the ends and there.
pub fn critical_points(c: &[f64]) -> ([f64; 2], f64) {
    // The slope in x = 2s − 1 ([`legendre_slope`]): a·x² + b·x + k.
    let (a, b, k) = (15.0 * c[3], 6.0 * c[2], 2.0 * c[1] - 3.0 * c[3]);
    let mut x = [f64::NAN; 2];
    if a != 0.0 {
        let disc = b * b - 4.0 * a * k;
        if disc >= 0.0 {
            // The numerically stable pair of roots.
            let q = -0.5 * (b + b.signum() * disc.sqrt());
            x = [q / a, if q != 0.0 { k / q } else { f64::NAN }];
        }
    } else if b != 0.0 {
        x[0] = -k / b;
    }
    let slope_x = if a != 0.0 { -b / (2.0 * a) } else { f64::NAN };
    let s = |x: f64| {
        let s = 0.5 * (x + 1.0);
        if s > 0.0 && s < 1.0 {
            s
        } else {
            f64::NAN
        }
    };
    ([s(x[0]), s(x[1])], s(slope_x))
}

/// (min, max) of the values, NaN if any is.
fn fold_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        if v.is_nan() || lo.is_nan() {
            (f64::NAN, f64::NAN)
        } else {
            (lo.min(v), hi.max(v))
        }
    })
}

/// P̃_0..P̃_3 at s.
pub fn legendre(s: f64) -> [f64; DEGREE + 1] {
    let x = 2.0 * s - 1.0;
    [
        1.0,
        x,
        0.5 * (3.0 * x * x - 1.0),
        0.5 * (5.0 * x * x * x - 3.0 * x),
    ]
}

/// dP̃_k/ds = 2·P_k'(2s − 1) at s.
pub fn legendre_slope(s: f64) -> [f64; DEGREE + 1] {
    let x = 2.0 * s - 1.0;
    [0.0, 2.0, 6.0 * x, 15.0 * x * x - 3.0]
}

/// One piece of the flown controls.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Piece {
    pub t_start_s: f64,
    pub t_end_s: f64,
    /// T \[N\].
    pub thrust_n: Signal,
    /// δ \[rad\].
    pub delta_rad: Signal,
}

impl Piece {
    /// Normalized time of `t_s` on this piece.
    pub fn s_of(&self, t_s: f64) -> f64 {
        let d = self.t_end_s - self.t_start_s;
        if d > 0.0 {
            ((t_s - self.t_start_s) / d).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }
}

/// The flown controls of an answer (module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FlownControls {
    pub pieces: Vec<Piece>,
}

impl FlownControls {
    /// t_f: the end of the last piece \[s\].
    pub fn tf_s(&self) -> f64 {
        self.pieces.last().map_or(0.0, |p| p.t_end_s)
    }

    /// The piece that flies time `t_s` (the last one at and after t_f).
    pub fn piece_at(&self, t_s: f64) -> Option<&Piece> {
        self.pieces
            .iter()
            .find(|p| t_s < p.t_end_s)
            .or(self.pieces.last())
    }

    /// (T \[N\], δ \[rad\], χ = δ̇ [rad/s]) at `t_s`.
    pub fn at(&self, t_s: f64) -> Option<(f64, f64, f64)> {
        let p = self.piece_at(t_s)?;
        let s = p.s_of(t_s);
        let d = p.t_end_s - p.t_start_s;
        let chi = if d > 0.0 {
            p.delta_rad.slope(s) / d
        } else {
            0.0
        };
        Some((p.thrust_n.value(s), p.delta_rad.value(s), chi))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shifted_legendre_is_orthogonal_on_the_unit_interval() {
        // Gauss–Legendre with 4 points integrates degree 6 exactly.
        let g = [
            (0.0694318442029737, 0.1739274225687269),
            (0.3300094782075719, 0.3260725774312731),
            (0.6699905217924281, 0.3260725774312731),
            (0.9305681557970263, 0.1739274225687269),
        ];
        for i in 0..=DEGREE {
            for j in 0..=DEGREE {
                let ip: f64 = g
                    .iter()
                    .map(|&(s, w)| w * legendre(s)[i] * legendre(s)[j])
                    .sum();
                let want = if i == j {
                    1.0 / (2 * i + 1) as f64
                } else {
                    0.0
                };
                assert!((ip - want).abs() < 1e-12, "<P{i}, P{j}> = {ip}");
            }
        }
    }

    #[test]
    fn slopes_match_finite_differences() {
        for &s in &[0.0f64, 0.3, 0.77, 1.0] {
            // One-sided at the ends: an error of h·max|d²P̃₃/ds²|/2 = 3e-6.
            let h = 1e-7;
            let (lo, hi) = ((s - h).max(0.0), (s + h).min(1.0));
            for k in 0..=DEGREE {
                let fd = (legendre(hi)[k] - legendre(lo)[k]) / (hi - lo);
                assert!((fd - legendre_slope(s)[k]).abs() < 1e-5, "k {k} s {s}");
            }
        }
    }

    #[test]
    fn pieces_are_found_by_time_and_the_rate_is_the_slope_over_the_duration() {
        let c = FlownControls {
            pieces: vec![
                Piece {
                    t_start_s: 0.0,
                    t_end_s: 2.0,
                    thrust_n: Signal::Bound { value: 5.0 },
                    delta_rad: Signal::Polynomial {
                        basis: Basis::ShiftedLegendre,
                        coefficients: vec![0.0, 0.1, 0.0, 0.0],
                    },
                },
                Piece {
                    t_start_s: 2.0,
                    t_end_s: 3.0,
                    thrust_n: Signal::Bound { value: 1.0 },
                    delta_rad: Signal::Bound { value: 0.1 },
                },
            ],
        };
        let (t, d, chi) = c.at(1.0).unwrap();
        assert_eq!((t, d), (5.0, 0.0));
        assert!(
            (chi - 0.1).abs() < 1e-15,
            "δ = 0.1·(2s − 1), s = t/2: δ̇ = 0.1"
        );
        assert_eq!(c.at(2.5).unwrap().0, 1.0);
        assert_eq!(c.at(9.0).unwrap().0, 1.0);
        assert_eq!(c.tf_s(), 3.0);
    }
}
