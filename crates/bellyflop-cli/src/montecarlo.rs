//! `bellyflop montecarlo`: many dispersed closed-loop landings in parallel.
//!
//! Each run is `sim` with its own run index: the draw depends only on
//! (seed, run index), and the rows are written in run order, so the same seed
//! gives the same results whatever the thread count: re-plan deadlines are
//! iteration budgets, not clock readings (re-plans slower than the period on
//! the clock are counted as `late` but do not change the flight).

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use bellyflop::guidance::{end_state, Flight, ReplanOutcome};
use bellyflop::sim::{Outcome, RunOutcome, TouchdownLimits};
use bellyflop::Scenario;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::Serialize;
use serde_json::{json, Value};

use crate::output::{self, OutputError};
use crate::sim::load;
use crate::{campaign_plot, EXIT_BAD_INPUT};

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
    /// Write runs.csv, summary.json and the plots (touchdown scatter,
    /// re-plan time histogram) into DIR.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

/// One row of runs.csv.
#[derive(Debug, Clone, Serialize)]
pub struct RunRow {
    pub run: u64,
    /// How the run ended, its touchdown judged by the `[touchdown]` limits.
    pub outcome: RunOutcome,
    pub time_s: f64,
    pub x_error_m: f64,
    pub vertical_velocity_mps: f64,
    pub horizontal_velocity_mps: f64,
    pub speed_mps: f64,
    pub pitch_error_deg: f64,
    pub pitch_rate_degps: f64,
    pub fuel_kg: f64,
    pub replans: usize,
    pub failed_replans: usize,
    pub missed_replans: usize,
    /// Re-plans unconverged at the budget but flown (usable iterate).
    pub usable_replans: usize,
    /// Re-plans slower than the wall-clock deadline (reported only).
    pub late_replans: usize,
    pub max_replan_ms: f64,
    pub first_plan_nominal: bool,
    /// Every re-plan's solve time \[ms\] (for the histogram; not in the CSV).
    #[serde(skip)]
    pub replan_ms: Vec<f64>,
    /// The landing spec the run was judged by (for the worst case; not in
    /// the CSV).
    #[serde(skip)]
    pub limits: TouchdownLimits,
}

impl RunRow {
    fn new(run: u64, f: &Flight, limits: &TouchdownLimits) -> RunRow {
        let s = end_state(&f.outcome);
        let (time_s, pitch_error_deg) = match &f.outcome {
            Outcome::Touchdown(td) => (td.time_s, td.pitch_error_deg),
            Outcome::PropellantExhausted { time_s, .. }
            | Outcome::TimeLimit { time_s, .. }
            | Outcome::NonFinite { time_s, .. } => (*time_s, s.theta_rad.to_degrees()),
        };
        let replan_ms: Vec<f64> = f.replans.iter().map(|r| r.solve_ms).collect();
        RunRow {
            run,
            outcome: RunOutcome::of(&f.outcome, limits),
            time_s,
            x_error_m: match &f.outcome {
                Outcome::Touchdown(td) => td.x_error_m,
                _ => f64::NAN,
            },
            vertical_velocity_mps: s.vz_mps,
            horizontal_velocity_mps: s.vx_mps,
            speed_mps: s.vx_mps.hypot(s.vz_mps),
            pitch_error_deg,
            pitch_rate_degps: s.pitch_rate_radps.to_degrees(),
            fuel_kg: f.fuel_kg(),
            replans: f.replans.len(),
            failed_replans: f.count(ReplanOutcome::Failed),
            missed_replans: f.count(ReplanOutcome::Missed),
            usable_replans: f.count(ReplanOutcome::Usable),
            late_replans: f.replans.iter().filter(|r| r.late).count(),
            max_replan_ms: replan_ms.iter().copied().fold(0.0, f64::max),
            first_plan_nominal: f.first_plan_nominal,
            replan_ms,
            limits: *limits,
        }
    }

    /// The run ended on the ground (landed, hard landing or crash).
    pub fn touchdown(&self) -> bool {
        self.outcome.touched_down()
    }

    /// Within the landing requirement (`landed`).
    pub fn in_spec(&self) -> bool {
        self.outcome == RunOutcome::Landed
    }

    /// The largest of the three errors, each divided by its requirement
    /// (∞ without a touchdown): how the worst case is chosen.
    fn badness(&self) -> f64 {
        if !self.touchdown() {
            return f64::INFINITY;
        }
        let l = &self.limits;
        (self.x_error_m.abs() / l.landed_position_m)
            .max(self.speed_mps / l.landed_speed_mps)
            .max(self.pitch_error_deg.abs() / l.landed_pitch_deg)
    }
}

/// Percentiles p50/p95/p99/max by the nearest-rank rule.
pub fn percentiles(values: &[f64]) -> Value {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return json!({"p50": null, "p95": null, "p99": null, "max": null});
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let rank = |p: f64| v[((p / 100.0 * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
    json!({"p50": rank(50.0), "p95": rank(95.0), "p99": rank(99.0), "max": v[v.len() - 1]})
}

/// The campaign summary (the `--json` object).
pub fn summary(
    rows: &[RunRow],
    limits: &TouchdownLimits,
    seed: u64,
    threads: usize,
    wall_s: f64,
    open_loop: bool,
) -> Value {
    let outcomes: serde_json::Map<String, Value> = RunOutcome::ALL
        .iter()
        .map(|&o| {
            let n = rows.iter().filter(|r| r.outcome == o).count();
            (o.as_str().to_string(), n.into())
        })
        .collect();
    let td: Vec<&RunRow> = rows.iter().filter(|r| r.touchdown()).collect();
    let of = |g: &dyn Fn(&RunRow) -> f64| td.iter().map(|r| g(r)).collect::<Vec<f64>>();
    let all_ms: Vec<f64> = rows
        .iter()
        .flat_map(|r| r.replan_ms.iter().copied())
        .collect();
    let worst = rows
        .iter()
        .max_by(|a, b| a.badness().total_cmp(&b.badness()))
        .map(|r| serde_json::to_value(r).unwrap_or_default());
    json!({
        "runs": rows.len(),
        "seed": seed,
        "threads": threads,
        "replanning": !open_loop,
        "wall_time_s": wall_s,
        "failures": rows.len() - td.len(),
        "in_spec": rows.iter().filter(|r| r.in_spec()).count(),
        "in_spec_fraction": rows.iter().filter(|r| r.in_spec()).count() as f64 / rows.len().max(1) as f64,
        "outcomes": outcomes,
        "spec": {"position_m": limits.landed_position_m, "speed_mps": limits.landed_speed_mps, "pitch_deg": limits.landed_pitch_deg},
        "touchdown_limits": limits,
        "replans": all_ms.len(),
        "failed_replans": rows.iter().map(|r| r.failed_replans).sum::<usize>(),
        "missed_replans": rows.iter().map(|r| r.missed_replans).sum::<usize>(),
        "usable_replans": rows.iter().map(|r| r.usable_replans).sum::<usize>(),
        "late_replans": rows.iter().map(|r| r.late_replans).sum::<usize>(),
        "nominal_first_plans": rows.iter().filter(|r| r.first_plan_nominal).count(),
        "touchdown_position_m": percentiles(&of(&|r| r.x_error_m.abs())),
        "touchdown_speed_mps": percentiles(&of(&|r| r.speed_mps)),
        "touchdown_vertical_speed_mps": percentiles(&of(&|r| r.vertical_velocity_mps.abs())),
        "touchdown_horizontal_speed_mps": percentiles(&of(&|r| r.horizontal_velocity_mps.abs())),
        "touchdown_pitch_deg": percentiles(&of(&|r| r.pitch_error_deg.abs())),
        "fuel_kg": percentiles(&rows.iter().map(|r| r.fuel_kg).collect::<Vec<f64>>()),
        "replan_time_ms": percentiles(&all_ms),
        "worst": worst,
    })
}

pub fn run(args: &MonteCarloArgs) -> ExitCode {
    let (scenario, config) = match load(&args.scenario, &args.config, args.open_loop, false) {
        Ok(v) => v,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    if args.runs == 0 || args.runs > 1_000_000 {
        eprintln!(
            "error: --runs = {} is out of range: allowed 1 to 1000000",
            args.runs
        );
        return ExitCode::from(EXIT_BAD_INPUT);
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
            return ExitCode::from(EXIT_BAD_INPUT);
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
                let f = config.fly(&scenario, args.seed, k, false)?;
                bar.inc(1);
                Ok(RunRow::new(k, &f, &config.touchdown))
            })
            .collect()
    });
    bar.finish_and_clear();
    let rows = match rows {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let wall_s = start.elapsed().as_secs_f64();
    let s = summary(
        &rows,
        &config.touchdown,
        args.seed,
        threads,
        wall_s,
        args.open_loop,
    );
    if args.json {
        println!("{s}");
    } else {
        print_summary(&s);
    }
    if let Some(dir) = &args.out {
        if let Err(code) = output::report(dir, write(dir, &rows, &s, &scenario), args.json) {
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

fn write(
    dir: &std::path::Path,
    rows: &[RunRow],
    s: &Value,
    scenario: &Scenario,
) -> Result<Vec<PathBuf>, OutputError> {
    let mut files = Vec::new();
    let mut csv = String::from("run,outcome,time_s,x_error_m,vertical_velocity_mps,horizontal_velocity_mps,speed_mps,pitch_error_deg,pitch_rate_degps,fuel_kg,replans,failed_replans,missed_replans,usable_replans,late_replans,max_replan_ms,first_plan_nominal\n");
    for r in rows {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.run,
            r.outcome.as_str(),
            r.time_s,
            r.x_error_m,
            r.vertical_velocity_mps,
            r.horizontal_velocity_mps,
            r.speed_mps,
            r.pitch_error_deg,
            r.pitch_rate_degps,
            r.fuel_kg,
            r.replans,
            r.failed_replans,
            r.missed_replans,
            r.usable_replans,
            r.late_replans,
            r.max_replan_ms,
            r.first_plan_nominal
        );
    }
    let path = dir.join("runs.csv");
    std::fs::write(&path, csv).map_err(|e| OutputError::io(&path, e))?;
    files.push(path);
    let path = dir.join("summary.json");
    std::fs::write(&path, format!("{s}\n")).map_err(|e| OutputError::io(&path, e))?;
    files.push(path);
    files.extend(campaign_plot::campaign(dir, rows, &scenario.name)?);
    Ok(files)
}
