//! The plots of `solve --out DIR`, each as SVG and PNG (plotters):
//!
//! - `path`: the x–z path with the vehicle outline at regular times and the
//!   thrust vector, on equal axis scales, plus a zoom on the touchdown;
//! - `histories`: x, z, Vx, Vz, θ, w, m, T, δ against time, nodes marked;
//! - `convergence`: virtual control, scaled step, cost and trust radius per
//!   SCvx iteration, or the infeasibilities, μ and the step length per
//!   interior-point iteration of the direct method.
//!
//! An optional second trajectory (a re-integration of the solution's
//! controls) is drawn dashed on `path` and `histories`.
//!
//! Text uses DejaVu Sans, embedded from the `dejavu` crate and registered
//! with plotters' `ab_glyph` font backend, so no system font is needed.
//!
//! The plots of closed-loop runs (`sim --out`, `montecarlo --out`) are in
//! [`closed_loop`]; those of a 6-DoF solve (`path` and `histories` in 3-D)
//! in [`six_dof`].
//!
//! The files, in dependency order: `common` (font, colours, labels, ranges),
//! `data` (what is drawn), `pose` (the path's geometry), `legend`, `path`,
//! `histories`, `convergence`, `render` (the files); `closed_loop`;
//! `six_dof`.

mod closed_loop;
mod common;
mod convergence;
mod data;
mod histories;
mod legend;
mod path;
mod pose;
mod render;
pub mod six_dof;

pub use closed_loop::{campaign, timeline};
pub use data::PlotData;
pub use render::render_all;
