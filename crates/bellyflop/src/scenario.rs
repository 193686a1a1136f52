//! Scenario: vehicle, boundary conditions, discretization and solver settings.
//!
//! A scenario is read from TOML (see `scenarios/paper.toml`), then validated:
//! every field is checked against an allowed range before any mathematics runs,
//! so bad input fails with a message that names the field, its value and the range.

use serde::{Deserialize, Serialize};

use crate::error::InputError;

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
}

/// The state when the landing burn starts (Eq. 4, x(t0) = x0).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
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
    /// Nozzle angle δ at ignition.
    pub gimbal_deg: f64,
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

/// Which form of the thrust-direction constraint the subproblem uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Formulation {
    /// Physically exact (default): controls σ = T/m and χ = δ̇; the thrust
    /// direction θ + δ stays inside the dynamics and is linearized by SCvx.
    /// ‖T‖ = σ holds by construction, and thrust cannot point backwards.
    #[default]
    Exact,
    /// The paper's P4 (Eq. 26–30): controls Txm, Tzm, σ, χ with the lossless
    /// cone ‖(Txm, Tzm)‖ ≤ σ and the linearized direction constraint (Eq. 27).
    Paper,
    /// Thrust-vector form: the paper's controls (Txm, Tzm, σ, χ) and cone, with
    /// the thrust forced onto the nozzle axis by two linearized equalities,
    /// Txm·cos φ − Tzm·sin φ = 0 and Txm·sin φ + Tzm·cos φ = σ (φ = θ + δ),
    /// under virtual control. Physically exact at convergence.
    Vector,
}

/// Which method solves the transcription.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Successive convexification with Clarabel (the paper's method).
    Scvx,
    /// A primal–dual interior-point method on the nonlinear program P2
    /// ([`crate::direct`]); the default: on seeded dispersed states it
    /// solves every state IPOPT solves, 2–3× faster than IPOPT and 15× faster
    /// than SCvx (BENCHMARKS.md, `bench/envelope.py`).
    #[default]
    Direct,
}

impl Method {
    pub fn as_str(self) -> &'static str {
        match self {
            Method::Scvx => "scvx",
            Method::Direct => "direct",
        }
    }
}

/// Discretization: LGR collocation with N points (Section 3.2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Discretization {
    /// Number of LGR collocation points N (4 to 100).
    pub nodes: usize,
    /// Number of LGR mesh intervals M (1 to N/2; see [`crate::mesh`]). 1 is the
    /// paper's global mesh; more intervals make each subproblem far cheaper.
    #[serde(default = "one")]
    pub intervals: usize,
    /// Initial guess of the final time t_f \[s\].
    pub tf_guess_s: f64,
    /// Initial guess of the final mass \[kg\] for the straight-line guess.
    pub final_mass_guess_kg: f64,
}

fn one() -> usize {
    1
}

/// SCvx settings (Section 3.4, with the trust-region rule of Mao et al. 2016).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SolverSettings {
    /// The method: `scvx` (the paper's) or `direct`.
    pub method: Method,
    /// Settings of the direct method.
    pub direct: crate::direct::DirectSettings,
    pub formulation: Formulation,
    /// Exact formulation only: iterations allowed to the paper's relaxation
    /// before the exact form is solved; its answer is kept only if it passes
    /// every physical check. 0 solves the exact form directly.
    pub relaxed_first_iterations: usize,
    /// Iteration limit; past it the status is `not_converged`.
    pub max_iterations: usize,
    /// Convergence: scaled step ‖Δz‖∞ below this.
    pub step_tolerance: f64,
    /// Convergence: largest nonlinear collocation defect (scaled, Eq. 24) below this.
    pub defect_tolerance: f64,
    /// Convergence: scaled virtual control ‖ν‖∞ below this.
    pub virtual_control_tolerance: f64,
    /// Exact-penalty weight λ on ‖ν‖₁ (scaled units).
    pub virtual_control_weight: f64,
    /// Weight w of the proximal term w·‖Δẑ‖² that regularizes each subproblem.
    pub proximal_weight: f64,
    /// Initial trust-region radius (scaled ∞-norm). The relaxed first phase
    /// of the `exact` formulation has its own (0.6, see `scvx`).
    pub trust_region_initial: f64,
    /// Smallest trust-region radius before the iteration stops.
    pub trust_region_min: f64,
    /// Largest trust-region radius.
    pub trust_region_max: f64,
    /// Acceptance-ratio thresholds ρ0 < ρ1 < ρ2 (Mao, Szmuk, Açıkmeşe 2016).
    pub rho0: f64,
    pub rho1: f64,
    pub rho2: f64,
    /// Radius shrink factor (>1) when ρ < ρ1, and growth factor (>1) when ρ ≥ ρ2.
    pub shrink: f64,
    pub grow: f64,
    /// Second-order correction of poor candidates (ρ < ρ1): remove the
    /// candidate's linearization error by a minimum-norm step on the
    /// linearized equalities before judging it (Nocedal & Wright §15.6).
    /// Without it the exact-penalty merit rejects steps for their O(Δ²)
    /// defects (the Maratos effect) and the trust region shrinks onto a
    /// point short of the optimum.
    pub second_order_correction: bool,
    /// Accepted relaxation gap max(1 − ‖T‖/σ) of a returned solution.
    pub relaxation_gap_tolerance: f64,
    /// Soft thrust margin μ (0 = off): a throttle outside
    /// [(1+μ)·T_min, (1−μ)·T_max] is allowed, up to the hard bounds, at a cost
    /// of `thrust_margin_weight` per node and unit of scaled σ. Closed-loop
    /// plans keep thrust range for feedback this way without declaring a
    /// state infeasible that the engine can still land from.
    pub thrust_margin_frac: f64,
    /// Cost weight of the soft thrust margin's use (scaled units; the fuel
    /// cost −ω̂(t_f) is of order one).
    pub thrust_margin_weight: f64,
    /// Soft terminal position and horizontal velocity (0 = hard, the
    /// paper's Eq. 4): a miss of x(t_f) or Vx(t_f) costs this weight per
    /// unit of scaled miss. A closed-loop re-plan that cannot null the
    /// lateral error any more then returns the smallest miss instead of
    /// failing.
    pub terminal_lateral_weight: f64,
    /// Largest re-integrated landing position error ‖(x, z)(t_f) − (x_f, z_f)‖
    /// of a `solved` answer \[m\] ([`crate::accuracy`]); beyond it the status
    /// is `inaccurate`. Default 5 m, six times the paper's case at N = 20
    /// (0.81 m with both methods).
    pub landing_position_tolerance_m: f64,
    /// Largest re-integrated landing velocity error ‖(Vx, Vz)(t_f) − (Vx_f,
    /// Vz_f)‖ [m/s]. Default 2 m/s, six times the paper's case at N = 20
    /// (0.32 m/s).
    pub landing_velocity_tolerance_mps: f64,
}

impl Default for SolverSettings {
    fn default() -> Self {
        Self {
            method: Method::Direct,
            direct: crate::direct::DirectSettings::default(),
            formulation: Formulation::Exact,
            relaxed_first_iterations: 10,
            max_iterations: 100,
            step_tolerance: 1e-3,
            defect_tolerance: 1e-6,
            virtual_control_tolerance: 1e-7,
            virtual_control_weight: 1e3,
            proximal_weight: 0.0,
            trust_region_initial: 0.3,
            trust_region_min: 1e-6,
            trust_region_max: 10.0,
            rho0: 0.0,
            rho1: 0.25,
            rho2: 0.7,
            shrink: 3.0,
            grow: 2.0,
            second_order_correction: true,
            relaxation_gap_tolerance: 1e-6,
            thrust_margin_frac: 0.0,
            thrust_margin_weight: 100.0,
            terminal_lateral_weight: 0.0,
            landing_position_tolerance_m: 5.0,
            landing_velocity_tolerance_mps: 2.0,
        }
    }
}

/// A whole landing problem: the vehicle, its environment, the boundary
/// states and the mesh. How it is solved is a [`SolverSettings`] value of its
/// own; a scenario file holds both ([`Case`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub name: String,
    pub vehicle: Vehicle,
    pub environment: Environment,
    pub initial: InitialState,
    pub terminal: TerminalState,
    pub discretization: Discretization,
}

/// What a scenario file holds: the problem and, in its optional `[solver]`
/// table, the settings to solve it with.
#[derive(Debug, Clone, PartialEq)]
pub struct Case {
    pub scenario: Scenario,
    pub solver: SolverSettings,
}

/// A scenario file's tables, for serde: [`Case`] with the problem's tables at
/// the top level.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct CaseFile {
    name: String,
    vehicle: Vehicle,
    environment: Environment,
    initial: InitialState,
    terminal: TerminalState,
    discretization: Discretization,
    #[serde(default)]
    solver: SolverSettings,
}

impl Serialize for Case {
    fn serialize<S: serde::Serializer>(&self, ser: S) -> Result<S::Ok, S::Error> {
        let s = self.scenario.clone();
        CaseFile {
            name: s.name,
            vehicle: s.vehicle,
            environment: s.environment,
            initial: s.initial,
            terminal: s.terminal,
            discretization: s.discretization,
            solver: self.solver.clone(),
        }
        .serialize(ser)
    }
}

impl<'de> Deserialize<'de> for Case {
    fn deserialize<D: serde::Deserializer<'de>>(de: D) -> Result<Self, D::Error> {
        let f = CaseFile::deserialize(de)?;
        Ok(Case {
            scenario: Scenario {
                name: f.name,
                vehicle: f.vehicle,
                environment: f.environment,
                initial: f.initial,
                terminal: f.terminal,
                discretization: f.discretization,
            },
            solver: f.solver,
        })
    }
}

impl Case {
    /// The paper's case and its settings, as shipped in `scenarios/paper.toml`.
    pub fn paper() -> Self {
        Self::from_toml_str(PAPER_TOML).expect("the shipped paper scenario is valid")
    }

    /// Parse and validate a scenario file's text.
    pub fn from_toml_str(text: &str) -> Result<Self, InputError> {
        let case: Case = crate::error::parse_toml(crate::error::FileKind::Scenario, text)?;
        case.validate()?;
        Ok(case)
    }

    /// Read, parse and validate a scenario file.
    pub fn from_file(path: &std::path::Path) -> Result<Self, InputError> {
        Self::from_toml_str(&crate::error::read_text(
            crate::error::FileKind::Scenario,
            path,
        )?)
    }

    /// Check the problem and the settings, each field against its range.
    pub fn validate(&self) -> Result<(), InputError> {
        self.scenario.validate()?;
        self.solver.validate()
    }

    /// Solve with [`crate::solve`].
    pub fn solve(&self, observer: &mut dyn crate::Observer) -> crate::Solution {
        crate::solve(&self.scenario, &self.solver, observer)
    }
}

impl SolverSettings {
    /// Check every field against its allowed range.
    pub fn validate(&self) -> Result<(), InputError> {
        crate::validate::solver(self)
    }
}

/// The paper's case, as shipped in `scenarios/paper.toml`.
pub const PAPER_TOML: &str = include_str!("../../../scenarios/paper.toml");

impl Scenario {
    /// The paper's case (Table 1, Section 4 boundary conditions, C_LD = 195.52 kg/m).
    pub fn paper() -> Self {
        Case::paper().scenario
    }

    /// Check every field against its allowed range.
    pub fn validate(&self) -> Result<(), InputError> {
        crate::validate::scenario(self)
    }
}
