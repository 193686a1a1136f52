//! Criterion benchmarks of the solver's building blocks (issue 5).
//!
//! Run with `cargo bench -p bellyflop --bench solver`. Only the public API is
//! used. Sample counts are kept small so the whole run takes a few minutes on
//! a 2-core machine; see BENCHMARKS.md for the latest numbers.

use std::hint::black_box;
use std::time::Duration;

use bellyflop::collocation::radau::Lgr;
use bellyflop::guidance::planner::{initial_state, Planner};
use bellyflop::method::observer::Silent;
use bellyflop::method::scvx::conic::ConicSolver;
use bellyflop::method::scvx::straight_line;
use bellyflop::method::scvx::transcription::Transcription;
use bellyflop::problem::dynamics::linearize;
use bellyflop::{Case, Formulation};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode};

/// The paper's case at `n` LGR points.
/// (SCvx: these benchmarks are of its building blocks; `benches/kkt.rs` has
/// the direct method.)
fn paper(n: usize) -> Case {
    let mut s = Case::paper();
    s.scenario.discretization.nodes = n;
    s.solver.method = bellyflop::Method::Scvx;
    s
}

/// The transcription of the first SCvx subproblem of a cold solve: the relaxed
/// P4 (`Formulation::Paper`) without the ground bound, as `bellyflop::solve`
/// builds it for its first phase.
fn first_subproblem(
    n: usize,
) -> (
    Transcription,
    bellyflop::collocation::trajectory::Trajectory,
    f64,
) {
    let mut s = paper(n);
    s.solver.formulation = Formulation::Paper;
    let tr = Transcription::new(&s.scenario, &s.solver).without_ground_bound();
    let d = &s.scenario.discretization;
    let guess = straight_line(&tr, d.tf_guess_s, d.final_mass_guess_kg);
    (tr, guess, s.solver.trust_region_initial)
}

/// Full cold solve of the paper's case to convergence (default settings).
fn cold_solve(c: &mut Criterion) {
    let mut g = c.benchmark_group("cold_solve");
    // Flat sampling: a solve at N = 60 takes seconds, so each sample is one
    // (or a few) solves rather than criterion's linearly growing batches.
    g.sampling_mode(SamplingMode::Flat);
    g.sample_size(10);
    g.warm_up_time(Duration::from_secs(1));
    g.measurement_time(Duration::from_secs(5));
    for n in [10, 20, 40, 60] {
        let s = paper(n);
        g.bench_with_input(BenchmarkId::from_parameter(n), &s, |b, s| {
            b.iter(|| {
                let sol = black_box(s).solve(&mut Silent).expect("a planar scenario");
                assert_eq!(sol.status, bellyflop::Status::Solved, "N = {n}");
                sol
            })
        });
    }
    g.finish();
}

/// Cold solve on an hp mesh (N points over M intervals): each subproblem is
/// cheaper; from some t_f guesses SCvx needs many more iterations there
/// (`bench/hp_sweep.sh`, BENCHMARKS.md).
fn cold_solve_hp(c: &mut Criterion) {
    let mut g = c.benchmark_group("cold_solve_hp");
    g.sampling_mode(SamplingMode::Flat);
    g.sample_size(10);
    g.warm_up_time(Duration::from_secs(1));
    g.measurement_time(Duration::from_secs(5));
    for (n, m) in [(20, 4), (40, 8)] {
        let mut s = paper(n);
        s.scenario.discretization.intervals = m;
        g.bench_with_input(
            BenchmarkId::from_parameter(format!("{n}x{m}")),
            &s,
            |b, s| {
                b.iter(|| {
                    let sol = black_box(s).solve(&mut Silent).expect("a planar scenario");
                    assert_eq!(sol.status, bellyflop::Status::Solved, "N = {n}, M = {m}");
                    sol
                })
            },
        );
    }
    g.finish();
}

/// Warm re-plan 0.5 s along the cold plan, from the plan's own state there,
/// with the planner's conic solvers already set up (as in a guidance loop)
/// and its defaults (exact form directly, warm proximal weight).
fn warm_replan(c: &mut Criterion) {
    let mut g = c.benchmark_group("warm_replan");
    g.sampling_mode(SamplingMode::Flat);
    g.sample_size(10);
    g.warm_up_time(Duration::from_secs(1));
    g.measurement_time(Duration::from_secs(5));
    for n in [10, 20, 40] {
        let mut planner = {
            let c = paper(n);
            Planner::new(c.scenario, c.solver)
        };
        // The SCvx warm re-plan (the scenario's default method is direct).
        planner.method = bellyflop::Method::Scvx;
        planner.cold(&mut Silent);
        let plan = planner.plan.clone().expect("cold solve solved");
        let state = initial_state(&plan.state_at(0.5));
        g.bench_function(BenchmarkId::from_parameter(n), |b| {
            b.iter(|| {
                planner.plan = Some(plan.clone());
                let sol = planner.replan(black_box(&state), 0.5, &mut Silent).unwrap();
                assert_eq!(sol.status, bellyflop::Status::Solved, "N = {n}");
                sol
            })
        });
    }
    g.finish();
}

/// One subproblem: assemble at the straight-line guess, then solve with Clarabel.
fn subproblem(c: &mut Criterion) {
    let mut g = c.benchmark_group("subproblem");
    g.sampling_mode(SamplingMode::Flat);
    g.sample_size(10);
    g.warm_up_time(Duration::from_secs(1));
    g.measurement_time(Duration::from_secs(5));
    for n in [20, 40] {
        let (tr, guess, radius) = first_subproblem(n);
        g.bench_function(BenchmarkId::new("fresh", n), |b| {
            b.iter(|| {
                let data = tr.assemble(black_box(&guess), radius, 0.0);
                tr.solve(&data).expect("subproblem solves")
            })
        });
        // The same subproblem through a solver set up once and updated in place.
        let mut conic = ConicSolver::new();
        g.bench_function(BenchmarkId::new("in_place", n), |b| {
            b.iter(|| {
                let data = tr.assemble(black_box(&guess), radius, 0.0);
                tr.solve_with(&mut conic, &data).expect("subproblem solves")
            })
        });
    }
    g.finish();
}

/// Subproblem assembly alone (linearization, sparse matrices, cones).
fn assembly(c: &mut Criterion) {
    let mut g = c.benchmark_group("assembly");
    g.sample_size(20);
    g.warm_up_time(Duration::from_secs(1));
    g.measurement_time(Duration::from_secs(3));
    for n in [20, 40] {
        let (tr, guess, radius) = first_subproblem(n);
        g.bench_function(BenchmarkId::from_parameter(n), |b| {
            b.iter(|| tr.assemble(black_box(&guess), radius, 0.0))
        });
    }
    g.finish();
}

/// The second-order correction of a candidate (`Transcription::
/// second_order_correction`: defects, one sparse LDLᵀ factorization and
/// solve), against the subproblem whose candidate it corrects.
fn correction(c: &mut Criterion) {
    let mut g = c.benchmark_group("correction");
    g.sample_size(20);
    g.warm_up_time(Duration::from_secs(1));
    g.measurement_time(Duration::from_secs(3));
    for n in [20, 40] {
        let (tr, guess, radius) = first_subproblem(n);
        let data = tr.assemble(&guess, radius, 0.0);
        let sub = tr.solve(&data).expect("subproblem solves");
        g.bench_function(BenchmarkId::from_parameter(n), |b| {
            b.iter(|| {
                tr.second_order_correction(black_box(&data), black_box(&sub))
                    .expect("the correction factors")
            })
        });
    }
    g.finish();
}

/// One Jacobian evaluation (`linearize`: f, ∂f/∂x, ∂f/∂u by forward-mode AD)
/// at the straight-line guess's middle node, in both formulations.
fn jacobian(c: &mut Criterion) {
    let mut g = c.benchmark_group("jacobian");
    g.warm_up_time(Duration::from_secs(1));
    g.measurement_time(Duration::from_secs(2));
    for form in [Formulation::Paper, Formulation::Exact] {
        let mut s = paper(20);
        s.solver.formulation = form;
        let tr = Transcription::new(&s.scenario, &s.solver);
        let d = &s.scenario.discretization;
        let guess = straight_line(&tr, d.tf_guess_s, d.final_mass_guess_kg);
        let (x, u) = (guess.x[10], guess.u[10]);
        g.bench_function(BenchmarkId::from_parameter(format!("{form:?}")), |b| {
            b.iter(|| linearize(&tr.model, form, black_box(&x), black_box(&u)))
        });
    }
    g.finish();
}

/// LGR setup: nodes, weights and the differentiation matrix.
fn lgr_setup(c: &mut Criterion) {
    let mut g = c.benchmark_group("lgr_setup");
    g.warm_up_time(Duration::from_secs(1));
    g.measurement_time(Duration::from_secs(2));
    for n in [20, 40, 100] {
        g.bench_function(BenchmarkId::from_parameter(n), |b| {
            b.iter(|| Lgr::new(black_box(n)))
        });
    }
    g.finish();
}

criterion_group!(
    benches,
    lgr_setup,
    jacobian,
    assembly,
    correction,
    subproblem,
    cold_solve,
    cold_solve_hp,
    warm_replan
);
criterion_main!(benches);
