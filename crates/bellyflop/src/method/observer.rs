//! What a solver reports as it iterates: one callback over a typed
//! iteration record, whichever method runs (progress bars, logs, plots).

use crate::solution::{DirectIteration, IterationRecord, Pass};

/// One completed iteration of a method.
#[derive(Debug, Clone, Copy)]
pub enum Iteration<'a> {
    /// An SCvx iteration (a convex subproblem solved and judged).
    Scvx(&'a IterationRecord),
    /// An interior-point iteration of the direct method.
    Direct(&'a DirectIteration),
}

/// Receives each iteration as it completes (progress bars, logs, plots).
pub trait Observer {
    /// An iteration of whichever method runs.
    fn iteration(&mut self, record: Iteration<'_>);
    /// A pass of mesh refinement, solved and estimated (ignored unless
    /// overridden).
    fn pass(&mut self, _pass: &Pass) {}
    /// Whether the solve must end now (a wall-clock deadline), asked after
    /// each iteration: the method then returns its last iterate as
    /// `not_converged`. Never, unless overridden.
    fn deadline_passed(&mut self) -> bool {
        false
    }
}

/// The message of a solve that an [`Observer`]'s deadline ended after
/// `iterations` iterations of `method_iterations` ("interior-point" or "SCvx").
pub fn deadline_message(iterations: usize, method_iterations: &str) -> String {
    format!("the deadline passed after {iterations} {method_iterations} iterations; the last iterate is returned")
}

/// An observer that ignores everything.
pub struct Silent;

impl Observer for Silent {
    fn iteration(&mut self, _: Iteration<'_>) {}
}

impl<F: FnMut(Iteration<'_>)> Observer for F {
    fn iteration(&mut self, record: Iteration<'_>) {
        self(record)
    }
}
