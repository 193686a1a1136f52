//! The re-plan sequence of `bellyflop sim` (the paper's case, the default
//! configuration, seed 1, run 0), for the latency bench
//! (`tests/c/bench_latency.c` and `examples/bench_latency.rs`).
//!
//! `cargo run --release -p bellyflop-c --example sim_replans -- DIR` flies
//! the run as `bellyflop sim` does and writes into DIR:
//!
//! - `replans.txt`: one line per state, `t_s x_m z_m vx_mps vz_mps
//!   theta_rad pitch_rate_radps mass_kg gimbal_rad`: first the true initial
//!   state (t = 0), then the true plant state at each flight time at which
//!   the sim re-planned. The sim re-planned from the measured state (the
//!   true one with navigation noise, filtered), which the flight does not
//!   record; the true state at the same instant is the closest it keeps.
//!   The nozzle angle is held within the plans' gimbal limit, as guidance's
//!   `Planning::start` holds it.
//! - `planning.toml`: the problem guidance re-plans on, for the default
//!   guidance settings: the paper's case with the soft thrust margin, the
//!   gimbal margins, the gate above the pad as the terminal state, the soft
//!   lateral terminal weight and the re-plan mesh (guidance's
//!   `Planning::new` and `set_up_replans`, which are private to guidance:
//!   this copies what they do). Not reproduced: the wind estimate of each
//!   re-plan (the C API plans in the problem's steady wind) and
//!   `continue_missed` (the C API warm-starts from its last solved plan).
use std::path::PathBuf;

use bellyflop::guidance::SimConfig;
use bellyflop::Case;

fn main() {
    let dir = PathBuf::from(std::env::args().nth(1).expect("usage: sim_replans DIR"));
    std::fs::create_dir_all(&dir).expect("create DIR");
    let case = Case::paper();
    let config = SimConfig::default();
    let flight = config
        .fly(&case, 1, 0, true)
        .expect("the paper's case flies");
    let g = &config.guidance;

    // The planning problem (guidance::planning, for these settings).
    assert!(g.thrust_margin_soft, "the default thrust margin is soft");
    let mut planning = case.clone();
    planning.solver.thrust_margin_frac = g.thrust_margin_frac;
    planning.solver.thrust_margin_weight = g.thrust_margin_weight;
    planning.solver.terminal_lateral_weight = g.terminal_lateral_weight;
    let s = &mut planning.scenario;
    s.terminal.z_m += g.gate_height_m;
    s.terminal.vz_mps -= g.gate_speed_mps;
    s.vehicle.max_gimbal_deg *= 1.0 - g.gimbal_margin_frac;
    s.vehicle.max_gimbal_rate_degps *= 1.0 - g.gimbal_margin_frac;
    if g.replan_nodes > 0 {
        s.discretization.nodes = g.replan_nodes;
        s.discretization.intervals = s.discretization.intervals.min(g.replan_nodes / 2);
    }
    let gimbal_max = s.vehicle.max_gimbal_deg.to_radians();
    planning.validate().expect("the planning problem is valid");
    let toml = toml::to_string(&planning).expect("a case serializes");
    std::fs::write(dir.join("planning.toml"), toml).expect("write planning.toml");

    // The states: the initial one, then one per re-plan.
    let mut out = String::new();
    let mut line = |t: f64, x: &bellyflop::sim::PlantState| {
        let d = x.gimbal_rad.clamp(-gimbal_max, gimbal_max);
        out.push_str(&format!(
            "{t:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {d:e}\n",
            x.x_m, x.z_m, x.vx_mps, x.vz_mps, x.theta_rad, x.pitch_rate_radps, x.mass_kg
        ));
    };
    let first = flight.trace.first().expect("a trace");
    line(0.0, &first.state);
    for event in &flight.replans {
        let sample = flight
            .trace
            .iter()
            .find(|s| s.t_s == event.time_s)
            .expect("the trace has a sample at each re-plan's time");
        line(event.time_s, &sample.state);
    }
    std::fs::write(dir.join("replans.txt"), out).expect("write replans.txt");
    eprintln!(
        "sim_replans: {} re-plans of `bellyflop sim` (seed 1, run 0) into {}",
        flight.replans.len(),
        dir.display()
    );
}
