//! `bellyflop montecarlo`: many dispersed closed-loop landings in parallel.
//!
//! Each run is `sim` with its own run index: the draw depends only on
//! (seed, run index), and the rows are written in run order, so the same seed
//! gives the same results whatever the thread count: re-plan deadlines are
//! iteration budgets, not clock readings (re-plans slower than the period on
//! the clock are counted as `late` but do not change the flight).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use bellyflop::output::campaign::{fly_row, runs_csv, summary, RunRow};
use bellyflop::sim::{RunOutcome, TouchdownLimits};
use bellyflop::Case;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde_json::Value;

use crate::error::OutputError;
use crate::{exit, load, output, plot};

#[derive(clap::Args)]
pub struct MonteCarloArgs {
    /// Number of landings.
    #[arg(long, default_value_t = 100)]
    runs: u64,
    /// Campaign seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Worker threads (0: one per core).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Scenario TOML file; the paper's case when omitted.
    #[arg(long)]
    scenario: Option<PathBuf>,
    /// Closed-loop configuration TOML ([dispersions], [guidance], [plant],
    /// [touchdown]).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Fly every first plan without re-planning.
    #[arg(long)]
    open_loop: bool,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    json: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Write runs.csv, summary.json, the plots (touchdown scatter,
    /// re-plan time histogram) and viewer.html (the scatter to click
    /// through, with the command that flies a run again) into DIR.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

pub fn run(args: &MonteCarloArgs) -> ExitCode {
    let (scenario, config) =
        match load::closed_loop(&args.scenario, &args.config, args.open_loop, false) {
            Ok(v) => v,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(exit::BAD_INPUT);
            }
        };
    if args.runs == 0 || args.runs > 1_000_000 {
        eprintln!(
            "error: --runs = {} is out of range: allowed 1 to 1000000",
            args.runs
        );
        return ExitCode::from(exit::BAD_INPUT);
    }
    if let Err(code) = output::prepare_or_exit(&args.out) {
        return code;
    }
    let pool = match rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()
    {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: --threads {}: {e}", args.threads);
            return ExitCode::from(exit::BAD_INPUT);
        }
    };
    let threads = pool.current_num_threads();
    let bar = if args.quiet || args.json {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(args.runs)
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} landings (eta {eta})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let start = Instant::now();
    let rows: Result<Vec<RunRow>, bellyflop::InputError> = pool.install(|| {
        (0..args.runs)
            .into_par_iter()
            .map(|k| {
                let row = fly_row(&scenario, &config, args.seed, k)?;
                bar.inc(1);
                Ok(row)
            })
            .collect()
    });
    bar.finish_and_clear();
    let rows = match rows {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(exit::BAD_INPUT);
        }
    };
    let wall_s = start.elapsed().as_secs_f64();
    let mut s = summary(
        &rows,
        &config.touchdown,
        args.seed,
        threads,
        wall_s,
        args.open_loop,
    );
    load::add_warnings(&mut s, &scenario.warnings);
    if args.json {
        println!("{s}");
    } else {
        print_summary(&s);
    }
    if let Some(dir) = &args.out {
        let sim = sim_command(args);
        let limits = &config.touchdown;
        if let Err(code) = output::report(
            dir,
            write(dir, &rows, &s, &scenario, limits, &sim),
            args.json,
        ) {
            return code;
        }
    }
    ExitCode::SUCCESS
}

fn print_summary(s: &Value) {
    let f = |v: &Value| v.as_f64().map_or("-".to_string(), |x| format!("{x:.3}"));
    println!(
        "campaign      {} runs, seed {}, {} threads, {}, {:.1} s",
        s["runs"],
        s["seed"],
        s["threads"],
        if s["replanning"].as_bool() == Some(true) {
            "re-planning"
        } else {
            "open loop (first plan only)"
        },
        s["wall_time_s"].as_f64().unwrap_or(0.0)
    );
    let spec = &s["spec"];
    println!(
        "touchdowns    {} of {} ({} failures); within spec (|x| <= {} m, speed <= {} m/s, |pitch| <= {} deg): {} ({:.1} %)",
        s["runs"].as_u64().unwrap_or(0) - s["failures"].as_u64().unwrap_or(0),
        s["runs"],
        s["failures"],
        spec["position_m"],
        spec["speed_mps"],
        spec["pitch_deg"],
        s["in_spec"],
        100.0 * s["in_spec_fraction"].as_f64().unwrap_or(0.0)
    );
    let outcomes: Vec<String> = RunOutcome::ALL
        .iter()
        .map(|o| format!("{} {}", o.as_str(), s["outcomes"][o.as_str()]))
        .collect();
    println!("outcomes      {}", outcomes.join(", "));
    println!(
        "re-plans      {} ({} failed, {} missed the deadline (iteration budget), {} flown unconverged at the budget, {} slower than the period on the clock)",
        s["replans"], s["failed_replans"], s["missed_replans"], s["usable_replans"], s["late_replans"]
    );
    println!("                              p50        p95        p99        max");
    for (key, label) in [
        ("touchdown_position_m", "position error [m]"),
        ("touchdown_speed_mps", "speed [m/s]"),
        ("touchdown_vertical_speed_mps", "  vertical [m/s]"),
        ("touchdown_horizontal_speed_mps", "  horizontal [m/s]"),
        ("touchdown_pitch_deg", "pitch error [deg]"),
        ("fuel_kg", "fuel [kg]"),
        ("replan_time_ms", "re-plan time [ms]"),
    ] {
        let p = &s[key];
        println!(
            "{label:<26}{:>10} {:>10} {:>10} {:>10}",
            f(&p["p50"]),
            f(&p["p95"]),
            f(&p["p99"]),
            f(&p["max"])
        );
    }
    let w = &s["worst"];
    println!(
        "worst run     {}: {}, x {} m, speed {} m/s, pitch {} deg",
        w["run"],
        w["outcome"].as_str().unwrap_or("-"),
        f(&w["x_error_m"]),
        f(&w["speed_mps"]),
        f(&w["pitch_error_deg"])
    );
}

/// A path as one shell word: as is when it holds only safe characters,
/// else in single quotes.
fn shell_word(p: &std::path::Path) -> String {
    let s = p.display().to_string();
    let safe = |c: char| c.is_ascii_alphanumeric() || "/._-+=:,".contains(c);
    if !s.is_empty() && s.chars().all(safe) {
        s
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// The `bellyflop sim` command that flies a run of this campaign again,
/// without its `--run K` (the viewer adds it).
fn sim_command(args: &MonteCarloArgs) -> String {
    let mut cmd = String::from("bellyflop sim");
    if let Some(p) = &args.scenario {
        cmd.push_str(&format!(" --scenario {}", shell_word(p)));
    }
    if let Some(p) = &args.config {
        cmd.push_str(&format!(" --config {}", shell_word(p)));
    }
    cmd.push_str(&format!(" --seed {}", args.seed));
    if args.open_loop {
        cmd.push_str(" --open-loop");
    }
    cmd
}

fn write(
    dir: &std::path::Path,
    rows: &[RunRow],
    s: &Value,
    case: &Case,
    limits: &TouchdownLimits,
    sim: &str,
) -> Result<Vec<PathBuf>, OutputError> {
    let mut files = Vec::new();
    let csv = runs_csv(rows);
    let path = dir.join("runs.csv");
    std::fs::write(&path, csv).map_err(|e| OutputError::io(&path, e))?;
    files.push(path);
    let path = dir.join("summary.json");
    std::fs::write(&path, format!("{s}\n")).map_err(|e| OutputError::io(&path, e))?;
    files.push(path);
    files.extend(plot::campaign(dir, rows, &case.scenario.name)?);
    let data = bellyflop::output::viewer::campaign_data(rows, s, limits, sim);
    files.push(output::write_viewer(dir, &data)?);
    Ok(files)
}
