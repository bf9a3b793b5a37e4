//! Problems with known answers, for tests, examples and benchmarks.

use flexstage_scenario::{Scenario, StageParams};
use flexstage_sim::plant::{PlantActuator, PlantParams};

use crate::excitation::{Excitation, SimulationParams};

/// Table 4's guess (the estimator's starting point), damping ratio 2 % (DECISIONS.md).
pub fn table4_guess() -> StageParams {
    Scenario::paper().stage.guess
}

/// Table 4's estimate (the simulated plant's truth), damping ratio 2 %.
pub fn table4_truth() -> StageParams {
    Scenario::paper().stage.truth
}

/// A simulation of the paper's scenario: plant truth = Table 4 estimates, sensors, timing
/// and hysteresis of the scenario, the default excitation of `duration` seconds.
///
/// `linear` = true gives the linear model of Eq. (36): ideal actuator (x_nom commanded
/// directly), no cross terms. `noisy` = false removes the sensor noise and quantization on
/// q_o and x_in.
pub fn paper_simulation(duration: f64, linear: bool, noisy: bool) -> SimulationParams {
    simulation(&Scenario::paper(), duration, linear, noisy)
}

/// The simulation of a scenario (see [`paper_simulation`]).
pub fn simulation(s: &Scenario, duration: f64, linear: bool, noisy: bool) -> SimulationParams {
    let mut plant = PlantParams::from_scenario(s);
    if linear {
        plant.actuator = PlantActuator::Ideal;
        plant.coupling = 0.0;
    }
    if !noisy {
        plant.resolution = [0.0; 2];
        plant.noise_std = [0.0; 2];
    }
    let h = &plant.hysteresis[0];
    let slope = flexstage_sim::pea::mean_slope(h, plant.voltage_range);
    let excitation = Excitation {
        duration,
        amplitude: 0.9 * s.controller.stroke,
        ..Excitation::default()
    };
    SimulationParams {
        plate_sensor: [plant.resolution[0], plant.noise_std[0]],
        plant,
        excitation,
        oversample: 10,
        slope,
    }
}
