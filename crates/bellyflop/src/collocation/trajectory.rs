//! A trajectory on the collocation grid, in physical units: what every
//! method returns and every check reads.

use crate::problem::dynamics::{NU_MAX, NX};

/// A trajectory in physical units (SI, radians, ω = ln m) on the LGR grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    /// States at the N+1 points τ_1 = −1, …, τ_N, τ_{N+1} = +1.
    pub x: Vec<[f64; NX]>,
    /// Controls at the N collocation points (first `control_dim` entries used).
    pub u: Vec<[f64; NU_MAX]>,
    pub tf_s: f64,
}

impl Trajectory {
    /// Every state, control and t_f is finite.
    pub fn is_finite(&self) -> bool {
        self.tf_s.is_finite()
            && self.x.iter().flatten().all(|v| v.is_finite())
            && self.u.iter().flatten().all(|v| v.is_finite())
    }
}
