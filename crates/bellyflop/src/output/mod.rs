//! The records a user reads: the JSON of a solve, the rows and summary
//! of a Monte Carlo campaign, and the viewer page that plays them.

pub mod campaign;
pub mod report;
pub mod samples;
pub mod viewer;
