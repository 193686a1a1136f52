//! The direct method: a primal–dual interior-point method on the nonlinear
//! program P2 ([`crate::method::direct::nlp`]), after Wächter & Biegler, "On the
//! implementation of an interior-point filter line-search algorithm for
//! large-scale nonlinear programming", Math. Prog. 106 (2006) — IPOPT's
//! published algorithm, restricted to what P2 needs: equality constraints
//! (the defects) and simple bounds.
//!
//! - Barrier subproblems min φ_μ(w) = f(w) − μ Σ ln(w − l) − μ Σ ln(u − w)
//!   s.t. c(w) = 0, with the monotone μ update of §3.1 (Eq. 7).
//! - Newton steps on the primal–dual equations (Eq. 11–13), solved by the
//!   structured KKT solve of [`crate::method::direct::kkt`]; inertia correction (§3.1.1)
//!   regularizes each indefinite node block until the system has the
//!   inertia of a descent direction.
//! - The filter line search of §2.3 with second-order corrections (§2.4).
//! - A feasibility restoration (§3.3, simplified to regularized
//!   Gauss–Newton steps on ‖c‖ inside the bounds); when it cannot reduce
//!   the infeasibility the problem is reported locally infeasible.
//!
//! The driver is [`solve_nlp`]; each iteration is reported to an
//! [`Observer`] as a [`DirectIteration`].

#![allow(clippy::needless_range_loop)] // Dense block algebra indexes several arrays by one index.

pub mod kkt;
pub mod nlp;
pub mod solver;

use std::time::Instant;

use crate::input::settings::SolverSettings;
pub use crate::input::settings::{DirectSettings, MuStrategy};
use crate::method::direct::kkt::{Inertia, KktMatrix, KktSolver};
pub use crate::method::direct::nlp::Duals;
use crate::method::direct::nlp::{Nlp, PointDerivatives, NL, NS};
use crate::method::observer::Observer;
pub use crate::solution::DirectIteration;
use crate::solution::Status;

/// μ_0 of the fine solve after a coarse start, and of warm starts.
pub const WARM_MU: f64 = 1e-4;

/// The answer of [`solve_nlp`]: the last iterate (scaled) and how it ended.
#[derive(Debug, Clone)]
pub struct NlpResult {
    pub w: Vec<f64>,
    pub lambda: Vec<f64>,
    /// The bound multipliers of the last iterate.
    pub zl: Vec<f64>,
    pub zu: Vec<f64>,
    pub status: Status,
    pub message: String,
    pub history: Vec<DirectIteration>,
    /// Largest |defect| of `w` (scaled).
    pub max_defect: f64,
}

// Constants of Wächter & Biegler (2006), Table 1 and §3, at IPOPT's defaults.
const KAPPA_EPS: f64 = 10.0;
const KAPPA_MU: f64 = 0.2;
const THETA_MU: f64 = 1.5;
const TAU_MIN: f64 = 0.99;
const KAPPA_SIGMA: f64 = 1e10;
const S_MAX: f64 = 100.0;
const GAMMA_THETA: f64 = 1e-5;
const GAMMA_PHI: f64 = 1e-8;
const DELTA_SWITCH: f64 = 1.0;
const S_THETA: f64 = 1.1;
const S_PHI: f64 = 2.3;
const ETA_PHI: f64 = 1e-8;
const GAMMA_ALPHA: f64 = 0.05;
const MAX_SOC: usize = 4;
/// Filter entries reserved at setup.
const FILTER_CAPACITY: usize = 256;
const KAPPA_SOC: f64 = 0.99;
const BOUND_PUSH: f64 = 1e-2;
/// The bound push of a primal–dual warm start ([`solve_nlp_warm`]): small,
/// so that the controls on their bounds stay there (IPOPT's
/// `warm_start_bound_push` plays this part).
const WARM_BOUND_PUSH: f64 = 1e-8;
/// Inertia correction (§3.1.1): first trial, growth and decrease factors.
const DELTA_W_FIRST: f64 = 1e-4;
const DELTA_W_MIN: f64 = 1e-20;
const DELTA_W_MAX: f64 = 1e40;
const KAPPA_W_MINUS: f64 = 1.0 / 3.0;
const KAPPA_W_PLUS: f64 = 8.0;
const KAPPA_W_PLUS_FIRST: f64 = 100.0;
/// Static regularization of every node block (scaled units). The free
/// variable w enters the problem linearly and has no bounds, so its rows of
/// W are zero; 1e-9 keeps the blocks factorable without counting as an
/// inertia correction, and iterative refinement removes its effect on the
/// step. (x is linear too, but the KKT solve eliminates it exactly.)
const DELTA_STATIC: f64 = 1e-9;
/// Dual regularization δ_c = 1e-8·μ^{1/4} when S is singular.
const DELTA_C: f64 = 1e-8;
/// Iterative refinement stops once the residual is this fraction of the right-hand side.
const REFINE_TOL: f64 = 1e-12;
/// Adaptive μ: iterations over which E_0 must fall by 0.01 %.
pub const ADAPTIVE_WINDOW: usize = 4;
const ADAPTIVE_DECREASE: f64 = 0.9999;
/// Restoration: iterations, and the factor by which it must reduce θ.
const RESTORATION_ITERATIONS: usize = 40;
const RESTORATION_REDUCTION: f64 = 0.9;

/// Scratch of one solve.
struct Workspace {
    kkt: KktMatrix,
    solver: KktSolver,
    derivs: Vec<PointDerivatives>,
    jac: Vec<[[f64; NL]; NS]>,
    c: Vec<f64>,
    c_trial: Vec<f64>,
    grad: Vec<f64>,
    rw: Vec<f64>,
    rl: Vec<f64>,
    dw: Vec<f64>,
    dl: Vec<f64>,
    res_w: Vec<f64>,
    res_l: Vec<f64>,
    cor_w: Vec<f64>,
    cor_l: Vec<f64>,
    trial: Vec<f64>,
    /// The iterate before the step, the Newton step, the bound-multiplier
    /// steps and the corrected constraint values of the SOC: kept here so
    /// that an iteration allocates nothing.
    w_old: Vec<f64>,
    step_w: Vec<f64>,
    step_l: Vec<f64>,
    dzl: Vec<f64>,
    dzu: Vec<f64>,
    c_soc: Vec<f64>,
}

/// The primal–dual iterate.
struct Iterate {
    w: Vec<f64>,
    lambda: Vec<f64>,
    zl: Vec<f64>,
    zu: Vec<f64>,
}

/// Which bounds each variable has (fixed variables have neither).
struct Bounds {
    lo: Vec<f64>,
    hi: Vec<f64>,
    has_lo: Vec<bool>,
    has_hi: Vec<bool>,
    free: Vec<bool>,
}

impl Bounds {
    fn new(nlp: &Nlp) -> Self {
        let n = nlp.n_var();
        let free: Vec<bool> = (0..n).map(|j| !nlp.is_fixed(j)).collect();
        Bounds {
            has_lo: (0..n).map(|j| free[j] && nlp.lo[j].is_finite()).collect(),
            has_hi: (0..n).map(|j| free[j] && nlp.hi[j].is_finite()).collect(),
            lo: nlp.lo.clone(),
            hi: nlp.hi.clone(),
            free,
        }
    }

    /// Push a point strictly inside the bounds by `push` (relative, §3.6)
    /// and set fixed values.
    fn push_inside(&self, w: &mut [f64], push: f64) {
        for j in 0..w.len() {
            if !self.free[j] {
                w[j] = self.lo[j];
                continue;
            }
            let (l, u) = (self.lo[j], self.hi[j]);
            let gap = if self.has_lo[j] && self.has_hi[j] {
                u - l
            } else {
                f64::INFINITY
            };
            if self.has_lo[j] {
                let p = (push * l.abs().max(1.0)).min(push * gap);
                w[j] = w[j].max(l + p);
            }
            if self.has_hi[j] {
                let p = (push * u.abs().max(1.0)).min(push * gap);
                w[j] = w[j].min(u - p);
            }
        }
    }

    /// The barrier term −μ Σ ln(slack) of φ_μ.
    fn barrier(&self, w: &[f64], mu: f64) -> f64 {
        let mut b = 0.0;
        for j in 0..w.len() {
            if self.has_lo[j] {
                b -= mu * (w[j] - self.lo[j]).ln();
            }
            if self.has_hi[j] {
                b -= mu * (self.hi[j] - w[j]).ln();
            }
        }
        b
    }

    /// Largest α ≤ 1 with w + α·dw keeping a fraction τ of each slack.
    fn max_step(&self, w: &[f64], dw: &[f64], tau: f64) -> f64 {
        let mut a = 1.0f64;
        for j in 0..w.len() {
            if self.has_lo[j] && dw[j] < 0.0 {
                a = a.min(-tau * (w[j] - self.lo[j]) / dw[j]);
            }
            if self.has_hi[j] && dw[j] > 0.0 {
                a = a.min(tau * (self.hi[j] - w[j]) / dw[j]);
            }
        }
        a
    }
}

fn inf_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn l1_norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x.abs()).sum()
}

/// Solve P2 from the scaled point `w0` (pushed inside its bounds).
pub fn solve_nlp(
    nlp: &Nlp,
    w0: &[f64],
    lambda0: Option<&[f64]>,
    settings: &DirectSettings,
    observer: &mut dyn Observer,
) -> NlpResult {
    Driver::new(nlp, settings).run(Start::Primal(w0, lambda0), observer)
}

/// Solve P2 from a primal–dual point: `w0` pushed only [`WARM_BOUND_PUSH`]
/// inside its bounds, the defect multipliers of `duals`, and each bound
/// multiplier at least μ_0/s (s: the slack), so that no pair starts far
/// below the barrier's complementarity. For the passes of mesh refinement,
/// whose starts are the last pass's answer and multipliers carried onto a
/// finer mesh ([`crate::method::direct::nlp::Nlp::interpolate_duals_from`]).
pub fn solve_nlp_warm(
    nlp: &Nlp,
    w0: &[f64],
    duals: &Duals,
    settings: &DirectSettings,
    observer: &mut dyn Observer,
) -> NlpResult {
    Driver::new(nlp, settings).run(Start::PrimalDual(w0, duals), observer)
}

/// Filter entries (θ, φ) (§2.3).
struct Filter(Vec<(f64, f64)>);

impl Filter {
    fn acceptable(&self, theta: f64, phi: f64) -> bool {
        self.0.iter().all(|&(t, p)| theta < t || phi < p)
    }
    fn add(&mut self, theta: f64, phi: f64) {
        self.0.retain(|&(t, p)| t < theta || p < phi);
        self.0.push((theta, phi));
    }
}

/// How a line search ended.
enum LineSearch {
    Accepted {
        alpha: f64,
        trials: usize,
        f_type: bool,
    },
    Failed,
}

struct Driver<'a> {
    nlp: &'a Nlp,
    settings: &'a DirectSettings,
    bounds: Bounds,
    ws: Workspace,
    mu: f64,
    tau: f64,
    filter: Filter,
    theta_max: f64,
    theta_min: f64,
    delta_c: f64,
    /// δ_w of the last factorization (0: none needed) and the last nonzero one.
    inertia: f64,
    delta_w_last: f64,
    /// Free primal variables (with t̂_f).
    n_primal: usize,
    /// Whether μ follows the adaptive rule (until it falls back).
    adaptive: bool,
    /// E_0 at the iterations of the adaptive mode, for its progress test.
    e0_history: Vec<f64>,
}

impl<'a> Driver<'a> {
    fn new(nlp: &'a Nlp, settings: &'a DirectSettings) -> Self {
        let (nv, nc) = (nlp.n_var(), nlp.n_con());
        let ws = Workspace {
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
            jac: vec![[[0.0; NL]; NS]; nlp.n],
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
        };
        Driver {
            nlp,
            settings,
            bounds: Bounds::new(nlp),
            ws,
            mu: settings.mu_init,
            tau: TAU_MIN.max(1.0 - settings.mu_init),
            // Room for the entries of a barrier subproblem: no growth in an iteration.
            filter: Filter(Vec::with_capacity(FILTER_CAPACITY)),
            theta_max: 0.0,
            theta_min: 0.0,
            delta_c: 0.0,
            inertia: 0.0,
            delta_w_last: 0.0,
            n_primal: (0..nv).filter(|&j| !nlp.is_fixed(j)).count(),
            adaptive: settings.mu_strategy == MuStrategy::Adaptive,
            e0_history: Vec::with_capacity(settings.max_iterations),
        }
    }

    fn final_mass_kg(&self, w: &[f64]) -> f64 {
        let k = self
            .nlp
            .idx(self.nlp.n, crate::method::direct::nlp::slot::M);
        self.nlp.physical(crate::method::direct::nlp::slot::M, w[k])
    }

    /// φ_μ(w) = f(w) + barrier.
    fn phi(&self, w: &[f64]) -> f64 {
        self.nlp.objective(w) + self.bounds.barrier(w, self.mu)
    }

    /// Derivatives at every collocation point, with multipliers λ.
    fn evaluate(&mut self, w: &[f64], lambda: &[f64]) {
        for i in 0..self.nlp.n {
            let d = self
                .nlp
                .point_derivatives(w, i, &lambda[i * NS..(i + 1) * NS]);
            self.ws.jac[i] = d.jac;
            self.ws.derivs[i] = d;
        }
        self.nlp.defects(w, &mut self.ws.c);
    }

    /// ∇f + Jᵀλ into ws.grad (without the bound multipliers).
    fn lagrangian_gradient(&mut self, w: &[f64], lambda: &[f64]) {
        self.nlp.objective_gradient(w, &mut self.ws.grad);
        self.nlp
            .add_jt_lambda(w, &self.ws.jac, lambda, &mut self.ws.grad);
    }

    /// Optimality error E_μ (Eq. 5) of the iterate; ws.grad must hold ∇f + Jᵀλ.
    fn optimality_error(&self, it: &Iterate, mu: f64) -> (f64, f64, f64) {
        let b = &self.bounds;
        let (mut dual, mut compl) = (0.0f64, 0.0f64);
        let mut z_sum = 0.0;
        let mut n_free = 0usize;
        for j in 0..it.w.len() {
            if !b.free[j] {
                continue;
            }
            n_free += 1;
            dual = dual.max((self.ws.grad[j] - it.zl[j] + it.zu[j]).abs());
            if b.has_lo[j] {
                compl = compl.max(((it.w[j] - b.lo[j]) * it.zl[j] - mu).abs());
                z_sum += it.zl[j];
            }
            if b.has_hi[j] {
                compl = compl.max(((b.hi[j] - it.w[j]) * it.zu[j] - mu).abs());
                z_sum += it.zu[j];
            }
        }
        let m = it.lambda.len();
        let s_d = (S_MAX.max((l1_norm(&it.lambda) + z_sum) / (m + n_free) as f64)) / S_MAX;
        let s_c = (S_MAX.max(z_sum / n_free as f64)) / S_MAX;
        let primal = inf_norm(&self.ws.c);
        let dual = dual / s_d;
        (dual.max(primal).max(compl / s_c), primal, dual)
    }

    /// Fill the KKT blocks at the iterate: W = ∇²L + Σ, with the
    /// regularization added at factorization.
    fn build_kkt(&mut self, it: &Iterate) {
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
    }

    /// Factor K with W + δ_w I and δ_c; its inertia.
    fn factor_with(&mut self, delta_w: f64, delta_c: f64, h_tt: f64) -> Inertia {
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
    fn correct_inertia(&self, i: Inertia) -> bool {
        i.zero == 0 && i.positive == self.n_primal && i.negative == self.nlp.n_con()
    }

    /// Inertia-correcting factorization (§3.1.1, Algorithm IC): the smallest
    /// δ_w of IPOPT's schedule with which K has the inertia (n, m, 0), and
    /// δ_c > 0 once K is singular.
    fn factor(&mut self) -> Result<(), String> {
        let h_tt = self.ws.kkt.h_tt;
        // After an iteration that needed a correction, start from a third of
        // it instead of from 0 (which would almost surely fail again and cost
        // a factorization).
        let mut delta_w = if self.inertia > 0.0 {
            (KAPPA_W_MINUS * self.delta_w_last).max(DELTA_W_MIN)
        } else {
            0.0
        };
        let mut delta_c = 0.0;
        loop {
            let inertia = self.factor_with(delta_w, delta_c, h_tt);
            if self.correct_inertia(inertia) {
                break;
            }
            if inertia.zero > 0 && delta_c == 0.0 {
                delta_c = DELTA_C * self.mu.powf(0.25);
                continue;
            }
            delta_w = if delta_w == 0.0 {
                if self.delta_w_last == 0.0 {
                    DELTA_W_FIRST
                } else {
                    (KAPPA_W_MINUS * self.delta_w_last).max(DELTA_W_MIN)
                }
            } else if self.delta_w_last == 0.0 {
                KAPPA_W_PLUS_FIRST * delta_w
            } else {
                KAPPA_W_PLUS * delta_w
            };
            if delta_w > DELTA_W_MAX {
                return Err(
                    "the Newton system cannot be regularized to the inertia of a descent direction"
                        .into(),
                );
            }
        }
        if delta_w > 0.0 {
            self.delta_w_last = delta_w;
            // Keep the system consistent with its factors for refinement
            // (the eliminated positions take no correction: x is fixed by
            // its defects, so δ_w on it would not change the reduced Hessian).
            for (k, w) in self.ws.kkt.w.iter_mut().enumerate() {
                for (s, row) in w.iter_mut().enumerate() {
                    if !self.ws.solver.eliminates(k, s) {
                        row[s] += delta_w;
                    }
                }
            }
        }
        self.inertia = delta_w;
        self.delta_c = delta_c;
        Ok(())
    }

    /// Solve K d = r with two steps of iterative refinement against the
    /// system without the static regularization.
    fn solve_kkt(&mut self) {
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
    fn newton_rhs(&mut self, it: &Iterate) {
        let b = &self.bounds;
        for j in 0..it.w.len() {
            let mut g = self.ws.grad[j];
            if b.has_lo[j] {
                g -= self.mu / (it.w[j] - b.lo[j]);
            }
            if b.has_hi[j] {
                g += self.mu / (b.hi[j] - it.w[j]);
            }
            self.ws.rw[j] = if b.free[j] { -g } else { 0.0 };
        }
        for (r, c) in self.ws.rl.iter_mut().zip(&self.ws.c) {
            *r = -c;
        }
    }

    /// Initial multipliers: λ from the least-squares estimate (§3.6), set to
    /// zero if it is large. The eliminated positions keep W's zero rows, so
    /// their stationarity (Aᵀλ_x = 0, x being absent from the objective) is
    /// met exactly rather than in the least-squares sense.
    fn initial_multipliers(&mut self, it: &mut Iterate) {
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

    fn run(mut self, start: Start, observer: &mut dyn Observer) -> NlpResult {
        let nlp = self.nlp;
        let (nv, nc) = (nlp.n_var(), nlp.n_con());
        let (w0, lambda0, warm) = match start {
            Start::Primal(w0, lambda0) => (w0, lambda0, None),
            Start::PrimalDual(w0, duals) => (w0, Some(&duals.lambda[..]), Some(duals)),
        };
        let mut w = w0.to_vec();
        let push = if warm.is_some() {
            WARM_BOUND_PUSH
        } else {
            BOUND_PUSH
        };
        self.bounds.push_inside(&mut w, push);
        let b = &self.bounds;
        let mu0 = self.mu;
        // Cold: z = 1 (§3.6). Warm: the given z, at least μ_0/s.
        let start_z = |j: usize, has: bool, slack: f64, given: Option<&Vec<f64>>| {
            if !has {
                return 0.0;
            }
            match given {
                Some(z) if z.len() == nv => z[j].max(mu0 / slack),
                _ => 1.0,
            }
        };
        let zl = (0..nv)
            .map(|j| start_z(j, b.has_lo[j], w[j] - b.lo[j], warm.map(|d| &d.zl)))
            .collect();
        let zu = (0..nv)
            .map(|j| start_z(j, b.has_hi[j], b.hi[j] - w[j], warm.map(|d| &d.zu)))
            .collect();
        let mut it = Iterate {
            w,
            lambda: vec![0.0; nc],
            zl,
            zu,
        };
        self.evaluate(&it.w, &it.lambda);
        match lambda0 {
            Some(l) if l.len() == nc => it.lambda.copy_from_slice(l),
            _ => self.initial_multipliers(&mut it),
        }
        let theta0 = l1_norm(&self.ws.c);
        self.theta_max = 1e4 * theta0.max(1.0);
        self.theta_min = 1e-4 * theta0.max(1.0);
        let mut history = Vec::with_capacity(self.settings.max_iterations);
        let tol = self.settings.tolerance;
        let mut outcome: Option<(Status, String)> = None;

        for iteration in 1..=self.settings.max_iterations {
            let t0 = Instant::now();
            self.evaluate(&it.w, &it.lambda);
            self.lagrangian_gradient(&it.w, &it.lambda);
            self.ws.w_old.copy_from_slice(&it.w);
            let (e0, primal, dual) = self.optimality_error(&it, 0.0);
            if !(e0.is_finite()) {
                outcome = Some((
                    Status::SolverFailed,
                    "the iterate is no longer finite".to_string(),
                ));
                break;
            }
            if e0 <= tol {
                outcome = Some((Status::Solved, String::new()));
                break;
            }
            if self.adaptive && !self.adaptive_progress(e0) {
                self.leave_adaptive_mode(&it);
            }
            if !self.adaptive {
                // Monotone barrier update (§3.1, Eq. 7), possibly several times.
                while self.optimality_error(&it, self.mu).0 <= KAPPA_EPS * self.mu
                    && self.mu > tol / 10.0
                {
                    self.mu = (tol / 10.0).max((KAPPA_MU * self.mu).min(self.mu.powf(THETA_MU)));
                    self.tau = TAU_MIN.max(1.0 - self.mu);
                    self.filter.0.clear();
                }
            }
            self.build_kkt(&it);
            if let Err(msg) = self.factor() {
                outcome = Some((Status::SolverFailed, msg));
                break;
            }
            if self.adaptive {
                self.mu = self.probe_mu(&it);
                self.tau = TAU_MIN.max(1.0 - self.mu);
                self.filter.0.clear();
            }
            self.newton_rhs(&it);
            self.solve_kkt();
            let (step, trials, restoration) = match self.line_search(&mut it) {
                LineSearch::Accepted {
                    alpha,
                    trials,
                    f_type,
                } => {
                    if !f_type {
                        let theta = l1_norm(&self.ws.c);
                        let phi = self.phi(&self.ws.w_old);
                        self.filter
                            .add((1.0 - GAMMA_THETA) * theta, phi - GAMMA_PHI * theta);
                    }
                    (alpha, trials, false)
                }
                LineSearch::Failed if self.adaptive => {
                    // No restoration in the adaptive mode: fall back and retry.
                    self.leave_adaptive_mode(&it);
                    (0.0, 0, false)
                }
                LineSearch::Failed => match self.restore(&mut it) {
                    Ok(()) => (0.0, 0, true),
                    Err(msg) => {
                        outcome = Some((Status::Infeasible, msg));
                        break;
                    }
                },
            };
            let record = DirectIteration {
                iteration,
                mesh_nodes: self.nlp.n,
                final_mass_kg: self.final_mass_kg(&it.w),
                primal_infeasibility: primal,
                dual_infeasibility: dual,
                mu: self.mu,
                step,
                inertia_correction: self.inertia,
                line_search_trials: trials,
                restoration,
                ms: t0.elapsed().as_secs_f64() * 1e3,
            };
            observer.on_direct_iteration(&record);
            history.push(record);
        }
        let (status, message) = outcome.unwrap_or((
            Status::NotConverged,
            format!(
                "no convergence in {} interior-point iterations; the last iterate is returned",
                self.settings.max_iterations
            ),
        ));
        self.nlp.defects(&it.w, &mut self.ws.c);
        NlpResult {
            max_defect: inf_norm(&self.ws.c),
            w: it.w,
            lambda: it.lambda,
            zl: it.zl,
            zu: it.zu,
            status,
            message,
            history,
        }
    }

    /// Whether the adaptive mode still makes progress: E_0 fell by
    /// [`ADAPTIVE_DECREASE`] against its value [`ADAPTIVE_WINDOW`] iterations ago.
    fn adaptive_progress(&mut self, e0: f64) -> bool {
        self.e0_history.push(e0);
        let n = self.e0_history.len();
        n <= ADAPTIVE_WINDOW || e0 <= ADAPTIVE_DECREASE * self.e0_history[n - 1 - ADAPTIVE_WINDOW]
    }

    /// Switch to the monotone rule for the rest of the solve, at μ = κ_μ
    /// times the average complementarity.
    fn leave_adaptive_mode(&mut self, it: &Iterate) {
        self.adaptive = false;
        let (avg, _) = self.complementarity(it, None);
        self.mu = (KAPPA_MU * avg).max(self.settings.tolerance / 10.0);
        self.tau = TAU_MIN.max(1.0 - self.mu);
        self.filter.0.clear();
    }

    /// Average complementarity sᵀz/n of the iterate, or of the iterate moved
    /// by (α_p·dw, α_d·dz) when `step` is given; and the pair count.
    fn complementarity(&self, it: &Iterate, step: Option<(f64, f64)>) -> (f64, usize) {
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
        (sum / count.max(1) as f64, count)
    }

    /// Mehrotra's probe: the affine-scaling step (μ = 0) with the current
    /// factors, its complementarity μ_aff, and μ = σ·avg with
    /// σ = (μ_aff/avg)³.
    fn probe_mu(&mut self, it: &Iterate) -> f64 {
        let mu = self.mu;
        self.mu = 0.0;
        self.newton_rhs(it);
        self.solve_kkt();
        let (mut dzl, mut dzu) = (
            std::mem::take(&mut self.ws.dzl),
            std::mem::take(&mut self.ws.dzu),
        );
        let dw = std::mem::take(&mut self.ws.dw);
        let ad = self.dual_step(it, &dw, &mut dzl, &mut dzu, (0.0, 1.0));
        let ap = self.bounds.max_step(&it.w, &dw, 1.0);
        (self.ws.dzl, self.ws.dzu, self.ws.dw) = (dzl, dzu, dw);
        self.mu = mu;
        let (avg, _) = self.complementarity(it, None);
        let (aff, _) = self.complementarity(it, Some((ap, ad)));
        let sigma = (aff / avg).clamp(0.0, 1.0).powi(3);
        (sigma * avg).clamp(self.settings.tolerance / 10.0, 1e3)
    }

    /// Bound-multiplier step dz from dw (Eq. 13) at barrier `mu` into `dzl`,
    /// `dzu`, and its largest step α_z at fraction to the boundary `tau`
    /// (μ = 0, τ = 1 for Mehrotra's affine probe).
    fn dual_step(
        &self,
        it: &Iterate,
        dw: &[f64],
        dzl: &mut [f64],
        dzu: &mut [f64],
        (mu, tau): (f64, f64),
    ) -> f64 {
        let b = &self.bounds;
        let n = it.w.len();
        let mut a = 1.0f64;
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
    /// then the safeguard of Eq. 16.
    fn accept(&mut self, it: &mut Iterate, alpha: f64, dw: &[f64], dl: &[f64]) {
        let (mut dzl, mut dzu) = (
            std::mem::take(&mut self.ws.dzl),
            std::mem::take(&mut self.ws.dzu),
        );
        let az = self.dual_step(it, dw, &mut dzl, &mut dzu, (self.mu, self.tau));
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
                it.zl[j] = z.clamp(self.mu / (KAPPA_SIGMA * s), KAPPA_SIGMA * self.mu / s);
            }
            if b.has_hi[j] {
                let s = b.hi[j] - it.w[j];
                let z = it.zu[j] + az * dzu[j];
                it.zu[j] = z.clamp(self.mu / (KAPPA_SIGMA * s), KAPPA_SIGMA * self.mu / s);
            }
        }
        self.ws.dzl = dzl;
        self.ws.dzu = dzu;
    }

    /// θ and φ_μ at w + α·d (in ws.trial, ws.c_trial).
    fn trial_point(&mut self, w: &[f64], d: &[f64], alpha: f64) -> (f64, f64) {
        for j in 0..w.len() {
            self.ws.trial[j] = w[j] + alpha * d[j];
        }
        let trial = std::mem::take(&mut self.ws.trial);
        self.nlp.defects(&trial, &mut self.ws.c_trial);
        let phi = self.phi(&trial);
        self.ws.trial = trial;
        (l1_norm(&self.ws.c_trial), phi)
    }

    /// The acceptance tests of §2.3 for a trial point.
    fn acceptable(
        &self,
        theta0: f64,
        phi0: f64,
        m_phi: f64,
        alpha: f64,
        theta: f64,
        phi: f64,
    ) -> Option<bool> {
        if !theta.is_finite() || !phi.is_finite() || theta > self.theta_max {
            return None;
        }
        if !self.filter.acceptable(theta, phi) {
            return None;
        }
        let switching = m_phi < 0.0
            && alpha * (-m_phi).powf(S_PHI) > DELTA_SWITCH * theta0.powf(S_THETA)
            && theta0 <= self.theta_min;
        if switching {
            (phi <= phi0 + ETA_PHI * alpha * m_phi).then_some(true)
        } else {
            (theta <= (1.0 - GAMMA_THETA) * theta0 || phi <= phi0 - GAMMA_PHI * theta0)
                .then_some(false)
        }
    }

    /// The backtracking filter line search with second-order corrections.
    fn line_search(&mut self, it: &mut Iterate) -> LineSearch {
        // The Newton step, kept apart (the SOC overwrites ws.dw, ws.dl).
        let (mut dw, mut dl) = (
            std::mem::take(&mut self.ws.step_w),
            std::mem::take(&mut self.ws.step_l),
        );
        dw.copy_from_slice(&self.ws.dw);
        dl.copy_from_slice(&self.ws.dl);
        let w = std::mem::take(&mut self.ws.w_old);
        let out = self.backtrack(it, &w, &dw, &dl);
        (self.ws.step_w, self.ws.step_l, self.ws.w_old) = (dw, dl, w);
        out
    }

    fn backtrack(&mut self, it: &mut Iterate, w: &[f64], dw: &[f64], dl: &[f64]) -> LineSearch {
        let theta0 = l1_norm(&self.ws.c);
        let phi0 = self.phi(w);
        // ∇φ_μᵀ dw = −rwᵀ dw.
        let m_phi: f64 = -self.ws.rw.iter().zip(dw).map(|(a, b)| a * b).sum::<f64>();
        let alpha_min = if m_phi < 0.0 {
            GAMMA_ALPHA
                * GAMMA_THETA
                    .min(GAMMA_PHI * theta0 / -m_phi)
                    .min(DELTA_SWITCH * theta0.powf(S_THETA) / (-m_phi).powf(S_PHI))
        } else {
            GAMMA_ALPHA * GAMMA_THETA
        };
        let mut alpha = self.bounds.max_step(w, dw, self.tau);
        let mut trials = 0;
        loop {
            trials += 1;
            let (theta, phi) = self.trial_point(w, dw, alpha);
            if let Some(f_type) = self.acceptable(theta0, phi0, m_phi, alpha, theta, phi) {
                self.accept(it, alpha, dw, dl);
                return LineSearch::Accepted {
                    alpha,
                    trials,
                    f_type,
                };
            }
            if trials == 1 && theta >= theta0 {
                if let Some(accepted) =
                    self.second_order_correction(it, alpha, theta0, phi0, m_phi, theta, w)
                {
                    return accepted;
                }
            }
            alpha *= 0.5;
            if alpha < alpha_min {
                break;
            }
        }
        LineSearch::Failed
    }

    /// Second-order corrections of the first trial (§2.4): steps on the
    /// accumulated constraint values c_soc = α·c_soc + c(w + α d_soc).
    #[allow(clippy::too_many_arguments)]
    fn second_order_correction(
        &mut self,
        it: &mut Iterate,
        alpha: f64,
        theta0: f64,
        phi0: f64,
        m_phi: f64,
        theta_trial: f64,
        w: &[f64],
    ) -> Option<LineSearch> {
        let mut c_soc = std::mem::take(&mut self.ws.c_soc);
        for ((cs, c), t) in c_soc.iter_mut().zip(&self.ws.c).zip(&self.ws.c_trial) {
            *cs = alpha * c + t;
        }
        let mut theta_old = theta_trial;
        let mut out = None;
        for p in 0..MAX_SOC {
            for (r, c) in self.ws.rl.iter_mut().zip(&c_soc) {
                *r = -c;
            }
            self.solve_kkt();
            let (d, dl) = (
                std::mem::take(&mut self.ws.dw),
                std::mem::take(&mut self.ws.dl),
            );
            let a_soc = self.bounds.max_step(w, &d, self.tau);
            let (theta, phi) = self.trial_point(w, &d, a_soc);
            let accepted = self.acceptable(theta0, phi0, m_phi, alpha, theta, phi);
            if let Some(f_type) = accepted {
                self.accept(it, a_soc, &d, &dl);
                out = Some(LineSearch::Accepted {
                    alpha: a_soc,
                    trials: 1 + p + 1,
                    f_type,
                });
            }
            (self.ws.dw, self.ws.dl) = (d, dl);
            if out.is_some() || theta > KAPPA_SOC * theta_old {
                break;
            }
            theta_old = theta;
            for (cs, t) in c_soc.iter_mut().zip(&self.ws.c_trial) {
                *cs = a_soc * *cs + t;
            }
        }
        self.ws.c_soc = c_soc;
        out
    }

    /// Feasibility restoration: regularized Gauss–Newton steps on ½‖c‖²
    /// that keep the bounds' barrier, until θ has fallen by
    /// [`RESTORATION_REDUCTION`] and the point is acceptable to the filter.
    fn restore(&mut self, it: &mut Iterate) -> Result<(), String> {
        let nlp = self.nlp;
        let theta_start = l1_norm(&self.ws.c);
        let phi_start = self.phi(&it.w);
        self.filter.add(
            (1.0 - GAMMA_THETA) * theta_start,
            phi_start - GAMMA_PHI * theta_start,
        );
        let zeta = self.mu.sqrt();
        for _ in 0..RESTORATION_ITERATIONS {
            let (w, l) = (it.w.clone(), it.lambda.clone());
            self.evaluate(&w, &l);
            let theta0 = l1_norm(&self.ws.c);
            // W = ζ I + Σ; gradient of the barrier only.
            self.build_kkt(it);
            for k in 0..=nlp.n {
                for r in 0..NL {
                    for c in 0..NL {
                        if r != c {
                            self.ws.kkt.w[k][r][c] = 0.0;
                        }
                    }
                    self.ws.kkt.w[k][r][r] = self.ws.kkt.w[k][r][r].max(0.0) + zeta;
                }
                self.ws.kkt.h_t[k] = [0.0; NL];
            }
            self.ws.kkt.h_tt += zeta;
            if self.factor().is_err() {
                return Err("the restoration's Newton system cannot be factored".into());
            }
            let b = &self.bounds;
            for j in 0..w.len() {
                let mut g = 0.0;
                if b.has_lo[j] {
                    g -= self.mu / (w[j] - b.lo[j]);
                }
                if b.has_hi[j] {
                    g += self.mu / (b.hi[j] - w[j]);
                }
                self.ws.rw[j] = if b.free[j] { -g } else { 0.0 };
            }
            for (r, c) in self.ws.rl.iter_mut().zip(&self.ws.c) {
                *r = -c;
            }
            self.solve_kkt();
            let dw = self.ws.dw.clone();
            let mut alpha = self.bounds.max_step(&w, &dw, self.tau);
            let mut accepted = false;
            while alpha > 1e-8 {
                let (theta, _) = self.trial_point(&w, &dw, alpha);
                if theta <= (1.0 - GAMMA_THETA) * theta0 {
                    accepted = true;
                    break;
                }
                alpha *= 0.5;
            }
            if !accepted {
                return Err(format!(
                    "locally infeasible: no trajectory near this one meets the dynamics and boundary conditions; the feasibility restoration stalled at a defect of {:.2e} (scaled, summed over the collocation equations)",
                    theta0
                ));
            }
            let zero = vec![0.0; it.lambda.len()];
            self.accept(it, alpha, &dw, &zero);
            self.nlp.defects(&it.w, &mut self.ws.c);
            let theta = l1_norm(&self.ws.c);
            let phi = self.phi(&it.w);
            if theta <= RESTORATION_REDUCTION * theta_start && self.filter.acceptable(theta, phi) {
                // Fresh multipliers for the regular phase.
                let (w, l) = (it.w.clone(), it.lambda.clone());
                self.evaluate(&w, &l);
                self.initial_multipliers(it);
                return Ok(());
            }
        }
        Err(format!(
            "locally infeasible: no trajectory near this one meets the dynamics and boundary conditions; {RESTORATION_ITERATIONS} restoration iterations reduced the defect from {theta_start:.2e} to {:.2e} only",
            l1_norm(&self.ws.c)
        ))
    }
}

/// The Hessian of the Lagrangian f + λᵀc and the Jacobian of c in the
/// blocks of [`KktMatrix`] (no barrier, no regularization), from the
/// point derivatives at `w` with multipliers `lambda`.
pub fn lagrangian_blocks(
    nlp: &Nlp,
    w: &[f64],
    lambda: &[f64],
    derivs: &[PointDerivatives],
    kkt: &mut KktMatrix,
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

/// Checks of a P2 answer against the nonlinear problem: its own defects,
/// the thrust bounds at every reported value and the ground. The thrust is
/// along the nozzle by construction (gap 0, alignment 1).
pub fn checks(nlp: &Nlp, w: &[f64]) -> crate::solution::Checks {
    use crate::method::direct::nlp::slot;
    let mut c = vec![0.0; nlp.n_con()];
    nlp.defects(w, &mut c);
    let m = &nlp.model;
    let mut bound = 0.0f64;
    for i in 0..nlp.n {
        let t = nlp.thrust_n(w, i);
        bound = bound.max(m.min_thrust_n - t).max(t - m.max_thrust_n);
    }
    let z_f = nlp.xf[slot::Z];
    let min_altitude_margin_m = (0..=nlp.n)
        .map(|k| nlp.physical(slot::Z, w[nlp.idx(k, slot::Z)]) - z_f)
        .fold(f64::INFINITY, f64::min);
    crate::solution::Checks {
        relaxation_gap: 0.0,
        thrust_alignment_min: 1.0,
        thrust_bound_violation_n: bound,
        max_defect: inf_norm(&c),
        virtual_control: 0.0,
        min_altitude_margin_m,
    }
}

/// Solve a scenario with the direct method from the reference's straight
/// line (states linear in τ, T mid-range, χ = 0, the scenario's guesses).
pub fn solve(
    scenario: &crate::Scenario,
    settings: &SolverSettings,
    observer: &mut dyn Observer,
) -> crate::Solution {
    solve_keeping_duals(scenario, settings, observer).0
}

/// [`solve`], and the NLP of the scenario's mesh with the multipliers of
/// the answer on it: the start of a primal–dual warm start on another mesh
/// ([`crate::method::direct::nlp::Nlp::interpolate_duals_from`], [`solve_nlp_warm`]).
pub fn solve_keeping_duals(
    scenario: &crate::Scenario,
    settings: &SolverSettings,
    observer: &mut dyn Observer,
) -> (crate::Solution, Nlp, Duals) {
    let nlp = Nlp::new(scenario, settings);
    let d = &scenario.discretization;
    let w0 = nlp.straight_line(d.tf_guess_s, d.final_mass_guess_kg);
    let coarse_n = settings.direct.coarse_nodes;
    if coarse_n < 4 || 2 * coarse_n > d.nodes {
        let (sol, duals) =
            solve_from_start(scenario, settings, &nlp, Start::Primal(&w0, None), observer);
        return (sol, nlp, duals);
    }
    // Every phase's iterations and time are counted in the answer.
    let start = Instant::now();
    let mut spent = Vec::new();
    let mut coarse = scenario.clone();
    coarse.discretization.nodes = coarse_n;
    coarse.discretization.intervals = 1;
    coarse.discretization.mesh = None;
    let cnlp = Nlp::new(&coarse, settings);
    let cw0 = cnlp.straight_line(d.tf_guess_s, d.final_mass_guess_kg);
    let coarse_settings = DirectSettings {
        tolerance: settings.direct.coarse_tolerance,
        ..settings.direct.clone()
    };
    let mut first = solve_nlp(&cnlp, &cw0, None, &coarse_settings, observer);
    spent.append(&mut first.history);
    let max_iterations = settings.direct.max_iterations;
    let mut budget = settings.clone();
    budget.direct.max_iterations = max_iterations.saturating_sub(spent.len());
    let warm = interpolate(&cnlp, &first.w, &nlp);
    if budget.direct.max_iterations > 0 && first.status == Status::Solved {
        let mut fine = budget.clone();
        fine.direct.mu_init = WARM_MU;
        let (mut sol, duals) =
            solve_from_start(scenario, &fine, &nlp, Start::Primal(&warm, None), observer);
        spent.append(&mut sol.direct_history);
        if sol.status == Status::Solved {
            return (with_phases(sol, spent, start), nlp, duals);
        }
        budget.direct.max_iterations = max_iterations.saturating_sub(spent.len());
    }
    if budget.direct.max_iterations == 0 {
        // The limit was spent on the coarse phase: its last iterate, carried
        // onto the scenario's mesh, not iterated there.
        let (mut sol, duals) = solve_from_start(
            scenario,
            &budget,
            &nlp,
            Start::Primal(&warm, None),
            observer,
        );
        sol.status = Status::NotConverged;
        sol.message = format!(
            "no convergence in {max_iterations} interior-point iterations (coarse start included); the last iterate is returned"
        );
        return (with_phases(sol, spent, start), nlp, duals);
    }
    let (mut sol, duals) =
        solve_from_start(scenario, &budget, &nlp, Start::Primal(&w0, None), observer);
    let mut own = std::mem::take(&mut sol.direct_history);
    spent.append(&mut own);
    (with_phases(sol, spent, start), nlp, duals)
}

/// A solution with the iterations of every phase, renumbered in order, and
/// the time since `start`.
fn with_phases(
    mut sol: crate::Solution,
    mut history: Vec<DirectIteration>,
    start: Instant,
) -> crate::Solution {
    for (k, h) in history.iter_mut().enumerate() {
        h.iteration = k + 1;
    }
    sol.iterations = history.len();
    sol.direct_history = history;
    sol.solve_time_ms = start.elapsed().as_secs_f64() * 1e3;
    sol
}

/// A scaled vector of `from` carried onto `to`'s mesh: states by the state
/// interpolant (per interval, degree n_k), controls by the control
/// interpolant, t_f as is.
pub fn interpolate(from: &Nlp, w: &[f64], to: &Nlp) -> Vec<f64> {
    let mut out = vec![0.0; to.n_var()];
    let mut values = vec![0.0; from.n + 1];
    for s in 0..NL {
        let count = if s < NS { from.n + 1 } else { from.n };
        for (k, v) in values.iter_mut().enumerate().take(count) {
            *v = from.physical(s, w[from.idx(k, s)]);
        }
        for (k, &tau) in to.mesh.nodes.iter().enumerate() {
            let phys = if s < NS {
                from.mesh.interpolate_states(&values, tau)
            } else if k < to.n {
                from.mesh.interpolate_controls(&values[..from.n], tau)
            } else {
                continue;
            };
            out[to.idx(k, s)] = (phys - to.offset[s]) / to.scale[s];
        }
    }
    out[to.tf_idx()] = from.tf_s(w) / to.tf_scale;
    out
}

/// Solve from a given scaled point (and optionally multipliers, for warm
/// starts), and report the answer as a [`crate::Solution`].
pub fn solve_from(
    scenario: &crate::Scenario,
    settings: &SolverSettings,
    nlp: &Nlp,
    w0: &[f64],
    lambda0: Option<&[f64]>,
    observer: &mut dyn Observer,
) -> crate::Solution {
    solve_from_start(
        scenario,
        settings,
        nlp,
        Start::Primal(w0, lambda0),
        observer,
    )
    .0
}

/// Where a solve starts: a primal point, with the defect multipliers or
/// without ([`solve_nlp`]), or a primal–dual point ([`solve_nlp_warm`]).
#[derive(Debug, Clone, Copy)]
pub enum Start<'a> {
    Primal(&'a [f64], Option<&'a [f64]>),
    PrimalDual(&'a [f64], &'a Duals),
}

/// Solve from `start`, and report the answer as a [`crate::Solution`] with
/// the multipliers of its last iterate.
pub fn solve_from_start(
    scenario: &crate::Scenario,
    settings: &SolverSettings,
    nlp: &Nlp,
    start_point: Start,
    observer: &mut dyn Observer,
) -> (crate::Solution, Duals) {
    let start = Instant::now();
    let r = Driver::new(nlp, &settings.direct).run(start_point, observer);
    let ms = start.elapsed().as_secs_f64() * 1e3;
    let exact = SolverSettings {
        formulation: crate::Formulation::Exact,
        ..settings.clone()
    };
    let tr = crate::method::scvx::transcription::Transcription::new(scenario, &exact);
    let checks = checks(nlp, &r.w);
    let (mut status, mut message) = (r.status, r.message);
    if status == Status::Solved
        && checks.min_altitude_margin_m < -crate::solution::GROUND_TOLERANCE_M
    {
        status = Status::NonPhysical;
        message = format!(
            "the trajectory passes {:.3} m below the landing altitude",
            -checks.min_altitude_margin_m
        );
    }
    let mut sol = crate::Solution::new(
        &tr,
        nlp.to_trajectory(&r.w),
        status,
        message,
        checks,
        Vec::new(),
        ms,
    );
    sol.method = crate::input::scenario::Method::Direct;
    sol.iterations = r.history.len();
    sol.direct_history = r.history;
    let duals = Duals {
        lambda: r.lambda,
        zl: r.zl,
        zu: r.zu,
    };
    (sol, duals)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;

    /// ∇_w (f + λᵀc) of the transcription, from its point derivatives.
    fn lagrangian_gradient(nlp: &Nlp, w: &[f64], lambda: &[f64]) -> Vec<f64> {
        let jac: Vec<_> = (0..nlp.n)
            .map(|i| {
                nlp.point_derivatives(w, i, &lambda[i * NS..(i + 1) * NS])
                    .jac
            })
            .collect();
        let mut g = vec![0.0; nlp.n_var()];
        nlp.objective_gradient(w, &mut g);
        nlp.add_jt_lambda(w, &jac, lambda, &mut g);
        g
    }

    /// The KKT blocks are the derivatives of the whole NLP: J·v against
    /// differences of c, Jᵀλ against differences of λᵀc, and H·v against
    /// differences of ∇L, including every t_f term, on the global mesh and
    /// on an hp mesh, and with the soft terms (the margin's slacks in use).
    #[test]
    fn kkt_blocks_match_finite_differences() {
        for (nodes, intervals, soft) in [(7, 1, false), (9, 3, false), (7, 1, true)] {
            let mut s = Scenario::paper();
            s.discretization.nodes = nodes;
            s.discretization.intervals = intervals;
            let mut sv = SolverSettings::default();
            if soft {
                sv.thrust_margin_frac = 0.1;
                sv.thrust_margin_weight = 3.0;
                sv.terminal_lateral_weight = 2.0;
            }
            let nlp = Nlp::new(&s, &sv);
            let mut w = nlp.straight_line(11.0, 114_000.0);
            if soft {
                use crate::method::direct::nlp::slot;
                for i in 0..nlp.n {
                    let s = if i % 2 == 0 { slot::ABOVE } else { slot::BELOW };
                    w[nlp.idx(i, s)] = 0.01 * (1.0 + i as f64);
                }
            }
            let nv = nlp.n_var();
            let v: Vec<f64> = (0..nv)
                .map(|j| {
                    if nlp.is_fixed(j) {
                        0.0
                    } else {
                        ((j as f64) * 1.3).cos()
                    }
                })
                .collect();
            for j in 0..nv {
                if !nlp.is_fixed(j) {
                    w[j] += 0.03 * ((j as f64) * 0.37).sin();
                }
            }
            let lambda: Vec<f64> = (0..nlp.n_con())
                .map(|r| ((r as f64) * 0.91).sin())
                .collect();
            let derivs: Vec<_> = (0..nlp.n)
                .map(|i| nlp.point_derivatives(&w, i, &lambda[i * NS..(i + 1) * NS]))
                .collect();
            let mut kkt = KktMatrix::zeros(&nlp);
            lagrangian_blocks(&nlp, &w, &lambda, &derivs, &mut kkt);
            let (mut yw, mut yl) = (vec![0.0; nv], vec![0.0; nlp.n_con()]);
            // [H v + Jᵀ·0; J v] = K [v; 0].
            kkt.multiply(&nlp, &v, &vec![0.0; nlp.n_con()], &mut yw, &mut yl);
            let h = 1e-6;
            let shift = |a: f64| -> Vec<f64> { w.iter().zip(&v).map(|(x, d)| x + a * d).collect() };
            let (wp, wm) = (shift(h), shift(-h));
            let (mut cp, mut cm) = (vec![0.0; nlp.n_con()], vec![0.0; nlp.n_con()]);
            nlp.defects(&wp, &mut cp);
            nlp.defects(&wm, &mut cm);
            for r in 0..nlp.n_con() {
                let fd = (cp[r] - cm[r]) / (2.0 * h);
                assert!(
                    (fd - yl[r]).abs() < 1e-6 * (1.0 + fd.abs()),
                    "{nodes}/{intervals} (Jv)[{r}]: {} vs {fd}",
                    yl[r]
                );
            }
            let (gp, gm) = (
                lagrangian_gradient(&nlp, &wp, &lambda),
                lagrangian_gradient(&nlp, &wm, &lambda),
            );
            for j in 0..nv {
                if nlp.is_fixed(j) {
                    continue;
                }
                let fd = (gp[j] - gm[j]) / (2.0 * h);
                assert!(
                    (fd - yw[j]).abs() < 1e-5 * (1.0 + fd.abs()),
                    "{nodes}/{intervals} (Hv)[{j}]: {} vs {fd}",
                    yw[j]
                );
            }
            // Jᵀλ = K [0; λ] on the free variables, against ∇(λᵀc) by differences.
            kkt.multiply(&nlp, &vec![0.0; nv], &lambda, &mut yw, &mut yl);
            let g = lagrangian_gradient(&nlp, &w, &lambda);
            let mut grad_f = vec![0.0; nv];
            nlp.objective_gradient(&w, &mut grad_f);
            // ∇f against differences of f.
            for j in 0..nv {
                if nlp.is_fixed(j) {
                    continue;
                }
                let (mut e, mut f) = (w.clone(), w.clone());
                e[j] += h;
                f[j] -= h;
                let fd = (nlp.objective(&e) - nlp.objective(&f)) / (2.0 * h);
                assert!(
                    (fd - grad_f[j]).abs() < 1e-6 * (1.0 + fd.abs()),
                    "(∇f)[{j}]"
                );
            }
            for j in 0..nv {
                if nlp.is_fixed(j) {
                    continue;
                }
                let mut e = w.clone();
                e[j] += h;
                let mut f = w.clone();
                f[j] -= h;
                let (mut c1, mut c2) = (vec![0.0; nlp.n_con()], vec![0.0; nlp.n_con()]);
                nlp.defects(&e, &mut c1);
                nlp.defects(&f, &mut c2);
                let fd: f64 = (0..nlp.n_con())
                    .map(|r| lambda[r] * (c1[r] - c2[r]) / (2.0 * h))
                    .sum();
                let obj = grad_f[j];
                assert!(
                    (fd + obj - g[j]).abs() < 1e-6 * (1.0 + fd.abs()),
                    "grad[{j}]"
                );
                assert!((fd - yw[j]).abs() < 1e-6 * (1.0 + fd.abs()), "(Jᵀλ)[{j}]");
            }
        }
    }
}

/// Non-uniform meshes and warm starts across meshes
/// ([`Nlp::interpolate_from`]).
#[cfg(test)]
mod mesh_tests {
    use super::*;
    use crate::input::mesh_layout::MeshLayout;
    use crate::input::scenario::{Case, Scenario};
    use crate::method::scvx::Silent;

    /// The paper's case and its (direct) settings on N points over M
    /// uniform intervals.
    fn paper_on(nodes: usize, intervals: usize) -> (Scenario, SolverSettings) {
        let case = Case::paper();
        let mut s = case.scenario;
        s.discretization.nodes = nodes;
        s.discretization.intervals = intervals;
        s.validate().expect("valid");
        (s, case.solver)
    }

    fn max_diff(a: &[f64], b: &[f64]) -> f64 {
        assert_eq!(a.len(), b.len());
        a.iter()
            .zip(b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
    }

    /// On the solution's own mesh the interpolated start is the solution's
    /// trajectory itself, as `from_trajectory` makes it, with and without
    /// the soft thrust margin's slacks.
    #[test]
    fn interpolating_onto_the_same_mesh_is_from_trajectory() {
        let (s, sv) = paper_on(20, 4);
        let sol = solve(&s, &sv, &mut Silent);
        assert_eq!(sol.status, Status::Solved, "{}", sol.message);
        assert_eq!(sol.mesh, MeshLayout::uniform(20, 4));
        let mut margin = sv.clone();
        margin.thrust_margin_frac = 0.05;
        margin.thrust_margin_weight = 3.0;
        for settings in [&sv, &margin] {
            let nlp = Nlp::new(&s, settings);
            let d = max_diff(
                &nlp.interpolate_from(&sol),
                &nlp.from_trajectory(&sol.trajectory),
            );
            assert!(d < 1e-12, "{d:e}");
        }
    }

    /// A 4×5 answer carried onto 8×5 converges there in fewer interior-point
    /// iterations than the straight line does: the point of the warm start.
    ///
    /// Both start at μ_0 = [`WARM_MU`], as the coarse-to-fine start of
    /// [`solve`] does: measured on this case, 18 iterations warm against 20
    /// from the straight line (and 28 from the line at the default μ_0 =
    /// 0.1). At the default μ_0 the warm start does not pay (29 against 28):
    /// a large barrier first pushes the point off the active bounds it
    /// carries. The interpolated point's largest scaled defect, 0.49, is
    /// the coarse mesh's own error between its collocation points.
    #[test]
    fn a_coarse_answer_warm_starts_a_finer_mesh() {
        let (coarse, sv) = paper_on(20, 4);
        let from = solve(&coarse, &sv, &mut Silent);
        assert_eq!(from.status, Status::Solved, "{}", from.message);
        let (fine, mut settings) = paper_on(40, 8);
        settings.direct.mu_init = WARM_MU;
        let nlp = Nlp::new(&fine, &settings);
        let w0 = nlp.interpolate_from(&from);
        let warm = solve_from(&fine, &settings, &nlp, &w0, None, &mut Silent);
        let d = &fine.discretization;
        let line = nlp.straight_line(d.tf_guess_s, d.final_mass_guess_kg);
        let cold = solve_from(&fine, &settings, &nlp, &line, None, &mut Silent);
        eprintln!(
            "8x5 from 4x5: {} iterations (m_f {:.3} kg); from the straight line: {} (m_f {:.3} kg)",
            warm.iterations, warm.final_mass_kg, cold.iterations, cold.final_mass_kg
        );
        assert_eq!(warm.status, Status::Solved, "{}", warm.message);
        assert_eq!(cold.status, Status::Solved, "{}", cold.message);
        assert!((warm.final_mass_kg - cold.final_mass_kg).abs() < 1.0);
        assert!(
            warm.iterations < cold.iterations,
            "warm {} against cold {}",
            warm.iterations,
            cold.iterations
        );
    }

    /// With its multipliers carried too (primal–dual, at
    /// [`crate::method::direct::solver::WARM_PD_MU`]) the 4×5 answer converges on 8×5 in
    /// fewer iterations than from its states and controls alone (at
    /// [`WARM_MU`]), to the same optimum.
    #[test]
    fn a_primal_dual_start_takes_fewer_iterations_than_a_primal_one() {
        let (coarse, sv) = paper_on(20, 4);
        let (from, from_nlp, duals) = solve_keeping_duals(&coarse, &sv, &mut Silent);
        assert_eq!(from.status, Status::Solved, "{}", from.message);
        assert_eq!(duals.lambda.len(), from_nlp.n_con());
        assert_eq!(duals.zl.len(), from_nlp.n_var());
        let (fine, mut settings) = paper_on(40, 8);
        let nlp = Nlp::new(&fine, &settings);
        let w0 = nlp.interpolate_from(&from);
        settings.direct.mu_init = WARM_MU;
        let primal = solve_from(&fine, &settings, &nlp, &w0, None, &mut Silent);
        settings.direct.mu_init = crate::method::direct::solver::WARM_PD_MU;
        let carried = nlp.interpolate_duals_from(&from_nlp, &duals);
        let start = Start::PrimalDual(&w0, &carried);
        let (pd, _) = solve_from_start(&fine, &settings, &nlp, start, &mut Silent);
        eprintln!(
            "8x5 from 4x5: primal-dual {} iterations (m_f {:.3} kg), primal {} (m_f {:.3} kg)",
            pd.iterations, pd.final_mass_kg, primal.iterations, primal.final_mass_kg
        );
        assert_eq!(pd.status, Status::Solved, "{}", pd.message);
        assert_eq!(primal.status, Status::Solved, "{}", primal.message);
        assert!((pd.final_mass_kg - primal.final_mass_kg).abs() < 0.01);
        assert!(
            pd.iterations < primal.iterations,
            "primal-dual {} against primal {}",
            pd.iterations,
            primal.iterations
        );
    }

    /// The paper's case solves on a non-uniform mesh, which reaches the
    /// transcription, the NLP, the answer and the error estimate.
    #[test]
    fn a_non_uniform_mesh_solves() {
        let layout = MeshLayout {
            breaks_tau: vec![-1.0, -0.45, 0.15, 0.7, 1.0],
            points: vec![6, 5, 5, 4],
        };
        let (mut s, sv) = paper_on(20, 4);
        s.discretization.mesh = Some(layout.clone());
        s.validate().expect("valid");
        let tr = crate::method::scvx::transcription::Transcription::new(&s, &sv);
        assert_eq!(tr.mesh.layout(), layout);
        assert_eq!(Nlp::new(&s, &sv).mesh.layout(), layout);
        let sol = solve(&s, &sv, &mut Silent);
        assert_eq!(sol.status, Status::Solved, "{}", sol.message);
        assert_eq!(sol.mesh, layout);
        let mesh = sol.mesh();
        for (k, t) in sol.t_s.iter().enumerate() {
            assert_eq!(*t, mesh.time_s(k, sol.tf_s));
        }
        let (u, _) = paper_on(20, 4);
        let uniform = solve(&u, &sv, &mut Silent);
        eprintln!(
            "non-uniform: m_f {:.3} kg, t_f {:.4} s, {} iterations; uniform 4 intervals: m_f {:.3} kg, t_f {:.4} s",
            sol.final_mass_kg, sol.tf_s, sol.iterations, uniform.final_mass_kg, uniform.tf_s
        );
        assert!((sol.final_mass_kg - uniform.final_mass_kg).abs() < 0.005 * uniform.fuel_kg);
        let errors = crate::verify::mesh_error::estimate(&s, &sol).expect("estimate");
        let points: Vec<usize> = errors.iter().map(|e| e.points).collect();
        assert_eq!(points, layout.points);
        // SCvx on the same mesh (the method alone, as the direct answer above).
        let mut scvx = sv.clone();
        scvx.method = crate::input::scenario::Method::Scvx;
        let other = crate::method::scvx::solve(&s, &scvx, &mut Silent);
        eprintln!(
            "scvx non-uniform: {:?} m_f {:.3} kg, {} iterations",
            other.status, other.final_mass_kg, other.iterations
        );
        assert_eq!(other.status, Status::Solved, "{}", other.message);
        assert_eq!(other.mesh, layout);
        assert!((other.final_mass_kg - sol.final_mass_kg).abs() < 0.005 * sol.fuel_kg);
    }
}
