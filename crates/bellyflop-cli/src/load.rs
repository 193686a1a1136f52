//! Loading a scenario (and a closed-loop configuration) with the flags'
//! overrides, and validating it, before any work.

use std::path::PathBuf;

use bellyflop::guidance::SimConfig;
use bellyflop::input::overrides::Overrides;
use bellyflop::sim::Dispersions;
use bellyflop::Case;

use crate::args::SolveArgs;

/// `solve`'s name in messages: the one command that solves a 6-DoF
/// scenario.
pub const SOLVE: &str = "`bellyflop solve`";

/// The scenario file (the paper's case by default) with the flags' overrides.
/// A 6-DoF scenario is refused ([`bellyflop::InputError::ModelUnavailable`],
/// naming `command`) unless `command` is `solve`'s, which solves it
/// ([`crate::solve_six_dof`]).
pub fn case(args: &SolveArgs, command: &str) -> Result<Case, bellyflop::InputError> {
    let case = match &args.scenario {
        Some(path) => Case::from_file(path)?,
        None => Case::paper(),
    };
    if command != SOLVE {
        case.scenario.require_planar(command)?;
    }
    warn(&case);
    Overrides {
        nodes: args.nodes,
        intervals: args.intervals,
        formulation: args.formulation,
        method: args.method,
        mesh_tolerance: args.mesh_tolerance,
        fast: args.fast,
    }
    .apply(case)
}

/// The scenario file and the closed-loop configuration of `sim` and
/// `montecarlo` (the paper's case and the defaults when omitted), with the
/// flags' overrides. A 6-DoF scenario is refused, naming `command`, as in
/// [`case`].
pub fn closed_loop(
    command: &str,
    scenario: &Option<PathBuf>,
    config: &Option<PathBuf>,
    open_loop: bool,
    no_dispersions: bool,
) -> Result<(Case, SimConfig), bellyflop::InputError> {
    let s = match scenario {
        Some(p) => Case::from_file(p)?,
        None => Case::paper(),
    };
    s.scenario.require_planar(command)?;
    warn(&s);
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

/// The scenario's warnings as the JSON's `warnings` list, only when there
/// are any: the library's, which Python's answers carry too.
pub use bellyflop::output::report::add_warnings;

/// The scenario's warnings (a guess clamped into its range), one
/// `warning: ...` line each on stderr, whatever `--quiet` says: the answer is
/// that of another file than the one given.
fn warn(case: &Case) {
    for w in &case.warnings {
        errln!("warning: {w}");
    }
}
