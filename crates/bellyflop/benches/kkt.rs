//! The direct method's Newton (KKT) solve against QDLDL on the same matrix,
//! and the direct method's cold solve against SCvx's (issue 15).
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

use bellyflop::input::settings::DirectSettings;
use bellyflop::method::direct::kkt::{KktMatrix, KktSolver};
use bellyflop::method::direct::nlp::{Nlp, NL, NS};
use bellyflop::method::direct::{self, lagrangian_blocks};
use bellyflop::method::observer::Silent;
use bellyflop::{Case, Method, Status};
use clarabel::algebra::CscMatrix;
use clarabel::qdldl::{QDLDLFactorisation, QDLDLSettingsBuilder};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode};

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
    let settings = DirectSettings {
        max_iterations: 5,
        ..DirectSettings::default()
    };
    let r = direct::solve_nlp(&nlp, &w0, None, &settings, &mut Silent);
    let derivs: Vec<_> = (0..nlp.n)
        .map(|i| nlp.point_derivatives(&r.w, i, &r.lambda[i * NS..(i + 1) * NS]))
        .collect();
    let mut kkt = KktMatrix::zeros(&nlp);
    lagrangian_blocks(&nlp, &r.w, &r.lambda, &derivs, &mut kkt);
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
    (nlp, kkt)
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
        let rw: Vec<f64> = (0..nlp.n_var())
            .map(|j| {
                if nlp.is_fixed(j) {
                    0.0
                } else {
                    (j as f64 * 0.3).sin()
                }
            })
            .collect();
        let rl: Vec<f64> = (0..nlp.n_con()).map(|r| (r as f64 * 0.7).cos()).collect();
        let mut solver = KktSolver::new(&nlp);
        let (mut xw, mut xl) = (vec![0.0; nlp.n_var()], vec![0.0; nlp.n_con()]);
        g.bench_with_input(BenchmarkId::new("structured", &id), &n, |b, _| {
            b.iter(|| {
                for k in 0..=nlp.n {
                    black_box(solver.factor_node(k, &kkt.w[k], 0.0));
                }
                black_box(solver.factor_reduced(&kkt));
                solver.solve(&nlp, &kkt, &rw, &rl, &mut xw, &mut xl);
                black_box(xw[0])
            })
        });
        let (nf, dim, ri, ci, vv) = kkt.upper_triplets(&nlp);
        let k = CscMatrix::new_from_triplets(dim, dim, ri, ci, vv);
        let mut signs = vec![1i8; nf];
        signs.resize(dim, -1);
        let opts = QDLDLSettingsBuilder::default()
            .Dsigns(signs)
            .build()
            .expect("QDLDL settings");
        let mut ldl = QDLDLFactorisation::new(&k, Some(opts)).expect("QDLDL factors K");
        let mut rhs = vec![0.0; dim];
        g.bench_with_input(BenchmarkId::new("qdldl", &id), &n, |b, _| {
            b.iter(|| {
                ldl.refactor().expect("QDLDL refactors K");
                rhs.iter_mut()
                    .enumerate()
                    .for_each(|(i, v)| *v = (i as f64 * 0.3).sin());
                ldl.solve(&mut rhs);
                black_box(rhs[0])
            })
        });
        println!(
            "N = {n} over {intervals} intervals: K is {dim} square, {} stored nonzeros; QDLDL's L has {} nonzeros; reduced system {} square ({}); last path {:?}",
            k.nnz(),
            ldl.nnzL(),
            7 * nlp.n + 2,
            if intervals == 1 { "dense" } else { "block-tridiagonal" },
            solver.reduced_path(),
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
                    let sol = black_box(s).solve(&mut Silent);
                    assert_eq!(sol.status, Status::Solved, "N = {n}");
                    sol
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, kkt_solve, cold_solve);
criterion_main!(benches);
