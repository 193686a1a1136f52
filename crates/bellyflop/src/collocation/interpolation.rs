//! Interpolation of node values in time: piecewise linear, or the monotone
//! piecewise cubic PCHIP (Fritsch–Carlson), for flying a plan and for the
//! re-integration of an answer's controls.

use serde::Serialize;

// ---------------------------------------------------------------------------
// Interpolation of the controls
// ---------------------------------------------------------------------------

/// How the controls are interpolated between nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Interpolation {
    /// Piecewise linear between node values.
    Linear,
    /// Monotone piecewise cubic Hermite (PCHIP, Fritsch–Carlson): no overshoot,
    /// C¹. The default (see the module documentation for the measurements).
    #[default]
    Pchip,
}

impl Interpolation {
    pub fn as_str(self) -> &'static str {
        match self {
            Interpolation::Linear => "linear",
            Interpolation::Pchip => "pchip",
        }
    }
}

/// A piecewise interpolant y(t) through (t_k, y_k), as a cubic Hermite
/// polynomial on each interval (linear interpolation uses the secant slopes on
/// each interval, so it is exact Hermite data too).
#[derive(Debug, Clone, PartialEq)]
pub struct Interpolant {
    t: Vec<f64>,
    y: Vec<f64>,
    /// PCHIP: slopes d_k at the nodes; linear: empty.
    d: Vec<f64>,
}

impl Interpolant {
    /// Interpolate `y` at strictly increasing times `t` (at least two points).
    pub fn new(kind: Interpolation, t: &[f64], y: &[f64]) -> Self {
        let mut p = Interpolant {
            t: Vec::new(),
            y: Vec::new(),
            d: Vec::new(),
        };
        p.refill(kind, t, y.iter().copied());
        p
    }

    /// [`Self::new`] in place, in this interpolant's own storage (a
    /// re-plan's plan allocates nothing): through `values` at `t`.
    pub fn refill(&mut self, kind: Interpolation, t: &[f64], values: impl Iterator<Item = f64>) {
        self.t.clear();
        self.t.extend_from_slice(t);
        self.y.clear();
        self.y.extend(values);
        assert_eq!(t.len(), self.y.len(), "as many times as values");
        assert!(t.len() >= 2, "at least two points");
        assert!(
            t.windows(2).all(|w| w[1] > w[0]),
            "times strictly increasing"
        );
        self.d.clear();
        if kind == Interpolation::Pchip {
            pchip_slopes(&self.t, &self.y, &mut self.d);
        }
    }

    /// Index of the interval [t_k, t_{k+1}] that contains `t` (clamped to the ends).
    pub fn segment(&self, t: f64) -> usize {
        let k = self.t.partition_point(|&tk| tk <= t);
        k.saturating_sub(1).min(self.t.len() - 2)
    }

    /// Value at `t` of the polynomial piece on interval `k` (extrapolated
    /// outside it), so that an integration step inside one interval sees one
    /// smooth function.
    pub fn eval_on(&self, k: usize, t: f64) -> f64 {
        let (t0, t1) = (self.t[k], self.t[k + 1]);
        let (y0, y1) = (self.y[k], self.y[k + 1]);
        let h = t1 - t0;
        let s = (t - t0) / h;
        if self.d.is_empty() {
            return y0 + s * (y1 - y0);
        }
        let (d0, d1) = (self.d[k], self.d[k + 1]);
        let s2 = s * s;
        let s3 = s2 * s;
        let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
        let h10 = s3 - 2.0 * s2 + s;
        let h01 = -2.0 * s3 + 3.0 * s2;
        let h11 = s3 - s2;
        h00 * y0 + h10 * h * d0 + h01 * y1 + h11 * h * d1
    }

    /// Value at `t`.
    pub fn eval(&self, t: f64) -> f64 {
        self.eval_on(self.segment(t), t)
    }
}

/// Node slopes of the monotone cubic interpolant (PCHIP) of Fritsch and Carlson
/// (1980), with the interior slopes of Fritsch and Butland (1984) as in MATLAB's
/// `pchip` and SciPy's `PchipInterpolator`: zero at a local extremum or flat
/// interval, else the weighted harmonic mean of the neighbouring secants (which
/// meets the Fritsch–Carlson monotonicity condition α, β ≤ 3), and a one-sided
/// three-point shape-preserving formula at the two ends.
fn pchip_slopes(t: &[f64], y: &[f64], d: &mut Vec<f64>) {
    let n = t.len();
    // The interval widths and secants, h_k and Δ_k.
    let h = |k: usize| t[k + 1] - t[k];
    let delta = |k: usize| (y[k + 1] - y[k]) / h(k);
    if n == 2 {
        d.extend([delta(0), delta(0)]);
        return;
    }
    d.resize(n, 0.0);
    for (k, dk) in d.iter_mut().enumerate().take(n - 1).skip(1) {
        let (a, b) = (delta(k - 1), delta(k));
        if a * b > 0.0 {
            let w1 = 2.0 * h(k) + h(k - 1);
            let w2 = h(k) + 2.0 * h(k - 1);
            *dk = (w1 + w2) / (w1 / a + w2 / b);
        }
    }
    d[0] = pchip_end_slope(h(0), h(1), delta(0), delta(1));
    d[n - 1] = pchip_end_slope(h(n - 2), h(n - 3), delta(n - 2), delta(n - 3));
}

/// Three-point end slope, limited to keep the end interval shape-preserving.
fn pchip_end_slope(h0: f64, h1: f64, del0: f64, del1: f64) -> f64 {
    let d = ((2.0 * h0 + h1) * del0 - h0 * del1) / (h0 + h1);
    if d.signum() != del0.signum() || del0 == 0.0 {
        0.0
    } else if del0.signum() != del1.signum() && d.abs() > 3.0 * del0.abs() {
        3.0 * del0
    } else {
        d
    }
}
