//! The Newton step on the primal–dual equations (Eq. 11–13): the barrier
//! problem's derivatives at the iterate, the KKT system built from them and
//! its solve with iterative refinement, the bound-multiplier step (Eq. 13)
//! and the safeguarded update of an accepted step (Eq. 16).
//!
//! Every buffer is in the [`Workspace`], allocated once per solve: an
//! iteration allocates nothing.

#![allow(clippy::needless_range_loop)] // Dense block algebra indexes several arrays by one index.

use crate::collocation::derivatives::Differentiable;
use crate::method::direct::iterate::{inf_norm, l1_norm, Bounds, Iterate};
use crate::method::direct::kkt::{Inertia, KktMatrix, KktSolver};
use crate::method::direct::nlp::{PointDerivatives, Transcription};
use crate::method::direct::rows::NodeRows;

/// s_max of the scaled optimality error (Eq. 5).
const S_MAX: f64 = 100.0;
/// κ_Σ of the safeguard on the bound multipliers (Eq. 16).
const KAPPA_SIGMA: f64 = 1e10;
/// Static regularization of every node block (scaled units). The free
/// variable w enters the problem linearly and has no bounds, so its rows of
/// W are zero; 1e-9 keeps the blocks factorable without counting as an
/// inertia correction, and iterative refinement removes its effect on the
/// step. (x is linear too, but the KKT solve eliminates it exactly.)
const DELTA_STATIC: f64 = 1e-9;
/// Iterative refinement stops once the residual is this fraction of the right-hand side.
const REFINE_TOL: f64 = 1e-12;

/// The Hessian of the Lagrangian f + λᵀc and the Jacobian of c in the
/// blocks of [`KktMatrix`] (no barrier, no regularization), from the
/// point derivatives at `w` with multipliers `lambda`.
pub fn lagrangian_blocks<M: Differentiable, const NS: usize, const NL: usize>(
    nlp: &Transcription<M, NS, NL>,
    w: &[f64],
    lambda: &[f64],
    derivs: &[PointDerivatives<NS, NL>],
    kkt: &mut KktMatrix<NS, NL>,
) {
    let n = nlp.n;
    let half_tf = 0.5 * nlp.tf_s(w);
    let half_scale = 0.5 * nlp.tf_scale;
    for k in 0..=n {
        kkt.w[k] = [[0.0; NL]; NL];
        kkt.h_t[k] = [0.0; NL];
        if k == n {
            continue;
        }
        let d = &derivs[k];
        let l = &lambda[k * NS..(k + 1) * NS];
        for r in 0..NL {
            for c in 0..NL {
                kkt.w[k][r][c] = -half_tf * d.hess[r][c];
            }
            kkt.h_t[k][r] = -half_scale * (0..NS).map(|q| l[q] * d.jac[q][r]).sum::<f64>();
        }
        for r in 0..NS {
            for c in 0..NL {
                kkt.b[k][r][c] = -half_tf * d.jac[r][c];
            }
            kkt.j_t[k][r] = -half_scale * d.f[r];
        }
    }
    nlp.add_objective_hessian(w, &mut kkt.w);
    kkt.h_tt = 0.0;
    kkt.delta_c = 0.0;
}

/// Scratch of one solve.
pub(super) struct Workspace<const NS: usize, const NL: usize> {
    pub(super) kkt: KktMatrix<NS, NL>,
    pub(super) solver: KktSolver<NS, NL>,
    pub(super) derivs: Vec<PointDerivatives<NS, NL>>,
    pub(super) c: Vec<f64>,
    pub(super) c_trial: Vec<f64>,
    pub(super) grad: Vec<f64>,
    pub(super) rw: Vec<f64>,
    pub(super) rl: Vec<f64>,
    pub(super) dw: Vec<f64>,
    pub(super) dl: Vec<f64>,
    res_w: Vec<f64>,
    res_l: Vec<f64>,
    cor_w: Vec<f64>,
    cor_l: Vec<f64>,
    trial: Vec<f64>,
    /// The iterate before the step, the Newton step, the bound-multiplier
    /// steps and the corrected constraint values of the SOC: kept here so
    /// that an iteration allocates nothing.
    pub(super) w_old: Vec<f64>,
    pub(super) step_w: Vec<f64>,
    pub(super) step_l: Vec<f64>,
    pub(super) dzl: Vec<f64>,
    pub(super) dzu: Vec<f64>,
    pub(super) c_soc: Vec<f64>,
    /// The storage of [`Newton::rows`] and [`Newton::dzr`] between solves.
    rows: NodeRows<NL>,
    dzr: Vec<f64>,
}

impl<const NS: usize, const NL: usize> Workspace<NS, NL> {
    pub(super) fn new<M: Differentiable>(nlp: &Transcription<M, NS, NL>) -> Self {
        let mut rows = NodeRows::default();
        rows.refill(nlp);
        let (nv, nc) = (nlp.n_var(), nlp.n_con());
        Workspace {
            kkt: KktMatrix::zeros(nlp),
            solver: KktSolver::new(nlp),
            derivs: vec![
                PointDerivatives {
                    f: [0.0; NS],
                    jac: [[0.0; NL]; NS],
                    hess: [[0.0; NL]; NL],
                };
                nlp.n
            ],
            c: vec![0.0; nc],
            c_trial: vec![0.0; nc],
            grad: vec![0.0; nv],
            rw: vec![0.0; nv],
            rl: vec![0.0; nc],
            dw: vec![0.0; nv],
            dl: vec![0.0; nc],
            res_w: vec![0.0; nv],
            res_l: vec![0.0; nc],
            cor_w: vec![0.0; nv],
            cor_l: vec![0.0; nc],
            trial: vec![0.0; nv],
            w_old: vec![0.0; nv],
            step_w: vec![0.0; nv],
            step_l: vec![0.0; nc],
            dzl: vec![0.0; nv],
            dzu: vec![0.0; nv],
            c_soc: vec![0.0; nc],
            dzr: vec![0.0; rows.len()],
            rows,
        }
    }
}

impl<const NS: usize, const NL: usize> Workspace<NS, NL> {
    /// Back to the state of [`Workspace::new`] for an NLP of the same
    /// structure ([`KktSolver::fits`]).
    pub(super) fn reset(&mut self) {
        self.kkt.reset();
        self.solver.reset();
        self.derivs.fill(PointDerivatives {
            f: [0.0; NS],
            jac: [[0.0; NL]; NS],
            hess: [[0.0; NL]; NL],
        });
        for v in [
            &mut self.c,
            &mut self.c_trial,
            &mut self.grad,
            &mut self.rw,
            &mut self.rl,
            &mut self.dw,
            &mut self.dl,
            &mut self.res_w,
            &mut self.res_l,
            &mut self.cor_w,
            &mut self.cor_l,
            &mut self.trial,
            &mut self.w_old,
            &mut self.step_w,
            &mut self.step_l,
            &mut self.dzl,
            &mut self.dzu,
            &mut self.c_soc,
        ] {
            v.fill(0.0);
        }
    }
}

/// The barrier problem of P2 at an iterate, and its Newton system.
pub(super) struct Newton<'a, M, const NS: usize, const NL: usize> {
    pub(super) nlp: &'a Transcription<M, NS, NL>,
    pub(super) bounds: Bounds,
    /// The operational rows at the nodes, evaluated with the iterate.
    pub(super) rows: NodeRows<NL>,
    /// Their multiplier step.
    pub(super) dzr: Vec<f64>,
    pub(super) ws: Workspace<NS, NL>,
    /// Free primal variables (with t̂_f).
    n_primal: usize,
}

impl<'a, M: Differentiable, const NS: usize, const NL: usize> Newton<'a, M, NS, NL> {
    /// The system of `nlp` in `ws` and `bounds` (made or refilled for
    /// `nlp`).
    pub(super) fn with_parts(
        nlp: &'a Transcription<M, NS, NL>,
        mut ws: Workspace<NS, NL>,
        bounds: Bounds,
    ) -> Self {
        let nv = nlp.n_var();
        let mut rows = std::mem::take(&mut ws.rows);
        rows.refill(nlp);
        let mut dzr = std::mem::take(&mut ws.dzr);
        dzr.clear();
        dzr.resize(rows.len(), 0.0);
        Newton {
            nlp,
            ws,
            bounds,
            dzr,
            rows,
            n_primal: (0..nv).filter(|&j| !nlp.is_fixed(j)).count(),
        }
    }

    /// Its workspace and bounds, for the next solve of the same structure.
    pub(super) fn into_parts(mut self) -> (Workspace<NS, NL>, Bounds) {
        self.ws.rows = self.rows;
        self.ws.dzr = self.dzr;
        (self.ws, self.bounds)
    }

    /// φ_μ(w) = f(w) + barrier.
    pub(super) fn phi(&self, w: &[f64], mu: f64) -> f64 {
        self.nlp.objective(w) + self.bounds.barrier(w, mu) + self.rows.barrier(self.nlp, w, mu)
    }

    /// Largest α ≤ 1 that keeps a fraction τ of every slack: the bounds'
    /// and the rows' (at the evaluated point w).
    pub(super) fn max_step(&self, w: &[f64], dw: &[f64], tau: f64) -> f64 {
        self.bounds
            .max_step(w, dw, tau)
            .min(self.rows.max_step(self.nlp, w, dw, tau))
    }

    /// Derivatives at every collocation point, with multipliers λ.
    pub(super) fn evaluate(&mut self, w: &[f64], lambda: &[f64]) {
        for i in 0..self.nlp.n {
            let l = &lambda[i * NS..(i + 1) * NS];
            self.nlp.point_derivatives(w, i, l, &mut self.ws.derivs[i]);
        }
        self.nlp.defects(w, &mut self.ws.c);
        self.rows.evaluate(self.nlp, w);
    }

    /// ∇f + Jᵀλ into ws.grad (without the bound multipliers).
    pub(super) fn lagrangian_gradient(&mut self, w: &[f64], lambda: &[f64]) {
        self.nlp.objective_gradient(w, &mut self.ws.grad);
        self.nlp
            .add_jt_lambda(w, &self.ws.derivs, lambda, &mut self.ws.grad);
    }
    /// Optimality error E_μ (Eq. 5) of the iterate; ws.grad must hold ∇f + Jᵀλ.
    pub(super) fn optimality_error(&self, it: &Iterate, mu: f64) -> (f64, f64, f64) {
        let b = &self.bounds;
        let (mut compl, mut z_sum) = self.rows.complementarity_error(&it.zr, mu);
        let mut dual = 0.0f64;
        let mut n_free = 0usize;
        for j in 0..it.w.len() {
            if !b.free[j] {
                continue;
            }
            n_free += 1;
            // The rows' Σ z∇ĝ joins the Lagrangian's gradient.
            let rows = self.rows.gradient_entry(self.nlp, &it.zr, j);
            dual = dual.max((self.ws.grad[j] + rows - it.zl[j] + it.zu[j]).abs());
            if b.has_lo[j] {
                compl = compl.max(((it.w[j] - b.lo[j]) * it.zl[j] - mu).abs());
                z_sum += it.zl[j];
            }
            if b.has_hi[j] {
                compl = compl.max(((b.hi[j] - it.w[j]) * it.zu[j] - mu).abs());
                z_sum += it.zu[j];
            }
        }
        let m = it.lambda.len() + self.rows.len();
        let s_d = (S_MAX.max((l1_norm(&it.lambda) + z_sum) / (m + n_free) as f64)) / S_MAX;
        let s_c = (S_MAX.max(z_sum / n_free as f64)) / S_MAX;
        let primal = inf_norm(&self.ws.c);
        let dual = dual / s_d;
        (dual.max(primal).max(compl / s_c), primal, dual)
    }

    /// Fill the KKT blocks at the iterate: W = ∇²L + Σ, with the
    /// regularization added at factorization.
    pub(super) fn build_kkt(&mut self, it: &Iterate) {
        let nlp = self.nlp;
        lagrangian_blocks(nlp, &it.w, &it.lambda, &self.ws.derivs, &mut self.ws.kkt);
        let b = &self.bounds;
        let sigma = |j: usize| {
            let mut s = 0.0;
            if b.has_lo[j] {
                s += it.zl[j] / (it.w[j] - b.lo[j]);
            }
            if b.has_hi[j] {
                s += it.zu[j] / (b.hi[j] - it.w[j]);
            }
            s
        };
        let kkt = &mut self.ws.kkt;
        for k in 0..=nlp.n {
            for s in 0..NL {
                // The eliminated positions' rows stay zero (kkt.rs).
                if !self.ws.solver.eliminates(k, s) {
                    kkt.w[k][s][s] += sigma(nlp.idx(k, s)) + DELTA_STATIC;
                }
            }
        }
        kkt.h_tt = sigma(nlp.tf_idx());
        self.rows.add_hessian(&it.zr, &mut kkt.w, false);
    }

    /// Factor K with W + δ_w I and δ_c; its inertia.
    pub(super) fn factor_with(&mut self, delta_w: f64, delta_c: f64, h_tt: f64) -> Inertia {
        let mut inertia = Inertia::default();
        for k in 0..=self.nlp.n {
            inertia = inertia + self.ws.solver.factor_node(k, &self.ws.kkt.w[k], delta_w);
            if inertia.zero > 0 {
                return inertia;
            }
        }
        self.ws.kkt.h_tt = h_tt + delta_w;
        self.ws.kkt.delta_c = delta_c;
        inertia + self.ws.solver.factor_reduced(&self.ws.kkt)
    }

    /// Whether an inertia is that of a descent direction: n positive, m negative.
    pub(super) fn correct_inertia(&self, i: Inertia) -> bool {
        i.zero == 0 && i.positive == self.n_primal && i.negative == self.nlp.n_con()
    }

    /// Solve K d = r with two steps of iterative refinement against the
    /// system without the static regularization.
    pub(super) fn solve_kkt(&mut self) {
        let nlp = self.nlp;
        let ws = &mut self.ws;
        ws.solver
            .solve(nlp, &ws.kkt, &ws.rw, &ws.rl, &mut ws.dw, &mut ws.dl);
        for _ in 0..2 {
            // K without the static part: subtract DELTA_STATIC·x from K x.
            ws.kkt
                .multiply(nlp, &ws.dw, &ws.dl, &mut ws.res_w, &mut ws.res_l);
            let mut worst = 0.0f64;
            for j in 0..ws.res_w.len() {
                if j == nlp.tf_idx() {
                    continue;
                }
                if !self.bounds.free[j] {
                    ws.res_w[j] = 0.0;
                    continue;
                }
                let (k, s) = (j / NL, j % NL);
                let static_part = if ws.solver.eliminates(k, s) {
                    0.0
                } else {
                    DELTA_STATIC * ws.dw[j]
                };
                ws.res_w[j] = ws.rw[j] - (ws.res_w[j] - static_part);
                worst = worst.max(ws.res_w[j].abs());
            }
            let tf = nlp.tf_idx();
            ws.res_w[tf] = ws.rw[tf] - ws.res_w[tf];
            worst = worst.max(ws.res_w[tf].abs());
            for r in 0..ws.res_l.len() {
                ws.res_l[r] = ws.rl[r] - ws.res_l[r];
                worst = worst.max(ws.res_l[r].abs());
            }
            let scale = inf_norm(&ws.rw).max(inf_norm(&ws.rl)).max(1e-300);
            if worst <= REFINE_TOL * scale {
                break;
            }
            ws.solver.solve(
                nlp,
                &ws.kkt,
                &ws.res_w,
                &ws.res_l,
                &mut ws.cor_w,
                &mut ws.cor_l,
            );
            for (d, c) in ws.dw.iter_mut().zip(&ws.cor_w) {
                *d += c;
            }
            for (d, c) in ws.dl.iter_mut().zip(&ws.cor_l) {
                *d += c;
            }
        }
    }

    /// Right-hand side of the barrier Newton step: −∇φ_μ − Jᵀλ and −c.
    pub(super) fn newton_rhs(&mut self, it: &Iterate, mu: f64) {
        let b = &self.bounds;
        for j in 0..it.w.len() {
            let mut g = self.ws.grad[j];
            if b.has_lo[j] {
                g -= mu / (it.w[j] - b.lo[j]);
            }
            if b.has_hi[j] {
                g += mu / (b.hi[j] - it.w[j]);
            }
            self.ws.rw[j] = if b.free[j] { -g } else { 0.0 };
        }
        self.rows
            .add_barrier_gradient(self.nlp, -mu, &mut self.ws.rw);
        for (r, c) in self.ws.rl.iter_mut().zip(&self.ws.c) {
            *r = -c;
        }
    }

    /// Initial multipliers: λ from the least-squares estimate (§3.6), set to
    /// zero if it is large. The eliminated positions keep W's zero rows, so
    /// their stationarity (Aᵀλ_x = 0, x being absent from the objective) is
    /// met exactly rather than in the least-squares sense.
    pub(super) fn initial_multipliers(&mut self, it: &mut Iterate) {
        let nlp = self.nlp;
        for k in 0..=nlp.n {
            let w = &mut self.ws.kkt.w[k];
            *w = [[0.0; NL]; NL];
            for (s, row) in w.iter_mut().enumerate() {
                if !self.ws.solver.eliminates(k, s) {
                    row[s] = 1.0;
                }
            }
            self.ws.kkt.h_t[k] = [0.0; NL];
            if k < nlp.n {
                let d = &self.ws.derivs[k];
                let half_tf = 0.5 * nlp.tf_s(&it.w);
                for r in 0..NS {
                    for c in 0..NL {
                        self.ws.kkt.b[k][r][c] = -half_tf * d.jac[r][c];
                    }
                    self.ws.kkt.j_t[k][r] = -0.5 * nlp.tf_scale * d.f[r];
                }
            }
        }
        self.ws.kkt.h_tt = 1.0;
        self.ws.kkt.delta_c = 0.0;
        let inertia = self.factor_with(0.0, 0.0, 1.0);
        if self.correct_inertia(inertia) {
            nlp.objective_gradient(&it.w, &mut self.ws.grad);
            for j in 0..it.w.len() {
                let g = self.ws.grad[j];
                self.ws.rw[j] = if self.bounds.free[j] {
                    -(g - it.zl[j] + it.zu[j])
                } else {
                    0.0
                };
            }
            self.ws.rl.iter_mut().for_each(|v| *v = 0.0);
            let ws = &mut self.ws;
            ws.solver
                .solve(nlp, &ws.kkt, &ws.rw, &ws.rl, &mut ws.dw, &mut ws.dl);
            if inf_norm(&ws.dl) <= 1e3 {
                it.lambda.copy_from_slice(&ws.dl);
                return;
            }
        }
        it.lambda.iter_mut().for_each(|v| *v = 0.0);
    }

    /// Average complementarity sᵀz/n of the iterate, or of the iterate moved
    /// by (α_p·dw, α_d·dz) when `step` is given; and the pair count.
    pub(super) fn complementarity(&self, it: &Iterate, step: Option<(f64, f64)>) -> (f64, usize) {
        let b = &self.bounds;
        let (mut sum, mut count) = (0.0, 0usize);
        let (ap, ad) = step.unwrap_or((0.0, 0.0));
        for j in 0..it.w.len() {
            let dw = self.ws.dw[j];
            if b.has_lo[j] {
                let s = it.w[j] - b.lo[j] + ap * dw;
                sum += s * (it.zl[j] + ad * self.ws.dzl[j]);
                count += 1;
            }
            if b.has_hi[j] {
                let s = b.hi[j] - it.w[j] - ap * dw;
                sum += s * (it.zu[j] + ad * self.ws.dzu[j]);
                count += 1;
            }
        }
        let (rows_sum, rows_count) =
            self.rows
                .complementarity(self.nlp, &it.zr, &self.ws.dw, &self.dzr, (ap, ad));
        let (sum, count) = (sum + rows_sum, count + rows_count);
        (sum / count.max(1) as f64, count)
    }

    /// Bound-multiplier step dz from dw (Eq. 13) at barrier `mu` into `dzl`,
    /// `dzu`, and its largest step α_z at fraction to the boundary `tau`
    /// (μ = 0, τ = 1 for Mehrotra's affine probe).
    pub(super) fn dual_step(
        &self,
        it: &Iterate,
        dw: &[f64],
        dzl: &mut [f64],
        dzu: &mut [f64],
        dzr: &mut [f64],
        (mu, tau): (f64, f64),
    ) -> f64 {
        let b = &self.bounds;
        let n = it.w.len();
        let mut a = self.rows.dual_step(self.nlp, &it.zr, dw, dzr, (mu, tau));
        for j in 0..n {
            if b.has_lo[j] {
                let s = it.w[j] - b.lo[j];
                dzl[j] = mu / s - it.zl[j] - it.zl[j] / s * dw[j];
                if dzl[j] < 0.0 {
                    a = a.min(-tau * it.zl[j] / dzl[j]);
                }
            }
            if b.has_hi[j] {
                let s = b.hi[j] - it.w[j];
                dzu[j] = mu / s - it.zu[j] + it.zu[j] / s * dw[j];
                if dzu[j] < 0.0 {
                    a = a.min(-tau * it.zu[j] / dzu[j]);
                }
            }
        }
        a
    }

    /// Accept the trial point: primal and λ by α, bound multipliers by α_z,
    /// then the safeguard of Eq. 16, at barrier `mu` and fraction to the
    /// boundary `tau`.
    pub(super) fn accept(
        &mut self,
        it: &mut Iterate,
        alpha: f64,
        dw: &[f64],
        dl: &[f64],
        (mu, tau): (f64, f64),
    ) {
        let (mut dzl, mut dzu, mut dzr) = (
            std::mem::take(&mut self.ws.dzl),
            std::mem::take(&mut self.ws.dzu),
            std::mem::take(&mut self.dzr),
        );
        let az = self.dual_step(it, dw, &mut dzl, &mut dzu, &mut dzr, (mu, tau));
        for j in 0..it.w.len() {
            it.w[j] += alpha * dw[j];
        }
        for (l, d) in it.lambda.iter_mut().zip(dl) {
            *l += alpha * d;
        }
        let b = &self.bounds;
        for j in 0..it.w.len() {
            if b.has_lo[j] {
                let s = it.w[j] - b.lo[j];
                let z = it.zl[j] + az * dzl[j];
                it.zl[j] = z.clamp(mu / (KAPPA_SIGMA * s), KAPPA_SIGMA * mu / s);
            }
            if b.has_hi[j] {
                let s = b.hi[j] - it.w[j];
                let z = it.zu[j] + az * dzu[j];
                it.zu[j] = z.clamp(mu / (KAPPA_SIGMA * s), KAPPA_SIGMA * mu / s);
            }
        }
        self.rows
            .accept(self.nlp, &it.w, &mut it.zr, &dzr, (az, mu, KAPPA_SIGMA));
        self.ws.dzl = dzl;
        self.ws.dzu = dzu;
        self.dzr = dzr;
    }

    /// θ and φ_μ at w + α·d (in ws.trial, ws.c_trial).
    pub(super) fn trial_point(&mut self, w: &[f64], d: &[f64], alpha: f64, mu: f64) -> (f64, f64) {
        for j in 0..w.len() {
            self.ws.trial[j] = w[j] + alpha * d[j];
        }
        let trial = std::mem::take(&mut self.ws.trial);
        self.nlp.defects(&trial, &mut self.ws.c_trial);
        let phi = self.phi(&trial, mu);
        self.ws.trial = trial;
        (l1_norm(&self.ws.c_trial), phi)
    }
}
