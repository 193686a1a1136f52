//! Landing precision by re-propagation (the check of the paper's Tables 4–5).
//!
//! A collocation solution meets the dynamics only at its nodes. To see how well
//! its controls actually land the vehicle, [`propagate`] integrates the full
//! nonlinear model of Eq. (1)–(3) in mass and thrust form
//! ([`dynamics::rhs_physical`], state x, z, Vx, Vz, θ, w, m) from the solution's
//! initial state to t_f, with the thrust T(t) and nozzle angle δ(t) interpolated
//! in time from the solution, and measures the miss against the scenario's
//! terminal state.
//!
//! # The integrator
//!
//! [`Dop853`] is the explicit Runge–Kutta method of Dormand and Prince of order
//! 8 with embedded error estimators of orders 5 and 3 and the step-size control of
//! Hairer's `DOP853` (Hairer, Nørsett, Wanner, *Solving ODEs I*, 2nd ed., §II.10;
//! coefficients from `dop853.f`). It is our own code rather than a crate because:
//! `ode_solvers` 0.6 (which has `Dop853`) depends on nalgebra 0.34 while this
//! workspace uses 0.35, so its state vectors would be a second, incompatible
//! nalgebra in the build, and it collects every output point of a call into its
//! own result vectors, which the segment-by-segment integration below does not
//! need; `diffsol` targets stiff and implicit problems and brings faer and a large
//! dependency tree for what is, here, one explicit method on a 7-state system.
//! The method is ~200 lines, checked in the tests against analytic solutions and
//! for its eighth order of convergence.
//!
//! # The controls
//!
//! The thrust is known at the N collocation points (the last entry of
//! [`Solution::thrust_n`], at t_f, holds the last collocation point's σ = T/m
//! times m(t_f), within [T_min, T_max]); δ is a
//! state known at all N + 1 nodes ([`Solution::delta_rad`]). Between nodes they
//! are interpolated by [`Interpolation::Linear`] or [`Interpolation::Pchip`]
//! (monotone piecewise cubic). The integration runs segment by segment between
//! node times, so that no step straddles a kink of the interpolant.
//!
//! [`NozzleModel::Angle`] (default) interpolates δ itself, as the paper's P1;
//! [`NozzleModel::Rate`] integrates δ̇ = χ (Eq. 8, problem P2) from the
//! interpolated gimbal rate χ instead.
//!
//! **Default: PCHIP with the nozzle angle.** On the paper's case the optimal
//! thrust is bang-bang. PCHIP follows the switch without overshoot (it never
//! leaves the range of the node values, so T stays within its bounds) and,
//! unlike the chords of linear interpolation, follows the smooth arcs of T and δ
//! to third order. Measured on the paper's case (`cargo run --release -p
//! bellyflop --example landing_precision`, and `bellyflop sweep
//! --interpolation linear|pchip`), position / velocity miss at t_f:
//!
//! | N | exact, PCHIP | exact, linear | paper form., PCHIP | paper form., linear |
//! |---|---|---|---|---|
//! | 15 | 1.123 m / 0.202 m/s | 2.218 / 0.358 | 0.469 / 0.187 | 3.108 / 0.892 |
//! | 20 | 1.317 / 0.648 | 2.565 / 0.803 | 0.808 / 0.323 | 2.112 / 0.662 |
//! | 30 | 0.167 / 0.076 | 0.761 / 0.195 | 0.452 / 0.186 | 0.895 / 0.286 |
//! | 40 | 0.400 / 0.250 | 0.581 / 0.217 | 0.324 / 0.138 | 0.513 / 0.172 |
//!
//! PCHIP lands closer in position in all eight cases and in velocity in seven.
//! Integrating the nozzle rate instead ([`NozzleModel::Rate`]) misses by 3 to
//! 72 m (exact formulation, N = 15 to 40): δ then accumulates the interpolation
//! error of χ, and the open-loop pitch dynamics amplify it.
//!
//! What remains is the thrust switch. The collocation's own polynomials (the
//! degree-(N−1) interpolant of T through the collocation points, the degree-N
//! interpolant of δ) land within 0.17 m and 0.07 m/s at N = 20, but that
//! thrust polynomial rings around the switch and leaves [T_min, T_max] by 2–13 %;
//! clipped to the bounds it misses by 4 m. Any realizable reconstruction of the
//! bang-bang thrust loses the ringing the collocated states were computed with,
//! and the miss shows up mainly as a pitch error that turns into a horizontal
//! position and velocity error. It is also sensitive to the solution itself:
//! the two formulations converge at N = 20 to points 0.6 kg apart in final mass,
//! which miss by 1.32 m and 0.81 m.
//!
//! **On an hp mesh** the controls are interpolated interval by interval
//! ([`Controls::interval_points`]), and **for a refined solution**
//! ([`crate::refine`], breaks at the switches) by the collocation's own
//! polynomials, as they can be flown ([`ControlSource::Collocation`],
//! [`crate::collocation::control_profile`]: within the bounds, held over the quadrature
//! cell of a point on a bound, and bang–bang inside the cell of a switch,
//! each point's impulse kept). On the paper's case refined to 1e-6 (6
//! passes, 96 points) the clamped polynomials landed 6 mm and 1.6 mm/s from
//! the pad where PCHIP's cubics, interval by interval, missed by 0.18 m and
//! 0.04 m/s (`bellyflop solve --mesh-tolerance 1e-6`, 2026-12-02); on the
//! refined envelope states the clamp lost up to 33 kg of propellant (the
//! propagation's mass error), the profile a fraction of a kilogram
//! (BENCHMARKS.md, "Mesh refinement", `bench/refinement.py`).

use serde::Serialize;

use crate::collocation::control_profile::Profile;
use crate::collocation::interpolation::{Interpolant, Interpolation};
use crate::flown::FlownControls;
use crate::input::scenario::Scenario;
use crate::problem::dynamics::{self, Model};
use crate::solution::Solution;
use crate::verify::ode::{Dop853, IntegrationError, Stats};

/// Where the nozzle angle of the propagation comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NozzleModel {
    /// Interpolate δ from its node values (problem P1). The default.
    #[default]
    Angle,
    /// Integrate δ̇ = χ with χ interpolated from the collocation points (Eq. 8, P2).
    Rate,
}

// ---------------------------------------------------------------------------
// Re-propagation of a solution
// ---------------------------------------------------------------------------

/// Options of [`propagate`].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Options {
    pub interpolation: Interpolation,
    pub nozzle: NozzleModel,
    pub integrator: Dop853,
    pub controls: ControlSource,
}

/// What the controls between the nodes are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ControlSource {
    /// `collocation` for a refined solution (its breaks are at the control
    /// switches), `nodes` otherwise. The default.
    #[default]
    Auto,
    /// [`Options::interpolation`] through the nodes (per interval on an hp
    /// mesh, see [`Controls::interval_points`]).
    Nodes,
    /// The collocation's own polynomials, per interval, as they can be
    /// flown: T and χ by [`crate::collocation::control_profile::Profile`] (degree
    /// n_k − 1 through its collocation points on interior arcs, held on the
    /// bounds, bang–bang across a switch, within the bounds), δ of degree
    /// n_k through its nodes, clamped. On a refined mesh the controls are
    /// smooth inside each interval, and these converge as the collocation
    /// does, where PCHIP's cubics do not (BENCHMARKS.md, "Mesh refinement").
    Collocation,
    /// The published controls of a polished answer
    /// ([`Solution::controls_flown`], [`crate::flown`]), piece by piece.
    /// `auto` picks them whenever the answer has them.
    Flown,
}

/// The miss at t_f against the scenario's terminal state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LandingError {
    /// ‖(x, z)(t_f) − (x_f, z_f)‖ \[m\].
    pub position_m: f64,
    /// ‖(Vx, Vz)(t_f) − (Vx_f, Vz_f)‖ [m/s].
    pub velocity_mps: f64,
    /// |θ(t_f) − θ_f| \[rad\].
    pub pitch_rad: f64,
    /// |w(t_f) − w_f| [rad/s].
    pub rate_radps: f64,
}

/// A re-propagated trajectory and its landing precision.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Propagation {
    pub options: Options,
    /// Times of the accepted integration steps, from 0 to t_f; every node time
    /// of the solution is among them.
    pub t_s: Vec<f64>,
    /// States (x, z, Vx, Vz, θ, w, m) at `t_s`, SI units and radians.
    pub states: Vec<[f64; 7]>,
    /// Nozzle angle δ at `t_s` \[rad\] (interpolated or integrated).
    pub delta_rad: Vec<f64>,
    pub landing_error: LandingError,
    /// m(t_f) of the propagation \[kg\].
    pub terminal_mass_kg: f64,
    /// Propagated minus optimized final mass \[kg\].
    pub mass_error_kg: f64,
    pub stats: Stats,
}

impl Propagation {
    /// The propagated state at t_f.
    pub fn final_state(&self) -> [f64; 7] {
        *self
            .states
            .last()
            .expect("a propagation has at least one state")
    }
}

/// Node data of a trajectory to re-propagate: node times and the controls at
/// them, and the initial state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Controls<'a> {
    /// Strictly increasing node times \[s\], from t_0 to t_f.
    pub t_s: &'a [f64],
    /// Thrust T at the node times \[N\].
    pub thrust_n: &'a [f64],
    /// Nozzle angle δ at the node times \[rad\] (used by [`NozzleModel::Angle`]).
    pub delta_rad: &'a [f64],
    /// Gimbal rate χ = δ̇ at the node times [rad/s] (used by [`NozzleModel::Rate`]).
    pub gimbal_rate_radps: &'a [f64],
    /// (x, z, Vx, Vz, θ, w, m) at t_0.
    pub initial: [f64; 7],
    /// The collocation points n_k of each mesh interval (Σ n_k = N); empty
    /// or one entry: one interpolant through every node. With several, T and
    /// χ are interpolated per interval, through its own collocation points
    /// and held from the last one to the interval's end: a break at a thrust
    /// switch is a discontinuity of the control, which an interpolant across
    /// the break would smear over the gap between the last point and the
    /// break (δ, a state, stays one interpolant through all the nodes).
    pub interval_points: &'a [usize],
    /// Interpolate by the collocation's polynomials per interval
    /// ([`ControlSource::Collocation`]) instead of [`Options::interpolation`].
    pub collocation: bool,
}

/// One interval's polynomial of δ: its node times and their barycentric
/// weights.
type PiecePolynomials = (Vec<f64>, Vec<f64>);

/// A propagated trajectory: times, states and nozzle angles at the accepted
/// steps, and the integrator's work.
pub type Track = (Vec<f64>, Vec<[f64; 7]>, Vec<f64>, Stats);

/// Integrate Eq. (1)–(3) with interpolated controls, node interval by node interval.
pub fn integrate_controls(
    model: &Model,
    c: &Controls,
    options: &Options,
) -> Result<Track, IntegrationError> {
    check_nodes(c)?;
    let pieces = segments(c)?;
    let functions = ControlFunctions::new(model, c, options.interpolation, &pieces);
    integrate_segments(model, c, options, &pieces, &functions)
}

/// The node data's own consistency: one control per node time, at least
/// two node times, finite and strictly increasing.
fn check_nodes(c: &Controls) -> Result<(), IntegrationError> {
    let m = c.t_s.len();
    if m < 2
        || [
            c.thrust_n.len(),
            c.delta_rad.len(),
            c.gimbal_rate_radps.len(),
        ]
        .iter()
        .any(|&l| l != m)
    {
        return Err(IntegrationError::BadSolution(format!(
            "the control arrays must all have the length of t_s ({m} ≥ 2)"
        )));
    }
    if !c.t_s.windows(2).all(|w| w[1] > w[0]) || c.t_s.iter().any(|t| !t.is_finite()) {
        return Err(IntegrationError::BadSolution(
            "node times must be finite and strictly increasing".into(),
        ));
    }
    Ok(())
}

/// The segments of the controls, one per mesh interval (or one through
/// every node): each one's first node and its node count (its points; the
/// segment ends at the node after them).
fn segments(c: &Controls) -> Result<Vec<(usize, usize)>, IntegrationError> {
    let m = c.t_s.len();
    if c.interval_points.len() <= 1 {
        return Ok(vec![(0, m - 1)]);
    }
    if c.interval_points.iter().sum::<usize>() + 1 != m || c.interval_points.contains(&0) {
        return Err(IntegrationError::BadSolution(format!(
            "the intervals' points must be positive and add up to the {} nodes less one",
            m
        )));
    }
    Ok(c.interval_points
        .iter()
        .scan(0, |start, &n| {
            let piece = (*start, n);
            *start += n;
            Some(piece)
        })
        .collect())
}

/// The controls of one re-propagation as functions of time, built once:
/// δ through every node; T and χ per segment, each held from the segment's
/// last point to its end; with [`Controls::collocation`], the collocation's
/// polynomials of δ per segment and the flyable profiles of T and χ.
struct ControlFunctions {
    delta: Interpolant,
    /// T and χ of each segment.
    controls: Vec<(Interpolant, Interpolant)>,
    /// The collocation's polynomial of δ on each segment (empty without
    /// [`Controls::collocation`]).
    polys: Vec<PiecePolynomials>,
    /// The flyable profiles of T and χ (with [`Controls::collocation`]).
    profiles: Option<(Profile, Profile)>,
}

impl ControlFunctions {
    fn new(model: &Model, c: &Controls, kind: Interpolation, pieces: &[(usize, usize)]) -> Self {
        let delta = Interpolant::new(kind, c.t_s, c.delta_rad);
        let held = |values: &[f64], start: usize, n: usize| -> Vec<f64> {
            let mut v = values[start..=start + n].to_vec();
            if pieces.len() > 1 {
                v[n] = v[n - 1];
            }
            v
        };
        let controls = pieces
            .iter()
            .map(|&(start, n)| {
                let t = &c.t_s[start..=start + n];
                (
                    Interpolant::new(kind, t, &held(c.thrust_n, start, n)),
                    Interpolant::new(kind, t, &held(c.gimbal_rate_radps, start, n)),
                )
            })
            .collect();
        let polys = if c.collocation {
            pieces
                .iter()
                .map(|&(start, n)| {
                    let tn = c.t_s[start..=start + n].to_vec();
                    let bn = crate::collocation::radau::barycentric_weights(&tn);
                    (tn, bn)
                })
                .collect()
        } else {
            Vec::new()
        };
        let points: Vec<usize> = pieces.iter().map(|&(_, n)| n).collect();
        let profiles = c.collocation.then(|| {
            let r = model.max_gimbal_rate_radps;
            (
                Profile::new(
                    c.t_s,
                    &points,
                    c.thrust_n,
                    model.min_thrust_n,
                    model.max_thrust_n,
                ),
                Profile::new(c.t_s, &points, c.gimbal_rate_radps, -r, r),
            )
        });
        ControlFunctions {
            delta,
            controls,
            polys,
            profiles,
        }
    }
}

/// The integration loop: node interval by node interval, each split at the
/// profiles' jumps inside it, from the initial state (and δ at t_0 for the
/// nozzle-rate model), recording every accepted step.
fn integrate_segments(
    model: &Model,
    c: &Controls,
    options: &Options,
    pieces: &[(usize, usize)],
    functions: &ControlFunctions,
) -> Result<Track, IntegrationError> {
    let ControlFunctions {
        delta,
        controls,
        polys,
        profiles,
    } = functions;
    let nozzle = options.nozzle;
    let jumping: Vec<&Profile> = profiles.iter().flat_map(|(t, chi)| [t, chi]).collect();
    let mut stops = Vec::new();
    let piece_of: Vec<usize> = pieces
        .iter()
        .enumerate()
        .flat_map(|(j, &(_, n))| std::iter::repeat_n(j, n))
        .collect();

    // The 7 physical states, plus δ for the nozzle-rate model.
    let p0 = c.initial;
    let mut y: [f64; 8] = [
        p0[0],
        p0[1],
        p0[2],
        p0[3],
        p0[4],
        p0[5],
        p0[6],
        c.delta_rad[0],
    ];
    let mut t_out = vec![c.t_s[0]];
    let mut states = vec![p0];
    let mut delta_out = vec![y[7]];
    let mut stats = Stats::default();
    let mut h = 0.0;
    for (k, &j) in piece_of.iter().enumerate() {
        let (thrust, chi) = &controls[j];
        let local = k - pieces[j].0;
        let (start, np) = pieces[j];
        let poly = polys.get(j);
        let thrust_at = |t: f64| match profiles {
            Some((thrust, _)) => thrust.at(t),
            None => thrust.eval_on(local, t),
        };
        let chi_at = |t: f64| match profiles {
            Some((_, chi)) => chi.at(t),
            None => chi.eval_on(local, t),
        };
        let delta_at = |t: f64| match poly {
            Some((tn, bn)) => {
                let r = model.max_gimbal_rad;
                crate::collocation::radau::interpolate(tn, bn, &c.delta_rad[start..=start + np], t)
                    .clamp(-r, r)
            }
            None => delta.eval_on(k, t),
        };
        let rhs = |t: f64, y: &[f64; 8]| -> [f64; 8] {
            let thrust_n = thrust_at(t);
            let (delta_rad, ddelta) = match nozzle {
                NozzleModel::Angle => (delta_at(t), 0.0),
                NozzleModel::Rate => (y[7], chi_at(t)),
            };
            let f = dynamics::rhs_physical(model, &physical(y), thrust_n, delta_rad);
            [f[0], f[1], f[2], f[3], f[4], f[5], f[6], ddelta]
        };
        // Stop at the profiles' jumps inside the node interval, instead of
        // letting the step-size control find them.
        Profile::stops(c.t_s[k], c.t_s[k + 1], &jumping, &mut stops);
        for span in stops.windows(2) {
            if span[1] <= span[0] {
                continue;
            }
            y = options.integrator.integrate(
                &rhs,
                span[0],
                y,
                span[1],
                &mut h,
                &mut stats,
                |t, y| {
                    t_out.push(t);
                    states.push(physical(y));
                    delta_out.push(match nozzle {
                        NozzleModel::Angle => delta_at(t),
                        NozzleModel::Rate => y[7],
                    });
                },
            )?;
        }
    }
    Ok((t_out, states, delta_out, stats))
}

/// Integrate Eq. (1)–(3) with the solution's controls from its initial state to
/// t_f and measure the landing error against `scenario.terminal`.
///
/// `scenario` supplies the vehicle model and the target; it should be the one
/// the solution was computed for.
pub fn propagate(
    scenario: &Scenario,
    solution: &Solution,
    options: &Options,
) -> Result<Propagation, IntegrationError> {
    let s = solution;
    let m = s.t_s.len();
    let columns = s.state_columns();
    let states0 = &columns[..7];
    if m < 2 || states0.iter().any(|v| v.len() != m) {
        return Err(IntegrationError::BadSolution(format!(
            "the state arrays must all have the length of t_s ({m} ≥ 2)"
        )));
    }
    let controls = Controls {
        t_s: &s.t_s,
        thrust_n: &s.thrust_n,
        delta_rad: &s.delta_rad,
        gimbal_rate_radps: &s.gimbal_rate_radps,
        initial: std::array::from_fn(|c| states0[c][0]),
        interval_points: &s.mesh.points,
        collocation: match options.controls {
            ControlSource::Auto | ControlSource::Flown => s.refinement.is_some(),
            ControlSource::Nodes => false,
            ControlSource::Collocation => true,
        },
    };
    let model = Model::new(&scenario.vehicle, &scenario.environment);
    let flown = match options.controls {
        ControlSource::Auto | ControlSource::Flown => s.controls_flown.as_ref(),
        _ => None,
    };
    if let Some(flown) = flown {
        let (track, _) = integrate_flown(
            &model,
            flown,
            &controls.initial,
            &options.integrator,
            &s.t_s,
        )?;
        return Ok(propagation(
            scenario,
            s,
            options,
            ControlSource::Flown,
            track,
        ));
    }
    if options.controls == ControlSource::Flown {
        return Err(IntegrationError::BadSolution(
            "the answer has no flown controls (it was not polished)".into(),
        ));
    }
    let track = integrate_controls(&model, &controls, options)?;
    let used = if controls.collocation {
        ControlSource::Collocation
    } else {
        ControlSource::Nodes
    };
    Ok(propagation(scenario, s, options, used, track))
}

/// A propagation's record of `track`, its landing error and mass error.
fn propagation(
    scenario: &Scenario,
    s: &Solution,
    options: &Options,
    used: ControlSource,
    track: Track,
) -> Propagation {
    let (t_s, states, delta_rad, stats) = track;
    let end = *states.last().expect("at least the initial state");
    let landing_error = landing_error(scenario, &end);
    Propagation {
        options: Options {
            controls: used,
            ..*options
        },
        t_s,
        states,
        delta_rad,
        landing_error,
        terminal_mass_kg: end[6],
        mass_error_kg: end[6] - s.final_mass_kg,
        stats,
    }
}

/// Integrate Eq. (1)–(3) under the flown controls ([`crate::flown`]) from
/// `initial` (x, z, Vx, Vz, θ, w, m), piece by piece (no step straddles a
/// piece's end, where T may jump), stopping also at each of the increasing
/// times `samples` \[s\]. Returns the track of every accepted step and the
/// state at each sample time.
pub fn integrate_flown(
    model: &Model,
    flown: &FlownControls,
    initial: &[f64; 7],
    integrator: &Dop853,
    samples: &[f64],
) -> Result<(Track, Vec<[f64; 7]>), IntegrationError> {
    let ok = !flown.pieces.is_empty()
        && flown
            .pieces
            .iter()
            .all(|p| p.t_end_s >= p.t_start_s && p.t_start_s.is_finite() && p.t_end_s.is_finite());
    if !ok {
        return Err(IntegrationError::BadSolution(
            "the flown controls need at least one piece, each with finite, ordered ends".into(),
        ));
    }
    let mut y = *initial;
    let mut t_out = vec![flown.pieces[0].t_start_s];
    let mut states = vec![y];
    let mut delta_out = vec![flown.pieces[0].delta_rad.value(0.0)];
    let mut at_samples = Vec::with_capacity(samples.len());
    let mut stats = Stats::default();
    let mut h = 0.0;
    let mut next = 0;
    for piece in &flown.pieces {
        let rhs = |t: f64, y: &[f64; 7]| -> [f64; 7] {
            let s = piece.s_of(t);
            dynamics::rhs_physical(model, y, piece.thrust_n.value(s), piece.delta_rad.value(s))
        };
        let mut t = piece.t_start_s;
        while next < samples.len() && samples[next] <= piece.t_start_s {
            at_samples.push(y);
            next += 1;
        }
        let mut stops: Vec<f64> = samples[next..]
            .iter()
            .copied()
            .take_while(|&s| s < piece.t_end_s)
            .collect();
        stops.push(piece.t_end_s);
        for stop in stops {
            y = integrator.integrate(rhs, t, y, stop, &mut h, &mut stats, |t, y| {
                t_out.push(t);
                states.push(*y);
                delta_out.push(piece.delta_rad.value(piece.s_of(t)));
            })?;
            t = stop;
            if stop < piece.t_end_s {
                at_samples.push(y);
                next += 1;
            }
        }
    }
    at_samples.resize(samples.len(), y);
    Ok(((t_out, states, delta_out, stats), at_samples))
}

/// The miss of a final state (x, z, Vx, Vz, θ, w, m) against `scenario.terminal`.
pub fn landing_error(scenario: &Scenario, end: &[f64; 7]) -> LandingError {
    let tf = &scenario.terminal;
    LandingError {
        position_m: (end[0] - tf.x_m).hypot(end[1] - tf.z_m),
        velocity_mps: (end[2] - tf.vx_mps).hypot(end[3] - tf.vz_mps),
        pitch_rad: (end[4] - tf.theta_deg.to_radians()).abs(),
        rate_radps: (end[5] - tf.pitch_rate_degps.to_radians()).abs(),
    }
}

fn physical(y: &[f64; 8]) -> [f64; 7] {
    [y[0], y[1], y[2], y[3], y[4], y[5], y[6]]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tight() -> Dop853 {
        Dop853 {
            rtol: 1e-12,
            atol: 1e-12,
            ..Dop853::default()
        }
    }

    /// y'' = −y, y = cos t, y' = −sin t: the global error of the default
    /// tolerance (1e-10) grows about 1e-10 per period, so it stays below 1e-8
    /// over 50 periods (314 s, 27 times the landing burn); at 1e-12 it does
    /// over 1000 periods.
    #[test]
    fn harmonic_oscillator_over_many_periods() {
        for (solver, periods) in [(Dop853::default(), 50.0), (tight(), 1000.0)] {
            let tf = 2.0 * std::f64::consts::PI * periods;
            let mut stats = Stats::default();
            let mut h = 0.0;
            let y = solver
                .integrate(
                    |_, y: &[f64; 2]| [y[1], -y[0]],
                    0.0,
                    [1.0, 0.0],
                    tf,
                    &mut h,
                    &mut stats,
                    |_, _| {},
                )
                .unwrap();
            let err = (y[0] - tf.cos()).abs().max((y[1] + tf.sin()).abs());
            assert!(
                err <= 1e-8,
                "{periods} periods: error {err:e} after {stats:?}"
            );
        }
    }

    /// y' = ∓y/2 over 40 s: decay to e^−20 (absolute error ≤ 1e-12, where the
    /// absolute tolerance governs) and growth to e^20 (relative error ≤ 1e-8),
    /// and the decay integrated backwards in time.
    #[test]
    fn exponential_decay_and_growth() {
        for rate in [-0.5, 0.5] {
            let mut stats = Stats::default();
            let mut h = 0.0;
            let y = Dop853::default()
                .integrate(
                    |_, y: &[f64; 1]| [rate * y[0]],
                    0.0,
                    [1.0],
                    40.0,
                    &mut h,
                    &mut stats,
                    |_, _| {},
                )
                .unwrap();
            let exact = (rate * 40.0f64).exp();
            assert!(
                (y[0] - exact).abs() <= (1e-8 * exact).max(1e-12),
                "rate {rate}: {} vs {exact}",
                y[0]
            );
        }
        let (mut stats, mut h) = (Stats::default(), 0.0);
        let back = Dop853::default()
            .integrate(
                |_, y: &[f64; 1]| [-0.5 * y[0]],
                40.0,
                [1.0],
                0.0,
                &mut h,
                &mut stats,
                |_, _| {},
            )
            .unwrap();
        assert!((back[0] - 20f64.exp()).abs() <= 1e-8 * 20f64.exp());
    }

    /// A time-dependent, nonlinear problem: y' = 2t·y² with y(0) = 1, whose
    /// solution y = 1/(1 − t²) blows up at t = 1.
    #[test]
    fn nonlinear_time_dependent_near_blow_up() {
        let mut stats = Stats::default();
        let mut h = 0.0;
        let mut visited = vec![];
        let y = tight()
            .integrate(
                |t, y: &[f64; 1]| [2.0 * t * y[0] * y[0]],
                0.0,
                [1.0],
                0.99,
                &mut h,
                &mut stats,
                |t, _| visited.push(t),
            )
            .unwrap();
        let exact = 1.0 / (1.0 - 0.99 * 0.99);
        assert!((y[0] - exact).abs() <= 1e-9 * exact, "{} vs {exact}", y[0]);
        assert_eq!(*visited.last().unwrap(), 0.99);
        assert!(visited.windows(2).all(|w| w[1] > w[0]));
    }

    /// The method has order 8: halving a fixed step divides the error of
    /// y'' = −y over one period by about 2⁸ = 256.
    #[test]
    fn eighth_order_of_convergence() {
        let solver = Dop853::default();
        let error = |steps: usize| {
            let tf = 2.0 * std::f64::consts::PI;
            let h = tf / steps as f64;
            let mut y = [1.0, 0.0];
            let mut f = |_: f64, y: &[f64; 2]| [y[1], -y[0]];
            for i in 0..steps {
                let t = i as f64 * h;
                let k1 = f(t, &y);
                y = solver.step(&mut f, t, &y, &k1, h).0;
            }
            (y[0] - 1.0).abs().max(y[1].abs())
        };
        let (e1, e2) = (error(8), error(16));
        let order = (e1 / e2).log2();
        assert!((7.5..9.0).contains(&order), "observed order {order}");
    }

    #[test]
    fn pchip_is_monotone_and_exact_on_lines() {
        let t = [0.0, 1.0, 1.5, 3.0, 4.0, 6.0];
        // A step: PCHIP stays inside [0, 1] and monotone.
        let y = [0.0, 0.0, 0.1, 1.0, 1.0, 1.0];
        let p = Interpolant::new(Interpolation::Pchip, &t, &y);
        let mut prev = f64::NEG_INFINITY;
        for i in 0..=600 {
            let v = p.eval(i as f64 * 0.01);
            assert!((0.0..=1.0).contains(&v), "overshoot {v}");
            assert!(v >= prev - 1e-15, "not monotone at {}", i as f64 * 0.01);
            prev = v;
        }
        for (tk, yk) in t.iter().zip(y) {
            assert_eq!(p.eval(*tk), yk);
        }
        // Lines are reproduced exactly by both interpolants.
        let line: Vec<f64> = t.iter().map(|t| 3.0 - 2.0 * t).collect();
        for kind in [Interpolation::Linear, Interpolation::Pchip] {
            let p = Interpolant::new(kind, &t, &line);
            for i in 0..=60 {
                let x = i as f64 * 0.1;
                assert!((p.eval(x) - (3.0 - 2.0 * x)).abs() < 1e-13, "{kind:?}");
            }
        }
    }

    /// Vertical flight without drag under constant thrust has a closed form;
    /// propagating its node data reproduces it with every option.
    #[test]
    fn constant_thrust_vertical_flight_matches_closed_form() {
        let mut scenario = Scenario::paper();
        scenario.vehicle.drag_coefficient_kgpm = 0.0;
        let model = Model::new(&scenario.vehicle, &scenario.environment);
        // θ = δ = 0, ṁ = αT: m = m0 + αT·t, Vz = Vz0 + ln(m/m0)/α − g·t,
        // z = z0 + Vz0·t + [m·ln(m/m0) − m + m0]/(α²T) − g·t²/2.
        let (m0, thrust, vz0, z0, tf) = (120_000.0, 2.0e6, -80.0, 600.0, 10.0);
        let (a, g) = (model.alpha_spm, model.g0_mps2);
        let mass = |t: f64| m0 + a * thrust * t;
        let vz = |t: f64| vz0 + (mass(t) / m0).ln() / a - g * t;
        let z = |t: f64| {
            let m = mass(t);
            z0 + vz0 * t + (m * (m / m0).ln() - m + m0) / (a * a * thrust) - 0.5 * g * t * t
        };
        let n = 6;
        let t_s: Vec<f64> = (0..=n).map(|k| tf * k as f64 / n as f64).collect();
        let zeros = vec![0.0; n + 1];
        let thrusts = vec![thrust; n + 1];
        let controls = Controls {
            t_s: &t_s,
            thrust_n: &thrusts,
            delta_rad: &zeros,
            gimbal_rate_radps: &zeros,
            initial: [0.0, z0, 0.0, vz0, 0.0, 0.0, m0],
            interval_points: &[],
            collocation: false,
        };
        for interpolation in [Interpolation::Linear, Interpolation::Pchip] {
            for nozzle in [NozzleModel::Angle, NozzleModel::Rate] {
                let opts = Options {
                    interpolation,
                    nozzle,
                    ..Options::default()
                };
                let (t, states, _, _) = integrate_controls(&model, &controls, &opts).unwrap();
                let end = *states.last().unwrap();
                assert!((end[1] - z(tf)).abs() < 1e-7, "{opts:?}: z {}", end[1]);
                assert!((end[3] - vz(tf)).abs() < 1e-8, "{opts:?}: vz {}", end[3]);
                assert!((end[6] - mass(tf)).abs() < 1e-6, "{opts:?}: m {}", end[6]);
                assert_eq!(end[0], 0.0);
                assert_eq!(*t.last().unwrap(), tf);
                for tk in &t_s {
                    assert!(t.contains(tk), "node time {tk} not visited");
                }
                let e = landing_error(&scenario, &end);
                assert!((e.position_m - z(tf).abs()).abs() < 1e-7);
                assert!((e.velocity_mps - vz(tf).abs()).abs() < 1e-8);
            }
        }
    }
}
