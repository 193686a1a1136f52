//! SCvx's trust-region rules (Mao, Szmuk, Açıkmeşe 2016): a candidate is
//! accepted when ρ ≥ ρ0; the radius shrinks when the step is rejected or
//! ρ < ρ1, and grows (up to its maximum) when ρ ≥ ρ2 — with one addition,
//! the shrink of a creeping iteration.

use crate::input::settings::SolverSettings;

/// Consecutive creeping steps (see [`TrustRegion::update`]) after which the
/// trust region shrinks.
const CREEP_WINDOW: usize = 5;
/// A step at least this fraction of the radius reaches the trust region.
const CREEP_BOUND: f64 = 0.99;
/// Failed subproblems after which the conic solver has failed for good.
const MAX_FAILURES: usize = 5;

/// The ∞-norm trust region (scaled) and the counts its rules keep.
pub(super) struct TrustRegion {
    pub radius: f64,
    /// Failed subproblems so far.
    failures: usize,
    /// Consecutive creeping steps.
    creep: usize,
}

impl TrustRegion {
    pub fn new(settings: &SolverSettings) -> Self {
        TrustRegion {
            radius: settings.trust_region_initial,
            failures: 0,
            creep: 0,
        }
    }

    /// A failed subproblem is treated like a rejected step: the radius
    /// shrinks. True when the solver has failed for good (too often, or the
    /// radius is below its minimum).
    pub fn after_failure(&mut self, settings: &SolverSettings) -> bool {
        self.failures += 1;
        self.radius /= settings.shrink;
        self.radius < settings.trust_region_min || self.failures > MAX_FAILURES
    }

    /// Whether a candidate with ratio `rho` becomes the reference: always
    /// when the iteration has `converged`.
    pub fn accepts(converged: bool, rho: f64, settings: &SolverSettings) -> bool {
        converged || rho >= settings.rho0
    }

    /// Shrink or grow the radius after a step of length `step` with ratio
    /// `rho`, `accepted` or not; `reference_vc` is the virtual control of
    /// the reference after the step.
    ///
    /// Creep: on a feasible reference, accepted steps that all reach the
    /// trust region while the model over-predicts (ρ < ρ2). The ∞-norm
    /// linear model moves every free variable to the box, so its steps
    /// never shrink on their own near the optimum; [`CREEP_WINDOW`] such
    /// steps in a row are treated like ρ < ρ1. (Without the second-order
    /// correction the rejected steps shrink the radius instead.)
    pub fn update(
        &mut self,
        accepted: bool,
        rho: f64,
        step: f64,
        reference_vc: f64,
        settings: &SolverSettings,
    ) {
        let creeping = settings.second_order_correction
            && accepted
            && rho < settings.rho2
            && step >= CREEP_BOUND * self.radius
            && reference_vc <= settings.virtual_control_tolerance;
        self.creep = if creeping { self.creep + 1 } else { 0 };
        if !accepted || rho < settings.rho1 || self.creep >= CREEP_WINDOW {
            self.radius /= settings.shrink;
            self.creep = 0;
        } else if rho >= settings.rho2 {
            self.radius = (self.radius * settings.grow).min(settings.trust_region_max);
        }
    }

    /// Whether the radius has shrunk below its minimum: no step, however
    /// short, lowers the merit.
    pub fn collapsed(&self, settings: &SolverSettings) -> bool {
        self.radius < settings.trust_region_min
    }
}
