//! The labelled set's data, shared by `tests/labelled.rs` and
//! `examples/labelled_report.rs` (each uses part of it).
#![allow(dead_code)]

use bellyflop::{Case, Method, Solution};
use serde::Deserialize;

pub const DATA: &str = include_str!("../data/labelled_states.toml");

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Label {
    Feasible,
    Infeasible,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Set {
    Envelope,
    Outside,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Entry {
    pub name: String,
    pub label: Label,
    pub set: Set,
    /// The method whose `solved` answer is the evidence (feasible states),
    /// and its number of collocation points.
    pub method: Option<Method>,
    pub nodes: Option<usize>,
    pub x_m: f64,
    pub z_m: f64,
    pub vx_mps: f64,
    pub vz_mps: f64,
    pub theta_deg: f64,
    pub mass_kg: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Data {
    pub state: Vec<Entry>,
}

pub fn entries() -> Vec<Entry> {
    toml::from_str::<Data>(DATA)
        .expect("labelled_states.toml parses")
        .state
}

/// The paper's case from the entry's initial state.
pub fn scenario(e: &Entry, method: Method) -> Case {
    let mut s = Case::paper();
    s.scenario.discretization.nodes = e.nodes.unwrap_or(20);
    s.scenario.initial.x_m = e.x_m;
    s.scenario.initial.z_m = e.z_m;
    s.scenario.initial.vx_mps = e.vx_mps;
    s.scenario.initial.vz_mps = e.vz_mps;
    s.scenario.initial.theta_deg = e.theta_deg;
    s.scenario.initial.mass_kg = e.mass_kg;
    s.scenario.discretization.final_mass_guess_kg =
        (e.mass_kg - 5000.0).max(s.scenario.vehicle.dry_mass_kg);
    s.solver.method = method;
    s.validate()
        .unwrap_or_else(|err| panic!("{}: {err}", e.name));
    s
}

pub fn in_envelope(e: &Entry) -> bool {
    e.x_m.abs() <= 200.0
        && (500.0..=800.0).contains(&e.z_m)
        && e.vx_mps.abs() <= 15.0
        && (-95.0..=-70.0).contains(&e.vz_mps)
        && (80.0..=95.0).contains(&e.theta_deg)
        && (110_000.0..=125_000.0).contains(&e.mass_kg)
}

/// The set is as documented: at least 40 states, both labels and both sets
/// well represented, and `set` matches the envelope's bounds.
pub fn describe(sol: &Solution) -> String {
    let short: String = sol.message.chars().take(90).collect();
    format!(
        "{:<13} {:>4} it  {short}",
        sol.status.as_str(),
        sol.iterations
    )
}
