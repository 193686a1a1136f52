//! The direct method's Newton (KKT) solve against QDLDL on the same matrix,
//! and the direct method's cold solve against SCvx's (issue 15); and the
//! same solve at the 6-DoF model's sizes (issue 38).
//!
//! `cargo bench -p bellyflop --bench kkt`
//!
//! The matrix is the Newton system at the 5th iterate of a cold direct solve
//! of the paper's case: the Hessian of the Lagrangian, the barrier terms
//! μ/s² (μ = 0.1, the iterate's barrier) and the defect Jacobian.
//! - `kkt/structured`: our factorization (x_1 … x_{N−1} and their defects
//!   eliminated, the node blocks, then the dense (7N + 2)-square reduced
//!   system by faer's unpivoted LDLᵀ, Bunch–Kaufman as fallback) and one
//!   solve. It does not read x's rows of W, which the elimination needs to be
//!   zero: here they hold the static 1e-9 that QDLDL's matrix keeps;
//! - `kkt/qdldl`: Clarabel's QDLDL, numeric refactorization (its symbolic
//!   AMD analysis done once, outside the loop) and one solve, of the same
//!   matrix's upper triangle. QDLDL does not pivot: on this indefinite
//!   matrix it runs, but it reports no inertia, which the interior-point
//!   method needs; the comparison is of cost.

use std::hint::black_box;
use std::time::Duration;

use bellyflop::collocation::derivatives::{Differentiable, PointDerivatives};
use bellyflop::collocation::mesh::Mesh;
use bellyflop::input::scenario::Scenario;
use bellyflop::input::settings::DirectSettings;
use bellyflop::method::direct::kkt::{KktMatrix, KktSolver, Layout, ReducedPath};
use bellyflop::method::direct::nlp::{Nlp, Transcription};
use bellyflop::method::direct::six_dof::{solve_cold, Nlp6, NL as NL6, NS as NS6};
use bellyflop::method::direct::{self, lagrangian_blocks};
use bellyflop::method::observer::Silent;
use bellyflop::problem::six_dof::{self, SixDof};
use bellyflop::{Case, Method, Status};
use clarabel::algebra::CscMatrix;
use clarabel::qdldl::{QDLDLFactorisation, QDLDLSettingsBuilder};
use criterion::measurement::WallTime;
use criterion::{
    criterion_group, criterion_main, BenchmarkGroup, BenchmarkId, Criterion, SamplingMode,
};

fn paper(n: usize) -> Case {
    let mut s = Case::paper();
    s.scenario.discretization.nodes = n;
    s
}

/// The Newton system at the 5th iterate of a cold direct solve, on `n`
/// points over `intervals` LGR intervals.
fn system(n: usize, intervals: usize) -> (Nlp, KktMatrix) {
    let mut s = paper(n);
    s.scenario.discretization.intervals = intervals;
    let nlp = Nlp::new(&s.scenario, &s.solver);
    let d = &s.scenario.discretization;
    let w0 = nlp.straight_line(d.tf_guess_s, d.final_mass_guess_kg);
    let kkt = newton_system(&nlp, &w0);
    (nlp, kkt)
}

/// The Newton system of `nlp` at the 5th iterate of its solve from `w0`:
/// the Hessian of the Lagrangian, the barrier terms μ/s² (μ = 0.1) and the
/// defect Jacobian.
fn newton_system<M: Differentiable, const NS: usize, const NL: usize>(
    nlp: &Transcription<M, NS, NL>,
    w0: &[f64],
) -> KktMatrix<NS, NL> {
    let settings = DirectSettings {
        max_iterations: 5,
        ..DirectSettings::default()
    };
    let r = direct::solve_nlp(nlp, w0, None, &settings, &mut Silent);
    let derivs: Vec<_> = (0..nlp.n)
        .map(|i| {
            let mut d = PointDerivatives::default();
            nlp.point_derivatives(&r.w, i, &r.lambda[i * NS..(i + 1) * NS], &mut d);
            d
        })
        .collect();
    let mut kkt = KktMatrix::zeros(nlp);
    lagrangian_blocks(nlp, &r.w, &r.lambda, &derivs, &mut kkt);
    let mu = 0.1;
    let sigma = |j: usize| {
        let mut s = 1e-9;
        if !nlp.is_fixed(j) {
            if nlp.lo[j].is_finite() {
                s += mu / (r.w[j] - nlp.lo[j]).powi(2);
            }
            if nlp.hi[j].is_finite() {
                s += mu / (nlp.hi[j] - r.w[j]).powi(2);
            }
        }
        s
    };
    for k in 0..=nlp.n {
        for sl in 0..NL {
            kkt.w[k][sl][sl] += sigma(nlp.idx(k, sl));
        }
    }
    kkt.h_tt = sigma(nlp.tf_idx());
    kkt
}

/// Benchmarks one Newton system two ways, as `structured/{id}` (every
/// node block, R, one solve) and `qdldl/{id}` (QDLDL's numeric
/// refactorization of the same matrix and one solve); returns K's
/// dimension, its stored nonzeros, those of QDLDL's L and R's last path.
fn structured_and_qdldl<const NS: usize, const NL: usize>(
    g: &mut BenchmarkGroup<WallTime>,
    id: &str,
    layout: &impl Layout<NS, NL>,
    kkt: &KktMatrix<NS, NL>,
) -> (usize, usize, usize, ReducedPath) {
    let (nv, nc) = (layout.n_var(), layout.n_con());
    let rw: Vec<f64> = (0..nv)
        .map(|j| {
            if layout.is_fixed(j) {
                0.0
            } else {
                (j as f64 * 0.3).sin()
            }
        })
        .collect();
    let rl: Vec<f64> = (0..nc).map(|r| (r as f64 * 0.7).cos()).collect();
    let mut solver = KktSolver::new(layout);
    let (mut xw, mut xl) = (vec![0.0; nv], vec![0.0; nc]);
    g.bench_function(BenchmarkId::new("structured", id), |b| {
        b.iter(|| {
            for k in 0..=layout.n() {
                black_box(solver.factor_node(k, &kkt.w[k], 0.0));
            }
            black_box(solver.factor_reduced(kkt));
            solver.solve(layout, kkt, &rw, &rl, &mut xw, &mut xl);
            black_box(xw[0])
        })
    });
    let (nf, dim, ri, ci, vv) = kkt.upper_triplets(layout);
    let k = CscMatrix::new_from_triplets(dim, dim, ri, ci, vv);
    let mut signs = vec![1i8; nf];
    signs.resize(dim, -1);
    let opts = QDLDLSettingsBuilder::default()
        .Dsigns(signs)
        .build()
        .expect("QDLDL settings");
    let mut ldl = QDLDLFactorisation::new(&k, Some(opts)).expect("QDLDL factors K");
    let mut rhs = vec![0.0; dim];
    g.bench_function(BenchmarkId::new("qdldl", id), |b| {
        b.iter(|| {
            ldl.refactor().expect("QDLDL refactors K");
            rhs.iter_mut()
                .enumerate()
                .for_each(|(i, v)| *v = (i as f64 * 0.3).sin());
            ldl.solve(&mut rhs);
            black_box(rhs[0])
        })
    });
    (dim, k.nnz(), ldl.nnzL(), solver.reduced_path())
}

fn kkt_solve(c: &mut Criterion) {
    let mut g = c.benchmark_group("kkt");
    g.warm_up_time(Duration::from_secs(1));
    g.measurement_time(Duration::from_secs(3));
    // The global mesh (dense R) and hp meshes of 8 intervals (banded R).
    for (n, intervals) in [(20, 1), (40, 1), (40, 8), (80, 8)] {
        let (nlp, kkt) = system(n, intervals);
        let id = if intervals == 1 {
            n.to_string()
        } else {
            format!("{n}_over_{intervals}")
        };
        let (dim, nnz, nnz_l, path) = structured_and_qdldl(&mut g, &id, &nlp, &kkt);
        println!(
            "N = {n} over {intervals} intervals: K is {dim} square, {nnz} stored nonzeros; QDLDL's L has {nnz_l} nonzeros; reduced system {} square ({}); last path {path:?}",
            7 * nlp.n + 2,
            if intervals == 1 { "dense" } else { "block-tridiagonal" },
        );
    }
    g.finish();
}

/// Cold solves of the paper's case, direct method and SCvx side by side.
fn cold_solve(c: &mut Criterion) {
    let mut g = c.benchmark_group("method_cold_solve");
    g.sampling_mode(SamplingMode::Flat);
    g.sample_size(10);
    g.warm_up_time(Duration::from_secs(1));
    g.measurement_time(Duration::from_secs(4));
    for n in [20, 40] {
        for method in [Method::Direct, Method::Scvx] {
            let mut s = paper(n);
            s.solver.method = method;
            g.bench_with_input(BenchmarkId::new(method.as_str(), n), &s, |b, s| {
                b.iter(|| {
                    let sol = black_box(s).solve(&mut Silent).expect("a planar scenario");
                    assert_eq!(sol.status, Status::Solved, "N = {n}");
                    sol
                })
            });
        }
    }
    g.finish();
}

/// The first seeded 3-D state of IPOPT's 6-DoF fixture
/// (`tests/data/six_dof_answers.json`), and the three states' names and
/// starts.
fn six_dof_starts() -> Vec<(String, [f64; NS6])> {
    let data: serde_json::Value =
        serde_json::from_str(include_str!("../tests/data/six_dof_answers.json")).unwrap();
    data["answers"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| {
            let start: Vec<f64> = a["start"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            (
                a["name"].as_str().unwrap().to_string(),
                start.try_into().unwrap(),
            )
        })
        .collect()
}

/// The 6-DoF transcription of `start` on `n` points over `intervals`.
fn six_dof_nlp(start: [f64; NS6], n: usize, intervals: usize) -> Nlp6 {
    let s = Scenario::paper();
    let model = SixDof::new(&s.vehicle, &s.environment);
    Nlp6::six_dof(model, Mesh::uniform(n, intervals), start, &s.terminal)
}

/// The 6-DoF Newton system at the 5th iterate of the solve of the
/// fixture's first state from the straight line.
fn six_dof_system(n: usize, intervals: usize) -> (Nlp6, KktMatrix<NS6, NL6>) {
    let (_, start) = six_dof_starts().remove(0);
    let nlp = six_dof_nlp(start, n, intervals);
    let w0 = nlp.straight_line(12.0, start[six_dof::sx::M] - 5000.0);
    let kkt = newton_system(&nlp, &w0);
    (nlp, kkt)
}

/// The structured solve and QDLDL at the 6-DoF model's sizes (issue 38),
/// beside the planar `kkt` group: its per-iteration cost decides whether a
/// 6-DoF direct solve can be several times faster than IPOPT's.
fn kkt_six_dof(c: &mut Criterion) {
    let mut g = c.benchmark_group("kkt_six_dof");
    g.warm_up_time(Duration::from_secs(1));
    g.measurement_time(Duration::from_secs(3));
    for (n, intervals) in [(20, 1), (40, 8)] {
        let (nlp, kkt) = six_dof_system(n, intervals);
        let id = if intervals == 1 {
            n.to_string()
        } else {
            format!("{n}_over_{intervals}")
        };
        let (dim, _, nnz_l, path) = structured_and_qdldl(&mut g, &id, &nlp, &kkt);
        println!(
            "6-DoF, N = {n} over {intervals} intervals: K is {dim} square; QDLDL's L has {nnz_l} nonzeros; reduced system {} square; last path {path:?}",
            (NS6 - 1) * n + 2,
        );
    }
    g.finish();
}

/// The 6-DoF cold solve (`six_dof::solve_cold`: the coarse start, then
/// N = 20) of the three seeded 3-D states of IPOPT's fixture. The side by
/// side with IPOPT on 100 states is `bench/six_dof_vs_ipopt.py`.
fn six_dof_cold_solve(c: &mut Criterion) {
    let mut g = c.benchmark_group("six_dof_cold_solve");
    g.sampling_mode(SamplingMode::Flat);
    g.sample_size(10);
    g.warm_up_time(Duration::from_secs(1));
    g.measurement_time(Duration::from_secs(3));
    let settings = DirectSettings::default();
    for (name, start) in six_dof_starts() {
        g.bench_function(BenchmarkId::new("direct", &name), |b| {
            b.iter(|| {
                let nlp = six_dof_nlp(start, 20, 1);
                let r = solve_cold(
                    &nlp,
                    12.0,
                    start[six_dof::sx::M] - 5000.0,
                    &settings,
                    &mut Silent,
                );
                assert_eq!(r.status, Status::Solved, "{name}");
                black_box(r)
            })
        });
    }
    g.finish();
}

criterion_group!(
    benches,
    kkt_solve,
    kkt_six_dof,
    cold_solve,
    six_dof_cold_solve
);
criterion_main!(benches);
