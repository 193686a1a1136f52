//! Legendre–Gauss–Radau collocation, shared by every method: the nodes,
//! weights and differentiation of one interval, the global or hp mesh, and
//! the controls as they can be flown between the collocation points.

pub mod control_profile;
pub mod derivatives;
pub mod interpolation;
pub mod mesh;
pub mod plan;
pub mod radau;
pub mod residuals;
pub mod scaling;
pub mod six_dof_derivatives;
pub mod trajectory;
