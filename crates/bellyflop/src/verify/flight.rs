//! Any model behind the seam ([`Dynamics`]) flown under given controls by
//! the Dormand–Prince 8(5,3) integrator ([`crate::verify::ode`]): the
//! re-integration that checks an answer against the nonlinear dynamics,
//! for the 6-DoF model as for the plane (issue 38).
//!
//! The controls are a function of time per segment, and the integration
//! stops at every segment's end, where a control may jump or kink. An
//! answer of a collocation mesh flies as the references fly it
//! ([`collocation_controls`]): the thrust linear in time between the
//! collocation times and held from the last one to t_f, and each gimbal
//! angle linear between the nodes, which its rate, constant on each node
//! interval at the secant's slope, gives exactly.

use crate::problem::model::{check_sizes, Dynamics};
use crate::verify::ode::{Dop853, IntegrationError, Stats};

/// A flight: the times and states at the accepted steps (the first at t_0,
/// the last at t_f), the lowest altitude among them, and the integrator's
/// work.
#[derive(Debug, Clone, PartialEq)]
pub struct Flight<const NX: usize> {
    pub t_s: Vec<f64>,
    pub states: Vec<[f64; NX]>,
    /// The least altitude at the accepted steps \[m\].
    pub lowest_altitude_m: f64,
    pub stats: Stats,
}

impl<const NX: usize> Flight<NX> {
    /// The state at t_f.
    pub fn end(&self) -> &[f64; NX] {
        self.states.last().expect("a flight has its initial state")
    }
}

/// Fly `model` from `x0` over the segments between consecutive `breaks_s`
/// (increasing), with the control `u(k, t)` on segment k.
pub fn fly<M: Dynamics, const NX: usize, const NU: usize>(
    model: &M,
    x0: [f64; NX],
    breaks_s: &[f64],
    u: impl Fn(usize, f64) -> [f64; NU],
    integrator: &Dop853,
) -> Result<Flight<NX>, IntegrationError> {
    const { check_sizes::<M, NX, NU>() }
    let mut flight = Flight {
        t_s: vec![breaks_s.first().copied().unwrap_or(0.0)],
        states: vec![x0],
        lowest_altitude_m: x0[M::ALTITUDE],
        stats: Stats::default(),
    };
    let (mut y, mut h) = (x0, 0.0);
    for (k, span) in breaks_s.windows(2).enumerate() {
        if span[1] <= span[0] {
            continue;
        }
        let rhs = |t: f64, y: &[f64; NX]| -> [f64; NX] {
            let mut f = [0.0; NX];
            model.rhs(y, &u(k, t), &mut f);
            f
        };
        let (t_s, states, lowest) = (
            &mut flight.t_s,
            &mut flight.states,
            &mut flight.lowest_altitude_m,
        );
        y = integrator.integrate(
            rhs,
            span[0],
            y,
            span[1],
            &mut h,
            &mut flight.stats,
            |t, y| {
                t_s.push(t);
                states.push(*y);
                *lowest = lowest.min(y[M::ALTITUDE]);
            },
        )?;
    }
    Ok(flight)
}

/// The breaks and the controls of a collocation answer as flown (module
/// docs): `node_times_s` the N + 1 node times (t_0 … t_{N−1} the collocation
/// points, t_N = t_f), `states` the N + 1 node states, `controls` the N
/// points' controls, and `rates` the pairs (state slot of an angle, control
/// slot of its rate) whose rate is flown at the secant's slope. The breaks
/// are the node times.
pub fn collocation_controls<'a, const NX: usize, const NU: usize>(
    node_times_s: &'a [f64],
    states: &'a [[f64; NX]],
    controls: &'a [[f64; NU]],
    rates: &'a [(usize, usize)],
) -> impl Fn(usize, f64) -> [f64; NU] + 'a {
    let n = controls.len();
    move |k: usize, t: f64| {
        let (ta, tb) = (node_times_s[k], node_times_s[k + 1]);
        let a = (t - ta) / (tb - ta);
        // Linear between the points k and k + 1, held after the last.
        let (ua, ub) = (&controls[k], &controls[(k + 1).min(n - 1)]);
        let mut u: [f64; NU] = std::array::from_fn(|j| ua[j] + a * (ub[j] - ua[j]));
        for &(angle, rate) in rates {
            u[rate] = (states[k + 1][angle] - states[k][angle]) / (tb - ta);
        }
        u
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;
    use crate::problem::dynamics::{ix, Model};
    use crate::problem::six_dof::{self, su, sx, SixDof};

    /// The paper's planar controls flown through the 6-DoF model from the
    /// lifted start land where the planar flight of the same controls
    /// does: the special case holds along a whole flight, not only in the
    /// rhs. The controls: a constant thrust and a gimbal sweep.
    #[test]
    fn a_planar_flight_is_a_special_case_of_the_six_dof_one() {
        let s = Scenario::paper();
        let planar = Model::new(&s.vehicle, &s.environment);
        let lifted = SixDof::new(&s.vehicle, &s.environment);
        let x0 = s.initial.state_si();
        let breaks = [0.0, 2.0, 4.5, 6.0];
        let thrust = 0.5 * (planar.min_thrust_n + planar.max_thrust_n);
        let chi = |k: usize| [0.05, -0.08, 0.02][k];
        let ode = Dop853::default();
        let p = fly::<Model, 8, 2>(&planar, x0, &breaks, |k, _| [thrust, chi(k)], &ode).unwrap();
        let l = fly::<SixDof, { six_dof::NX }, { six_dof::NU }>(
            &lifted,
            six_dof::planar_state(&x0),
            &breaks,
            |k, _| [thrust, chi(k), 0.0],
            &ode,
        )
        .unwrap();
        let want = six_dof::planar_state(p.end());
        for (c, (a, b)) in l.end().iter().zip(&want).enumerate() {
            assert!(
                (a - b).abs() < 1e-6 * (1.0 + b.abs()),
                "slot {c}: {a} against {b}"
            );
        }
        assert_eq!(l.end()[sx::Y], 0.0);
        assert!((l.lowest_altitude_m - p.lowest_altitude_m).abs() < 1e-6);
        assert!(p.lowest_altitude_m < x0[ix::Z]);
        // The gimbal's rate integrates to its sweep exactly.
        let sweep: f64 = (0..3).map(|k| chi(k) * (breaks[k + 1] - breaks[k])).sum();
        assert!((l.end()[sx::DELTA] - (x0[ix::DELTA] + sweep)).abs() < 1e-12);
        assert_eq!(su::T, 0);
    }
}
