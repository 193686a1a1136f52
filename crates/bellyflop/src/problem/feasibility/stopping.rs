//! The vertical stopping bound: the descent cannot be slowed in time.
//!
//! Let v = −Vz be the descent rate, v0 = −Vz(0) and v_f = −Vz_f the one
//! required at touchdown, h = z0 − z_f the altitude available. From Eq. (1)–(3),
//!
//! v̇ = g − T·cos(θ + δ)/m − C_LD·‖V_a‖·v/m,  V_a = (Vx − W, Vz).
//!
//! **Assumptions** (the problem both methods solve): T_min ≤ T ≤ T_max with
//! T_min > 0 for the burn-time bound; ṁ = −T/(I_sp·g0); m ≥ m_dry; the ground
//! z(t) ≥ z_f at every time; Vz(t_f) = Vz_f; g0, C_LD, W constant. Nothing is
//! assumed about θ, δ or their rates, so the bound holds for any attitude.
//!
//! **Bounds on the coefficients.** The mass satisfies
//! m(t) ≥ m_lb(t) = max(m_dry, m0 − T_max·t/(I_sp·g0)). The thrust
//! acceleration a = T/m ≤ Γ(t) = T_max/m_lb(t), and its integral is at most
//! the rocket equation's Δv_cap = I_sp·g0·ln(m0/m_dry) (∫T/m dt = I_sp·g0·
//! ln(m0/m(t))), so A(t) = ∫₀ᵗ a ≤ Ā(t) = min(∫₀ᵗ Γ, Δv_cap). The horizontal
//! air speed Y = |Vx − W| changes by the thrust alone (drag only slows it),
//! so Y ≤ Ȳ(t) = Y(0) + Ā(t), and ‖V_a‖ ≤ √(v² + Ȳ²). With k(t) = C_LD/m_lb(t):
//!
//! v̇ ≥ g − a − k·v⁺·√(v² + Ȳ²) ≥ g − Γ − k·v⁺·√(v² + Ȳ²)    (v⁺ = max(v, 0)).
//!
//! **Two comparison solutions.**
//! 1. Full thrust, largest drag: V̇ = g − Γ − k·V⁺·√(V² + Ȳ²), V(0) = v0.
//!    The comparison lemma (v̇ ≥ f(t, v), f Lipschitz) gives v ≥ V.
//! 2. No thrust, largest drag, minus the whole impulse: U̇ = g − k·U⁺·√(U² + Ȳ²),
//!    U(0) = v0. Since the right-hand side F(t, ·) does not increase in v,
//!    E = v − U + A has Ė ≥ F(t, v) − F(t, U) ≥ 0 whenever E < 0, so E ≥ 0 and
//!    v ≥ U − A ≥ U − Ā. This one carries the propellant limit.
//!
//! So v(t) ≥ L(t) = max(V, U − Ā). While L > v_f, Vz < Vz_f, so t_f lies
//! beyond, and z(t) = z0 − ∫v ≤ z0 − ∫₀ᵗL. Hence:
//! - **altitude**: if ∫₀ᵗL > h while L > v_f on [0, t], the vehicle is below
//!   z_f at t < t_f — no trajectory;
//! - **propellant**: T ≥ T_min burns at least T_min/(I_sp·g0) kg/s, so
//!   t_f ≤ t_burn = (m0 − m_dry)·I_sp·g0/T_min; if L > v_f on all of
//!   [0, t_burn], Vz(t_f) = Vz_f cannot hold — no trajectory.
//!
//! V and U are integrated by RK4 at 5 ms (the stop of the paper's case moves
//! by 1e-4 m against 1 ms; the last step may overrun the stop by 5 ms·v_f),
//! and certify only with a margin — 1 m plus 0.1 % of h, and 0.1 % of
//! t_burn — far above that error and the methods' ground tolerance (1 mm).
//!
//! On the paper's case the bound needs 238.8 m of the 600 m: every state of
//! the documented envelope passes, and the paper's case from z0 = 100 m
//! (the same 238.8 m would be needed: the bound does not depend on z0) is
//! certified.

use serde::Serialize;

use crate::input::scenario::Scenario;

use super::RELATIVE_MARGIN;

/// Integration step of the comparison solutions \[s\].
pub(super) const STEP_S: f64 = 5e-3;
/// Longest time the comparison solutions are integrated \[s\] (2·10⁵ steps);
/// a scenario that needs longer is not certified.
const HORIZON_S: f64 = 1000.0;
/// The vertical stopping bound of a scenario (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StoppingBound {
    /// Altitude available, h = z0 − z_f \[m\].
    pub available_m: f64,
    /// Initial descent rate v0 = −Vz(0) [m/s].
    pub descent_rate_mps: f64,
    /// Descent rate required at touchdown, v_f = −Vz_f [m/s].
    pub final_descent_rate_mps: f64,
    /// Lower bound on the altitude lost before the descent rate can reach
    /// v_f, ∫L dt \[m\] (integrated until L ≤ v_f, the burn time, the
    /// horizon, or 10·h + 1 km: then it is "at least" this).
    pub distance_m: f64,
    /// Time at which the integration stopped \[s\].
    pub time_s: f64,
    /// Whether L reached v_f (false: the descent could not be slowed to v_f
    /// within `time_s`).
    pub stops: bool,
    /// Upper bound on t_f, (m0 − m_dry)·I_sp·g0/T_min \[s\] (∞ for T_min = 0).
    pub burn_time_max_s: f64,
}

/// The vertical stopping bound, or `None` when the vehicle does not descend
/// faster than the touchdown rate (Vz(0) ≥ Vz_f: nothing to stop).
pub fn stopping_bound(s: &Scenario) -> Option<StoppingBound> {
    let v = &s.vehicle;
    let g = s.environment.g0_mps2;
    let h = s.initial.z_m - s.terminal.z_m;
    // 0 − x, not −x: a still target prints as 0.0 m/s, not −0.0.
    let v0 = 0.0 - s.initial.vz_mps;
    let vf = 0.0 - s.terminal.vz_mps;
    if v0 <= vf {
        return None;
    }
    let (m0, m_dry, c) = (s.initial.mass_kg, v.dry_mass_kg, v.drag_coefficient_kgpm);
    let exhaust = v.isp_s * g; // I_sp·g0 [m/s]
    let flow_max = v.max_thrust_n / exhaust; // largest ṁ [kg/s]
    let dv_cap = exhaust * (m0 / m_dry).ln();
    let burn_time_max_s = if v.min_thrust_n > 0.0 {
        (m0 - m_dry) * exhaust / v.min_thrust_n
    } else {
        f64::INFINITY
    };
    let t_dry = (m0 - m_dry) / flow_max; // m_lb reaches m_dry
    let m_lb = |t: f64| (m0 - flow_max * t).max(m_dry);
    // Ā(t) = min(∫Γ, Δv_cap): ∫Γ = I_sp·g0·ln(m0/m_lb) until t_dry, then grows
    // at T_max/m_dry — past t_dry it is above Δv_cap already.
    let a_bar = |t: f64| {
        if t < t_dry {
            (exhaust * (m0 / m_lb(t)).ln()).min(dv_cap)
        } else {
            dv_cap
        }
    };
    let y0 = (s.initial.vx_mps - s.environment.wind_x_mps).abs();
    let drag = |t: f64, w: f64| {
        let y = y0 + a_bar(t);
        c / m_lb(t) * w.max(0.0) * (w * w + y * y).sqrt()
    };
    let full = |t: f64, w: f64| g - v.max_thrust_n / m_lb(t) - drag(t, w);
    let coast = |t: f64, w: f64| g - drag(t, w);
    let rk4 = |f: &dyn Fn(f64, f64) -> f64, t: f64, y: f64| {
        let k1 = f(t, y);
        let k2 = f(t + 0.5 * STEP_S, y + 0.5 * STEP_S * k1);
        let k3 = f(t + 0.5 * STEP_S, y + 0.5 * STEP_S * k2);
        let k4 = f(t + STEP_S, y + STEP_S * k3);
        y + STEP_S / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    };
    // Past t_burn by the margin, so that the propellant certificate can hold.
    let limit_s = (burn_time_max_s * (1.0 + RELATIVE_MARGIN)).min(HORIZON_S);
    // Far past the certificate's threshold, so that the message can give
    // the whole stopping distance in all but extreme cases.
    let enough_m = 10.0 * h + 1000.0;
    let (mut t, mut big_v, mut u, mut lower, mut distance) = (0.0, v0, v0, v0, 0.0);
    let mut stops = false;
    loop {
        if lower <= vf {
            stops = true;
            break;
        }
        if t >= limit_s || distance > enough_m {
            break;
        }
        big_v = rk4(&full, t, big_v);
        u = rk4(&coast, t, u);
        t += STEP_S;
        let next = big_v.max(u - a_bar(t));
        distance += 0.5 * STEP_S * (lower + next);
        lower = next;
    }
    Some(StoppingBound {
        available_m: h,
        descent_rate_mps: v0,
        final_descent_rate_mps: vf,
        distance_m: distance,
        time_s: t,
        stops,
        burn_time_max_s,
    })
}

#[cfg(test)]
mod tests {
    use super::super::paper_from;
    use super::*;

    /// The bound only grows with the descent rate and shrinks with the
    /// thrust; with no descent to stop there is no bound.
    #[test]
    fn bound_is_monotone_and_absent_without_descent() {
        let d = |edit: fn(&mut Scenario)| stopping_bound(&paper_from(edit)).unwrap().distance_m;
        let base = d(|_| ());
        assert!(d(|s| s.initial.vz_mps = -95.0) > base);
        assert!(d(|s| s.vehicle.max_thrust_n = 2.5e6) < base);
        assert!(d(|s| s.vehicle.drag_coefficient_kgpm = 300.0) < base);
        assert!(stopping_bound(&paper_from(|s| s.initial.vz_mps = 0.0)).is_none());
    }

    /// In vacuum without horizontal motion, at constant mass (a huge I_sp),
    /// the bound is the closed form v0²/(2(T_max/m0 − g)).
    #[test]
    fn vacuum_bound_matches_the_closed_form() {
        let s = paper_from(|s| {
            s.vehicle.drag_coefficient_kgpm = 0.0;
            s.vehicle.isp_s = 1000.0;
        });
        let b = stopping_bound(&s).unwrap();
        // m_lb falls at T_max/(I_sp·g0) = 225 kg/s for the ~10 s of the
        // stop, by ~2.2 t: the closed form at m0 is an upper bound, at
        // m0 − 2.5 t a lower one.
        let at = |m: f64| 85.0f64.powi(2) / (2.0 * (2.21e6 / m - 9.81));
        assert!(b.distance_m <= at(120_000.0) + 1e-6, "{b:?}");
        assert!(b.distance_m >= at(117_500.0), "{b:?}");
    }
}
