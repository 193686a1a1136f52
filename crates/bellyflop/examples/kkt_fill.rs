//! Fill-in of the interior-point KKT factorization of one subproblem (issue 5).
//!
//! `cargo run --release -p bellyflop --example kkt_fill [--drop x,z,...]`
//!
//! Builds the first subproblem of a cold solve (straight-line reference, unit
//! trust radius) in the paper's and the exact formulation at N = 20 and 40,
//! forms the quasi-definite matrix [I Aᵀ; A −I] with A's pattern, orders it
//! with AMD exactly as Clarabel's QDLDL does (dense threshold 1.5), and
//! reports nnz(L) and the time of one numeric factorization (mean of 20).
//!
//! `--drop` removes the collocation-defect rows of the named states (x, z,
//! vx, vz, theta, w, omega, delta) before factoring. The result is no longer
//! the subproblem; it bounds what any reformulation that takes those states
//! out of the dense coupling (condensing, integral form) could save.

use std::time::Instant;

use bellyflop::method::scvx::straight_line;
use bellyflop::method::scvx::transcription::Transcription;
use bellyflop::problem::dynamics::NX;
use bellyflop::{Case, Formulation};
use clarabel::algebra::CscMatrix;
use clarabel::qdldl::{QDLDLFactorisation, QDLDLSettings};

const NAMES: [&str; NX] = ["x", "z", "vx", "vz", "theta", "w", "omega", "delta"];

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let drop: Vec<usize> = match args.iter().position(|a| a == "--drop") {
        Some(i) => args
            .get(i + 1)
            .map(|v| v.split(',').collect::<Vec<_>>())
            .unwrap_or_default()
            .iter()
            .map(|name| {
                NAMES
                    .iter()
                    .position(|n| n == name)
                    .unwrap_or_else(|| panic!("unknown state {name:?}; one of {NAMES:?}"))
            })
            .collect(),
        None => vec![],
    };
    println!("  N  formulation  vars  rows  nnz(A)  nnz(L)  factor [ms]   (defect rows dropped: {drop:?})");
    for n in [20usize, 40] {
        for form in [Formulation::Paper, Formulation::Exact] {
            let mut s = Case::paper();
            s.scenario.discretization.nodes = n;
            s.solver.formulation = form;
            let tr = Transcription::new(&s.scenario, &s.solver);
            let d = &s.scenario.discretization;
            let guess = straight_line(&tr, d.tf_guess_s, d.final_mass_guess_kg);
            let data = tr.assemble(&guess, 1.0, 0.0);
            let (m, nv) = (data.a.m, data.a.n);
            // Upper triangle of [I Aᵀ; A −I]. The defect rows come first in A,
            // NX per collocation point (`Transcription::assemble`).
            let (mut ri, mut ci, mut vv) = (vec![], vec![], vec![]);
            for j in 0..nv {
                ri.push(j);
                ci.push(j);
                vv.push(1.0);
                for p in data.a.colptr[j]..data.a.colptr[j + 1] {
                    let r = data.a.rowval[p];
                    if r < NX * n && drop.contains(&(r % NX)) {
                        continue;
                    }
                    ri.push(j);
                    ci.push(nv + r);
                    vv.push(data.a.nzval[p]);
                }
            }
            for i in 0..m {
                ri.push(nv + i);
                ci.push(nv + i);
                vv.push(-1.0);
            }
            let nnz_a = ri.len() - nv - m;
            let kkt = CscMatrix::new_from_triplets(nv + m, nv + m, ri, ci, vv);
            let mut signs = vec![1i8; nv];
            signs.extend(vec![-1i8; m]);
            let opts = QDLDLSettings {
                Dsigns: Some(signs),
                amd_dense_scale: 1.5,
                ..Default::default()
            };
            let mut f = QDLDLFactorisation::new(&kkt, Some(opts)).expect("quasi-definite");
            let reps = 20;
            let t = Instant::now();
            for _ in 0..reps {
                f.refactor().expect("quasi-definite");
            }
            let ms = t.elapsed().as_secs_f64() * 1e3 / reps as f64;
            println!(
                "{n:>3}  {:<11} {nv:>5} {m:>5} {nnz_a:>7} {:>7} {ms:>12.3}",
                format!("{form:?}"),
                f.nnzL()
            );
        }
    }
}
