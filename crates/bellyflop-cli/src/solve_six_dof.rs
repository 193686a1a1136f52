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

use std::convert::Infallible;
use std::path::Path;
use std::process::ExitCode;

use bellyflop::input::settings::Method;
use bellyflop::method::observer::Silent;
use bellyflop::pipeline::six_dof::{solve, SixDofSolution};
use bellyflop::problem::six_dof::start_state;
use bellyflop::{Scenario, SolverSettings};

use crate::args::SolveArgs;
use crate::error::OutputError;
use crate::{exit, files, load, output, plot, repeat};

/// Solve the 6-DoF `scenario` (module docs); the exit code is the status's.
pub fn run(
    args: &SolveArgs,
    scenario: &Scenario,
    settings: &SolverSettings,
    warnings: &[String],
) -> ExitCode {
    if settings.method != Method::Direct {
        errln!(
            "error: solver.method = \"{}\" solves only the planar model; a 6-DoF scenario is solved by the direct method (solver.method = \"direct\", the default)",
            settings.method.as_str()
        );
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
