//! The landing problem itself: the vehicle's dynamics (Eq. 1–3, 8, 21–22)
//! and the certificates that no trajectory exists.

pub mod constraints;
pub mod dynamics;
pub mod feasibility;
pub mod model;
pub mod six_dof;
