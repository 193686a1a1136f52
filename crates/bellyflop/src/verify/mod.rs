//! What an answer is worth against the nonlinear model: re-integration of
//! its controls, the landing error against the tolerances, and the relative
//! error of each mesh interval, and the path constraints along the flight.

pub mod accuracy;
pub mod flight;
pub mod mesh_error;
pub mod ode;
pub mod path;
pub mod propagate;
