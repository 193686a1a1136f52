//! Dense sampling of a solution from its LGR interpolants: what
//! `trajectory.csv`, the plots and the viewer (`viewer.html`) draw.
//!
//! The states are the degree-N Lagrange polynomials through the N + 1 LGR
//! nodes (`Mesh::interpolate_states`, piecewise on an hp mesh); the controls
//! are the degree-(N − 1) polynomials through the N collocation points
//! (`Mesh::interpolate_controls`). The controls are not collocated on
//! (τ_N, 1]; there they hold the value of the last collocation point, as the
//! `Solution` arrays do at t_f (the extrapolated polynomial can overshoot the
//! thrust bounds). Between nodes these polynomials are what the collocation
//! method represents; only the node values are optimized.

use crate::input::scenario::Scenario;
use crate::problem::dynamics::{self, ix, Model};
use crate::verify::ode::Dop853;
use crate::verify::propagate::integrate_flown;
use crate::Solution;

/// The names of the sampled columns, in order, with their units as
/// suffixes (the keys of the solution's JSON node arrays).
pub const COLUMN_NAMES: [&str; 11] = {
    let state = crate::solution::STATE_COLUMN_NAMES;
    let mut names = ["t_s"; 11];
    let mut k = 0;
    while k < state.len() {
        names[1 + k] = state[k];
        k += 1;
    }
    names[9] = "thrust_n";
    names[10] = "gimbal_rate_radps";
    names
};

/// A solution sampled densely: the columns of [`COLUMN_NAMES`], and for each
/// sample `Some(k)` where it is LGR node k (0 ≤ k ≤ N).
#[derive(Debug, Clone, PartialEq)]
pub struct Samples {
    pub columns: [Vec<f64>; 11],
    pub node: Vec<Option<usize>>,
}

/// The τ of the samples: `per` on each of the N intervals between
/// consecutive LGR nodes (the node first), plus the final node.
fn sample_taus(nodes: &[f64], per: usize) -> (Vec<f64>, Vec<Option<usize>>) {
    let n = nodes.len() - 1;
    let mut taus = Vec::with_capacity(n * per + 1);
    let mut node = Vec::with_capacity(n * per + 1);
    for k in 0..n {
        let (a, b) = (nodes[k], nodes[k + 1]);
        for j in 0..per {
            taus.push(if j == 0 {
                a
            } else {
                a + (b - a) * j as f64 / per as f64
            });
            node.push((j == 0).then_some(k));
        }
    }
    taus.push(nodes[n]);
    node.push(Some(n));
    (taus, node)
}

/// The samples of an answer at [`sample`]'s times: for a polished answer
/// its flight ([`sample_flown`]), else its interpolants ([`sample`]).
pub fn of(scenario: &Scenario, s: &Solution, per_interval: usize) -> Samples {
    if s.controls_flown.is_some() {
        if let Some(samples) = sample_flown(scenario, s, per_interval) {
            return samples;
        }
    }
    sample(s, per_interval)
}

/// A polished answer sampled as it flies: its `controls_flown` integrated
/// from the scenario's initial state (DOP853 at 1e-10, the landing
/// check's), the states at [`sample`]'s times and T, δ, χ of the flown
/// controls there. None without flown controls or if the integration fails.
pub fn sample_flown(scenario: &Scenario, s: &Solution, per_interval: usize) -> Option<Samples> {
    let flown = s.controls_flown.as_ref()?;
    let (taus, node) = sample_taus(&s.mesh().nodes, per_interval.max(1));
    // At a node, its time and (below) its values are the node arrays' own,
    // bit for bit: the same flight, sampled with other stops, differs in
    // the last digits only.
    let times: Vec<f64> = taus
        .iter()
        .zip(&node)
        .map(|(tau, k)| k.map_or((tau + 1.0) * s.tf_s / 2.0, |k| s.t_s[k]))
        .collect();
    let model = Model::new(&scenario.vehicle, &scenario.environment);
    let s0 = scenario.initial.state_si();
    let y0 = [s0[0], s0[1], s0[2], s0[3], s0[4], s0[5], s0[6]];
    let (_, states) = integrate_flown(&model, flown, &y0, &Dop853::default(), &times).ok()?;
    let mut columns: [Vec<f64>; 11] = Default::default();
    let at_node = s.state_columns();
    for ((&t, y), k) in times.iter().zip(&states).zip(&node) {
        let (thrust, delta, chi) = flown.at(t)?;
        let row = match *k {
            Some(k) => {
                let c = |i: usize| at_node[i][k];
                [
                    t,
                    c(0),
                    c(1),
                    c(2),
                    c(3),
                    c(4),
                    c(5),
                    c(6),
                    s.delta_rad[k],
                    s.thrust_n[k],
                    s.gimbal_rate_radps[k],
                ]
            }
            None => [
                t, y[0], y[1], y[2], y[3], y[4], y[5], y[6], delta, thrust, chi,
            ],
        };
        for (c, v) in columns.iter_mut().zip(row) {
            c.push(v);
        }
    }
    Some(Samples { columns, node })
}

/// Sample the solution's interpolants: `per_interval` samples on each of
/// the N intervals between consecutive LGR nodes, plus the final node, so
/// N·`per_interval` + 1 samples that include every node exactly.
///
/// At a node the states are the node values of the solution bit for bit
/// (the barycentric formula returns them as is); the thrust is σ·m with σ
/// from the control polynomial, equal to the node value to rounding.
pub fn sample(s: &Solution, per_interval: usize) -> Samples {
    let per = per_interval.max(1);
    let tr = &s.trajectory;
    let n = tr.x.len() - 1;
    let lgr = s.mesh();
    let nu = dynamics::control_dim(s.formulation);

    let state = |c: usize| tr.x.iter().map(|x| x[c]).collect::<Vec<f64>>();
    let sigma: Vec<f64> = (0..n)
        .map(|i| dynamics::thrust_components(s.formulation, &tr.x[i], &tr.u[i][..nu]).2)
        .collect();
    let chi: Vec<f64> = (0..n).map(|i| tr.u[i][nu - 1]).collect();
    let states = [
        state(ix::X),
        state(ix::Z),
        state(ix::VX),
        state(ix::VZ),
        state(ix::THETA),
        state(ix::W),
        state(ix::OMEGA),
        state(ix::DELTA),
    ];
    let (taus, node) = sample_taus(&lgr.nodes, per);
    let mut columns: [Vec<f64>; 11] = Default::default();
    for &tau in &taus {
        let st: Vec<f64> = states
            .iter()
            .map(|c| lgr.interpolate_states(c, tau))
            .collect();
        let mass = st[6].exp();
        // On (τ_N, 1] the controls hold the last collocation value, as in
        // the Solution's arrays; the polynomial would be extrapolated there.
        let tau_c = tau.min(lgr.nodes[n - 1]);
        let row = [
            (tau + 1.0) * tr.tf_s / 2.0,
            st[0],
            st[1],
            st[2],
            st[3],
            st[4],
            st[5],
            mass,
            st[7],
            lgr.interpolate_controls(&sigma, tau_c) * mass,
            lgr.interpolate_controls(&chi, tau_c),
        ];
        for (c, v) in columns.iter_mut().zip(row) {
            c.push(v);
        }
    }
    Samples { columns, node }
}
