//! A cold solve from the straight line, in storage that a solver keeps: a
//! coarse phase at `solver.direct.coarse_nodes` from the straight line,
//! carried onto the scenario's mesh and finished there at μ_0 =
//! [`WARM_MU`], with the straight line on the scenario's mesh as the
//! fallback. Every phase's iterations and time count in the answer.
//!
//! [`ColdWork`] holds both phases' NLPs, their solver storage and the start
//! vectors. Made once (a flight loop's setup) and refreshed for each cold
//! solve of the same discretization, a cold solve that converges allocates
//! nothing (issue 27); [`super::solve_keeping_duals`] makes one per solve.

use std::time::Instant;

use crate::input::mesh_layout::MeshLayout;
use crate::input::scenario::{Discretization, Scenario};
use crate::input::settings::{DirectSettings, SolverSettings};
use crate::method::direct::answer::{solve_appending, solve_into};
use crate::method::direct::driver::{Driver, Start, Storage};
use crate::method::direct::mesh_transfer::interpolate_into;
use crate::method::direct::nlp::{Duals, Nlp};
use crate::method::observer::Observer;
use crate::solution::{Solution, Status};

/// μ_0 of the fine solve after a coarse start, and of warm starts.
pub const WARM_MU: f64 = 1e-4;

/// What fixes a discretization's mesh (its nodes, intervals and explicit
/// layout), kept with storage built for it: storage fits a later scenario
/// whose discretization has the same.
#[derive(Debug)]
pub(super) struct MeshKey {
    nodes: usize,
    intervals: usize,
    layout: Option<MeshLayout>,
}

impl MeshKey {
    /// The key of `d`'s mesh.
    pub(super) fn of(d: &Discretization) -> MeshKey {
        MeshKey {
            nodes: d.nodes,
            intervals: d.intervals,
            layout: d.mesh.clone(),
        }
    }

    /// Whether `d` asks for this mesh (compared without allocating).
    pub(super) fn matches(&self, d: &Discretization) -> bool {
        self.nodes == d.nodes && self.intervals == d.intervals && self.layout == d.mesh
    }
}

/// The storage of a cold solve on one discretization.
#[derive(Debug)]
pub struct ColdWork {
    mesh: MeshKey,
    coarse_nodes: usize,
    /// The scenario's mesh: its NLP, solver storage and straight line.
    pub(super) nlp: Nlp,
    storage: Option<Storage>,
    w0: Vec<f64>,
    /// The coarse phase, when the settings ask for one on this mesh.
    coarse: Option<Coarse>,
    /// The coarse answer carried onto the scenario's mesh, and the work
    /// vector of that interpolation.
    warm: Vec<f64>,
    values: Vec<f64>,
    /// The multipliers of the last answer's iterate, and that answer's
    /// final mass (which identifies it; none before a solve).
    pub(super) duals: Duals,
    final_mass_kg: Option<f64>,
    /// Whether a phase on the scenario's mesh has run in this solve.
    fine_used: bool,
}

/// The coarse phase's NLP, solver storage and straight line.
#[derive(Debug)]
struct Coarse {
    nlp: Nlp,
    storage: Option<Storage>,
    w0: Vec<f64>,
}

/// Where a phase on the scenario's mesh starts.
#[derive(Debug, Clone, Copy)]
enum FineStart {
    /// The coarse answer, carried onto the mesh.
    Coarse,
    /// The straight line.
    StraightLine,
}

/// Storage from `slot`, or new storage for `nlp` if it is empty (it is
/// only while a solve has it).
fn take(slot: &mut Option<Storage>, nlp: &Nlp) -> Storage {
    slot.take().unwrap_or_else(|| Storage::new(nlp))
}

impl ColdWork {
    /// The storage of a cold solve of `scenario` with `settings`.
    pub fn new(scenario: &Scenario, settings: &SolverSettings) -> ColdWork {
        let d = &scenario.discretization;
        let coarse_nodes = settings.direct.coarse_nodes;
        let coarse = (coarse_nodes >= 4 && 2 * coarse_nodes <= d.nodes).then(|| {
            let mut c = scenario.clone();
            c.discretization.nodes = coarse_nodes;
            c.discretization.intervals = 1;
            c.discretization.mesh = None;
            let nlp = Nlp::new(&c, settings);
            Coarse {
                storage: Some(Storage::new(&nlp)),
                nlp,
                w0: Vec::new(),
            }
        });
        let nlp = Nlp::new(scenario, settings);
        ColdWork {
            mesh: MeshKey::of(d),
            coarse_nodes,
            storage: Some(Storage::new(&nlp)),
            nlp,
            w0: Vec::new(),
            coarse,
            warm: Vec::new(),
            values: Vec::new(),
            duals: Duals::default(),
            final_mass_kg: None,
            fine_used: false,
        }
    }

    /// Whether this storage is for `scenario`'s discretization and
    /// `settings`' coarse phase.
    pub fn fits(&self, scenario: &Scenario, settings: &SolverSettings) -> bool {
        self.mesh.matches(&scenario.discretization)
            && self.coarse_nodes == settings.direct.coarse_nodes
    }

    /// Set both NLPs to `scenario` and `settings` in place (the mesh is
    /// the same: [`Self::fits`]), their storage back to its new state.
    pub fn refresh(&mut self, scenario: &Scenario, settings: &SolverSettings) {
        self.final_mass_kg = None;
        self.nlp.refresh(scenario, settings);
        self.storage = self.storage.take().map(|s| s.reuse_for(&self.nlp));
        if let Some(c) = &mut self.coarse {
            // An NLP's refresh reads no discretization: the coarse one is
            // refreshed from the scenario itself.
            c.nlp.refresh(scenario, settings);
            c.storage = c.storage.take().map(|s| s.reuse_for(&c.nlp));
        }
    }

    /// Room for a cold solve of up to `max_iterations` iterations, and the
    /// allocation that this thread's first KKT product makes, done now.
    pub fn reserve(&mut self, max_iterations: usize) {
        if let Some(s) = &self.storage {
            s.warm_up_thread();
        }
        let nv = self.nlp.n_var();
        for v in [&mut self.w0, &mut self.warm] {
            v.reserve(nv.saturating_sub(v.len()));
        }
        if let Some(s) = &mut self.storage {
            s.reserve(&self.nlp, max_iterations);
        }
        if let Some(c) = &mut self.coarse {
            c.w0.reserve(c.nlp.n_var().saturating_sub(c.w0.len()));
            if let Some(s) = &mut c.storage {
                s.reserve(&c.nlp, max_iterations);
            }
            self.values
                .reserve((c.nlp.n + 1).saturating_sub(self.values.len()));
        }
        let (nc, d) = (self.nlp.n_con(), &mut self.duals);
        d.lambda.reserve(nc.saturating_sub(d.lambda.len()));
        for v in [&mut d.zl, &mut d.zu] {
            v.reserve(nv.saturating_sub(v.len()));
        }
    }

    /// The cold solve of `scenario` (which [`Self::fits`] and was
    /// refreshed into this storage) into `out`.
    pub fn solve_into(
        &mut self,
        scenario: &Scenario,
        settings: &SolverSettings,
        observer: &mut dyn Observer,
        out: &mut Solution,
    ) {
        let d = &scenario.discretization;
        self.nlp
            .straight_line_into(d.tf_guess_s, d.final_mass_guess_kg, &mut self.w0);
        out.history.scvx.clear();
        out.history.direct.clear();
        self.fine_used = false;
        if self.coarse.is_none() {
            let storage = take(&mut self.storage, &self.nlp);
            let start = Start::Primal(&self.w0, None);
            self.storage = Some(solve_into(
                settings, &self.nlp, start, observer, storage, out,
            ));
        } else {
            let start = Instant::now();
            self.phases(scenario, settings, observer, out);
            renumber(out);
            out.iterations = out.history.len();
            out.solve_time_ms = start.elapsed().as_secs_f64() * 1e3;
        }
        self.keep_duals();
        self.final_mass_kg = Some(out.final_mass_kg);
    }

    /// The final mass of the last answer solved in this storage.
    pub fn final_mass_kg(&self) -> Option<f64> {
        self.final_mass_kg
    }

    /// The coarse phase, then the fine one from its answer, then (when that
    /// fails) the fine one from the straight line, each appending its
    /// iterations to `out`'s history.
    fn phases(
        &mut self,
        scenario: &Scenario,
        settings: &SolverSettings,
        observer: &mut dyn Observer,
        out: &mut Solution,
    ) {
        let d = &scenario.discretization;
        let Some(c) = &mut self.coarse else {
            return;
        };
        c.nlp
            .straight_line_into(d.tf_guess_s, d.final_mass_guess_kg, &mut c.w0);
        let coarse_settings = DirectSettings {
            tolerance: settings.direct.coarse_tolerance,
            ..settings.direct.clone()
        };
        let driver = Driver::with_storage(&c.nlp, &coarse_settings, take(&mut c.storage, &c.nlp));
        let start = Start::Primal(&c.w0, None);
        let (first, storage) = driver.run_in(start, observer, &mut out.history.direct);
        interpolate_into(
            &c.nlp,
            storage.w(),
            &self.nlp,
            &mut self.warm,
            &mut self.values,
        );
        c.storage = Some(storage);
        let max_iterations = settings.direct.max_iterations;
        let mut budget = settings.clone();
        budget.direct.max_iterations = max_iterations.saturating_sub(out.history.len());
        if budget.direct.max_iterations > 0 && first.status == Status::Solved {
            let mut fine = budget.clone();
            fine.direct.mu_init = WARM_MU;
            self.fine(&fine, FineStart::Coarse, observer, out);
            if out.status == Status::Solved {
                return;
            }
            budget.direct.max_iterations = max_iterations.saturating_sub(out.history.len());
        }
        if budget.direct.max_iterations == 0 {
            // The limit was spent on the coarse phase: its last iterate,
            // carried onto the scenario's mesh, not iterated there.
            self.fine(&budget, FineStart::Coarse, observer, out);
            out.status = Status::NotConverged;
            out.message = format!(
                "no convergence in {max_iterations} interior-point iterations (coarse start included); the last iterate is returned"
            );
            return;
        }
        self.fine(&budget, FineStart::StraightLine, observer, out);
    }

    /// A phase on the scenario's mesh from `from`, appending to `out`.
    fn fine(
        &mut self,
        settings: &SolverSettings,
        from: FineStart,
        observer: &mut dyn Observer,
        out: &mut Solution,
    ) {
        let mut storage = take(&mut self.storage, &self.nlp);
        if self.fine_used {
            // A second phase on this mesh starts from new storage, as a
            // solve of its own would.
            storage = storage.reuse_for(&self.nlp);
        }
        self.fine_used = true;
        let w0 = match from {
            FineStart::Coarse => &self.warm,
            FineStart::StraightLine => &self.w0,
        };
        let start = Start::Primal(w0, None);
        self.storage = Some(solve_appending(
            settings, &self.nlp, start, observer, storage, out,
        ));
    }

    /// The last iterate's multipliers into `duals`, in its storage.
    fn keep_duals(&mut self) {
        if let Some(s) = &self.storage {
            let it = &s.iterate;
            self.duals.lambda.clone_from(&it.lambda);
            self.duals.zl.clone_from(&it.zl);
            self.duals.zu.clone_from(&it.zu);
        }
    }
}

/// Number the direct iterations of `out`'s history 1, 2, … in order, over
/// every phase (as [`crate::solution::History::append`] does).
fn renumber(out: &mut Solution) {
    for (k, h) in out.history.direct.iter_mut().enumerate() {
        h.iteration = k + 1;
    }
}
