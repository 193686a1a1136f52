//! The plots of `solve --out DIR` on a 6-DoF scenario, each as SVG and PNG
//! (the planar plots' names, fonts, colours and tick labels):
//!
//! - `path`: the path of the centre of mass in the x–z and y–z side views
//!   and the x–y top view, each on equal axis scales, with the vehicle's
//!   axis (engine to nose) at regular nodes, and a summary;
//! - `histories`: altitude, horizontal position, speed, tilt of the axis
//!   from vertical, body rates, mass, thrust, gimbal angles and gimbal
//!   rates against time.
//!
//! They draw the answer's node table (`trajectory.csv`): the states at the
//! N + 1 node times, the controls at the first N. Between the nodes the
//! path is the cubic Hermite interpolant of (r, V); the histories join the
//! nodes with straight lines. A `solved` answer's nodes are its flown
//! (polished) trajectory's; an `inaccurate` one's are the raw collocation
//! answer's, whose controls, flown, land elsewhere (the summary says where).

mod histories;
mod path;

use std::path::{Path, PathBuf};

use bellyflop::pipeline::six_dof::SixDofSolution;
use bellyflop::problem::six_dof::{rotation, su, sx, NU, NX};
use bellyflop::Scenario;
use plotters::prelude::*;

use super::common::fonts;
use super::render::svg_and_png;
use crate::error::OutputError;
use crate::files::commit;

/// Every 6-DoF plot: file stem and size in pixels.
pub const PLOTS: [(&str, (u32, u32)); 2] = [("path", (1500, 1150)), ("histories", (1600, 1150))];

/// What the 6-DoF plots draw: the answer's node table, row by row.
pub struct SixDofPlot<'a> {
    pub scenario: &'a Scenario,
    pub solution: &'a SixDofSolution,
    /// The N + 1 node times \[s\].
    t_s: Vec<f64>,
    /// The states at `t_s` (a missing value NaN).
    states: Vec<[f64; NX]>,
    /// The controls at the first N of `t_s`.
    controls: Vec<[f64; NU]>,
}

/// A row as a fixed array, a missing value NaN.
fn row<const N: usize>(r: &[f64]) -> [f64; N] {
    std::array::from_fn(|i| r.get(i).copied().unwrap_or(f64::NAN))
}

impl<'a> SixDofPlot<'a> {
    pub fn new(scenario: &'a Scenario, solution: &'a SixDofSolution) -> Self {
        let n = solution.t_s.len().min(solution.states.rows.len());
        SixDofPlot {
            scenario,
            solution,
            t_s: solution.t_s[..n].to_vec(),
            states: solution.states.rows[..n].iter().map(|r| row(r)).collect(),
            controls: solution
                .controls
                .rows
                .iter()
                .take(n)
                .map(|r| row(r))
                .collect(),
        }
    }

    /// State `i` ([`sx`]) at the nodes, times `scale`.
    fn state(&self, i: usize, scale: f64) -> Vec<f64> {
        self.states.iter().map(|s| s[i] * scale).collect()
    }

    /// Control `i` ([`su`]) at the first N nodes, times `scale`.
    fn control(&self, i: usize, scale: f64) -> Vec<f64> {
        self.controls.iter().map(|u| u[i] * scale).collect()
    }

    /// The times of the controls: the first N node times.
    fn control_times(&self) -> &[f64] {
        &self.t_s[..self.controls.len()]
    }

    /// The vehicle's axis e_z (toward the nose) in the inertial frame at
    /// each node: the third column of R(q).
    fn axes(&self) -> Vec<[f64; 3]> {
        self.states
            .iter()
            .map(|s| {
                let r = rotation([s[sx::Q], s[sx::Q + 1], s[sx::Q + 2], s[sx::Q + 3]]);
                [r[0][2], r[1][2], r[2][2]]
            })
            .collect()
    }

    /// The speed ‖V‖ at the nodes \[m/s\].
    fn speed(&self) -> Vec<f64> {
        self.states
            .iter()
            .map(|s| {
                let v = &s[sx::VX..sx::VX + 3];
                v.iter().map(|c| c * c).sum::<f64>().sqrt()
            })
            .collect()
    }

    /// The tilt of the axis from the vertical at the nodes \[deg\].
    fn tilt_deg(&self) -> Vec<f64> {
        self.axes()
            .iter()
            .map(|a| a[2].clamp(-1.0, 1.0).acos().to_degrees())
            .collect()
    }

    /// The thrust at the first N nodes \[kN\].
    fn thrust_kn(&self) -> Vec<f64> {
        self.control(su::T, 1e-3)
    }

    fn title(&self) -> String {
        let s = self.solution;
        let polish = if s.controls_flown.is_some() {
            ", polished"
        } else {
            ""
        };
        format!(
            "{}: 6-DoF, N = {}, direct method{polish}, {}, t_f = {:.3} s, final mass {:.1} kg",
            self.scenario.name,
            s.nodes,
            s.status.as_str(),
            s.tf_s,
            s.final_mass_kg
        )
    }
}

/// Draw every 6-DoF plot as `DIR/NAME.svg` and `DIR/NAME.png`; return the
/// paths.
pub fn render_all(dir: &Path, d: &SixDofPlot) -> Result<Vec<PathBuf>, OutputError> {
    fonts();
    let mut written = Vec::new();
    for (stem, size) in PLOTS {
        match stem {
            "path" => svg_and_png!(dir, written, stem, size, draw_path, d),
            _ => svg_and_png!(dir, written, stem, size, draw_histories, d),
        }
    }
    Ok(written)
}

use histories::draw_histories;
use path::draw_path;
