//! `solve --out DIR`: the trajectory as CSV, the solution as JSON, the plots
//! and the interactive viewer (`viewer.html`).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use bellyflop::output::viewer;
use bellyflop::verify::propagate::Propagation;
use bellyflop::{Scenario, Solution, SolverSettings};

use crate::error::OutputError;
use crate::files;
use crate::sample::{Dense, COLUMNS};
use crate::{exit, plot};

/// Samples per interval between consecutive LGR nodes in `trajectory.csv`
/// and in the plots.
pub const SAMPLES_PER_INTERVAL: usize = 10;

/// Write everything for `solve --out DIR`: `json` is the object `--json`
/// prints, `propagation` the re-integration of the solution (drawn dashed).
/// On success list the files on stderr (unless `quiet`); on failure print
/// the error and return the exit code.
pub fn write_and_report(
    dir: &Path,
    scenario: &Scenario,
    settings: &SolverSettings,
    solution: &Solution,
    json: &serde_json::Value,
    propagation: Option<&Propagation>,
    quiet: bool,
) -> Result<(), std::process::ExitCode> {
    let over = propagation.map(|p| overlay(solution, p));
    let written =
        write_all(dir, scenario, settings, solution, json, over.as_ref()).and_then(|mut files| {
            let data = viewer::solve_data(scenario, solution, json, propagation);
            files.push(write_viewer(dir, &data)?);
            Ok(files)
        });
    report(dir, written, quiet)
}

/// Write `viewer.html` (the page of [`bellyflop::output::viewer`]) for
/// `data` into `dir`, and return its path.
pub fn write_viewer(dir: &Path, data: &serde_json::Value) -> Result<PathBuf, OutputError> {
    let path = dir.join("viewer.html");
    let page = viewer::html(&data.to_string()).map_err(|e| OutputError::io(&path, e))?;
    files::write_file(&path, page)?;
    Ok(path)
}

/// After writing into `dir`: list the files on stderr (unless `quiet`), or
/// print the error and return the exit code.
pub fn report(
    dir: &Path,
    written: Result<Vec<PathBuf>, OutputError>,
    quiet: bool,
) -> Result<(), std::process::ExitCode> {
    match written {
        Ok(files) => {
            if !quiet {
                let names: Vec<String> = files
                    .iter()
                    .filter_map(|f| f.file_name().map(|n| n.to_string_lossy().into_owned()))
                    .collect();
                errln!("wrote {}: {}", dir.display(), names.join(", "));
            }
            Ok(())
        }
        Err(e) => {
            errln!("error: {e}");
            Err(std::process::ExitCode::from(exit::OUTPUT))
        }
    }
}

/// Create the `--out` directory before any work; on failure print the error
/// and return the bad-input exit code.
pub fn prepare_or_exit(dir: &Option<PathBuf>) -> Result<(), std::process::ExitCode> {
    if let Some(dir) = dir {
        if let Err(e) = prepare(dir) {
            errln!("error: --out {e}");
            return Err(std::process::ExitCode::from(exit::BAD_INPUT));
        }
    }
    Ok(())
}

/// The re-integrated trajectory as drawn dashed over the solution in the
/// path and time-history plots, sampled at the integrator's accepted steps.
/// Its thrust and gimbal rate are the interpolants the integration used.
pub fn overlay(solution: &Solution, p: &Propagation) -> Dense {
    Dense::from_columns(viewer::propagation_columns(solution, p))
}

/// Create the output directory (and its parents) if needed.
pub fn prepare(dir: &Path) -> Result<(), OutputError> {
    std::fs::create_dir_all(dir).map_err(|e| OutputError::io(dir, e))
}

/// Write `trajectory.csv`, `solution.json` (the text of `json`) and every
/// plot (SVG and PNG) into `dir`, and return the paths written. `overlay` is
/// drawn dashed on the path and time-history plots (e.g. a re-integrated
/// trajectory).
pub fn write_all(
    dir: &Path,
    scenario: &Scenario,
    settings: &SolverSettings,
    solution: &Solution,
    json: &serde_json::Value,
    overlay: Option<&Dense>,
) -> Result<Vec<PathBuf>, OutputError> {
    prepare(dir)?;
    let dense = Dense::from_solution(scenario, solution, SAMPLES_PER_INTERVAL);
    let mut written = Vec::new();

    let csv = dir.join("trajectory.csv");
    files::write_file(&csv, trajectory_csv(&dense))?;
    written.push(csv);

    let json_path = dir.join("solution.json");
    files::write_file(&json_path, format!("{json}\n"))?;
    written.push(json_path);

    let data = plot::PlotData::new(scenario, settings, solution, &dense, overlay);
    written.extend(plot::render_all(dir, &data)?);
    Ok(written)
}

/// The CSV text: one header line of column names with their units as
/// suffixes (the same names as the JSON keys), then one line per sample in
/// full precision (`{}` of f64 is the shortest string that reads back to the
/// same number). The last column `is_node` is 1 on the LGR nodes, else 0.
pub fn trajectory_csv(d: &Dense) -> String {
    let mut s = String::new();
    for (name, _) in COLUMNS {
        s.push_str(name);
        s.push(',');
    }
    s.push_str("is_node\n");
    for i in 0..d.len() {
        for (_, col) in COLUMNS {
            let _ = write!(s, "{},", col(d)[i]);
        }
        s.push_str(if d.node[i].is_some() { "1\n" } else { "0\n" });
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_round_trips_every_digit() {
        let x = [0.1 + 0.2, 1.0 / 3.0, 114_568.912_345_678_9, -1e-300, 2.0];
        let cols: [Vec<f64>; 11] =
            std::array::from_fn(|c| x.iter().map(|v| v * (c as f64 + 1.0)).collect::<Vec<f64>>());
        let mut d = Dense::from_columns(cols.clone());
        d.node[0] = Some(0);
        let text = trajectory_csv(&d);
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(header.len(), 12);
        assert_eq!(header[0], "t_s");
        assert_eq!(header[11], "is_node");
        for (i, line) in lines.enumerate() {
            let fields: Vec<&str> = line.split(',').collect();
            for (c, col) in cols.iter().enumerate() {
                assert_eq!(fields[c].parse::<f64>().unwrap(), col[i]);
            }
            assert_eq!(fields[11], if i == 0 { "1" } else { "0" });
        }
    }
}
