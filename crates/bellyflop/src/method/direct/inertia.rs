//! Inertia correction (§3.1.1, Algorithm IC): the regularization δ_w I of
//! W and −δ_c I of the constraint block with which the Newton system has
//! the inertia of a descent direction, and the memory of the last δ_w that
//! IPOPT's schedule starts from.

use crate::collocation::derivatives::Differentiable;
use crate::method::direct::newton::Newton;

/// First trial, smallest and largest δ_w, and its decrease and growth factors.
const DELTA_W_FIRST: f64 = 1e-4;
const DELTA_W_MIN: f64 = 1e-20;
const DELTA_W_MAX: f64 = 1e40;
const KAPPA_W_MINUS: f64 = 1.0 / 3.0;
const KAPPA_W_PLUS: f64 = 8.0;
const KAPPA_W_PLUS_FIRST: f64 = 100.0;
/// Dual regularization δ_c = 1e-8·μ^{1/4} when S is singular.
const DELTA_C: f64 = 1e-8;

/// The state of the inertia correction across iterations.
#[derive(Debug, Default)]
pub(super) struct InertiaCorrection {
    /// δ_w of the last factorization (0: none needed).
    pub(super) delta_w: f64,
    /// The last nonzero δ_w (δ_w^last). (δ_c is not kept: each
    /// factorization starts from δ_c = 0, and the KKT matrix carries the
    /// one it used.)
    delta_w_last: f64,
}

impl InertiaCorrection {
    /// Inertia-correcting factorization of `sys`'s KKT blocks at barrier
    /// `mu`: the smallest δ_w of IPOPT's schedule with which K has the
    /// inertia (n, m, 0), and δ_c > 0 once K is singular.
    pub(super) fn factor<M: Differentiable, const NS: usize, const NL: usize>(
        &mut self,
        sys: &mut Newton<'_, M, NS, NL>,
        mu: f64,
    ) -> Result<(), String> {
        let h_tt = sys.ws.kkt.h_tt;
        // After an iteration that needed a correction, start from a third of
        // it instead of from 0 (which would almost surely fail again and cost
        // a factorization).
        let mut delta_w = if self.delta_w > 0.0 {
            (KAPPA_W_MINUS * self.delta_w_last).max(DELTA_W_MIN)
        } else {
            0.0
        };
        let mut delta_c = 0.0;
        loop {
            let inertia = sys.factor_with(delta_w, delta_c, h_tt);
            if sys.correct_inertia(inertia) {
                break;
            }
            if inertia.zero > 0 && delta_c == 0.0 {
                delta_c = DELTA_C * mu.powf(0.25);
                continue;
            }
            delta_w = if delta_w == 0.0 {
                if self.delta_w_last == 0.0 {
                    DELTA_W_FIRST
                } else {
                    (KAPPA_W_MINUS * self.delta_w_last).max(DELTA_W_MIN)
                }
            } else if self.delta_w_last == 0.0 {
                KAPPA_W_PLUS_FIRST * delta_w
            } else {
                KAPPA_W_PLUS * delta_w
            };
            if delta_w > DELTA_W_MAX {
                return Err(
                    "the Newton system cannot be regularized to the inertia of a descent direction"
                        .into(),
                );
            }
        }
        if delta_w > 0.0 {
            self.delta_w_last = delta_w;
            // Keep the system consistent with its factors for refinement
            // (the eliminated positions take no correction: x is fixed by
            // its defects, so δ_w on it would not change the reduced Hessian).
            for (k, w) in sys.ws.kkt.w.iter_mut().enumerate() {
                for (s, row) in w.iter_mut().enumerate() {
                    if !sys.ws.solver.eliminates(k, s) {
                        row[s] += delta_w;
                    }
                }
            }
        }
        self.delta_w = delta_w;
        Ok(())
    }
}
