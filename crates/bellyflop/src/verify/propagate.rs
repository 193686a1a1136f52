//! Landing precision by re-propagation (the check of the paper's Tables 4–5).
//!
//! A collocation solution meets the dynamics only at its nodes. To see how well
//! its controls actually land the vehicle, [`propagate`] integrates the full
//! nonlinear model of Eq. (1)–(3) in mass and thrust form
//! ([`dynamics::rhs_physical`], state x, z, Vx, Vz, θ, w, m) from the solution's
//! initial state to t_f, with the thrust T(t) and nozzle angle δ(t) interpolated
//! in time from the solution, and measures the miss against the scenario's
//! terminal state.
//!
//! # The integrator
//!
//! [`Dop853`] is the explicit Runge–Kutta method of Dormand and Prince of order
//! 8 with embedded error estimators of orders 5 and 3 and the step-size control of
//! Hairer's `DOP853` (Hairer, Nørsett, Wanner, *Solving ODEs I*, 2nd ed., §II.10;
//! coefficients from `dop853.f`). It is our own code rather than a crate because:
//! `ode_solvers` 0.6 (which has `Dop853`) depends on nalgebra 0.34 while this
//! workspace uses 0.35, so its state vectors would be a second, incompatible
//! nalgebra in the build, and it collects every output point of a call into its
//! own result vectors, which the segment-by-segment integration below does not
//! need; `diffsol` targets stiff and implicit problems and brings faer and a large
//! dependency tree for what is, here, one explicit method on a 7-state system.
//! The method is ~200 lines, checked in the tests against analytic solutions and
//! for its eighth order of convergence.
//!
//! # The controls
//!
//! The thrust is known at the N collocation points (the last entry of
//! [`Solution::thrust_n`], at t_f, holds the last collocation point's σ = T/m
//! times m(t_f), within [T_min, T_max]); δ is a
//! state known at all N + 1 nodes ([`Solution::delta_rad`]). Between nodes they
//! are interpolated by [`Interpolation::Linear`] or [`Interpolation::Pchip`]
//! (monotone piecewise cubic). The integration runs segment by segment between
//! node times, so that no step straddles a kink of the interpolant.
//!
//! [`NozzleModel::Angle`] (default) interpolates δ itself, as the paper's P1;
//! [`NozzleModel::Rate`] integrates δ̇ = χ (Eq. 8, problem P2) from the
//! interpolated gimbal rate χ instead.
//!
//! **Default: PCHIP with the nozzle angle.** On the paper's case the optimal
//! thrust is bang-bang. PCHIP follows the switch without overshoot (it never
//! leaves the range of the node values, so T stays within its bounds) and,
//! unlike the chords of linear interpolation, follows the smooth arcs of T and δ
//! to third order. Measured on the paper's case (`cargo run --release -p
//! bellyflop --example landing_precision`, and `bellyflop sweep
//! --interpolation linear|pchip`), position / velocity miss at t_f:
//!
//! | N | exact, PCHIP | exact, linear | paper form., PCHIP | paper form., linear |
//! |---|---|---|---|---|
//! | 15 | 1.123 m / 0.202 m/s | 2.218 / 0.358 | 0.469 / 0.187 | 3.108 / 0.892 |
//! | 20 | 1.317 / 0.648 | 2.565 / 0.803 | 0.808 / 0.323 | 2.112 / 0.662 |
//! | 30 | 0.167 / 0.076 | 0.761 / 0.195 | 0.452 / 0.186 | 0.895 / 0.286 |
//! | 40 | 0.400 / 0.250 | 0.581 / 0.217 | 0.324 / 0.138 | 0.513 / 0.172 |
//!
//! PCHIP lands closer in position in all eight cases and in velocity in seven.
//! Integrating the nozzle rate instead ([`NozzleModel::Rate`]) misses by 3 to
//! 72 m (exact formulation, N = 15 to 40): δ then accumulates the interpolation
//! error of χ, and the open-loop pitch dynamics amplify it.
//!
//! What remains is the thrust switch. The collocation's own polynomials (the
//! degree-(N−1) interpolant of T through the collocation points, the degree-N
//! interpolant of δ) land within 0.17 m and 0.07 m/s at N = 20, but that
//! thrust polynomial rings around the switch and leaves [T_min, T_max] by 2–13 %;
//! clipped to the bounds it misses by 4 m. Any realizable reconstruction of the
//! bang-bang thrust loses the ringing the collocated states were computed with,
//! and the miss shows up mainly as a pitch error that turns into a horizontal
//! position and velocity error. It is also sensitive to the solution itself:
//! the two formulations converge at N = 20 to points 0.6 kg apart in final mass,
//! which miss by 1.32 m and 0.81 m.
//!
//! **On an hp mesh** the controls are interpolated interval by interval
//! ([`Controls::interval_points`]), and **for a refined solution**
//! ([`crate::refine`], breaks at the switches) by the collocation's own
//! polynomials, as they can be flown ([`ControlSource::Collocation`],
//! [`crate::collocation::control_profile`]: within the bounds, held over the quadrature
//! cell of a point on a bound, and bang–bang inside the cell of a switch,
//! each point's impulse kept). On the paper's case refined to 1e-6 (6
//! passes, 96 points) the clamped polynomials landed 6 mm and 1.6 mm/s from
//! the pad where PCHIP's cubics, interval by interval, missed by 0.18 m and
//! 0.04 m/s (`bellyflop solve --mesh-tolerance 1e-6`, 2026-12-02); on the
//! refined envelope states the clamp lost up to 33 kg of propellant (the
//! propagation's mass error), the profile a fraction of a kilogram
//! (BENCHMARKS.md, "Mesh refinement", `bench/refinement.py`).

use serde::Serialize;
use thiserror::Error;

use crate::collocation::control_profile::Profile;
use crate::input::scenario::Scenario;
use crate::problem::dynamics::{self, Model};
use crate::solution::Solution;

// ---------------------------------------------------------------------------
// Dormand–Prince 8(5,3)
// ---------------------------------------------------------------------------

/// Nodes c_i of the 12 stages (stage 12 is at t + h).
#[allow(clippy::excessive_precision)] // the digits as published in dop853.f
const C: [f64; 12] = [
    0.0,
    0.526001519587677318785587544488e-1,
    0.789002279381515978178381316732e-1,
    0.118350341907227396726757197510,
    0.281649658092772603273242802490,
    0.333333333333333333333333333333,
    0.25,
    0.307692307692307692307692307692,
    0.651282051282051282051282051282,
    0.6,
    0.857142857142857142857142857142,
    1.0,
];

/// Rows a_{i,1..i−1} of the Butcher matrix, stages 2 to 12.
#[allow(clippy::excessive_precision)] // the digits as published in dop853.f
const A: [&[f64]; 12] = [
    &[],
    &[5.26001519587677318785587544488e-2],
    &[
        1.97250569845378994544595329183e-2,
        5.91751709536136983633785987549e-2,
    ],
    &[
        2.95875854768068491816892993775e-2,
        0.0,
        8.87627564304205475450678981324e-2,
    ],
    &[
        2.41365134159266685502369798665e-1,
        0.0,
        -8.84549479328286085344864962717e-1,
        9.24834003261792003115737966543e-1,
    ],
    &[
        3.70370370370370370370370370370e-2,
        0.0,
        0.0,
        1.70828608729473871279604482173e-1,
        1.25467687566822425016691814123e-1,
    ],
    &[
        3.71093750000000000000000000000e-2,
        0.0,
        0.0,
        1.70252211019544039314978060272e-1,
        6.02165389804559606850219397283e-2,
        -1.75781250000000000000000000000e-2,
    ],
    &[
        3.70920001185047927108779319836e-2,
        0.0,
        0.0,
        1.70383925712239993810214054705e-1,
        1.07262030446373284651809199168e-1,
        -1.53194377486244017527936158236e-2,
        8.27378916381402288758473766002e-3,
    ],
    &[
        6.24110958716075717114429577812e-1,
        0.0,
        0.0,
        -3.36089262944694129406857109825,
        -8.68219346841726006818189891453e-1,
        2.75920996994467083049415600797e1,
        2.01540675504778934086186788979e1,
        -4.34898841810699588477366255144e1,
    ],
    &[
        4.77662536438264365890433908527e-1,
        0.0,
        0.0,
        -2.48811461997166764192642586468,
        -5.90290826836842996371446475743e-1,
        2.12300514481811942347288949897e1,
        1.52792336328824235832596922938e1,
        -3.32882109689848629194453265587e1,
        -2.03312017085086261358222928593e-2,
    ],
    &[
        -9.37142430085987325717040216580e-1,
        0.0,
        0.0,
        5.18637242884406370830023853209,
        1.09143734899672957818500254654,
        -8.14978701074692612513997267357,
        -1.85200656599969598641566180701e1,
        2.27394870993505042818970056734e1,
        2.49360555267965238987089396762,
        -3.04676447189821950038236690220,
    ],
    &[
        2.27331014751653820792359768449,
        0.0,
        0.0,
        -1.05344954667372501984066689879e1,
        -2.00087205822486249909675718444,
        -1.79589318631187989172765950534e1,
        2.79488845294199600508499808837e1,
        -2.85899827713502369474065508674,
        -8.87285693353062954433549289258,
        1.23605671757943030647266201528e1,
        6.43392746015763530355970484046e-1,
    ],
];

/// Weights of the eighth-order solution.
#[allow(clippy::excessive_precision)] // the digits as published in dop853.f
const B: [f64; 12] = [
    5.42937341165687622380535766363e-2,
    0.0,
    0.0,
    0.0,
    0.0,
    4.45031289275240888144113950566,
    1.89151789931450038304281599044,
    -5.80120396001058478146721142270,
    3.11164366957819894408916062370e-1,
    -1.52160949662516078556178806805e-1,
    2.01365400804030348374776537501e-1,
    4.47106157277725905176885569043e-2,
];

/// Third-order estimator: B − (bhh1 e_1 + bhh2 e_9 + bhh3 e_12).
#[allow(clippy::excessive_precision)] // the digits as published in dop853.f
const BHH: [f64; 3] = [
    0.244094488188976377952755905512,
    0.733846688281611857341361741547,
    0.220588235294117647058823529412e-1,
];

/// Fifth-order error estimator weights (difference to B).
#[allow(clippy::excessive_precision)] // the digits as published in dop853.f
const E: [f64; 12] = [
    0.1312004499419488073250102996e-1,
    0.0,
    0.0,
    0.0,
    0.0,
    -0.1225156446376204440720569753e1,
    -0.4957589496572501915214079952,
    0.1664377182454986536961530415e1,
    -0.3503288487499736816886487290,
    0.3341791187130174790297318841,
    0.8192320648511571246570742613e-1,
    -0.2235530786388629525884427845e-1,
];

/// Step-size control constants of `dop853.f`: safety factor, and the bounds
/// 1/6 ≤ h_new/h ≤ 3 (fac1 = 0.333, fac2 = 6).
const SAFETY: f64 = 0.9;
const FAC_MIN: f64 = 0.333;
const FAC_MAX: f64 = 6.0;

/// Why an integration stopped early.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum IntegrationError {
    /// The step size fell below the resolution of t.
    #[error("step size underflow at t = {t_s} s (h = {h_s:e} s)")]
    StepSizeUnderflow { t_s: f64, h_s: f64 },
    /// More steps than [`Dop853::max_steps`].
    #[error("more than {max_steps} steps at t = {t_s} s")]
    TooManySteps { t_s: f64, max_steps: usize },
    /// The right-hand side returned NaN or infinity and no smaller step helped.
    #[error("non-finite state or derivative at t = {t_s} s")]
    NonFinite { t_s: f64 },
    /// The solution to propagate has no usable node arrays.
    #[error("cannot propagate: {0}")]
    BadSolution(String),
}

/// Work done by an integration.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Stats {
    pub accepted_steps: usize,
    pub rejected_steps: usize,
    pub evaluations: usize,
}

/// The Dormand–Prince 8(5,3) integrator with adaptive steps.
///
/// Component i of the local error is measured against
/// `atol + rtol·max(|y_i(t)|, |y_i(t + h)|)`; a step is accepted when the
/// combined error of `dop853.f` is at most 1.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Dop853 {
    pub rtol: f64,
    pub atol: f64,
    /// Largest step size \[s\]; infinite by default.
    pub h_max: f64,
    /// Step limit per call of [`Dop853::integrate`].
    pub max_steps: usize,
}

impl Default for Dop853 {
    fn default() -> Self {
        Dop853 {
            rtol: 1e-10,
            atol: 1e-10,
            h_max: f64::INFINITY,
            max_steps: 100_000,
        }
    }
}

impl Dop853 {
    /// One step of size `h` from (t, y) with f(t, y) = `k1`. Returns the
    /// eighth-order solution at t + h and the (unscaled) error norm of
    /// `dop853.f`, err ≤ 1 meaning the step meets the tolerance.
    fn step<const D: usize>(
        &self,
        f: &mut impl FnMut(f64, &[f64; D]) -> [f64; D],
        t: f64,
        y: &[f64; D],
        k1: &[f64; D],
        h: f64,
    ) -> ([f64; D], f64) {
        let mut k = [[0.0; D]; 12];
        k[0] = *k1;
        for s in 1..12 {
            let mut ys = *y;
            for (j, &a) in A[s].iter().enumerate() {
                if a != 0.0 {
                    for c in 0..D {
                        ys[c] += h * a * k[j][c];
                    }
                }
            }
            k[s] = f(t + C[s] * h, &ys);
        }
        let mut y_new = *y;
        let (mut err, mut err2) = (0.0, 0.0);
        for c in 0..D {
            let incr: f64 = (0..12).map(|s| B[s] * k[s][c]).sum();
            y_new[c] = y[c] + h * incr;
            let sk = self.atol + self.rtol * y[c].abs().max(y_new[c].abs());
            let e3 = incr - BHH[0] * k[0][c] - BHH[1] * k[8][c] - BHH[2] * k[11][c];
            let e5: f64 = (0..12).map(|s| E[s] * k[s][c]).sum();
            err2 += (e3 / sk) * (e3 / sk);
            err += (e5 / sk) * (e5 / sk);
        }
        let mut deno = err + 0.01 * err2;
        if deno <= 0.0 {
            deno = 1.0;
        }
        let err = h.abs() * err * (1.0 / (D as f64 * deno)).sqrt();
        (y_new, err)
    }

    /// Initial step size guess of `dop853.f` (`hinit`) for a method of order 8.
    fn initial_step<const D: usize>(
        &self,
        f: &mut impl FnMut(f64, &[f64; D]) -> [f64; D],
        t: f64,
        y: &[f64; D],
        f0: &[f64; D],
        span: f64,
    ) -> f64 {
        let dir = span.signum();
        let h_max = self.h_max.min(span.abs());
        let (mut dnf, mut dny) = (0.0, 0.0);
        for c in 0..D {
            let sk = self.atol + self.rtol * y[c].abs();
            dnf += (f0[c] / sk).powi(2);
            dny += (y[c] / sk).powi(2);
        }
        let mut h = if dnf <= 1e-10 || dny <= 1e-10 {
            1e-6
        } else {
            (dny / dnf).sqrt() * 0.01
        };
        h = h.min(h_max);
        let y1: [f64; D] = std::array::from_fn(|c| y[c] + dir * h * f0[c]);
        let f1 = f(t + dir * h, &y1);
        let mut der2 = 0.0;
        for c in 0..D {
            let sk = self.atol + self.rtol * y[c].abs();
            der2 += ((f1[c] - f0[c]) / sk).powi(2);
        }
        let der2 = der2.sqrt() / h;
        let der12 = der2.abs().max(dnf.sqrt());
        let h1 = if der12 <= 1e-15 {
            1e-6f64.max(h * 1e-3)
        } else {
            (0.01 / der12).powf(1.0 / 8.0)
        };
        let h = (100.0 * h).min(h1).min(h_max);
        if h.is_finite() && h > 0.0 {
            h
        } else {
            span.abs() * 1e-3
        }
    }

    /// Integrate y' = f(t, y) from (`t0`, `y0`) to `t1` and return y(`t1`).
    ///
    /// `h` is the first step size to try (≤ 0: estimated); on return it holds the
    /// step size proposed for a continuation. `on_step(t, y)` is called after every
    /// accepted step, the last one exactly at `t1`. `f` is evaluated only on
    /// [t0, t1].
    #[allow(clippy::too_many_arguments)]
    pub fn integrate<const D: usize>(
        &self,
        mut f: impl FnMut(f64, &[f64; D]) -> [f64; D],
        t0: f64,
        y0: [f64; D],
        t1: f64,
        h: &mut f64,
        stats: &mut Stats,
        mut on_step: impl FnMut(f64, &[f64; D]),
    ) -> Result<[f64; D], IntegrationError> {
        let span = t1 - t0;
        if span == 0.0 {
            return Ok(y0);
        }
        let dir = span.signum();
        let mut t = t0;
        let mut y = y0;
        let mut k1 = f(t, &y);
        stats.evaluations += 1;
        if k1.iter().any(|v| !v.is_finite()) {
            return Err(IntegrationError::NonFinite { t_s: t });
        }
        let mut step_size = if *h > 0.0 {
            h.min(self.h_max)
        } else {
            stats.evaluations += 1;
            self.initial_step(&mut f, t, &y, &k1, span)
        };
        let mut rejected_last = false;
        let mut steps = 0;
        loop {
            if steps >= self.max_steps {
                return Err(IntegrationError::TooManySteps {
                    t_s: t,
                    max_steps: self.max_steps,
                });
            }
            if 0.1 * step_size <= t.abs().max(t1.abs()) * f64::EPSILON {
                return Err(IntegrationError::StepSizeUnderflow {
                    t_s: t,
                    h_s: step_size,
                });
            }
            // Land exactly on t1 (and do not leave a sliver of a last step).
            let last = (t + 1.01 * dir * step_size - t1) * dir >= 0.0;
            if last {
                step_size = (t1 - t).abs();
            }
            let hs = dir * step_size;
            let (y_new, err) = self.step(&mut f, t, &y, &k1, hs);
            stats.evaluations += 11;
            steps += 1;
            if !err.is_finite() {
                // Stepped into a region where f is undefined: retry much smaller.
                stats.rejected_steps += 1;
                step_size *= 0.1;
                rejected_last = true;
                continue;
            }
            let fac11 = err.powf(1.0 / 8.0);
            let fac = (fac11 / SAFETY).clamp(1.0 / FAC_MAX, 1.0 / FAC_MIN);
            if err <= 1.0 {
                t = if last { t1 } else { t + hs };
                y = y_new;
                k1 = f(t, &y);
                stats.evaluations += 1;
                stats.accepted_steps += 1;
                if k1.iter().any(|v| !v.is_finite()) {
                    return Err(IntegrationError::NonFinite { t_s: t });
                }
                on_step(t, &y);
                let mut h_new = (step_size / fac).min(self.h_max);
                if rejected_last {
                    h_new = h_new.min(step_size);
                }
                rejected_last = false;
                if last {
                    *h = h_new;
                    return Ok(y);
                }
                step_size = h_new;
            } else {
                stats.rejected_steps += 1;
                rejected_last = true;
                step_size /= (fac11 / SAFETY).min(1.0 / FAC_MIN);
            }
        }
    }
}

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

/// Where the nozzle angle of the propagation comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NozzleModel {
    /// Interpolate δ from its node values (problem P1). The default.
    #[default]
    Angle,
    /// Integrate δ̇ = χ with χ interpolated from the collocation points (Eq. 8, P2).
    Rate,
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
        assert_eq!(t.len(), y.len(), "as many times as values");
        assert!(t.len() >= 2, "at least two points");
        assert!(
            t.windows(2).all(|w| w[1] > w[0]),
            "times strictly increasing"
        );
        let d = match kind {
            Interpolation::Linear => vec![],
            Interpolation::Pchip => pchip_slopes(t, y),
        };
        Interpolant {
            t: t.to_vec(),
            y: y.to_vec(),
            d,
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
fn pchip_slopes(t: &[f64], y: &[f64]) -> Vec<f64> {
    let n = t.len();
    let h: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let delta: Vec<f64> = (0..n - 1).map(|k| (y[k + 1] - y[k]) / h[k]).collect();
    if n == 2 {
        return vec![delta[0], delta[0]];
    }
    let mut d = vec![0.0; n];
    for k in 1..n - 1 {
        let (a, b) = (delta[k - 1], delta[k]);
        if a * b > 0.0 {
            let w1 = 2.0 * h[k] + h[k - 1];
            let w2 = h[k] + 2.0 * h[k - 1];
            d[k] = (w1 + w2) / (w1 / a + w2 / b);
        }
    }
    d[0] = pchip_end_slope(h[0], h[1], delta[0], delta[1]);
    d[n - 1] = pchip_end_slope(h[n - 2], h[n - 3], delta[n - 2], delta[n - 3]);
    d
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

// ---------------------------------------------------------------------------
// Re-propagation of a solution
// ---------------------------------------------------------------------------

/// Options of [`propagate`].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Options {
    pub interpolation: Interpolation,
    pub nozzle: NozzleModel,
    pub integrator: Dop853,
    pub controls: ControlSource,
}

/// What the controls between the nodes are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ControlSource {
    /// `collocation` for a refined solution (its breaks are at the control
    /// switches), `nodes` otherwise. The default.
    #[default]
    Auto,
    /// [`Options::interpolation`] through the nodes (per interval on an hp
    /// mesh, see [`Controls::interval_points`]).
    Nodes,
    /// The collocation's own polynomials, per interval, as they can be
    /// flown: T and χ by [`crate::collocation::control_profile::Profile`] (degree
    /// n_k − 1 through its collocation points on interior arcs, held on the
    /// bounds, bang–bang across a switch, within the bounds), δ of degree
    /// n_k through its nodes, clamped. On a refined mesh the controls are
    /// smooth inside each interval, and these converge as the collocation
    /// does, where PCHIP's cubics do not (BENCHMARKS.md, "Mesh refinement").
    Collocation,
}

/// The miss at t_f against the scenario's terminal state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LandingError {
    /// ‖(x, z)(t_f) − (x_f, z_f)‖ \[m\].
    pub position_m: f64,
    /// ‖(Vx, Vz)(t_f) − (Vx_f, Vz_f)‖ [m/s].
    pub velocity_mps: f64,
    /// |θ(t_f) − θ_f| \[rad\].
    pub pitch_rad: f64,
    /// |w(t_f) − w_f| [rad/s].
    pub rate_radps: f64,
}

/// A re-propagated trajectory and its landing precision.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Propagation {
    pub options: Options,
    /// Times of the accepted integration steps, from 0 to t_f; every node time
    /// of the solution is among them.
    pub t_s: Vec<f64>,
    /// States (x, z, Vx, Vz, θ, w, m) at `t_s`, SI units and radians.
    pub states: Vec<[f64; 7]>,
    /// Nozzle angle δ at `t_s` \[rad\] (interpolated or integrated).
    pub delta_rad: Vec<f64>,
    pub landing_error: LandingError,
    /// m(t_f) of the propagation \[kg\].
    pub terminal_mass_kg: f64,
    /// Propagated minus optimized final mass \[kg\].
    pub mass_error_kg: f64,
    pub stats: Stats,
}

impl Propagation {
    /// The propagated state at t_f.
    pub fn final_state(&self) -> [f64; 7] {
        *self
            .states
            .last()
            .expect("a propagation has at least one state")
    }
}

/// Node data of a trajectory to re-propagate: node times and the controls at
/// them, and the initial state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Controls<'a> {
    /// Strictly increasing node times \[s\], from t_0 to t_f.
    pub t_s: &'a [f64],
    /// Thrust T at the node times \[N\].
    pub thrust_n: &'a [f64],
    /// Nozzle angle δ at the node times \[rad\] (used by [`NozzleModel::Angle`]).
    pub delta_rad: &'a [f64],
    /// Gimbal rate χ = δ̇ at the node times [rad/s] (used by [`NozzleModel::Rate`]).
    pub gimbal_rate_radps: &'a [f64],
    /// (x, z, Vx, Vz, θ, w, m) at t_0.
    pub initial: [f64; 7],
    /// The collocation points n_k of each mesh interval (Σ n_k = N); empty
    /// or one entry: one interpolant through every node. With several, T and
    /// χ are interpolated per interval, through its own collocation points
    /// and held from the last one to the interval's end: a break at a thrust
    /// switch is a discontinuity of the control, which an interpolant across
    /// the break would smear over the gap between the last point and the
    /// break (δ, a state, stays one interpolant through all the nodes).
    pub interval_points: &'a [usize],
    /// Interpolate by the collocation's polynomials per interval
    /// ([`ControlSource::Collocation`]) instead of [`Options::interpolation`].
    pub collocation: bool,
}

/// One interval's polynomial of δ: its node times and their barycentric
/// weights.
type PiecePolynomials = (Vec<f64>, Vec<f64>);

/// A propagated trajectory: times, states and nozzle angles at the accepted
/// steps, and the integrator's work.
pub type Track = (Vec<f64>, Vec<[f64; 7]>, Vec<f64>, Stats);

/// Integrate Eq. (1)–(3) with interpolated controls, node interval by node interval.
pub fn integrate_controls(
    model: &Model,
    c: &Controls,
    options: &Options,
) -> Result<Track, IntegrationError> {
    let m = c.t_s.len();
    if m < 2
        || [
            c.thrust_n.len(),
            c.delta_rad.len(),
            c.gimbal_rate_radps.len(),
        ]
        .iter()
        .any(|&l| l != m)
    {
        return Err(IntegrationError::BadSolution(format!(
            "the control arrays must all have the length of t_s ({m} ≥ 2)"
        )));
    }
    if !c.t_s.windows(2).all(|w| w[1] > w[0]) || c.t_s.iter().any(|t| !t.is_finite()) {
        return Err(IntegrationError::BadSolution(
            "node times must be finite and strictly increasing".into(),
        ));
    }
    let kind = options.interpolation;
    let delta = Interpolant::new(kind, c.t_s, c.delta_rad);
    let nozzle = options.nozzle;
    // Per interval (first node, node count + 1 with its end): T and χ, each
    // held from the interval's last point to its end.
    let pieces: Vec<(usize, usize)> = if c.interval_points.len() > 1 {
        if c.interval_points.iter().sum::<usize>() + 1 != m || c.interval_points.contains(&0) {
            return Err(IntegrationError::BadSolution(format!(
                "the intervals' points must be positive and add up to the {} nodes less one",
                m
            )));
        }
        c.interval_points
            .iter()
            .scan(0, |start, &n| {
                let piece = (*start, n);
                *start += n;
                Some(piece)
            })
            .collect()
    } else {
        vec![(0, m - 1)]
    };
    let held = |values: &[f64], start: usize, n: usize| -> Vec<f64> {
        let mut v = values[start..=start + n].to_vec();
        if pieces.len() > 1 {
            v[n] = v[n - 1];
        }
        v
    };
    let controls: Vec<(Interpolant, Interpolant)> = pieces
        .iter()
        .map(|&(start, n)| {
            let t = &c.t_s[start..=start + n];
            (
                Interpolant::new(kind, t, &held(c.thrust_n, start, n)),
                Interpolant::new(kind, t, &held(c.gimbal_rate_radps, start, n)),
            )
        })
        .collect();
    // The collocation's polynomials of δ per piece (its node times and
    // their barycentric weights), and the flyable profiles of T and χ.
    let polys: Vec<PiecePolynomials> = if c.collocation {
        pieces
            .iter()
            .map(|&(start, n)| {
                let tn = c.t_s[start..=start + n].to_vec();
                let bn = crate::collocation::radau::barycentric_weights(&tn);
                (tn, bn)
            })
            .collect()
    } else {
        Vec::new()
    };
    let points: Vec<usize> = pieces.iter().map(|&(_, n)| n).collect();
    let profiles = c.collocation.then(|| {
        let r = model.max_gimbal_rate_radps;
        (
            Profile::new(
                c.t_s,
                &points,
                c.thrust_n,
                model.min_thrust_n,
                model.max_thrust_n,
            ),
            Profile::new(c.t_s, &points, c.gimbal_rate_radps, -r, r),
        )
    });
    let jumping: Vec<&Profile> = profiles.iter().flat_map(|(t, chi)| [t, chi]).collect();
    let mut stops = Vec::new();
    let piece_of: Vec<usize> = pieces
        .iter()
        .enumerate()
        .flat_map(|(j, &(_, n))| std::iter::repeat_n(j, n))
        .collect();

    // The 7 physical states, plus δ for the nozzle-rate model.
    let p0 = c.initial;
    let mut y: [f64; 8] = [
        p0[0],
        p0[1],
        p0[2],
        p0[3],
        p0[4],
        p0[5],
        p0[6],
        c.delta_rad[0],
    ];
    let mut t_out = vec![c.t_s[0]];
    let mut states = vec![p0];
    let mut delta_out = vec![y[7]];
    let mut stats = Stats::default();
    let mut h = 0.0;
    for (k, &j) in piece_of.iter().enumerate() {
        let (thrust, chi) = &controls[j];
        let local = k - pieces[j].0;
        let (start, np) = pieces[j];
        let poly = polys.get(j);
        let thrust_at = |t: f64| match &profiles {
            Some((thrust, _)) => thrust.at(t),
            None => thrust.eval_on(local, t),
        };
        let chi_at = |t: f64| match &profiles {
            Some((_, chi)) => chi.at(t),
            None => chi.eval_on(local, t),
        };
        let delta_at = |t: f64| match poly {
            Some((tn, bn)) => {
                let r = model.max_gimbal_rad;
                crate::collocation::radau::interpolate(tn, bn, &c.delta_rad[start..=start + np], t)
                    .clamp(-r, r)
            }
            None => delta.eval_on(k, t),
        };
        let rhs = |t: f64, y: &[f64; 8]| -> [f64; 8] {
            let thrust_n = thrust_at(t);
            let (delta_rad, ddelta) = match nozzle {
                NozzleModel::Angle => (delta_at(t), 0.0),
                NozzleModel::Rate => (y[7], chi_at(t)),
            };
            let f = dynamics::rhs_physical(model, &physical(y), thrust_n, delta_rad);
            [f[0], f[1], f[2], f[3], f[4], f[5], f[6], ddelta]
        };
        // Stop at the profiles' jumps inside the node interval, instead of
        // letting the step-size control find them.
        Profile::stops(c.t_s[k], c.t_s[k + 1], &jumping, &mut stops);
        for span in stops.windows(2) {
            if span[1] <= span[0] {
                continue;
            }
            y = options.integrator.integrate(
                &rhs,
                span[0],
                y,
                span[1],
                &mut h,
                &mut stats,
                |t, y| {
                    t_out.push(t);
                    states.push(physical(y));
                    delta_out.push(match nozzle {
                        NozzleModel::Angle => delta_at(t),
                        NozzleModel::Rate => y[7],
                    });
                },
            )?;
        }
    }
    Ok((t_out, states, delta_out, stats))
}

/// Integrate Eq. (1)–(3) with the solution's controls from its initial state to
/// t_f and measure the landing error against `scenario.terminal`.
///
/// `scenario` supplies the vehicle model and the target; it should be the one
/// the solution was computed for.
pub fn propagate(
    scenario: &Scenario,
    solution: &Solution,
    options: &Options,
) -> Result<Propagation, IntegrationError> {
    let s = solution;
    let m = s.t_s.len();
    let columns = s.state_columns();
    let states0 = &columns[..7];
    if m < 2 || states0.iter().any(|v| v.len() != m) {
        return Err(IntegrationError::BadSolution(format!(
            "the state arrays must all have the length of t_s ({m} ≥ 2)"
        )));
    }
    let controls = Controls {
        t_s: &s.t_s,
        thrust_n: &s.thrust_n,
        delta_rad: &s.delta_rad,
        gimbal_rate_radps: &s.gimbal_rate_radps,
        initial: std::array::from_fn(|c| states0[c][0]),
        interval_points: &s.mesh.points,
        collocation: match options.controls {
            ControlSource::Auto => s.refinement.is_some(),
            ControlSource::Nodes => false,
            ControlSource::Collocation => true,
        },
    };
    let model = Model::new(&scenario.vehicle, &scenario.environment);
    let (t_s, states, delta_rad, stats) = integrate_controls(&model, &controls, options)?;
    let end = *states.last().expect("at least the initial state");
    let landing_error = landing_error(scenario, &end);
    let mut used = *options;
    used.controls = if controls.collocation {
        ControlSource::Collocation
    } else {
        ControlSource::Nodes
    };
    Ok(Propagation {
        options: used,
        t_s,
        states,
        delta_rad,
        landing_error,
        terminal_mass_kg: end[6],
        mass_error_kg: end[6] - s.final_mass_kg,
        stats,
    })
}

/// The miss of a final state (x, z, Vx, Vz, θ, w, m) against `scenario.terminal`.
pub fn landing_error(scenario: &Scenario, end: &[f64; 7]) -> LandingError {
    let tf = &scenario.terminal;
    LandingError {
        position_m: (end[0] - tf.x_m).hypot(end[1] - tf.z_m),
        velocity_mps: (end[2] - tf.vx_mps).hypot(end[3] - tf.vz_mps),
        pitch_rad: (end[4] - tf.theta_deg.to_radians()).abs(),
        rate_radps: (end[5] - tf.pitch_rate_degps.to_radians()).abs(),
    }
}

fn physical(y: &[f64; 8]) -> [f64; 7] {
    [y[0], y[1], y[2], y[3], y[4], y[5], y[6]]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tight() -> Dop853 {
        Dop853 {
            rtol: 1e-12,
            atol: 1e-12,
            ..Dop853::default()
        }
    }

    /// y'' = −y, y = cos t, y' = −sin t: the global error of the default
    /// tolerance (1e-10) grows about 1e-10 per period, so it stays below 1e-8
    /// over 50 periods (314 s, 27 times the landing burn); at 1e-12 it does
    /// over 1000 periods.
    #[test]
    fn harmonic_oscillator_over_many_periods() {
        for (solver, periods) in [(Dop853::default(), 50.0), (tight(), 1000.0)] {
            let tf = 2.0 * std::f64::consts::PI * periods;
            let mut stats = Stats::default();
            let mut h = 0.0;
            let y = solver
                .integrate(
                    |_, y: &[f64; 2]| [y[1], -y[0]],
                    0.0,
                    [1.0, 0.0],
                    tf,
                    &mut h,
                    &mut stats,
                    |_, _| {},
                )
                .unwrap();
            let err = (y[0] - tf.cos()).abs().max((y[1] + tf.sin()).abs());
            assert!(
                err <= 1e-8,
                "{periods} periods: error {err:e} after {stats:?}"
            );
        }
    }

    /// y' = ∓y/2 over 40 s: decay to e^−20 (absolute error ≤ 1e-12, where the
    /// absolute tolerance governs) and growth to e^20 (relative error ≤ 1e-8),
    /// and the decay integrated backwards in time.
    #[test]
    fn exponential_decay_and_growth() {
        for rate in [-0.5, 0.5] {
            let mut stats = Stats::default();
            let mut h = 0.0;
            let y = Dop853::default()
                .integrate(
                    |_, y: &[f64; 1]| [rate * y[0]],
                    0.0,
                    [1.0],
                    40.0,
                    &mut h,
                    &mut stats,
                    |_, _| {},
                )
                .unwrap();
            let exact = (rate * 40.0f64).exp();
            assert!(
                (y[0] - exact).abs() <= (1e-8 * exact).max(1e-12),
                "rate {rate}: {} vs {exact}",
                y[0]
            );
        }
        let (mut stats, mut h) = (Stats::default(), 0.0);
        let back = Dop853::default()
            .integrate(
                |_, y: &[f64; 1]| [-0.5 * y[0]],
                40.0,
                [1.0],
                0.0,
                &mut h,
                &mut stats,
                |_, _| {},
            )
            .unwrap();
        assert!((back[0] - 20f64.exp()).abs() <= 1e-8 * 20f64.exp());
    }

    /// A time-dependent, nonlinear problem: y' = 2t·y² with y(0) = 1, whose
    /// solution y = 1/(1 − t²) blows up at t = 1.
    #[test]
    fn nonlinear_time_dependent_near_blow_up() {
        let mut stats = Stats::default();
        let mut h = 0.0;
        let mut visited = vec![];
        let y = tight()
            .integrate(
                |t, y: &[f64; 1]| [2.0 * t * y[0] * y[0]],
                0.0,
                [1.0],
                0.99,
                &mut h,
                &mut stats,
                |t, _| visited.push(t),
            )
            .unwrap();
        let exact = 1.0 / (1.0 - 0.99 * 0.99);
        assert!((y[0] - exact).abs() <= 1e-9 * exact, "{} vs {exact}", y[0]);
        assert_eq!(*visited.last().unwrap(), 0.99);
        assert!(visited.windows(2).all(|w| w[1] > w[0]));
    }

    /// The method has order 8: halving a fixed step divides the error of
    /// y'' = −y over one period by about 2⁸ = 256.
    #[test]
    fn eighth_order_of_convergence() {
        let solver = Dop853::default();
        let error = |steps: usize| {
            let tf = 2.0 * std::f64::consts::PI;
            let h = tf / steps as f64;
            let mut y = [1.0, 0.0];
            let mut f = |_: f64, y: &[f64; 2]| [y[1], -y[0]];
            for i in 0..steps {
                let t = i as f64 * h;
                let k1 = f(t, &y);
                y = solver.step(&mut f, t, &y, &k1, h).0;
            }
            (y[0] - 1.0).abs().max(y[1].abs())
        };
        let (e1, e2) = (error(8), error(16));
        let order = (e1 / e2).log2();
        assert!((7.5..9.0).contains(&order), "observed order {order}");
    }

    #[test]
    fn pchip_is_monotone_and_exact_on_lines() {
        let t = [0.0, 1.0, 1.5, 3.0, 4.0, 6.0];
        // A step: PCHIP stays inside [0, 1] and monotone.
        let y = [0.0, 0.0, 0.1, 1.0, 1.0, 1.0];
        let p = Interpolant::new(Interpolation::Pchip, &t, &y);
        let mut prev = f64::NEG_INFINITY;
        for i in 0..=600 {
            let v = p.eval(i as f64 * 0.01);
            assert!((0.0..=1.0).contains(&v), "overshoot {v}");
            assert!(v >= prev - 1e-15, "not monotone at {}", i as f64 * 0.01);
            prev = v;
        }
        for (tk, yk) in t.iter().zip(y) {
            assert_eq!(p.eval(*tk), yk);
        }
        // Lines are reproduced exactly by both interpolants.
        let line: Vec<f64> = t.iter().map(|t| 3.0 - 2.0 * t).collect();
        for kind in [Interpolation::Linear, Interpolation::Pchip] {
            let p = Interpolant::new(kind, &t, &line);
            for i in 0..=60 {
                let x = i as f64 * 0.1;
                assert!((p.eval(x) - (3.0 - 2.0 * x)).abs() < 1e-13, "{kind:?}");
            }
        }
    }

    /// Vertical flight without drag under constant thrust has a closed form;
    /// propagating its node data reproduces it with every option.
    #[test]
    fn constant_thrust_vertical_flight_matches_closed_form() {
        let mut scenario = Scenario::paper();
        scenario.vehicle.drag_coefficient_kgpm = 0.0;
        let model = Model::new(&scenario.vehicle, &scenario.environment);
        // θ = δ = 0, ṁ = αT: m = m0 + αT·t, Vz = Vz0 + ln(m/m0)/α − g·t,
        // z = z0 + Vz0·t + [m·ln(m/m0) − m + m0]/(α²T) − g·t²/2.
        let (m0, thrust, vz0, z0, tf) = (120_000.0, 2.0e6, -80.0, 600.0, 10.0);
        let (a, g) = (model.alpha_spm, model.g0_mps2);
        let mass = |t: f64| m0 + a * thrust * t;
        let vz = |t: f64| vz0 + (mass(t) / m0).ln() / a - g * t;
        let z = |t: f64| {
            let m = mass(t);
            z0 + vz0 * t + (m * (m / m0).ln() - m + m0) / (a * a * thrust) - 0.5 * g * t * t
        };
        let n = 6;
        let t_s: Vec<f64> = (0..=n).map(|k| tf * k as f64 / n as f64).collect();
        let zeros = vec![0.0; n + 1];
        let thrusts = vec![thrust; n + 1];
        let controls = Controls {
            t_s: &t_s,
            thrust_n: &thrusts,
            delta_rad: &zeros,
            gimbal_rate_radps: &zeros,
            initial: [0.0, z0, 0.0, vz0, 0.0, 0.0, m0],
            interval_points: &[],
            collocation: false,
        };
        for interpolation in [Interpolation::Linear, Interpolation::Pchip] {
            for nozzle in [NozzleModel::Angle, NozzleModel::Rate] {
                let opts = Options {
                    interpolation,
                    nozzle,
                    ..Options::default()
                };
                let (t, states, _, _) = integrate_controls(&model, &controls, &opts).unwrap();
                let end = *states.last().unwrap();
                assert!((end[1] - z(tf)).abs() < 1e-7, "{opts:?}: z {}", end[1]);
                assert!((end[3] - vz(tf)).abs() < 1e-8, "{opts:?}: vz {}", end[3]);
                assert!((end[6] - mass(tf)).abs() < 1e-6, "{opts:?}: m {}", end[6]);
                assert_eq!(end[0], 0.0);
                assert_eq!(*t.last().unwrap(), tf);
                for tk in &t_s {
                    assert!(t.contains(tk), "node time {tk} not visited");
                }
                let e = landing_error(&scenario, &end);
                assert!((e.position_m - z(tf).abs()).abs() < 1e-7);
                assert!((e.velocity_mps - vz(tf).abs()).abs() < 1e-8);
            }
        }
    }
}
