//! The C API of bellyflop, for flight software: a problem, a solver that
//! keeps its plan and its method's warm start, a cold solve and warm
//! re-plans from measured states, with iteration and wall-clock budgets,
//! and answers written into caller-owned buffers. The header is
//! `include/bellyflop.h`, generated from this crate by cbindgen
//! (`tests/header.rs` checks that the committed one is current).
//!
//! # Calls
//!
//! Every function that can fail returns a `bf_error` (`BF_ERROR_OK`, 0, on
//! success) and writes its results through out-pointers; the message of a
//! failure is `bf_last_error()`. Every pointer argument is checked for NULL
//! (`BF_ERROR_NULL_POINTER`), and no Rust panic crosses the boundary: one is
//! caught and returned as `BF_ERROR_PANIC`. `bf_solve` and `bf_replan`
//! return `BF_ERROR_OK` when the method ran; how it ended is the solution's
//! `status` (`bf_status_str` names it).
//!
//! # Threads
//!
//! A `bf_solver` or a `bf_problem` is used by one thread at a time: calls
//! on the same object from two threads at once are undefined behaviour
//! (nothing locks). Different objects are independent, so several solvers
//! may run in parallel, one per thread; a solver may move between threads
//! between calls. `bf_last_error` is per thread: it reports that thread's
//! last failure. The const queries (`bf_problem_node_count`,
//! `bf_plan_state_at`, …) only read, and may run on several threads at once
//! if no call mutates the object meanwhile.
//!
//! # Layout
//!
//! - `types`: the C data (`bf_error`, `bf_status`, `bf_settings`,
//!   `bf_state`, `bf_node`, `bf_solution`);
//! - `engine`: the safe Rust behind the calls, on the library's public API
//!   ([`bellyflop::Case`], [`bellyflop::guidance::planner::Planner`]);
//! - `error`: a failure's code and message, and the per-thread last error;
//! - `ffi`: the `extern "C"` functions, the crate's only `unsafe`.
pub mod engine;
pub mod error;
pub mod ffi;
pub mod types;
