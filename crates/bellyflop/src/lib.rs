//! bellyflop: fuel-optimal flip-and-land trajectories by Legendre–Gauss–Radau
//! collocation and successive convexification (Chen, Ma, Wang, Su 2023), or
//! a direct interior-point method on the same transcription.
//!
//! The modules, in the order a solve runs through them:
//!
//! - [`input`]: the scenario and the solver settings from TOML, their ranges
//!   and validation, and the typed errors of bad input;
//! - [`problem`]: the vehicle's dynamics and the certificates that no
//!   trajectory exists;
//! - [`collocation`]: LGR nodes and weights, the global or hp mesh, and the
//!   controls as they can be flown between the collocation points;
//! - [`method`]: the methods that solve the transcribed problem (SCvx with
//!   Clarabel, the direct interior-point method) and their iteration records;
//! - [`solution`]: the answer: status, trajectory in physical units, checks
//!   and history;
//! - [`verify`]: re-integration of the controls, the landing error against
//!   the tolerances, and the error of each mesh interval;
//! - [`polish`]: the controls as flown (bounds and cubics per arc, [`flown`])
//!   made to land and to be fuel-optimal by single shooting;
//! - [`refine`]: hp mesh refinement to a tolerance, with breaks at the switches;
//! - [`pipeline`]: [`solve`], the whole of it, with statuses that are claims
//!   (planar: a 6-DoF scenario is refused with a typed error, and solved by
//!   [`pipeline::six_dof::solve`]);
//! - [`guidance`]: the closed loop: navigation, re-planning, control;
//! - [`sim`]: the truth plant, dispersions and the touchdown verdict;
//! - [`output`]: the JSON of a solve and the records of a Monte Carlo campaign;
//! - `fuzzing` (with the `fuzzing` feature, test tooling): the function the
//!   fuzz target and the corpus replay run on raw scenario bytes, with the
//!   invariants every answer must keep.
//!
//! The methods' internals (the direct method's `kkt` and `nlp`, SCvx's
//! `conic` and `transcription`) are public for the benchmarks and tests that
//! measure them, and hidden from these docs: they are not the API.
pub mod collocation;
pub mod flown;
#[cfg(feature = "fuzzing")]
pub mod fuzzing;
pub mod guidance;
pub mod input;
pub mod method;
pub mod output;
pub mod pipeline;
pub mod polish;
pub mod problem;
pub mod refine;
pub mod sim;
pub mod solution;
pub mod verify;

pub use collocation::mesh::Mesh;
pub use input::error::InputError;
pub use input::mesh_layout::MeshLayout;
pub use input::scenario::{Case, Scenario};
pub use input::settings::{Formulation, Method, SolverSettings};
pub use method::observer::Observer;
pub use pipeline::solve;
pub use solution::{Solution, Status};
