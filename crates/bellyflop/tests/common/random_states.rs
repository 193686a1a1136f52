//! The random states of issue 18, shared by `tests/random_states.rs` (24
//! seeded states through proptest) and `examples/random_states_campaign.rs`
//! (the local campaign of docs/reliability.md): a box wider than the
//! documented envelope, low and fast states too, and the invariants every
//! answer of `bellyflop::solve` keeps.
#![allow(dead_code)]

use bellyflop::{Case, Method, Status};

/// (x, z, Vx, Vz, θ, m0) ranges: [m, m, m/s, m/s, deg, kg].
pub const BOX: [(f64, f64); 6] = [
    (-400.0, 400.0),
    (150.0, 1000.0),
    (-30.0, 30.0),
    (-120.0, -40.0),
    (60.0, 110.0),
    (100_000.0, 128_000.0),
];

/// The paper's case from the state `x` = (x, z, Vx, Vz, θ, m0), with N nodes.
pub fn scenario(x: [f64; 6], method: Method, nodes: usize) -> Case {
    let mut s = Case::paper();
    let i = &mut s.scenario.initial;
    (i.x_m, i.z_m, i.vx_mps, i.vz_mps, i.theta_deg, i.mass_kg) =
        (x[0], x[1], x[2], x[3], x[4], x[5]);
    s.scenario.discretization.final_mass_guess_kg = x[5] - 5000.0;
    s.scenario.discretization.nodes = nodes;
    s.solver.method = method;
    s
}

/// The invariants of one answer: JSON for every status, naming status and
/// method; exit code 0 exactly for `solved`; a reason for every other
/// status; `solved` means every check passes.
pub fn check(s: &Case, sol: &bellyflop::Solution) -> Result<(), String> {
    let v = sol.to_json();
    let fail = |m: String| Err(format!("{:?} ({}): {m}", sol.status, sol.message));
    if v["status"].as_str() != Some(sol.status.as_str())
        || v["method"].as_str() != Some(s.solver.method.as_str())
    {
        return fail(format!("JSON names {} / {}", v["status"], v["method"]));
    }
    if (sol.status.exit_code() == 0) != (sol.status == Status::Solved) {
        return fail(format!("exit code {}", sol.status.exit_code()));
    }
    if sol.status != Status::Solved {
        return if sol.message.is_empty() {
            fail("no reason".into())
        } else {
            Ok(())
        };
    }
    let c = &sol.checks;
    if !sol.trajectory.is_finite() {
        return fail("not finite".into());
    }
    if c.max_defect >= 1e-6 {
        return fail(format!("defect {}", c.max_defect));
    }
    if c.min_altitude_margin_m <= -1e-3 {
        return fail(format!("{} m below the ground", -c.min_altitude_margin_m));
    }
    if c.thrust_bound_violation_n >= 1e-6 * s.scenario.vehicle.max_thrust_n {
        return fail(format!(
            "thrust {} N out of bounds",
            c.thrust_bound_violation_n
        ));
    }
    if c.thrust_alignment_min <= 0.0 {
        return fail(format!("thrust backwards {}", c.thrust_alignment_min));
    }
    Ok(())
}
