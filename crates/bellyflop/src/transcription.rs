//! The convex subproblem P4 (Eq. 26–30) as sparse conic data for Clarabel.
//!
//! This is the one place that builds solver data. Decision variables are scaled
//! to order one (`value = offset + scale·ẑ`); every constraint row is divided by
//! the scale of the quantity it constrains.
//!
//! Variables, in order: states X̂ at the N+1 LGR points, controls Û at the N
//! collocation points, t̂_f; then the non-negative penalty variables: virtual
//! control ν⁺, ν⁻ on every collocation defect, buffers on the two σ bounds, and
//! (paper formulation) ν⁺, ν⁻ on the linearized direction constraint (Eq. 27).
//! Their weighted sum is the exact penalty that keeps every subproblem feasible.
//! Two optional soft constraints for closed-loop plans follow, each at its own
//! weight and part of the cost, not of the infeasibility: the use of a thrust
//! margin ([`crate::scenario::SolverSettings::thrust_margin_frac`]) per node
//! and side, and the misses of x(t_f) and Vx(t_f)
//! ([`crate::scenario::SolverSettings::terminal_lateral_weight`]).

use clarabel::algebra::CscMatrix;
use clarabel::solver::{SolverStatus, SupportedConeT};

use crate::conic::ConicSolver;
use crate::dynamics::{self, ix, Model, NU_MAX, NX};
use crate::mesh::Mesh;
use crate::scenario::{Formulation, Scenario};

/// A trajectory in physical units (SI, radians, ω = ln m) on the LGR grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    /// States at the N+1 points τ_1 = −1, …, τ_N, τ_{N+1} = +1.
    pub x: Vec<[f64; NX]>,
    /// Controls at the N collocation points (first `control_dim` entries used).
    pub u: Vec<[f64; NU_MAX]>,
    pub tf_s: f64,
}

impl Trajectory {
    /// Every state, control and t_f is finite.
    pub fn is_finite(&self) -> bool {
        self.tf_s.is_finite()
            && self.x.iter().flatten().all(|v| v.is_finite())
            && self.u.iter().flatten().all(|v| v.is_finite())
    }
}

/// Index map of the decision vector.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    pub n: usize,
    pub nu: usize,
    /// Linearized path equalities per node with virtual control:
    /// 0 (exact), 1 (paper: direction, Eq. 27), 2 (vector: direction and magnitude).
    pub path_rows: usize,
    /// Whether the soft thrust margin's variables are present
    /// ([`crate::scenario::SolverSettings::thrust_margin_frac`]).
    pub soft_margin: bool,
    /// Whether x(t_f) and Vx(t_f) are soft (their misses are variables).
    pub soft_terminal: bool,
}

impl Layout {
    pub fn x(&self, k: usize, c: usize) -> usize {
        k * NX + c
    }
    pub fn u(&self, i: usize, c: usize) -> usize {
        NX * (self.n + 1) + i * self.nu + c
    }
    pub fn tf(&self) -> usize {
        NX * (self.n + 1) + self.nu * self.n
    }
    /// Number of trajectory variables (states, controls, t_f): the trust region acts on these.
    pub fn n_primal(&self) -> usize {
        self.tf() + 1
    }
    pub fn vc_pos(&self, i: usize, c: usize) -> usize {
        self.n_primal() + i * NX + c
    }
    pub fn vc_neg(&self, i: usize, c: usize) -> usize {
        self.n_primal() + NX * self.n + i * NX + c
    }
    /// Buffer on the lower (side 0) or upper (side 1) σ bound at node i.
    pub fn buffer(&self, i: usize, side: usize) -> usize {
        self.n_primal() + 2 * NX * self.n + 2 * i + side
    }
    /// Virtual control on path equality `r` at node i: positive (side 0) or negative part.
    pub fn dir(&self, i: usize, r: usize, side: usize) -> usize {
        debug_assert!(r < self.path_rows);
        self.n_primal() + 2 * NX * self.n + 2 * self.n + 2 * (i * self.path_rows + r) + side
    }
    /// Use of the soft thrust margin below (side 0) or above (side 1) at node i.
    pub fn margin(&self, i: usize, side: usize) -> usize {
        debug_assert!(self.soft_margin);
        self.n_penalty_end() + 2 * i + side
    }
    /// End of the exact-penalty variables (virtual control, buffers, path).
    fn n_penalty_end(&self) -> usize {
        self.n_primal() + 2 * NX * self.n + 2 * self.n + 2 * self.path_rows * self.n
    }
    fn n_margin_end(&self) -> usize {
        self.n_penalty_end() + if self.soft_margin { 2 * self.n } else { 0 }
    }
    /// Miss of the soft terminal x (c = 0) or Vx (c = 1), positive (side 0)
    /// or negative part.
    pub fn terminal_miss(&self, c: usize, side: usize) -> usize {
        debug_assert!(self.soft_terminal);
        self.n_margin_end() + 2 * c + side
    }
    pub fn n_var(&self) -> usize {
        self.n_margin_end() + if self.soft_terminal { 4 } else { 0 }
    }
}

/// Affine scaling of every trajectory variable: value = offset + scale·ẑ.
#[derive(Debug, Clone, PartialEq)]
pub struct Scaling {
    pub x_offset: [f64; NX],
    pub x_scale: [f64; NX],
    pub u_scale: [f64; NU_MAX],
    pub tf_scale: f64,
}

impl Scaling {
    /// Scales from the scenario's own magnitudes, so every ẑ is of order one.
    pub fn new(s: &Scenario, model: &Model, form: Formulation) -> Self {
        let (i, t) = (&s.initial, &s.terminal);
        let length = (i.x_m - t.x_m).abs().max((i.z_m - t.z_m).abs()).max(1.0);
        let speed = i
            .vx_mps
            .hypot(i.vz_mps)
            .max(t.vx_mps.hypot(t.vz_mps))
            .max(1.0);
        let angle = (i.theta_deg - t.theta_deg).to_radians().abs().max(0.1);
        // Time scale of the descent, independent of the t_f guess: the trust
        // region on t_f is a fraction of it, so a guess far from the optimum
        // must not widen it. 1.7·Δz/V is measured (examples/convergence): it
        // lets SCvx converge in ≤ 9 iterations from guesses of 8 to 20 s,
        // where scaling by the guess itself needed 30+ from 20 s.
        let drop = (i.z_m - t.z_m).abs().max(1.0);
        let fall_speed = i
            .vx_mps
            .hypot(i.vz_mps)
            .max((s.environment.g0_mps2 * drop).sqrt());
        let tf = TIME_SCALE_FACTOR * drop / fall_speed;
        let rate = angle / (0.25 * tf);
        let omega_span = (i.mass_kg / model.dry_mass_kg).ln();
        let accel = model.max_thrust_n / i.mass_kg;
        let sigma_scale = accel;
        let u_scale = match form {
            Formulation::Paper | Formulation::Vector => [
                sigma_scale,
                sigma_scale,
                sigma_scale,
                model.max_gimbal_rate_radps,
            ],
            Formulation::Exact => [sigma_scale, model.max_gimbal_rate_radps, 1.0, 1.0],
        };
        Scaling {
            x_offset: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, i.mass_kg.ln(), 0.0],
            x_scale: [
                length,
                length,
                speed,
                speed,
                angle,
                rate,
                omega_span,
                model.max_gimbal_rad,
            ],
            u_scale,
            tf_scale: tf,
        }
    }
}

/// Regularization ε of the second-order correction's system [I Aᵀ; A −εI]:
/// small against the unit primal block, so the step is the minimum-norm one
/// to ~1e-10, yet it keeps the factorization quasi-definite when A_eq is
/// rank-deficient.
const CORRECTION_REGULARIZATION: f64 = 1e-10;

/// Time scale of t_f = this × altitude drop / initial speed (see [`Scaling::new`]).
const TIME_SCALE_FACTOR: f64 = 1.7;

/// Everything about the subproblem that does not change between SCvx iterations.
#[derive(Debug, Clone)]
pub struct Transcription {
    pub model: Model,
    pub form: Formulation,
    pub mesh: Mesh,
    pub layout: Layout,
    pub scaling: Scaling,
    /// Initial state (all 8 LCvx states) and terminal x, z, Vx, Vz, θ, w, physical.
    pub x0: [f64; NX],
    pub xf: [f64; 6],
    /// Exact-penalty weight λ.
    pub penalty: f64,
    /// Soft thrust margin μ and its weight (μ = 0: off).
    pub margin_frac: f64,
    pub margin_weight: f64,
    /// Weight of the soft terminal x and Vx.
    pub terminal_weight: f64,
    /// Whether z ≥ z_f is imposed at every node (see `set_bounds`).
    pub ground_bound: bool,
    /// Structural nonzeros of ∂f/∂x and ∂f/∂u: `assemble` emits exactly these
    /// entries, zero or not, so every subproblem has the same sparsity and
    /// Clarabel can be updated in place ([`crate::conic`]).
    pattern_a: [[bool; NX]; NX],
    pattern_b: [[bool; NU_MAX]; NX],
    /// Scaled bounds of the trajectory variables (±∞ where free).
    lo: Vec<f64>,
    hi: Vec<f64>,
}

/// Conic data of one subproblem: minimize qᵀz s.t. A z + s = b, s ∈ cones.
#[derive(Debug, Clone)]
pub struct ConicData {
    /// Upper triangle of the quadratic cost: the proximal term w·‖ẑ − ẑ_ref‖².
    pub p: CscMatrix<f64>,
    /// Linear cost of the convex model L (cost plus exact penalty).
    pub q_model: Vec<f64>,
    /// Linear cost including the proximal term's linear part.
    pub q: Vec<f64>,
    pub a: CscMatrix<f64>,
    pub b: Vec<f64>,
    pub cones: Vec<SupportedConeT<f64>>,
}

/// The answer of one subproblem.
#[derive(Debug, Clone)]
pub struct SubproblemResult {
    pub trajectory: Trajectory,
    /// Scaled trajectory variables.
    pub z: Vec<f64>,
    /// Objective of the convex model L(z) (cost plus linear penalty).
    pub model_cost: f64,
    /// Largest virtual control or buffer (scaled ∞-norm).
    pub virtual_control: f64,
    pub ipm_iterations: u32,
    pub status: SolverStatus,
    /// Virtual control ν⁺ − ν⁻ of every collocation defect (node-major, N·NX).
    pub defect_virtual_control: Vec<f64>,
}

/// Value of the penalized nonlinear cost J(z) (SCvx merit function).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Merit {
    /// Scaled cost −ω̂(t_f).
    pub cost: f64,
    /// Σ |collocation defect| (scaled, Eq. 24).
    pub defect_l1: f64,
    /// Largest |collocation defect| (scaled).
    pub defect_max: f64,
    /// Σ path-constraint violation (σ bounds, Eq. 20; direction, Eq. 18), scaled.
    pub path_l1: f64,
    /// cost + λ·(defect_l1 + path_l1).
    pub total: f64,
}

struct Rows {
    i: Vec<usize>,
    j: Vec<usize>,
    v: Vec<f64>,
    b: Vec<f64>,
}

impl Rows {
    fn new() -> Self {
        Rows {
            i: vec![],
            j: vec![],
            v: vec![],
            b: vec![],
        }
    }
    fn push(&mut self, entries: &[(usize, f64)], rhs: f64) {
        let r = self.b.len();
        for &(j, v) in entries {
            self.i.push(r);
            self.j.push(j);
            self.v.push(v);
        }
        self.b.push(rhs);
    }
    fn entry(&mut self, j: usize, v: f64) {
        self.i.push(self.b.len());
        self.j.push(j);
        self.v.push(v);
    }
    fn finish_row(&mut self, rhs: f64) {
        self.b.push(rhs);
    }
}

impl Transcription {
    /// The transcription of `s` on its mesh (`s.discretization`: N points over
    /// M intervals). `s` must have passed validation.
    pub fn new(s: &Scenario) -> Self {
        let nodes = s.discretization.nodes;
        let model = Model::new(&s.vehicle, &s.environment);
        let form = s.solver.formulation;
        let layout = Layout {
            n: nodes,
            nu: dynamics::control_dim(form),
            path_rows: match form {
                Formulation::Exact => 0,
                Formulation::Paper => 1,
                Formulation::Vector => 2,
            },
            soft_margin: s.solver.thrust_margin_frac > 0.0,
            soft_terminal: s.solver.terminal_lateral_weight > 0.0,
        };
        let scaling = Scaling::new(s, &model, form);
        let i = &s.initial;
        let t = &s.terminal;
        // The LCvx state carries ω = ln m where P2 carries m.
        let mut x0 = i.state_si();
        x0[ix::OMEGA] = i.mass_kg.ln();
        let xf = t.state_si();
        let mut tr = Transcription {
            mesh: Mesh::uniform(nodes, s.discretization.intervals),
            model,
            form,
            layout,
            scaling,
            x0,
            xf,
            penalty: s.solver.virtual_control_weight,
            margin_frac: s.solver.thrust_margin_frac,
            margin_weight: s.solver.thrust_margin_weight,
            terminal_weight: s.solver.terminal_lateral_weight,
            ground_bound: true,
            pattern_a: [[false; NX]; NX],
            pattern_b: [[false; NU_MAX]; NX],
            lo: vec![],
            hi: vec![],
        };
        tr.set_bounds();
        tr.set_pattern();
        tr
    }

    /// The Jacobians' structural nonzeros: the union of the nonzeros at two
    /// generic points (no component zero, angles off every multiple of π/4).
    fn set_pattern(&mut self) {
        let points: [([f64; NX], [f64; NU_MAX]); 2] = [
            (
                [13.0, 320.0, 7.0, -41.0, 0.71, 0.053, 11.6, 0.031],
                [2.1, 6.3, 7.4, 0.017],
            ),
            (
                [-5.0, 80.0, -3.0, -12.0, 1.37, -0.021, 11.5, -0.07],
                [-1.3, 9.2, 9.9, -0.04],
            ),
        ];
        let nu = self.layout.nu;
        for (x, u) in points {
            let mut u = u;
            if nu == 2 {
                u = [u[2], u[3], 0.0, 0.0];
            }
            let lin = dynamics::linearize(&self.model, self.form, &x, &u[..nu]);
            for c in 0..NX {
                for c2 in 0..NX {
                    self.pattern_a[c][c2] |= lin.a[c][c2] != 0.0;
                }
                for c2 in 0..nu {
                    self.pattern_b[c][c2] |= lin.b[c][c2] != 0.0;
                }
            }
        }
    }

    /// The same transcription without the ground bound z ≥ z_f.
    pub fn without_ground_bound(mut self) -> Self {
        self.ground_bound = false;
        self.set_bounds();
        self
    }

    fn set_bounds(&mut self) {
        let l = self.layout;
        let sc = &self.scaling;
        let mut lo = vec![f64::NEG_INFINITY; l.n_primal()];
        let mut hi = vec![f64::INFINITY; l.n_primal()];
        let dmax = self.model.max_gimbal_rad / sc.x_scale[ix::DELTA];
        // The ground: z ≥ z_f at every node. The paper states no such bound, but
        // without it a vehicle too low to stop "lands" by diving below the
        // landing point and climbing back. It is inactive on the paper's case.
        // `ground_bound` false leaves it out (the relaxed first phase); every
        // returned solution is still checked against it.
        let ground = (self.xf[ix::Z] - sc.x_offset[ix::Z]) / sc.x_scale[ix::Z];
        for k in 0..=l.n {
            lo[l.x(k, ix::DELTA)] = -dmax;
            hi[l.x(k, ix::DELTA)] = dmax;
            if self.ground_bound {
                lo[l.x(k, ix::Z)] = ground;
            }
        }
        // ω(t_f) ≥ ln m_dry (Eq. 17)
        lo[l.x(l.n, ix::OMEGA)] =
            (self.model.dry_mass_kg.ln() - sc.x_offset[ix::OMEGA]) / sc.x_scale[ix::OMEGA];
        let chi = l.nu - 1;
        let sigma = if self.form != Formulation::Exact {
            2
        } else {
            0
        };
        for i in 0..l.n {
            let cmax = self.model.max_gimbal_rate_radps / sc.u_scale[chi];
            lo[l.u(i, chi)] = -cmax;
            hi[l.u(i, chi)] = cmax;
            lo[l.u(i, sigma)] = 0.0;
        }
        // t_f > 0; a landing burn of less than 2 % of the guess is not sought.
        lo[l.tf()] = 0.02;
        self.lo = lo;
        self.hi = hi;
    }

    /// Index of σ in the control vector.
    pub fn sigma_index(&self) -> usize {
        match self.form {
            Formulation::Paper | Formulation::Vector => 2,
            Formulation::Exact => 0,
        }
    }

    /// Physical → scaled trajectory variables.
    pub fn to_scaled(&self, t: &Trajectory) -> Vec<f64> {
        let l = self.layout;
        let sc = &self.scaling;
        let mut z = vec![0.0; l.n_primal()];
        for (k, xk) in t.x.iter().enumerate() {
            for c in 0..NX {
                z[l.x(k, c)] = (xk[c] - sc.x_offset[c]) / sc.x_scale[c];
            }
        }
        for (i, ui) in t.u.iter().enumerate() {
            for c in 0..l.nu {
                z[l.u(i, c)] = ui[c] / sc.u_scale[c];
            }
        }
        z[l.tf()] = t.tf_s / sc.tf_scale;
        z
    }

    /// Scaled → physical trajectory.
    pub fn from_scaled(&self, z: &[f64]) -> Trajectory {
        let l = self.layout;
        let sc = &self.scaling;
        let x = (0..=l.n)
            .map(|k| std::array::from_fn(|c| sc.x_offset[c] + sc.x_scale[c] * z[l.x(k, c)]))
            .collect();
        let u = (0..l.n)
            .map(|i| {
                std::array::from_fn(|c| {
                    if c < l.nu {
                        sc.u_scale[c] * z[l.u(i, c)]
                    } else {
                        0.0
                    }
                })
            })
            .collect();
        Trajectory {
            x,
            u,
            tf_s: sc.tf_scale * z[l.tf()],
        }
    }

    /// Thrust direction φ = atan2(Txm, Tzm) of the paper's controls, with its
    /// gradient (k_x, k_z) (Eq. 27). A zero vector takes the nozzle direction.
    fn direction(&self, x: &[f64; NX], u: &[f64; NU_MAX]) -> (f64, f64, f64) {
        let (mut tx, mut tz) = (u[0], u[1]);
        let r2 = tx * tx + tz * tz;
        if r2 < 1e-12 {
            let phi = x[ix::THETA] + x[ix::DELTA];
            let s = u[2].max(1e-3);
            tx = s * phi.sin();
            tz = s * phi.cos();
        }
        let r2 = tx * tx + tz * tz;
        (tx.atan2(tz), tz / r2, -tx / r2)
    }

    /// Nonlinear collocation defects (Eq. 24, divided by each state's scale).
    pub fn defects(&self, t: &Trajectory) -> Vec<[f64; NX]> {
        let n = self.layout.n;
        (0..n)
            .map(|i| {
                let f =
                    dynamics::rhs_lcvx(&self.model, self.form, &t.x[i], &t.u[i][..self.layout.nu]);
                std::array::from_fn(|c| {
                    let (s0, row) = self.mesh.d_row(i);
                    let dx: f64 = row.iter().zip(&t.x[s0..]).map(|(d, x)| d * x[c]).sum();
                    (dx - 0.5 * t.tf_s * f[c]) / self.scaling.x_scale[c]
                })
            })
            .collect()
    }

    /// Path-constraint violations per node (scaled): σ bounds (Eq. 20) and,
    /// for the paper's formulation, the direction equality (Eq. 18).
    fn path_violation(&self, t: &Trajectory) -> f64 {
        let si = self.sigma_index();
        let s_sigma = self.scaling.u_scale[si];
        let mut total = 0.0;
        for i in 0..self.layout.n {
            let inv_m = (-t.x[i][ix::OMEGA]).exp();
            let sigma = t.u[i][si];
            total += (self.model.min_thrust_n * inv_m - sigma).max(0.0) / s_sigma;
            total += (sigma - self.model.max_thrust_n * inv_m).max(0.0) / s_sigma;
            match self.form {
                Formulation::Exact => {}
                Formulation::Paper => {
                    let (phi, _, _) = self.direction(&t.x[i], &t.u[i]);
                    total += wrap_angle(phi - t.x[i][ix::THETA] - t.x[i][ix::DELTA]).abs();
                }
                Formulation::Vector => {
                    let (g1, g2) = vector_residuals(&t.x[i], &t.u[i]);
                    total += (g1.abs() + g2.abs()) / s_sigma;
                }
            }
        }
        total
    }

    /// Cost of the soft thrust margin's use: its weight times the scaled σ
    /// outside [(1+μ)·T_min, (1−μ)·T_max]/m, summed over the nodes.
    fn margin_cost(&self, t: &Trajectory) -> f64 {
        if !self.layout.soft_margin {
            return 0.0;
        }
        let si = self.sigma_index();
        let s_sigma = self.scaling.u_scale[si];
        let (lo, hi) = self.margin_thrust_n();
        let used: f64 = (0..self.layout.n)
            .map(|i| {
                let inv_m = (-t.x[i][ix::OMEGA]).exp();
                let sigma = t.u[i][si];
                ((lo * inv_m - sigma).max(0.0) + (sigma - hi * inv_m).max(0.0)) / s_sigma
            })
            .sum();
        self.margin_weight * used
    }

    /// Cost of the soft terminal x and Vx: weight times the scaled misses.
    fn terminal_cost(&self, t: &Trajectory) -> f64 {
        if !self.layout.soft_terminal {
            return 0.0;
        }
        let xn = &t.x[self.layout.n];
        self.terminal_weight
            * [ix::X, ix::VX]
                .iter()
                .map(|&c| (xn[c] - self.xf[c]).abs() / self.scaling.x_scale[c])
                .sum::<f64>()
    }

    /// The soft thrust margin's throttle interval [(1+μ)·T_min, (1−μ)·T_max].
    fn margin_thrust_n(&self) -> (f64, f64) {
        (
            self.model.min_thrust_n * (1.0 + self.margin_frac),
            self.model.max_thrust_n * (1.0 - self.margin_frac),
        )
    }

    /// The SCvx merit function J: scaled cost (with the soft constraints')
    /// plus λ·(nonlinear constraint violation).
    pub fn merit(&self, t: &Trajectory) -> Merit {
        let l = self.layout;
        let omega_f = t.x[l.n][ix::OMEGA];
        let cost = -(omega_f - self.scaling.x_offset[ix::OMEGA]) / self.scaling.x_scale[ix::OMEGA]
            + self.margin_cost(t)
            + self.terminal_cost(t);
        let d = self.defects(t);
        let defect_l1: f64 = d.iter().flatten().map(|v| v.abs()).sum();
        let defect_max = d.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let path_l1 = self.path_violation(t);
        Merit {
            cost,
            defect_l1,
            defect_max,
            path_l1,
            total: cost + self.penalty * (defect_l1 + path_l1),
        }
    }

    /// Assemble P4 linearized about `reference`, with an ∞-norm trust region of
    /// scaled radius `radius` (Eq. 29).
    ///
    /// `proximal_weight` w adds w·‖ẑ − ẑ_ref‖² over the trajectory variables. It
    /// vanishes at convergence, so it does not move the optimum, but it makes the
    /// subproblem strongly convex: without it the solution of the (linear-cost)
    /// subproblem jumps between vertices on singular arcs — the gimbal rate χ
    /// chatters between ±χ_max — and the trust region binds on every iteration.
    pub fn assemble(&self, reference: &Trajectory, radius: f64, proximal_weight: f64) -> ConicData {
        let l = self.layout;
        let sc = &self.scaling;
        let n = l.n;
        let zref = self.to_scaled(reference);
        let tf = reference.tf_s;

        let mut eq = Rows::new();
        // Collocation defects, linearized (Eq. 24–26) with virtual control.
        for i in 0..n {
            let lin = dynamics::linearize(
                &self.model,
                self.form,
                &reference.x[i],
                &reference.u[i][..l.nu],
            );
            for c in 0..NX {
                let inv = 1.0 / sc.x_scale[c];
                let (s0, row) = self.mesh.d_row(i);
                for (j, &d) in row.iter().enumerate() {
                    eq.entry(l.x(s0 + j, c), d);
                }
                let mut rhs = 0.0;
                for c2 in 0..NX {
                    let coef = -0.5 * tf * lin.a[c][c2] * sc.x_scale[c2] * inv;
                    debug_assert!(self.pattern_a[c][c2] || coef == 0.0);
                    if self.pattern_a[c][c2] {
                        eq.entry(l.x(i, c2), coef);
                    }
                    rhs += coef * zref[l.x(i, c2)];
                }
                for c2 in 0..l.nu {
                    let coef = -0.5 * tf * lin.b[c][c2] * sc.u_scale[c2] * inv;
                    debug_assert!(self.pattern_b[c][c2] || coef == 0.0);
                    if self.pattern_b[c][c2] {
                        eq.entry(l.u(i, c2), coef);
                    }
                    rhs += coef * zref[l.u(i, c2)];
                }
                eq.entry(l.tf(), -0.5 * lin.f[c] * sc.tf_scale * inv);
                eq.entry(l.vc_pos(i, c), 1.0);
                eq.entry(l.vc_neg(i, c), -1.0);
                eq.finish_row(rhs);
            }
        }
        // Boundary conditions (Eq. 4).
        for c in 0..NX {
            eq.push(
                &[(l.x(0, c), 1.0)],
                (self.x0[c] - sc.x_offset[c]) / sc.x_scale[c],
            );
        }
        for c in 0..6 {
            let rhs = (self.xf[c] - sc.x_offset[c]) / sc.x_scale[c];
            let soft = [ix::X, ix::VX].iter().position(|&s| s == c);
            match soft {
                Some(j) if l.soft_terminal => eq.push(
                    &[
                        (l.x(n, c), 1.0),
                        (l.terminal_miss(j, 0), -1.0),
                        (l.terminal_miss(j, 1), 1.0),
                    ],
                    rhs,
                ),
                _ => eq.push(&[(l.x(n, c), 1.0)], rhs),
            }
        }
        // Paper formulation: linearized direction constraint (Eq. 27).
        if self.form == Formulation::Vector {
            // T ∥ nozzle axis and |T| = σ, linearized in (T, σ, φ = θ + δ).
            let s_t = sc.u_scale[0];
            let offs = sc.x_offset[ix::THETA] + sc.x_offset[ix::DELTA];
            for i in 0..n {
                let (x, u) = (&reference.x[i], &reference.u[i]);
                let phi = x[ix::THETA] + x[ix::DELTA];
                let (sp, cp) = phi.sin_cos();
                let (g1, _) = vector_residuals(x, u);
                let along = u[0] * sp + u[1] * cp;
                let rows: [(&[(usize, f64)], f64); 2] = [
                    (&[(l.u(i, 0), cp), (l.u(i, 1), -sp)], -along),
                    (&[(l.u(i, 2), 1.0), (l.u(i, 0), -sp), (l.u(i, 1), -cp)], -g1),
                ];
                for (r, (t_entries, c_phi)) in rows.into_iter().enumerate() {
                    for &(j, v) in t_entries {
                        eq.entry(j, v);
                    }
                    eq.entry(l.x(i, ix::THETA), c_phi * sc.x_scale[ix::THETA] / s_t);
                    eq.entry(l.x(i, ix::DELTA), c_phi * sc.x_scale[ix::DELTA] / s_t);
                    eq.entry(l.dir(i, r, 0), 1.0);
                    eq.entry(l.dir(i, r, 1), -1.0);
                    eq.finish_row((c_phi * phi - c_phi * offs) / s_t);
                }
            }
        }
        if self.form == Formulation::Paper {
            for i in 0..n {
                let (phi, kx, kz) = self.direction(&reference.x[i], &reference.u[i]);
                let u = &reference.u[i];
                eq.push(
                    &[
                        (l.u(i, 0), kx * sc.u_scale[0]),
                        (l.u(i, 1), kz * sc.u_scale[1]),
                        (l.x(i, ix::THETA), -sc.x_scale[ix::THETA]),
                        (l.x(i, ix::DELTA), -sc.x_scale[ix::DELTA]),
                        (l.dir(i, 0, 0), 1.0),
                        (l.dir(i, 0, 1), -1.0),
                    ],
                    -phi + kx * u[0] + kz * u[1] + sc.x_offset[ix::THETA] + sc.x_offset[ix::DELTA],
                );
            }
        }

        let mut ineq = Rows::new();
        // Variable bounds intersected with the trust region (Eq. 29).
        for (p, (&zr, (&lo, &hi))) in zref.iter().zip(self.lo.iter().zip(&self.hi)).enumerate() {
            let centre = zr.clamp(lo, hi);
            let hi = hi.min(centre + radius);
            let lo = lo.max(centre - radius);
            ineq.push(&[(p, 1.0)], hi);
            ineq.push(&[(p, -1.0)], -lo);
        }
        // Linearized thrust bounds (Eq. 28) with penalized buffers.
        let si = self.sigma_index();
        let s_sigma = sc.u_scale[si];
        let (s_om, o_om) = (sc.x_scale[ix::OMEGA], sc.x_offset[ix::OMEGA]);
        let (lo, hi) = self.margin_thrust_n();
        for i in 0..n {
            let w0 = reference.x[i][ix::OMEGA];
            let e = (-w0).exp();
            // sign·(σ − T e^{−ω̄}(1 − (ω − ω̄))) ≤ slack: the engine's bounds
            // with penalized buffers, and (when on) the soft margin's
            // interval with its use as the slack.
            let engine = [
                (self.model.min_thrust_n, -1.0, l.buffer(i, 0)),
                (self.model.max_thrust_n, 1.0, l.buffer(i, 1)),
            ];
            let margin = l
                .soft_margin
                .then(|| [(lo, -1.0, l.margin(i, 0)), (hi, 1.0, l.margin(i, 1))]);
            for (thrust, sign, slack) in engine.into_iter().chain(margin.into_iter().flatten()) {
                let k = thrust * e;
                ineq.push(
                    &[
                        (l.u(i, si), sign),
                        (l.x(i, ix::OMEGA), sign * k * s_om / s_sigma),
                        (slack, -1.0),
                    ],
                    sign * k * (1.0 + w0 - o_om) / s_sigma,
                );
            }
        }
        // Penalty, margin and terminal-miss variables are non-negative.
        for p in l.n_primal()..l.n_var() {
            ineq.push(&[(p, -1.0)], 0.0);
        }

        let mut soc = Rows::new();
        // The vector formulation has no cone: its linearized equalities already
        // fix |T| = σ, and the cone would forbid the first-order rotation of T
        // (a tangent step lengthens T by σ·Δφ²/2), stalling the iteration.
        if self.form == Formulation::Paper {
            // ‖(Txm, Tzm)‖ ≤ σ (Eq. 19); the three share one scale.
            for i in 0..n {
                soc.push(&[(l.u(i, 2), -1.0)], 0.0);
                soc.push(&[(l.u(i, 0), -1.0)], 0.0);
                soc.push(&[(l.u(i, 1), -1.0)], 0.0);
            }
        }

        let (m_eq, m_in, m_soc) = (eq.b.len(), ineq.b.len(), soc.b.len());
        let mut rows = eq.i;
        rows.extend(ineq.i.iter().map(|r| r + m_eq));
        rows.extend(soc.i.iter().map(|r| r + m_eq + m_in));
        let mut cols = eq.j;
        cols.extend(ineq.j);
        cols.extend(soc.j);
        let mut vals = eq.v;
        vals.extend(ineq.v);
        vals.extend(soc.v);
        let mut b = eq.b;
        b.extend(ineq.b);
        b.extend(soc.b);
        let m = m_eq + m_in + m_soc;
        let a = CscMatrix::new_from_triplets(m, l.n_var(), rows, cols, vals);

        let mut cones = vec![
            SupportedConeT::ZeroConeT(m_eq),
            SupportedConeT::NonnegativeConeT(m_in),
        ];
        cones.extend((0..m_soc / 3).map(|_| SupportedConeT::SecondOrderConeT(3)));

        let mut q = vec![0.0; l.n_var()];
        q[l.x(n, ix::OMEGA)] = -1.0;
        q[l.n_primal()..l.n_penalty_end()].fill(self.penalty);
        q[l.n_penalty_end()..l.n_margin_end()].fill(self.margin_weight);
        q[l.n_margin_end()..].fill(self.terminal_weight);
        let q_model = q.clone();
        let np = l.n_primal();
        let p = if proximal_weight > 0.0 {
            for (k, zr) in zref.iter().enumerate() {
                q[k] -= 2.0 * proximal_weight * zr;
            }
            CscMatrix::new(
                l.n_var(),
                l.n_var(),
                (0..=l.n_var()).map(|c| c.min(np)).collect(),
                (0..np).collect(),
                vec![2.0 * proximal_weight; np],
            )
        } else {
            CscMatrix::zeros((l.n_var(), l.n_var()))
        };
        ConicData {
            p,
            q_model,
            q,
            a,
            b,
            cones,
        }
    }

    /// Second-order correction of a subproblem's answer `sub` (Nocedal &
    /// Wright §15.6, in its minimum-norm form): the smallest scaled change Δẑ
    /// of the trajectory variables with A_eq·Δẑ = −(c(ẑ⁺) − c_lin(ẑ⁺)) on the
    /// linearized equalities of `data` (collocation defects, boundary
    /// conditions), then clipped to the variable bounds. The candidate ẑ⁺ + Δẑ
    /// meets the nonlinear defects to O(‖Δẑ‖·‖ẑ⁺ − ẑ_ref‖) where ẑ⁺ met them to
    /// O(‖ẑ⁺ − ẑ_ref‖²), and keeps ẑ⁺'s virtual control (c_lin(ẑ⁺) = −ν).
    ///
    /// One sparse quasi-definite LDLᵀ solve of [I Aᵀ; A −εI] (Clarabel's
    /// QDLDL) instead of a second conic solve: measured on 40 dispersed
    /// states, a conic correction doubles the cost of a corrected iteration
    /// for no better answers. Returns the corrected scaled trajectory
    /// variables and the trajectory; `None` if the system cannot be factored.
    pub fn second_order_correction(
        &self,
        data: &ConicData,
        sub: &SubproblemResult,
    ) -> Option<(Vec<f64>, Trajectory)> {
        use clarabel::qdldl::{QDLDLFactorisation, QDLDLSettingsBuilder};
        let l = self.layout;
        let np = l.n_primal();
        let m_eq = match data.cones.first() {
            Some(SupportedConeT::ZeroConeT(m)) => *m,
            _ => return None,
        };
        // Upper triangle of K: the unit primal block, A_eq (trajectory
        // columns) as the block above the −ε diagonal.
        let dim = np + m_eq;
        let (mut ri, mut ci, mut vv): (Vec<usize>, Vec<usize>, Vec<f64>) =
            ((0..np).collect(), (0..np).collect(), vec![1.0; np]);
        for j in 0..np {
            for k in data.a.colptr[j]..data.a.colptr[j + 1] {
                if data.a.rowval[k] < m_eq {
                    ri.push(j);
                    ci.push(np + data.a.rowval[k]);
                    vv.push(data.a.nzval[k]);
                }
            }
        }
        ri.extend(np..dim);
        ci.extend(np..dim);
        vv.resize(vv.len() + m_eq, -CORRECTION_REGULARIZATION);
        let k = CscMatrix::new_from_triplets(dim, dim, ri, ci, vv);
        let mut signs = vec![1i8; np];
        signs.resize(dim, -1);
        let opts = QDLDLSettingsBuilder::default().Dsigns(signs).build().ok()?;
        let mut ldl = QDLDLFactorisation::new(&k, Some(opts)).ok()?;
        // Right-hand side: minus the linearization error of each defect row
        // (the defect rows come first, node-major); boundary rows are linear.
        let mut rhs = vec![0.0; dim];
        let defects = self.defects(&sub.trajectory);
        for (r, (d, v)) in defects
            .iter()
            .flatten()
            .zip(&sub.defect_virtual_control)
            .enumerate()
        {
            rhs[np + r] = -(d + v);
        }
        ldl.solve(&mut rhs);
        let z: Vec<f64> = (0..np)
            .map(|j| (sub.z[j] + rhs[j]).clamp(self.lo[j], self.hi[j]))
            .collect();
        if !z.iter().all(|v| v.is_finite()) {
            return None;
        }
        let t = self.from_scaled(&z);
        Some((z, t))
    }

    /// Solve one subproblem with Clarabel; an error names the solver status when it fails.
    pub fn solve(&self, data: &ConicData) -> Result<SubproblemResult, String> {
        crate::conic::solve_once(self, data)
    }

    /// Solve one subproblem with a solver kept across iterations (set up on
    /// its first use, then updated in place).
    pub fn solve_with(
        &self,
        conic: &mut ConicSolver,
        data: &ConicData,
    ) -> Result<SubproblemResult, String> {
        let l = self.layout;
        let sol = conic.solve(data)?;
        let z = sol.x[..l.n_primal()].to_vec();
        let defect_virtual_control: Vec<f64> = (0..l.n)
            .flat_map(|i| (0..NX).map(move |c| (i, c)))
            .map(|(i, c)| sol.x[l.vc_pos(i, c)] - sol.x[l.vc_neg(i, c)])
            .collect();
        let mut vc = defect_virtual_control
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        for i in 0..l.n {
            vc = vc.max(sol.x[l.buffer(i, 0)]).max(sol.x[l.buffer(i, 1)]);
            for r in 0..l.path_rows {
                vc = vc.max((sol.x[l.dir(i, r, 0)] - sol.x[l.dir(i, r, 1)]).abs());
            }
        }
        Ok(SubproblemResult {
            defect_virtual_control,
            trajectory: self.from_scaled(&z),
            z,
            model_cost: data.q_model.iter().zip(&sol.x).map(|(q, x)| q * x).sum(),
            virtual_control: vc,
            ipm_iterations: sol.iterations,
            status: sol.status,
        })
    }
}

/// Residuals of the vector formulation's path equalities (φ = θ + δ):
/// g1 = Txm·cos φ − Tzm·sin φ (thrust off the nozzle axis) and
/// g2 = σ − (Txm·sin φ + Tzm·cos φ) (thrust magnitude short of σ).
pub fn vector_residuals(x: &[f64; NX], u: &[f64; NU_MAX]) -> (f64, f64) {
    let (sp, cp) = (x[ix::THETA] + x[ix::DELTA]).sin_cos();
    (u[0] * cp - u[1] * sp, u[2] - u[0] * sp - u[1] * cp)
}

/// Wrap an angle to (−π, π].
pub fn wrap_angle(a: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let r = a.rem_euclid(two_pi);
    if r > std::f64::consts::PI {
        r - two_pi
    } else {
        r
    }
}
