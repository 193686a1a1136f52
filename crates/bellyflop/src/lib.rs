//! bellyflop: fuel-optimal flip-and-land trajectories by Legendre–Gauss–Radau
//! collocation and successive convexification (Chen, Ma, Wang, Su 2023).
pub mod error;
pub mod radau;
pub mod scenario;
pub mod validate;

pub use error::InputError;
pub use scenario::{Formulation, Scenario};
