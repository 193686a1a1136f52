//! The changes that `bellyflop solve`'s flags and Python's `solve(...)`
//! arguments make to a case, in one place.

use crate::input::error::InputError;
use crate::input::scenario::Case;
use crate::input::settings::{Formulation, Method};

/// Overrides of a case's discretization and solver settings; `None` keeps
/// the case's own value.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Overrides {
    /// Collocation points N (`--nodes`).
    pub nodes: Option<usize>,
    /// Mesh intervals M (`--intervals`).
    pub intervals: Option<usize>,
    pub formulation: Option<Formulation>,
    pub method: Option<Method>,
    /// `solver.refinement.tolerance` (`--mesh-tolerance`; 0: no refinement).
    pub mesh_tolerance: Option<f64>,
    /// The raw collocation answer, without the polish (`--fast`:
    /// `solver.polish = false`).
    pub fast: bool,
}

impl Overrides {
    /// `case` with these overrides, validated. A count of nodes or
    /// intervals gives a uniform mesh of those counts in place of the
    /// file's explicit `[discretization.mesh]`.
    pub fn apply(&self, mut case: Case) -> Result<Case, InputError> {
        let d = &mut case.scenario.discretization;
        if self.nodes.is_some() || self.intervals.is_some() {
            d.mesh = None;
        }
        if let Some(n) = self.nodes {
            d.nodes = n;
        }
        if let Some(m) = self.intervals {
            d.intervals = m;
        }
        if let Some(f) = self.formulation {
            case.solver.formulation = f;
        }
        if let Some(m) = self.method {
            case.solver.method = m;
        }
        if let Some(tol) = self.mesh_tolerance {
            case.solver.refinement.tolerance = tol;
        }
        if self.fast {
            case.solver.polish = false;
        }
        case.validate()?;
        Ok(case)
    }
}
