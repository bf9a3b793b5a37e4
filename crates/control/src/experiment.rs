//! The tracking experiment (Section 4, Figures 9–11) with the controllers of this crate: a
//! controller variant built from the scenario's settings ([`Setup`]), run on a simulated
//! stage by `flexstage_sim::experiment::run`.
//!
//! The runner takes any [`StagePlant`]: the lumped plant in its minimal loop
//! ([`experiment`], the controller's ideal-loop tests), the lumped plant in the scenario's
//! rig ([`Setup::lumped_plant`]) or the finite-element twin of the designed stage
//! (`flexstage-twin`), through [`experiment_on`]. Before a run, [`Setup::check_reference`]
//! refuses references the rig cannot follow (above the Nyquist frequency, beyond the
//! amplifier range, the amplifier current or the controller's stroke).

use flexstage_piezo::BoucWenParams;
use flexstage_scenario::Scenario;
use flexstage_sim::experiment::{Record, StageControl, run};
use flexstage_sim::model::StageModel;
use flexstage_sim::plant::{LumpedStage, Plant, PlantParams};
use flexstage_sim::rig::{RigParams, RigPlant, StagePlant};
use flexstage_sim::trajectory::{Reference, Workspace};

use crate::actuator::{ActuatorParams, Compensation};
use crate::backstepping::LawParams;
use crate::controller::{
    BacksteppingController, ControllerParams, Estimator, Inner, PidParams, Velocity,
};
use crate::error::{ControlError, Result};
use crate::estimator::KalmanParams;
use crate::feasibility::{Feasibility, feasibility};
use crate::observer::ObserverParams;
use crate::pi_notch::{PiNotchController, PiNotchParams};

/// The controller variants compared.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variant {
    /// Backstepping with the robust terms (Figure 9b).
    Robust,
    /// Backstepping without the robust terms (Figure 9a).
    NonRobust,
    /// PID with inverse-hysteresis feedforward, tuned on the simulated plant's sampled
    /// frequency response by the same procedure as [`Variant::PiNotch`] ([`crate::tuning`],
    /// [`Setup::pid_tuned`]); where nothing was tuned (the lumped plant), the scenario's
    /// gains (`controller.pid`), as [`Variant::PidScenario`].
    PidFeedforward,
    /// PID with inverse-hysteresis feedforward with the scenario's gains (`controller.pid`)
    /// and the controller model's static gain, untuned: not among the defaults
    /// ([`Variant::ALL`]), run only when asked for by name (`--variant pid-ff-scenario`).
    PidScenario,
    /// PI + notches + inverse-hysteresis feedforward tuned on the simulated plant's sampled
    /// frequency response ([`crate::tuning`], [`Setup::pi_notch`]): the default, the one
    /// controller that meets 6 dB / 40° on the twin with one sample of delay.
    PiNotch,
}

impl Variant {
    /// All variants, in report order (the default first).
    pub const ALL: [Variant; 4] = [
        Variant::PiNotch,
        Variant::Robust,
        Variant::NonRobust,
        Variant::PidFeedforward,
    ];

    /// The default controller (DECISIONS.md, Control).
    pub const DEFAULT: Variant = Variant::PiNotch;

    /// Short name for files and tables.
    pub fn name(self) -> &'static str {
        match self {
            Variant::Robust => "robust",
            Variant::NonRobust => "nonrobust",
            Variant::PidFeedforward => "pid-ff",
            Variant::PidScenario => "pid-ff-scenario",
            Variant::PiNotch => "pi-notch-ff",
        }
    }

    /// Every variant that can be asked for by name: [`Variant::ALL`] and
    /// [`Variant::PidScenario`].
    pub const NAMED: [Variant; 5] = [
        Variant::PiNotch,
        Variant::Robust,
        Variant::NonRobust,
        Variant::PidFeedforward,
        Variant::PidScenario,
    ];

    /// Parses [`Variant::name`] (any of [`Variant::NAMED`]).
    pub fn from_name(s: &str) -> Option<Variant> {
        Variant::NAMED.into_iter().find(|v| v.name() == s)
    }
}

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
    /// The PI + notch gains of [`Variant::PiNotch`], tuned on the plant that is simulated
    /// ([`crate::tuning::tune`]); `None` until tuned (that variant is then refused).
    pub pi_notch: Option<PiNotchParams>,
    /// The PID gains of [`Variant::PidFeedforward`] tuned by the same procedure
    /// ([`crate::tuning::tune`] with [`crate::tuning::Structure::Pid`]); `None`: that variant
    /// runs the scenario's gains.
    pub pid_tuned: Option<PiNotchParams>,
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
                },
            },
            pid: PidParams {
                kp: c.pid[0],
                ki: c.pid[1],
                kd: c.pid[2],
            },
            plant: PlantParams::from_scenario(s),
            rig: RigParams::from_scenario(s),
            pi_notch: None,
            pid_tuned: None,
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
            None => {
                let g = StageModel::new(&self.controller.model)?.dc_gain()?;
                [[g[(0, 0)], g[(0, 1)]], [g[(1, 0)], g[(1, 1)]]]
            }
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

    /// Builds the controller of a variant with the given compensation mode.
    pub fn controller(
        &self,
        variant: Variant,
        compensation: Compensation,
        reference: Reference,
    ) -> Result<Box<dyn StageControl>> {
        let mut actuator = self.controller.actuator;
        actuator.compensation = compensation;
        Ok(match variant {
            Variant::Robust | Variant::NonRobust => {
                let mut p = self.controller.clone();
                p.actuator = actuator;
                p.law.robust = variant == Variant::Robust;
                Box::new(BacksteppingController::new(&p, reference)?)
            }
            Variant::PidFeedforward if self.pid_tuned.is_some() => {
                let p = self.pid_tuned.expect("checked");
                Box::new(PiNotchController::new(p, actuator, reference)?)
            }
            Variant::PidFeedforward | Variant::PidScenario => {
                let p = self
                    .pid
                    .with_model(&self.controller.model, self.controller.observer.sample_time)?;
                Box::new(PiNotchController::new(p, actuator, reference)?)
            }
            Variant::PiNotch => {
                let p = self.pi_notch.ok_or_else(|| ControlError::Infeasible {
                    what: "controller pi-notch-ff".into(),
                    detail: "its gains are tuned on the simulated plant's frequency response \
                             (Setup::pi_notch), and none were given"
                        .into(),
                })?;
                Box::new(PiNotchController::new(p, actuator, reference)?)
            }
        })
    }
}

/// One experiment: variant, compensation, reference and duration on the setup's lumped
/// plant in its minimal loop ([`Setup::plant`]: the controller's ideal-loop conditions).
pub fn experiment(
    setup: &Setup,
    variant: Variant,
    compensation: Compensation,
    reference: Reference,
    duration: f64,
) -> Result<Record> {
    experiment_with_progress(setup, variant, compensation, reference, duration, |_| {})
}

/// [`experiment`] with a progress callback (called with the number of samples done since the
/// last call, every 1000 samples).
pub fn experiment_with_progress(
    setup: &Setup,
    variant: Variant,
    compensation: Compensation,
    reference: Reference,
    duration: f64,
    progress: impl FnMut(usize),
) -> Result<Record> {
    crate::error::positive("duration", duration)?;
    // The minimal loop has no delay: the controller predicts over none.
    let mut minimal = setup.clone();
    minimal.controller.delay = 0;
    let mut c = minimal.controller(variant, compensation, reference)?;
    let mut plant = Plant::new(setup.plant.clone())?;
    Ok(run(
        c.as_mut(),
        &mut plant,
        duration,
        setup.controller.observer.sample_time,
        progress,
    ))
}

/// One experiment on a given plant (e.g. [`Setup::lumped_plant`] or the twin of
/// `flexstage-twin`), from the plant's current state. `progress` is called with the number of
/// samples done since the last call, every 1000 samples.
pub fn experiment_on(
    setup: &Setup,
    variant: Variant,
    compensation: Compensation,
    reference: Reference,
    duration: f64,
    plant: &mut dyn StagePlant,
    progress: impl FnMut(usize),
) -> Result<Record> {
    crate::error::positive("duration", duration)?;
    let mut c = setup.controller(variant, compensation, reference)?;
    Ok(run(
        c.as_mut(),
        plant,
        duration,
        setup.controller.observer.sample_time,
        progress,
    ))
}
