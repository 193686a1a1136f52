//! `bellyflop montecarlo`: many dispersed closed-loop landings in parallel.
//!
//! Each run is `sim` with its own run index: the draw depends only on
//! (seed, run index), and the rows are written in run order, so the same seed
//! gives the same results whatever the thread count: re-plan deadlines are
//! iteration budgets, not clock readings (re-plans slower than the period on
//! the clock are counted as `late` but do not change the flight).
//!
//! Every run is accounted for (`bellyflop::output::campaign::account`):
//! each index in 0..runs comes back exactly once, or the command says which
//! did not. Ctrl-C (SIGINT) stops starting runs: the runs that finished are
//! summarized and written (`summary.json` says `"partial": true`) and the
//! command exits 130; a second Ctrl-C ends it at once.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use bellyflop::guidance::SimConfig;
use bellyflop::input::validate::{RUNS, THREADS};
use bellyflop::output::campaign::{account, fly_row, runs_csv, summary, RunRow};
use bellyflop::sim::{RunOutcome, TouchdownLimits};
use bellyflop::Case;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde_json::Value;

use crate::error::OutputError;
use crate::{exit, files, load, output, plot};

#[derive(clap::Args)]
pub struct MonteCarloArgs {
    /// Number of landings.
    #[arg(long, default_value_t = 100)]
    runs: u64,
    /// Campaign seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Worker threads (0: one per core); at most one per run is started.
    #[arg(long, default_value_t = 0)]
    threads: u64,
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

/// Set by SIGINT while a campaign flies.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

extern "C" fn on_sigint(_: libc::c_int) {
    INTERRUPTED.store(true, Ordering::SeqCst);
    // A second Ctrl-C ends the process at once. SAFETY: signal(2) is
    // async-signal-safe.
    unsafe {
        libc::signal(libc::SIGINT, libc::SIG_DFL);
    }
}

/// From here on, SIGINT sets [`INTERRUPTED`] instead of ending the process.
fn catch_sigint() {
    let handler: extern "C" fn(libc::c_int) = on_sigint;
    // SAFETY: the handler only stores to an atomic and calls signal(2),
    // both async-signal-safe.
    unsafe {
        libc::signal(libc::SIGINT, handler as libc::sighandler_t);
    }
}

/// The threads to start for `runs` runs when `asked` (0: one per core):
/// never more than the runs, and a warning when more than the cores.
fn thread_count(asked: u64, runs: u64) -> (usize, Option<String>) {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get()) as u64;
    let want = if asked == 0 { cores } else { asked };
    let warning = (asked > cores).then(|| {
        format!(
            "--threads {asked} is more than this machine's {cores} cores: the runs share them, which only adds overhead"
        )
    });
    (want.min(runs).max(1) as usize, warning)
}

/// A count argument outside its range (from `bellyflop::input::validate`).
fn check_count(flag: &str, value: u64, (lo, hi): (u64, u64)) -> Result<(), String> {
    if (lo..=hi).contains(&value) {
        Ok(())
    } else {
        Err(format!(
            "{flag} = {value} is out of range: allowed {lo} to {hi}"
        ))
    }
}

pub fn run(args: &MonteCarloArgs) -> ExitCode {
    let (scenario, config) = match load::closed_loop(
        "`bellyflop montecarlo`",
        &args.scenario,
        &args.config,
        args.open_loop,
        false,
    ) {
        Ok(v) => v,
        Err(e) => {
            errln!("error: {e}");
            return ExitCode::from(exit::BAD_INPUT);
        }
    };
    let counts = check_count("--runs", args.runs, RUNS)
        .and_then(|()| check_count("--threads", args.threads, THREADS));
    if let Err(e) = counts {
        errln!("error: {e}");
        return ExitCode::from(exit::BAD_INPUT);
    }
    if let Err(code) = output::prepare_or_exit(&args.out) {
        return code;
    }
    let (threads, warning) = thread_count(args.threads, args.runs);
    if let Some(w) = warning {
        errln!("warning: {w}");
    }
    let pool = match rayon::ThreadPoolBuilder::new().num_threads(threads).build() {
        Ok(p) => p,
        Err(e) => {
            errln!("error: --threads {}: {e}", args.threads);
            return ExitCode::from(exit::BAD_INPUT);
        }
    };
    let start = Instant::now();
    let (rows, interrupted) = match fly_all(args, &scenario, &config, &pool) {
        Ok(v) => v,
        Err(code) => return code,
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
    if interrupted {
        s["partial"] = true.into();
        s["requested_runs"] = args.runs.into();
    }
    load::add_warnings(&mut s, &scenario.warnings);
    if args.json {
        outln!("{s}");
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
    if interrupted {
        errln!(
            "interrupted: {} of {} runs finished{}",
            rows.len(),
            args.runs,
            if args.out.is_some() {
                " and were written (summary.json: \"partial\": true)"
            } else {
                ""
            }
        );
        return ExitCode::from(exit::INTERRUPTED);
    }
    ExitCode::SUCCESS
}

/// Fly every run on `pool` with a progress bar: one row per run in run
/// order, accounted for (`bellyflop::output::campaign::account`), and
/// whether Ctrl-C stopped the campaign (then the rows are those that
/// finished). On an error, print it and return the exit code.
fn fly_all(
    args: &MonteCarloArgs,
    scenario: &Case,
    config: &SimConfig,
    pool: &rayon::ThreadPool,
) -> Result<(Vec<RunRow>, bool), ExitCode> {
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
    catch_sigint();
    let rows: Result<Vec<Option<RunRow>>, bellyflop::InputError> = pool.install(|| {
        (0..args.runs)
            .into_par_iter()
            .map(|k| {
                // After Ctrl-C, no run starts; those in flight finish.
                if INTERRUPTED.load(Ordering::SeqCst) {
                    return Ok(None);
                }
                let row = fly_row(scenario, config, args.seed, k)?;
                bar.inc(1);
                Ok(Some(row))
            })
            .collect()
    });
    bar.finish_and_clear();
    let interrupted = INTERRUPTED.load(Ordering::SeqCst);
    let rows = rows.map_err(|e| {
        errln!("error: {e}");
        ExitCode::from(exit::BAD_INPUT)
    })?;
    // Interrupted, the runs that finished; else every run, or an error.
    let accounted = account(rows.into_iter().flatten(), args.runs);
    let rows = match accounted {
        Ok(a) if interrupted => Ok(a.rows),
        Ok(a) => a.complete(args.runs),
        Err(e) => Err(e),
    };
    rows.map(|r| (r, interrupted)).map_err(|e| {
        errln!("error: {e}");
        ExitCode::from(exit::OUTPUT)
    })
}

fn print_summary(s: &Value) {
    let f = |v: &Value| v.as_f64().map_or("-".to_string(), |x| format!("{x:.3}"));
    outln!(
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
    outln!(
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
    outln!("outcomes      {}", outcomes.join(", "));
    outln!(
        "re-plans      {} ({} failed, {} missed the deadline (iteration budget), {} flown unconverged at the budget, {} slower than the period on the clock)",
        s["replans"], s["failed_replans"], s["missed_replans"], s["usable_replans"], s["late_replans"]
    );
    outln!("                              p50        p95        p99        max");
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
        outln!(
            "{label:<26}{:>10} {:>10} {:>10} {:>10}",
            f(&p["p50"]),
            f(&p["p95"]),
            f(&p["p99"]),
            f(&p["max"])
        );
    }
    let w = &s["worst"];
    outln!(
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
    files::write_file(&path, csv)?;
    files.push(path);
    let path = dir.join("summary.json");
    files::write_file(&path, format!("{s}\n"))?;
    files.push(path);
    files.extend(plot::campaign(dir, rows, &case.scenario.name)?);
    let data = bellyflop::output::viewer::campaign_data(rows, s, limits, sim);
    files.push(output::write_viewer(dir, &data)?);
    Ok(files)
}
