//! Problem P2 (Eq. 8–10) on the LGR mesh as one nonlinear program, for the
//! direct method ([`crate::method::direct`]).
//!
//! This is the transcription that the CasADi + IPOPT reference
//! (`bench/reference/nlp_reference.py`) solves, with the ground bound
//! z ≥ z_f added: states (x, z, Vx, Vz, θ, w, m, δ) at the N + 1 nodes,
//! controls (T, χ) at the N collocation points, and t_f. Every constraint is
//! either a collocation defect (Eq. 24) or a simple bound, so an interior
//! point method needs barriers on variables only.
//!
//! Variables are scaled to order one (`value = offset + scale·ŵ`, the scales of
//! [`Scaling`]); each defect row is divided by the scale of its state. The
//! full vector has [`NL`] slots per node (node N's control slots are fixed at
//! zero) and t̂_f last; fixed values (the boundary conditions, T when
//! T_min = T_max) keep their slots with `lo == hi`.
//!
//! Derivatives are exact: num-dual's second-order dual numbers over the six
//! inputs that enter f nonlinearly (Vx, Vz, θ, m, δ, T); the linear entries
//! θ̇ = w and δ̇ = χ are added by hand.
//!
//! The transcription is generic over the model behind the seam
//! ([`Transcription`], issue 38): its layout (NS states, then the model's
//! controls, then the two thrust slacks, NL slots per node), scaling,
//! bounds, objective, defects and their derivatives hold for any
//! [`Dynamics`](crate::problem::model::Dynamics). [`Nlp`] is the planar P2 one, and keeps what is planar:
//! its construction from a scenario, the operational limits of issue 37,
//! and the conversions to and from the LCvx trajectories and solutions.

#![allow(clippy::needless_range_loop)] // Dense block algebra indexes several arrays by one index.

use crate::collocation::derivatives::{self, Differentiable};
use crate::collocation::mesh::Mesh;
use crate::collocation::scaling::Scaling;
use crate::input::scenario::{Scenario, TerminalState};
use crate::input::settings::{Formulation, SolverSettings};
use crate::problem::constraints::Limit;
use crate::problem::dynamics::Model;

/// States of P2 at a node: x, z, Vx, Vz, θ, w, m, δ.
pub const NS: usize = 8;
/// Controls of P2: T, χ, and the soft thrust margin's two slacks (fixed at
/// zero unless the margin is on, [`SoftTerms`]).
pub const NC: usize = 4;
/// Local slots per node: the states, then the controls.
pub const NL: usize = NS + NC;

/// Slot indices of a node's local vector: the states, with the crate's
/// state indices ([`crate::problem::dynamics::ix`]), then the controls.
pub mod slot {
    pub use crate::problem::dynamics::ix::{DELTA, M, THETA, VX, VZ, W, X, Z};
    pub const T: usize = 8;
    pub const CHI: usize = 9;
    /// Thrust used above the soft margin's band, and below it: the thrust
    /// is T + ABOVE − BELOW.
    pub const ABOVE: usize = 10;
    pub const BELOW: usize = 11;
}

/// Bounds on t_f \[s\], as in the IPOPT reference.
pub const TF_BOUNDS_S: (f64, f64) = (1.0, 100.0);

/// The multipliers of an iterate (scaled units): λ of the defects, and z_L,
/// z_U of the lower and upper bounds (zero where a variable has none).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Duals {
    pub lambda: Vec<f64>,
    pub zl: Vec<f64>,
    pub zu: Vec<f64>,
}

/// Derivatives of the dynamics at one collocation point, in scaled units
/// (the thrust slacks' columns filled by [`Transcription::point_derivatives`]).
pub type PointDerivatives<const NS: usize = 8, const NL: usize = 12> =
    derivatives::PointDerivatives<NS, NL>;

/// P2 on a mesh, the planar transcription.
pub type Nlp = Transcription<Model, NS, NL>;

/// A model's problem on a mesh: scaling, bounds, defects and their
/// derivatives (module docs). NS is the model's state count and NL = NS +
/// its control count + 2 (the thrust slacks).
#[derive(Debug, Clone)]
pub struct Transcription<M, const NS: usize, const NL: usize> {
    pub model: M,
    pub mesh: Mesh,
    /// Collocation points N.
    pub n: usize,
    /// value = offset + scale·ŵ per local slot.
    pub offset: [f64; NL],
    pub scale: [f64; NL],
    pub tf_scale: f64,
    /// Scaled bounds of the full vector (±∞ where free; equal where fixed).
    pub lo: Vec<f64>,
    pub hi: Vec<f64>,
    /// Initial state (all of the model's), physical, and the landing
    /// ([`Dynamics::terminal_fixed`](crate::problem::model::Dynamics::terminal_fixed) reads its fixed slots from it).
    pub x0: [f64; NS],
    pub target: TerminalState,
    /// For each node k: the collocation points i with D_ik ≠ 0 and D_ik.
    pub d_cols: Vec<Vec<(usize, f64)>>,
    /// Soft constraints of closed-loop plans, in the objective.
    pub soft: SoftTerms,
    /// A symmetric bound |v_s| ≤ b on one state slot s at every free node:
    /// (w, w_max \[rad/s\]) for the pitch-rate limit of the scenario's
    /// constraints (issue 37).
    pub rate_bound: Option<(usize, f64)>,
    /// The operational rows held at the free nodes (the tilt limit and the
    /// final descent, in the direct method's `rows` module).
    pub limits: Vec<crate::problem::constraints::Row>,
    /// The constant Jacobian entries of the inputs that enter f linearly
    /// (θ̇ = w, δ̇ = χ): [`derivatives::linear_columns`].
    linear: Vec<(usize, usize, f64)>,
}

/// The soft constraints of [`crate::input::settings::SolverSettings`], as exact
/// penalties in the objective, in scaled units:
///
/// - thrust margin: the thrust is T + A − B with T in the band
///   [T_lo, T_hi] = [(1+μ)·T_min, (1−μ)·T_max] and the slacks
///   A ∈ [0, T_max − T_hi], B ∈ [0, T_lo − T_min] (slots `ABOVE`,
///   `BELOW`), at a cost w_T Σ_i (Â_i + B̂_i): linear, as SCvx's slack is. A
///   smoothed hinge in T instead (tried) keeps the thrust some 100·ε below
///   the band's edge and cost 285 kg on the paper's case at ε = 1e-3, while
///   ε = 1e-5 took 229 iterations;
/// - terminal lateral: w_x (ρ(x̂_N − x̂_f) + ρ(V̂x_N − V̂x_f)), with x_N and
///   Vx_N free and the smoothed absolute value ρ(u) = √(u² + ε²) − ε
///   ([`SOFT_EPS`]), twice differentiable as Newton's method needs.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SoftTerms {
    /// w_T (0: no soft margin) and the band [T_lo, T_hi] \[N\].
    pub margin_weight: f64,
    pub margin_band_n: (f64, f64),
    /// w_x (0: terminal x and Vx are fixed).
    pub lateral_weight: f64,
    /// x̂_f and V̂x_f.
    pub lateral_target: (f64, f64),
    /// The slots of x and Vx.
    pub lateral_slots: (usize, usize),
}

/// Smoothing ε of the soft terminal x and Vx (scaled units: 1e-3 of the
/// state's scale, some 0.1 m of position, is where the penalty turns from
/// quadratic to linear).
pub const SOFT_EPS: f64 = 1e-3;

/// Smoothed absolute value ρ(u) = √(u² + ε²) − ε and its first two derivatives.
fn smooth_abs(u: f64) -> (f64, f64, f64) {
    let r = (u * u + SOFT_EPS * SOFT_EPS).sqrt();
    (r - SOFT_EPS, u / r, SOFT_EPS * SOFT_EPS / (r * r * r))
}

impl Nlp {
    /// The transcription of a validated scenario on its mesh, with the
    /// ground bound z ≥ z_f at every node and the soft terms of `sv`.
    pub fn new(s: &Scenario, sv: &SolverSettings) -> Self {
        let mut nlp = Transcription::empty(
            Model::new(&s.vehicle, &s.environment),
            s.discretization.collocation_mesh(),
            s.terminal.clone(),
        );
        nlp.refresh(s, sv);
        nlp
    }

    /// Set everything but the mesh (and D's columns) from `s` and `sv`:
    /// the model, the scaling, the boundary states, the soft terms and the
    /// bounds, in place. `s` must have this NLP's mesh: a re-plan reuses
    /// its NLP this way, with no allocation
    /// ([`crate::method::direct::solver::DirectSolver`]).
    pub fn refresh(&mut self, s: &Scenario, sv: &SolverSettings) {
        let model = Model::new(&s.vehicle, &s.environment);
        let sc = Scaling::new(s, &model, Formulation::Exact);
        let (i, t) = (&s.initial, &s.terminal);
        let m0 = i.mass_kg;
        let mut offset = [0.0; NL];
        offset[slot::M] = m0;
        let mut scale = [1.0; NL];
        scale[..6].copy_from_slice(&sc.x_scale[..6]);
        scale[slot::M] = m0 - model.dry_mass_kg;
        scale[slot::DELTA] = model.max_gimbal_rad;
        scale[slot::T] = model.max_thrust_n;
        scale[slot::ABOVE] = model.max_thrust_n;
        scale[slot::BELOW] = model.max_thrust_n;
        scale[slot::CHI] = model.max_gimbal_rate_radps;
        derivatives::linear_columns(&model, &offset, &mut self.linear);
        self.model = model;
        self.offset = offset;
        self.scale = scale;
        self.tf_scale = sc.tf_scale;
        self.x0 = i.state_si();
        self.target.clone_from(t);
        self.soft = SoftTerms::default();
        let (t_min, t_max) = (self.model.min_thrust_n, self.model.max_thrust_n);
        if sv.thrust_margin_frac > 0.0 {
            self.soft.margin_weight = sv.thrust_margin_weight;
            self.soft.margin_band_n = (
                t_min * (1.0 + sv.thrust_margin_frac),
                t_max * (1.0 - sv.thrust_margin_frac),
            );
        }
        if sv.terminal_lateral_weight > 0.0 {
            self.soft.lateral_weight = sv.terminal_lateral_weight;
            self.soft.lateral_target =
                (self.scaled(slot::X, t.x_m), self.scaled(slot::VX, t.vx_mps));
            self.soft.lateral_slots = (slot::X, slot::VX);
        }
        self.rate_bound = s
            .constraints
            .max_pitch_rate_degps
            .map(|w| (slot::W, w.to_radians()));
        // The rows it holds at its nodes ([`crate::method::direct::rows`]).
        // In place: a re-plan's update allocates nothing (issue 27).
        self.limits.clear();
        self.limits.extend(
            crate::problem::constraints::each_row(s)
                .filter(|r| matches!(r.limit, Limit::Cone | Limit::Tilt | Limit::FinalDescent)),
        );
        self.set_bounds(t);
    }
}

impl<M: Differentiable, const NS: usize, const NL: usize> Transcription<M, NS, NL> {
    /// The thrust slot: the model's thrust control.
    pub const T: usize = NS + M::THRUST;
    /// The thrust slacks, after the model's controls ([`SoftTerms`]).
    pub const ABOVE: usize = NS + M::NU;
    pub const BELOW: usize = NS + M::NU + 1;

    /// A transcription of `model` on `mesh`, its scaling, start and bounds
    /// yet to be set (by the model's own constructor).
    pub fn empty(model: M, mesh: Mesh, target: TerminalState) -> Self {
        const { assert!(NS == M::NX && NL == M::NX + M::NU + 2) };
        let n = mesh.n;
        let d_cols = mesh.d_columns();
        Transcription {
            model,
            mesh,
            n,
            offset: [0.0; NL],
            scale: [1.0; NL],
            tf_scale: 1.0,
            lo: vec![],
            hi: vec![],
            x0: [0.0; NS],
            target,
            d_cols,
            soft: SoftTerms::default(),
            rate_bound: None,
            limits: Vec::new(),
            linear: Vec::with_capacity(NL),
        }
    }

    /// Set the scaling (value = offset + scale·ŵ per slot, t_f = tf_scale·t̂_f),
    /// the start `x0` and the landing, and the bounds from them: how a
    /// model's own constructor finishes a transcription.
    pub fn set_problem(
        &mut self,
        (offset, scale, tf_scale): ([f64; NL], [f64; NL], f64),
        x0: [f64; NS],
        target: &TerminalState,
    ) {
        // At the start: a point where f is defined (the 6-DoF model's
        // rotation is not at q = 0).
        let p: [f64; NL] = std::array::from_fn(|s| if s < NS { x0[s] } else { offset[s] });
        derivatives::linear_columns(&self.model, &p, &mut self.linear);
        self.offset = offset;
        self.scale = scale;
        self.tf_scale = tf_scale;
        self.x0 = x0;
        self.target.clone_from(target);
        self.set_bounds(target);
    }

    /// Index of slot `s` of node `k` in the full vector.
    #[inline]
    pub fn idx(&self, k: usize, s: usize) -> usize {
        k * NL + s
    }

    /// Index of t̂_f.
    #[inline]
    pub fn tf_idx(&self) -> usize {
        (self.n + 1) * NL
    }

    /// Length of the full vector.
    #[inline]
    pub fn n_var(&self) -> usize {
        self.tf_idx() + 1
    }

    /// Number of equality constraints (defects), N·NS.
    #[inline]
    pub fn n_con(&self) -> usize {
        self.n * NS
    }

    fn scaled(&self, s: usize, v: f64) -> f64 {
        (v - self.offset[s]) / self.scale[s]
    }

    /// Physical value of slot `s` from its scaled value.
    #[inline]
    pub fn physical(&self, s: usize, w: f64) -> f64 {
        self.offset[s] + self.scale[s] * w
    }

    /// The bounds of every node, from the model's boxes and landing slots
    /// through the seam ([`Dynamics`](crate::problem::model::Dynamics)): x_0 fixed; after it the state boxes,
    /// with the ground z ≥ z_f and the mass at most m_0 (and the pitch-rate
    /// limit); at node N the landing's fixed slots (`target`, the ground
    /// at its altitude); at the points the control boxes (the thrust in the
    /// soft margin's band, when on).
    pub(crate) fn set_bounds(&mut self, target: &TerminalState) {
        let nv = self.n_var();
        // Refilled in place: no allocation once the vectors have their size.
        let (mut lo, mut hi) = (std::mem::take(&mut self.lo), std::mem::take(&mut self.hi));
        lo.clear();
        lo.resize(nv, f64::NEG_INFINITY);
        hi.clear();
        hi.resize(nv, f64::INFINITY);
        let (n, m) = (self.n, &self.model);
        let set = |lo: &mut Vec<f64>, hi: &mut Vec<f64>, k: usize, s: usize, a: f64, b: f64| {
            let j = k * NL + s;
            lo[j] = (a - self.offset[s]) / self.scale[s];
            hi[j] = (b - self.offset[s]) / self.scale[s];
        };
        for k in 0..=n {
            if k == 0 {
                for s in 0..NS {
                    set(&mut lo, &mut hi, k, s, self.x0[s], self.x0[s]);
                }
            } else {
                for s in 0..NS {
                    let (mut a, mut b) = m.state_box(s);
                    if s == M::ALTITUDE {
                        a = a.max(target.z_m);
                    }
                    if s == M::MASS {
                        b = b.min(self.x0[s]);
                    }
                    if a.is_finite() || b.is_finite() {
                        set(&mut lo, &mut hi, k, s, a, b);
                    }
                }
                if let Some((s, b)) = self.rate_bound {
                    set(&mut lo, &mut hi, k, s, -b, b);
                }
            }
            if k == n {
                for s in 0..NS {
                    if let Some(v) = m.terminal_fixed(target, s) {
                        set(&mut lo, &mut hi, k, s, v, v);
                    }
                }
                if self.soft.lateral_weight > 0.0 {
                    let (x, vx) = self.soft.lateral_slots;
                    for s in [x, vx] {
                        lo[k * NL + s] = f64::NEG_INFINITY;
                        hi[k * NL + s] = f64::INFINITY;
                    }
                }
                for s in NS..NL {
                    set(&mut lo, &mut hi, k, s, 0.0, 0.0);
                }
                continue;
            }
            for j in 0..M::NU {
                let (a, b) = m.control_box(j);
                set(&mut lo, &mut hi, k, NS + j, a, b);
            }
            let (t_min, t_max) = m.control_box(M::THRUST);
            let (above, below) = if self.soft.margin_weight > 0.0 {
                let (t_lo, t_hi) = self.soft.margin_band_n;
                set(&mut lo, &mut hi, k, Self::T, t_lo, t_hi);
                (t_max - t_hi, t_lo - t_min)
            } else {
                (0.0, 0.0)
            };
            set(&mut lo, &mut hi, k, Self::ABOVE, 0.0, above);
            set(&mut lo, &mut hi, k, Self::BELOW, 0.0, below);
        }
        let tf = self.tf_idx();
        lo[tf] = TF_BOUNDS_S.0 / self.tf_scale;
        hi[tf] = TF_BOUNDS_S.1 / self.tf_scale;
        self.lo = lo;
        self.hi = hi;
    }

    /// Whether variable `j` is fixed (`lo == hi`).
    #[inline]
    pub fn is_fixed(&self, j: usize) -> bool {
        self.lo[j] == self.hi[j]
    }

    /// Physical t_f \[s\] of a scaled vector.
    #[inline]
    pub fn tf_s(&self, w: &[f64]) -> f64 {
        self.tf_scale * w[self.tf_idx()]
    }

    /// Objective −ŵ_m(t_f) (maximize the final mass, Eq. 6) plus the soft
    /// terms ([`SoftTerms`]).
    pub fn objective(&self, w: &[f64]) -> f64 {
        let mut f = -w[self.idx(self.n, M::MASS)];
        self.for_each_soft_term(w, |_, (v, _, _)| f += v);
        f
    }

    /// ∇f into `g` (overwritten).
    pub fn objective_gradient(&self, w: &[f64], g: &mut [f64]) {
        g.iter_mut().for_each(|v| *v = 0.0);
        g[self.idx(self.n, M::MASS)] = -1.0;
        self.for_each_soft_term(w, |j, (_, d1, _)| g[j] += d1);
    }

    /// ∇²f (diagonal: the soft terms only) added to the node blocks.
    pub fn add_objective_hessian(&self, w: &[f64], blocks: &mut [[[f64; NL]; NL]]) {
        self.for_each_soft_term(w, |j, (_, _, d2)| {
            let (k, s) = (j / NL, j % NL);
            blocks[k][s][s] += d2;
        });
    }

    /// Each soft term's variable index and (value, first, second derivative)
    /// with respect to it, weight included.
    fn for_each_soft_term(&self, w: &[f64], mut f: impl FnMut(usize, (f64, f64, f64))) {
        let st = &self.soft;
        if st.margin_weight > 0.0 {
            for i in 0..self.n {
                for s in [Self::ABOVE, Self::BELOW] {
                    let j = self.idx(i, s);
                    f(j, (st.margin_weight * w[j], st.margin_weight, 0.0));
                }
            }
        }
        if st.lateral_weight > 0.0 {
            let a = st.lateral_weight;
            for (s, target) in [
                (st.lateral_slots.0, st.lateral_target.0),
                (st.lateral_slots.1, st.lateral_target.1),
            ] {
                let j = self.idx(self.n, s);
                let (v, g, h) = smooth_abs(w[j] - target);
                f(j, (a * v, a * g, a * h));
            }
        }
    }

    /// Physical values of node k's slots, with the thrust slot holding the
    /// thrust itself, T + ABOVE − BELOW.
    fn physical_node(&self, w: &[f64], k: usize) -> [f64; NL] {
        let mut p: [f64; NL] = std::array::from_fn(|s| self.physical(s, w[self.idx(k, s)]));
        p[Self::T] += p[Self::ABOVE] - p[Self::BELOW];
        p
    }

    /// The answer in physical units, node-major as
    /// [`crate::collocation::residuals::Answer`] reads it: the states at the
    /// N + 1 nodes (NS each), and the model's controls at the N points, the
    /// thrust with its slacks (T + ABOVE − BELOW).
    pub fn physical_answer(&self, w: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let states = (0..=self.n)
            .flat_map(|k| (0..NS).map(move |s| (k, s)))
            .map(|(k, s)| self.physical(s, w[self.idx(k, s)]))
            .collect();
        let controls = (0..self.n)
            .flat_map(|i| (0..M::NU).map(move |j| (i, NS + j)))
            .map(|(i, s)| self.physical_node(w, i)[s])
            .collect();
        (states, controls)
    }

    /// Thrust \[N\] at collocation point `i`: T + ABOVE − BELOW.
    pub fn thrust_n(&self, w: &[f64], i: usize) -> f64 {
        self.physical_node(w, i)[Self::T]
    }

    /// Scaled rates F = f/scale at collocation point `i`.
    pub fn rates(&self, w: &[f64], i: usize) -> [f64; NS] {
        let p = self.physical_node(w, i);
        let mut f = [0.0; NS];
        self.model.rhs(&p[..NS], &p[NS..NS + M::NU], &mut f);
        std::array::from_fn(|c| f[c] / self.scale[c])
    }

    /// Collocation defects (Eq. 24), scaled: Σ_j D_ij X̂_j − (t_f/2)·F_i,
    /// point-major (`out[i·8 + c]`).
    pub fn defects(&self, w: &[f64], out: &mut [f64]) {
        let half_tf = 0.5 * self.tf_s(w);
        for i in 0..self.n {
            let f = self.rates(w, i);
            let (first, row) = self.mesh.d_row(i);
            for c in 0..NS {
                let dx: f64 = row
                    .iter()
                    .enumerate()
                    .map(|(j, d)| d * w[self.idx(first + j, c)])
                    .sum();
                out[i * NS + c] = dx - half_tf * f[c];
            }
        }
    }

    /// F, ∂F/∂ŵ and Σ_c λ_c ∇²F_c at collocation point `i` (λ: NS weights).
    pub fn point_derivatives(
        &self,
        w: &[f64],
        i: usize,
        lambda: &[f64],
        out: &mut PointDerivatives<NS, NL>,
    ) {
        let p = self.physical_node(w, i);
        self.model
            .point_derivatives::<NS, NL>(&p, &self.scale, lambda, &self.linear, out);
        // The slacks enter as the thrust does, with signs e = (+1, −1): their
        // columns are e·(T's column), and ∇² rows and columns likewise.
        for (s, e) in [(Self::ABOVE, 1.0), (Self::BELOW, -1.0)] {
            for c in 0..NS {
                out.jac[c][s] = e * out.jac[c][Self::T];
            }
        }
        let t_row = out.hess[Self::T];
        for (s, e) in [(Self::ABOVE, 1.0), (Self::BELOW, -1.0)] {
            for q in 0..NL {
                let v = if q == Self::ABOVE {
                    e * t_row[Self::T]
                } else if q == Self::BELOW {
                    -e * t_row[Self::T]
                } else {
                    e * t_row[q]
                };
                out.hess[s][q] = v;
                out.hess[q][s] = v;
            }
        }
    }

    /// Jᵀλ of the defects (full-vector gradient), added into `out`, from
    /// the points' Jacobians.
    pub fn add_jt_lambda(
        &self,
        w: &[f64],
        derivs: &[PointDerivatives<NS, NL>],
        lambda: &[f64],
        out: &mut [f64],
    ) {
        let half_tf = 0.5 * self.tf_s(w);
        let tf = self.tf_idx();
        for i in 0..self.n {
            let l = &lambda[i * NS..(i + 1) * NS];
            let (first, row) = self.mesh.d_row(i);
            for (j, d) in row.iter().enumerate() {
                for c in 0..NS {
                    out[self.idx(first + j, c)] += d * l[c];
                }
            }
            let f = self.rates(w, i);
            for c in 0..NS {
                for s in 0..NL {
                    out[self.idx(i, s)] -= half_tf * derivs[i].jac[c][s] * l[c];
                }
                out[tf] -= 0.5 * self.tf_scale * f[c] * l[c];
            }
        }
    }

    /// The multipliers of an answer on `from`'s mesh carried onto this
    /// NLP's, for a primal–dual warm start ([`crate::method::direct::solve_nlp_warm`]).
    ///
    /// Collocation multipliers scale with the quadrature weights: λ_ic/w_i
    /// is the discrete costate of state c at τ_i, and a bound multiplier of
    /// a slot at node k, over w_k (w_{N−1} at node N), a density of the
    /// path multiplier. Each density is carried piecewise linearly in τ
    /// (multipliers of bounds switch on and off with their arcs, where a
    /// polynomial would ring) and multiplied by this mesh's weights; t̂_f's
    /// bound multipliers are copied.
    pub fn interpolate_duals_from(&self, from: &Self, duals: &Duals) -> Duals {
        let weight = |nlp: &Self, k: usize| nlp.mesh.weights[k.min(nlp.n - 1)];
        let carry = |values: &dyn Fn(usize) -> f64, count: usize, to: usize| -> Vec<f64> {
            let xs = &from.mesh.nodes[..count];
            let ys: Vec<f64> = (0..count).map(|k| values(k) / weight(from, k)).collect();
            (0..to)
                .map(|k| weight(self, k) * piecewise_linear(xs, &ys, self.mesh.nodes[k]))
                .collect()
        };
        let mut lambda = vec![0.0; self.n_con()];
        for c in 0..NS {
            let new = carry(&|i| duals.lambda[i * NS + c], from.n, self.n);
            for (i, v) in new.into_iter().enumerate() {
                lambda[i * NS + c] = v;
            }
        }
        let bound = |z: &[f64]| {
            let mut out = vec![0.0; self.n_var()];
            for s in 0..NL {
                let new = carry(&|k| z[from.idx(k, s)], from.n + 1, self.n + 1);
                for (k, v) in new.into_iter().enumerate() {
                    out[self.idx(k, s)] = v;
                }
            }
            out[self.tf_idx()] = z[from.tf_idx()];
            out
        };
        let zl = bound(&duals.zl);
        let zu = bound(&duals.zu);
        Duals { lambda, zl, zu }
    }
}

impl Nlp {
    /// The straight-line guess of the reference: states linear in τ from the
    /// initial to the terminal state (mass to `final_mass_kg`, δ to 0),
    /// T = (T_min + T_max)/2, χ = 0, t_f = `tf_s`. Scaled.
    pub fn straight_line(&self, tf_s: f64, final_mass_kg: f64) -> Vec<f64> {
        let mut w = Vec::new();
        self.straight_line_into(tf_s, final_mass_kg, &mut w);
        w
    }

    /// [`Self::straight_line`] into `w`, in its own storage.
    pub fn straight_line_into(&self, tf_s: f64, final_mass_kg: f64, w: &mut Vec<f64>) {
        w.clear();
        w.resize(self.n_var(), 0.0);
        let mut end = [0.0; NS];
        end[..6].copy_from_slice(&self.target.state_si());
        end[slot::M] = final_mass_kg;
        let thrust = 0.5 * (self.model.min_thrust_n + self.model.max_thrust_n);
        for (k, &tau) in self.mesh.nodes.iter().enumerate() {
            let a = 0.5 * (tau + 1.0);
            for s in 0..NS {
                w[self.idx(k, s)] = self.scaled(s, self.x0[s] + a * (end[s] - self.x0[s]));
            }
            if k < self.n {
                w[self.idx(k, slot::T)] = self.scaled(slot::T, thrust);
            }
        }
        w[self.tf_idx()] = tf_s / self.tf_scale;
    }

    /// The scaled vector as a trajectory of the exact LCvx formulation
    /// (ω = ln m, σ = T/m, χ), which [`crate::solution::Solution`] reports.
    pub fn to_trajectory(&self, w: &[f64]) -> crate::collocation::trajectory::Trajectory {
        let mut t = crate::collocation::trajectory::Trajectory {
            x: Vec::new(),
            u: Vec::new(),
            tf_s: 0.0,
        };
        self.to_trajectory_into(w, &mut t);
        t
    }

    /// [`Self::to_trajectory`] into `t`, in its vectors' own storage.
    pub fn to_trajectory_into(
        &self,
        w: &[f64],
        t: &mut crate::collocation::trajectory::Trajectory,
    ) {
        use crate::problem::dynamics::{ix, NU_MAX, NX};
        t.x.clear();
        t.x.extend((0..=self.n).map(|k| {
            let p = self.physical_node(w, k);
            let mut x = [0.0; NX];
            x[..6].copy_from_slice(&p[..6]);
            x[ix::OMEGA] = p[slot::M].ln();
            x[ix::DELTA] = p[slot::DELTA];
            x
        }));
        t.u.clear();
        t.u.extend((0..self.n).map(|i| {
            let p = self.physical_node(w, i);
            let mut u = [0.0; NU_MAX];
            u[0] = p[slot::T] / p[slot::M];
            u[1] = p[slot::CHI];
            u
        }));
        t.tf_s = self.tf_s(w);
    }

    /// The scaled vector of an exact-formulation trajectory (the inverse of
    /// [`Nlp::to_trajectory`]), for warm starts from an earlier plan.
    pub fn from_trajectory(&self, t: &crate::collocation::trajectory::Trajectory) -> Vec<f64> {
        let mut w = Vec::new();
        self.from_trajectory_into(t, &mut w);
        w
    }

    /// [`Self::from_trajectory`] into `w`, in its own storage.
    pub fn from_trajectory_into(
        &self,
        t: &crate::collocation::trajectory::Trajectory,
        w: &mut Vec<f64>,
    ) {
        use crate::problem::dynamics::ix;
        w.clear();
        w.resize(self.n_var(), 0.0);
        for k in 0..=self.n {
            let x = &t.x[k];
            let m = x[ix::OMEGA].exp();
            let mut state = [0.0; NS];
            state[..6].copy_from_slice(&x[..6]);
            state[slot::M] = m;
            state[slot::DELTA] = x[ix::DELTA];
            let control = (k < self.n).then(|| (t.u[k][0] * m, t.u[k][1]));
            self.set_node(w, k, &state, control);
        }
        w[self.tf_idx()] = t.tf_s / self.tf_scale;
    }

    /// The scaled start point on this NLP's mesh from a solution on any
    /// mesh ([`Solution::mesh`](crate::Solution::mesh)), for warm starts
    /// across meshes (hp refinement): the states at each node τ_k from the
    /// solution's piecewise state polynomials ([`Mesh::interpolate_states`],
    /// mass in kg as P2 carries it), thrust \[N\] and χ at each collocation
    /// point from its control polynomials ([`Mesh::interpolate_controls`]),
    /// and its t_f. As in [`Nlp::from_trajectory`], a thrust outside the soft
    /// margin's band goes into the slacks. On the solution's own mesh this is
    /// [`Nlp::from_trajectory`] of its trajectory (the node values return
    /// unchanged). Bounds are not enforced; the interior-point method pushes
    /// the point inside them.
    ///
    /// # Panics
    /// Panics if the solution's arrays do not fit its mesh (N + 1 nodes per
    /// state, N controls), which a solve never returns.
    pub fn interpolate_from(&self, sol: &crate::Solution) -> Vec<f64> {
        let from = sol.mesh();
        let states = sol.state_columns();
        let (thrust_n, chi_radps) = (&sol.thrust_n[..from.n], &sol.gimbal_rate_radps[..from.n]);
        let mut w = vec![0.0; self.n_var()];
        for (k, &tau) in self.mesh.nodes.iter().enumerate() {
            let state: [f64; NS] = std::array::from_fn(|c| from.interpolate_states(states[c], tau));
            let control = (k < self.n).then(|| {
                (
                    from.interpolate_controls(thrust_n, tau),
                    from.interpolate_controls(chi_radps, tau),
                )
            });
            self.set_node(&mut w, k, &state, control);
        }
        w[self.tf_idx()] = sol.tf_s / self.tf_scale;
        w
    }

    /// Node k of the scaled vector from P2's physical state (mass in kg)
    /// and, at a collocation point, the thrust \[N\] and χ \[rad/s\]: with the
    /// soft margin on, the thrust within its band [T_lo, T_hi] and the rest
    /// in the slacks, A = max(T − T_hi, 0), B = max(T_lo − T, 0).
    fn set_node(&self, w: &mut [f64], k: usize, state: &[f64; NS], control: Option<(f64, f64)>) {
        for (s, &v) in state.iter().enumerate() {
            w[self.idx(k, s)] = self.scaled(s, v);
        }
        if let Some((thrust, chi)) = control {
            if self.soft.margin_weight > 0.0 {
                let (lo, hi) = self.soft.margin_band_n;
                w[self.idx(k, slot::T)] = self.scaled(slot::T, thrust.clamp(lo, hi));
                w[self.idx(k, slot::ABOVE)] = self.scaled(slot::ABOVE, (thrust - hi).max(0.0));
                w[self.idx(k, slot::BELOW)] = self.scaled(slot::BELOW, (lo - thrust).max(0.0));
            } else {
                w[self.idx(k, slot::T)] = self.scaled(slot::T, thrust);
            }
            w[self.idx(k, slot::CHI)] = self.scaled(slot::CHI, chi);
        }
    }
}

/// The piecewise-linear interpolant through (xs, ys) (xs increasing) at x,
/// held constant beyond the ends.
fn piecewise_linear(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    let j = xs.partition_point(|&v| v <= x);
    if j == 0 {
        return ys[0];
    }
    if j == xs.len() {
        return ys[j - 1];
    }
    let (x0, x1) = (xs[j - 1], xs[j]);
    ys[j - 1] + (ys[j] - ys[j - 1]) * (x - x0) / (x1 - x0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nlp() -> Nlp {
        let mut s = Scenario::paper();
        s.discretization.nodes = 7;
        Nlp::new(&s, &SolverSettings::default())
    }

    /// The point derivatives at point i, by value.
    fn derivs(nlp: &Nlp, w: &[f64], i: usize, lambda: &[f64]) -> PointDerivatives {
        let mut d = PointDerivatives::default();
        nlp.point_derivatives(w, i, lambda, &mut d);
        d
    }

    /// A generic interior point: the straight line, perturbed.
    fn point(nlp: &Nlp) -> Vec<f64> {
        let mut w = nlp.straight_line(11.0, 114_000.0);
        for (j, v) in w.iter_mut().enumerate() {
            if !nlp.is_fixed(j) {
                *v += 0.05 * ((j as f64) * 0.7).sin();
            }
        }
        w
    }

    #[test]
    fn jacobian_matches_central_differences() {
        let nlp = nlp();
        let w = point(&nlp);
        let lambda = [0.0; NS];
        for i in 0..nlp.n {
            let d = derivs(&nlp, &w, i, &lambda);
            for (a, b) in d.f.iter().zip(nlp.rates(&w, i)) {
                assert!((a - b).abs() <= 1e-15 * (1.0 + b.abs()));
            }
            for s in 0..NL {
                let h = 1e-6;
                let (mut wp, mut wm) = (w.clone(), w.clone());
                wp[nlp.idx(i, s)] += h;
                wm[nlp.idx(i, s)] -= h;
                let (fp, fm) = (nlp.rates(&wp, i), nlp.rates(&wm, i));
                for c in 0..NS {
                    let fd = (fp[c] - fm[c]) / (2.0 * h);
                    assert!(
                        (fd - d.jac[c][s]).abs() <= 1e-6 * (1.0 + fd.abs()),
                        "point {i}: dF{c}/dw{s}: AD {} FD {fd}",
                        d.jac[c][s]
                    );
                }
            }
        }
    }

    #[test]
    fn hessian_matches_differences_of_the_jacobian() {
        let nlp = nlp();
        let w = point(&nlp);
        let lambda = [0.3, -1.2, 0.8, 2.1, -0.4, 1.7, -0.9, 0.6];
        for i in 0..nlp.n {
            let d = derivs(&nlp, &w, i, &lambda);
            for r in 0..NL {
                for s in 0..NL {
                    assert_eq!(d.hess[r][s], d.hess[s][r], "symmetric");
                }
                let h = 1e-5;
                let (mut wp, mut wm) = (w.clone(), w.clone());
                wp[nlp.idx(i, r)] += h;
                wm[nlp.idx(i, r)] -= h;
                let (jp, jm) = (
                    derivs(&nlp, &wp, i, &lambda).jac,
                    derivs(&nlp, &wm, i, &lambda).jac,
                );
                for s in 0..NL {
                    let fd: f64 = (0..NS)
                        .map(|c| lambda[c] * (jp[c][s] - jm[c][s]) / (2.0 * h))
                        .sum();
                    assert!(
                        (fd - d.hess[r][s]).abs() <= 1e-5 * (1.0 + fd.abs()),
                        "point {i}: H[{r}][{s}]: AD {} FD {fd}",
                        d.hess[r][s]
                    );
                }
            }
        }
    }

    #[test]
    fn defects_vanish_on_a_polynomial_trajectory_of_the_dynamics() {
        // Free fall without drag: x, z quadratic in t, which the LGR rule
        // differentiates exactly, so every defect is zero to rounding.
        let mut s = Scenario::paper();
        s.vehicle.drag_coefficient_kgpm = 0.0;
        s.discretization.nodes = 6;
        let nlp = Nlp::new(&s, &SolverSettings::default());
        let tf = 10.0;
        let g = nlp.model.g0_mps2;
        let mut w = vec![0.0; nlp.n_var()];
        for (k, &tau) in nlp.mesh.nodes.iter().enumerate() {
            let t = (tau + 1.0) * tf / 2.0;
            let p = [
                3.0 * t,
                500.0 - 0.5 * g * t * t,
                3.0,
                -g * t,
                0.2,
                0.0,
                110_000.0,
                0.0,
                0.0,
                0.0,
            ];
            for (sl, v) in p.iter().enumerate() {
                w[nlp.idx(k, sl)] = nlp.scaled(sl, *v);
            }
        }
        w[nlp.tf_idx()] = tf / nlp.tf_scale;
        let mut d = vec![0.0; nlp.n_con()];
        nlp.defects(&w, &mut d);
        assert!(d.iter().all(|v| v.abs() < 1e-12), "{d:?}");
    }

    /// Multipliers carried onto their own mesh come back unchanged (the
    /// densities are divided and multiplied by the same weights), and onto
    /// a finer mesh they keep the discrete costate λ_i/w_i.
    #[test]
    fn duals_carried_onto_a_mesh_keep_their_densities() {
        let from = nlp();
        let nv = from.n_var();
        let duals = Duals {
            lambda: (0..from.n_con()).map(|j| (j as f64 * 0.37).sin()).collect(),
            zl: (0..nv).map(|j| 1.0 + (j as f64 * 0.11).cos()).collect(),
            zu: (0..nv).map(|j| 2.0 + (j as f64 * 0.23).sin()).collect(),
        };
        let same = from.interpolate_duals_from(&from, &duals);
        for (a, b) in [
            (&same.lambda, &duals.lambda),
            (&same.zl, &duals.zl),
            (&same.zu, &duals.zu),
        ] {
            for (x, y) in a.iter().zip(b.iter()) {
                assert!((x - y).abs() <= 1e-12 * y.abs().max(1.0), "{x} {y}");
            }
        }
        // A constant costate on the coarse mesh is constant on a finer one.
        let mut s = Scenario::paper();
        s.discretization.nodes = 12;
        s.discretization.intervals = 3;
        let to = Nlp::new(&s, &SolverSettings::default());
        let mut flat = duals.clone();
        for i in 0..from.n {
            for c in 0..NS {
                flat.lambda[i * NS + c] = (c as f64 + 1.0) * from.mesh.weights[i];
            }
        }
        let fine = to.interpolate_duals_from(&from, &flat);
        for i in 0..to.n {
            for c in 0..NS {
                let density = fine.lambda[i * NS + c] / to.mesh.weights[i];
                assert!((density - (c as f64 + 1.0)).abs() < 1e-12, "{density}");
            }
        }
    }

    #[test]
    fn trajectory_round_trip() {
        let nlp = nlp();
        let w = point(&nlp);
        let back = nlp.from_trajectory(&nlp.to_trajectory(&w));
        for (j, (a, b)) in w.iter().zip(&back).enumerate() {
            let node_n_control = j >= nlp.idx(nlp.n, NS) && j < nlp.tf_idx();
            if !node_n_control {
                assert!((a - b).abs() < 1e-12, "{j}: {a} {b}");
            }
        }
    }
}
