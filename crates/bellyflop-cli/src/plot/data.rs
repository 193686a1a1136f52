//! What the plots of `solve --out` draw: a solution, its dense samples, an
//! optional overlay, and what is derived from them (switches, breaks, title).

use bellyflop::{Scenario, Solution, SolverSettings};

use crate::sample::Dense;

/// The names of the method that ran.
pub(super) struct MethodNames {
    /// In the plots' titles: "direct method", "SCvx, exact formulation".
    pub(super) title: String,
    /// Before "iterations": "interior-point" or "SCvx".
    pub(super) iterations: &'static str,
}

/// Everything the plots draw.
pub struct PlotData<'a> {
    pub scenario: &'a Scenario,
    pub settings: &'a SolverSettings,
    pub solution: &'a Solution,
    /// The solution's interpolants, densely sampled.
    pub dense: &'a Dense,
    /// The solution at its LGR nodes.
    pub nodes: Dense,
    /// A second trajectory drawn dashed (e.g. re-integrated), if any.
    pub overlay: Option<&'a Dense>,
    /// Times where the thrust crosses the middle of [T_min, T_max]
    /// (between nodes, linearly interpolated), with `true` for upward.
    pub switches: Vec<(f64, bool)>,
    /// The times of the mesh's inner interval breaks \[s\] (none on the
    /// global mesh).
    pub breaks_s: Vec<f64>,
}

impl<'a> PlotData<'a> {
    pub fn new(
        scenario: &'a Scenario,
        settings: &'a SolverSettings,
        solution: &'a Solution,
        dense: &'a Dense,
        overlay: Option<&'a Dense>,
    ) -> Self {
        let nodes = Dense::nodes_of(solution);
        let v = &scenario.vehicle;
        let mid = 0.5 * (v.min_thrust_n + v.max_thrust_n);
        let mut switches = Vec::new();
        if v.max_thrust_n > v.min_thrust_n {
            for k in 1..nodes.len() {
                let (a, b) = (nodes.thrust_n[k - 1] - mid, nodes.thrust_n[k] - mid);
                if (a < 0.0) != (b < 0.0) {
                    let (t0, t1) = (nodes.t_s[k - 1], nodes.t_s[k]);
                    switches.push((t0 + (t1 - t0) * a / (a - b), b > a));
                }
            }
        }
        let b = &solution.mesh.breaks_tau;
        let breaks_s = b
            .iter()
            .skip(1)
            .take(b.len().saturating_sub(2))
            .map(|tau| 0.5 * (tau + 1.0) * solution.tf_s)
            .collect();
        PlotData {
            scenario,
            settings,
            solution,
            dense,
            nodes,
            overlay,
            switches,
            breaks_s,
        }
    }

    /// The method that ran, as the plots name it: in the title (SCvx with
    /// its formulation), and for its iterations.
    pub(super) fn method_names(&self) -> MethodNames {
        let names = self.solution.method.names();
        MethodNames {
            title: format!(
                "{}, {} formulation",
                names.title,
                self.solution.formulation_label(self.settings.formulation)
            ),
            iterations: names.iteration,
        }
    }

    pub(super) fn title(&self) -> String {
        let method = self.method_names().title;
        let mesh = match (self.solution.intervals, &self.solution.refinement) {
            (1, _) => String::new(),
            (m, Some(r)) => format!(" over {m} intervals (refined, {} passes)", r.passes.len()),
            (m, None) => format!(" over {m} intervals"),
        };
        format!(
            "{}: N = {}{mesh}, {method}, {}, t_f = {:.3} s, final mass {:.1} kg",
            self.scenario.name,
            self.solution.nodes,
            self.solution.status.as_str(),
            self.solution.tf_s,
            self.solution.final_mass_kg
        )
    }
}
