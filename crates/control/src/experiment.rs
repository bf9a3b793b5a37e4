//! The tracking experiment (Section 4, Figures 9–11) with the controllers of this crate: a
//! controller of the registry ([`crate::registry`]) designed for a stage from the scenario's
//! settings ([`Setup`]), run on a simulated stage by `flexstage_sim::experiment::run`.
//!
//! The runner takes any [`StagePlant`]: the lumped plant in its minimal loop
//! ([`experiment`], the controller's ideal-loop tests), the lumped plant in the scenario's
//! rig ([`Setup::lumped_plant`]) or the finite-element twin of the designed stage
//! (`flexstage-twin`), through [`experiment_on`]. Before a run, [`Setup::check_reference`]
//! refuses references the rig cannot follow (above the Nyquist frequency, beyond the
//! amplifier range, the amplifier current or the controller's stroke).

use std::sync::Arc;

use flexstage_piezo::BoucWenParams;
use flexstage_scenario::Scenario;
use flexstage_sim::experiment::{Record, StageControl, run};
use flexstage_sim::model::StageModel;
use flexstage_sim::plant::{LumpedStage, Plant, PlantParams};
use flexstage_sim::rig::{RigParams, RigPlant, StagePlant};
use flexstage_sim::trajectory::{Reference, Workspace};

use crate::actuator::{ActuatorParams, Compensation};
use crate::backstepping::LawParams;
use crate::controller::{ControllerParams, Estimator, Inner, Velocity};
use crate::error::{ControlError, Result};
use crate::estimator::KalmanParams;
use crate::feasibility::{Feasibility, feasibility};
use crate::observer::ObserverParams;
use crate::pid::PidParams;
use crate::registry::{Controller, Design, Stage};

/// Everything needed to run experiments: controller, baseline and plant settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Setup {
    /// Backstepping controller settings (robust on; the non-robust variant switches it off).
    pub controller: ControllerParams,
    /// PID baseline gains.
    pub pid: PidParams,
    /// The lumped plant (truth parameters, cross terms) in its minimal loop.
    pub plant: PlantParams,
    /// The loop of the scenario's rig (`[rig]`), for [`Setup::lumped_plant`] and the twin.
    pub rig: RigParams,
}

impl Setup {
    /// The setup of a scenario: controller model = `stage.guess`, plant = `stage.truth`
    /// with the cross terms, gains from `controller`, sensors, timing and hysteresis from the
    /// scenario. The bias voltage is the middle of the amplifier range.
    pub fn from_scenario(s: &Scenario) -> Setup {
        let h = &s.hysteresis;
        let hysteresis = [BoucWenParams::from(&h.pea1), BoucWenParams::from(&h.pea2)];
        let voltage_range = [h.voltage_min, h.voltage_max];
        let bias_voltage = 0.5 * (h.voltage_min + h.voltage_max);
        let c = &s.controller;
        Setup {
            controller: ControllerParams {
                model: s.stage.guess.clone(),
                coupling: 0.0,
                observer: ObserverParams {
                    gain: c.observer_gain,
                    sample_time: s.simulation.sample_time,
                    disturbance_gain: c.disturbance_gain,
                },
                law: LawParams {
                    error_gain: c.error_gain,
                    eta_gain: c.eta_gain,
                    feedback_gain: c.feedback_gain,
                    robust: true,
                    eta_bound: c.eta_bound,
                    a_bound: c.a_bound,
                    boundary_layer: c.boundary_layer,
                },
                velocity: if c.observer_velocity {
                    Velocity::Observer
                } else {
                    Velocity::FiniteDifference
                },
                inner: Inner::Command,
                estimator: Estimator::Kalman(KalmanParams::with_sensor_noise(s.sensors.noise_std)),
                disturbance_feedback: true,
                measurement_notches: [[None; 2]; 2],
                delay: RigParams::from_scenario(s).delay,
                actuator: ActuatorParams {
                    hysteresis,
                    voltage_range,
                    bias_voltage,
                    stroke: s.controller.stroke,
                    compensation: Compensation::Inverse,
                    max_voltage_step: amplifier_step(s),
                },
            },
            pid: PidParams {
                kp: c.pid[0],
                ki: c.pid[1],
                kd: c.pid[2],
            },
            plant: PlantParams::from_scenario(s),
            rig: RigParams::from_scenario(s),
        }
    }

    /// The lumped plant (truth parameters and cross terms of [`Setup::plant`]) inside the
    /// scenario's rig ([`Setup::rig`]): delay, amplifier limits, the rig's own PEAs with creep,
    /// sensor dynamics and noise, floor vibration.
    pub fn lumped_plant(&self) -> Result<RigPlant<LumpedStage>> {
        Ok(self.plant.in_rig(self.rig.clone())?)
    }

    /// Whether `reference` over `duration` seconds can be followed on this rig, with the
    /// static gain `dc_gain` (x_nom → q) of the plant it will run on (`None`: the controller
    /// model's). Errors name what is exceeded and by how much ([`feasibility`]).
    pub fn check_reference(
        &self,
        reference: &Reference,
        duration: f64,
        dc_gain: Option<[[f64; 2]; 2]>,
    ) -> Result<Feasibility> {
        let gain = match dc_gain {
            Some(g) => g,
            None => self.controller_dc_gain()?,
        };
        feasibility(
            reference,
            duration,
            self.controller.observer.sample_time,
            gain,
            &self.controller.actuator,
            &self.rig.amplifier,
        )
    }

    /// The static gain x_nom → q of the controllers' model.
    pub fn controller_dc_gain(&self) -> Result<[[f64; 2]; 2]> {
        let g = StageModel::new(&self.controller.model)?.dc_gain()?;
        Ok([[g[(0, 0)], g[(0, 1)]], [g[(1, 0)], g[(1, 1)]]])
    }

    /// The designed workspace of the controller's model: the image of |x_nom,i| ≤ stroke.
    pub fn workspace(&self) -> Result<Workspace> {
        let m = StageModel::new(&self.controller.model)?;
        let g = m
            .dc_gain()?
            .try_inverse()
            .ok_or_else(|| crate::error::ControlError::Singular {
                what: "static gain G_dc".into(),
            })?;
        Ok(Workspace {
            inverse_gain: [[g[(0, 0)], g[(0, 1)]], [g[(1, 0)], g[(1, 1)]]],
            stroke: self.controller.actuator.stroke,
        })
    }

    /// The controllers' actuator stage with the compensation mode `compensation`.
    pub fn actuator(&self, compensation: Compensation) -> ActuatorParams {
        let mut a = self.controller.actuator;
        a.compensation = compensation;
        a
    }

    /// `controller` designed from the scenario's settings ([`Setup::design`]) and built with
    /// `compensation` for `reference`, predicting over the rig's delay.
    pub fn controller(
        &self,
        controller: &Controller,
        compensation: Compensation,
        reference: Reference,
    ) -> Result<Box<dyn StageControl>> {
        self.design(controller)?.build(
            self.actuator(compensation),
            self.controller.delay,
            reference,
        )
    }

    /// The design of `controller` from the scenario's settings alone
    /// ([`Stage::scenario`]: nothing tuned); refused for a controller whose design needs the
    /// stage's sampled response.
    pub fn design(&self, controller: &Controller) -> Result<Arc<dyn Design>> {
        (controller.design)(&Stage::scenario(self))?.ok_or_else(|| ControlError::Infeasible {
            what: format!("controller {}", controller.name),
            detail: "it is designed from the stage's sampled response, and this stage has none"
                .into(),
        })
    }
}

/// One experiment: `controller` designed from the scenario's settings ([`Setup::design`]),
/// compensation, reference and duration on the setup's lumped plant in its minimal loop
/// ([`Setup::plant`]: the controller's ideal-loop conditions).
pub fn experiment(
    setup: &Setup,
    controller: &Controller,
    compensation: Compensation,
    reference: Reference,
    duration: f64,
) -> Result<Record> {
    let design = setup.design(controller)?;
    experiment_with_progress(setup, &*design, compensation, reference, duration, |_| {})
}

/// The design `design` on the setup's lumped plant in its minimal loop, with a progress
/// callback (called with the number of samples done since the last call, every 1000
/// samples).
pub fn experiment_with_progress(
    setup: &Setup,
    design: &dyn Design,
    compensation: Compensation,
    reference: Reference,
    duration: f64,
    progress: impl FnMut(usize),
) -> Result<Record> {
    crate::error::positive("duration", duration)?;
    // The minimal loop has no delay: the controller predicts over none.
    let mut c = design.build(setup.actuator(compensation), 0, reference)?;
    let mut plant = Plant::new(setup.plant.clone())?;
    Ok(run(
        c.as_mut(),
        &mut plant,
        duration,
        setup.controller.observer.sample_time,
        progress,
    ))
}

/// One experiment of the design `design` on a given plant (e.g. [`Setup::lumped_plant`] or
/// the twin of `flexstage-twin`) with the rig's delay, from the plant's current state.
/// `progress` is called with the number of samples done since the last call, every 1000
/// samples.
pub fn experiment_on(
    setup: &Setup,
    design: &dyn Design,
    compensation: Compensation,
    reference: Reference,
    duration: f64,
    plant: &mut dyn StagePlant,
    progress: impl FnMut(usize),
) -> Result<Record> {
    crate::error::positive("duration", duration)?;
    let delay = setup.controller.delay;
    let mut c = design.build(setup.actuator(compensation), delay, reference)?;
    Ok(run(
        c.as_mut(),
        plant,
        duration,
        setup.controller.observer.sample_time,
        progress,
    ))
}

/// The linear controllers' rate limit [V per sample] from what the lab knows: the scenario's
/// amplifier (datasheet bandwidth, slew rate and current limit, the PEA's capacitance) and
/// sample time ([`crate::actuator::max_voltage_step`]).
fn amplifier_step(s: &Scenario) -> f64 {
    let a = RigParams::from_scenario(s).amplifier;
    crate::actuator::max_voltage_step(a.bandwidth, a.max_rate(), s.simulation.sample_time)
}
