//! A second-order cone program in Clarabel's form — the data of one SCvx
//! subproblem P4 — and the answer to one.
//!
//! These are the types that the assembly ([`super::subproblem`]) and the
//! interior-point solve ([`super::conic`]) share; keeping them here lets
//! both depend on this module and neither on the other's.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{SolverStatus, SupportedConeT};

use crate::collocation::trajectory::Trajectory;

/// Conic data of one subproblem: minimize qᵀz s.t. A z + s = b, s ∈ cones.
#[derive(Debug, Clone)]
pub struct ConicData {
    /// Upper triangle of the quadratic cost: the proximal term w·‖ẑ − ẑ_ref‖².
    pub p: CscMatrix<f64>,
    /// Linear cost of the convex model L (cost plus exact penalty).
    pub q_model: Vec<f64>,
    /// Linear cost including the proximal term's linear part.
    pub q: Vec<f64>,
    pub a: CscMatrix<f64>,
    pub b: Vec<f64>,
    pub cones: Vec<SupportedConeT<f64>>,
}

/// The answer of one subproblem.
#[derive(Debug, Clone)]
pub struct SubproblemResult {
    pub trajectory: Trajectory,
    /// Scaled trajectory variables.
    pub z: Vec<f64>,
    /// Objective of the convex model L(z) (cost plus linear penalty).
    pub model_cost: f64,
    /// Largest virtual control or buffer (scaled ∞-norm).
    pub virtual_control: f64,
    pub ipm_iterations: u32,
    pub status: SolverStatus,
    /// Virtual control ν⁺ − ν⁻ of every collocation defect (node-major, N·NX).
    pub defect_virtual_control: Vec<f64>,
}
