//! How a scenario is solved, apart from the problem itself: the method, the
//! SCvx settings and the direct method's (`[solver]` and `[solver.direct]`
//! of a scenario file). Their ranges are checked by [`crate::input::validate`].

use serde::{Deserialize, Serialize};

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
    /// ([`crate::method::direct`]); the default: on 150 seeded dispersed states it
    /// solves every state IPOPT solves, 7.3× (N = 20) and 12.7× (N = 40)
    /// faster than IPOPT (BENCHMARKS.md, `bench/envelope.py`).
    #[default]
    Direct,
}

impl Method {
    /// Every method, in the order the documentation lists them.
    pub const ALL: [Method; 2] = [Method::Scvx, Method::Direct];

    /// The method's name in a scenario file and in the JSON.
    pub fn as_str(self) -> &'static str {
        self.names().key
    }

    /// The method's row of [`METHOD_NAMES`].
    pub fn names(self) -> &'static MethodNames {
        &METHOD_NAMES[self as usize]
    }
}

/// What a method is called: in a scenario file and the JSON, and in the
/// reports and plots.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MethodNames {
    /// The name in a scenario file and in the JSON (`method = "direct"`).
    pub key: &'static str,
    /// The name in a report's or a plot's title.
    pub title: &'static str,
    /// What one of its iterations is called ("28 SCvx iterations").
    pub iteration: &'static str,
}

/// One row per method, in the order of the enum's variants (a test checks).
pub const METHOD_NAMES: [MethodNames; 2] = [
    MethodNames {
        key: "scvx",
        title: "SCvx",
        iteration: "SCvx",
    },
    MethodNames {
        key: "direct",
        title: "direct method",
        iteration: "interior-point",
    },
];

impl std::str::FromStr for Method {
    type Err = String;
    /// A method by its name ([`Method::as_str`]).
    fn from_str(s: &str) -> Result<Self, String> {
        Method::ALL
            .into_iter()
            .find(|m| m.as_str() == s)
            .ok_or_else(|| format!("unknown method {s:?}: expected \"scvx\" or \"direct\""))
    }
}

impl Formulation {
    /// Every formulation, in the order the documentation lists them.
    pub const ALL: [Formulation; 3] = [Formulation::Exact, Formulation::Paper, Formulation::Vector];

    /// The formulation's name in a scenario file and in the JSON.
    pub fn as_str(self) -> &'static str {
        match self {
            Formulation::Exact => "exact",
            Formulation::Paper => "paper",
            Formulation::Vector => "vector",
        }
    }
}

impl std::str::FromStr for Formulation {
    type Err = String;
    /// A formulation by its name ([`Formulation::as_str`]).
    fn from_str(s: &str) -> Result<Self, String> {
        Formulation::ALL
            .into_iter()
            .find(|f| f.as_str() == s)
            .ok_or_else(|| {
                format!("unknown formulation {s:?}: expected \"exact\", \"paper\" or \"vector\"")
            })
    }
}

/// How a scenario is solved (`[solver]`): the method, the formulation, the
/// landing tolerances and mesh refinement, which every method reads; SCvx's
/// own settings (Section 3.4, with the trust-region rule of Mao et al. 2016)
/// in place, for the scenario files' sake; the direct method's in
/// [`DirectSettings`] (`[solver.direct]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SolverSettings {
    /// The method: `scvx` (the paper's) or `direct`.
    pub method: Method,
    /// Settings of the direct method.
    pub direct: DirectSettings,
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
    /// Polish a solved collocation answer into controls that fly
    /// ([`crate::polish`]; the default). `false` (`--fast` on the command
    /// line) returns the raw collocation answer, which the landing check
    /// then judges as it is.
    pub polish: bool,
    /// Polishes on repaired arcs after the first, at most
    /// ([`crate::polish::repair`]): where the answer's switching function
    /// contradicts a thrust arc, a short arc of the other bound is seeded
    /// there and the polish runs again, while each gains mass. Default 3;
    /// 0 keeps the first structure (faster, kilograms heavier in fuel on
    /// some states: BENCHMARKS.md, issue 35).
    pub polish_repairs: usize,
    /// The polish's Newton mode ([`crate::polish`]): near the answer, its
    /// QPs take the Lagrangian's exact Hessian through the RK4 steps
    /// (made positive definite by its eigenvalues' magnitudes) beside the
    /// proximal term. Default false: on 46 seeded envelope states it ends
    /// a median 0.16 kg short of the fine reference instead of 0.30, at
    /// about twice the time (BENCHMARKS.md, issue 35).
    pub polish_hessian: bool,
    /// Largest re-integrated landing position error ‖(x, z)(t_f) − (x_f, z_f)‖
    /// of a `solved` answer \[m\] ([`crate::verify::accuracy`]); beyond it the status
    /// is `inaccurate`. Default 0.1 m: the polished answer lands within
    /// micrometres; a raw collocation answer (`polish = false`) at N = 20
    /// misses by 0.8 m on the paper's case and by metres elsewhere.
    pub landing_position_tolerance_m: f64,
    /// Largest re-integrated landing velocity error ‖(Vx, Vz)(t_f) − (Vx_f,
    /// Vz_f)‖ [m/s]. Default 0.05 m/s.
    pub landing_velocity_tolerance_mps: f64,
    /// hp mesh refinement (`[solver.refinement]`; off unless its tolerance
    /// is set).
    pub refinement: RefinementSettings,
}

impl Default for SolverSettings {
    fn default() -> Self {
        Self {
            method: Method::Direct,
            direct: DirectSettings::default(),
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
            polish: true,
            polish_repairs: 3,
            polish_hessian: false,
            landing_position_tolerance_m: 0.1,
            landing_velocity_tolerance_mps: 0.05,
            refinement: RefinementSettings::default(),
        }
    }
}

/// hp mesh refinement to a tolerance ([`crate::refine`]; `[solver.refinement]`
/// in a scenario, `--mesh-tolerance` on the command line).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RefinementSettings {
    /// The largest relative error e_k of any mesh interval that is accepted
    /// ([`crate::verify::mesh_error`]); 0 (the default) solves on the scenario's
    /// mesh alone.
    pub tolerance: f64,
    /// Passes, the first solve included.
    pub max_passes: usize,
    /// Points of a new interval when one is split (n_min of the ph rule).
    pub min_points: usize,
    /// Most points per interval before it is split (n_max).
    pub max_points: usize,
    /// Most collocation points of a refined mesh; refinement stops before a
    /// mesh with more.
    pub max_total_points: usize,
}

impl Default for RefinementSettings {
    fn default() -> Self {
        RefinementSettings {
            tolerance: 0.0,
            max_passes: 6,
            min_points: 4,
            max_points: 10,
            max_total_points: 80,
        }
    }
}

/// Settings of the direct method (`[solver.direct]` in a scenario).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DirectSettings {
    /// Convergence: the scaled optimality error E_0 (Eq. 5) below this.
    pub tolerance: f64,
    /// Iteration limit; past it the status is `not_converged`.
    pub max_iterations: usize,
    /// Initial barrier parameter μ_0.
    pub mu_init: f64,
    /// How μ falls: `monotone` (Fiacco–McCormick, IPOPT's default) or
    /// `adaptive` (Mehrotra's probing rule each iteration, with a fall-back
    /// to the monotone rule when the optimality error stops falling).
    pub mu_strategy: MuStrategy,
    /// Coarse-to-fine start: first solve on a global mesh of this many
    /// points from the straight line, then start the scenario's mesh from
    /// that answer, interpolated, at μ_0 = [`crate::method::direct::WARM_MU`]. Used when the
    /// scenario's N is at least twice as many; 0 always starts from the
    /// straight line. Default 10, measured on 18 dispersed states
    /// (BENCHMARKS.md "Direct method"): 2.7× → 3.4× faster than IPOPT at
    /// N = 20 and 3.0× → 6.1× at N = 40, and it reaches IPOPT's optimum on
    /// the two states of 150 where the straight line led to a worse one.
    pub coarse_nodes: usize,
    /// Tolerance of the coarse start's solve (its E_0, as `tolerance`). The
    /// coarse answer only places the fine solve near its optimum: converging
    /// it further is work that the fine mesh redoes (its μ restarts at
    /// [`crate::method::direct::WARM_MU`]). Default 1e-2 (BENCHMARKS.md "Direct method").
    pub coarse_tolerance: f64,
}

/// The barrier parameter update.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum MuStrategy {
    /// μ ← max(ε/10, min(κ_μ μ, μ^θ_μ)) once the barrier problem is solved
    /// to κ_ε μ (Wächter & Biegler 2006, Eq. 7).
    #[default]
    Monotone,
    /// μ = σ·(sᵀz/n) with σ = (μ_aff/(sᵀz/n))³ from an affine-scaling probe
    /// (Mehrotra 1992; Nocedal, Wächter & Waltz 2009), the filter reset as μ
    /// changes; monotone from the first iteration that fails to reduce the
    /// optimality error E_0 over [`crate::method::direct::ADAPTIVE_WINDOW`] iterations, or whose
    /// line search fails.
    Adaptive,
}

impl Default for DirectSettings {
    fn default() -> Self {
        DirectSettings {
            tolerance: 1e-8,
            max_iterations: 500,
            mu_init: 0.1,
            mu_strategy: MuStrategy::Monotone,
            coarse_nodes: 10,
            coarse_tolerance: 1e-2,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each method's row of the names table is its own: the key is what
    /// serde writes for it and what `FromStr` reads back.
    #[test]
    fn method_names_rows_follow_the_variants() {
        for m in Method::ALL {
            let json = serde_json::to_string(&m).unwrap();
            assert_eq!(json, format!("\"{}\"", m.names().key));
            assert_eq!(m.as_str().parse::<Method>(), Ok(m));
        }
        assert_eq!(Method::ALL.len(), METHOD_NAMES.len());
    }
}
