//! A scenario file's tables as serde reads and writes them: [`Case`] with
//! the problem's tables at the top level, and `[discretization]` with its
//! two optional guesses, resolved by [`crate::input::guess::resolve`] once
//! the state is known (issue 29).

use serde::{Deserialize, Serialize};

use crate::input::mesh_layout::MeshLayout;
use crate::input::scenario::{
    Case, Constraints, Discretization, Environment, InitialState, ModelKind, Scenario,
    TerminalState, Vehicle,
};
use crate::input::settings::SolverSettings;

/// `[discretization]` as a scenario file holds it: the two guesses may be
/// left out (resolved by [`crate::input::guess::resolve`] once the state is
/// known).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DiscretizationFile {
    nodes: usize,
    #[serde(default = "crate::input::scenario::one")]
    intervals: usize,
    #[serde(default)]
    tf_guess_s: Option<f64>,
    #[serde(default)]
    final_mass_guess_kg: Option<f64>,
    #[serde(default)]
    mesh: Option<MeshLayout>,
}

/// A scenario file's tables, for serde: [`Case`] with the problem's tables at
/// the top level (`D`: the discretization as written, or as read with its
/// optional guesses).
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct CaseFile<D> {
    name: String,
    #[serde(default, skip_serializing_if = "ModelKind::is_planar")]
    model: ModelKind,
    vehicle: Vehicle,
    environment: Environment,
    initial: InitialState,
    terminal: TerminalState,
    discretization: D,
    #[serde(default, skip_serializing_if = "Constraints::is_empty")]
    constraints: Constraints,
    #[serde(default)]
    solver: SolverSettings,
}

impl Serialize for Case {
    fn serialize<S: serde::Serializer>(&self, ser: S) -> Result<S::Ok, S::Error> {
        let s = self.scenario.clone();
        CaseFile {
            name: s.name,
            model: s.model,
            vehicle: s.vehicle,
            environment: s.environment,
            initial: s.initial,
            terminal: s.terminal,
            discretization: s.discretization,
            constraints: s.constraints,
            solver: self.solver.clone(),
        }
        .serialize(ser)
    }
}

impl<'de> Deserialize<'de> for Case {
    fn deserialize<D: serde::Deserializer<'de>>(de: D) -> Result<Self, D::Error> {
        let f = CaseFile::<DiscretizationFile>::deserialize(de)?;
        let d = f.discretization;
        let mut scenario = Scenario {
            name: f.name,
            model: f.model,
            vehicle: f.vehicle,
            environment: f.environment,
            initial: f.initial,
            terminal: f.terminal,
            discretization: Discretization {
                nodes: d.nodes,
                intervals: d.intervals,
                tf_guess_s: f64::NAN,
                final_mass_guess_kg: f64::NAN,
                mesh: d.mesh,
            },
            constraints: f.constraints,
        };
        let warnings =
            crate::input::guess::resolve(&mut scenario, d.tf_guess_s, d.final_mass_guess_kg);
        Ok(Case {
            scenario,
            solver: f.solver,
            warnings,
        })
    }
}
