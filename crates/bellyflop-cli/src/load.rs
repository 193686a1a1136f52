//! Loading a scenario (and a closed-loop configuration) with the flags'
//! overrides, and validating it, before any work.

use std::path::PathBuf;

use bellyflop::guidance::SimConfig;
use bellyflop::sim::Dispersions;
use bellyflop::{Case, Formulation, Method};

use crate::args::{FormulationArg, MethodArg, SolveArgs};

/// The scenario file (the paper's case by default) with the flags' overrides.
pub fn case(args: &SolveArgs) -> Result<Case, bellyflop::InputError> {
    let mut case = match &args.scenario {
        Some(path) => Case::from_file(path)?,
        None => Case::paper(),
    };
    let d = &mut case.scenario.discretization;
    if args.nodes.is_some() || args.intervals.is_some() {
        // The flags ask for the uniform mesh of their counts, in place of
        // the file's explicit `[discretization.mesh]`.
        d.mesh = None;
    }
    if let Some(n) = args.nodes {
        d.nodes = n;
    }
    if let Some(m) = args.intervals {
        d.intervals = m;
    }
    if let Some(f) = args.formulation {
        case.solver.formulation = match f {
            FormulationArg::Exact => Formulation::Exact,
            FormulationArg::Paper => Formulation::Paper,
            FormulationArg::Vector => Formulation::Vector,
        };
    }
    if let Some(m) = args.method {
        case.solver.method = match m {
            MethodArg::Scvx => Method::Scvx,
            MethodArg::Direct => Method::Direct,
        };
    }
    if let Some(tol) = args.mesh_tolerance {
        case.solver.refinement.tolerance = tol;
    }
    case.validate()?;
    Ok(case)
}

/// The scenario file and the closed-loop configuration of `sim` and
/// `montecarlo` (the paper's case and the defaults when omitted), with the
/// flags' overrides.
pub fn closed_loop(
    scenario: &Option<PathBuf>,
    config: &Option<PathBuf>,
    open_loop: bool,
    no_dispersions: bool,
) -> Result<(Case, SimConfig), bellyflop::InputError> {
    let s = match scenario {
        Some(p) => Case::from_file(p)?,
        None => Case::paper(),
    };
    let mut c = match config {
        Some(p) => SimConfig::from_file(p)?,
        None => SimConfig::default(),
    };
    if open_loop {
        c.guidance.replan = false;
    }
    if no_dispersions {
        c.dispersions = Dispersions::none();
    }
    c.validate()?;
    Ok((s, c))
}
