//! The lumped rig the learning tests run on: the paper scenario's lumped stage in its rig
//! (delay, amplifier, PEAs, sensor chain, noise) under the PID + feed-forward baseline with
//! the inverse compensation, on the scenario's first trajectory (the 3:1 Lissajous at 2 Hz).

use flexstage_control::actuator::Compensation;
use flexstage_control::experiment::Setup;
use flexstage_control::learning::{
    LearningPlant, Readings, measure_learning_plant, rms_per_period,
};
use flexstage_control::pid::PID_FF;
use flexstage_sim::experiment::{StageControl, run};
use flexstage_sim::trajectory::Reference;

/// The rig, its reference, its sample time `t` \[s\] and the reference's period in samples.
pub struct LumpedRig {
    pub setup: Setup,
    pub reference: Reference,
    pub t: f64,
    pub period: usize,
}

impl LumpedRig {
    /// The paper scenario's rig (`setup` may be changed before use: the period and the
    /// sample time are the controller's).
    pub fn paper() -> LumpedRig {
        let scenario = flexstage_scenario::Scenario::paper();
        let setup = Setup::from_scenario(&scenario);
        let (reference, _) = Reference::from_scenario(&scenario.trajectories[0]);
        let t = setup.controller.observer.sample_time;
        let period = (0.5 / t).round() as usize; // the 3:1 Lissajous at 2 Hz
        LumpedRig {
            setup,
            reference,
            t,
            period,
        }
    }

    /// The baseline: PID + feed-forward with the inverse compensation.
    pub fn baseline(&self) -> Box<dyn StageControl> {
        self.setup
            .controller(&PID_FF, Compensation::Inverse, self.reference)
            .unwrap()
    }

    /// Fresh baseline loops as the learning layer's measurement and trials see them: the
    /// controller and the rig's readings.
    pub fn loops(
        &self,
    ) -> impl FnMut() -> flexstage_control::Result<(Box<dyn StageControl>, Readings)> + '_ {
        move || {
            let c = self
                .setup
                .controller(&PID_FF, Compensation::Inverse, self.reference)?;
            Ok((c, Readings::new(self.setup.lumped_plant()?)))
        }
    }

    /// The learning plant measured from the baseline loop's readings alone (`periods`
    /// periods per run of a 20 nm excitation).
    pub fn learning_plant(&self, periods: usize) -> LearningPlant {
        measure_learning_plant(&mut self.loops(), self.period, periods, 20e-9).unwrap()
    }

    /// The true output's RMS error per period, per axis, of `controller` run for `periods`
    /// periods on a fresh lumped plant.
    pub fn rms(&self, controller: &mut dyn StageControl, periods: usize) -> Vec<[f64; 2]> {
        let mut plant = self.setup.lumped_plant().unwrap();
        let duration = periods as f64 * self.period as f64 * self.t;
        let rec = run(controller, &mut plant, duration, self.t, |_| {});
        rms_per_period(&rec.error, self.period)
    }
}
