//! Heap allocations inside `bf_solve` and `bf_replan` after setup
//! (`bf_solver_new`, on the same thread), counted by a global allocator
//! wrapper (as `crates/bellyflop/examples/allocations.rs` counts the
//! library's): none, on the converging path of the direct method. It counts
//! the calling thread's allocations (the solves start no thread), so that
//! the test harness's own, on its main thread, do not count.
//!
//! `cargo test -p bellyflop-c --test allocations -- --nocapture` prints
//! the counts.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use bellyflop_c::ffi::*;
use bellyflop_c::types::{bf_error, bf_node, bf_solution, bf_state, bf_status};

struct Counting;

thread_local! {
    /// This thread's allocations (a const-initialized Cell: reading it
    /// neither allocates nor registers a destructor).
    static ALLOCS: Cell<usize> = const { Cell::new(0) };
}

/// One more allocation on this thread (none counted while the thread's
/// locals are being torn down).
fn count() {
    let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
}

// SAFETY: every call forwards to the system allocator unchanged; the
// counter is thread-local.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: forwarded with the caller's layout.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded with the caller's pointer and layout.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        // SAFETY: forwarded with the caller's arguments.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations_in(f: impl FnOnce()) -> usize {
    let before = ALLOCS.with(Cell::get);
    f();
    ALLOCS.with(Cell::get) - before
}

/// Allocations of a cold `bf_solve`, of each of 20 `bf_replan` calls from
/// states along the plan, measured off it (a navigation error of
/// decimetres and decimetres per second), and of a second cold `bf_solve`,
/// on the paper's case, or on `scenario` (given to the C API as its TOML).
fn counts(scenario: Option<&bellyflop::input::scenario::Scenario>) -> (usize, Vec<usize>, usize) {
    let mut problem = std::ptr::null_mut();
    match scenario {
        None => assert_eq!(bf_problem_paper(&mut problem), bf_error::Ok),
        Some(s) => {
            let text = std::ffi::CString::new(toml::to_string(s).unwrap()).unwrap();
            assert_eq!(
                bf_problem_from_toml_str(text.as_ptr(), &mut problem),
                bf_error::Ok
            );
        }
    }
    let settings = bf_settings_default();
    let mut solver = std::ptr::null_mut();
    assert_eq!(bf_solver_new(problem, &settings, &mut solver), bf_error::Ok);
    let mut n = 0;
    assert_eq!(bf_solver_node_count(solver, &mut n), bf_error::Ok);
    let mut nodes = vec![bf_node::default(); n];
    let mut sol = bf_solution {
        nodes: nodes.as_mut_ptr(),
        node_capacity: n,
        node_count: 0,
        status: bf_status::SolverFailed,
        iterations: 0,
        adopted: false,
        tf_s: 0.0,
        final_mass_kg: 0.0,
        solve_time_ms: 0.0,
    };
    let cold = allocations_in(|| assert_eq!(bf_solve(solver, &mut sol), bf_error::Ok));
    assert_eq!(sol.status, bf_status::Solved);
    let dt = 0.5 * sol.tf_s / 20.0;
    let mut x = bf_state::default();
    let replans = (1..=20)
        .map(|k| {
            let t = k as f64 * dt;
            assert_eq!(bf_plan_state_at(solver, t, &mut x), bf_error::Ok);
            let e = 0.1 * ((k % 5) as f64 - 2.0);
            x.x_m += 3.0 * e;
            x.z_m -= 2.0 * e;
            x.vx_mps += e;
            x.vz_mps -= 0.5 * e;
            let a = allocations_in(|| assert_eq!(bf_replan(solver, &x, t, &mut sol), bf_error::Ok));
            // The nominal path: a converged re-plan that became the plan.
            assert_eq!(sol.status, bf_status::Solved, "re-plan {k}");
            assert!(sol.adopted, "re-plan {k}");
            a
        })
        .collect();
    let again = allocations_in(|| assert_eq!(bf_solve(solver, &mut sol), bf_error::Ok));
    assert_eq!(sol.status, bf_status::Solved);
    bf_solver_free(solver);
    bf_problem_free(problem);
    (cold, replans, again)
}

/// No allocation inside a solve or a re-plan once the solver is set up.
#[test]
fn solves_and_replans_after_setup_do_not_allocate() {
    assert_none("", counts(None));
}

/// The same with the limits that the direct method holds at its nodes
/// (pitch rate, tilt, final descent; a 20 deg/s rate that binds): the rows
/// and their multipliers live in the solver's storage, so the re-plans of
/// a constrained flight allocate nothing either.
#[test]
fn constrained_solves_and_replans_after_setup_do_not_allocate() {
    let mut scenario = bellyflop::input::scenario::Scenario::paper();
    scenario.constraints = bellyflop::input::scenario::Constraints {
        max_pitch_rate_degps: Some(20.0),
        max_tilt_deg: Some(10.0),
        tilt_below_m: Some(50.0),
        final_descent_m: Some(20.0),
        final_descent_lateral_mps: Some(2.0),
        ..Default::default()
    };
    assert_none(", with limits", counts(Some(&scenario)));
}

/// Prints the counts of [`counts`] and asserts that each is 0.
fn assert_none(label: &str, (cold, replans, again): (usize, Vec<usize>, usize)) {
    println!(
        "allocations{label}: cold bf_solve {cold}; bf_replan {replans:?}; bf_solve again {again}"
    );
    assert_eq!(cold, 0, "the cold bf_solve allocated");
    assert!(
        replans.iter().all(|&a| a == 0),
        "bf_replan allocated: {replans:?}"
    );
    assert_eq!(again, 0, "the second bf_solve allocated");
}
