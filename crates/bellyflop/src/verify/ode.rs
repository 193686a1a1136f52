//! The Dormand–Prince 8(5,3) integrator (Hairer, Nørsett, Wanner, *Solving
//! ODEs I*, 2nd ed., §II.10; coefficients from `dop853.f`), with the step-size
//! control of Hairer's `DOP853`: the re-integration of every answer against
//! the nonlinear model ([`crate::verify::propagate`]). Why our own code rather
//! than a crate: see [`crate::verify::propagate`].

use serde::Serialize;
use thiserror::Error;

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
    pub(crate) fn step<const D: usize>(
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
