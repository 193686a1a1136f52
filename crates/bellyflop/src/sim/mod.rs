//! The truth plant for closed-loop guidance: what the vehicle actually does when
//! a guidance law commands it.
//!
//! - [`plant`]: the truth dynamics, Eq. (1)–(3) with the nozzle-rate state
//!   δ̇ = χ of Eq. (8), perturbed by wind, a drag-coefficient error, a thrust
//!   error and a gimbal bias ([`truth_rhs`]); actuator saturation
//!   ([`saturate`]); a fixed-step RK4 integrator with zero-order hold on the
//!   command and the wind ([`Plant`]); touchdown, propellant and time-limit
//!   detection ([`Outcome`], [`Touchdown`]).
//! - [`truth`]: the true vehicle's state ([`PlantState`]) and its
//!   deviations from the guidance model ([`TruthParams`]), used by both the
//!   plant and the dispersions.
//! - [`verdict`]: touchdowns judged `landed`, `hard_landing` or `crash`
//!   ([`TouchdownLimits`], [`RunOutcome`]).
//! - [`disturbance`]: the Monte-Carlo dispersions ([`Dispersions`], defaults
//!   listed there) and one deterministic draw of them ([`Realization`]):
//!   initial-state offsets, model errors, steady wind plus Gauss–Markov gusts,
//!   and navigation noise.
//!
//! [`run`] couples them: every plant step it measures the state with
//! navigation noise, asks the controller for a command, draws the wind and
//! advances the plant, until the run ends.
//!
//! Everything here is deterministic: a run depends only on the scenario, the
//! configuration, the controller and the `(seed, run_index)` of its
//! realization, never on thread count or scheduling.

pub mod disturbance;
pub mod plant;
pub mod truth;
pub mod verdict;

pub use disturbance::{Dispersions, InitialOffset, Realization};
pub use plant::{
    rk4_step, saturate, truth_rhs, Command, Outcome, Plant, PlantConfig, Saturation,
    SaturationCounts, StepResult, Touchdown,
};
pub use truth::{PlantState, TruthParams};
pub use verdict::{RunOutcome, TouchdownLimits};

/// Run the plant in closed loop until it ends (touchdown, propellant
/// exhausted, time limit or a non-finite state) and return how it ended.
///
/// Every plant step (at [`PlantConfig::rate_hz`]): the state is measured with
/// the realization's navigation noise ([`Realization::measure`]), the
/// controller maps (time \[s\], measured state) to a [`Command`], the wind for
/// the step is drawn ([`Realization::wind_at_step`]) and the plant advances one
/// step with both held constant. A guidance law that runs slower than the
/// plant can hold its last command inside the closure, or drive
/// [`Plant::step`] itself.
///
/// Terminates: the plant ends at the latest at [`PlantConfig::max_time_s`].
/// The saturation counts of the run stay available in [`Plant::saturation`].
pub fn run(
    plant: &mut Plant,
    realization: &mut Realization,
    mut controller: impl FnMut(f64, &PlantState) -> Command,
) -> Outcome {
    loop {
        let measured = realization.measure(plant.state());
        let command = controller(plant.time_s(), &measured);
        let wind_x_mps = realization.wind_at_step(plant.dt_s());
        if let StepResult::Ended(outcome) = plant.step(command, wind_x_mps) {
            return outcome;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::range::Range;
    use crate::input::scenario::Scenario;

    #[test]
    fn closed_loop_run_ends_deterministically() {
        // Full thrust with the nozzle held straight: with the paper's
        // belly-first start the vehicle falls and touches down or runs out of
        // time, but the run ends, and the same (seed, run) repeats exactly.
        let scenario = Scenario::paper();
        let config = PlantConfig {
            max_time_s: 20.0,
            ..PlantConfig::default()
        };
        let dispersions = Dispersions::default();
        let once = || {
            let mut r = dispersions.sample(7, 3);
            let mut plant = Plant::from_realization(&scenario, &config, &r).unwrap();
            let max_rate = plant.model().max_gimbal_rate_radps;
            let dt = plant.dt_s();
            let outcome = run(&mut plant, &mut r, |_, s| {
                Command::tracking_gimbal(2.0e6, 0.0, s.gimbal_rad, dt, max_rate)
            });
            (outcome, *plant.saturation())
        };
        let (a, sat_a) = once();
        let (b, sat_b) = once();
        assert_eq!(a, b);
        assert_eq!(sat_a, sat_b);
        assert!(sat_a.steps > 0);
    }

    #[test]
    fn range_errors_name_the_field() {
        let err = Range::closed(0.0, 1.0, "m").check("a.b", -1.0).unwrap_err();
        assert_eq!(
            err.to_string(),
            "a.b = -1 is out of range: allowed [0, 1] m"
        );
        assert!(Range::closed(0.0, 1.0, "").check("f", f64::NAN).is_err());
        assert!(Range::open_closed(0.0, 1.0, "").check("f", 0.0).is_err());
        assert!(Range::open(0.0, 1.0, "").check("f", 1.0).is_err());
        assert!(Range::open(0.0, 1.0, "").check("f", 0.5).is_ok());
    }
}
