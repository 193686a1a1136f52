//! `bellyflop sweep`: solve one scenario at several N and tabulate t_f, final
//! mass, landing precision, iterations and solve time (the paper's Tables 3–5).

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use bellyflop::method::observer::Silent;
use bellyflop::Status;
use serde_json::{json, Value};

use crate::args::{formulation_parser, SolveArgs};
use crate::landing::{self, InterpolationArg};
use crate::{exit, load};

#[derive(clap::Args)]
pub struct SweepArgs {
    /// Numbers of LGR collocation points N, comma-separated (each 4 to 100).
    #[arg(long, value_delimiter = ',', default_value = "15,20,30,40")]
    nodes: Vec<usize>,
    /// Scenario TOML file; the paper's case when omitted.
    #[arg(long)]
    scenario: Option<PathBuf>,
    /// Thrust-direction formulation; overrides the scenario.
    #[arg(long, value_parser = formulation_parser())]
    formulation: Option<bellyflop::Formulation>,
    /// Interpolation of the controls for the landing-precision re-propagation.
    #[arg(long, value_enum, default_value = "pchip")]
    interpolation: InterpolationArg,
    /// Print one JSON object on stdout instead of a table.
    #[arg(long)]
    json: bool,
}

/// Solve at every N. Exits 0 when every N solved, else with the exit code of
/// the first N that did not (2 for bad input, before anything is solved).
pub fn run(args: &SweepArgs) -> ExitCode {
    // Each N goes through the same loading and validation as `solve`.
    let mut scenarios = Vec::with_capacity(args.nodes.len());
    for &n in &args.nodes {
        let solve_args = SolveArgs {
            scenario: args.scenario.clone(),
            nodes: Some(n),
            formulation: args.formulation,
            ..SolveArgs::default()
        };
        match load::case(&solve_args, "`bellyflop sweep`") {
            Ok(s) => scenarios.push(s),
            Err(e) => {
                errln!("error: {e}");
                return ExitCode::from(exit::BAD_INPUT);
            }
        }
    }
    let Some(base) = scenarios.first() else {
        errln!("error: --nodes needs at least one N");
        return ExitCode::from(exit::BAD_INPUT);
    };

    if !args.json {
        outln!(
            "scenario {}, {:?} formulation, landing error by DOP853 re-propagation with {} controls",
            base.scenario.name,
            base.solver.formulation,
            bellyflop::collocation::interpolation::Interpolation::from(args.interpolation).as_str()
        );
        outln!(
            "{:>4}  {:<13} {:>9} {:>11} {:>9} {:>10} {:>10} {:>11} {:>6} {:>9}",
            "N",
            "status",
            "t_f [s]",
            "m_f [kg]",
            "pos [m]",
            "vel [m/s]",
            "pitch [°]",
            "rate [°/s]",
            "iter",
            "time [ms]"
        );
    }
    let mut runs = Vec::with_capacity(scenarios.len());
    let mut exit = 0u8;
    for s in &scenarios {
        let sol = match s.solve(&mut Silent) {
            Ok(sol) => sol,
            Err(e) => {
                errln!("error: {e}");
                return ExitCode::from(exit::BAD_INPUT);
            }
        };
        let prop = landing::propagate(&s.scenario, &sol, args.interpolation);
        if sol.status != Status::Solved && exit == 0 {
            exit = sol.status.exit_code() as u8;
        }
        if args.json {
            runs.push(json!({
                "nodes": sol.nodes,
                "status": sol.status.as_str(),
                "message": sol.message,
                "tf_s": sol.tf_s,
                "final_mass_kg": sol.final_mass_kg,
                "fuel_kg": sol.fuel_kg,
                "iterations": sol.iterations,
                "solve_time_ms": sol.solve_time_ms,
                "landing_error": landing::landing_error_json(&prop),
                "propagation": landing::propagation_json(&prop),
            }));
        } else {
            let cell = |f: &dyn Fn(&bellyflop::verify::propagate::LandingError) -> f64| match &prop
            {
                Ok(p) => format!("{:.4}", f(&p.landing_error)),
                Err(_) => "-".into(),
            };
            outln!(
                "{:>4}  {:<13} {:>9.4} {:>11.1} {:>9} {:>10} {:>10} {:>11} {:>6} {:>9.1}",
                sol.nodes,
                sol.status.as_str(),
                sol.tf_s,
                sol.final_mass_kg,
                cell(&|e| e.position_m),
                cell(&|e| e.velocity_mps),
                cell(&|e| e.pitch_rad.to_degrees()),
                cell(&|e| e.rate_radps.to_degrees()),
                sol.iterations,
                sol.solve_time_ms
            );
            if let Err(e) = &prop {
                outln!("      landing error unavailable: {e}");
            }
            let _ = std::io::stdout().flush();
        }
    }
    if args.json {
        let out: Value = json!({
            "scenario": base.scenario.name,
            "formulation": base.solver.formulation,
            "interpolation": bellyflop::collocation::interpolation::Interpolation::from(args.interpolation),
            "runs": runs,
        });
        outln!("{out}");
    }
    ExitCode::from(exit)
}
