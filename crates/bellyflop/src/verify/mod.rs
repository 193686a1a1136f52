//! What an answer is worth against the nonlinear model: re-integration of
//! its controls, the landing error against the tolerances, and the relative
//! error of each mesh interval.

pub mod accuracy;
pub mod mesh_error;
pub mod ode;
pub mod propagate;
