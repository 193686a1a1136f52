//! `bellyflop solve` on a 6-DoF scenario (`model = "6dof"`, issue 38): the
//! library's 6-DoF pipeline (the direct method's cold solve, the 6-DoF
//! polish, the flown check), its summary or JSON, and with `--out` its
//! `solution.json`, `trajectory.csv` (the node table, columns named by
//! the model) and the plots `path` and `histories` as SVG and PNG
//! ([`crate::plot::six_dof`]: the path in the x–z, y–z and top views, and
//! the thrust, gimbal, attitude, body-rate, mass and speed histories). The
//! convergence plot and the viewer are planar only for now. `--repeat R`
//! solves R times and reports the median solve time, as for a planar
//! scenario ([`crate::repeat`]).
//!
//! `--nodes`, `--intervals`, `--fast`, `--repeat`, `--json`, `--quiet` and
//! `--out` apply as to a planar scenario; `--method direct` and
//! `--mesh-tolerance 0` say what it does. The flags that would be ignored
//! are refused, naming the flag, its value and why (exit 2), as the Python
//! binding refuses the same arguments: another `--method`, any
//! `--formulation` or `--interpolation`, another `--mesh-tolerance`. So
//! are the scenario's settings that the 6-DoF solve does not read, at a
//! value other than their default
//! ([`bellyflop::pipeline::six_dof::check_settings`]).

use std::convert::Infallible;
use std::path::Path;
use std::process::ExitCode;

use bellyflop::collocation::interpolation::Interpolation;
use bellyflop::input::settings::Method;
use bellyflop::method::observer::Silent;
use bellyflop::pipeline::six_dof::settings::{
    DIRECT_ONLY, NO_FORMULATION, NO_INTERPOLATION, NO_REFINEMENT,
};
use bellyflop::pipeline::six_dof::{check_settings, solve, SixDofSolution};
use bellyflop::problem::six_dof::start_state;
use bellyflop::{InputError, Scenario, SolverSettings};

use crate::args::SolveArgs;
use crate::error::OutputError;
use crate::{exit, files, load, output, plot, repeat};

/// Solve the 6-DoF `scenario` (module docs); the exit code is the status's.
/// `settings` are the scenario's with the flags' overrides.
pub fn run(
    args: &SolveArgs,
    scenario: &Scenario,
    settings: &SolverSettings,
    warnings: &[String],
) -> ExitCode {
    if let Err(e) = check_flags(args).and_then(|()| check_settings(settings)) {
        errln!("error: {e}");
        return ExitCode::from(exit::BAD_INPUT);
    }
    if let Err(code) = output::prepare_or_exit(&args.out) {
        return code;
    }
    let quiet = args.quiet || args.json;
    if !quiet {
        errln!(
            "solving the 6-DoF problem at N = {} (direct method{})",
            scenario.discretization.nodes,
            if settings.polish {
                ", then the 6-DoF polish"
            } else {
                ""
            }
        );
    }
    let x0 = start_state(&scenario.initial);
    let (mut sol, times_ms) = match repeat::repeated(
        args.repeat,
        |_| Ok::<_, Infallible>(solve(scenario, x0, settings, &mut Silent)),
        |s| (s.status, s.final_mass_kg, s.solve_time_ms),
    ) {
        Ok(solved) => solved,
        Err(never) => match never {},
    };
    sol.solve_time_ms = repeat::median(&times_ms);
    let mut v = sol.to_json();
    repeat::add_json(&mut v, args.repeat, &times_ms);
    load::add_warnings(&mut v, warnings);
    if args.json {
        outln!("{v}");
    } else {
        print_summary(&sol, &times_ms);
    }
    if let Some(dir) = &args.out {
        let written = write(dir, scenario, &sol, &v);
        if let Err(code) = output::report(dir, written, quiet) {
            return code;
        }
    }
    ExitCode::from(sol.status.exit_code() as u8)
}

/// `Err` naming the first flag that the 6-DoF solve would ignore (module
/// docs), with the library's reasons: the Python binding refuses the same
/// arguments, in the same order, for the same reasons.
fn check_flags(args: &SolveArgs) -> Result<(), InputError> {
    let refuse = |field: &str, value: &str, why: &str, hint: &str| {
        Err(InputError::NotApplicable {
            field: field.into(),
            value: value.into(),
            reason: format!("{why} ({hint})"),
        })
    };
    if let Some(m) = args.method.filter(|m| *m != Method::Direct) {
        let hint = "--method direct, or leave it out";
        return refuse("--method", m.as_str(), DIRECT_ONLY, hint);
    }
    if let Some(f) = args.formulation {
        return refuse("--formulation", f.as_str(), NO_FORMULATION, "leave it out");
    }
    if let Some(i) = args.interpolation {
        let name = Interpolation::from(i).as_str();
        return refuse("--interpolation", name, NO_INTERPOLATION, "leave it out");
    }
    if let Some(t) = args.mesh_tolerance.filter(|t| *t != 0.0) {
        let hint = "leave it out, or 0";
        return refuse("--mesh-tolerance", &format!("{t:?}"), NO_REFINEMENT, hint);
    }
    Ok(())
}

/// `solution.json`, `trajectory.csv` and the plots into `dir`.
fn write(
    dir: &Path,
    scenario: &Scenario,
    sol: &SixDofSolution,
    json: &serde_json::Value,
) -> Result<Vec<std::path::PathBuf>, OutputError> {
    output::prepare(dir)?;
    let json_path = dir.join("solution.json");
    files::write_file(&json_path, format!("{json}\n"))?;
    let csv_path = dir.join("trajectory.csv");
    files::write_file(&csv_path, sol.to_csv())?;
    let mut written = vec![json_path, csv_path];
    let data = plot::six_dof::SixDofPlot::new(scenario, sol);
    written.extend(plot::six_dof::render_all(dir, &data)?);
    Ok(written)
}

/// The human summary on stdout; `times_ms` are the sorted solve times of
/// `--repeat`.
fn print_summary(sol: &SixDofSolution, times_ms: &[f64]) {
    outln!("model:          6dof");
    outln!("status:         {}", sol.status.as_str());
    if !sol.message.is_empty() {
        outln!("message:        {}", sol.message);
    }
    outln!("t_f:            {:.4} s", sol.tf_s);
    outln!(
        "final mass:     {:.3} kg (fuel {:.3} kg)",
        sol.final_mass_kg,
        sol.fuel_kg
    );
    match sol.polish_iterations {
        Some(p) => outln!("iterations:     {} (direct), {p} (polish)", sol.iterations),
        None => outln!("iterations:     {} (direct)", sol.iterations),
    }
    outln!(
        "solve time:     {}",
        repeat::time_text(sol.solve_time_ms, times_ms)
    );
    if let Some(f) = &sol.flown {
        let which = if sol.controls_flown.is_some() {
            "polished"
        } else {
            "raw"
        };
        outln!(
            "flown ({which}):  lands {:.2e} m, {:.2e} m/s from the target; lowest {:.4} m above the pad before t_f",
            f.landing_miss_m,
            f.landing_miss_mps,
            f.lowest_altitude_m
        );
        outln!(
            "                nozzle ≤ {:.3}°, its rate ≤ {:.3}°/s, thrust {:.0}–{:.0} N",
            f.max_gimbal_deg,
            f.max_gimbal_rate_degps,
            f.thrust_range_n.0,
            f.thrust_range_n.1
        );
    }
}
