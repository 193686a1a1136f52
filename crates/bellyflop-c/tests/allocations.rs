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
/// on the paper's case, or on it with the `[constraints]` of `limits`
/// (TOML) when given.
fn counts(limits: Option<&str>) -> (usize, Vec<usize>, usize) {
    let mut problem = std::ptr::null_mut();
    match limits {
        None => assert_eq!(bf_problem_paper(&mut problem), bf_error::Ok),
        Some(table) => {
            let text = std::ffi::CString::new(format!("{}{table}", paper_toml())).unwrap();
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
    let (cold, replans, again) = counts(None);
    println!("allocations: cold bf_solve {cold}; bf_replan {replans:?}; bf_solve again {again}");
    assert_eq!(cold, 0, "the cold bf_solve allocated");
    assert!(
        replans.iter().all(|&a| a == 0),
        "bf_replan allocated: {replans:?}"
    );
    assert_eq!(again, 0, "the second bf_solve allocated");
}

/// The paper's scenario as TOML: `bellyflop init`'s tables without the
/// optional `[solver]` ones, from the library's own paper case.
fn paper_toml() -> String {
    let s = bellyflop::input::scenario::Scenario::paper();
    let (v, e, i, t, d) = (
        &s.vehicle,
        &s.environment,
        &s.initial,
        &s.terminal,
        &s.discretization,
    );
    format!(
        "name = \"paper\"\n[vehicle]\ndry_mass_kg = {:?}\nlength_m = {:?}\nradius_m = {:?}\ncg_m = {:?}\ncp_m = {:?}\nmax_thrust_n = {:?}\nmin_thrust_n = {:?}\nisp_s = {:?}\nmax_gimbal_deg = {:?}\nmax_gimbal_rate_degps = {:?}\ndrag_coefficient_kgpm = {:?}\n[environment]\ng0_mps2 = {:?}\nwind_x_mps = {:?}\n[initial]\nx_m = {:?}\nz_m = {:?}\nvx_mps = {:?}\nvz_mps = {:?}\ntheta_deg = {:?}\npitch_rate_degps = {:?}\nmass_kg = {:?}\ngimbal_deg = {:?}\n[terminal]\nx_m = {:?}\nz_m = {:?}\nvx_mps = {:?}\nvz_mps = {:?}\ntheta_deg = {:?}\npitch_rate_degps = {:?}\n[discretization]\nnodes = {}\nintervals = {}\n",
        v.dry_mass_kg, v.length_m, v.radius_m, v.cg_m, v.cp_m, v.max_thrust_n, v.min_thrust_n,
        v.isp_s, v.max_gimbal_deg, v.max_gimbal_rate_degps, v.drag_coefficient_kgpm,
        e.g0_mps2, e.wind_x_mps,
        i.x_m, i.z_m, i.vx_mps, i.vz_mps, i.theta_deg, i.pitch_rate_degps, i.mass_kg, i.gimbal_deg,
        t.x_m, t.z_m, t.vx_mps, t.vz_mps, t.theta_deg, t.pitch_rate_degps,
        d.nodes, d.intervals,
    )
}

/// The same with the limits that the direct method holds at its nodes
/// (pitch rate, tilt, final descent; a 20 deg/s rate that binds): the rows
/// and their multipliers live in the solver's storage, so the re-plans of
/// a constrained flight allocate nothing either.
#[test]
fn constrained_solves_and_replans_after_setup_do_not_allocate() {
    let limits = "[constraints]\nmax_pitch_rate_degps = 20.0\nmax_tilt_deg = 10.0\ntilt_below_m = 50.0\nfinal_descent_m = 20.0\nfinal_descent_lateral_mps = 2.0\n";
    let (cold, replans, again) = counts(Some(limits));
    println!("allocations, with limits: cold bf_solve {cold}; bf_replan {replans:?}; bf_solve again {again}");
    assert_eq!(cold, 0, "the cold bf_solve allocated");
    assert!(
        replans.iter().all(|&a| a == 0),
        "bf_replan allocated: {replans:?}"
    );
    assert_eq!(again, 0, "the second bf_solve allocated");
}
