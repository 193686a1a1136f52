//! Certificates of infeasibility.
//!
//! A method that stops at a point it cannot make feasible has found no
//! trajectory, which is not a proof that none exists (issue 18: 13 of 50
//! such states solved with another guess, formulation or mesh). `infeasible`
//! is reported only with a [`Certificate`]: a bound, valid for every control
//! history, that the boundary conditions cannot meet.
//!
//! - [`certify`], before any solve: the initial state against the limits,
//!   and the vertical stopping bound ([`stopping`]) against the altitude
//!   and the propellant;
//! - [`certify_limits`], after the first method found no trajectory that
//!   holds the operational limits, before the second tries: the
//!   reachability bound on the approach cone ([`cone`]), which costs tens
//!   of milliseconds and so is not paid by the solves that succeed.

use std::fmt;

use serde::Serialize;

use crate::input::scenario::Scenario;
use crate::problem::constraints::{self, Limit};

pub mod cone;
pub mod stopping;

pub use cone::{cone_bound, ConeBound};
pub use stopping::{stopping_bound, StoppingBound};

/// Absolute altitude margin of the altitude certificate \[m\].
const ALTITUDE_MARGIN_M: f64 = 1.0;
/// Relative margin of the certificates (on h and on t_burn).
const RELATIVE_MARGIN: f64 = 1e-3;

/// Why no trajectory exists.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Certificate {
    /// The descent cannot be slowed to Vz_f before z reaches z_f.
    Altitude(StoppingBound),
    /// The descent cannot be slowed to Vz_f before the propellant runs out.
    Propellant(StoppingBound),
    /// The initial state already breaks an operational path constraint
    /// (issue 37), which must hold along the whole flight from t = 0.
    InitialState(InitialViolation),
    /// Every control history leaves the approach cone before it can have
    /// landed.
    Cone(ConeBound),
}

/// An operational constraint that the initial state breaks: its row g(y₀)
/// > 0 ([`crate::problem::constraints`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct InitialViolation {
    pub limit: Limit,
    /// g(y₀), in the limit's unit ([`Limit::unit`]).
    pub excess: f64,
}

impl fmt::Display for Certificate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Certificate::Altitude(b) => write!(
                f,
                "no trajectory exists (certified from the initial state by the vertical stopping bound): descending at {:.1} m/s with {:.1} m above the landing altitude, even T_max at the least possible mass with the largest possible drag needs at least {:.1} m to slow the descent to {:.1} m/s",
                b.descent_rate_mps, b.available_m, b.distance_m, b.final_descent_rate_mps
            ),
            Certificate::Propellant(b) => write!(
                f,
                "no trajectory exists (certified from the initial state by the propellant bound): the propellant lasts at most {:.2} s even at T_min, and the descent at {:.1} m/s cannot be slowed to {:.1} m/s within that time by the thrust impulse the propellant gives with the largest possible drag",
                b.burn_time_max_s, b.descent_rate_mps, b.final_descent_rate_mps
            ),
            Certificate::InitialState(v) => write!(
                f,
                "no trajectory exists: the initial state breaks {} by {:.4} {}, and it must hold along the whole flight from t = 0",
                v.limit.describe(),
                v.excess,
                v.limit.unit()
            ),
            Certificate::Cone(b) => write!(
                f,
                "no trajectory exists (certified from the initial state by a reachability bound on the approach cone): whatever the thrust, gimbal and attitude, the vehicle is at least {:.1} m outside the {:.1}° cone on the {} side of the pad at t = {:.2} s, and it cannot have landed before t = {:.2} s (the vertical stopping bound)",
                b.outside_m,
                b.half_angle_deg,
                b.side.describe(),
                b.time_s,
                b.landing_not_before_s
            ),
        }
    }
}

/// A certificate that no trajectory exists, or `None` when the bound leaves
/// room for one (which does not mean that one exists).
pub fn certify(s: &Scenario) -> Option<Certificate> {
    if let Some(v) = initial_violation(s) {
        return Some(Certificate::InitialState(v));
    }
    let b = stopping_bound(s)?;
    if b.distance_m > b.available_m * (1.0 + RELATIVE_MARGIN) + ALTITUDE_MARGIN_M {
        Some(Certificate::Altitude(b))
    } else if !b.stops && b.time_s >= b.burn_time_max_s * (1.0 + RELATIVE_MARGIN) {
        Some(Certificate::Propellant(b))
    } else {
        None
    }
}

/// A certificate that no trajectory holds the operational limits, beyond
/// [`certify`]'s: the cone's reachability bound ([`cone`]), before the
/// earliest landing that the vertical stopping bound allows. `None` when
/// the scenario has no cone, or the bound leaves room for a trajectory
/// (which does not mean that one exists).
pub fn certify_limits(s: &Scenario) -> Option<Certificate> {
    let landing = stopping_bound(s)?;
    // L > v_f held at the grid time before `time_s`.
    cone_bound(s, landing.time_s - stopping::STEP_S).map(Certificate::Cone)
}

/// The operational constraint that the initial state breaks most, if any
/// (beyond rounding: 1e-9 of the row's scale).
pub fn initial_violation(s: &Scenario) -> Option<InitialViolation> {
    let rows = constraints::rows(s);
    let y0 = s.initial.state_si();
    let (i, g) = constraints::worst(&rows, &y0[..7])?;
    (g > 1e-9 * rows[i].scale()).then_some(InitialViolation {
        limit: rows[i].limit,
        excess: g,
    })
}

/// Why a method's local infeasibility is not a proof, for the message of a
/// `not_converged` answer.
pub fn not_proven(s: &Scenario) -> String {
    match stopping_bound(s) {
        Some(b) if b.stops => format!(
            "the vertical stopping bound needs only {:.1} m of the {:.1} m available",
            b.distance_m, b.available_m
        ),
        Some(_) => "no certificate applies".to_string(),
        None => format!(
            "the vertical stopping bound does not apply (Vz(0) = {:.1} m/s is not below Vz_f = {:.1} m/s)",
            s.initial.vz_mps, s.terminal.vz_mps
        ),
    }
}

/// The paper's scenario with one edit, for the certificates' tests.
#[cfg(test)]
fn paper_from(edit: impl FnOnce(&mut Scenario)) -> Scenario {
    let mut s = Scenario::paper();
    edit(&mut s);
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper's case needs 238.8 m of its 600 m (computed independently
    /// with the same equations when the bound was written); from 100 m it is
    /// certified.
    #[test]
    fn paper_case_passes_and_100_m_is_certified() {
        let b = stopping_bound(&Scenario::paper()).unwrap();
        assert!(b.stops);
        assert!((b.distance_m - 238.8).abs() < 0.1, "{b:?}");
        assert!(certify(&Scenario::paper()).is_none());
        // The stopping distance does not depend on z0: from 100 m it is the
        // same 238.8 m, and the message says so.
        let low = paper_from(|s| s.initial.z_m = 100.0);
        match certify(&low) {
            Some(c @ Certificate::Altitude(b)) => {
                assert!((b.distance_m - 238.8).abs() < 0.1, "{b:?}");
                let m = c.to_string();
                assert!(
                    m.contains("needs at least 238.8 m") && m.contains("to 0.0 m/s"),
                    "{m}"
                );
            }
            c => panic!("{c:?}"),
        }
    }

    /// 1,000 kg of propellant burn for at most 3.68 s at T_min, too short to
    /// stop the paper's descent.
    #[test]
    fn too_little_propellant_is_certified() {
        let s = paper_from(|s| s.initial.mass_kg = 86_000.0);
        match certify(&s) {
            Some(Certificate::Propellant(b)) => {
                assert!((b.burn_time_max_s - 3.678).abs() < 1e-2, "{b:?}");
                assert!(!b.stops);
            }
            c => panic!("{c:?}"),
        }
    }
}
