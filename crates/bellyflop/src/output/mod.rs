//! The records a user reads: the JSON of a solve and the rows and summary
//! of a Monte Carlo campaign.

pub mod campaign;
pub mod report;
