//! SCvx's transcription of P2 on the LGR mesh: the variable layout, the
//! scaling, the bounds, the defects and the merit function of the convex
//! subproblem P4 (Eq. 26–30). Its assembly as conic data for Clarabel, and
//! Clarabel itself, live on the SCvx side (`method::scvx::subproblem`).
//!
//! Decision variables are scaled
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
//! margin ([`crate::input::settings::SolverSettings::thrust_margin_frac`]) per node
//! and side, and the misses of x(t_f) and Vx(t_f)
//! ([`crate::input::settings::SolverSettings::terminal_lateral_weight`]).

use crate::collocation::mesh::Mesh;
use crate::collocation::scaling::Scaling;
use crate::collocation::trajectory::Trajectory;
use crate::input::scenario::Scenario;
use crate::input::settings::{Formulation, SolverSettings};
use crate::problem::constraints::{self, Row};
use crate::problem::dynamics::{self, ix, Model, NU_MAX, NX};
use crate::solution::{node_thrust_n, Checks};

/// Index map of the decision vector.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    pub n: usize,
    pub nu: usize,
    /// Linearized path equalities per node with virtual control:
    /// 0 (exact), 1 (paper: direction, Eq. 27), 2 (vector: direction and magnitude).
    pub path_rows: usize,
    /// Whether the soft thrust margin's variables are present
    /// ([`crate::input::settings::SolverSettings::thrust_margin_frac`]).
    pub soft_margin: bool,
    /// Whether x(t_f) and Vx(t_f) are soft (their misses are variables).
    pub soft_terminal: bool,
    /// Rows of the operational constraints per node (issue 37,
    /// [`crate::problem::constraints`]), each with a penalized buffer.
    pub limit_rows: usize,
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
    /// Buffer on operational row `r` at collocation point i.
    pub fn limit_buffer(&self, i: usize, r: usize) -> usize {
        debug_assert!(r < self.limit_rows);
        self.n_primal()
            + 2 * NX * self.n
            + 2 * self.n
            + 2 * self.path_rows * self.n
            + i * self.limit_rows
            + r
    }
    /// Use of the soft thrust margin below (side 0) or above (side 1) at node i.
    pub fn margin(&self, i: usize, side: usize) -> usize {
        debug_assert!(self.soft_margin);
        self.n_penalty_end() + 2 * i + side
    }
    /// End of the exact-penalty variables (virtual control, buffers, path).
    pub(crate) fn n_penalty_end(&self) -> usize {
        self.n_primal()
            + 2 * NX * self.n
            + 2 * self.n
            + 2 * self.path_rows * self.n
            + self.limit_rows * self.n
    }
    pub(crate) fn n_margin_end(&self) -> usize {
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
    /// The operational constraints' rows, linearized at every collocation
    /// point but the first (whose state is fixed and certified inside them).
    pub limits: Vec<Row>,
    /// Structural nonzeros of ∂f/∂x and ∂f/∂u: `assemble` emits exactly these
    /// entries, zero or not, so every subproblem has the same sparsity and
    /// Clarabel can be updated in place ([`crate::method::scvx::conic`]).
    pub(crate) pattern_a: [[bool; NX]; NX],
    pub(crate) pattern_b: [[bool; NU_MAX]; NX],
    /// Scaled bounds of the trajectory variables (±∞ where free).
    pub(crate) lo: Vec<f64>,
    pub(crate) hi: Vec<f64>,
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

impl Transcription {
    /// The transcription of `s` on its mesh (`s.discretization`: N points over
    /// M intervals) for SCvx with settings `sv`. Both must have passed
    /// validation.
    pub fn new(s: &Scenario, sv: &SolverSettings) -> Self {
        let nodes = s.discretization.nodes;
        let model = Model::new(&s.vehicle, &s.environment);
        let form = sv.formulation;
        let layout = Layout {
            n: nodes,
            nu: dynamics::control_dim(form),
            path_rows: match form {
                Formulation::Exact => 0,
                Formulation::Paper => 1,
                Formulation::Vector => 2,
            },
            soft_margin: sv.thrust_margin_frac > 0.0,
            soft_terminal: sv.terminal_lateral_weight > 0.0,
            limit_rows: constraints::rows(s).len(),
        };
        let scaling = Scaling::new(s, &model, form);
        let i = &s.initial;
        let t = &s.terminal;
        // The LCvx state carries ω = ln m where P2 carries m.
        let mut x0 = i.state_si();
        x0[ix::OMEGA] = i.mass_kg.ln();
        let xf = t.state_si();
        let mut tr = Transcription {
            mesh: s.discretization.collocation_mesh(),
            model,
            form,
            layout,
            scaling,
            x0,
            xf,
            penalty: sv.virtual_control_weight,
            margin_frac: sv.thrust_margin_frac,
            margin_weight: sv.thrust_margin_weight,
            terminal_weight: sv.terminal_lateral_weight,
            ground_bound: true,
            limits: constraints::rows(s),
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
        dynamics::sigma_index(self.form)
    }

    /// The physical checks of a trajectory of this transcription: the
    /// relaxation gap and thrust alignment at each collocation point, the
    /// thrust bounds at every reported thrust, the nonlinear defects and
    /// the ground.
    pub fn checks(&self, t: &Trajectory, virtual_control: f64) -> Checks {
        let mut gap = 0.0f64;
        let mut align = 1.0f64;
        let mut bound = 0.0f64;
        for i in 0..self.layout.n {
            let x = &t.x[i];
            let (txm, tzm, sigma) =
                dynamics::thrust_components(self.form, x, &t.u[i][..self.layout.nu]);
            let norm = txm.hypot(tzm);
            if sigma > 0.0 {
                gap = gap.max(1.0 - norm / sigma);
            }
            let phi = x[ix::THETA] + x[ix::DELTA];
            if norm > 0.0 {
                align = align.min((txm * phi.sin() + tzm * phi.cos()) / norm);
            }
        }
        // Every reported thrust, the final node's included.
        for thrust in node_thrust_n(&self.model, self.form, t) {
            bound = bound
                .max(self.model.min_thrust_n - thrust)
                .max(thrust - self.model.max_thrust_n);
        }
        let max_defect = self
            .defects(t)
            .iter()
            .flatten()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let min_altitude_margin_m =
            t.x.iter()
                .map(|x| x[ix::Z] - self.xf[ix::Z])
                .fold(f64::INFINITY, f64::min);
        Checks {
            min_altitude_margin_m,
            relaxation_gap: gap,
            thrust_alignment_min: align,
            thrust_bound_violation_n: bound,
            max_defect,
            virtual_control,
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
    pub(crate) fn direction(&self, x: &[f64; NX], u: &[f64; NU_MAX]) -> (f64, f64, f64) {
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

    /// Path-constraint violations per node (scaled): σ bounds (Eq. 20), the
    /// operational constraints (over their rows' scales) and, for the
    /// paper's formulation, the direction equality (Eq. 18).
    fn path_violation(&self, t: &Trajectory) -> f64 {
        let si = self.sigma_index();
        let s_sigma = self.scaling.u_scale[si];
        let mut total = 0.0;
        for i in 0..self.layout.n {
            let inv_m = (-t.x[i][ix::OMEGA]).exp();
            let sigma = t.u[i][si];
            total += (self.model.min_thrust_n * inv_m - sigma).max(0.0) / s_sigma;
            total += (sigma - self.model.max_thrust_n * inv_m).max(0.0) / s_sigma;
            for r in &self.limits {
                total += r.value(&t.x[i]).max(0.0) / r.scale();
            }
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
    pub(crate) fn margin_thrust_n(&self) -> (f64, f64) {
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
