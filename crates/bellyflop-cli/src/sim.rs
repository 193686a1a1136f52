//! `bellyflop sim`: one closed-loop landing with dispersions.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use bellyflop::guidance::{end_state, Flight, ReplanOutcome};
use bellyflop::sim::{Outcome, RunOutcome};
use bellyflop::Case;
use serde_json::Value;

use crate::error::OutputError;
use crate::sample::Dense;
use crate::{exit, files, load, output, plot};

#[derive(clap::Args, Default)]
pub struct SimArgs {
    /// Scenario TOML file; the paper's case when omitted.
    #[arg(long)]
    scenario: Option<PathBuf>,
    /// Closed-loop configuration TOML ([dispersions], [guidance], [plant],
    /// [touchdown]);
    /// every field defaults (see `bellyflop::guidance::SimConfig`).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Campaign seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Run index within the campaign (the same draw as that run of
    /// `montecarlo` with the same seed).
    #[arg(long, default_value_t = 0)]
    run: u64,
    /// Fly the first plan without re-planning.
    #[arg(long)]
    open_loop: bool,
    /// Switch every dispersion off (nominal vehicle, no wind, exact navigation).
    #[arg(long)]
    no_dispersions: bool,
    /// Print one JSON object on stdout instead of a summary.
    #[arg(long)]
    json: bool,
    /// Write the plan's files and plots (as `solve --out`) with the flown
    /// trajectory overlaid, plus flight.csv, replans.csv, flight.json, the
    /// re-plan timeline plot and viewer.html (the flight, to play in a
    /// browser), into DIR.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

pub fn run(args: &SimArgs) -> ExitCode {
    let (scenario, config) = match load::closed_loop(
        "`bellyflop sim`",
        &args.scenario,
        &args.config,
        args.open_loop,
        args.no_dispersions,
    ) {
        Ok(v) => v,
        Err(e) => {
            errln!("error: {e}");
            return ExitCode::from(exit::BAD_INPUT);
        }
    };
    if let Err(code) = output::prepare_or_exit(&args.out) {
        return code;
    }
    let flight = match config.fly(&scenario, args.seed, args.run, args.out.is_some()) {
        Ok(f) => f,
        Err(e) => {
            errln!("error: {e}");
            return ExitCode::from(exit::BAD_INPUT);
        }
    };
    let outcome = config.outcome(&flight);
    let mut v = flight_json(&flight, outcome, args.seed, args.run, &config);
    load::add_warnings(&mut v, &scenario.warnings);
    if args.json {
        outln!("{v}");
    } else {
        print_summary(&flight, outcome, args.seed, args.run);
    }
    if let Some(dir) = &args.out {
        if let Err(code) = output::report(dir, write(dir, &scenario, &flight, &v), args.json) {
            return code;
        }
    }
    ExitCode::from(exit_code(outcome))
}

/// The exit code of `sim`: 0 landed or hard landing, [`exit::CRASH`] on a
/// crash, [`exit::NO_TOUCHDOWN`] without a touchdown.
pub fn exit_code(o: RunOutcome) -> u8 {
    match o {
        RunOutcome::Landed | RunOutcome::HardLanding => 0,
        RunOutcome::Crash => exit::CRASH,
        RunOutcome::PropellantExhausted | RunOutcome::TimeLimit | RunOutcome::NonFinite => {
            exit::NO_TOUCHDOWN
        }
    }
}

fn print_summary(f: &Flight, outcome: RunOutcome, seed: u64, run: u64) {
    outln!("run           seed {seed}, run {run}");
    outln!(
        "first plan    {}{}, t_f {:.3} s, {} iterations",
        f.first_plan.status.as_str(),
        if f.first_plan_nominal {
            " (nominal scenario's: the dispersed one did not solve)"
        } else {
            ""
        },
        f.first_plan.tf_s,
        f.first_plan.iterations
    );
    outln!("outcome       {}", outcome.as_str());
    if let Outcome::Touchdown(td) = &f.outcome {
        outln!("touchdown     t = {:.3} s", td.time_s);
        outln!("  position    {:+.3} m", td.x_error_m);
        outln!(
            "  velocity    vertical {:+.3} m/s, horizontal {:+.3} m/s (speed {:.3} m/s)",
            td.vertical_velocity_mps,
            td.horizontal_velocity_mps,
            td.speed_mps
        );
        outln!(
            "  attitude    pitch {:+.3} deg, pitch rate {:+.3} deg/s",
            td.pitch_error_deg,
            td.pitch_rate_degps
        );
        outln!("  propellant  {:.1} kg left", td.propellant_left_kg);
    } else {
        let s = end_state(&f.outcome);
        outln!("  ended at    x {:.2} m, z {:.2} m", s.x_m, s.z_m);
    }
    outln!("fuel          {:.1} kg", f.fuel_kg());
    let times: Vec<f64> = f.replans.iter().map(|r| r.solve_ms).collect();
    let max = times.iter().copied().fold(0.0, f64::max);
    outln!(
        "re-plans      {} ({} solved, {} flown unconverged at the budget, {} failed, {} missed the deadline), slowest {:.1} ms ({} slower than the period)",
        f.replans.len(),
        f.count(ReplanOutcome::Accepted),
        f.count(ReplanOutcome::Usable),
        f.count(ReplanOutcome::Failed),
        f.count(ReplanOutcome::Missed),
        max,
        f.replans.iter().filter(|r| r.late).count()
    );
    for r in &f.replans {
        if matches!(r.outcome, ReplanOutcome::Failed | ReplanOutcome::Missed) {
            outln!(
                "  t = {:6.2} s  {:?}: {} after {} iterations, {:.1} ms. {}",
                r.time_s,
                r.outcome,
                r.status,
                r.iterations,
                r.solve_ms,
                r.reason
            );
        }
    }
}

pub use bellyflop::output::report::flight_json;

/// The flown trajectory in the columns of `trajectory.csv`: the flight
/// trace's columns ([`bellyflop::output::report::trace_columns`]) without the wind.
fn flown(f: &Flight) -> Dense {
    let [t, x, z, vx, vz, theta, w, m, delta, thrust, chi, _wind] =
        bellyflop::output::report::trace_columns(f);
    Dense::from_columns([t, x, z, vx, vz, theta, w, m, delta, thrust, chi])
}

fn write(
    dir: &std::path::Path,
    case: &Case,
    f: &Flight,
    v: &Value,
) -> Result<Vec<PathBuf>, OutputError> {
    let flown = flown(f);
    // The first plan as `solve --out` writes it, with the flight overlaid.
    let plan_json = f.first_plan.to_json();
    let mut files = output::write_all(
        dir,
        &case.scenario,
        &case.solver,
        &f.first_plan,
        &plan_json,
        Some(&flown),
    )?;

    let csv = bellyflop::output::report::trace_csv(f);
    let path = dir.join("flight.csv");
    files::write_file(&path, csv)?;
    files.push(path);

    let mut csv = String::from(
        "time_s,solve_ms,iterations,status,max_defect,virtual_control,wind_estimate_mps,outcome\n",
    );
    for r in &f.replans {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{}",
            r.time_s,
            r.solve_ms,
            r.iterations,
            r.status.as_str(),
            r.max_defect,
            r.virtual_control,
            r.wind_estimate_mps,
            serde_json::to_value(r.outcome)
                .unwrap_or_default()
                .as_str()
                .unwrap_or("")
        );
    }
    let path = dir.join("replans.csv");
    files::write_file(&path, csv)?;
    files.push(path);

    let path = dir.join("flight.json");
    files::write_file(&path, format!("{v}\n"))?;
    files.push(path);

    files.extend(plot::timeline(dir, f)?);
    let data = bellyflop::output::viewer::flight_data(&case.scenario, f, v);
    files.push(output::write_viewer(dir, &data)?);
    Ok(files)
}
