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
//! [`Observer`] as a [`DirectIteration`](crate::solution::DirectIteration).
//!
//! IPOPT's strategy objects, each owning its state: the iteration loop in
//! `driver`; the iterate and its bounds in `iterate`; the Newton system and
//! its workspace in `newton`; the barrier update (monotone and adaptive) in
//! `barrier`; the inertia correction in `inertia`; the filter line search
//! with second-order corrections in `line_search`; the feasibility
//! restoration in `restoration`.

#![allow(clippy::needless_range_loop)] // Dense block algebra indexes several arrays by one index.

mod answer;
mod barrier;
pub mod cold;
mod driver;
mod inertia;
mod iterate;
#[doc(hidden)] // internals, for the KKT benchmarks and tests; not the API
pub mod kkt;
mod line_search;
mod mesh_transfer;
mod newton;
#[doc(hidden)] // internals, for the benchmarks and tests; not the API
pub mod nlp;
mod restoration;
mod rows;
pub mod six_dof;
pub mod solver;

use crate::collocation::derivatives::Differentiable;
use crate::input::settings::DirectSettings;
use crate::input::settings::Method;
use crate::input::settings::SolverSettings;
pub use crate::method::direct::answer::checks;
use crate::method::direct::answer::solve_into;
pub use crate::method::direct::barrier::ADAPTIVE_WINDOW;
use crate::method::direct::cold::ColdWork;
pub use crate::method::direct::cold::WARM_MU;
use crate::method::direct::driver::Driver;
use crate::method::direct::driver::Storage;
pub use crate::method::direct::driver::{NlpResult, Start};
pub use crate::method::direct::mesh_transfer::interpolate;
pub use crate::method::direct::newton::lagrangian_blocks;
use crate::method::direct::nlp::Duals;
use crate::method::direct::nlp::{Nlp, Transcription};
use crate::method::observer::Observer;

/// Solve a transcription (P2, or a model's behind the seam) from the
/// scaled point `w0` (pushed inside its bounds).
pub fn solve_nlp<M: Differentiable, const NS: usize, const NL: usize>(
    nlp: &Transcription<M, NS, NL>,
    w0: &[f64],
    lambda0: Option<&[f64]>,
    settings: &DirectSettings,
    observer: &mut dyn Observer,
) -> NlpResult {
    Driver::new(nlp, settings).run(Start::Primal(w0, lambda0), observer)
}

/// Solve P2 from a primal–dual point: `w0` pushed only `WARM_BOUND_PUSH`
/// inside its bounds, the defect multipliers of `duals`, and each bound
/// multiplier at least μ_0/s (s: the slack), so that no pair starts far
/// below the barrier's complementarity. For the passes of mesh refinement,
/// whose starts are the last pass's answer and multipliers carried onto a
/// finer mesh ([`crate::method::direct::nlp::Nlp::interpolate_duals_from`]).
pub fn solve_nlp_warm<M: Differentiable, const NS: usize, const NL: usize>(
    nlp: &Transcription<M, NS, NL>,
    w0: &[f64],
    duals: &Duals,
    settings: &DirectSettings,
    observer: &mut dyn Observer,
) -> NlpResult {
    Driver::new(nlp, settings).run(Start::PrimalDual(w0, duals), observer)
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
    let mut work = ColdWork::new(scenario, settings);
    let mut sol = crate::Solution::empty(Method::Direct);
    work.solve_into(scenario, settings, observer, &mut sol);
    (sol, work.nlp, work.duals)
}

/// Solve from a given scaled point (and optionally multipliers, for warm
/// starts), and report the answer as a [`crate::Solution`].
pub fn solve_from(
    settings: &SolverSettings,
    nlp: &Nlp,
    w0: &[f64],
    lambda0: Option<&[f64]>,
    observer: &mut dyn Observer,
) -> crate::Solution {
    solve_from_start(settings, nlp, Start::Primal(w0, lambda0), observer).0
}

/// Solve from `start`, and report the answer as a [`crate::Solution`] with
/// the multipliers of its last iterate.
pub fn solve_from_start(
    settings: &SolverSettings,
    nlp: &Nlp,
    start_point: Start,
    observer: &mut dyn Observer,
) -> (crate::Solution, Duals) {
    let mut sol = crate::Solution::empty(Method::Direct);
    let mut storage = solve_into(
        settings,
        nlp,
        start_point,
        observer,
        Storage::new(nlp),
        &mut sol,
    );
    let it = &mut storage.iterate;
    let duals = Duals {
        lambda: std::mem::take(&mut it.lambda),
        zl: std::mem::take(&mut it.zl),
        zu: std::mem::take(&mut it.zu),
    };
    (sol, duals)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Scenario;
    use crate::method::direct::kkt::KktMatrix;
    use crate::method::direct::nlp::NS;

    /// ∇_w (f + λᵀc) of the transcription, from its point derivatives.
    fn lagrangian_gradient(nlp: &Nlp, w: &[f64], lambda: &[f64]) -> Vec<f64> {
        let derivs: Vec<_> = (0..nlp.n)
            .map(|i| {
                let mut d = Default::default();
                nlp.point_derivatives(w, i, &lambda[i * NS..(i + 1) * NS], &mut d);
                d
            })
            .collect();
        let mut g = vec![0.0; nlp.n_var()];
        nlp.objective_gradient(w, &mut g);
        nlp.add_jt_lambda(w, &derivs, lambda, &mut g);
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
                .map(|i| {
                    let mut d = Default::default();
                    nlp.point_derivatives(&w, i, &lambda[i * NS..(i + 1) * NS], &mut d);
                    d
                })
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
    use crate::method::observer::Silent;
    use crate::solution::Status;

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
        let warm = solve_from(&settings, &nlp, &w0, None, &mut Silent);
        let d = &fine.discretization;
        let line = nlp.straight_line(d.tf_guess_s, d.final_mass_guess_kg);
        let cold = solve_from(&settings, &nlp, &line, None, &mut Silent);
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
        let primal = solve_from(&settings, &nlp, &w0, None, &mut Silent);
        settings.direct.mu_init = crate::method::direct::solver::WARM_PD_MU;
        let carried = nlp.interpolate_duals_from(&from_nlp, &duals);
        let start = Start::PrimalDual(&w0, &carried);
        let (pd, _) = solve_from_start(&settings, &nlp, start, &mut Silent);
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
        scvx.method = crate::input::settings::Method::Scvx;
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
