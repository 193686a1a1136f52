//! The convex subproblem P4 (Eq. 26–30) of a [`Transcription`] as sparse
//! conic data for Clarabel, its second-order correction (Clarabel's QDLDL),
//! and its solve: the one place that builds solver data. With
//! [`super::socp`] (the data's types) and [`super::conic`] (the solver),
//! the only files that name Clarabel's types.
//!
//! Every constraint row is divided by the scale of the quantity it
//! constrains; the layout and the scaling are the transcription's.

use clarabel::algebra::CscMatrix;
use clarabel::solver::SupportedConeT;

use super::conic::ConicSolver;
use super::socp::{ConicData, SubproblemResult};
use crate::collocation::trajectory::Trajectory;
use crate::input::settings::Formulation;
use crate::method::scvx::transcription::{vector_residuals, Transcription};
use crate::problem::dynamics::{self, ix, NX};

/// Regularization ε of the second-order correction's system [I Aᵀ; A −εI]:
/// small against the unit primal block, so the step is the minimum-norm one
/// to ~1e-10, yet it keeps the factorization quasi-definite when A_eq is
/// rank-deficient.
const CORRECTION_REGULARIZATION: f64 = 1e-10;

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

/// The constraint matrix A, right-hand side b and cones of the stacked
/// blocks: equalities (the zero cone), inequalities (the non-negative
/// cone), then the second-order cones of three rows each.
fn stack(
    eq: Rows,
    ineq: Rows,
    soc: Rows,
    n_var: usize,
) -> (CscMatrix<f64>, Vec<f64>, Vec<SupportedConeT<f64>>) {
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
    let a = CscMatrix::new_from_triplets(m, n_var, rows, cols, vals);

    let mut cones = vec![
        SupportedConeT::ZeroConeT(m_eq),
        SupportedConeT::NonnegativeConeT(m_in),
    ];
    cones.extend((0..m_soc / 3).map(|_| SupportedConeT::SecondOrderConeT(3)));
    (a, b, cones)
}

impl Transcription {
    /// Assemble P4 linearized about `reference`, with an ∞-norm trust region of
    /// scaled radius `radius` (Eq. 29).
    ///
    /// `proximal_weight` w adds w·‖ẑ − ẑ_ref‖² over the trajectory variables. It
    /// vanishes at convergence, so it does not move the optimum, but it makes the
    /// subproblem strongly convex: without it the solution of the (linear-cost)
    /// subproblem jumps between vertices on singular arcs — the gimbal rate χ
    /// chatters between ±χ_max — and the trust region binds on every iteration.
    pub fn assemble(&self, reference: &Trajectory, radius: f64, proximal_weight: f64) -> ConicData {
        let zref = self.to_scaled(reference);

        let mut eq = Rows::new();
        self.defect_rows(&mut eq, reference, &zref);
        self.boundary_rows(&mut eq);
        match self.form {
            Formulation::Vector => self.vector_direction_rows(&mut eq, reference),
            Formulation::Paper => self.paper_direction_rows(&mut eq, reference),
            Formulation::Exact => {}
        }

        let mut ineq = Rows::new();
        self.trust_region_rows(&mut ineq, &zref, radius);
        self.thrust_rows(&mut ineq, reference);
        self.limit_rows(&mut ineq, reference);
        self.nonnegative_rows(&mut ineq);

        let mut soc = Rows::new();
        // The vector formulation has no cone: its linearized equalities already
        // fix |T| = σ, and the cone would forbid the first-order rotation of T
        // (a tangent step lengthens T by σ·Δφ²/2), stalling the iteration.
        if self.form == Formulation::Paper {
            self.thrust_cone_rows(&mut soc);
        }

        let (a, b, cones) = stack(eq, ineq, soc, self.layout.n_var());
        let (p, q_model, q) = self.cost(&zref, proximal_weight);
        ConicData {
            p,
            q_model,
            q,
            a,
            b,
            cones,
        }
    }

    /// Collocation defects, linearized (Eq. 24–26) with virtual control:
    /// N·NX rows, node-major (the second-order correction relies on it).
    fn defect_rows(&self, eq: &mut Rows, reference: &Trajectory, zref: &[f64]) {
        let l = self.layout;
        let sc = &self.scaling;
        let tf = reference.tf_s;
        for i in 0..l.n {
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
    }

    /// Boundary conditions (Eq. 4): the whole initial state, and the final
    /// position, velocity and attitude (x and Vx with penalized misses when
    /// the terminal condition is soft).
    fn boundary_rows(&self, eq: &mut Rows) {
        let l = self.layout;
        let sc = &self.scaling;
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
                        (l.x(l.n, c), 1.0),
                        (l.terminal_miss(j, 0), -1.0),
                        (l.terminal_miss(j, 1), 1.0),
                    ],
                    rhs,
                ),
                _ => eq.push(&[(l.x(l.n, c), 1.0)], rhs),
            }
        }
    }

    /// Vector formulation: T ∥ nozzle axis and |T| = σ, linearized in
    /// (T, σ, φ = θ + δ), two rows per node with virtual control.
    fn vector_direction_rows(&self, eq: &mut Rows, reference: &Trajectory) {
        let l = self.layout;
        let sc = &self.scaling;
        let s_t = sc.u_scale[0];
        let offs = sc.x_offset[ix::THETA] + sc.x_offset[ix::DELTA];
        for i in 0..l.n {
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

    /// Paper formulation: the linearized direction constraint (Eq. 27), one
    /// row per node with virtual control.
    fn paper_direction_rows(&self, eq: &mut Rows, reference: &Trajectory) {
        let l = self.layout;
        let sc = &self.scaling;
        for i in 0..l.n {
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

    /// Variable bounds intersected with the trust region (Eq. 29): the box
    /// of ∞-norm radius `radius` about the reference (clamped into the
    /// bounds), two rows per trajectory variable.
    fn trust_region_rows(&self, ineq: &mut Rows, zref: &[f64], radius: f64) {
        for (p, (&zr, (&lo, &hi))) in zref.iter().zip(self.lo.iter().zip(&self.hi)).enumerate() {
            let centre = zr.clamp(lo, hi);
            let hi = hi.min(centre + radius);
            let lo = lo.max(centre - radius);
            ineq.push(&[(p, 1.0)], hi);
            ineq.push(&[(p, -1.0)], -lo);
        }
    }

    /// Linearized thrust bounds (Eq. 28) with penalized buffers, and the
    /// soft margin's interval when it is on.
    fn thrust_rows(&self, ineq: &mut Rows, reference: &Trajectory) {
        let l = self.layout;
        let sc = &self.scaling;
        let si = self.sigma_index();
        let s_sigma = sc.u_scale[si];
        let (s_om, o_om) = (sc.x_scale[ix::OMEGA], sc.x_offset[ix::OMEGA]);
        let (lo, hi) = self.margin_thrust_n();
        for i in 0..l.n {
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
    }

    /// The operational constraints (issue 37) linearized at the reference,
    /// g(ȳ) + ∇g(ȳ)·(y − ȳ) ≤ buffer, at every collocation point but the
    /// first, over the row's scale. The triggered rows are concave in z, so
    /// their linearization is the tighter. Every state a row may involve
    /// gets its entry, zero or not, so the sparsity never changes.
    fn limit_rows(&self, ineq: &mut Rows, reference: &Trajectory) {
        const STATES: [usize; 5] = [ix::X, ix::Z, ix::VX, ix::THETA, ix::W];
        let l = self.layout;
        let sc = &self.scaling;
        for i in 0..l.n {
            for (r, row) in self.limits.iter().enumerate() {
                let (scale, buffer) = (row.scale(), l.limit_buffer(i, r));
                if i == 0 {
                    // The fixed initial state: only the buffer, kept at 0.
                    ineq.push(&[(buffer, -1.0)], 0.0);
                    continue;
                }
                let y = &reference.x[i];
                let e = row.eval(y);
                let mut rhs = -e.g;
                for c in STATES {
                    ineq.entry(l.x(i, c), e.grad[c] * sc.x_scale[c] / scale);
                    rhs += e.grad[c] * (y[c] - sc.x_offset[c]);
                }
                ineq.entry(buffer, -1.0);
                ineq.finish_row(rhs / scale);
            }
        }
    }

    /// Penalty, margin and terminal-miss variables are non-negative.
    fn nonnegative_rows(&self, ineq: &mut Rows) {
        let l = self.layout;
        for p in l.n_primal()..l.n_var() {
            ineq.push(&[(p, -1.0)], 0.0);
        }
    }

    /// The paper formulation's cone ‖(Txm, Tzm)‖ ≤ σ (Eq. 19), three rows
    /// per node (σ first); the three share one scale.
    fn thrust_cone_rows(&self, soc: &mut Rows) {
        let l = self.layout;
        for i in 0..l.n {
            soc.push(&[(l.u(i, 2), -1.0)], 0.0);
            soc.push(&[(l.u(i, 0), -1.0)], 0.0);
            soc.push(&[(l.u(i, 1), -1.0)], 0.0);
        }
    }

    /// The cost: the linear model's (−ω̂(t_f), the exact penalty on virtual
    /// control and buffers, the margin's and the terminal miss's weights),
    /// and with the proximal term w·‖ẑ − ẑ_ref‖² its quadratic part and the
    /// linear part it adds. Returns (P, q_model, q).
    fn cost(&self, zref: &[f64], proximal_weight: f64) -> (CscMatrix<f64>, Vec<f64>, Vec<f64>) {
        let l = self.layout;
        let mut q = vec![0.0; l.n_var()];
        q[l.x(l.n, ix::OMEGA)] = -1.0;
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
        (p, q_model, q)
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
        self.solve_with(&mut ConicSolver::new(), data)
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
