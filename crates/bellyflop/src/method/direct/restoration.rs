//! Feasibility restoration (§3.3), simplified to regularized Gauss–Newton
//! steps on ½‖c‖² inside the bounds: it runs when the filter line search
//! finds no acceptable step, and returns a point that is acceptable to the
//! filter and less infeasible, or reports the problem locally infeasible.

#![allow(clippy::needless_range_loop)] // Dense block algebra indexes several arrays by one index.

use crate::collocation::derivatives::Differentiable;
use crate::method::direct::inertia::InertiaCorrection;
use crate::method::direct::iterate::{l1_norm, Iterate};
use crate::method::direct::line_search::{FilterLineSearch, GAMMA_THETA};
use crate::method::direct::newton::Newton;

/// Restoration: iterations, and the factor by which it must reduce θ.
const RESTORATION_ITERATIONS: usize = 40;
const RESTORATION_REDUCTION: f64 = 0.9;

/// One restoration phase at the barrier parameter of the regular phase.
pub(super) struct Restoration {
    /// θ when the phase started.
    theta_start: f64,
    /// The proximal weight ζ = √μ of W = ζ I + Σ.
    zeta: f64,
    mu: f64,
    tau: f64,
}

impl Restoration {
    /// Feasibility restoration: regularized Gauss–Newton steps on ½‖c‖²
    /// that keep the bounds' barrier, until θ has fallen by
    /// [`RESTORATION_REDUCTION`] and the point is acceptable to the filter
    /// (augmented first with the point the phase starts from).
    pub(super) fn run<M: Differentiable, const NS: usize, const NL: usize>(
        sys: &mut Newton<'_, M, NS, NL>,
        inertia: &mut InertiaCorrection,
        search: &mut FilterLineSearch,
        it: &mut Iterate,
        (mu, tau): (f64, f64),
    ) -> Result<(), String> {
        let theta_start = l1_norm(&sys.ws.c);
        let phi_start = sys.phi(&it.w, mu);
        search.augment(theta_start, phi_start);
        let phase = Restoration {
            theta_start,
            zeta: mu.sqrt(),
            mu,
            tau,
        };
        for _ in 0..RESTORATION_ITERATIONS {
            if phase.iteration(sys, inertia, search, it)? {
                return Ok(());
            }
        }
        Err(format!(
            "locally infeasible: no trajectory near this one meets the dynamics and boundary conditions; {RESTORATION_ITERATIONS} restoration iterations reduced the defect from {theta_start:.2e} to {:.2e} only",
            l1_norm(&sys.ws.c)
        ))
    }

    /// One restoration iteration; whether the phase is over (with fresh
    /// multipliers for the regular phase).
    fn iteration<M: Differentiable, const NS: usize, const NL: usize>(
        &self,
        sys: &mut Newton<'_, M, NS, NL>,
        inertia: &mut InertiaCorrection,
        search: &FilterLineSearch,
        it: &mut Iterate,
    ) -> Result<bool, String> {
        let (w, l) = (it.w.clone(), it.lambda.clone());
        sys.evaluate(&w, &l);
        let theta0 = l1_norm(&sys.ws.c);
        self.newton_step(sys, inertia, it, &w)?;
        let dw = sys.ws.dw.clone();
        let Some(alpha) = self.backtrack(sys, &w, &dw, theta0) else {
            return Err(format!(
                "locally infeasible: no trajectory near this one meets the dynamics and boundary conditions; the feasibility restoration stalled at a defect of {:.2e} (scaled, summed over the collocation equations)",
                theta0
            ));
        };
        let zero = vec![0.0; it.lambda.len()];
        sys.accept(it, alpha, &dw, &zero, (self.mu, self.tau));
        sys.nlp.defects(&it.w, &mut sys.ws.c);
        let theta = l1_norm(&sys.ws.c);
        let phi = sys.phi(&it.w, self.mu);
        if theta <= RESTORATION_REDUCTION * self.theta_start && search.filter.acceptable(theta, phi)
        {
            // Fresh multipliers for the regular phase.
            let (w, l) = (it.w.clone(), it.lambda.clone());
            sys.evaluate(&w, &l);
            sys.initial_multipliers(it);
            return Ok(true);
        }
        Ok(false)
    }

    /// The Gauss–Newton step at `w` (the iterate) into ws.dw: W = ζ I + Σ,
    /// the gradient of the barrier only.
    fn newton_step<M: Differentiable, const NS: usize, const NL: usize>(
        &self,
        sys: &mut Newton<'_, M, NS, NL>,
        inertia: &mut InertiaCorrection,
        it: &Iterate,
        w: &[f64],
    ) -> Result<(), String> {
        let nlp = sys.nlp;
        let zeta = self.zeta;
        sys.build_kkt(it);
        for k in 0..=nlp.n {
            for r in 0..NL {
                for c in 0..NL {
                    if r != c {
                        sys.ws.kkt.w[k][r][c] = 0.0;
                    }
                }
                sys.ws.kkt.w[k][r][r] = sys.ws.kkt.w[k][r][r].max(0.0) + zeta;
            }
            sys.ws.kkt.h_t[k] = [0.0; NL];
        }
        sys.ws.kkt.h_tt += zeta;
        if inertia.factor(sys, self.mu).is_err() {
            return Err("the restoration's Newton system cannot be factored".into());
        }
        let b = &sys.bounds;
        for j in 0..w.len() {
            let mut g = 0.0;
            if b.has_lo[j] {
                g -= self.mu / (w[j] - b.lo[j]);
            }
            if b.has_hi[j] {
                g += self.mu / (b.hi[j] - w[j]);
            }
            sys.ws.rw[j] = if b.free[j] { -g } else { 0.0 };
        }
        sys.rows.add_barrier_gradient(nlp, -self.mu, &mut sys.ws.rw);
        for (r, c) in sys.ws.rl.iter_mut().zip(&sys.ws.c) {
            *r = -c;
        }
        sys.solve_kkt();
        Ok(())
    }

    /// The largest α = α_max·2^−l above 1e-8 that reduces θ below
    /// (1 − γ_θ)·`theta0`, if any.
    fn backtrack<M: Differentiable, const NS: usize, const NL: usize>(
        &self,
        sys: &mut Newton<'_, M, NS, NL>,
        w: &[f64],
        dw: &[f64],
        theta0: f64,
    ) -> Option<f64> {
        let mut alpha = sys.max_step(w, dw, self.tau);
        while alpha > 1e-8 {
            let (theta, _) = sys.trial_point(w, dw, alpha, self.mu);
            if theta <= (1.0 - GAMMA_THETA) * theta0 {
                return Some(alpha);
            }
            alpha *= 0.5;
        }
        None
    }
}
