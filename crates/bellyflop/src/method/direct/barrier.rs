//! The barrier parameter update: the monotone (Fiacco–McCormick) rule of
//! §3.1 (Eq. 7), and the adaptive rule (Mehrotra's probe), which falls back
//! to the monotone one when its optimality error E_0 stalls.

use crate::collocation::derivatives::Differentiable;
use crate::input::settings::{DirectSettings, MuStrategy};
use crate::method::direct::iterate::Iterate;
use crate::method::direct::newton::Newton;

// Constants of Wächter & Biegler (2006), Table 1 and §3, at IPOPT's defaults.
const KAPPA_EPS: f64 = 10.0;
const KAPPA_MU: f64 = 0.2;
const THETA_MU: f64 = 1.5;
const TAU_MIN: f64 = 0.99;
/// Adaptive μ: iterations over which E_0 must fall by 0.01 %.
pub const ADAPTIVE_WINDOW: usize = 4;

/// Adaptive μ: the factor by which E_0 must fall over [`ADAPTIVE_WINDOW`]
/// iterations.
const ADAPTIVE_DECREASE: f64 = 0.9999;

/// μ and the fraction to the boundary τ = max(τ_min, 1 − μ) (Eq. 8), and the
/// state of the adaptive rule.
pub(super) struct Barrier {
    pub(super) mu: f64,
    pub(super) tau: f64,
    /// Whether μ follows the adaptive rule (until it falls back).
    adaptive: bool,
    /// E_0 at the iterations of the adaptive mode, for its progress test.
    e0_history: Vec<f64>,
    /// The overall tolerance ε_tol; μ stays at least ε_tol/10.
    tol: f64,
}

impl Barrier {
    /// The barrier of `settings` at its start, its E_0 history kept in `e0_history` (emptied;
    /// reused storage, so that a re-plan does not allocate).
    pub(super) fn with_history(settings: &DirectSettings, mut e0_history: Vec<f64>) -> Self {
        e0_history.clear();
        e0_history.reserve(settings.max_iterations);
        Barrier {
            mu: settings.mu_init,
            tau: TAU_MIN.max(1.0 - settings.mu_init),
            adaptive: settings.mu_strategy == MuStrategy::Adaptive,
            e0_history,
            tol: settings.tolerance,
        }
    }

    /// Its E_0 history's storage, for [`Barrier::with_history`].
    pub(super) fn into_history(self) -> Vec<f64> {
        self.e0_history
    }

    pub(super) fn is_adaptive(&self) -> bool {
        self.adaptive
    }

    /// μ and the τ that goes with it.
    fn set(&mut self, mu: f64) {
        self.mu = mu;
        self.tau = TAU_MIN.max(1.0 - self.mu);
    }

    /// The update at the start of an iteration with optimality error `e0`
    /// (E_0): leave the adaptive mode if it stalls; in the monotone mode,
    /// decrease μ (Eq. 7) while the barrier problem is solved to κ_ε·μ,
    /// possibly several times. Whether μ changed (and the filter must be
    /// reset).
    pub(super) fn update<M: Differentiable, const NS: usize, const NL: usize>(
        &mut self,
        sys: &Newton<'_, M, NS, NL>,
        it: &Iterate,
        e0: f64,
    ) -> bool {
        let mut changed = false;
        if self.adaptive && !self.adaptive_progress(e0) {
            self.leave_adaptive_mode(sys, it);
            changed = true;
        }
        if !self.adaptive {
            // Monotone barrier update (§3.1, Eq. 7), possibly several times.
            let tol = self.tol;
            while sys.optimality_error(it, self.mu).0 <= KAPPA_EPS * self.mu && self.mu > tol / 10.0
            {
                self.set((tol / 10.0).max((KAPPA_MU * self.mu).min(self.mu.powf(THETA_MU))));
                changed = true;
            }
        }
        changed
    }

    /// In the adaptive mode, after the factorization: μ from Mehrotra's
    /// probe. Whether μ was set (and the filter must be reset).
    pub(super) fn probe<M: Differentiable, const NS: usize, const NL: usize>(
        &mut self,
        sys: &mut Newton<'_, M, NS, NL>,
        it: &Iterate,
    ) -> bool {
        if !self.adaptive {
            return false;
        }
        let mu = self.probe_mu(sys, it);
        self.set(mu);
        true
    }

    /// Whether the adaptive mode still makes progress: E_0 fell by
    /// [`ADAPTIVE_DECREASE`] against its value [`ADAPTIVE_WINDOW`] iterations ago.
    fn adaptive_progress(&mut self, e0: f64) -> bool {
        self.e0_history.push(e0);
        let n = self.e0_history.len();
        n <= ADAPTIVE_WINDOW || e0 <= ADAPTIVE_DECREASE * self.e0_history[n - 1 - ADAPTIVE_WINDOW]
    }

    /// Switch to the monotone rule for the rest of the solve, at μ = κ_μ
    /// times the average complementarity (the caller resets the filter).
    pub(super) fn leave_adaptive_mode<M: Differentiable, const NS: usize, const NL: usize>(
        &mut self,
        sys: &Newton<'_, M, NS, NL>,
        it: &Iterate,
    ) {
        self.adaptive = false;
        let (avg, _) = sys.complementarity(it, None);
        self.set((KAPPA_MU * avg).max(self.tol / 10.0));
    }

    /// Mehrotra's probe: the affine-scaling step (μ = 0) with the current
    /// factors, its complementarity μ_aff, and μ = σ·avg with
    /// σ = (μ_aff/avg)³.
    fn probe_mu<M: Differentiable, const NS: usize, const NL: usize>(
        &self,
        sys: &mut Newton<'_, M, NS, NL>,
        it: &Iterate,
    ) -> f64 {
        sys.newton_rhs(it, 0.0);
        sys.solve_kkt();
        let (mut dzl, mut dzu) = (
            std::mem::take(&mut sys.ws.dzl),
            std::mem::take(&mut sys.ws.dzu),
        );
        let mut dzr = std::mem::take(&mut sys.dzr);
        let dw = std::mem::take(&mut sys.ws.dw);
        let ad = sys.dual_step(it, &dw, &mut dzl, &mut dzu, &mut dzr, (0.0, 1.0));
        let ap = sys.max_step(&it.w, &dw, 1.0);
        (sys.ws.dzl, sys.ws.dzu, sys.ws.dw, sys.dzr) = (dzl, dzu, dw, dzr);
        let (avg, _) = sys.complementarity(it, None);
        let (aff, _) = sys.complementarity(it, Some((ap, ad)));
        let sigma = (aff / avg).clamp(0.0, 1.0).powi(3);
        (sigma * avg).clamp(self.tol / 10.0, 1e3)
    }
}
