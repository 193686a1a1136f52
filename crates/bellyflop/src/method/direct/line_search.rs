//! The backtracking filter line search of §2.3, with the second-order
//! corrections of §2.4: a trial step is accepted when it reduces the
//! infeasibility θ or the barrier objective φ_μ enough against the current
//! point (or the Armijo condition in the switching case) and is acceptable
//! to the filter of (θ, φ) pairs.

use crate::collocation::derivatives::Differentiable;
use crate::method::direct::iterate::{l1_norm, Iterate};
use crate::method::direct::newton::Newton;

// Constants of Wächter & Biegler (2006), Table 1 and §3, at IPOPT's defaults.
pub(super) const GAMMA_THETA: f64 = 1e-5;
const GAMMA_PHI: f64 = 1e-8;
const DELTA_SWITCH: f64 = 1.0;
const S_THETA: f64 = 1.1;
const S_PHI: f64 = 2.3;
const ETA_PHI: f64 = 1e-8;
const GAMMA_ALPHA: f64 = 0.05;
const MAX_SOC: usize = 4;
const KAPPA_SOC: f64 = 0.99;
/// Filter entries reserved at setup.
pub(super) const FILTER_CAPACITY: usize = 256;

/// Filter entries (θ, φ) (§2.3).
pub(super) struct Filter(Vec<(f64, f64)>);

impl Filter {
    pub(super) fn acceptable(&self, theta: f64, phi: f64) -> bool {
        self.0.iter().all(|&(t, p)| theta < t || phi < p)
    }
    fn add(&mut self, theta: f64, phi: f64) {
        self.0.retain(|&(t, p)| t < theta || p < phi);
        self.0.push((theta, phi));
    }
}

/// How a line search ended.
pub(super) enum LineSearch {
    Accepted {
        alpha: f64,
        trials: usize,
        f_type: bool,
    },
    Failed,
}

/// The point a line search starts from: θ(w_k), φ_μ(w_k) and the
/// directional derivative m_φ = ∇φ_μᵀd_k.
#[derive(Clone, Copy)]
struct Origin {
    theta: f64,
    phi: f64,
    m_phi: f64,
}

/// The filter and the infeasibility limits θ_max, θ_min of a solve.
pub(super) struct FilterLineSearch {
    pub(super) filter: Filter,
    theta_max: f64,
    theta_min: f64,
}

impl FilterLineSearch {
    /// An empty filter line search, its filter in `entries` (emptied;
    /// reused storage, so that a re-plan does not allocate).
    pub(super) fn with_storage(mut entries: Vec<(f64, f64)>) -> Self {
        entries.clear();
        // Room for the entries of a barrier subproblem: no growth in an iteration.
        entries.reserve(FILTER_CAPACITY);
        FilterLineSearch {
            filter: Filter(entries),
            theta_max: 0.0,
            theta_min: 0.0,
        }
    }

    /// Its filter's storage, for [`FilterLineSearch::with_storage`].
    pub(super) fn into_storage(self) -> Vec<(f64, f64)> {
        self.filter.0
    }

    /// θ_max and θ_min from the starting point's infeasibility θ_0.
    pub(super) fn start(&mut self, theta0: f64) {
        self.theta_max = 1e4 * theta0.max(1.0);
        self.theta_min = 1e-4 * theta0.max(1.0);
    }

    /// Empty the filter: a new barrier subproblem.
    pub(super) fn reset(&mut self) {
        self.filter.0.clear();
    }

    /// Augment the filter with the margins of a point (θ, φ) (Eq. 22 of the
    /// paper's §2.3, after an h-type step, and at restoration).
    pub(super) fn augment(&mut self, theta: f64, phi: f64) {
        self.filter
            .add((1.0 - GAMMA_THETA) * theta, phi - GAMMA_PHI * theta);
    }

    /// The line search along the Newton step in `sys.ws` from the iterate
    /// (in `sys.ws.w_old`) at barrier `mu` and fraction to the boundary
    /// `tau`; on an accepted step that is not of f-type, the filter is
    /// augmented with the starting point.
    pub(super) fn search<M: Differentiable, const NS: usize, const NL: usize>(
        &mut self,
        sys: &mut Newton<'_, M, NS, NL>,
        it: &mut Iterate,
        (mu, tau): (f64, f64),
    ) -> LineSearch {
        // The Newton step, kept apart (the SOC overwrites ws.dw, ws.dl).
        let (mut dw, mut dl) = (
            std::mem::take(&mut sys.ws.step_w),
            std::mem::take(&mut sys.ws.step_l),
        );
        dw.copy_from_slice(&sys.ws.dw);
        dl.copy_from_slice(&sys.ws.dl);
        let w = std::mem::take(&mut sys.ws.w_old);
        let out = self.backtrack(sys, it, &w, &dw, &dl, (mu, tau));
        (sys.ws.step_w, sys.ws.step_l, sys.ws.w_old) = (dw, dl, w);
        if let LineSearch::Accepted { f_type: false, .. } = out {
            let theta = l1_norm(&sys.ws.c);
            let phi = sys.phi(&sys.ws.w_old, mu);
            self.augment(theta, phi);
        }
        out
    }

    /// The acceptance tests of §2.3 for a trial point at step `alpha` with
    /// (θ, φ): None if rejected, else whether it is an f-type step.
    fn acceptable(&self, o: Origin, alpha: f64, theta: f64, phi: f64) -> Option<bool> {
        if !theta.is_finite() || !phi.is_finite() || theta > self.theta_max {
            return None;
        }
        if !self.filter.acceptable(theta, phi) {
            return None;
        }
        let switching = o.m_phi < 0.0
            && alpha * (-o.m_phi).powf(S_PHI) > DELTA_SWITCH * o.theta.powf(S_THETA)
            && o.theta <= self.theta_min;
        if switching {
            (phi <= o.phi + ETA_PHI * alpha * o.m_phi).then_some(true)
        } else {
            (theta <= (1.0 - GAMMA_THETA) * o.theta || phi <= o.phi - GAMMA_PHI * o.theta)
                .then_some(false)
        }
    }

    /// The backtracking filter line search with second-order corrections,
    /// from `w` along (`dw`, `dl`).
    fn backtrack<M: Differentiable, const NS: usize, const NL: usize>(
        &mut self,
        sys: &mut Newton<'_, M, NS, NL>,
        it: &mut Iterate,
        w: &[f64],
        dw: &[f64],
        dl: &[f64],
        (mu, tau): (f64, f64),
    ) -> LineSearch {
        let theta0 = l1_norm(&sys.ws.c);
        let phi0 = sys.phi(w, mu);
        // ∇φ_μᵀ dw = −rwᵀ dw.
        let m_phi: f64 = -sys.ws.rw.iter().zip(dw).map(|(a, b)| a * b).sum::<f64>();
        let o = Origin {
            theta: theta0,
            phi: phi0,
            m_phi,
        };
        let alpha_min = if m_phi < 0.0 {
            GAMMA_ALPHA
                * GAMMA_THETA
                    .min(GAMMA_PHI * theta0 / -m_phi)
                    .min(DELTA_SWITCH * theta0.powf(S_THETA) / (-m_phi).powf(S_PHI))
        } else {
            GAMMA_ALPHA * GAMMA_THETA
        };
        let mut alpha = sys.max_step(w, dw, tau);
        let mut trials = 0;
        loop {
            trials += 1;
            let (theta, phi) = sys.trial_point(w, dw, alpha, mu);
            if let Some(f_type) = self.acceptable(o, alpha, theta, phi) {
                sys.accept(it, alpha, dw, dl, (mu, tau));
                return LineSearch::Accepted {
                    alpha,
                    trials,
                    f_type,
                };
            }
            if trials == 1 && theta >= theta0 {
                if let Some(accepted) =
                    self.second_order_correction(sys, it, o, (alpha, theta), w, (mu, tau))
                {
                    return accepted;
                }
            }
            alpha *= 0.5;
            if alpha < alpha_min {
                break;
            }
        }
        LineSearch::Failed
    }

    /// Second-order corrections of the first trial (§2.4), at step `alpha`
    /// with infeasibility `theta_trial`: steps on the accumulated constraint
    /// values c_soc = α·c_soc + c(w + α d_soc).
    fn second_order_correction<M: Differentiable, const NS: usize, const NL: usize>(
        &mut self,
        sys: &mut Newton<'_, M, NS, NL>,
        it: &mut Iterate,
        o: Origin,
        (alpha, theta_trial): (f64, f64),
        w: &[f64],
        (mu, tau): (f64, f64),
    ) -> Option<LineSearch> {
        let mut c_soc = std::mem::take(&mut sys.ws.c_soc);
        for ((cs, c), t) in c_soc.iter_mut().zip(&sys.ws.c).zip(&sys.ws.c_trial) {
            *cs = alpha * c + t;
        }
        let mut theta_old = theta_trial;
        let mut out = None;
        for p in 0..MAX_SOC {
            for (r, c) in sys.ws.rl.iter_mut().zip(&c_soc) {
                *r = -c;
            }
            sys.solve_kkt();
            let (d, dl) = (
                std::mem::take(&mut sys.ws.dw),
                std::mem::take(&mut sys.ws.dl),
            );
            let a_soc = sys.max_step(w, &d, tau);
            let (theta, phi) = sys.trial_point(w, &d, a_soc, mu);
            let accepted = self.acceptable(o, alpha, theta, phi);
            if let Some(f_type) = accepted {
                sys.accept(it, a_soc, &d, &dl, (mu, tau));
                out = Some(LineSearch::Accepted {
                    alpha: a_soc,
                    trials: 1 + p + 1,
                    f_type,
                });
            }
            (sys.ws.dw, sys.ws.dl) = (d, dl);
            if out.is_some() || theta > KAPPA_SOC * theta_old {
                break;
            }
            theta_old = theta;
            for (cs, t) in c_soc.iter_mut().zip(&sys.ws.c_trial) {
                *cs = a_soc * *cs + t;
            }
        }
        sys.ws.c_soc = c_soc;
        out
    }
}
