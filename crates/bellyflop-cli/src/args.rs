//! The flags that `solve` and `sweep` share: the scenario file and its
//! overrides.

use std::path::PathBuf;

use bellyflop::{Formulation, Method};
use clap::builder::{PossibleValuesParser, TypedValueParser};

use crate::landing;

/// `--method`'s parser: the library's names of its methods.
fn method_parser() -> impl TypedValueParser<Value = Method> {
    PossibleValuesParser::new(Method::ALL.map(Method::as_str))
        .map(|s| s.parse().expect("one of the possible values"))
}

/// `--formulation`'s parser: the library's names of its formulations.
pub fn formulation_parser() -> impl TypedValueParser<Value = Formulation> {
    PossibleValuesParser::new(Formulation::ALL.map(Formulation::as_str))
        .map(|s| s.parse().expect("one of the possible values"))
}

#[derive(clap::Args, Default)]
pub struct SolveArgs {
    /// Scenario TOML file; the paper's case when omitted.
    #[arg(long)]
    pub scenario: Option<PathBuf>,
    /// Number of LGR collocation points N (4 to 200; at most 100 on the global mesh); overrides the scenario
    /// (a `[discretization.mesh]` of the file gives way to the uniform mesh).
    #[arg(long)]
    pub nodes: Option<usize>,
    /// Number of LGR mesh intervals M (1 to N/2; 1 is the paper's global
    /// mesh); overrides the scenario (and its `[discretization.mesh]`, as
    /// `--nodes` does).
    #[arg(long)]
    pub intervals: Option<usize>,
    /// Thrust-direction formulation of SCvx; overrides the scenario. Planar
    /// only: a 6-DoF scenario refuses it.
    #[arg(long, value_parser = formulation_parser())]
    pub formulation: Option<Formulation>,
    /// Solution method: `scvx` (successive convexification, the paper's) or
    /// `direct` (interior point on the nonlinear program); overrides the
    /// scenario's `solver.method`.
    #[arg(long, value_parser = method_parser())]
    pub method: Option<Method>,
    /// Refine the mesh (hp, with breaks at the control switches) until every
    /// interval's relative error is at most TOL; overrides the scenario's
    /// `solver.refinement.tolerance` (0: no refinement). Planar only: a
    /// 6-DoF scenario refuses a tolerance other than 0.
    #[arg(long, value_name = "TOL")]
    pub mesh_tolerance: Option<f64>,
    /// The raw collocation answer, without the polish that makes its
    /// controls fly (`solver.polish = false`): faster, and at N = 20 it
    /// misses the pad by metres on much of the envelope, so the default
    /// landing tolerances call it `inaccurate` there.
    #[arg(long)]
    pub fast: bool,
    /// Print one JSON object on stdout instead of a summary.
    #[arg(long)]
    pub json: bool,
    /// Do not print per-iteration progress on stderr.
    #[arg(long)]
    pub quiet: bool,
    /// Interpolation of the controls when re-propagating for the landing
    /// error: `pchip` (the default) or `linear`. Planar only: a 6-DoF
    /// scenario refuses it.
    #[arg(long, value_enum)]
    pub interpolation: Option<landing::InterpolationArg>,
    /// Write trajectory.csv, solution.json, the plots (SVG and PNG) and
    /// viewer.html (the solve, to play in a browser) into DIR; for a 6-DoF
    /// scenario, solution.json, trajectory.csv and its plots (path and
    /// histories; no viewer yet).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Solve R times in this process and report the median solve time (and
    /// its minimum and maximum), as the IPOPT reference's `--repeat` does;
    /// the solution is the last run's (every run gives the same one).
    #[arg(long, value_name = "R", default_value_t = 1,
          value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub repeat: u32,
}
