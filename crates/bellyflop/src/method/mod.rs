//! The methods that solve a transcribed landing problem, and what they
//! report as they iterate:
//!
//! - [`scvx`]: successive convexification of P2 with Clarabel (the paper's);
//! - [`direct`]: a primal–dual interior-point method on the nonlinear
//!   program, with a KKT solve that exploits the collocation's structure;
//! - [`observer`]: the iteration records, as they complete.

pub mod direct;
pub mod observer;
pub mod scvx;
