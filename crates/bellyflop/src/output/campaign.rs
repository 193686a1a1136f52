//! Monte Carlo campaigns of closed-loop landings: one row per run and the
//! summary, shared by `bellyflop montecarlo` (runs.csv, summary.json) and the
//! Python package's `montecarlo`.
//!
//! A run's draw depends only on (campaign seed, run index), so a row is the
//! same whichever process, thread or chunk flies it.

use std::fmt::Write as _;

use serde::Serialize;
use serde_json::{json, Value};

use crate::guidance::{end_state, Flight, ReplanOutcome, SimConfig};
use crate::sim::{Outcome, RunOutcome, TouchdownLimits};
use crate::{Case, InputError};

/// What a column of runs.csv holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A count or an index (written as an integer).
    Count,
    /// A number, in full precision (NaN where there is none).
    Number,
    /// A yes/no (written `true`/`false`).
    Flag,
    /// How the run ended ([`RunOutcome::as_str`]).
    Outcome,
}

/// One cell of a runs.csv row, typed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Cell {
    Count(u64),
    Number(f64),
    Flag(bool),
    Outcome(RunOutcome),
}

impl std::fmt::Display for Cell {
    /// The cell as runs.csv writes it: the value's own `Display`, as in the
    /// CSV since the start.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Cell::Count(n) => write!(f, "{n}"),
            Cell::Number(x) => write!(f, "{x}"),
            Cell::Flag(b) => write!(f, "{b}"),
            Cell::Outcome(o) => f.write_str(o.as_str()),
        }
    }
}

/// One column of runs.csv: its name, what it holds, and how a row's field
/// is read and written (`set` is false for a cell of another kind).
#[derive(Clone, Copy)]
pub struct Column {
    pub name: &'static str,
    pub kind: Kind,
    pub get: fn(&RunRow) -> Cell,
    pub set: fn(&mut RunRow, Cell) -> bool,
}

/// The column named after a field of [`RunRow`], of the given kind.
macro_rules! column {
    ($name:ident, Count) => {
        Column {
            name: stringify!($name),
            kind: Kind::Count,
            get: |r| Cell::Count(r.$name as u64),
            set: |r, c| match c {
                Cell::Count(n) => {
                    r.$name = n as _;
                    true
                }
                _ => false,
            },
        }
    };
    ($name:ident, Number) => {
        Column {
            name: stringify!($name),
            kind: Kind::Number,
            get: |r| Cell::Number(r.$name),
            set: |r, c| match c {
                Cell::Number(x) => {
                    r.$name = x;
                    true
                }
                _ => false,
            },
        }
    };
    ($name:ident, Flag) => {
        Column {
            name: stringify!($name),
            kind: Kind::Flag,
            get: |r| Cell::Flag(r.$name),
            set: |r, c| match c {
                Cell::Flag(b) => {
                    r.$name = b;
                    true
                }
                _ => false,
            },
        }
    };
    ($name:ident, Outcome) => {
        Column {
            name: stringify!($name),
            kind: Kind::Outcome,
            get: |r| Cell::Outcome(r.$name),
            set: |r, c| match c {
                Cell::Outcome(o) => {
                    r.$name = o;
                    true
                }
                _ => false,
            },
        }
    };
}

/// runs.csv's columns, in order: the one definition that [`RUNS_CSV_COLUMNS`],
/// [`runs_csv`], [`RunRow::cells`] and [`RunRow::from_cells`] (and the
/// Python package's tables) are read from.
pub const RUNS_CSV: [Column; 17] = [
    column!(run, Count),
    column!(outcome, Outcome),
    column!(time_s, Number),
    column!(x_error_m, Number),
    column!(vertical_velocity_mps, Number),
    column!(horizontal_velocity_mps, Number),
    column!(speed_mps, Number),
    column!(pitch_error_deg, Number),
    column!(pitch_rate_degps, Number),
    column!(fuel_kg, Number),
    column!(replans, Count),
    column!(failed_replans, Count),
    column!(missed_replans, Count),
    column!(usable_replans, Count),
    column!(late_replans, Count),
    column!(max_replan_ms, Number),
    column!(first_plan_nominal, Flag),
];

/// The columns of runs.csv, in order: the names of the table [`RUNS_CSV`].
pub const RUNS_CSV_COLUMNS: [&str; 17] = {
    let mut names = [""; 17];
    let mut i = 0;
    while i < names.len() {
        names[i] = RUNS_CSV[i].name;
        i += 1;
    }
    names
};

/// Fly run `run` of the campaign `seed` (no trace recorded) and build its row.
pub fn fly_row(case: &Case, config: &SimConfig, seed: u64, run: u64) -> Result<RunRow, InputError> {
    let f = config.fly(case, seed, run, false)?;
    Ok(RunRow::new(run, &f, &config.touchdown))
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
    /// The row of run `run` from its flight, judged by `limits`.
    pub fn new(run: u64, f: &Flight, limits: &TouchdownLimits) -> RunRow {
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

    /// The row's cells, in [`RUNS_CSV`]'s order.
    pub fn cells(&self) -> [Cell; 17] {
        RUNS_CSV.map(|c| (c.get)(self))
    }

    /// The row whose runs.csv cells are `cells` (in [`RUNS_CSV`]'s order),
    /// with its re-plan times and the limits it was judged by; an error
    /// names the first column whose cell is missing or of another kind.
    pub fn from_cells(
        cells: &[Cell],
        replan_ms: Vec<f64>,
        limits: TouchdownLimits,
    ) -> Result<RunRow, String> {
        let mut row = RunRow {
            run: 0,
            outcome: RunOutcome::Landed,
            time_s: f64::NAN,
            x_error_m: f64::NAN,
            vertical_velocity_mps: f64::NAN,
            horizontal_velocity_mps: f64::NAN,
            speed_mps: f64::NAN,
            pitch_error_deg: f64::NAN,
            pitch_rate_degps: f64::NAN,
            fuel_kg: f64::NAN,
            replans: 0,
            failed_replans: 0,
            missed_replans: 0,
            usable_replans: 0,
            late_replans: 0,
            max_replan_ms: f64::NAN,
            first_plan_nominal: false,
            replan_ms,
            limits,
        };
        for (k, column) in RUNS_CSV.iter().enumerate() {
            let ok = cells.get(k).is_some_and(|&c| (column.set)(&mut row, c));
            if !ok {
                return Err(format!(
                    "column {k} ({}): expected a {:?} cell, found {:?}",
                    column.name,
                    column.kind,
                    cells.get(k)
                ));
            }
        }
        Ok(row)
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

/// runs.csv's wall-clock columns: two deliveries of one run (an executor
/// that ran it twice) may differ in these and in nothing else.
pub const TIMING_COLUMNS: [&str; 2] = ["late_replans", "max_replan_ms"];

impl RunRow {
    /// The first column other than [`TIMING_COLUMNS`] in which `self` and
    /// `other` differ (bit for bit, so NaN equals NaN), with both cells;
    /// `None` when they are the same run's row.
    pub fn differs_from(&self, other: &RunRow) -> Option<(&'static str, String, String)> {
        let (a, b) = (self.cells(), other.cells());
        RUNS_CSV
            .iter()
            .zip(a.iter().zip(b.iter()))
            .filter(|(c, _)| !TIMING_COLUMNS.contains(&c.name))
            .find(|(_, (x, y))| !same_cell(**x, **y))
            .map(|(c, (x, y))| (c.name, x.to_string(), y.to_string()))
    }
}

fn same_cell(a: Cell, b: Cell) -> bool {
    match (a, b) {
        (Cell::Number(x), Cell::Number(y)) => x.to_bits() == y.to_bits(),
        _ => a == b,
    }
}

/// Why the rows that came back do not make the campaign.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CampaignError {
    /// Runs that never came back (after any re-submissions).
    #[error("{} of the campaign's {runs} runs did not come back: runs {}", missing.len(), list_runs(missing))]
    Missing { runs: u64, missing: Vec<u64> },
    /// One run came back twice with different deterministic cells.
    #[error("run {run} came back twice with different results: {column} = {first} and {second}")]
    Conflict {
        run: u64,
        column: &'static str,
        first: String,
        second: String,
    },
    /// A row whose run index is not in 0..runs.
    #[error("a row of run {run} came back, which is not a run of this campaign (0 to {})", runs.saturating_sub(1))]
    Stray { run: u64, runs: u64 },
}

/// The runs `missing` as text: ranges of consecutive runs (`3, 7-9`), at
/// most 20 of them, then how many more.
pub fn list_runs(missing: &[u64]) -> String {
    let mut ranges: Vec<(u64, u64)> = Vec::new();
    for &k in missing {
        match ranges.last_mut() {
            Some((_, hi)) if *hi + 1 == k => *hi = k,
            _ => ranges.push((k, k)),
        }
    }
    let mut text: Vec<String> = ranges
        .iter()
        .take(20)
        .map(|&(lo, hi)| {
            if lo == hi {
                lo.to_string()
            } else {
                format!("{lo}-{hi}")
            }
        })
        .collect();
    if ranges.len() > 20 {
        text.push(format!("... ({} runs in all)", missing.len()));
    }
    text.join(", ")
}

/// The rows of a campaign of `runs` runs, accounted for: one row per run in
/// run order, and the runs that did not come back.
#[derive(Debug, Clone)]
pub struct Accounted {
    pub rows: Vec<RunRow>,
    pub missing: Vec<u64>,
}

impl Accounted {
    /// The rows if every run came back, else [`CampaignError::Missing`].
    pub fn complete(self, runs: u64) -> Result<Vec<RunRow>, CampaignError> {
        if self.missing.is_empty() {
            Ok(self.rows)
        } else {
            Err(CampaignError::Missing {
                runs,
                missing: self.missing,
            })
        }
    }
}

/// Account for every run of a campaign of `runs` runs: each index in
/// 0..runs must come back exactly once. A second row of a run equal to the
/// first (runs are deterministic from the seed, but for
/// [`TIMING_COLUMNS`]) is dropped; one that differs is
/// [`CampaignError::Conflict`], a run outside 0..runs
/// [`CampaignError::Stray`]. The rows come back in run order, with the
/// runs that are missing.
pub fn account(
    rows: impl IntoIterator<Item = RunRow>,
    runs: u64,
) -> Result<Accounted, CampaignError> {
    let mut rows: Vec<RunRow> = rows.into_iter().collect();
    if let Some(r) = rows.iter().find(|r| r.run >= runs) {
        return Err(CampaignError::Stray { run: r.run, runs });
    }
    // Stable: the first delivery of a run stays first.
    rows.sort_by_key(|r| r.run);
    let mut unique: Vec<RunRow> = Vec::with_capacity(rows.len());
    for r in rows {
        match unique.last() {
            Some(first) if first.run == r.run => {
                if let Some((column, a, b)) = first.differs_from(&r) {
                    return Err(CampaignError::Conflict {
                        run: r.run,
                        column,
                        first: a,
                        second: b,
                    });
                }
            }
            _ => unique.push(r),
        }
    }
    let mut missing = Vec::new();
    let mut next = 0;
    for r in &unique {
        missing.extend(next..r.run);
        next = r.run + 1;
    }
    missing.extend(next..runs);
    Ok(Accounted {
        rows: unique,
        missing,
    })
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

/// The text of runs.csv: the header ([`RUNS_CSV_COLUMNS`]) and one line per
/// row, numbers in full precision.
pub fn runs_csv(rows: &[RunRow]) -> String {
    let mut csv = RUNS_CSV_COLUMNS.join(",");
    csv.push('\n');
    for r in rows {
        for (i, column) in RUNS_CSV.iter().enumerate() {
            if i > 0 {
                csv.push(',');
            }
            let _ = write!(csv, "{}", (column.get)(r));
        }
        csv.push('\n');
    }
    csv
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row with a distinct value in every column.
    fn sample_row() -> RunRow {
        let cells: Vec<Cell> = RUNS_CSV
            .iter()
            .enumerate()
            .map(|(k, c)| match c.kind {
                Kind::Count => Cell::Count(k as u64 + 1),
                Kind::Number => Cell::Number(k as f64 + 0.25),
                Kind::Flag => Cell::Flag(k % 2 == 0),
                Kind::Outcome => Cell::Outcome(RunOutcome::ALL[k % RunOutcome::ALL.len()]),
            })
            .collect();
        RunRow::from_cells(&cells, vec![1.5, 2.5], TouchdownLimits::default()).unwrap()
    }

    #[test]
    fn cells_round_trip_through_the_table() {
        let row = sample_row();
        let back = RunRow::from_cells(&row.cells(), row.replan_ms.clone(), row.limits).unwrap();
        assert_eq!(back.cells(), row.cells());
        // Each column reads its own field: the cells are all distinct.
        let text: Vec<String> = row.cells().iter().map(|c| c.to_string()).collect();
        for (k, t) in text.iter().enumerate() {
            let kind = RUNS_CSV[k].kind;
            if kind == Kind::Count || kind == Kind::Number {
                assert_eq!(text.iter().filter(|u| *u == t).count(), 1, "{t}");
            }
        }
        assert_eq!(runs_csv(&[row]).lines().nth(1).unwrap(), text.join(","));
    }

    #[test]
    fn a_cell_of_the_wrong_kind_names_its_column() {
        let mut cells = sample_row().cells();
        cells[2] = Cell::Flag(true);
        let err = RunRow::from_cells(&cells, vec![], TouchdownLimits::default()).unwrap_err();
        assert!(err.contains("time_s"), "{err}");
        let short = RunRow::from_cells(&cells[..1], vec![], TouchdownLimits::default());
        assert!(short.unwrap_err().contains("outcome"));
    }

    fn row(run: u64) -> RunRow {
        let mut r = sample_row();
        r.run = run;
        r.fuel_kg = f64::NAN; // NaN equals NaN in the accounting
        r
    }

    #[test]
    fn every_run_is_accounted_for_once() {
        // Run 3 twice (the second with other wall-clock cells: dropped),
        // runs 1 and 5 to 7 missing.
        let mut late = row(3);
        late.max_replan_ms += 1.0;
        late.late_replans += 1;
        let rows = vec![row(4), row(3), row(0), late, row(2)];
        let a = account(rows, 8).unwrap();
        let runs: Vec<u64> = a.rows.iter().map(|r| r.run).collect();
        assert_eq!(runs, [0, 2, 3, 4]);
        assert_eq!(
            a.rows[2].max_replan_ms,
            row(3).max_replan_ms,
            "the first kept"
        );
        assert_eq!(a.missing, [1, 5, 6, 7]);
        let err = a.complete(8).unwrap_err();
        assert_eq!(
            err.to_string(),
            "4 of the campaign's 8 runs did not come back: runs 1, 5-7"
        );
        assert!(account((0..3).map(row), 3).unwrap().complete(3).is_ok());
    }

    #[test]
    fn a_differing_duplicate_or_a_stray_run_is_an_error() {
        let mut other = row(1);
        other.x_error_m = 9.5;
        let err = account(vec![row(0), row(1), other], 2).unwrap_err();
        assert!(
            matches!(
                err,
                CampaignError::Conflict {
                    run: 1,
                    column: "x_error_m",
                    ..
                }
            ),
            "{err}"
        );
        assert!(err.to_string().contains("x_error_m = "), "{err}");
        let err = account(vec![row(0), row(2)], 2).unwrap_err();
        assert_eq!(err, CampaignError::Stray { run: 2, runs: 2 });
    }

    #[test]
    fn long_lists_of_runs_are_cut() {
        let every_other: Vec<u64> = (0..100).map(|k| 2 * k).collect();
        let text = list_runs(&every_other);
        assert!(text.starts_with("0, 2, 4"), "{text}");
        assert!(text.ends_with("... (100 runs in all)"), "{text}");
    }
}
