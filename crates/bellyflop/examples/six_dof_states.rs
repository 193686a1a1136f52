//! Solve 6-DoF states with the direct method (issue 38), for the
//! side-by-side with IPOPT in `bench/six_dof_vs_ipopt.py`: reads a JSON
//! file of states and guesses, solves each cold (`six_dof::solve_cold`: the
//! planar default's coarse start, then N from its answer) `repeat` times, and prints one JSON object with, per state, the
//! status, iterations, t_f, m_f, the median wall time of the solve (the
//! transcription's construction and the guess included) and the answer.
//!
//!     cargo run --release -p bellyflop --example six_dof_states -- STATES.json
//!
//! STATES.json: {"nodes": 20, "repeat": 5, "states": [{"name": ...,
//! "start": [16 numbers], "tf_guess_s": ..., "mf_guess_kg": ...}, ...],
//! "direct": {...}} (the last optional: `[solver.direct]`'s settings).
//! The vehicle and the landing are the paper's.

use std::time::Instant;

use bellyflop::input::settings::DirectSettings;
use bellyflop::method::direct::six_dof::{self, Nlp6, NS};
use bellyflop::method::observer::Silent;
use bellyflop::problem::six_dof::{sx, SixDof};
use bellyflop::{Mesh, Scenario};
use serde_json::{json, Value};

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("an array")
        .iter()
        .map(|x| x.as_f64().expect("a number"))
        .collect()
}

fn main() {
    let path = std::env::args()
        .nth(1)
        .expect("usage: six_dof_states STATES.json");
    let text = std::fs::read_to_string(&path).expect("readable states file");
    let input: Value = serde_json::from_str(&text).expect("JSON");
    let nodes = input["nodes"].as_u64().unwrap_or(20) as usize;
    let repeat = input["repeat"].as_u64().unwrap_or(1).max(1) as usize;
    let paper = Scenario::paper();
    let model = SixDof::new(&paper.vehicle, &paper.environment);
    // Optional "direct": settings of the direct method, as a scenario's
    // `[solver.direct]` (the defaults otherwise).
    let settings: DirectSettings = match input.get("direct") {
        Some(v) => serde_json::from_value(v.clone()).expect("direct settings"),
        None => DirectSettings::default(),
    };
    // Optional "pipeline": true solves each state through
    // `pipeline::six_dof::solve` (the raw solve, the 6-DoF polish and the
    // flown check) instead of the raw solve alone.
    if input["pipeline"].as_bool().unwrap_or(false) {
        return pipeline(&input, nodes, repeat, settings);
    }
    let mut rows = Vec::new();
    for state in input["states"].as_array().expect("states") {
        let start: [f64; NS] = numbers(&state["start"]).try_into().expect("16 numbers");
        let (tf_guess, mf_guess) = (
            state["tf_guess_s"].as_f64().expect("tf_guess_s"),
            state["mf_guess_kg"].as_f64().expect("mf_guess_kg"),
        );
        let mut times = Vec::with_capacity(repeat);
        let mut last = None;
        for _ in 0..repeat {
            let t0 = Instant::now();
            let nlp = Nlp6::six_dof(model.clone(), Mesh::global(nodes), start, &paper.terminal);
            let r = six_dof::solve_cold(&nlp, tf_guess, mf_guess, &settings, &mut Silent);
            times.push(t0.elapsed().as_secs_f64() * 1e3);
            last = Some((nlp, r));
        }
        times.sort_by(f64::total_cmp);
        let (nlp, r) = last.expect("one solve");
        let (states, controls) = nlp.physical_answer(&r.w);
        rows.push(json!({
            "name": state["name"],
            "status": r.status,
            "iterations": r.history.len(),
            "coarse_iterations": r.history.iter().filter(|h| h.mesh_nodes < nodes).count(),
            "inertia_corrections": r.history.iter().filter(|h| h.inertia_correction > 0.0).count(),
            "line_search_trials": r.history.iter().map(|h| h.line_search_trials).sum::<usize>(),
            "restorations": r.history.iter().filter(|h| h.restoration).count(),
            "tf_s": nlp.tf_s(&r.w),
            "mf_kg": nlp.physical(sx::M, r.w[nlp.idx(nlp.n, sx::M)]),
            "time_ms": times[times.len() / 2],
            "states": states,
            "controls": controls,
        }));
    }
    println!(
        "{}",
        json!({ "nodes": nodes, "repeat": repeat, "results": rows })
    );
}

/// The states through the 6-DoF pipeline: per state the status, its
/// message, the polish's iterations, t_f, m_f, the flown check and the
/// median wall time of the whole solve.
fn pipeline(input: &Value, nodes: usize, repeat: usize, direct: DirectSettings) {
    use bellyflop::pipeline::six_dof::solve;
    use bellyflop::SolverSettings;
    let settings = SolverSettings {
        direct,
        ..SolverSettings::default()
    };
    let mut rows = Vec::new();
    for state in input["states"].as_array().expect("states") {
        let start: [f64; NS] = numbers(&state["start"]).try_into().expect("16 numbers");
        let mut scenario = Scenario::paper();
        scenario.discretization.nodes = nodes;
        scenario.discretization.tf_guess_s = state["tf_guess_s"].as_f64().expect("tf_guess_s");
        scenario.discretization.final_mass_guess_kg =
            state["mf_guess_kg"].as_f64().expect("mf_guess_kg");
        let mut times = Vec::with_capacity(repeat);
        let mut last = None;
        for _ in 0..repeat {
            let t0 = Instant::now();
            let sol = solve(&scenario, start, &settings, &mut Silent);
            times.push(t0.elapsed().as_secs_f64() * 1e3);
            last = Some(sol);
        }
        times.sort_by(f64::total_cmp);
        let sol = last.expect("one solve");
        eprintln!(
            "{}: {} in {:.0} ms, {:?} polish iterations",
            state["name"],
            sol.status.as_str(),
            times[times.len() / 2],
            sol.polish_iterations
        );
        rows.push(json!({
            "name": state["name"],
            "status": sol.status,
            "message": sol.message,
            "iterations": sol.iterations,
            "polish_iterations": sol.polish_iterations,
            "tf_s": sol.tf_s,
            "mf_kg": sol.final_mass_kg,
            "flown": sol.flown,
            "controls_flown": sol.controls_flown,
            "time_ms": times[times.len() / 2],
        }));
    }
    println!(
        "{}",
        json!({ "nodes": nodes, "repeat": repeat, "results": rows })
    );
}
