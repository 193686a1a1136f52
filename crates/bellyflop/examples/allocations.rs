//! Heap allocations per SCvx iteration (issue 5) and per iteration of the
//! direct method (issue 15), counted by a global allocator wrapper around
//! the system allocator.
//!
//! `cargo run --release -p bellyflop --example allocations`
//!
//! For the paper's case at each N: a cold solve (allocations and bytes per
//! iteration, Clarabel setups), and a warm re-plan 0.5 s along the plan with
//! the planner's solvers already set up (so only in-place updates remain).

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

use bellyflop::guidance::planner::{initial_state, Planner};
use bellyflop::input::settings::DirectSettings;
use bellyflop::method::direct;
use bellyflop::method::direct::nlp::Nlp;
use bellyflop::method::observer::Silent;
use bellyflop::Case;

struct Counting;
static ALLOCS: AtomicUsize = AtomicUsize::new(0);
static BYTES: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCS.fetch_add(1, Relaxed);
        BYTES.fetch_add(layout.size(), Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCS.fetch_add(1, Relaxed);
        BYTES.fetch_add(new_size, Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn count<T>(f: impl FnOnce() -> T) -> (T, usize, usize) {
    let (a0, b0) = (ALLOCS.load(Relaxed), BYTES.load(Relaxed));
    let out = f();
    (out, ALLOCS.load(Relaxed) - a0, BYTES.load(Relaxed) - b0)
}

/// The direct method: a cold solve's allocations in all (setup included),
/// and per iteration as the difference between solves stopped after k and
/// k + 10 iterations from the same start.
fn direct_rows() {
    println!("  N  direct: allocations in a cold solve (its), and per iteration after setup");
    for n in [10, 20, 40] {
        let mut s = Case::paper();
        s.scenario.discretization.nodes = n;
        // The raw collocation solve (the pipeline's certificate and
        // accuracy check included), without the polish, which is counted
        // apart below.
        s.solver.polish = false;
        let (sol, a, b) = count(|| {
            bellyflop::solve(&s.scenario, &s.solver, &mut Silent).expect("a planar scenario")
        });
        s.solver.polish = true;
        let (polished, pa, pb) = count(|| {
            bellyflop::solve(&s.scenario, &s.solver, &mut Silent).expect("a planar scenario")
        });
        assert!(polished.controls_flown.is_some(), "{}", polished.message);
        let nlp = Nlp::new(&s.scenario, &s.solver);
        let d = &s.scenario.discretization;
        let w0 = nlp.straight_line(d.tf_guess_s, d.final_mass_guess_kg);
        let run = |k: usize| {
            let settings = DirectSettings {
                max_iterations: k,
                ..DirectSettings::default()
            };
            count(|| direct::solve_nlp(&nlp, &w0, None, &settings, &mut Silent))
        };
        let ((r5, a5, _), (r15, a15, _)) = (run(5), run(15));
        assert_eq!((r5.history.len(), r15.history.len()), (5, 15));
        println!(
            "{n:>3}  cold {:>4} its: {a:>6} allocations, {:>6} kB; iterations 6-15: {:.1} allocations per iteration; the polish adds {} allocations, {} kB",
            sol.iterations,
            b / 1024,
            (a15 - a5) as f64 / 10.0,
            pa.saturating_sub(a),
            pb.saturating_sub(b) / 1024
        );
    }
}

fn main() {
    direct_rows();
    println!("  N  run        its  allocs/it  kB/it");
    for n in [10, 20, 40] {
        let mut s = Case::paper();
        s.scenario.discretization.nodes = n;
        s.solver.method = bellyflop::Method::Scvx;
        let mut planner = Planner::new(s.scenario, s.solver);
        // The SCvx warm re-plan (the scenario's default method is direct).
        planner.method = bellyflop::Method::Scvx;
        let (cold, a, b) = count(|| planner.cold(&mut Silent));
        let it = cold.iterations.max(1);
        println!(
            "{n:>3}  cold    {:>6}  {:>9}  {:>5}",
            it,
            a / it,
            b / it / 1024
        );
        let plan = planner.plan.clone().expect("cold solve solved");
        // First re-plan sets up the planner's solvers; the second reuses them.
        for label in ["warm #1", "warm #2"] {
            let state = initial_state(&plan.state_at(0.5));
            let (warm, a, b) = count(|| planner.replan(&state, 0.5, &mut Silent).unwrap());
            let it = warm.iterations.max(1);
            println!(
                "{n:>3}  {label} {:>6}  {:>9}  {:>5}",
                it,
                a / it,
                b / it / 1024
            );
            planner.plan = Some(plan.clone());
        }
    }
}
