//! What the user brings: the scenario (vehicle, environment, boundary
//! states, discretization), the solver settings, their ranges and
//! validation, and the typed errors of bad input.

mod case_file;
pub mod error;
pub mod guess;
pub mod mesh_layout;
pub mod model_kind;
pub mod overrides;
pub(crate) mod range;
pub mod scenario;
pub mod settings;
pub mod validate;
