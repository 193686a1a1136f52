//! A reachability bound on the approach cone: no control history keeps the
//! vehicle inside the cone until it can have landed.
//!
//! # The cone's margin
//!
//! With Δx = x − x_f, Δz = z − z_f and the cone of half-angle γ about the
//! pad ([`crate::problem::constraints`]), each side σ = ±1 of the cone asks
//! for the margin c = tan γ·Δz − σ·Δx ≥ 0 at every t ∈ [0, t_f], and the
//! landing puts c(t_f) = 0. With n = (−σ, tan γ), c′ = u = n·V and, from
//! Eq. (1)–(2) with the thrust direction d(φ) = (−sin φ, cos φ), φ = θ + δ,
//!
//! u′ = (T/m)·n·d(φ) − (C_LD/m)·‖V_a‖·(u + σW) − g·tan γ,
//!
//! where n·d(φ) = R·cos(φ − φ_n), R = 1/cos γ, cos φ_n = sin γ and
//! sin φ_n = σ·cos γ: the thrust helps the margin only when it points within
//! 90° of φ_n. From the belly-first attitude (θ ≈ 90°) the thrust points
//! along −x, so on the −x side of the pad it pushes the vehicle out of the
//! cone until the flip has turned it.
//!
//! # Bounds valid for every control history
//!
//! With the mass bounds m_lb(t) = max(m_dry, m0 − T_max·t/(I_sp·g0)) ≤ m ≤
//! m_ub(t) = max(m_dry, m0 − T_min·t/(I_sp·g0)), the thrust acceleration
//! a = T/m lies in [a_min, Γ] = [T_min/m_ub, T_max/m_lb]. Nothing else about
//! T, δ or θ is assumed but the bounds |δ| ≤ δ_max, |δ′| ≤ χ_max and the
//! dynamics of Eq. (3).
//!
//! - **Air speed.** S = ‖V_a‖ (constant wind) has S′ ≤ a + g − (C_LD/m)S²,
//!   so S ≤ S̄, S̄′ = Γ + g − (C_LD/m_ub)·S̄², S̄(0) = S(0) (comparison: the
//!   right-hand side does not increase in S ≥ 0).
//! - **Pitch.** Eq. (3) is θ″ = −(T/m)(l_cg/k)·sin δ + M_D/(m·k), k = J/m,
//!   with |M_D| ≤ C_LD·S²·|l_cp − l_cg|, so the drag's part is within
//!   A_D = C_LD·S̄²·|l_cp − l_cg|/(m_lb·k), and (T/m)·sin δ ≤ q(δ) = Γ·sin δ
//!   for δ ≥ 0, a_min·sin δ for δ < 0. By Taylor's formula,
//!
//!   φ(t) ≥ θ0 + w0·t − ∫₀ᵗ(t − s)·A_D ds − (l_cg/k)·∫₀ᵗ(t − s)·q(δ(s)) ds + δ(t).
//!
//!   For a given δ(t) = δ_f the largest gimbal history that the bounds allow
//!   is δ*(s) = min(δ_max, δ0 + χ_max·s, δ_f + χ_max·(t − s)), and q grows
//!   with δ, so the right-hand side is least at δ*; δ* grows with δ_f, so on
//!   a cell [a, b] of δ_f the bound with δ*_b and a + … holds for the cell.
//!   The least over the cells is a lower bound φ_lo(t) on the thrust
//!   direction; mirrored (θ, w, δ → −θ, −w, −δ), an upper bound φ_hi(t).
//!   Turning the thrust takes the gimbal first, which swings it the other
//!   way: that coupling is what the bound keeps.
//! - **The margin's rate.** On [φ_lo, φ_hi], cos(φ − φ_n) ≤ h̄ (1 where φ_n
//!   lies inside), so the thrust's part is at most Γ·R·h̄ (a_min·R·h̄ when
//!   h̄ < 0). The drag's part, with u_a = u + σW, is at most
//!   (C_LD/m_lb)·S̄·(−u_a) for u_a < 0 and −(C_LD/m_ub)·cos γ·u_a² for
//!   u_a ≥ 0 (‖V_a‖ ≥ |n·V_a|/‖n‖). The bound F(t, u) so found does not
//!   increase in u, so u ≤ U with U′ = F(t, U), U(0) = u(0), and
//!   c(t) ≤ C̄(t) = c(0) + ∫₀ᵗU.
//!
//! **The certificate.** The vertical stopping bound ([`super::stopping`])
//! gives a time t_s before which Vz < Vz_f, so t_f ≥ t_s. If C̄(t) < 0 at
//! some t < t_s, then c(t) < 0 while the vehicle is still flying: no
//! trajectory holds the cone.
//!
//! The bounds are integrated on a 10 ms grid (RK4 for S̄ and for (C̄, U), the
//! trapezoid rule for the pitch integrals, 32 cells of δ_f), each step with
//! the least favourable of its ends' coefficients, and certify only beyond a
//! margin of 1 m plus 0.1 % of c(0) and before 99.9 % of t_s. The grid's
//! error is far below that margin (the test halves the step); the search
//! stops at 20 s, past which the attitude bounds no longer bind.

use serde::{Deserialize, Serialize};

use crate::input::scenario::Scenario;
use crate::problem::dynamics::Model;

/// Step of the bounds' grid \[s\].
const STEP_S: f64 = 1e-2;
/// Longest time searched for a breach \[s\].
const HORIZON_S: f64 = 20.0;
/// Cells of the final gimbal angle δ_f in the pitch bound.
const GIMBAL_CELLS: usize = 32;
/// Absolute margin on the cone's margin \[m\].
const MARGIN_M: f64 = 1.0;
/// Relative margins: on c(0), and on the landing time t_s.
const RELATIVE_MARGIN: f64 = 1e-3;

/// The side of the pad on which the cone is left.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    /// x < x_f (σ = −1).
    NegativeX,
    /// x > x_f (σ = +1).
    PositiveX,
}

impl Side {
    /// σ in c = tan γ·Δz − σ·Δx.
    fn sign(self) -> f64 {
        match self {
            Side::NegativeX => -1.0,
            Side::PositiveX => 1.0,
        }
    }

    /// A readable name for messages.
    pub fn describe(self) -> &'static str {
        match self {
            Side::NegativeX => "−x",
            Side::PositiveX => "+x",
        }
    }
}

/// Where and by how much every control history leaves the cone.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ConeBound {
    /// The cone's half-angle γ \[deg\].
    pub half_angle_deg: f64,
    pub side: Side,
    /// The first time at which the margin's upper bound C̄ is below the
    /// certificate's margin \[s\].
    pub time_s: f64,
    /// −C̄ there: every trajectory is at least this far outside the cone,
    /// measured along x \[m\].
    pub outside_m: f64,
    /// The vertical stopping bound's t_s: no trajectory lands before it \[s\].
    pub landing_not_before_s: f64,
}

/// The bound's coefficients at one grid time.
#[derive(Debug, Clone, Copy)]
struct Coefficients {
    m_lb: f64,
    m_ub: f64,
    /// Γ = T_max/m_lb and a_min = T_min/m_ub [m/s²].
    accel_max: f64,
    accel_min: f64,
    /// S̄ [m/s].
    speed: f64,
    /// A_D [rad/s²].
    drag_pitch: f64,
}

/// The constants of the bound, from the scenario.
struct Setting {
    model: Model,
    m0: f64,
    /// Mass flows at T_max and T_min \[kg/s\].
    flow_max: f64,
    flow_min: f64,
    theta0: f64,
    w0: f64,
    delta0: f64,
}

impl Setting {
    fn new(s: &Scenario) -> Self {
        let model = Model::new(&s.vehicle, &s.environment);
        let exhaust = -1.0 / model.alpha_spm;
        let y0 = s.initial.state_si();
        Setting {
            flow_max: model.max_thrust_n / exhaust,
            flow_min: model.min_thrust_n / exhaust,
            m0: s.initial.mass_kg,
            theta0: y0[4],
            w0: y0[5],
            delta0: y0[7],
            model,
        }
    }

    /// m_lb, m_ub and the acceleration bounds at t (S̄ and A_D filled later).
    fn masses(&self, t: f64) -> Coefficients {
        let dry = self.model.dry_mass_kg;
        let m_lb = (self.m0 - self.flow_max * t).max(dry);
        let m_ub = (self.m0 - self.flow_min * t).max(dry);
        Coefficients {
            m_lb,
            m_ub,
            accel_max: self.model.max_thrust_n / m_lb,
            accel_min: self.model.min_thrust_n / m_ub,
            speed: 0.0,
            drag_pitch: 0.0,
        }
    }
}

/// The coefficients on the grid t_i = i·h, i = 0..=n, with S̄ by RK4.
fn coefficients(set: &Setting, speed0: f64, n: usize, h: f64) -> Vec<Coefficients> {
    let m = &set.model;
    let arm = (m.cp_m - m.cg_m).abs();
    let rate = |t: f64, s: f64| {
        let c = set.masses(t);
        c.accel_max + m.g0_mps2 - m.c_ld_kgpm / c.m_ub * s * s
    };
    let mut speed = speed0;
    (0..=n)
        .map(|i| {
            let t = i as f64 * h;
            let mut c = set.masses(t);
            c.speed = speed;
            c.drag_pitch = m.c_ld_kgpm * speed * speed * arm / (c.m_lb * m.inertia_per_mass_m2);
            let k1 = rate(t, speed);
            let k2 = rate(t + 0.5 * h, speed + 0.5 * h * k1);
            let k3 = rate(t + 0.5 * h, speed + 0.5 * h * k2);
            let k4 = rate(t + h, speed + h * k3);
            speed += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
            c
        })
        .collect()
}

/// The lower bound φ_lo(t_i) on θ + δ for every i, from (θ0, w0, δ0) (the
/// mirrored call gives −φ_hi).
fn pointing_lower(set: &Setting, coef: &[Coefficients], h: f64, start: [f64; 3]) -> Vec<f64> {
    let [theta0, w0, delta0] = start;
    let m = &set.model;
    let (d_max, chi) = (m.max_gimbal_rad, m.max_gimbal_rate_radps);
    let lever = m.cg_m / m.inertia_per_mass_m2;
    // q(s, δ), the largest (T/m)·sin δ.
    let q = |c: &Coefficients, d: f64| {
        let s = d.sin();
        if s >= 0.0 {
            c.accel_max * s
        } else {
            c.accel_min * s
        }
    };
    let cap = |s: f64| d_max.min(delta0 + chi * s);
    // Trapezoid weights: h/2 at s = 0; the last point's weight does not
    // matter, its (t − s) is zero.
    let weight = |j: usize| if j == 0 { 0.5 * h } else { h };
    // Prefix sums of ω_j·f_j and ω_j·s_j·f_j for f = A_D and f = q(δ = cap).
    let prefix = |f: &dyn Fn(usize) -> f64| {
        let (mut p0, mut p1) = (vec![0.0], vec![0.0]);
        for j in 0..coef.len() {
            let w = weight(j) * f(j);
            p0.push(p0[j] + w);
            p1.push(p1[j] + w * j as f64 * h);
        }
        (p0, p1)
    };
    let (a0, a1) = prefix(&|j| coef[j].drag_pitch);
    let (q0, q1) = prefix(&|j| q(&coef[j], cap(j as f64 * h)));
    (0..coef.len())
        .map(|i| {
            let t = i as f64 * h;
            // ∫₀ᵗ(t − s)·f ds over s_0..s_{j−1} from the prefix sums.
            let moment = |p0: &[f64], p1: &[f64], j: usize| t * p0[j] - p1[j];
            let base = theta0 + w0 * t - moment(&a0, &a1, i + 1);
            let lo = (-d_max).max(delta0 - chi * t);
            let hi = d_max.min(delta0 + chi * t);
            let cell = (hi - lo) / GIMBAL_CELLS as f64;
            let least = (0..GIMBAL_CELLS)
                .map(|k| {
                    let (a, b) = (lo + k as f64 * cell, lo + (k + 1) as f64 * cell);
                    // δ* = cap(s) until the ramp down to b starts.
                    // (b + χ(t − s) − cap(s) falls with s: a binary search.)
                    let ramp = first_true(0, i + 1, |j| {
                        let s = j as f64 * h;
                        b + chi * (t - s) < cap(s)
                    });
                    let tail: f64 = (ramp..=i)
                        .map(|j| {
                            let s = j as f64 * h;
                            weight(j) * (t - s) * q(&coef[j], cap(s).min(b + chi * (t - s)))
                        })
                        .sum();
                    a - lever * (moment(&q0, &q1, ramp) + tail)
                })
                .fold(f64::INFINITY, f64::min);
            base + least
        })
        .collect()
}

/// The least j in [lo, hi) with `pred(j)`, or hi: `pred` is false, then
/// true.
fn first_true(mut lo: usize, mut hi: usize, pred: impl Fn(usize) -> bool) -> usize {
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if pred(mid) {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    lo
}

/// max cos(φ − φ_n) over φ ∈ [lo, hi].
fn best_alignment(lo: f64, hi: f64, phi_n: f64) -> f64 {
    let turn = std::f64::consts::TAU;
    if hi - lo >= turn || phi_n + turn * ((lo - phi_n) / turn).ceil() <= hi {
        1.0
    } else {
        (lo - phi_n).cos().max((hi - phi_n).cos())
    }
}

/// The bounds on one grid: the coefficients and the pointing interval
/// [φ_lo, φ_hi] at each t_i = i·h.
struct Reach {
    h: f64,
    coef: Vec<Coefficients>,
    lower: Vec<f64>,
    upper: Vec<f64>,
}

impl Reach {
    /// The bounds on [0, span] on a grid of step h.
    fn new(s: &Scenario, set: &Setting, span: f64, h: f64) -> Self {
        let n = (span / h).ceil() as usize;
        let speed0 = (s.initial.vx_mps - set.model.wind_x_mps).hypot(s.initial.vz_mps);
        let coef = coefficients(set, speed0, n, h);
        let lower = pointing_lower(set, &coef, h, [set.theta0, set.w0, set.delta0]);
        let upper = pointing_lower(set, &coef, h, [-set.theta0, -set.w0, -set.delta0])
            .into_iter()
            .map(|v| -v)
            .collect();
        Reach {
            h,
            coef,
            lower,
            upper,
        }
    }

    /// C̄(t_i) on one side, for every t_i of the grid, by RK4 on (C̄, U).
    fn margin(&self, s: &Scenario, set: &Setting, gamma: f64, side: Side) -> Vec<f64> {
        let (tan, cos) = (gamma.tan(), gamma.cos());
        let sigma = side.sign();
        let phi_n = (sigma * cos).atan2(gamma.sin());
        let m = &set.model;
        let (g, c_ld, wind) = (m.g0_mps2, m.c_ld_kgpm, m.wind_x_mps);
        let (i0, t0) = (&s.initial, &s.terminal);
        let mut c = tan * (i0.z_m - t0.z_m) - sigma * (i0.x_m - t0.x_m);
        let mut u = tan * i0.vz_mps - sigma * i0.vx_mps;
        let mut trace = vec![c];
        for i in 0..self.coef.len() - 1 {
            let (now, next) = (&self.coef[i], &self.coef[i + 1]);
            // The step's least favourable coefficients: the union of its
            // ends' pointing intervals, Γ and S̄ at their largest, m_ub at
            // its largest, a_min at its least.
            let lo = self.lower[i].min(self.lower[i + 1]);
            let hi = self.upper[i].max(self.upper[i + 1]);
            let align = best_alignment(lo, hi, phi_n) / cos;
            let thrust = if align >= 0.0 {
                next.accel_max * align
            } else {
                now.accel_min * align
            };
            let speed = now.speed.max(next.speed);
            let (k_out, k_in) = (c_ld / next.m_lb * speed, c_ld / now.m_ub * cos);
            let rate = |u: f64| {
                let ua = u + sigma * wind;
                let drag = if ua < 0.0 {
                    -k_out * ua
                } else {
                    -k_in * ua * ua
                };
                thrust + drag - g * tan
            };
            let h = self.h;
            let k1 = rate(u);
            let k2 = rate(u + 0.5 * h * k1);
            let k3 = rate(u + 0.5 * h * k2);
            let k4 = rate(u + h * k3);
            // C̄′ = U: its RK4 stages are the U stages.
            c += h / 6.0 * (u + 2.0 * (u + 0.5 * h * k1) + 2.0 * (u + 0.5 * h * k2) + (u + h * k3));
            u += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
            trace.push(c);
        }
        trace
    }
}

/// The first grid time before `stop_s` at which C̄ is below the margin.
fn breach(trace: &[f64], h: f64, stop_s: f64) -> Option<(f64, f64)> {
    let margin = MARGIN_M + RELATIVE_MARGIN * trace[0].abs();
    trace
        .iter()
        .enumerate()
        .map(|(i, &c)| (i as f64 * h, c))
        .take_while(|&(t, _)| t < stop_s)
        .find(|&(_, c)| c < -margin)
}

/// The cone certificate: a side on which every control history leaves the
/// cone before it can have landed (`landing_not_before_s`, the vertical
/// stopping bound's t_s), or `None` (which does not mean that a trajectory
/// exists). Only with a cone in the scenario.
pub fn cone_bound(s: &Scenario, landing_not_before_s: f64) -> Option<ConeBound> {
    let gamma_deg = s.constraints.cone_half_angle_deg?;
    let set = Setting::new(s);
    let span = landing_not_before_s.min(HORIZON_S);
    if span <= 0.0 {
        return None;
    }
    let reach = Reach::new(s, &set, span, STEP_S);
    let stop = landing_not_before_s * (1.0 - RELATIVE_MARGIN);
    [Side::NegativeX, Side::PositiveX]
        .into_iter()
        .filter_map(|side| {
            let trace = reach.margin(s, &set, gamma_deg.to_radians(), side);
            let (time_s, c) = breach(&trace, reach.h, stop)?;
            Some(ConeBound {
                half_angle_deg: gamma_deg,
                side,
                time_s,
                outside_m: -c,
                landing_not_before_s,
            })
        })
        .min_by(|a, b| a.time_s.total_cmp(&b.time_s))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::scenario::Constraints;
    use crate::input::settings::SolverSettings;
    use crate::method::observer::Silent;
    use crate::problem::feasibility::stopping_bound;

    /// The paper's case started at `x0_m` with a cone of `cone_deg` (none
    /// for `None`).
    fn paper_at(x0_m: f64, cone_deg: Option<f64>) -> Scenario {
        let mut s = Scenario::paper();
        s.initial.x_m = x0_m;
        s.constraints = Constraints {
            cone_half_angle_deg: cone_deg,
            ..Default::default()
        };
        s
    }

    fn landing_s(s: &Scenario) -> f64 {
        stopping_bound(s).unwrap().time_s
    }

    /// The paper's case mirrored to x0 = −100 m falls belly-first with its
    /// thrust along −x, away from the pad: a 20° cone is certified broken
    /// on that side before the vehicle can land, a 25° one is not (and
    /// then the methods find the unconstrained answer breaks it, but
    /// nothing proves that no trajectory holds it). At x0 = +100 m the same
    /// thrust points at the pad, and even a 10° cone is not certified.
    #[test]
    fn the_mirrored_paper_case_leaves_a_20_degree_cone_on_its_far_side() {
        let s = paper_at(-100.0, Some(20.0));
        let b = cone_bound(&s, landing_s(&s)).expect("certified");
        assert_eq!(b.side, Side::NegativeX);
        assert!(
            b.outside_m > MARGIN_M && b.time_s < b.landing_not_before_s,
            "{b:?}"
        );
        let wide = paper_at(-100.0, Some(25.0));
        assert_eq!(cone_bound(&wide, landing_s(&wide)), None);
        let near = paper_at(100.0, Some(10.0));
        assert_eq!(cone_bound(&near, landing_s(&near)), None);
        assert_eq!(cone_bound(&paper_at(-100.0, None), 6.0), None);
    }

    /// Every bound holds along real flights: the default answers of the
    /// paper's case and of its mirror (unconstrained, polished, so their
    /// node states are the flown ones), at every node before the earliest
    /// landing: the air speed below S̄, the thrust direction θ + δ within
    /// [φ_lo, φ_hi], and each side's cone margin c below C̄.
    #[test]
    fn the_bounds_hold_along_flown_answers() {
        for x0 in [100.0, -100.0] {
            let s = paper_at(x0, None);
            let sol = crate::solve(&s, &SolverSettings::default(), &mut Silent)
                .expect("a planar scenario");
            assert_eq!(sol.status, crate::Status::Solved, "{}", sol.message);
            let set = Setting::new(&s);
            let span = landing_s(&s);
            let reach = Reach::new(&s, &set, span, STEP_S);
            // Linear interpolation on the grid (the bounds are smooth on
            // 10 ms; the slack below is far under their distance).
            let at = |v: &[f64], t: f64| {
                let k = ((t / reach.h) as usize).min(v.len() - 2);
                let w = t / reach.h - k as f64;
                v[k] * (1.0 - w) + v[k + 1] * w
            };
            let speed: Vec<f64> = reach.coef.iter().map(|c| c.speed).collect();
            let gamma = 20f64.to_radians();
            let sides = [Side::NegativeX, Side::PositiveX]
                .map(|side| (side.sign(), reach.margin(&s, &set, gamma, side)));
            let mut checked = 0;
            for k in 0..sol.t_s.len() {
                let t = sol.t_s[k];
                if t >= span {
                    break;
                }
                let air = (sol.vx_mps[k] - s.environment.wind_x_mps).hypot(sol.vz_mps[k]);
                assert!(air <= at(&speed, t) + 1e-6, "t = {t}: speed {air}");
                let phi = sol.theta_rad[k] + sol.delta_rad[k];
                assert!(at(&reach.lower, t) <= phi + 1e-6, "t = {t}: φ = {phi}");
                assert!(phi <= at(&reach.upper, t) + 1e-6, "t = {t}: φ = {phi}");
                for (sigma, trace) in &sides {
                    let c = gamma.tan() * (sol.z_m[k] - s.terminal.z_m)
                        - sigma * (sol.x_m[k] - s.terminal.x_m);
                    assert!(c <= at(trace, t) + 1e-6, "t = {t}, σ = {sigma}: c = {c}");
                }
                checked += 1;
            }
            assert!(checked > 5, "{checked} nodes before {span} s");
        }
    }

    /// The grid's error is far below the certificate's 1 m margin, and on
    /// the safe side: each step takes its ends' least favourable
    /// coefficients, so C̄ at 4 s falls as the step halves, by about half
    /// as much each time (first order), and the coarse grid's C̄ is within
    /// 0.3 m of the limit that the differences extrapolate to.
    #[test]
    fn halving_the_step_moves_the_margin_bound_little_and_down() {
        let s = paper_at(-100.0, Some(20.0));
        let set = Setting::new(&s);
        let gamma = 20f64.to_radians();
        let at_4s = |h: f64| {
            let reach = Reach::new(&s, &set, 4.0, h);
            *reach
                .margin(&s, &set, gamma, Side::NegativeX)
                .last()
                .unwrap()
        };
        let c = [1.0, 0.5, 0.25].map(|f| at_4s(f * STEP_S));
        let (d1, d2) = (c[0] - c[1], c[1] - c[2]);
        assert!(d1 > 0.0 && d2 > 0.0, "{c:?}");
        assert!((d2 / d1 - 0.5).abs() < 0.1, "{c:?}");
        // Richardson: the limit is c[2] − d2 (the remaining halvings sum
        // to d2).
        assert!(c[0] - (c[2] - d2) < 0.3, "{c:?}");
    }
}
