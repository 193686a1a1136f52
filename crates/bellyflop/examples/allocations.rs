//! Heap allocations per SCvx iteration (issue 5), counted by a global
//! allocator wrapper around the system allocator.
//!
//! `cargo run --release -p bellyflop --example allocations`
//!
//! For the paper's case at each N: a cold solve (allocations and bytes per
//! iteration, Clarabel setups), and a warm re-plan 0.5 s along the plan with
//! the planner's solvers already set up (so only in-place updates remain).

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

use bellyflop::replan::{initial_state, Planner};
use bellyflop::scvx::Silent;
use bellyflop::Scenario;

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

fn main() {
    println!("  N  run        its  allocs/it  kB/it");
    for n in [10, 20, 40] {
        let mut s = Scenario::paper();
        s.discretization.nodes = n;
        let mut planner = Planner::new(s);
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
