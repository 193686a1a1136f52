//! The `model` key of a scenario: which model it describes (issue 38).

use serde::{Deserialize, Serialize};

/// Which model a scenario describes: its top-level `model` key, `"planar"`
/// (the default, the paper's problem in the x–z plane) or `"6dof"` (the
/// 6-DoF model of [`crate::problem::six_dof`], which reads the out-of-plane
/// fields of `[initial]` and `environment.wind_y_mps` too).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum ModelKind {
    /// The paper's planar model (Eq. 1–3): `model = "planar"`, or no key.
    #[default]
    #[serde(rename = "planar")]
    Planar,
    /// The 6-DoF model (issue 38): `model = "6dof"`.
    #[serde(rename = "6dof")]
    SixDof,
}

impl ModelKind {
    /// The TOML spelling: `"planar"` or `"6dof"`.
    pub fn as_str(self) -> &'static str {
        match self {
            ModelKind::Planar => "planar",
            ModelKind::SixDof => "6dof",
        }
    }

    /// The default, planar model (not written to a file).
    pub fn is_planar(&self) -> bool {
        *self == ModelKind::Planar
    }
}

impl std::fmt::Display for ModelKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}
