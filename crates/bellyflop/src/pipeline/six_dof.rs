//! The 6-DoF solve of a scenario (issue 38): the direct method's cold solve
//! of the 6-DoF transcription, the 6-DoF polish of its controls as flown
//! ([`polish::six_dof`]), then the check of the published controls as
//! flown, with statuses that are claims as in the planar pipeline.
//!
//! The controls fly as the references fly them ([`flight::collocation_controls`]:
//! the thrust linear between the node times, each gimbal angle linear
//! between the nodes at its secant rate), re-integrated by DOP853 at
//! 1e-10 with steps of at most [`path::STEP_S`]. A `solved` answer must:
//!
//! - land within the scenario's tolerances (`solver.landing_position_tolerance_m`,
//!   `solver.landing_velocity_tolerance_mps`), in 3-D;
//! - stay above the ground before t_f, in continuous time: between two
//!   accepted steps z is the cubic Hermite interpolant of (z, V_z)
//!   ([`path::hermite_minimum`]), within [`GROUND_TOLERANCE_M`];
//! - hold the control bounds along the flight, exactly: the thrust is linear
//!   between in-bound values, the gimbal angles are linear between nodes
//!   inside the (convex) nozzle cone, and each interval's secant rate is
//!   checked against the rate disc.
//!
//! Otherwise a converged answer is `inaccurate`, with the reason: at the
//! usual N = 20 the raw answers miss the pad by metres, and where the
//! polish does not converge the raw answer is published with its flown
//! miss and the polish's reason (BENCHMARKS.md, "Issue 38").

use serde::Serialize;

use crate::input::scenario::Scenario;
use crate::input::settings::SolverSettings;
use crate::method::direct::six_dof::{solve_cold, Nlp6};
use crate::method::observer::Observer;
use crate::polish::{self, six_dof::Controls6};
use crate::problem::model::{Dynamics, Field};
use crate::problem::six_dof::{su, sx, SixDof, NU, NX};
use crate::solution::{Status, GROUND_TOLERANCE_M};
use crate::verify::flight;
use crate::verify::ode::Dop853;
use crate::verify::path;

pub mod settings;
pub use settings::check_settings;

/// How far a control may stand beyond its bound, as a fraction of the
/// bound's scale: rounding (as the planar check's
/// [`path::CONTROL_TOLERANCE`]).
const CONTROL_TOLERANCE: f64 = path::CONTROL_TOLERANCE;

/// A model's values at the mesh's times, with their names and units from
/// the model's field table ([`Dynamics::STATE`], [`Dynamics::CONTROL`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Table {
    pub names: Vec<&'static str>,
    pub units: Vec<&'static str>,
    /// One row per time.
    pub rows: Vec<Vec<f64>>,
}

impl Table {
    fn new(fields: &[Field], rows: Vec<Vec<f64>>) -> Self {
        Table {
            names: fields.iter().map(|f| f.name).collect(),
            units: fields.iter().map(|f| f.unit).collect(),
            rows,
        }
    }
}

/// The answer's controls flown (module docs): where they land, and the
/// worst of each path constraint along the flight.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlownCheck {
    /// ‖r(t_f) − r_f‖ \[m\].
    pub landing_miss_m: f64,
    /// ‖V(t_f) − V_f‖ \[m/s\].
    pub landing_miss_mps: f64,
    /// The least altitude above the pad before t_f, in continuous time \[m\].
    pub lowest_altitude_m: f64,
    /// The largest nozzle angle from the body axis along the flight \[deg\].
    pub max_gimbal_deg: f64,
    /// The largest gimbal rate ‖(χ1, χ2)‖ flown \[deg/s\].
    pub max_gimbal_rate_degps: f64,
    /// The thrust's range flown \[N\].
    pub thrust_range_n: (f64, f64),
    /// The largest |‖q‖ − 1| at the integrator's steps.
    pub quaternion_norm_error: f64,
    /// The integrator's accepted steps.
    pub steps: usize,
}

/// The answer of the 6-DoF solve.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SixDofSolution {
    /// `"6dof"`.
    pub model: &'static str,
    pub status: Status,
    pub message: String,
    pub tf_s: f64,
    pub final_mass_kg: f64,
    /// Fuel used \[kg\].
    pub fuel_kg: f64,
    /// The direct method's iterations.
    pub iterations: usize,
    /// The polish's iterations, when it ran.
    pub polish_iterations: Option<usize>,
    pub solve_time_ms: f64,
    pub nodes: usize,
    /// The N + 1 node times \[s\] (the states'), the first N the
    /// collocation points (the controls').
    pub t_s: Vec<f64>,
    pub states: Table,
    pub controls: Table,
    /// The controls as published and flown, when polished
    /// ([`polish::six_dof::Controls6`]).
    pub controls_flown: Option<Controls6>,
    /// The check of the controls flown (the polished ones when `solved`,
    /// else the raw ones), when the solve converged.
    pub flown: Option<FlownCheck>,
}

/// Solve the 6-DoF problem of `scenario` from the 6-DoF start `x0` (module
/// docs): the direct method's cold solve with `settings.direct`, on the
/// scenario's mesh, from its t_f and final-mass guesses; then, unless
/// `settings.polish` is off, the 6-DoF polish ([`polish::six_dof`]) of its
/// controls; then the check of the controls as published, flown, against
/// the scenario's landing tolerances. It reads no other setting:
/// [`check_settings`] refuses those that would be ignored (the CLI and the
/// Python binding call it before solving).
pub fn solve(
    scenario: &Scenario,
    x0: [f64; NX],
    settings: &SolverSettings,
    observer: &mut dyn Observer,
) -> SixDofSolution {
    let clock = std::time::Instant::now();
    let model = SixDof::new(&scenario.vehicle, &scenario.environment);
    let mesh = scenario.discretization.collocation_mesh();
    let nlp = Nlp6::six_dof(model, mesh, x0, &scenario.terminal);
    let d = &scenario.discretization;
    let r = solve_cold(
        &nlp,
        d.tf_guess_s,
        d.final_mass_guess_kg,
        &settings.direct,
        observer,
    );
    let tf_s = nlp.tf_s(&r.w);
    let (states, controls) = nlp.physical_answer(&r.w);
    let states: Vec<[f64; NX]> = states
        .chunks_exact(NX)
        .map(|s| std::array::from_fn(|i| s[i]))
        .collect();
    let controls: Vec<[f64; NU]> = controls
        .chunks_exact(NU)
        .map(|u| std::array::from_fn(|j| u[j]))
        .collect();
    let raw = Controls6 {
        tf_s,
        tau: nlp.mesh.nodes.clone(),
        thrust_n: controls.iter().map(|u| u[su::T]).collect(),
        delta_rad: states
            .iter()
            .map(|s| [s[sx::DELTA], s[sx::DELTA + 1]])
            .collect(),
    };
    let t_s = raw.times_s();
    let final_mass_kg = states.last().map_or(f64::NAN, |s| s[sx::M]);
    let mut sol = SixDofSolution {
        model: "6dof",
        status: r.status,
        message: r.message,
        tf_s,
        final_mass_kg,
        fuel_kg: x0[sx::M] - final_mass_kg,
        iterations: r.history.len(),
        polish_iterations: None,
        solve_time_ms: 0.0,
        nodes: nlp.n,
        t_s,
        states: Table::new(SixDof::STATE, states.iter().map(|s| s.to_vec()).collect()),
        controls: Table::new(
            SixDof::CONTROL,
            controls.iter().map(|u| u.to_vec()).collect(),
        ),
        controls_flown: None,
        flown: None,
    };
    if sol.status == Status::Solved {
        let polished = settings
            .polish
            .then(|| polish::six_dof::polish(&nlp.model, x0, &scenario.terminal, &raw));
        finish(scenario, settings, &nlp.model, x0, &raw, polished, &mut sol);
    }
    sol.solve_time_ms = clock.elapsed().as_secs_f64() * 1e3;
    sol
}

/// After a converged solve: the polished controls when they fly and hold
/// every bound (the answer then `solved`, its tables the flight's at the
/// node times), else the raw answer's controls flown, `inaccurate` where
/// they miss or break a bound (module docs).
fn finish(
    scenario: &Scenario,
    settings: &SolverSettings,
    model: &SixDof,
    x0: [f64; NX],
    raw: &Controls6,
    polished: Option<polish::six_dof::Polished6>,
    sol: &mut SixDofSolution,
) {
    let mut why_not = String::new();
    if let Some(p) = polished {
        sol.polish_iterations = Some(p.iterations);
        if p.converged {
            match fly_and_check(scenario, settings, model, x0, &p.controls) {
                Ok((flight, check, reasons)) if reasons.is_empty() => {
                    publish(&p.controls, &flight, check, sol);
                    return;
                }
                Ok((_, _, reasons)) => {
                    why_not = format!("; the polished controls, flown, {}", reasons.join(", and "))
                }
                Err(e) => why_not = format!("; the polished controls could not be flown ({e})"),
            }
        } else {
            why_not = format!("; the polish did not converge ({})", p.message);
        }
    }
    match fly_and_check(scenario, settings, model, x0, raw) {
        Ok((_, check, reasons)) => {
            if !reasons.is_empty() || !why_not.is_empty() {
                sol.status = Status::Inaccurate;
                sol.message = format!(
                    "the raw collocation controls, flown (DOP853, as the references fly them), {}{why_not}",
                    if reasons.is_empty() {
                        "land and hold the bounds".to_string()
                    } else {
                        reasons.join(", and ")
                    }
                );
            }
            sol.flown = Some(check);
        }
        Err(e) => {
            sol.status = Status::Inaccurate;
            sol.message =
                format!("the controls could not be flown by re-integration ({e}){why_not}");
        }
    }
}

/// A polished answer, `solved`: its flown controls, and its tables the
/// flight's states at the node times with the controls flown on each node
/// interval (T at its start, the secant rates).
fn publish(
    c: &Controls6,
    flight: &flight::Flight<NX>,
    check: FlownCheck,
    sol: &mut SixDofSolution,
) {
    let t_s = c.times_s();
    let mut rows = Vec::with_capacity(t_s.len());
    let mut at = 0;
    for &t in &t_s {
        while at + 1 < flight.t_s.len() && flight.t_s[at] < t {
            at += 1;
        }
        rows.push(flight.states[at].to_vec());
    }
    let end = flight.end();
    sol.status = Status::Solved;
    sol.message = String::new();
    sol.tf_s = c.tf_s;
    sol.final_mass_kg = end[sx::M];
    sol.fuel_kg = flight.states[0][sx::M] - end[sx::M];
    sol.states = Table::new(SixDof::STATE, rows);
    sol.controls = Table::new(
        SixDof::CONTROL,
        (0..c.thrust_n.len())
            .map(|k| c.at_fraction(k, 0.0).to_vec())
            .collect(),
    );
    sol.t_s = t_s;
    sol.controls_flown = Some(c.clone());
    sol.flown = Some(check);
}

/// Fly the controls `c` from x0 and check them (module docs): the flight,
/// its measures, and the reasons it fails, if any.
fn fly_and_check(
    scenario: &Scenario,
    settings: &SolverSettings,
    model: &SixDof,
    x0: [f64; NX],
    c: &Controls6,
) -> Result<(flight::Flight<NX>, FlownCheck, Vec<String>), crate::verify::ode::IntegrationError> {
    let ode = Dop853 {
        h_max: path::STEP_S,
        ..Dop853::default()
    };
    let f = flight::fly::<SixDof, NX, NU>(model, x0, &c.times_s(), |k, t| c.at(k, t), &ode)?;
    let measured = measure(scenario, c, &f);
    let mut reasons = Vec::new();
    let (tol_m, tol_mps) = (
        settings.landing_position_tolerance_m,
        settings.landing_velocity_tolerance_mps,
    );
    if !(at_most(measured.landing_miss_m, tol_m) && at_most(measured.landing_miss_mps, tol_mps)) {
        reasons.push(format!(
            "land {:.3} m and {:.3} m/s from the target, beyond the tolerances of {tol_m} m and {tol_mps} m/s",
            measured.landing_miss_m, measured.landing_miss_mps
        ));
    }
    let floor = scenario.terminal.z_m.min(f.end()[sx::Z]) - GROUND_TOLERANCE_M;
    if !at_most(floor, measured.lowest_altitude_m + scenario.terminal.z_m) {
        reasons.push(format!(
            "reach {:.3} m below the pad before t_f",
            -measured.lowest_altitude_m
        ));
    }
    let p = &model.planar;
    let (lo, hi) = measured.thrust_range_n;
    let thrust_tol = CONTROL_TOLERANCE * (p.max_thrust_n - p.min_thrust_n);
    if !(at_most(p.min_thrust_n - thrust_tol, lo) && at_most(hi, p.max_thrust_n + thrust_tol)) {
        reasons.push(format!(
            "fly a thrust of {lo:.0}–{hi:.0} N, outside its bounds"
        ));
    }
    let gimbal_max_deg = p.max_gimbal_rad.to_degrees();
    if !at_most(
        measured.max_gimbal_deg,
        gimbal_max_deg * (1.0 + CONTROL_TOLERANCE),
    ) {
        reasons.push(format!(
            "tilt the nozzle {:.4}° from the axis, beyond δ_max = {gimbal_max_deg:.4}°",
            measured.max_gimbal_deg
        ));
    }
    let rate_max_degps = p.max_gimbal_rate_radps.to_degrees();
    if !at_most(
        measured.max_gimbal_rate_degps,
        rate_max_degps * (1.0 + CONTROL_TOLERANCE),
    ) {
        reasons.push(format!(
            "turn the nozzle at {:.4}°/s, beyond χ_max = {rate_max_degps:.4}°/s",
            measured.max_gimbal_rate_degps
        ));
    }
    if !at_most(p.dry_mass_kg, f.end()[sx::M]) {
        reasons.push(format!(
            "end at {:.3} kg, below the dry mass of {} kg",
            f.end()[sx::M],
            p.dry_mass_kg
        ));
    }
    Ok((f, measured, reasons))
}

/// a ≤ b, false when either is NaN (so that a NaN fails a check).
fn at_most(a: f64, b: f64) -> bool {
    a <= b
}

/// The flown checks' values (module docs).
fn measure(scenario: &Scenario, c: &Controls6, f: &flight::Flight<NX>) -> FlownCheck {
    let target = &scenario.terminal;
    let end = f.end();
    let pad = [target.x_m, 0.0, target.z_m];
    let rest = [target.vx_mps, 0.0, target.vz_mps];
    let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let landing_miss_m = norm(std::array::from_fn(|i| end[sx::X + i] - pad[i]));
    let landing_miss_mps = norm(std::array::from_fn(|i| end[sx::VX + i] - rest[i]));
    // The ground before t_f: the accepted steps, and the Hermite minima
    // between them.
    let mut lowest = f64::INFINITY;
    for (k, pair) in f.states.windows(2).enumerate() {
        let (a, b) = (&pair[0], &pair[1]);
        let h = f.t_s[k + 1] - f.t_s[k];
        lowest = lowest.min(a[sx::Z]).min(b[sx::Z]);
        if h > 0.0 {
            if let Some((_, z)) = path::hermite_minimum(a[sx::Z], a[sx::VZ], b[sx::Z], b[sx::VZ], h)
            {
                lowest = lowest.min(z);
            }
        }
    }
    // The nozzle's angle from the axis, cos⁻¹(cos δ1·cos δ2), at the nodes:
    // linear between them inside the convex cone.
    let max_gimbal_deg = c
        .delta_rad
        .iter()
        .map(|d| (d[0].cos() * d[1].cos()).clamp(-1.0, 1.0).acos())
        .fold(0.0, f64::max)
        .to_degrees();
    let max_gimbal_rate_degps = (0..c.thrust_n.len())
        .map(|k| {
            let u = c.at_fraction(k, 0.0);
            u[su::CHI].hypot(u[su::CHI + 1])
        })
        .fold(0.0, f64::max)
        .to_degrees();
    let thrust = c.thrust_n.iter().copied();
    let thrust_range_n = (
        thrust.clone().fold(f64::INFINITY, f64::min),
        thrust.fold(f64::NEG_INFINITY, f64::max),
    );
    let quaternion_norm_error = f
        .states
        .iter()
        .map(|s| {
            let q = &s[sx::Q..sx::Q + 4];
            (q.iter().map(|v| v * v).sum::<f64>().sqrt() - 1.0).abs()
        })
        .fold(0.0, f64::max);
    FlownCheck {
        landing_miss_m,
        landing_miss_mps,
        lowest_altitude_m: lowest - target.z_m,
        max_gimbal_deg,
        max_gimbal_rate_degps,
        thrust_range_n,
        quaternion_norm_error,
        steps: f.states.len() - 1,
    }
}

impl SixDofSolution {
    /// The answer as one JSON object (its fields as named above).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("a 6-DoF solution serializes")
    }

    /// The node table as CSV: `t_s`, the states' names, then the
    /// controls' (empty at t_f, where the collocation has none).
    pub fn to_csv(&self) -> String {
        let mut out = String::from("t_s");
        for name in self.states.names.iter().chain(&self.controls.names) {
            out.push(',');
            out.push_str(name);
        }
        out.push('\n');
        for (k, t) in self.t_s.iter().enumerate() {
            out.push_str(&format!("{t}"));
            for v in &self.states.rows[k] {
                out.push_str(&format!(",{v}"));
            }
            match self.controls.rows.get(k) {
                Some(u) => u.iter().for_each(|v| out.push_str(&format!(",{v}"))),
                None => self.controls.names.iter().for_each(|_| out.push(',')),
            }
            out.push('\n');
        }
        out
    }
}
