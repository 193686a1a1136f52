//! The straight-line guess's two numbers, t_f and m_f, when a scenario file
//! leaves them out (`discretization.tf_guess_s`, `final_mass_guess_kg`), and
//! the clamping of a given guess into its range (issue 29).
//!
//! A guess is the solver's business: it must never turn a valid problem into
//! bad input. So a missing guess is derived from the state, and a given one
//! outside its range is moved into it with a warning; only a value that is
//! no guess at all (NaN, ±inf, zero or negative) stays an error, reported by
//! validation with its field, value and range.
//!
//! # The estimate
//!
//! A fuel-optimal descent coasts while drag brakes it for free, then stops
//! at full thrust (the bang–bang burn of the paper's Fig. 5). In vertical
//! motion only, with the model's drag on the descent rate v = −Vz (C_LD·v²,
//! Eq. 2 without the horizontal air speed), the stop at T_max is
//!
//! v̇ = g − T_max/m − C_LD·v·|v|/m,  m = m0 − T_max·t/(I_sp·g0),
//!
//! integrated (explicit Euler, 5 ms) from v0 until v ≤ v_f: it takes t_s over
//! a distance d_s. If d_s ≤ h = z0 − z_f, the spare altitude is the coast,
//! flown at about the initial rate: t_f = t_s + (h − d_s)/v0. If it does not
//! stop within h, t_f = 2h/(v0 + v_f), the constant deceleration that does;
//! a vehicle that does not descend faster than v_f gets the time to fall h
//! from v0 under gravity. The engine cannot be off (T ≥ T_min), so
//! propellant burns all the way, at a rate between T_min's in the coast and
//! T_max's in the stop: m_f = m0 − ṁ·t_f with ṁ = T̄/(I_sp·g0) at the mean
//! thrust T̄ = (T_min + T_max)/2.
//!
//! This is the vertical part of [`crate::problem::feasibility`]'s stopping
//! bound, at the actual mass and drag instead of the least mass and the
//! largest drag: that bound is a lower bound (≈ 5 s on the paper's case),
//! this an estimate. (It is computed here, not by calling the bound, because
//! `input` sits below `problem`.) On the paper's case it gives t_f = 11.0 s
//! and m_f = 114.7 t against the optimum's 11.57 s and 114.57 t (whose mean
//! flow, 469 kg/s, is near T̄'s 477 kg/s; the file's own guesses are 12 s
//! and 110 t).
//!
//! Both are then clamped: t_f into [[`TF_MIN_S`], [`TF_MAX_S`]], m_f into
//! [m_dry, m0].

use crate::input::scenario::Scenario;

/// Shortest derived t_f \[s\].
pub const TF_MIN_S: f64 = 1.0;
/// Longest t_f, derived or given \[s\]: the upper end of
/// `discretization.tf_guess_s`'s range (a landing burn lasts tens of seconds).
pub const TF_MAX_S: f64 = 1000.0;
/// Integration step of the estimate \[s\].
const STEP_S: f64 = 5e-3;

/// The straight-line guess's final time and final mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Guess {
    /// t_f \[s\].
    pub tf_s: f64,
    /// m_f \[kg\].
    pub final_mass_kg: f64,
}

/// The guess derived from the scenario's vehicle, environment and boundary
/// states (its `discretization` guesses are not read). Finite and within
/// range for every scenario whose other fields are finite; with m_dry ≥ m0
/// (which validation rejects) m_f is m0.
pub fn derive(s: &Scenario) -> Guess {
    let v = &s.vehicle;
    let g = s.environment.g0_mps2;
    let h = (s.initial.z_m - s.terminal.z_m).max(0.0);
    let (v0, vf) = (-s.initial.vz_mps, -s.terminal.vz_mps);
    let (m0, m_dry) = (s.initial.mass_kg, v.dry_mass_kg);
    let exhaust = v.isp_s * g;
    let flow = 0.5 * (v.min_thrust_n + v.max_thrust_n) / exhaust;
    let (thrust, stop_flow) = (v.max_thrust_n, v.max_thrust_n / exhaust);
    let fall = || (-v0 + (v0 * v0 + 2.0 * g * h).sqrt()) / g;
    let tf = if v0 > vf {
        match stop(
            g,
            thrust,
            stop_flow,
            v.drag_coefficient_kgpm,
            m0,
            m_dry,
            v0,
            vf,
            h,
        ) {
            Some((t_s, d_s)) if v0 > 0.0 => t_s + (h - d_s) / v0,
            Some((t_s, _)) => t_s,
            None if v0 + vf > 0.0 => 2.0 * h / (v0 + vf),
            None => fall(),
        }
    } else {
        fall()
    };
    let tf = if tf.is_finite() { tf } else { TF_MAX_S };
    let tf = tf.clamp(TF_MIN_S, TF_MAX_S);
    let mf = clamp_mass(m0 - flow * tf, m_dry, m0);
    Guess {
        tf_s: tf,
        final_mass_kg: if mf.is_finite() { mf } else { m0 },
    }
}

/// Time and distance for the descent rate to fall from `v0` to `vf` at
/// `thrust`, or `None` if it does not within the altitude `h` (or
/// [`TF_MAX_S`]).
#[allow(clippy::too_many_arguments)]
fn stop(
    g: f64,
    thrust: f64,
    flow: f64,
    drag: f64,
    m0: f64,
    m_dry: f64,
    v0: f64,
    vf: f64,
    h: f64,
) -> Option<(f64, f64)> {
    let (mut t, mut v, mut d) = (0.0, v0, 0.0);
    while v > vf {
        if d > h || t > TF_MAX_S || !v.is_finite() {
            return None;
        }
        let m = (m0 - flow * t).max(m_dry).max(f64::MIN_POSITIVE);
        let next = v + STEP_S * (g - thrust / m - drag * v * v.abs() / m);
        d += 0.5 * STEP_S * (v + next.max(vf));
        v = next;
        t += STEP_S;
    }
    (d <= h).then_some((t, d))
}

/// `m` within [m_dry, m0]; m0 when m_dry > m0 (max then min: no panic).
fn clamp_mass(m: f64, m_dry: f64, m0: f64) -> f64 {
    m.max(m_dry).min(m0)
}

/// Fill in the scenario's guesses from the file's `tf_guess_s` and
/// `final_mass_guess_kg` (`None`: left out, so derived), and return a
/// warning for each given guess that was outside its range and clamped into
/// it. A given value that is not finite and positive is kept as it is, for
/// validation to reject with its field, value and range.
pub fn resolve(s: &mut Scenario, tf_s: Option<f64>, final_mass_kg: Option<f64>) -> Vec<String> {
    let derived = derive(s);
    let usable = |x: f64| x.is_finite() && x > 0.0;
    let mut warnings = Vec::new();
    let tf = match tf_s {
        None => derived.tf_s,
        Some(t) if usable(t) && t > TF_MAX_S => {
            warnings.push(format!(
                "discretization.tf_guess_s = {t} is outside (0, {TF_MAX_S}] s: clamped to {TF_MAX_S} s"
            ));
            TF_MAX_S
        }
        Some(t) => t,
    };
    let (m_dry, m0) = (s.vehicle.dry_mass_kg, s.initial.mass_kg);
    let mf = match final_mass_kg {
        None => derived.final_mass_kg,
        Some(m) if usable(m) => {
            let c = clamp_mass(m, m_dry, m0);
            if c != m && m_dry < m0 {
                warnings.push(format!(
                    "discretization.final_mass_guess_kg = {m} is outside [vehicle.dry_mass_kg, initial.mass_kg] = [{m_dry}, {m0}] kg: clamped to {c} kg"
                ));
            }
            c
        }
        Some(m) => m,
    };
    s.discretization.tf_guess_s = tf;
    s.discretization.final_mass_guess_kg = mf;
    warnings
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic generator (SplitMix64) for the seeded sample.
    struct Rng(u64);
    impl Rng {
        fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            lo + (hi - lo) * (z >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn the_paper_case_is_estimated_near_its_optimum() {
        let g = derive(&Scenario::paper());
        // The optimum (N = 20, direct): t_f = 11.57 s, m_f = 114.57 t.
        assert!((g.tf_s - 11.03).abs() < 0.05, "{g:?}");
        assert!((g.final_mass_kg - 114_740.0).abs() < 50.0, "{g:?}");
    }

    /// Issue 15's wide box (x0 ±300 m, z0 450–900 m, Vx0 ±20 m/s, Vz0 −100
    /// to −60 m/s, θ0 75–100°, m0 105–128 t), and beyond it (down to 100 m,
    /// hovering or climbing, 86 t, T_min = 0, no drag): every derived guess
    /// is finite, within its range, and the scenario with it validates.
    #[test]
    fn every_sampled_state_gets_a_guess_in_range_that_validates() {
        let mut rng = Rng(29);
        for k in 0..2000 {
            let mut s = Scenario::paper();
            let i = &mut s.initial;
            let wide = k % 2 == 0;
            i.x_m = rng.uniform(-300.0, 300.0);
            i.z_m = if wide {
                rng.uniform(450.0, 900.0)
            } else {
                rng.uniform(100.0, 3000.0)
            };
            i.vx_mps = rng.uniform(-20.0, 20.0);
            i.vz_mps = if wide {
                rng.uniform(-100.0, -60.0)
            } else {
                rng.uniform(-300.0, 20.0)
            };
            i.theta_deg = rng.uniform(75.0, 100.0);
            i.mass_kg = if wide {
                rng.uniform(105e3, 128e3)
            } else {
                rng.uniform(86e3, 200e3)
            };
            if !wide {
                let v = &mut s.vehicle;
                v.min_thrust_n = if k % 6 == 1 { 0.0 } else { v.min_thrust_n };
                v.drag_coefficient_kgpm = if k % 10 == 3 {
                    0.0
                } else {
                    v.drag_coefficient_kgpm
                };
            }
            let g = derive(&s);
            assert!(
                g.tf_s.is_finite() && (TF_MIN_S..=TF_MAX_S).contains(&g.tf_s),
                "{k}: {g:?}"
            );
            assert!(
                (s.vehicle.dry_mass_kg..=s.initial.mass_kg).contains(&g.final_mass_kg),
                "{k}: {g:?}"
            );
            if wide {
                // The envelope's landings take 5 to 30 s and burn some propellant.
                assert!((5.0..=30.0).contains(&g.tf_s), "{k}: {g:?}");
                assert!(g.final_mass_kg < s.initial.mass_kg, "{k}: {g:?}");
            }
            let w = resolve(&mut s, None, None);
            assert!(w.is_empty());
            assert_eq!(s.validate(), Ok(()), "{k}: {g:?}");
        }
    }

    #[test]
    fn a_given_guess_is_kept_inside_and_clamped_outside_its_range() {
        let mut s = Scenario::paper();
        assert!(resolve(&mut s, Some(12.0), Some(110_000.0)).is_empty());
        assert_eq!(s.discretization.tf_guess_s, 12.0);
        assert_eq!(s.discretization.final_mass_guess_kg, 110_000.0);
        s.initial.mass_kg = 105_000.0;
        let w = resolve(&mut s, Some(5000.0), Some(110_000.0));
        assert_eq!(s.discretization.tf_guess_s, TF_MAX_S);
        assert_eq!(s.discretization.final_mass_guess_kg, 105_000.0);
        assert_eq!(w.len(), 2, "{w:?}");
        assert!(
            w[0].starts_with("discretization.tf_guess_s = 5000"),
            "{w:?}"
        );
        assert!(w[1].contains("clamped to 105000 kg"), "{w:?}");
        let w = resolve(&mut s, None, Some(1.0));
        assert_eq!(s.discretization.final_mass_guess_kg, 85_000.0);
        assert_eq!(w.len(), 1, "{w:?}");
        // Not a guess at all: kept for validation to reject.
        for bad in [f64::NAN, -1.0, 0.0, f64::INFINITY] {
            assert!(resolve(&mut s, Some(bad), Some(bad)).is_empty());
            assert!(s.discretization.tf_guess_s.to_bits() == bad.to_bits());
            assert!(s.discretization.final_mass_guess_kg.to_bits() == bad.to_bits());
            assert!(s.validate().is_err());
        }
    }
}
