//! The interior-point iteration (Algorithm A of Wächter & Biegler 2006):
//! at each iterate, the optimality test, the barrier update, the
//! inertia-correcting factorization, the Newton step, and the filter line
//! search or, when it fails, the feasibility restoration; each iteration is
//! reported to the [`Observer`].

use std::ops::ControlFlow;
use std::time::Instant;

use crate::collocation::derivatives::Differentiable;
use crate::input::settings::DirectSettings;
use crate::method::direct::barrier::Barrier;
use crate::method::direct::inertia::InertiaCorrection;
use crate::method::direct::iterate::Bounds;
use crate::method::direct::iterate::{inf_norm, l1_norm, Iterate};
use crate::method::direct::line_search::{FilterLineSearch, LineSearch};
use crate::method::direct::newton::{Newton, Workspace};
use crate::method::direct::nlp::{Duals, Transcription};
use crate::method::direct::restoration::Restoration;
use crate::method::observer::{deadline_message, Iteration, Observer};
use crate::solution::{DirectIteration, Status};

/// Where a solve starts: a primal point, with the defect multipliers or
/// without ([`solve_nlp`](super::solve_nlp)), or a primal–dual point
/// ([`solve_nlp_warm`](super::solve_nlp_warm)).
#[derive(Debug, Clone, Copy)]
pub enum Start<'a> {
    Primal(&'a [f64], Option<&'a [f64]>),
    PrimalDual(&'a [f64], &'a Duals),
}

/// The answer of [`solve_nlp`](super::solve_nlp): the last iterate
/// (scaled) and how it ended.
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

/// The relative push of a start inside its bounds (§3.6).
const BOUND_PUSH: f64 = 1e-2;
/// The bound push of a primal–dual warm start
/// ([`solve_nlp_warm`](super::solve_nlp_warm)): small, so that the controls
/// on their bounds stay there (IPOPT's `warm_start_bound_push` plays this
/// part).
const WARM_BOUND_PUSH: f64 = 1e-8;

/// How a solve ended, when it ended before its iteration limit.
type Outcome = (Status, String);

/// What an iteration reports: the iterate's infeasibilities, and the step
/// taken from it.
struct Progress {
    primal: f64,
    dual: f64,
    step: f64,
    trials: usize,
    restoration: bool,
}

/// The storage of a solve: the Newton system's workspace and bounds, the
/// iterate, the barrier's E_0 history and the filter. Kept between the
/// solves of a re-plan sequence ([`Storage::reuse_for`]), so that a
/// re-plan allocates none of it (issue 27).
pub struct Storage<const NS: usize = 8, const NL: usize = 12> {
    ws: Workspace<NS, NL>,
    bounds: Bounds,
    pub(super) iterate: Iterate,
    e0_history: Vec<f64>,
    filter: Vec<(f64, f64)>,
}

impl<const NS: usize, const NL: usize> Storage<NS, NL> {
    /// Storage for `nlp`.
    pub fn new<M: Differentiable>(nlp: &Transcription<M, NS, NL>) -> Self {
        Storage {
            ws: Workspace::new(nlp),
            bounds: Bounds::new(nlp),
            iterate: Iterate {
                w: Vec::new(),
                lambda: Vec::new(),
                zl: Vec::new(),
                zu: Vec::new(),
                zr: Vec::new(),
            },
            e0_history: Vec::new(),
            filter: Vec::new(),
        }
    }

    /// This storage, reset to [`Storage::new`]'s state, for `nlp` when its
    /// structure fits (the same mesh and fixed variables); else new storage.
    pub fn reuse_for<M: Differentiable>(mut self, nlp: &Transcription<M, NS, NL>) -> Self {
        if !self.ws.solver.fits(nlp) {
            return Storage::new(nlp);
        }
        self.ws.reset();
        self.bounds.refill(nlp);
        self
    }

    /// The last solve's iterate: its scaled primal point.
    pub fn w(&self) -> &[f64] {
        &self.iterate.w
    }

    /// Room for a solve of `nlp` of up to `max_iterations` iterations: the
    /// iterate's vectors, the barrier's history and the filter, so that
    /// even the first solve in this storage allocates nothing.
    pub fn reserve<M: Differentiable>(
        &mut self,
        nlp: &Transcription<M, NS, NL>,
        max_iterations: usize,
    ) {
        let (nv, nc) = (nlp.n_var(), nlp.n_con());
        let it = &mut self.iterate;
        for (v, len) in [
            (&mut it.w, nv),
            (&mut it.lambda, nc),
            (&mut it.zl, nv),
            (&mut it.zu, nv),
            // At most every row at every node.
            (&mut it.zr, (nlp.limits.len() + M::PATH_ROWS) * (nlp.n + 1)),
        ] {
            v.reserve(len.saturating_sub(v.len()));
        }
        self.e0_history.reserve(max_iterations);
        self.filter
            .reserve(crate::method::direct::line_search::FILTER_CAPACITY);
    }

    /// Do, on this thread, the allocation that the KKT solve's first matrix
    /// product would ([`crate::method::direct::kkt::KktSolver::warm_up_thread`]).
    pub fn warm_up_thread(&self) {
        self.ws.solver.warm_up_thread();
    }

    /// The last iterate's primal point, and a defect buffer of the NLP's
    /// size (the workspace's, free between solves).
    pub(super) fn point_and_defects(&mut self) -> (&[f64], &mut [f64]) {
        (&self.iterate.w, &mut self.ws.c)
    }
}

impl<const NS: usize, const NL: usize> std::fmt::Debug for Storage<NS, NL> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Storage")
            .field("variables", &self.bounds.lo.len())
            .finish_non_exhaustive()
    }
}

/// How a solve in [`Storage`] ended; its iterate is the storage's.
pub(super) struct Ended {
    pub status: Status,
    pub message: String,
    /// Largest |defect| of the last iterate (scaled).
    pub max_defect: f64,
}

pub(super) struct Driver<'a, M, const NS: usize, const NL: usize> {
    nlp: &'a Transcription<M, NS, NL>,
    settings: &'a DirectSettings,
    sys: Newton<'a, M, NS, NL>,
    barrier: Barrier,
    inertia: InertiaCorrection,
    search: FilterLineSearch,
    /// The iterate's storage, taken by [`Self::initial_iterate`] and
    /// returned at the end.
    spare: Iterate,
}

impl<'a, M: Differentiable, const NS: usize, const NL: usize> Driver<'a, M, NS, NL> {
    pub(super) fn new(nlp: &'a Transcription<M, NS, NL>, settings: &'a DirectSettings) -> Self {
        Driver::with_storage(nlp, settings, Storage::new(nlp))
    }

    /// A driver that lives in `storage` (made for `nlp`).
    pub(super) fn with_storage(
        nlp: &'a Transcription<M, NS, NL>,
        settings: &'a DirectSettings,
        storage: Storage<NS, NL>,
    ) -> Self {
        Driver {
            nlp,
            settings,
            sys: Newton::with_parts(nlp, storage.ws, storage.bounds),
            barrier: Barrier::with_history(settings, storage.e0_history),
            inertia: InertiaCorrection::default(),
            search: FilterLineSearch::with_storage(storage.filter),
            spare: storage.iterate,
        }
    }

    /// Its storage, for the next solve of the same structure.
    fn into_storage(self, iterate: Iterate) -> Storage<NS, NL> {
        let (ws, bounds) = self.sys.into_parts();
        Storage {
            ws,
            bounds,
            iterate,
            e0_history: self.barrier.into_history(),
            filter: self.search.into_storage(),
        }
    }

    fn final_mass_kg(&self, w: &[f64]) -> f64 {
        let k = self.nlp.idx(self.nlp.n, M::MASS);
        self.nlp.physical(M::MASS, w[k])
    }

    pub(super) fn run(self, start: Start, observer: &mut dyn Observer) -> NlpResult {
        let mut history = Vec::with_capacity(self.settings.max_iterations);
        let (end, mut storage) = self.run_in(start, observer, &mut history);
        let it = &mut storage.iterate;
        NlpResult {
            w: std::mem::take(&mut it.w),
            lambda: std::mem::take(&mut it.lambda),
            zl: std::mem::take(&mut it.zl),
            zu: std::mem::take(&mut it.zu),
            status: end.status,
            message: end.message,
            history,
            max_defect: end.max_defect,
        }
    }

    /// [`Self::run`] with each iteration appended to `history` (its room
    /// reserved first) and the last iterate left in the returned storage,
    /// for the next solve of the same structure.
    pub(super) fn run_in(
        mut self,
        start: Start,
        observer: &mut dyn Observer,
        history: &mut Vec<DirectIteration>,
    ) -> (Ended, Storage<NS, NL>) {
        let mut it = self.initial_iterate(start);
        history.reserve(self.settings.max_iterations);
        let mut outcome: Option<Outcome> = None;

        for iteration in 1..=self.settings.max_iterations {
            let t0 = Instant::now();
            let p = match self.iteration(&mut it) {
                ControlFlow::Continue(p) => p,
                ControlFlow::Break(end) => {
                    outcome = Some(end);
                    break;
                }
            };
            let record = DirectIteration {
                iteration,
                mesh_nodes: self.nlp.n,
                final_mass_kg: self.final_mass_kg(&it.w),
                primal_infeasibility: p.primal,
                dual_infeasibility: p.dual,
                mu: self.barrier.mu,
                step: p.step,
                inertia_correction: self.inertia.delta_w,
                line_search_trials: p.trials,
                restoration: p.restoration,
                ms: t0.elapsed().as_secs_f64() * 1e3,
            };
            observer.iteration(Iteration::Direct(&record));
            history.push(record);
            if observer.deadline_passed() {
                let message = deadline_message(iteration, "interior-point");
                outcome = Some((Status::NotConverged, message));
                break;
            }
        }
        let end = self.finish(&it, outcome);
        (end, self.into_storage(it))
    }

    /// The starting iterate (§3.6): the point pushed inside its bounds, the
    /// bound multipliers (cold: z = 1; warm: the given z, at least μ_0/s),
    /// λ given or by least squares; and θ_max, θ_min from its infeasibility.
    fn initial_iterate(&mut self, start: Start) -> Iterate {
        let nlp = self.nlp;
        let (nv, nc) = (nlp.n_var(), nlp.n_con());
        let (w0, lambda0, warm) = match start {
            Start::Primal(w0, lambda0) => (w0, lambda0, None),
            Start::PrimalDual(w0, duals) => (w0, Some(&duals.lambda[..]), Some(duals)),
        };
        let spare = &mut self.spare;
        let mut w = std::mem::take(&mut spare.w);
        w.clear();
        w.extend_from_slice(w0);
        let push = if warm.is_some() {
            WARM_BOUND_PUSH
        } else {
            BOUND_PUSH
        };
        self.sys.bounds.push_inside(&mut w, push);
        self.sys.rows.push_inside(nlp, &mut w);
        let b = &self.sys.bounds;
        let mu0 = self.barrier.mu;
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
        let mut zl = std::mem::take(&mut spare.zl);
        zl.clear();
        zl.extend((0..nv).map(|j| start_z(j, b.has_lo[j], w[j] - b.lo[j], warm.map(|d| &d.zl))));
        let mut zu = std::mem::take(&mut spare.zu);
        zu.clear();
        zu.extend((0..nv).map(|j| start_z(j, b.has_hi[j], b.hi[j] - w[j], warm.map(|d| &d.zu))));
        let mut lambda = std::mem::take(&mut spare.lambda);
        lambda.clear();
        lambda.resize(nc, 0.0);
        let mut zr = std::mem::take(&mut spare.zr);
        zr.clear();
        zr.resize(self.sys.rows.len(), 1.0);
        let mut it = Iterate {
            w,
            lambda,
            zl,
            zu,
            zr,
        };
        self.sys.evaluate(&it.w, &it.lambda);
        match lambda0 {
            Some(l) if l.len() == nc => it.lambda.copy_from_slice(l),
            _ => self.sys.initial_multipliers(&mut it),
        }
        let theta0 = l1_norm(&self.sys.ws.c);
        self.search.start(theta0);
        it
    }

    /// One iteration from `it`: its derivatives and optimality error (the
    /// end of the solve when E_0 ≤ ε_tol), the barrier update, the Newton
    /// step and the step along it.
    fn iteration(&mut self, it: &mut Iterate) -> ControlFlow<Outcome, Progress> {
        let tol = self.settings.tolerance;
        self.sys.evaluate(&it.w, &it.lambda);
        self.sys.lagrangian_gradient(&it.w, &it.lambda);
        self.sys.ws.w_old.copy_from_slice(&it.w);
        let (e0, primal, dual) = self.sys.optimality_error(it, 0.0);
        if !(e0.is_finite()) {
            return ControlFlow::Break((
                Status::SolverFailed,
                "the iterate is no longer finite".to_string(),
            ));
        }
        if e0 <= tol {
            return ControlFlow::Break((Status::Solved, String::new()));
        }
        if self.barrier.update(&self.sys, it, e0) {
            self.search.reset();
        }
        if let Err(msg) = self.newton_step(it) {
            return ControlFlow::Break((Status::SolverFailed, msg));
        }
        match self.step(it) {
            Ok((step, trials, restoration)) => ControlFlow::Continue(Progress {
                primal,
                dual,
                step,
                trials,
                restoration,
            }),
            Err(msg) => ControlFlow::Break((Status::Infeasible, msg)),
        }
    }

    /// The Newton step (Eq. 11–13) into ws.dw, ws.dl: the KKT system at the
    /// iterate, factored with inertia correction, and (in the adaptive mode)
    /// μ from the probe on its factors.
    fn newton_step(&mut self, it: &Iterate) -> Result<(), String> {
        self.sys.build_kkt(it);
        self.inertia.factor(&mut self.sys, self.barrier.mu)?;
        if self.barrier.probe(&mut self.sys, it) {
            self.search.reset();
        }
        self.sys.newton_rhs(it, self.barrier.mu);
        self.sys.solve_kkt();
        Ok(())
    }

    /// The step along the Newton direction: the filter line search, or on
    /// its failure the fallback to the monotone mode (adaptive) or the
    /// restoration. Its length, trials and whether it restored; an error
    /// when the restoration fails.
    fn step(&mut self, it: &mut Iterate) -> Result<(f64, usize, bool), String> {
        let barrier = (self.barrier.mu, self.barrier.tau);
        match self.search.search(&mut self.sys, it, barrier) {
            LineSearch::Accepted { alpha, trials, .. } => Ok((alpha, trials, false)),
            LineSearch::Failed if self.barrier.is_adaptive() => {
                // No restoration in the adaptive mode: fall back and retry.
                self.barrier.leave_adaptive_mode(&self.sys, it);
                self.search.reset();
                Ok((0.0, 0, false))
            }
            LineSearch::Failed => {
                let (sys, inertia, search) = (&mut self.sys, &mut self.inertia, &mut self.search);
                Restoration::run(sys, inertia, search, it, barrier)?;
                Ok((0.0, 0, true))
            }
        }
    }

    /// How the solve ended, with the last iterate's defect.
    fn finish(&mut self, it: &Iterate, outcome: Option<Outcome>) -> Ended {
        let (status, message) = outcome.unwrap_or_else(|| {
            (
                Status::NotConverged,
                format!(
                    "no convergence in {} interior-point iterations; the last iterate is returned",
                    self.settings.max_iterations
                ),
            )
        });
        self.nlp.defects(&it.w, &mut self.sys.ws.c);
        Ended {
            max_defect: inf_norm(&self.sys.ws.c),
            status,
            message,
        }
    }
}
