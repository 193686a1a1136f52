//! The 6-DoF polish (issue 38): the controls as they are flown, made to
//! land and to be fuel-optimal by single shooting, as the planar polish
//! does for the plane (a simpler parameterization, below).
//!
//! **The flown controls** ([`Controls6`]): on N node intervals, the thrust
//! linear in time between its N values at the starts of the intervals and
//! held over the last, and each gimbal angle linear between its N + 1 node
//! values, so flown at the secant rate on each interval; δ at t_0 is the
//! start's. The references fly a collocation answer this way
//! ([`crate::verify::flight::collocation_controls`]), from which the polish
//! starts (the raw answer's mesh).
//!
//! **The problem** over p = (T_0 … T_{N−1}, δ1_1 … δ1_N, δ2_1 … δ2_N,
//! d_0 … d_{N−1}), the node intervals' durations free (t_f = Σ d_k):
//!
//!   max m(t_f)  s.t.  r, V at the landing, q1 = q2 = 0, ω_x = ω_y = 0 at t_f,
//!   T_min ≤ T_k ≤ T_max,  ‖δ_k‖ ≤ δ_max,  ‖δ_{k+1} − δ_k‖ ≤ χ_max·d_k,
//!   d_min ≤ d_k ≤ d_max,k,
//!   z ≥ z_f at every step of the shot before t_f,  m(t_f) ≥ m_dry.
//!
//! Free durations move the knots: a thrust ramp between two knots can
//! shorten into a switch, as the planar polish's arcs have free switch
//! times. With the knots fixed at the raw mesh's times the polished mass
//! stayed 9–15 kg below IPOPT's on a fine (40 × 8) mesh; free, it is
//! within about half a kilogram (`BENCHMARKS.md`).
//!
//! The control rows hold along the whole flight exactly: T is linear between
//! in-bound values, δ is linear between nodes inside the disc ‖δ‖ ≤ δ_max
//! (which lies inside the nozzle cone cos δ1·cos δ2 ≥ cos δ_max), and each
//! interval's rate is constant. The discs are held as the faces of an
//! inscribed [`FACES`]-gon, rows that are linear in p, so that no
//! linearization error enters them.
//!
//! The end state comes from RK4 at steps of at most [`STEP_S`] (each
//! interval's count of steps fixed from the raw mesh with room to grow by
//! half) in each interval's normalized time σ (dx/dσ = d_k·f), with its exact sensitivities
//! ∂x/∂p by the variational equations (f's Jacobian from
//! [`six::jacobian`], in closed form), condensed by interval (`Local`:
//! on interval k the flight reads p only through x_k and the few
//! parameters of its own controls). Each iteration solves a QP ([`crate::polish::qp`]):
//! the linearized mass gain, the linearized landing with penalized slacks,
//! the control faces and the linearized ground and dry mass, and a proximal
//! term ε‖Δp̂‖² that grows on a poor step (an exact-penalty merit judges
//! each by its own shot).
//!
//! **The curvature** of the QPs (`Curvature`): a damped BFGS model of the
//! Lagrangian's Hessian while the shot is far from the landing; once it is
//! near, the exact Hessian of the Lagrangian at the current p (by the
//! adjoint of the RK4 steps and the stages' forward sensitivities,
//! `hessian`), its eigenvalues raised to a floor
//! ([`crate::polish::hessian::clipped`]: weighting negative curvature by
//! its magnitude halved the steps along it, and the polish crawled).
//! BFGS alone converges linearly and stops short: on 30 seeded states
//! (seed 7) the exact Hessian halves the median iterations (29 → 14) and
//! ends 0.06–2.4 kg higher on each of the 27 that both land.
//!
//! **Corrections:** a trial step whose merit falls short is corrected (a
//! second-order correction, Maratos) by `correction`: the least change
//! that zeroes the trial's landing residual to first order and holds every
//! control row. At convergence the thrust is put on its box and the same
//! corrections take the landing residual below [`CORRECTED_RESIDUAL`].

#![allow(clippy::needless_range_loop)] // Dense block algebra indexes several arrays by one index.

use crate::input::scenario::TerminalState;
use crate::polish::qp::{self, Problem, Row};
use crate::problem::six_dof::{self as six, su, sx, SixDof, NU, NX};

mod hessian;

/// The largest RK4 step of the shot \[s\], as the planar polish's.
pub const STEP_S: f64 = 0.05;

/// The faces of the polygon inscribed in each disc.
pub const FACES: usize = 64;

/// The QP holds each control bound this fraction of its scale inside it:
/// its iterates meet their rows to ~1e-9 of the scale, and the flown check
/// allows 1e-9 ([`crate::verify::path::CONTROL_TOLERANCE`]). Costs ~1e-4 kg.
pub const BOUND_MARGIN: f64 = 1e-6;

/// Iteration limit.
pub const MAX_ITERATIONS: usize = 100;

/// Converged when the scaled landing residual Σ|r̂| is below this (0.1 mm
/// in position) ...
pub const RESIDUAL_TOLERANCE: f64 = 1e-4;

/// ... and the QP's step would gain less than this in final mass \[kg\];
/// then at most [`CORRECTIONS`] Newton corrections on the landing alone
/// bring Σ|r̂| below [`CORRECTED_RESIDUAL`] (10 nm).
pub const MASS_TOLERANCE_KG: f64 = 0.01;
pub const CORRECTIONS: usize = 6;
pub const CORRECTED_RESIDUAL: f64 = 1e-8;

/// The merit's unit of mass \[kg\].
const MASS_SCALE_KG: f64 = 100.0;

/// The weight of the landing residual, the ground and the dry mass in the
/// merit and of the QP's slacks, per scaled unit.
const PENALTY: f64 = 100.0;

/// Second-order corrections per trial step, at most.
const SECOND_ORDER_CORRECTIONS: usize = 3;

/// The proximal weight ε: first value and bounds.
const PROXIMAL_INITIAL: f64 = 0.3;
const PROXIMAL_MIN: f64 = 1e-8;
const PROXIMAL_MAX: f64 = 1e6;

/// The landing's rows: the slot and the scale of its residual (1 mm and
/// 1 mm/s at [`RESIDUAL_TOLERANCE`]·1e4; 10 µrad in q; 10 µrad/s in ω).
const LANDING: [(usize, f64); 10] = [
    (sx::X, 1.0),
    (sx::Y, 1.0),
    (sx::Z, 1.0),
    (sx::VX, 1.0),
    (sx::VY, 1.0),
    (sx::VZ, 1.0),
    (sx::Q + 1, 0.01),
    (sx::Q + 2, 0.01),
    (sx::W, 0.01),
    (sx::W + 1, 0.01),
];

/// The node intervals' least duration \[s\], and how much each may grow
/// (its RK4 substeps are fixed for that).
const MIN_DURATION_S: f64 = 0.02;
const GROWTH: f64 = 1.5;

/// The ground rows are held where the shot is within this of the pad \[m\].
const GROUND_WINDOW_M: f64 = 200.0;

/// The QP's ground rows ask for this much clearance at the step points
/// \[m\], so that between them (and the curvature of z(p) along a step) the
/// flown path does not dip below the pad. Without it one of 100 seeded
/// states (seed 38, box3d70) dipped 2.8e-5 m below the pad between step
/// points; with it the lowest point of the 100 is 1.8e-6 m below, the
/// landing's own miss. Counts, times and masses beyond noise unchanged
/// (at most 0.3 kg, on 130 states of seeds 38 and 7).
const GROUND_MARGIN_M: f64 = 1e-3;

/// The controls as flown (module docs), published with a 6-DoF answer.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Controls6 {
    /// t_f \[s\].
    pub tf_s: f64,
    /// The mesh's N + 1 nodes in τ ∈ [−1, 1] (t = t_f·(τ + 1)/2).
    pub tau: Vec<f64>,
    /// T at the N collocation points \[N\].
    pub thrust_n: Vec<f64>,
    /// (δ1, δ2) at the N + 1 nodes \[rad\].
    pub delta_rad: Vec<[f64; 2]>,
}

impl Controls6 {
    /// The N + 1 node times \[s\].
    pub fn times_s(&self) -> Vec<f64> {
        self.tau
            .iter()
            .map(|&t| 0.5 * (t + 1.0) * self.tf_s)
            .collect()
    }

    /// The control (T, χ1, χ2) on node interval k at the fraction a ∈ [0, 1]
    /// of it.
    pub fn at_fraction(&self, k: usize, a: f64) -> [f64; NU] {
        let n = self.thrust_n.len();
        let thrust = if k + 1 < n {
            self.thrust_n[k] + a * (self.thrust_n[k + 1] - self.thrust_n[k])
        } else {
            self.thrust_n[n - 1]
        };
        let dt = self.interval_s(k);
        let (d0, d1) = (self.delta_rad[k], self.delta_rad[k + 1]);
        [thrust, (d1[0] - d0[0]) / dt, (d1[1] - d0[1]) / dt]
    }

    /// Node interval k's duration \[s\].
    fn interval_s(&self, k: usize) -> f64 {
        0.5 * (self.tau[k + 1] - self.tau[k]) * self.tf_s
    }

    /// The control on node interval k at time t \[s\] (for
    /// [`crate::verify::flight::fly`], whose breaks are [`Self::times_s`]).
    pub fn at(&self, k: usize, t: f64) -> [f64; NU] {
        let t0 = 0.5 * (self.tau[k] + 1.0) * self.tf_s;
        self.at_fraction(k, (t - t0) / self.interval_s(k))
    }
}

/// A polished answer: its controls, the iterations and whether they
/// converged (the caller flies the controls itself).
#[derive(Debug, Clone, PartialEq)]
pub struct Polished6 {
    pub controls: Controls6,
    pub iterations: usize,
    pub converged: bool,
    /// Why it stopped, when it did not converge.
    pub message: String,
}

/// The layout of p (module docs), by node interval: block k is (T_k,
/// δ1_{k+1}, δ2_{k+1}, d_k), so that the controls of intervals 0..=k (which
/// read T_{k+1}) are the first [`Params::live`] entries, and a shot's
/// sensitivities on interval k need no more columns.
#[derive(Debug, Clone, Copy)]
struct Params {
    n: usize,
}

impl Params {
    fn len(self) -> usize {
        4 * self.n
    }
    fn thrust(self, k: usize) -> usize {
        4 * k
    }
    /// δ_j at node k ≥ 1.
    fn delta(self, j: usize, k: usize) -> usize {
        4 * (k - 1) + 1 + j
    }
    /// The duration of node interval k.
    fn duration(self, k: usize) -> usize {
        4 * k + 3
    }
    /// The entries of p that the flight up to the end of interval k
    /// depends on: the blocks 0..=k + 1.
    fn live(self, k: usize) -> usize {
        (4 * (k + 2)).min(self.len())
    }
}

/// The problem's fixed data.
struct Setup<'a> {
    model: &'a SixDof,
    x0: [f64; NX],
    target: &'a TerminalState,
    /// RK4 substeps per node interval, fixed from the raw answer's.
    substeps: Vec<usize>,
    par: Params,
    /// p's scales.
    scale: Vec<f64>,
}

impl Setup<'_> {
    fn controls(&self, p: &[f64]) -> Controls6 {
        let n = self.par.n;
        let d0 = [self.x0[sx::DELTA], self.x0[sx::DELTA + 1]];
        let tf_s: f64 = (0..n).map(|k| p[self.par.duration(k)]).sum();
        let mut tau = vec![-1.0; n + 1];
        let mut t = 0.0;
        for k in 0..n {
            t += p[self.par.duration(k)];
            tau[k + 1] = 2.0 * t / tf_s - 1.0;
        }
        tau[n] = 1.0;
        Controls6 {
            tf_s,
            tau,
            thrust_n: (0..n).map(|k| p[self.par.thrust(k)]).collect(),
            delta_rad: (0..=n)
                .map(|k| {
                    if k == 0 {
                        d0
                    } else {
                        [p[self.par.delta(0, k)], p[self.par.delta(1, k)]]
                    }
                })
                .collect(),
        }
    }

    /// The landing's residuals, scaled.
    fn residuals(&self, end: &[f64; NX]) -> [f64; 10] {
        std::array::from_fn(|i| {
            let (s, scale) = LANDING[i];
            let want = self.model_target(s);
            (end[s] - want) / scale
        })
    }

    fn model_target(&self, s: usize) -> f64 {
        use crate::problem::model::Dynamics;
        self.model.terminal_fixed(self.target, s).unwrap_or(0.0)
    }
}

/// One shot: the end state and its sensitivities, and the altitude at each
/// step point before t_f with its.
struct Shot {
    end: [f64; NX],
    d_end: Vec<Vec<f64>>,
    z: Vec<f64>,
    d_z: Vec<Vec<f64>>,
}

/// ∂u/∂p on node interval k at fraction a: (control, parameter, value).
fn control_partials(
    setup: &Setup,
    c: &Controls6,
    k: usize,
    a: f64,
    out: &mut Vec<(usize, usize, f64)>,
) {
    out.clear();
    let (par, n) = (setup.par, setup.par.n);
    if k + 1 < n {
        out.push((su::T, par.thrust(k), 1.0 - a));
        out.push((su::T, par.thrust(k + 1), a));
    } else {
        out.push((su::T, par.thrust(n - 1), 1.0));
    }
    let dt = c.interval_s(k);
    let u = c.at_fraction(k, a);
    for j in 0..2 {
        out.push((su::CHI + j, par.delta(j, k + 1), 1.0 / dt));
        if k >= 1 {
            out.push((su::CHI + j, par.delta(j, k), -1.0 / dt));
        }
        // χ = Δδ/d_k: ∂χ/∂d_k = −χ/d_k.
        out.push((su::CHI + j, par.duration(k), -u[su::CHI + j] / dt));
    }
}

/// The most parameters that one node interval's controls read: T_k,
/// T_{k+1}, δ_k and δ_{k+1} (two each), and d_k.
const MAX_LOCAL: usize = 7;
/// The columns of an interval's local sensitivities ∂/∂(x_k, p_local).
const NT: usize = NX + MAX_LOCAL;

/// The parameters that node interval k reads, p_local (slots past `len`
/// unused): the shot's sensitivities on the interval are taken against
/// (x_k, p_local) and mapped to p once at its end (module docs of
/// [`shoot_visiting`]).
#[derive(Debug, Clone, Copy)]
struct Local {
    params: [usize; MAX_LOCAL],
    len: usize,
}

impl Local {
    fn new(par: Params, k: usize) -> Self {
        let mut l = Local {
            params: [0; MAX_LOCAL],
            len: 0,
        };
        let mut push = |i: usize| {
            l.params[l.len] = i;
            l.len += 1;
        };
        push(par.thrust(k));
        if k + 1 < par.n {
            push(par.thrust(k + 1));
        }
        for j in 0..2 {
            push(par.delta(j, k + 1));
            if k >= 1 {
                push(par.delta(j, k));
            }
        }
        push(par.duration(k));
        l
    }

    /// The local column (NX + slot) of parameter i, one that the interval
    /// reads ([`control_partials`] names no other).
    fn column(&self, i: usize) -> usize {
        let slot = self.params[..self.len].iter().position(|&q| q == i);
        NX + slot.expect("the interval's controls read only its local parameters")
    }

    /// Row r of ∂x/∂p from the local sensitivities T (NX × NT) and S_k
    /// (NX rows of P, zero past `live`): Σ_m T_rm·S_k,m + Σ_j T_r,NX+j·e_pj.
    fn globalize(&self, t: &[f64], r: usize, s: &[f64], np: usize, live: usize, out: &mut [f64]) {
        out.fill(0.0);
        let row = &t[r * NT..(r + 1) * NT];
        for m in 0..NX {
            if row[m] != 0.0 {
                for (o, v) in out[..live].iter_mut().zip(&s[m * np..m * np + live]) {
                    *o += row[m] * v;
                }
            }
        }
        for j in 0..self.len {
            out[self.params[j]] += row[NX + j];
        }
    }
}

/// (dx/dσ, dT/dσ) at (x, T) on interval k at fraction a = σ of it, whose
/// duration is d_k: dx/dσ = d_k·f, dT/dσ = d_k·(f_x·T + f_u·∂u/∂p_local) +
/// f ⊗ e_{d_k}. T and dT/dσ are NX rows of NT, row-major; dT/dσ is written
/// into `dt`.
#[allow(clippy::too_many_arguments)] // The stage, its place and its output.
fn derivative(
    setup: &Setup,
    c: &Controls6,
    (k, a): (usize, f64),
    local: &Local,
    x: &[f64; NX],
    t: &[f64],
    partials: &mut Vec<(usize, usize, f64)>,
    dt: &mut [f64],
) -> [f64; NX] {
    let u = c.at_fraction(k, a);
    let (f, jac) = six::jacobian(setup.model, x, &u);
    control_partials(setup, c, k, a, partials);
    for q in partials.iter_mut() {
        q.1 = local.column(q.1);
    }
    let dk = c.interval_s(k);
    let duration = local.column(setup.par.duration(k));
    for r in 0..NX {
        let row = &mut dt[r * NT..(r + 1) * NT];
        row.fill(0.0);
        for m in 0..NX {
            let j = jac[r][m];
            if j != 0.0 {
                for (o, v) in row.iter_mut().zip(&t[m * NT..(m + 1) * NT]) {
                    *o += j * v;
                }
            }
        }
        for &(ui, col, v) in partials.iter() {
            row[col] += jac[r][NX + ui] * v;
        }
        for o in row.iter_mut() {
            *o *= dk;
        }
        row[duration] += f[r];
    }
    std::array::from_fn(|r| dk * f[r])
}

/// One RK4 stage of a shot, as [`shoot_visiting`] shows it: node interval
/// k, the fraction a of it, the stage's state Y and its local
/// sensitivities ∂Y/∂(x_k, p_local) (NX rows of NT, row-major).
struct Stage<'a> {
    k: usize,
    a: f64,
    y: &'a [f64; NX],
    t: &'a [f64],
    local: &'a Local,
}

/// What a shot shows as it goes ([`shoot_visiting`]).
trait Visit {
    /// Each RK4 stage, in order (four per step, the steps in time).
    fn stage(&mut self, st: &Stage);
    /// The end of node interval k, with S_k = ∂x_k/∂p at its start (NX
    /// rows of P, zero past `Params::live(k)`).
    fn interval(&mut self, _k: usize, _s: &[f64], _local: &Local) {}
    /// Whether the shot is to carry its sensitivities; without them it
    /// flies the same states (the same bits) at a fraction of the cost,
    /// and shows each stage an empty `t` and the intervals S_k = 0.
    fn sensitivities(&self) -> bool {
        true
    }
}

impl<F: FnMut(&Stage)> Visit for F {
    fn stage(&mut self, st: &Stage) {
        self(st)
    }
}

/// A visitor that reads the stages' states only ([`Visit::sensitivities`]).
struct StatesOnly<F>(F);

impl<F: FnMut(&Stage)> Visit for StatesOnly<F> {
    fn stage(&mut self, st: &Stage) {
        (self.0)(st)
    }
    fn sensitivities(&self) -> bool {
        false
    }
}

/// The shot of the controls `p` (module docs).
fn shoot(setup: &Setup, p: &[f64]) -> Shot {
    shoot_visiting(setup, p, &mut |_: &Stage| {})
}

/// [`shoot`], showing `visit` every RK4 stage and every interval's end.
///
/// The sensitivities are condensed by interval: on interval k the flight
/// depends on p only through its start x_k and the few parameters that
/// its controls read (p_local, [`Local`]), so RK4 carries T = ∂x/∂(x_k,
/// p_local) (NX × NT) and, at the interval's end, S_{k+1} = T_x·S_k +
/// T_p·E_local. The step points' altitude rows are mapped the same way.
/// Carrying ∂x/∂p itself cost NX × P per stage, P = 4N.
fn shoot_visiting(setup: &Setup, p: &[f64], visit: &mut dyn Visit) -> Shot {
    let carry = visit.sensitivities();
    let c = setup.controls(p);
    let np = setup.par.len();
    let mut x = setup.x0;
    let mut s = vec![0.0; NX * np];
    let mut s_next = vec![0.0; NX * np];
    let mut partials = Vec::with_capacity(8);
    let (mut z, mut d_z) = (Vec::new(), Vec::new());
    let mut t = vec![0.0; NX * NT];
    // The stages' dT/dσ, and a stage's T.
    let mut ks: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0; NX * NT]);
    let mut ty = vec![0.0; NX * NT];
    let axpy = |x: &[f64; NX], k: &[f64; NX], h: f64| -> [f64; NX] {
        std::array::from_fn(|i| x[i] + h * k[i])
    };
    let saxpy = |out: &mut [f64], s: &[f64], k: &[f64], h: f64| {
        for ((o, a), b) in out.iter_mut().zip(s).zip(k) {
            *o = a + h * b;
        }
    };
    for k in 0..setup.par.n {
        let (m, live, local) = (
            setup.substeps[k],
            setup.par.live(k),
            Local::new(setup.par, k),
        );
        t.fill(0.0);
        for r in 0..NX {
            t[r * NT + r] = 1.0;
        }
        // σ ∈ [0, 1] on each interval.
        let h = 1.0 / m as f64;
        for i in 0..m {
            if (k > 0 || i > 0) && carry {
                z.push(x[sx::Z]);
                let mut row = vec![0.0; np];
                local.globalize(&t, sx::Z, &s, np, live, &mut row);
                d_z.push(row);
            }
            let a0 = i as f64 / m as f64;
            let (a1, a2) = (a0 + 0.5 / m as f64, a0 + 1.0 / m as f64);
            let [k1s, k2s, k3s, k4s] = &mut ks;
            let mut stage = |a: f64, y: &[f64; NX], ty: &[f64], out: &mut [f64]| {
                visit.stage(&Stage {
                    k,
                    a,
                    y,
                    t: if carry { ty } else { &[] },
                    local: &local,
                });
                if carry {
                    derivative(setup, &c, (k, a), &local, y, ty, &mut partials, out)
                } else {
                    let (f, dk) = (
                        six::rhs(setup.model, y, &c.at_fraction(k, a)),
                        c.interval_s(k),
                    );
                    f.map(|v| dk * v)
                }
            };
            let k1x = stage(a0, &x, &t, k1s);
            let y2 = axpy(&x, &k1x, 0.5 * h);
            if carry {
                saxpy(&mut ty, &t, k1s, 0.5 * h);
            }
            let k2x = stage(a1, &y2, &ty, k2s);
            let y3 = axpy(&x, &k2x, 0.5 * h);
            if carry {
                saxpy(&mut ty, &t, k2s, 0.5 * h);
            }
            let k3x = stage(a1, &y3, &ty, k3s);
            let y4 = axpy(&x, &k3x, h);
            if carry {
                saxpy(&mut ty, &t, k3s, h);
            }
            let k4x = stage(a2, &y4, &ty, k4s);
            for r in 0..NX {
                x[r] += h / 6.0 * (k1x[r] + 2.0 * k2x[r] + 2.0 * k3x[r] + k4x[r]);
            }
            if carry {
                for q in 0..NX * NT {
                    t[q] += h / 6.0 * (k1s[q] + 2.0 * k2s[q] + 2.0 * k3s[q] + k4s[q]);
                }
            }
        }
        visit.interval(k, &s, &local);
        if !carry {
            continue;
        }
        for r in 0..NX {
            local.globalize(&t, r, &s, np, live, &mut s_next[r * np..(r + 1) * np]);
        }
        std::mem::swap(&mut s, &mut s_next);
    }
    Shot {
        end: x,
        d_end: s.chunks(np).map(<[f64]>::to_vec).collect(),
        z,
        d_z,
    }
}

/// The exact-penalty merit of a shot: −m_f/MASS_SCALE + PENALTY·(Σ|r̂| +
/// the ground's and the dry mass's violations, in m and kg).
fn merit(setup: &Setup, shot: &Shot) -> f64 {
    let r: f64 = setup.residuals(&shot.end).iter().map(|v| v.abs()).sum();
    -shot.end[sx::M] / MASS_SCALE_KG + PENALTY * (r + violation(setup, shot))
}

/// The largest of the ground's and the dry mass's violations of a shot
/// \[m, kg\]: the QP softens all their rows by one slack, which models
/// this largest violation, so that the merit's predicted decrease is the
/// merit's own. (A sum over the step points, against the slack's largest,
/// predicted a decrease of every point's violation from a step that
/// lowered one: from starts that flew through the ground at many points,
/// every trial fell short and the polish stopped.)
fn violation(setup: &Setup, shot: &Shot) -> f64 {
    let ground = shot
        .z
        .iter()
        .map(|z| setup.target.z_m - z)
        .fold(0.0, f64::max);
    ground.max(setup.model.planar.dry_mass_kg - shot.end[sx::M])
}

/// The unit normals of the faces of the polygon inscribed in a disc.
fn faces() -> impl Iterator<Item = [f64; 2]> {
    let step = std::f64::consts::TAU / FACES as f64;
    (0..FACES).map(move |j| {
        let a = j as f64 * step;
        [a.cos(), a.sin()]
    })
}

/// The control rows over Δp̂ at p (module docs): the thrust's box, the
/// faces of the gimbal's and of its rate's discs near each vector, and
/// t_f > 0. Linear in p, so exact.
fn control_rows(setup: &Setup, p: &[f64]) -> Vec<Row> {
    let (par, n) = (setup.par, setup.par.n);
    let sc = &setup.scale;
    let planar = &setup.model.planar;
    let mut rows: Vec<Row> = Vec::new();
    for k in 0..n {
        let i = par.thrust(k);
        let margin = BOUND_MARGIN * (planar.max_thrust_n - planar.min_thrust_n);
        rows.push((vec![(i, sc[i])], planar.max_thrust_n - margin - p[i]));
        rows.push((vec![(i, -sc[i])], p[i] - planar.min_thrust_n - margin));
    }
    let cos_face = (std::f64::consts::PI / FACES as f64).cos() * (1.0 - BOUND_MARGIN);
    let c = setup.controls(p);
    for k in 1..=n {
        // ‖δ_k‖ ≤ δ_max: n·(δ_k + Δδ_k) ≤ δ_max·cos(π/F).
        let d = c.delta_rad[k];
        for nv in faces() {
            let cols = vec![
                (par.delta(0, k), nv[0] * sc[par.delta(0, k)]),
                (par.delta(1, k), nv[1] * sc[par.delta(1, k)]),
            ];
            rows.push((
                cols,
                planar.max_gimbal_rad * cos_face - (nv[0] * d[0] + nv[1] * d[1]),
            ));
        }
    }
    for k in 0..n {
        // ‖δ_{k+1} − δ_k‖ ≤ χ_max·d_k.
        let (d0, d1) = (c.delta_rad[k], c.delta_rad[k + 1]);
        let diff = [d1[0] - d0[0], d1[1] - d0[1]];
        let (dk, di) = (p[par.duration(k)], par.duration(k));
        let reach = planar.max_gimbal_rate_radps * cos_face;
        for nv in faces() {
            let mut cols = Vec::with_capacity(5);
            for j in 0..2 {
                cols.push((par.delta(j, k + 1), nv[j] * sc[par.delta(j, k + 1)]));
                if k >= 1 {
                    cols.push((par.delta(j, k), -nv[j] * sc[par.delta(j, k)]));
                }
            }
            cols.push((di, -reach * sc[di]));
            rows.push((cols, reach * dk - (nv[0] * diff[0] + nv[1] * diff[1])));
        }
        // MIN_DURATION_S ≤ d_k ≤ its substeps' STEP_S each.
        rows.push((vec![(di, -sc[di])], dk - MIN_DURATION_S));
        let longest = setup.substeps[k] as f64 * STEP_S;
        rows.push((vec![(di, sc[di])], longest - dk));
    }
    rows
}

/// Whether p holds its control rows (each row's slack h − G·0 ≥ 0, to
/// rounding): the thrust's box, and the polygons, which lie inside the
/// discs.
fn holds_controls(setup: &Setup, p: &[f64]) -> bool {
    control_rows(setup, p).iter().all(|(cols, h)| {
        let size = cols.iter().map(|(_, v)| v.abs()).fold(0.0, f64::max);
        *h >= -1e-12 * size.max(1.0)
    })
}

/// The QP's inequality rows over Δp̂ (then the slacks: 20 of the landing,
/// one of the ground), at p.
/// Also returns the nonlinear rows' places: (row, step point) of each
/// ground row, and the dry mass's row.
fn inequality_rows(
    setup: &Setup,
    p: &[f64],
    shot: &Shot,
    ground_slack: usize,
) -> (Vec<Row>, Vec<(usize, usize)>, usize) {
    let (par, sc) = (setup.par, &setup.scale);
    let planar = &setup.model.planar;
    let mut rows = control_rows(setup, p);
    let mut ground = Vec::new();
    // The ground at the step points near it, and the dry mass, each
    // softened by the one slack g ≥ 0: −∂z·Δp − g ≤ z − z_f.
    for (i, (z, dz)) in shot.z.iter().zip(&shot.d_z).enumerate() {
        if z - setup.target.z_m < GROUND_WINDOW_M {
            ground.push((rows.len(), i));
            let mut cols: Vec<(usize, f64)> = dz
                .iter()
                .enumerate()
                .map(|(i, v)| (i, -v * sc[i]))
                .collect();
            cols.push((ground_slack, -1.0));
            rows.push((cols, z - setup.target.z_m - GROUND_MARGIN_M));
        }
    }
    let mut cols: Vec<(usize, f64)> = shot.d_end[sx::M]
        .iter()
        .enumerate()
        .map(|(i, v)| (i, -v * sc[i]))
        .collect();
    cols.push((ground_slack, -1.0));
    let mass_row = rows.len();
    rows.push((cols, shot.end[sx::M] - planar.dry_mass_kg));
    for s in par.len()..=ground_slack {
        rows.push((vec![(s, -1.0)], 0.0));
    }
    (rows, ground, mass_row)
}

/// The multipliers of a QP's nonlinear rows: the landing's (10), and the
/// ground's by step point with the dry mass's.
struct Multipliers {
    landing: Vec<f64>,
    ground: Vec<(usize, f64)>,
    mass: f64,
}

/// ∇L over p̂ of L = −m_f/MASS_SCALE + Σ y_j·r̂_j − Σ z_i·z(s_i) − z_m·m_f
/// at a shot: the QP's rows' gradients with its multipliers (its
/// stationarity is P·x + q + Aᵀ·y + Gᵀ·z = 0). The control rows are linear
/// and add no curvature.
fn lagrangian_gradient(setup: &Setup, shot: &Shot, mult: &Multipliers) -> Vec<f64> {
    let sc = &setup.scale;
    (0..setup.par.len())
        .map(|i| {
            let mut g = -shot.d_end[sx::M][i] / MASS_SCALE_KG;
            for (j, &(s, scale)) in LANDING.iter().enumerate() {
                g += mult.landing[j] * shot.d_end[s][i] / scale;
            }
            for &(point, z) in &mult.ground {
                g -= z * shot.d_z[point][i];
            }
            g -= mult.mass * shot.d_end[sx::M][i];
            g * sc[i]
        })
        .collect()
}

/// Λ's weights (∇Λ = [`lagrangian_gradient`]): λ_f on the end state, and
/// on the altitude at each ground row's step point.
fn lagrangian_weights(mult: &Multipliers) -> ([f64; NX], Vec<(usize, f64)>) {
    let mut lambda_f = [0.0; NX];
    lambda_f[sx::M] = -1.0 / MASS_SCALE_KG - mult.mass;
    for (j, &(s, scale)) in LANDING.iter().enumerate() {
        lambda_f[s] += mult.landing[j] / scale;
    }
    let ground = mult.ground.iter().map(|&(point, z)| (point, -z)).collect();
    (lambda_f, ground)
}

/// The least change (scaled) of `p` that zeroes the landing residual r of
/// the shot `at` to first order, with the Jacobian of `shot`, and holds every control
/// row: the minimum-norm solution Δ = M⁺·b of M = (landing rows;
/// the control rows held as equalities), b = (−r; their slacks), by linear
/// algebra rather than the QP, whose absolute accuracy (~1e-8 in p̂,
/// ~1e-5 m at the landing) is coarser than the corrections near the end.
/// The rows held are those active at p (within rounding of their bound),
/// then any that the last Δ broke, put on their bound, for a few rounds
/// (an active set, since a correction that leaves the control bounds is
/// no correction: the finish would clamp it back off the landing). `None`
/// where the rounds do not settle or the linear algebra fails. Used as the
/// second-order correction of a trial step (Maratos) and for the last
/// corrections.
fn correction(setup: &Setup, shot: &Shot, p: &[f64], at: &Shot) -> Option<Vec<f64>> {
    let np = setup.par.len();
    let rows = control_rows(setup, p);
    let size = |cols: &[(usize, f64)]| cols.iter().map(|(_, v)| v.abs()).fold(0.0, f64::max);
    let mut held: Vec<usize> = (0..rows.len())
        .filter(|&j| rows[j].1.abs() <= 1e-6 * size(&rows[j].0))
        .collect();
    for _ in 0..CORRECTION_ROUNDS {
        let step = min_norm_step(setup, shot, at, &rows, &held)?;
        // The most broken row of each bound (rows over the same
        // variables: a disc's faces, a thrust's two sides).
        let mut worst: std::collections::BTreeMap<Vec<usize>, (f64, usize)> = Default::default();
        for (j, (cols, h)) in rows.iter().enumerate() {
            let g: f64 = cols.iter().map(|&(i, v)| v * step[i]).sum();
            let excess = (g - h) / size(cols).max(1.0);
            if excess > 1e-12 && !held.contains(&j) {
                let key = cols.iter().map(|&(i, _)| i).collect();
                let e = worst.entry(key).or_insert((excess, j));
                if excess > e.0 {
                    *e = (excess, j);
                }
            }
        }
        if worst.is_empty() {
            return Some((0..np).map(|i| p[i] + step[i] * setup.scale[i]).collect());
        }
        held.extend(worst.values().map(|&(_, j)| j));
    }
    None
}

/// The rounds of [`correction`]'s active set.
const CORRECTION_ROUNDS: usize = 6;

/// [`correction`]'s Δ (scaled): the landing residual of `at` zeroed and
/// the control rows `held` as equalities G·Δ = h (on their bound), to
/// first order with the Jacobian of `shot`. (Raising the points of `at`
/// below the pad as well was tried: the same masses, slower.)
fn min_norm_step(
    setup: &Setup,
    shot: &Shot,
    at: &Shot,
    rows: &[Row],
    held: &[usize],
) -> Option<nalgebra::DVector<f64>> {
    let np = setup.par.len();
    let r = setup.residuals(&at.end);
    let m = 10 + held.len();
    let mut mat = nalgebra::DMatrix::zeros(m, np);
    let mut rhs = nalgebra::DVector::zeros(m);
    for j in 0..10 {
        let (s, sc) = LANDING[j];
        for i in 0..np {
            mat[(j, i)] = shot.d_end[s][i] * setup.scale[i] / sc;
        }
        rhs[j] = -r[j];
    }
    let o = 10;
    for (a, &j) in held.iter().enumerate() {
        let (cols, h) = &rows[j];
        for &(i, v) in cols {
            mat[(o + a, i)] = v;
        }
        rhs[o + a] = *h;
    }
    if !(mat.iter().all(|v| v.is_finite()) && rhs.iter().all(|v| v.is_finite())) {
        return None;
    }
    // The minimum-norm solution by a bounded SVD of M itself (of MMᵀ
    // would square its condition), a pseudo-inverse where held rows are
    // dependent.
    mat.try_svd(true, true, f64::EPSILON, 500)
        .and_then(|svd| svd.solve(&rhs, 1e-12).ok())
}

/// The damped BFGS update of B (n × n, row-major) by the step s and the
/// change y of ∇L (Powell's damping keeps B positive definite); the first
/// update starts from (yᵀy/sᵀy)·I.
fn bfgs_update(b: &mut [f64], n: usize, s: &[f64], y: &[f64], first: bool) {
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(a, b)| a * b).sum::<f64>();
    let sy = dot(s, y);
    if first {
        let scale = if sy > 0.0 { dot(y, y) / sy } else { 1.0 };
        b.iter_mut().for_each(|v| *v = 0.0);
        for i in 0..n {
            b[i * n + i] = scale;
        }
    }
    let bs: Vec<f64> = (0..n).map(|i| dot(&b[i * n..(i + 1) * n], s)).collect();
    let sbs = dot(s, &bs);
    if sbs <= 0.0 {
        return;
    }
    let theta = if sy >= 0.2 * sbs {
        1.0
    } else {
        0.8 * sbs / (sbs - sy)
    };
    let r: Vec<f64> = (0..n)
        .map(|i| theta * y[i] + (1.0 - theta) * bs[i])
        .collect();
    let sr = dot(s, &r);
    if sr <= 0.0 {
        return;
    }
    for i in 0..n {
        for j in 0..n {
            b[i * n + j] += r[i] * r[j] / sr - bs[i] * bs[j] / sbs;
        }
    }
}

/// Polish the raw answer's controls `raw` from x0 (module docs).
pub fn polish(model: &SixDof, x0: [f64; NX], target: &TerminalState, raw: &Controls6) -> Polished6 {
    let n = raw.thrust_n.len();
    let par = Params { n };
    let mut scale = vec![0.0; par.len()];
    for k in 0..n {
        scale[par.thrust(k)] = model.planar.max_thrust_n;
        scale[par.delta(0, k + 1)] = model.planar.max_gimbal_rad;
        scale[par.delta(1, k + 1)] = model.planar.max_gimbal_rad;
    }
    for k in 0..n {
        scale[par.duration(k)] = raw.tf_s / n as f64;
    }
    // Room for each interval to grow by half with steps of at most STEP_S.
    let substeps = (0..n)
        .map(|k| ((GROWTH * raw.interval_s(k) / STEP_S).ceil() as usize).max(1))
        .collect();
    let setup = Setup {
        model,
        x0,
        target,
        substeps,
        par,
        scale,
    };
    let mut p = vec![0.0; par.len()];
    for k in 0..n {
        p[par.thrust(k)] = raw.thrust_n[k];
        p[par.delta(0, k + 1)] = raw.delta_rad[k + 1][0];
        p[par.delta(1, k + 1)] = raw.delta_rad[k + 1][1];
    }
    for k in 0..n {
        p[par.duration(k)] = raw.interval_s(k);
    }
    run(&setup, p)
}

/// p moved to the nearest controls (in the scaled norm) that hold the
/// control rows: the raw answer's secant rates may break the rate's disc.
/// Each pass holds the faces near the current vectors; a few passes settle
/// them.
fn project(setup: &Setup, mut p: Vec<f64>) -> Result<Vec<f64>, String> {
    let np = setup.par.len();
    for _ in 0..8 {
        if holds_controls(setup, &p) {
            return Ok(p);
        }
        let le = control_rows(setup, &p);
        let answer = qp::solve(&Problem {
            p: &vec![1.0; np],
            dense: None,
            q: &vec![0.0; np],
            eq: &[],
            le: &le,
        })
        .map_err(|e| format!("the projection onto the control bounds failed: {e}"))?;
        for i in 0..np {
            p[i] += answer.x[i] * setup.scale[i];
        }
    }
    if holds_controls(setup, &p) {
        Ok(p)
    } else {
        Err("the projection onto the control bounds did not settle".into())
    }
}

/// One QP step at p (module docs): Δp̂, the multipliers of its nonlinear
/// rows, its predicted mass gain \[kg\], the landing residual it leaves to
/// first order, and the ground slack it uses.
struct Step {
    dp: Vec<f64>,
    mult: Multipliers,
    gain_kg: f64,
    linear_residual: f64,
    ground_slack: f64,
}

/// The QP of one iteration at p, with the proximal weight ε and the
/// quasi-Newton Hessian `b` when it has one.
fn qp_step(
    setup: &Setup,
    p: &[f64],
    shot: &Shot,
    eps: f64,
    b: Option<&[f64]>,
) -> Result<Step, String> {
    let np = setup.par.len();
    let (landing_slacks, ground_slack) = (np, np + 20);
    let nv = ground_slack + 1;
    let r = setup.residuals(&shot.end);
    let gain: Vec<f64> = (0..np)
        .map(|i| shot.d_end[sx::M][i] * setup.scale[i])
        .collect();
    let mut diag = vec![0.0; nv];
    diag[..np].iter_mut().for_each(|v| *v = eps);
    let mut q = vec![PENALTY; nv];
    for i in 0..np {
        q[i] = -gain[i] / MASS_SCALE_KG;
    }
    let landing_row = |j: usize, i: usize| {
        let (s, sc) = LANDING[j];
        shot.d_end[s][i] * setup.scale[i] / sc
    };
    let eq: Vec<Row> = (0..10)
        .map(|j| {
            let mut cols: Vec<(usize, f64)> = (0..np).map(|i| (i, landing_row(j, i))).collect();
            cols.push((landing_slacks + j, 1.0));
            cols.push((landing_slacks + 10 + j, -1.0));
            (cols, -r[j])
        })
        .collect();
    let (le, ground_rows, mass_row) = inequality_rows(setup, p, shot, ground_slack);
    let answer = qp::solve(&Problem {
        p: &diag,
        dense: b,
        q: &q,
        eq: &eq,
        le: &le,
    })
    .map_err(|e| format!("a QP failed: {e}"))?;
    let dp = answer.x[..np].to_vec();
    // The linearized landing residual after the step, r + ∇r·Δ, from the
    // step itself (the QP's own slacks hide its absolute accuracy).
    let linear_residual = (0..10)
        .map(|j| (r[j] + (0..np).map(|i| landing_row(j, i) * dp[i]).sum::<f64>()).abs())
        .sum();
    Ok(Step {
        gain_kg: (0..np).map(|i| gain[i] * dp[i]).sum(),
        linear_residual,
        ground_slack: answer.x[ground_slack],
        mult: Multipliers {
            landing: answer.y.clone(),
            ground: ground_rows
                .iter()
                .map(|&(row, point)| (point, answer.z[row]))
                .collect(),
            mass: answer.z[mass_row],
        },
        dp,
    })
}

/// A trial point, its shot, merit and ratio of actual to predicted merit
/// decrease.
struct Trial {
    p: Vec<f64>,
    shot: Shot,
    phi: f64,
    rho: f64,
}

/// Second-order corrections of a trial (Maratos): back onto the landing
/// from the trial's own residual, Newton with each shot's Jacobian, while
/// they raise the ratio.
fn corrected(setup: &Setup, base: &Shot, phi: f64, predicted: f64, mut t: Trial) -> Trial {
    let mut once = false;
    for _ in 0..SECOND_ORDER_CORRECTIONS {
        // The Jacobian of the last corrected shot, or of the base.
        let from = if once { &t.shot } else { base };
        let Some(p2) = correction(setup, from, &t.p, &t.shot) else {
            break;
        };
        let shot2 = shoot(setup, &p2);
        let phi2 = merit(setup, &shot2);
        let rho2 = (phi - phi2) / predicted.max(1e-16);
        if rho2 <= t.rho {
            break;
        }
        once = true;
        t = Trial {
            p: p2,
            shot: shot2,
            phi: phi2,
            rho: rho2,
        };
    }
    t
}

/// At convergence: the thrust put on its box exactly (the QP holds its rows
/// to its tolerance, ~1e-9 of T_max), then Newton corrections on the
/// landing alone, each keeping the active bounds. Whether the residual
/// reached [`CORRECTED_RESIDUAL`], or why not.
fn finish_landing(setup: &Setup, p: &mut Vec<f64>, shot: &mut Shot) -> Result<(), String> {
    let (par, planar) = (setup.par, &setup.model.planar);
    let margin = BOUND_MARGIN * (planar.max_thrust_n - planar.min_thrust_n);
    for k in 0..par.n {
        let t = &mut p[par.thrust(k)];
        *t = t.clamp(planar.min_thrust_n + margin, planar.max_thrust_n - margin);
    }
    *shot = shoot(setup, p);
    for _ in 0..CORRECTIONS {
        let r = setup.residuals(&shot.end);
        if r.iter().map(|v| v.abs()).sum::<f64>() < CORRECTED_RESIDUAL {
            break;
        }
        let Some(q) = correction(setup, shot, p, shot) else {
            break;
        };
        let next = shoot(setup, &q);
        if violation(setup, &next) > 0.0 || !holds_controls(setup, &q) {
            break;
        }
        (*p, *shot) = (q, next);
    }
    let residual: f64 = setup.residuals(&shot.end).iter().map(|v| v.abs()).sum();
    // The control bounds are checked exactly on the flown controls by the
    // caller (`pipeline::six_dof`).
    if residual < CORRECTED_RESIDUAL {
        Ok(())
    } else {
        Err(format!(
            "the last corrections left a landing residual of {residual:.2e}"
        ))
    }
}

/// The QPs' curvature over p̂ (module docs): a damped BFGS model of the
/// Lagrangian's Hessian, after its first update (before it, the proximal
/// term alone); once the shot is near the landing, the exact Hessian at
/// the current p with the last QP's multipliers ([`hessian`]), its
/// eigenvalues raised to a floor ([`crate::polish::hessian::clipped`]).
struct Curvature {
    bfgs: Vec<f64>,
    updated: bool,
    newton: bool,
    exact: Option<Vec<f64>>,
}

impl Curvature {
    fn new(np: usize) -> Self {
        Curvature {
            bfgs: vec![0.0; np * np],
            updated: false,
            newton: false,
            exact: None,
        }
    }

    /// At p, with its landing residual and violation and the last QP's
    /// multipliers: start the Newton mode when near (the proximal weight
    /// starts again), and compute the exact curvature where p moved.
    fn prepare(
        &mut self,
        setup: &Setup,
        p: &[f64],
        (residual, v0): (f64, f64),
        last: Option<&Multipliers>,
        eps: &mut f64,
    ) {
        let Some(mult) = last else { return };
        if !self.newton && residual < NEAR_RESIDUAL && v0 < NEAR_VIOLATION_M {
            self.newton = true;
            *eps = NEWTON_PROXIMAL_INITIAL;
        }
        if self.newton && self.exact.is_none() {
            let (lambda_f, ground) = lagrangian_weights(mult);
            let mut h = hessian::hessian(setup, p, &lambda_f, &ground);
            let (np, sc) = (setup.par.len(), &setup.scale);
            for i in 0..np {
                for j in 0..np {
                    h[i * np + j] *= sc[i] * sc[j];
                }
            }
            self.exact = crate::polish::hessian::clipped(&h, EIGENVALUE_FLOOR);
        }
    }

    /// The QP's dense block, if any.
    fn matrix(&self) -> Option<&[f64]> {
        match &self.exact {
            Some(h) => Some(h),
            None => self.updated.then_some(&self.bfgs[..]),
        }
    }

    /// An accepted step s (scaled) with the change y of ∇L along it.
    fn accepted(&mut self, s: &[f64], y: &[f64]) {
        bfgs_update(&mut self.bfgs, s.len(), s, y, !self.updated);
        self.updated = true;
        self.exact = None;
    }

    /// The least proximal weight.
    fn least_weight(&self) -> f64 {
        if self.newton {
            NEWTON_PROXIMAL_MIN
        } else {
            PROXIMAL_MIN
        }
    }
}

/// The Newton mode starts where the scaled landing residual (Σ|r̂|) and the
/// ground's violation \[m\] are below these.
const NEAR_RESIDUAL: f64 = 1e-2;
const NEAR_VIOLATION_M: f64 = 1e-2;
/// The proximal weight with which the Newton mode starts, and its least.
const NEWTON_PROXIMAL_INITIAL: f64 = 1e-2;
const NEWTON_PROXIMAL_MIN: f64 = 1e-8;
/// The least eigenvalue of the Newton mode's curvature.
const EIGENVALUE_FLOOR: f64 = 1e-8;

/// The iteration (module docs).
fn run(setup: &Setup, p: Vec<f64>) -> Polished6 {
    let np = setup.par.len();
    let mut p = match project(setup, p.clone()) {
        Ok(p) => p,
        Err(message) => {
            return Polished6 {
                controls: setup.controls(&p),
                iterations: 0,
                converged: false,
                message,
            };
        }
    };
    let mut shot = shoot(setup, &p);
    let mut phi = merit(setup, &shot);
    let mut eps = PROXIMAL_INITIAL;
    let mut curvature = Curvature::new(np);
    let mut last: Option<Multipliers> = None;
    let mut outcome = Err(String::from("the iteration limit was reached"));
    let mut iterations = 0;
    while iterations < MAX_ITERATIONS {
        iterations += 1;
        let residual: f64 = setup.residuals(&shot.end).iter().map(|v| v.abs()).sum();
        let v0 = violation(setup, &shot);
        curvature.prepare(setup, &p, (residual, v0), last.as_ref(), &mut eps);
        let step = match qp_step(setup, &p, &shot, eps, curvature.matrix()) {
            Ok(s) => s,
            Err(e) => {
                outcome = Err(e);
                break;
            }
        };
        // Converged where the QP finds no gain worth a step (none at all, or
        // a loss that its linearized rows ask for, near the rounding).
        if residual < RESIDUAL_TOLERANCE && v0 == 0.0 && step.gain_kg < MASS_TOLERANCE_KG {
            outcome = finish_landing(setup, &mut p, &mut shot);
            break;
        }
        let dp = &step.dp;
        let quadratic: f64 = curvature.matrix().map_or(0.0, |b| {
            (0..np)
                .map(|i| dp[i] * (0..np).map(|j| b[i * np + j] * dp[j]).sum::<f64>())
                .sum()
        });
        let predicted = step.gain_kg / MASS_SCALE_KG - 0.5 * quadratic
            + PENALTY * (residual - step.linear_residual + v0 - step.ground_slack);
        let trial: Vec<f64> = (0..np).map(|i| p[i] + dp[i] * setup.scale[i]).collect();
        let next = shoot(setup, &trial);
        let phi_next = merit(setup, &next);
        let mut t = Trial {
            p: trial,
            shot: next,
            phi: phi_next,
            rho: (phi - phi_next) / predicted.max(1e-16),
        };
        if t.rho < 0.75 {
            t = corrected(setup, &shot, phi, predicted, t);
        }
        if t.phi < phi && t.rho >= 0.1 {
            let s: Vec<f64> = (0..np).map(|i| (t.p[i] - p[i]) / setup.scale[i]).collect();
            let before = lagrangian_gradient(setup, &shot, &step.mult);
            let after = lagrangian_gradient(setup, &t.shot, &step.mult);
            let y: Vec<f64> = after.iter().zip(&before).map(|(a, b)| a - b).collect();
            curvature.accepted(&s, &y);
            if t.rho > 0.4 {
                eps = (0.25 * eps).max(curvature.least_weight());
            }
            (p, shot, phi) = (t.p, t.shot, t.phi);
        } else {
            eps *= 4.0;
            if eps > PROXIMAL_MAX {
                outcome = Err("the steps stopped decreasing the merit".into());
                break;
            }
        }
        last = Some(step.mult);
    }
    Polished6 {
        controls: setup.controls(&p),
        iterations,
        converged: outcome.is_ok(),
        message: outcome.err().unwrap_or_default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;
    use crate::problem::six_dof::planar_state;

    /// A short seeded flight's setup and controls: N = 6 node intervals
    /// over 3 s from a state off the plane, each of 3 RK4 steps, unscaled.
    fn fixture<'a>(model: &'a SixDof, target: &'a TerminalState) -> (Setup<'a>, Vec<f64>) {
        let mut x0 = planar_state(&[-40.0, 300.0, 15.0, -70.0, 0.9, -0.25, 105_000.0, 0.12]);
        x0[sx::Y] = 25.0;
        x0[sx::VY] = -6.0;
        x0[sx::W + 2] = 0.02;
        let tau: Vec<f64> = (0..=6)
            .map(|k| -1.0 + 2.0 * (k as f64 / 6.0).powf(1.2))
            .collect();
        let n = 6;
        let par = Params { n };
        let mut p = vec![0.0; par.len()];
        for k in 0..n {
            p[par.thrust(k)] = model.planar.min_thrust_n
                + (0.2 + 0.1 * k as f64) * (model.planar.max_thrust_n - model.planar.min_thrust_n);
            p[par.delta(0, k + 1)] = 0.12 - 0.03 * k as f64;
            p[par.delta(1, k + 1)] = 0.02 * (k as f64 - 2.0);
            p[par.duration(k)] = 0.5 * (tau[k + 1] - tau[k]) * 3.0;
        }
        let setup = Setup {
            model,
            x0,
            target,
            substeps: vec![3; n],
            par,
            scale: vec![1.0; par.len()],
        };
        (setup, p)
    }

    /// The Lagrangian's Hessian is the derivative of its gradient (central
    /// differences of ∇Λ over the whole shot), with weights on every landing
    /// row, the dry mass and two ground points.
    #[test]
    fn the_hessian_matches_differences_of_the_gradient() {
        let s = Scenario::paper();
        let model = SixDof::new(&s.vehicle, &s.environment);
        let (setup, p) = fixture(&model, &s.terminal);
        let par = setup.par;
        let mult = Multipliers {
            landing: (0..10).map(|j| 0.3 - 0.07 * j as f64).collect(),
            ground: vec![(4, 0.02), (11, -0.01)],
            mass: 1e-3,
        };
        let (lambda_f, ground) = lagrangian_weights(&mult);
        let h = hessian::hessian(&setup, &p, &lambda_f, &ground);
        let np = par.len();
        for i in 0..np {
            let step = 1e-5 * p[i].abs().max(1.0);
            let (mut up, mut dn) = (p.clone(), p.clone());
            up[i] += step;
            dn[i] -= step;
            let gu = lagrangian_gradient(&setup, &shoot(&setup, &up), &mult);
            let gd = lagrangian_gradient(&setup, &shoot(&setup, &dn), &mult);
            for j in 0..np {
                let fd = (gu[j] - gd[j]) / (2.0 * step);
                let d = h[j * np + i];
                assert!(
                    (fd - d).abs() <= 1e-5 * (1.0 + d.abs().max(fd.abs())),
                    "H[{j}][{i}]: {d} against {fd}"
                );
                assert_eq!(h[j * np + i], h[i * np + j], "symmetric at {i}, {j}");
            }
        }
    }

    /// The shot's sensitivities are the derivatives of the shot itself
    /// (central differences of the whole RK4 map), end and altitudes.
    #[test]
    fn the_shots_sensitivities_match_differences() {
        let s = Scenario::paper();
        let model = SixDof::new(&s.vehicle, &s.environment);
        let (setup, p) = fixture(&model, &s.terminal);
        let par = setup.par;
        let shot = shoot(&setup, &p);
        for i in 0..par.len() {
            let h = 1e-6 * p[i].abs().max(1.0);
            let (mut up, mut dn) = (p.clone(), p.clone());
            up[i] += h;
            dn[i] -= h;
            let (a, b) = (shoot(&setup, &up), shoot(&setup, &dn));
            for r in 0..NX {
                let fd = (a.end[r] - b.end[r]) / (2.0 * h);
                let d = shot.d_end[r][i];
                assert!(
                    (fd - d).abs() <= 1e-5 * (1.0 + d.abs().max(fd.abs())),
                    "∂x{r}/∂p{i}: {d} against {fd}"
                );
            }
            for (k, dz) in shot.d_z.iter().enumerate() {
                let fd = (a.z[k] - b.z[k]) / (2.0 * h);
                assert!(
                    (fd - dz[i]).abs() <= 1e-5 * (1.0 + dz[i].abs()),
                    "∂z{k}/∂p{i}: {} against {fd}",
                    dz[i]
                );
            }
        }
    }
}
