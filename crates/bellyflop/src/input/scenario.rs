//! Scenario: vehicle, boundary conditions, discretization and solver settings.
//!
//! A scenario is read from TOML (see `scenarios/paper.toml`), then validated:
//! every field is checked against an allowed range before any mathematics runs,
//! so bad input fails with a message that names the field, its value and the range.

use serde::{Deserialize, Serialize};

use crate::input::error::InputError;
use crate::input::mesh_layout::MeshLayout;
pub use crate::input::model_kind::ModelKind;
use crate::input::settings::SolverSettings;

/// Vehicle parameters (paper Table 1, plus the drag coefficient from NOTES.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Vehicle {
    /// Dry mass m_dry \[kg\]; the final mass must stay at or above it (Eq. 4).
    pub dry_mass_kg: f64,
    /// Body length l_s \[m\].
    pub length_m: f64,
    /// Body radius r_s \[m\].
    pub radius_m: f64,
    /// Centre-of-mass position l_cg, measured from the engine gimbal \[m\].
    pub cg_m: f64,
    /// Centre-of-pressure position l_cp, measured like l_cg \[m\].
    pub cp_m: f64,
    /// Maximum thrust T_max \[N\].
    pub max_thrust_n: f64,
    /// Minimum thrust T_min \[N\] (the engine cannot throttle below it, Eq. 5).
    pub min_thrust_n: f64,
    /// Specific impulse I_sp \[s\].
    pub isp_s: f64,
    /// Maximum nozzle (gimbal) angle δ_max \[deg\].
    pub max_gimbal_deg: f64,
    /// Maximum nozzle angle rate χ_max [deg/s].
    pub max_gimbal_rate_degps: f64,
    /// Lumped drag coefficient C_LD = ½·ρ·c_D·A [kg/m] (Eq. 2).
    pub drag_coefficient_kgpm: f64,
}

/// Whether an optional out-of-plane field is at its default, 0 (so it is
/// not written, and planar files and JSON stay as they were).
pub(crate) fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// Planet constants.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Environment {
    /// Gravitational acceleration g0 [m/s²], also used in I_sp·g0.
    pub g0_mps2: f64,
    /// Steady horizontal wind W [m/s], positive along +x: the drag of Eq. (2)
    /// acts on the air-relative velocity (Vx − W, Vz). Default 0, the paper's
    /// still air. Closed-loop guidance sets it to its wind estimate.
    #[serde(default)]
    pub wind_x_mps: f64,
    /// Steady cross wind along +y [m/s], 6-DoF model only (`model = "6dof"`);
    /// default 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub wind_y_mps: f64,
}

/// The state when the landing burn starts (Eq. 4, x(t0) = x0).
///
/// The fields after `gimbal_deg` are out of the plane and read only by the
/// 6-DoF model (`model = "6dof"`); each defaults to 0 and is not written at
/// 0. How they make the 6-DoF start: [`crate::problem::six_dof::start_state`].
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialState {
    pub x_m: f64,
    pub z_m: f64,
    pub vx_mps: f64,
    pub vz_mps: f64,
    /// Pitch from the vertical; 90° is belly-first (horizontal).
    pub theta_deg: f64,
    pub pitch_rate_degps: f64,
    pub mass_kg: f64,
    /// Nozzle angle δ at ignition (δ1 of the 6-DoF model).
    pub gimbal_deg: f64,
    /// Cross-range position y \[m\] (6-DoF only).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub y_m: f64,
    /// Cross-range velocity V_y [m/s] (6-DoF only).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub vy_mps: f64,
    /// Yaw ψ about the inertial z axis, applied after the pitch \[deg\]
    /// (6-DoF only).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub yaw_deg: f64,
    /// Roll φ about the vehicle axis e_z, applied before the pitch \[deg\]
    /// (6-DoF only).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub roll_deg: f64,
    /// Body rate ω_x about the body axis e_x [deg/s] (6-DoF only).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub body_rate_x_degps: f64,
    /// Roll rate ω_z about the vehicle axis e_z [deg/s] (6-DoF only).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub roll_rate_degps: f64,
    /// Second gimbal angle δ2 at ignition, which tilts the thrust out of the
    /// pitch plane \[deg\] (6-DoF only).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub gimbal2_deg: f64,
}

impl InitialState {
    /// (x, z, Vx, Vz, θ, w, m, δ) in SI units and radians (P2's state order).
    pub fn state_si(&self) -> [f64; 8] {
        [
            self.x_m,
            self.z_m,
            self.vx_mps,
            self.vz_mps,
            self.theta_deg.to_radians(),
            self.pitch_rate_degps.to_radians(),
            self.mass_kg,
            self.gimbal_deg.to_radians(),
        ]
    }

    /// The out-of-plane fields (read only by the 6-DoF model) by their
    /// scenario names, with their values.
    pub fn out_of_plane(&self) -> [(&'static str, f64); 7] {
        [
            ("initial.y_m", self.y_m),
            ("initial.vy_mps", self.vy_mps),
            ("initial.yaw_deg", self.yaw_deg),
            ("initial.roll_deg", self.roll_deg),
            ("initial.body_rate_x_degps", self.body_rate_x_degps),
            ("initial.roll_rate_degps", self.roll_rate_degps),
            ("initial.gimbal2_deg", self.gimbal2_deg),
        ]
    }
}

/// The touchdown state (Eq. 4, x|1:6(t_f) = x_f). Mass is free above m_dry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TerminalState {
    pub x_m: f64,
    pub z_m: f64,
    pub vx_mps: f64,
    pub vz_mps: f64,
    pub theta_deg: f64,
    pub pitch_rate_degps: f64,
}

impl TerminalState {
    /// (x, z, Vx, Vz, θ, w) in SI units and radians.
    pub fn state_si(&self) -> [f64; 6] {
        [
            self.x_m,
            self.z_m,
            self.vx_mps,
            self.vz_mps,
            self.theta_deg.to_radians(),
            self.pitch_rate_degps.to_radians(),
        ]
    }
}

/// The `[constraints]` table of a scenario: every limit optional, off when
/// left out. Ranges: [`crate::input::validate`]; the rows they make:
/// [`crate::problem::constraints`].
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Constraints {
    /// Approach cone about the pad: half-angle γ from the vertical \[deg\],
    /// |x − x_f| ≤ (z − z_f)·tan γ along the whole flight.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cone_half_angle_deg: Option<f64>,
    /// Pitch-rate limit w_max [deg/s]: |w| ≤ w_max along the whole flight.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_pitch_rate_degps: Option<f64>,
    /// Tilt limit θ_max \[deg\] below `tilt_below_m` (given together).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_tilt_deg: Option<f64>,
    /// The height above the pad below which |θ| ≤ θ_max holds \[m\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tilt_below_m: Option<f64>,
    /// Vertical final descent: below this height above the pad \[m\] ...
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub final_descent_m: Option<f64>,
    /// ... the lateral speed stays within |Vx| ≤ v_d [m/s] (given together).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub final_descent_lateral_mps: Option<f64>,
}

impl Constraints {
    /// The limits `bellyflop init` writes (commented out), each switched on:
    /// a 30° approach cone (SCPToolbox.jl's `starship_flip` flies 27°), a
    /// 30°/s pitch rate (SCpp's Starship set: 60°/s), upright within 10°
    /// below 50 m, and at most 2 m/s sideways below 20 m.
    pub fn recommended() -> Self {
        Self {
            cone_half_angle_deg: Some(30.0),
            max_pitch_rate_degps: Some(30.0),
            max_tilt_deg: Some(10.0),
            tilt_below_m: Some(50.0),
            final_descent_m: Some(20.0),
            final_descent_lateral_mps: Some(2.0),
        }
    }

    /// No limit switched on: the paper's problem.
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }
}

/// Discretization: LGR collocation with N points (Section 3.2) on M intervals
/// (uniform, or the explicit mesh of `mesh`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Discretization {
    /// Number of LGR collocation points N (4 to 200; at most 100 on the global mesh, one interval).
    pub nodes: usize,
    /// Number of LGR mesh intervals M (1 to N/2; see [`crate::collocation::mesh`]). 1 is the
    /// paper's global mesh; more intervals make each subproblem far cheaper.
    #[serde(default = "one")]
    pub intervals: usize,
    /// Initial guess of the final time t_f \[s\]. Optional in a scenario
    /// file: left out, it is derived from the state (`input::guess`).
    pub tf_guess_s: f64,
    /// Initial guess of the final mass \[kg\] for the straight-line guess.
    /// Optional in a scenario file, like `tf_guess_s`; a given one outside
    /// [m_dry, m0] is clamped into it with a warning ([`Case::warnings`]).
    pub final_mass_guess_kg: f64,
    /// An explicit hp mesh (`[discretization.mesh]`: `breaks_tau`, `points`)
    /// in place of the uniform split of `nodes` over `intervals`. It does not
    /// override them silently: validation requires `nodes` = Σ points and
    /// `intervals` = M, so the two counts always describe the mesh solved on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh: Option<MeshLayout>,
}

pub(crate) fn one() -> usize {
    1
}

/// A whole landing problem: the vehicle, its environment, the boundary
/// states and the mesh. How it is solved is a [`SolverSettings`] value of its
/// own; a scenario file holds both ([`Case`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub name: String,
    /// The model: planar (the default, not written) or 6-DoF.
    #[serde(default, skip_serializing_if = "ModelKind::is_planar")]
    pub model: ModelKind,
    pub vehicle: Vehicle,
    pub environment: Environment,
    pub initial: InitialState,
    pub terminal: TerminalState,
    pub discretization: Discretization,
    /// The operational path constraints (issue 37), each optional; none in
    /// the paper's case.
    #[serde(default, skip_serializing_if = "Constraints::is_empty")]
    pub constraints: Constraints,
}

/// What a scenario file holds: the problem and, in its optional `[solver]`
/// table, the settings to solve it with. Two cases are equal when their
/// problems and settings are: the warnings are remarks on how a file was
/// read, and a clamped file written back reads without any.
#[derive(Debug, Clone)]
pub struct Case {
    pub scenario: Scenario,
    pub solver: SolverSettings,
    /// What reading the file changed, one sentence each: a given guess
    /// outside its range, clamped into it (issue 29). Empty for the paper's
    /// file. The CLI prints them on stderr and in the JSON's `warnings`.
    pub warnings: Vec<String>,
}

impl PartialEq for Case {
    fn eq(&self, other: &Self) -> bool {
        self.scenario == other.scenario && self.solver == other.solver
    }
}

impl Case {
    /// The paper's case and its settings, as shipped in `scenarios/paper.toml`.
    pub fn paper() -> Self {
        Self::from_toml_str(PAPER_TOML).expect("the shipped paper scenario is valid")
    }

    /// Parse and validate a scenario file's text.
    pub fn from_toml_str(text: &str) -> Result<Self, InputError> {
        let case: Case =
            crate::input::error::parse_toml(crate::input::error::FileKind::Scenario, text)?;
        case.validate()?;
        Ok(case)
    }

    /// Read, parse and validate a scenario file.
    pub fn from_file(path: &std::path::Path) -> Result<Self, InputError> {
        Self::from_toml_str(&crate::input::error::read_text(
            crate::input::error::FileKind::Scenario,
            path,
        )?)
    }

    /// Check the problem and the settings, each field against its range.
    pub fn validate(&self) -> Result<(), InputError> {
        self.scenario.validate()?;
        self.solver.validate()
    }
}

/// The paper's case, as shipped in `scenarios/paper.toml`.
pub const PAPER_TOML: &str = include_str!("../../../../scenarios/paper.toml");

impl Scenario {
    /// The paper's case (Table 1, Section 4 boundary conditions, C_LD = 195.52 kg/m).
    pub fn paper() -> Self {
        Case::paper().scenario
    }

    /// The fields read only by the 6-DoF model, by their scenario names,
    /// with their values: all 0 in a planar scenario (validation checks).
    pub fn out_of_plane(&self) -> [(&'static str, f64); 8] {
        let i = self.initial.out_of_plane();
        let wind = ("environment.wind_y_mps", self.environment.wind_y_mps);
        [i[0], i[1], i[2], i[3], i[4], i[5], i[6], wind]
    }

    /// `Ok` for a planar scenario; for a 6-DoF one,
    /// [`InputError::ModelUnavailable`] naming `operation` (e.g. "the CLI's
    /// solve"): the planar solve, closed loop and bindings call this first,
    /// so a 6-DoF scenario is refused rather than solved as planar.
    pub fn require_planar(&self, operation: &str) -> Result<(), InputError> {
        match self.model {
            ModelKind::Planar => Ok(()),
            model => Err(InputError::ModelUnavailable {
                model,
                operation: operation.into(),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper's file with an explicit 3-interval mesh of 20 points.
    fn with_mesh(mesh_table: &str) -> String {
        let from = "final_mass_guess_kg = 110000.0\n";
        assert!(PAPER_TOML.contains(from));
        PAPER_TOML.replace(
            from,
            &format!("{from}intervals = 3\n\n[discretization.mesh]\n{mesh_table}\n"),
        )
    }

    #[test]
    fn an_explicit_mesh_reads_writes_and_reads_back() {
        let text = with_mesh("breaks_tau = [-1, -0.25, 0.5, 1.0]\npoints = [8, 7, 5]");
        let case = Case::from_toml_str(&text).expect("valid");
        let layout = case.scenario.discretization.mesh.clone().expect("a mesh");
        assert_eq!(layout.breaks_tau, [-1.0, -0.25, 0.5, 1.0]);
        assert_eq!(layout.points, [8, 7, 5]);
        let written = toml::to_string(&case).expect("serializes");
        assert!(written.contains("[discretization.mesh]"), "{written}");
        assert_eq!(Case::from_toml_str(&written).expect("reads back"), case);
        // Without a mesh, none is written.
        let paper = toml::to_string(&Case::paper()).unwrap();
        assert!(!paper.contains("mesh"), "{paper}");
    }

    #[test]
    fn unknown_fields_of_the_mesh_table_are_rejected() {
        let text =
            with_mesh("breaks_tau = [-1, -0.25, 0.5, 1.0]\npoints = [8, 7, 5]\nweights = [1]");
        let e = Case::from_toml_str(&text).unwrap_err();
        assert!(
            matches!(&e, InputError::Toml { message, .. } if message.contains("weights")),
            "{e}"
        );
    }

    #[test]
    fn a_mesh_that_disagrees_with_the_node_count_is_rejected() {
        let text = with_mesh("breaks_tau = [-1, -0.25, 0.5, 1.0]\npoints = [8, 7, 6]");
        let e = Case::from_toml_str(&text).unwrap_err();
        assert!(
            matches!(&e, InputError::Inconsistent { field, .. } if field == "discretization.nodes"),
            "{e}"
        );
    }
}
