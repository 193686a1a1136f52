//! The interior-point solve of a subproblem with Clarabel, set up once per
//! problem structure and updated in place afterwards.
//!
//! Every SCvx subproblem of one [`Transcription`] has the same sparsity:
//! [`Transcription::assemble`] emits every structural entry, zero or not. So the
//! first solve builds the Clarabel solver (equilibration, KKT pattern, AMD
//! ordering, symbolic factorization) and later solves only overwrite the values
//! through `update_data`. That API requires presolve, chordal decomposition and
//! zero-dropping to be off, as they change the problem's structure (chordal
//! decomposition exists only with Clarabel's `sdp` feature, which we do not
//! enable).
//!
//! [`Transcription`]: crate::method::scvx::transcription::Transcription
//! [`Transcription::assemble`]: crate::method::scvx::transcription::Transcription::assemble

use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, SolverStatus};

use super::socp::ConicData;

/// Clarabel's settings for SCvx subproblems.
fn settings() -> DefaultSettings<f64> {
    DefaultSettings {
        verbose: false,
        presolve_enable: false,
        input_sparse_dropzeros: false,
        ..DefaultSettings::default()
    }
}

/// A Clarabel solver kept across subproblems of the same structure.
#[derive(Default)]
pub struct ConicSolver {
    solver: Option<DefaultSolver<f64>>,
    /// Number of full setups performed (1 for a whole SCvx run when the
    /// structure never changes).
    pub setups: usize,
}

/// Primal answer of one conic solve.
#[derive(Debug, Clone)]
pub struct ConicAnswer {
    pub x: Vec<f64>,
    pub iterations: u32,
    pub status: SolverStatus,
}

impl ConicSolver {
    pub fn new() -> Self {
        Self::default()
    }

    /// Solve `data`: in place if the previous problem had the same structure,
    /// otherwise after a fresh setup. An error names Clarabel's failure.
    pub fn solve(&mut self, data: &ConicData) -> Result<ConicAnswer, String> {
        let updated = match &mut self.solver {
            Some(s) => s.update_data(&data.p, &data.q, &data.a, &data.b).is_ok(),
            None => false,
        };
        if !updated {
            let s = DefaultSolver::new(&data.p, &data.q, &data.a, &data.b, &data.cones, settings())
                .map_err(|e| format!("Clarabel setup failed: {e}"))?;
            self.solver = Some(s);
            self.setups += 1;
        }
        let s = self.solver.as_mut().expect("solver was just set up");
        s.solve();
        let sol = &s.solution;
        match sol.status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => Ok(ConicAnswer {
                x: sol.x.clone(),
                iterations: sol.iterations,
                status: sol.status,
            }),
            other => Err(format!("Clarabel status {other:?}")),
        }
    }
}

impl std::fmt::Debug for ConicSolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ConicSolver")
            .field("set_up", &self.solver.is_some())
            .field("setups", &self.setups)
            .finish()
    }
}
