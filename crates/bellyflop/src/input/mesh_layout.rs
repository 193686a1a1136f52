//! The shape of a collocation mesh, as a user gives it
//! (`[discretization.mesh]`) and as every answer reports it; the mesh itself
//! is [`crate::collocation::mesh::Mesh`].

use serde::{Deserialize, Serialize};

/// A mesh's shape, as data: M + 1 breaks τ_0 = −1 < τ_1 < … < τ_M = +1 and
/// the LGR points n_k of each of the M intervals (N = Σ n_k). A scenario may
/// give one in `[discretization.mesh]`; every [`crate::Solution`] carries
/// the one it was solved on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshLayout {
    /// Interval breaks in τ, M + 1 values from −1 to +1, strictly increasing.
    pub breaks_tau: Vec<f64>,
    /// LGR collocation points n_k of each interval (M values, each ≥ 2 in a
    /// scenario).
    pub points: Vec<usize>,
}

impl MeshLayout {
    /// `n` points over `intervals` equal intervals: τ_k = −1 + 2k/M (the last
    /// break exactly +1), n_k = ⌊N/M⌋ and the first N mod M intervals one more.
    pub fn uniform(n: usize, intervals: usize) -> MeshLayout {
        let m = intervals;
        let (base, extra) = (n / m.max(1), n % m.max(1));
        let breaks_tau = (0..=m)
            .map(|k| {
                if k == m {
                    1.0
                } else {
                    -1.0 + 2.0 * k as f64 / m as f64
                }
            })
            .collect();
        let points = (0..m).map(|k| base + usize::from(k < extra)).collect();
        MeshLayout { breaks_tau, points }
    }

    /// Number of intervals M.
    pub fn intervals(&self) -> usize {
        self.points.len()
    }

    /// Number of collocation points N = Σ n_k.
    pub fn nodes(&self) -> usize {
        self.points.iter().sum()
    }
}
