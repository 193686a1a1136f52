//! How a closed-loop run ended, with touchdowns judged against limits:
//! `landed` within the landing spec, `crash` beyond the survivable limits,
//! `hard_landing` between ([`TouchdownLimits`], [`RunOutcome`]).

use serde::{Deserialize, Serialize};

use crate::input::error::InputError;
use crate::input::range::Range;
use crate::sim::plant::{Outcome, Touchdown};

/// How a run ended; the three touchdown classes, then the plant's other ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RunOutcome {
    /// Touchdown within the landing spec (position, speed and pitch).
    Landed,
    /// Touchdown outside the landing spec, within the survivable limits.
    HardLanding,
    /// Touchdown beyond a survivable limit (vertical or horizontal speed, or
    /// pitch).
    Crash,
    /// The propellant ran out in flight.
    PropellantExhausted,
    /// The plant's time limit was reached in flight.
    TimeLimit,
    /// The state became non-finite.
    NonFinite,
}

impl RunOutcome {
    /// Every outcome, in the order above.
    pub const ALL: [RunOutcome; 6] = [
        RunOutcome::Landed,
        RunOutcome::HardLanding,
        RunOutcome::Crash,
        RunOutcome::PropellantExhausted,
        RunOutcome::TimeLimit,
        RunOutcome::NonFinite,
    ];

    /// The snake_case name (as serialized).
    pub fn as_str(self) -> &'static str {
        match self {
            RunOutcome::Landed => "landed",
            RunOutcome::HardLanding => "hard_landing",
            RunOutcome::Crash => "crash",
            RunOutcome::PropellantExhausted => "propellant_exhausted",
            RunOutcome::TimeLimit => "time_limit",
            RunOutcome::NonFinite => "non_finite",
        }
    }

    /// Whether the run ended on the ground (any touchdown class).
    pub fn touched_down(self) -> bool {
        matches!(
            self,
            RunOutcome::Landed | RunOutcome::HardLanding | RunOutcome::Crash
        )
    }

    /// The outcome of `o`, a touchdown judged by `limits`.
    pub fn of(o: &Outcome, limits: &TouchdownLimits) -> RunOutcome {
        match o {
            Outcome::Touchdown(td) => limits.classify(td),
            Outcome::PropellantExhausted { .. } => RunOutcome::PropellantExhausted,
            Outcome::TimeLimit { .. } => RunOutcome::TimeLimit,
            Outcome::NonFinite { .. } => RunOutcome::NonFinite,
        }
    }
}

/// Limits that classify a touchdown (table `[touchdown]` of the closed-loop
/// configuration). Missing fields take the defaults.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TouchdownLimits {
    /// `landed`: |x − x_f| at most this \[m\]. Default 1, the landing spec
    /// of the Monte-Carlo campaigns (issue 6). Range (0, 1000].
    pub landed_position_m: f64,
    /// `landed`: speed ‖(Vx, Vz)‖ at most this [m/s]. Default 1. Range
    /// (0, 100], and at most both crash speeds.
    pub landed_speed_mps: f64,
    /// `landed`: |θ − θ_f| at most this \[deg\]. Default 2. Range (0, 180],
    /// and at most `crash_pitch_deg`.
    pub landed_pitch_deg: f64,
    /// `crash`: |Vz| above this [m/s]. Default 5: five times the landing
    /// spec, about what landing legs absorb. Range (0, 100].
    pub crash_vertical_speed_mps: f64,
    /// `crash`: |Vx| above this [m/s]. Default 3: sideways speed tips a
    /// vehicle over on its legs before vertical speed breaks them. Range
    /// (0, 100].
    pub crash_horizontal_speed_mps: f64,
    /// `crash`: |θ − θ_f| above this \[deg\]. Default 10: a vehicle that far
    /// off upright lands on the edge of its leg footprint. Range (0, 180].
    pub crash_pitch_deg: f64,
}

impl Default for TouchdownLimits {
    fn default() -> Self {
        TouchdownLimits {
            landed_position_m: 1.0,
            landed_speed_mps: 1.0,
            landed_pitch_deg: 2.0,
            crash_vertical_speed_mps: 5.0,
            crash_horizontal_speed_mps: 3.0,
            crash_pitch_deg: 10.0,
        }
    }
}

impl TouchdownLimits {
    /// `crash` beyond any crash limit, else `landed` within every landing
    /// limit, else `hard_landing`. A non-finite touchdown value is a crash.
    pub fn classify(&self, td: &Touchdown) -> RunOutcome {
        let pitch = td.pitch_error_deg.abs();
        let within = |v: f64, limit: f64| v <= limit; // false for NaN
        if !within(
            td.vertical_velocity_mps.abs(),
            self.crash_vertical_speed_mps,
        ) || !within(
            td.horizontal_velocity_mps.abs(),
            self.crash_horizontal_speed_mps,
        ) || !within(pitch, self.crash_pitch_deg)
        {
            RunOutcome::Crash
        } else if within(td.x_error_m.abs(), self.landed_position_m)
            && within(td.speed_mps, self.landed_speed_mps)
            && within(pitch, self.landed_pitch_deg)
        {
            RunOutcome::Landed
        } else {
            RunOutcome::HardLanding
        }
    }

    /// Each limit in its range, and the landing spec inside the survivable
    /// limits.
    pub fn validate(&self) -> Result<(), InputError> {
        let rows: [(&str, f64, f64, &str); 6] = [
            ("landed_position_m", self.landed_position_m, 1000.0, "m"),
            ("landed_speed_mps", self.landed_speed_mps, 100.0, "m/s"),
            ("landed_pitch_deg", self.landed_pitch_deg, 180.0, "deg"),
            (
                "crash_vertical_speed_mps",
                self.crash_vertical_speed_mps,
                100.0,
                "m/s",
            ),
            (
                "crash_horizontal_speed_mps",
                self.crash_horizontal_speed_mps,
                100.0,
                "m/s",
            ),
            ("crash_pitch_deg", self.crash_pitch_deg, 180.0, "deg"),
        ];
        for (key, value, hi, unit) in rows {
            Range::open_closed(0.0, hi, unit).check(&format!("touchdown.{key}"), value)?;
        }
        let crash_speed = self
            .crash_vertical_speed_mps
            .min(self.crash_horizontal_speed_mps);
        if self.landed_speed_mps > crash_speed {
            return Err(InputError::Inconsistent {
                field: "touchdown.landed_speed_mps".into(),
                value: self.landed_speed_mps,
                reason: format!(
                    "must not exceed the crash speeds (smallest {crash_speed} m/s): a landing within spec cannot be a crash"
                ),
            });
        }
        if self.landed_pitch_deg > self.crash_pitch_deg {
            return Err(InputError::Inconsistent {
                field: "touchdown.landed_pitch_deg".into(),
                value: self.landed_pitch_deg,
                reason: format!(
                    "must not exceed touchdown.crash_pitch_deg = {} deg",
                    self.crash_pitch_deg
                ),
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::truth::PlantState;

    fn touchdown(x: f64, vx: f64, vz: f64, pitch_deg: f64) -> Touchdown {
        Touchdown {
            time_s: 10.0,
            x_error_m: x,
            vertical_velocity_mps: vz,
            horizontal_velocity_mps: vx,
            speed_mps: vx.hypot(vz),
            pitch_error_deg: pitch_deg,
            pitch_rate_degps: 0.0,
            propellant_left_kg: 1000.0,
            state: PlantState {
                x_m: x,
                z_m: 0.0,
                vx_mps: vx,
                vz_mps: vz,
                theta_rad: pitch_deg.to_radians(),
                pitch_rate_radps: 0.0,
                mass_kg: 90_000.0,
                gimbal_rad: 0.0,
            },
        }
    }

    /// Issue 18: a 116 m/s impact at 81° pitch was reported as `touchdown`.
    #[test]
    fn touchdowns_are_classified() {
        let l = TouchdownLimits::default();
        let c = |x, vx, vz, p| l.classify(&touchdown(x, vx, vz, p));
        assert_eq!(c(-30.0, 40.0, -108.9, 81.0), RunOutcome::Crash);
        assert_eq!(c(0.5, 0.3, -0.6, 1.0), RunOutcome::Landed);
        assert_eq!(c(1.0, 0.0, -1.0, -2.0), RunOutcome::Landed);
        // Outside the spec but survivable, on each axis.
        assert_eq!(c(50.0, 0.0, -0.5, 0.0), RunOutcome::HardLanding);
        assert_eq!(c(0.0, 0.0, -4.9, 0.0), RunOutcome::HardLanding);
        assert_eq!(c(0.0, 2.9, -0.5, 0.0), RunOutcome::HardLanding);
        assert_eq!(c(0.0, 0.0, -0.5, -9.0), RunOutcome::HardLanding);
        // Beyond each survivable limit.
        assert_eq!(c(0.0, 0.0, -5.1, 0.0), RunOutcome::Crash);
        assert_eq!(c(0.0, -3.1, -0.5, 0.0), RunOutcome::Crash);
        assert_eq!(c(0.0, 0.0, -0.5, 10.5), RunOutcome::Crash);
        assert_eq!(c(0.0, 0.0, f64::NAN, 0.0), RunOutcome::Crash);
    }

    #[test]
    fn outcomes_serialize_as_their_names() {
        for o in RunOutcome::ALL {
            assert_eq!(serde_json::to_value(o).unwrap(), o.as_str());
        }
    }

    #[test]
    fn limits_are_validated() {
        assert!(TouchdownLimits::default().validate().is_ok());
        let bad = TouchdownLimits {
            crash_pitch_deg: 0.0,
            ..TouchdownLimits::default()
        };
        let e = bad.validate().unwrap_err();
        assert!(e.to_string().contains("touchdown.crash_pitch_deg"), "{e}");
        let bad = TouchdownLimits {
            landed_speed_mps: 4.0,
            ..TouchdownLimits::default()
        };
        let e = bad.validate().unwrap_err();
        assert!(e.to_string().contains("touchdown.landed_speed_mps"), "{e}");
    }
}
