//! The `extern "C"` functions: the only `unsafe` of the crate. Each entry
//! point checks every pointer for NULL, runs the safe code of `engine` under
//! `catch_unwind` (a panic becomes `BF_ERROR_PANIC`, never an unwind into
//! C), and keeps the message of a failure for `bf_last_error`.
#![allow(non_camel_case_types)]
// These are C entry points: a C caller cannot see `unsafe`, every pointer is
// checked for NULL before use, and the caller's contract (a non-NULL pointer
// is valid for the stated length) is in the header's comments.
#![allow(clippy::not_unsafe_ptr_arg_deref)]

use std::ffi::{c_char, CStr};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::ptr::{addr_of, addr_of_mut};

use crate::engine::{self, Answer, FlightSolver, Problem};
use crate::error::{last_error_ptr, set_last_error, Failure};
use crate::types::{bf_error, bf_node, bf_settings, bf_solution, bf_state, bf_status};

/// A landing problem: a scenario and its solver settings. Opaque; made by
/// `bf_problem_paper`, `bf_problem_from_toml_str` or `bf_problem_from_file`,
/// released by `bf_problem_free`.
pub struct bf_problem(Problem);

/// A flight loop's solver: its workspaces, its current plan and the
/// warm-start state of its method. Opaque; made by `bf_solver_new`,
/// released by `bf_solver_free`.
pub struct bf_solver(FlightSolver);

/// Run `f` with panics caught: its failure's code (and message kept for
/// `bf_last_error`), `BF_ERROR_PANIC` for a panic, or `BF_ERROR_OK`.
pub(crate) fn guard(f: impl FnOnce() -> Result<(), Failure>) -> bf_error {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(())) => bf_error::Ok,
        Ok(Err(failure)) => {
            set_last_error(&failure.message);
            failure.code
        }
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "a panic without a message".to_string());
            set_last_error(&format!(
                "internal error (panic caught at the C boundary): {what}"
            ));
            bf_error::Panic
        }
    }
}

/// `p` as a shared reference, or the NULL failure naming `argument`.
///
/// # Safety
/// `p` is NULL or points to a live, properly aligned `T` that nothing
/// mutates for the lifetime `'a`.
unsafe fn shared<'a, T>(p: *const T, argument: &str) -> Result<&'a T, Failure> {
    // SAFETY: the caller's contract above; NULL is turned into an error.
    unsafe { p.as_ref() }.ok_or_else(|| Failure::null(argument))
}

/// `p` as an exclusive reference, or the NULL failure naming `argument`.
///
/// # Safety
/// `p` is NULL or points to a live, properly aligned `T` that nothing else
/// reads or writes for the lifetime `'a`.
unsafe fn exclusive<'a, T>(p: *mut T, argument: &str) -> Result<&'a mut T, Failure> {
    // SAFETY: the caller's contract above; NULL is turned into an error.
    unsafe { p.as_mut() }.ok_or_else(|| Failure::null(argument))
}

/// Write `value` through the out-pointer `out`, or fail if it is NULL.
///
/// # Safety
/// `out` is NULL or valid for a write of a `T` (it need not be initialized).
unsafe fn write_out<T>(out: *mut T, value: T, argument: &str) -> Result<(), Failure> {
    if out.is_null() {
        return Err(Failure::null(argument));
    }
    // SAFETY: non-NULL, and valid for a write by the caller's contract.
    unsafe { out.write(value) };
    Ok(())
}

/// A C string argument as UTF-8 text.
///
/// # Safety
/// `p` is NULL or points to a NUL-terminated string that lives for `'a`.
unsafe fn text<'a>(p: *const c_char, argument: &str) -> Result<&'a str, Failure> {
    if p.is_null() {
        return Err(Failure::null(argument));
    }
    // SAFETY: non-NULL and NUL-terminated by the caller's contract.
    let c = unsafe { CStr::from_ptr(p) };
    c.to_str().map_err(|e| Failure {
        code: bf_error::NotUtf8,
        message: format!(
            "{argument} is not UTF-8: invalid byte at byte {}",
            e.valid_up_to()
        ),
    })
}

/// The defaults of a solver's settings: the problem's method and iteration
/// budget for `bf_solve`, 40 interior-point iterations per `bf_replan`
/// (guidance's), no wall-clock budget.
#[no_mangle]
pub extern "C" fn bf_settings_default() -> bf_settings {
    engine::default_settings()
}

/// The name of a `bf_status` value ("solved", "not_converged", …, as the
/// CLI writes them), or "unknown". A static string: do not free it.
#[no_mangle]
pub extern "C" fn bf_status_str(status: i32) -> *const c_char {
    const NAMES: [&CStr; 6] = [
        c"solved",
        c"non_physical",
        c"infeasible",
        c"not_converged",
        c"solver_failed",
        c"inaccurate",
    ];
    usize::try_from(status)
        .ok()
        .and_then(|k| NAMES.get(k))
        .map_or(c"unknown".as_ptr(), |n| n.as_ptr())
}

/// The name of a `bf_error` value ("ok", "null_pointer", …), or "unknown".
/// A static string: do not free it.
#[no_mangle]
pub extern "C" fn bf_error_str(error: i32) -> *const c_char {
    const NAMES: [&CStr; 8] = [
        c"ok",
        c"null_pointer",
        c"invalid_input",
        c"parse",
        c"io",
        c"not_utf8",
        c"buffer_too_small",
        c"panic",
    ];
    usize::try_from(error)
        .ok()
        .and_then(|k| NAMES.get(k))
        .map_or(c"unknown".as_ptr(), |n| n.as_ptr())
}

/// The message of this thread's last failed call: the field, its value and
/// the allowed range for bad input; "" before any failure. Valid until the
/// thread's next failing call; do not free it. A successful call leaves it
/// as it was.
#[no_mangle]
pub extern "C" fn bf_last_error() -> *const c_char {
    last_error_ptr()
}

/// The paper's case (`scenarios/paper.toml`) into `*out`; free it with
/// `bf_problem_free`.
#[no_mangle]
pub extern "C" fn bf_problem_paper(out: *mut *mut bf_problem) -> bf_error {
    guard(|| {
        if out.is_null() {
            return Err(Failure::null("out"));
        }
        let p = Box::into_raw(Box::new(bf_problem(Problem::paper())));
        // SAFETY: `out` is non-NULL and valid for a write (API contract).
        unsafe { write_out(out, p, "out") }
    })
}

/// A problem from a scenario file's TOML text (NUL-terminated UTF-8),
/// parsed and validated, into `*out`; free it with `bf_problem_free`.
#[no_mangle]
pub extern "C" fn bf_problem_from_toml_str(
    toml: *const c_char,
    out: *mut *mut bf_problem,
) -> bf_error {
    guard(|| {
        if out.is_null() {
            return Err(Failure::null("out"));
        }
        // SAFETY: `toml` is NULL (an error) or a NUL-terminated string, as
        // the API requires.
        let problem = Problem::from_toml_str(unsafe { text(toml, "toml") }?)?;
        let p = Box::into_raw(Box::new(bf_problem(problem)));
        // SAFETY: `out` is non-NULL and valid for a write (API contract).
        unsafe { write_out(out, p, "out") }
    })
}

/// A problem from a scenario file (a NUL-terminated UTF-8 path), read,
/// parsed and validated, into `*out`; free it with `bf_problem_free`.
#[no_mangle]
pub extern "C" fn bf_problem_from_file(path: *const c_char, out: *mut *mut bf_problem) -> bf_error {
    guard(|| {
        if out.is_null() {
            return Err(Failure::null("out"));
        }
        // SAFETY: `path` is NULL (an error) or a NUL-terminated string, as
        // the API requires.
        let path = unsafe { text(path, "path") }?;
        let problem = Problem::from_file(std::path::Path::new(path))?;
        let p = Box::into_raw(Box::new(bf_problem(problem)));
        // SAFETY: `out` is non-NULL and valid for a write (API contract).
        unsafe { write_out(out, p, "out") }
    })
}

/// Free a problem made by this API (box `p` back and drop it).
fn drop_problem(p: *mut bf_problem) {
    if !p.is_null() {
        // SAFETY: `p` came from `Box::into_raw` in this API and is freed
        // once (the caller's contract for `bf_problem_free`).
        drop(unsafe { Box::from_raw(p) });
    }
}

/// Release a problem; NULL is ignored. Solvers made from it stay valid
/// (each keeps its own copy).
#[no_mangle]
pub extern "C" fn bf_problem_free(problem: *mut bf_problem) {
    // A panic in a destructor would abort; nothing here panics, and the
    // guard keeps an unwind out of C all the same.
    let _ = guard(|| {
        drop_problem(problem);
        Ok(())
    });
}

/// Replace the problem's initial state (SI units, radians). A state out of
/// range (NaN included) gives `BF_ERROR_INVALID_INPUT`, the field named in
/// `bf_last_error`, and the problem keeps its old state.
#[no_mangle]
pub extern "C" fn bf_problem_set_initial_state(
    problem: *mut bf_problem,
    state: *const bf_state,
) -> bf_error {
    guard(|| {
        // SAFETY: each pointer is NULL (an error) or valid, the problem
        // not used elsewhere during the call (API contract).
        let (p, s) = unsafe { (exclusive(problem, "problem")?, shared(state, "state")?) };
        p.0.set_initial_state(s)
    })
}

/// The problem's initial state into `*out`.
#[no_mangle]
pub extern "C" fn bf_problem_initial_state(
    problem: *const bf_problem,
    out: *mut bf_state,
) -> bf_error {
    guard(|| {
        // SAFETY: each pointer is NULL (an error) or valid (API contract).
        unsafe {
            let p = shared(problem, "problem")?;
            write_out(out, p.0.initial_state(), "out")
        }
    })
}

/// The number of nodes of the problem's solutions (N + 1) into `*out`: the
/// least `node_capacity` of a `bf_solution`.
#[no_mangle]
pub extern "C" fn bf_problem_node_count(problem: *const bf_problem, out: *mut usize) -> bf_error {
    guard(|| {
        // SAFETY: each pointer is NULL (an error) or valid (API contract).
        unsafe {
            let p = shared(problem, "problem")?;
            write_out(out, p.0.node_count(), "out")
        }
    })
}

/// A solver for `problem` (copied: the problem may be freed after) with
/// `settings` (from `bf_settings_default`, changed), into `*out`; free it
/// with `bf_solver_free`.
///
/// This is the setup: it allocates every workspace that `bf_solve` and
/// `bf_replan` use, and does the first matrix product of the thread it
/// runs on (faer's product allocates a packing buffer per thread at its
/// first). Call it on the thread that will use the solver; on another,
/// the first solve there makes that one allocation.
#[no_mangle]
pub extern "C" fn bf_solver_new(
    problem: *const bf_problem,
    settings: *const bf_settings,
    out: *mut *mut bf_solver,
) -> bf_error {
    guard(|| {
        if out.is_null() {
            return Err(Failure::null("out"));
        }
        // SAFETY: each pointer is NULL (an error) or valid (API contract).
        let (p, s) = unsafe { (shared(problem, "problem")?, shared(settings, "settings")?) };
        let solver = Box::into_raw(Box::new(bf_solver(FlightSolver::new(&p.0, s)?)));
        // SAFETY: `out` is non-NULL and valid for a write (API contract).
        unsafe { write_out(out, solver, "out") }
    })
}

/// Release a solver and its workspaces; NULL is ignored.
#[no_mangle]
pub extern "C" fn bf_solver_free(solver: *mut bf_solver) {
    let _ = guard(|| {
        if !solver.is_null() {
            // SAFETY: `solver` came from `Box::into_raw` in
            // `bf_solver_new` and is freed once (API contract).
            drop(unsafe { Box::from_raw(solver) });
        }
        Ok(())
    });
}

/// The number of nodes of the solver's solutions (N + 1) into `*out`.
#[no_mangle]
pub extern "C" fn bf_solver_node_count(solver: *const bf_solver, out: *mut usize) -> bf_error {
    guard(|| {
        // SAFETY: each pointer is NULL (an error) or valid (API contract).
        unsafe {
            let s = shared(solver, "solver")?;
            write_out(out, s.0.node_count(), "out")
        }
    })
}

/// The caller's node buffer of `solution`, checked: non-NULL, and at least
/// `needed` nodes long.
///
/// # Safety
/// `solution` is non-NULL and valid for reads of its `nodes` and
/// `node_capacity` fields.
unsafe fn node_buffer(
    solution: *const bf_solution,
    needed: usize,
) -> Result<*mut bf_node, Failure> {
    // SAFETY: valid for reads by the caller's contract; read field by
    // field, so that the output fields need not hold valid values yet.
    let (nodes, capacity) = unsafe {
        (
            addr_of!((*solution).nodes).read(),
            addr_of!((*solution).node_capacity).read(),
        )
    };
    if nodes.is_null() {
        return Err(Failure::null("solution.nodes"));
    }
    engine::check_capacity(capacity, needed)?;
    Ok(nodes)
}

/// Write `answer` into `solution` and its node buffer `nodes`.
///
/// # Safety
/// `solution` is valid for writes of its fields, and `nodes` for writes of
/// `answer`'s node count (checked by [`node_buffer`]).
unsafe fn write_solution(solution: *mut bf_solution, nodes: *mut bf_node, answer: &Answer) {
    let sol = &answer.solution;
    let count = sol.t_s.len();
    for k in 0..count {
        // SAFETY: k < count ≤ the buffer's checked capacity.
        unsafe { nodes.add(k).write(engine::node(sol, k)) };
    }
    // SAFETY: field writes through a pointer valid for writes (contract).
    unsafe {
        addr_of_mut!((*solution).node_count).write(count);
        addr_of_mut!((*solution).status).write(bf_status::from(sol.status));
        addr_of_mut!((*solution).iterations)
            .write(u32::try_from(sol.iterations).unwrap_or(u32::MAX));
        addr_of_mut!((*solution).adopted).write(answer.adopted);
        addr_of_mut!((*solution).tf_s).write(sol.tf_s);
        addr_of_mut!((*solution).final_mass_kg).write(sol.final_mass_kg);
        addr_of_mut!((*solution).solve_time_ms).write(sol.solve_time_ms);
    }
}

/// Cold solve from the problem's initial state (the straight-line start),
/// within the settings' `bf_solve` budgets, into `*solution`. A solved
/// answer becomes the plan, starting at flight time 0. `BF_ERROR_OK` means
/// the method ran: read `solution->status`.
///
/// With the direct method, a cold solve that converges allocates no heap
/// memory: `bf_solver_new` made its storage (tests/allocations.rs
/// counts). Off that path it may (see `bf_replan`).
#[no_mangle]
pub extern "C" fn bf_solve(solver: *mut bf_solver, solution: *mut bf_solution) -> bf_error {
    guard(|| {
        // SAFETY: each pointer is NULL (an error) or valid, the solver used
        // by this call alone (API contract: one thread per solver).
        let s = unsafe { exclusive(solver, "solver")? };
        if solution.is_null() {
            return Err(Failure::null("solution"));
        }
        // SAFETY: `solution` is non-NULL and valid (API contract).
        let nodes = unsafe { node_buffer(solution, s.0.node_count())? };
        let answer = s.0.solve();
        // SAFETY: the buffer was checked to hold the answer's nodes.
        unsafe { write_solution(solution, nodes, &answer) };
        Ok(())
    })
}

/// Re-plan from `measured_state`, measured at flight time `t_now_s` (the
/// clock on which the last `bf_solve`'s initial state is at 0), warm-started
/// from the current plan shifted to `t_now_s` (as guidance re-plans), within
/// the settings' `bf_replan` budgets. A solved answer becomes the plan,
/// starting at `t_now_s`; otherwise the old plan is kept (and
/// `solution->adopted` is false). Without a plan, a cold solve from the
/// measured state.
///
/// `t_now_s` must be finite and not before the current plan's start; the
/// state within the problem's ranges (`BF_ERROR_INVALID_INPUT` otherwise,
/// nothing solved).
///
/// With the direct method, a re-plan that converges allocates no heap
/// memory: `bf_solver_new` made its storage (tests/allocations.rs
/// counts). Off that path it may: a solve that does not converge or ends
/// below the ground (its message), a re-plan that lands far below the
/// plan's prediction (a cold retry), one without a plan yet (the cold
/// solve of a new answer's size), and every SCvx solve (Clarabel builds
/// each subproblem).
#[no_mangle]
pub extern "C" fn bf_replan(
    solver: *mut bf_solver,
    measured_state: *const bf_state,
    t_now_s: f64,
    solution: *mut bf_solution,
) -> bf_error {
    guard(|| {
        // SAFETY: each pointer is NULL (an error) or valid, the solver used
        // by this call alone (API contract: one thread per solver).
        let (s, x) = unsafe {
            (
                exclusive(solver, "solver")?,
                shared(measured_state, "measured_state")?,
            )
        };
        if solution.is_null() {
            return Err(Failure::null("solution"));
        }
        // SAFETY: `solution` is non-NULL and valid (API contract).
        let nodes = unsafe { node_buffer(solution, s.0.node_count())? };
        let answer = s.0.replan(x, t_now_s)?;
        // SAFETY: the buffer was checked to hold the answer's nodes.
        unsafe { write_solution(solution, nodes, &answer) };
        Ok(())
    })
}

/// The current plan's state at flight time `t_now_s` (held at the plan's
/// ends) into `*out`: the reference a controller tracks.
#[no_mangle]
pub extern "C" fn bf_plan_state_at(
    solver: *const bf_solver,
    t_now_s: f64,
    out: *mut bf_state,
) -> bf_error {
    guard(|| {
        // SAFETY: each pointer is NULL (an error) or valid (API contract).
        unsafe {
            let s = shared(solver, "solver")?;
            if out.is_null() {
                return Err(Failure::null("out"));
            }
            write_out(out, s.0.plan_state_at(t_now_s)?, "out")
        }
    })
}

/// The current plan's controls to fly at flight time `t_now_s`: the
/// thrust per unit mass σ = T/m \[N/kg\] (multiply by the measured mass) and
/// the nozzle angle δ \[rad\], PCHIP between the nodes as guidance flies them.
#[no_mangle]
pub extern "C" fn bf_plan_controls_at(
    solver: *const bf_solver,
    t_now_s: f64,
    thrust_per_mass_npkg: *mut f64,
    gimbal_rad: *mut f64,
) -> bf_error {
    guard(|| {
        if thrust_per_mass_npkg.is_null() || gimbal_rad.is_null() {
            return Err(Failure::null("thrust_per_mass_npkg or gimbal_rad"));
        }
        // SAFETY: each pointer is NULL (an error) or valid (API contract).
        unsafe {
            let s = shared(solver, "solver")?;
            let (sigma, delta) = s.0.plan_controls_at(t_now_s)?;
            write_out(thrust_per_mass_npkg, sigma, "thrust_per_mass_npkg")?;
            write_out(gimbal_rad, delta, "gimbal_rad")
        }
    })
}

/// The flight time at which the current plan starts \[s\] into `*out`.
#[no_mangle]
pub extern "C" fn bf_plan_start_s(solver: *const bf_solver, out: *mut f64) -> bf_error {
    guard(|| {
        // SAFETY: each pointer is NULL (an error) or valid (API contract).
        unsafe {
            let s = shared(solver, "solver")?;
            write_out(out, s.0.plan_start_s(), "out")
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::STATUSES;

    /// A panic inside an entry point comes back as `BF_ERROR_PANIC` with
    /// its message, not as an unwind.
    #[test]
    fn a_panic_becomes_an_error_code() {
        let code = guard(|| panic!("boom {}", 7));
        assert_eq!(code, bf_error::Panic);
        assert!(crate::error::last_error().contains("boom 7"));
    }

    /// The status names are the library's.
    #[test]
    fn status_names_are_the_librarys() {
        for (k, s) in STATUSES.iter().enumerate() {
            // SAFETY: bf_status_str returns a static NUL-terminated string.
            let name = unsafe { CStr::from_ptr(bf_status_str(k as i32)) };
            assert_eq!(name.to_str().unwrap(), s.as_str());
        }
        // SAFETY: as above.
        let unknown = unsafe { CStr::from_ptr(bf_status_str(99)) };
        assert_eq!(unknown.to_str().unwrap(), "unknown");
    }
}
