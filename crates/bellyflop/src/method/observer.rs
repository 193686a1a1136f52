//! What a solver reports as it iterates: one trait that both methods call
//! (progress bars, logs, plots).

use crate::solution::{DirectIteration, IterationRecord, Pass};

/// Receives each iteration as it completes (progress bars, logs, plots).
pub trait Observer {
    /// An SCvx iteration.
    fn on_iteration(&mut self, record: &IterationRecord);
    /// An iteration of the direct method (ignored unless overridden).
    fn on_direct_iteration(&mut self, _record: &DirectIteration) {}
    /// A pass of mesh refinement, solved and estimated (ignored unless
    /// overridden).
    fn pass(&mut self, _pass: &Pass) {}
}

/// An observer that ignores everything.
pub struct Silent;

impl Observer for Silent {
    fn on_iteration(&mut self, _: &IterationRecord) {}
}

impl<F: FnMut(&IterationRecord)> Observer for F {
    fn on_iteration(&mut self, record: &IterationRecord) {
        self(record)
    }
}
