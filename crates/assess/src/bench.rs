//! The test bench: the twin of a design, the controllers compared on it and how to build
//! each one, its linear loop for margins and its full rig for tracking.

use flexstage_control::actuator::Compensation;
use flexstage_control::experiment::{Setup, Variant};
use flexstage_control::pi_notch::{PiNotchController, PiNotchParams};
use flexstage_control::tuning::{Structure, Tuned, TuningParams, loop_margins, tune};
use flexstage_identify::response::ResponseFit;
use flexstage_sim::experiment::StageControl;
use flexstage_sim::modal::ModalPlant;
use flexstage_sim::rig::{AmplifierParams, PlantActuator, RigParams, RigPlant, SensorParams};
use flexstage_sim::trajectory::Reference;
use flexstage_twin::{Twin, TwinStage};

use crate::error::Result;

/// The controllers compared.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Candidate {
    /// Robust backstepping with the disturbance observer (scenario gains).
    Robust,
    /// Backstepping without the robust terms.
    NonRobust,
    /// The PID + FF baseline with the scenario's gains (`controller.pid`) and the
    /// controller model's static gain.
    PidScenario,
    /// PID + FF with the twin's static gain, tuned by [`flexstage_control::tuning`].
    PidTuned,
    /// PI + notch + FF with the twin's static gain, tuned by the same procedure.
    PiNotch,
}

impl Candidate {
    /// All, in report order.
    pub const ALL: [Candidate; 5] = [
        Candidate::Robust,
        Candidate::NonRobust,
        Candidate::PidScenario,
        Candidate::PidTuned,
        Candidate::PiNotch,
    ];

    /// Short name for files and tables (the `track` variant's name: `pid-ff` is the tuned
    /// PID, `pid-ff-scenario` the scenario's gains).
    pub fn name(self) -> &'static str {
        match self {
            Candidate::Robust => "robust",
            Candidate::NonRobust => "nonrobust",
            Candidate::PidScenario => "pid-ff-scenario",
            Candidate::PidTuned => "pid-ff",
            Candidate::PiNotch => "pi-notch-ff",
        }
    }

    /// Whether the controller is linear (margins computed analytically from its transfer
    /// function; otherwise by sine injection).
    pub fn is_linear(self) -> bool {
        !matches!(self, Candidate::Robust | Candidate::NonRobust)
    }
}

/// The bench: controllers' setup, the twin and the tuned baselines.
#[derive(Debug, Clone)]
pub struct Bench {
    /// The controllers' settings (backstepping model, gains, actuator) and the rig.
    pub setup: Setup,
    /// The twin of the design.
    pub twin: Twin,
    /// The tuned PID + FF.
    pub pid: Tuned,
    /// The tuned PI + notch + FF.
    pub pi_notch: Tuned,
    /// The tuning settings used.
    pub tuning: TuningParams,
    /// The response fit the backstepping's model comes from: one identified on the stage
    /// (`flexstage_identify::response`), or `None` for the fit of the twin's exact modes
    /// ([`flexstage_identify::response::ResponseFit::from_modes`]).
    pub identified: Option<ResponseFit>,
}

/// The twin's modes as a [`ModalPlant`] sampled at `t` with `delay` samples of delay and the
/// rig's sensor chain `sensor` (electronics and anti-aliasing filter) before the sampler.
pub fn modal_plant(twin: &Twin, t: f64, delay: usize, sensor: &SensorParams) -> Result<ModalPlant> {
    Ok(ModalPlant::with_sensor(
        twin.modal.plant_modes(),
        t,
        delay,
        sensor,
    )?)
}

impl Bench {
    /// Tunes the loop-shaping baselines on the twin's sampled loop with the rig's delay and
    /// returns the bench.
    pub fn new(setup: Setup, twin: Twin, tuning: TuningParams) -> Result<Bench> {
        Bench::with_identified(setup, twin, tuning, None)
    }

    /// [`Bench::new`] with the backstepping's model from an `identified` response fit
    /// ([`Bench::identified`]).
    pub fn with_identified(
        setup: Setup,
        twin: Twin,
        tuning: TuningParams,
        identified: Option<ResponseFit>,
    ) -> Result<Bench> {
        let plant = modal_plant(
            &twin,
            setup.rig.sample_time,
            setup.rig.delay,
            &setup.rig.sensor,
        )?;
        let pid = tune(&plant, Structure::Pid, &tuning)?;
        let pi_notch = tune(&plant, Structure::PiNotch, &tuning)?;
        let mut bench = Bench {
            setup,
            twin,
            pid,
            pi_notch,
            tuning,
            identified,
        };
        // The backstepping set up from the twin's sampled response, gains sized by the
        // margins (issue #18).
        crate::inject::size_backstepping(&mut bench)?;
        Ok(bench)
    }

    /// The linear-controller parameters of a linear candidate (the scenario's PID as a
    /// PI-notch structure with the controller model's static gain).
    pub fn linear_params(&self, c: Candidate) -> Result<Option<PiNotchParams>> {
        Ok(match c {
            Candidate::PidTuned => Some(self.pid.params),
            Candidate::PiNotch => Some(self.pi_notch.params),
            Candidate::PidScenario => Some(
                self.setup
                    .pid
                    .with_model(&self.setup.controller.model, self.setup.rig.sample_time)?,
            ),
            Candidate::Robust | Candidate::NonRobust => None,
        })
    }

    /// Builds a controller for `reference` with `compensation`, using `setup` (the bench's
    /// or a perturbed copy).
    pub fn controller_with(
        &self,
        setup: &Setup,
        c: Candidate,
        compensation: Compensation,
        reference: Reference,
    ) -> Result<Box<dyn StageControl>> {
        let mut actuator = setup.controller.actuator;
        actuator.compensation = compensation;
        Ok(match c {
            Candidate::Robust => setup.controller(Variant::Robust, compensation, reference)?,
            Candidate::NonRobust => {
                setup.controller(Variant::NonRobust, compensation, reference)?
            }
            Candidate::PidScenario => {
                let p = setup
                    .pid
                    .with_model(&setup.controller.model, setup.rig.sample_time)?;
                Box::new(PiNotchController::new(p, actuator, reference)?)
            }
            Candidate::PidTuned | Candidate::PiNotch => {
                let p = self.linear_params(c)?.expect("linear candidate");
                Box::new(PiNotchController::new(p, actuator, reference)?)
            }
        })
    }

    /// [`Bench::controller_with`] on the bench's own setup.
    pub fn controller(
        &self,
        c: Candidate,
        compensation: Compensation,
        reference: Reference,
    ) -> Result<Box<dyn StageControl>> {
        self.controller_with(&self.setup, c, compensation, reference)
    }

    /// The linear loop of the rig with `delay` samples: ideal amplifier, no PEA (x_nom
    /// applied directly), the rig's sensor chain (electronics and anti-aliasing filter)
    /// without noise, no creep or floor; the twin without its geometric correction. What
    /// margins are computed on.
    pub fn linear_rig(&self, delay: usize) -> RigParams {
        let mut r = self.setup.rig.clone();
        r.delay = delay;
        r.actuator = PlantActuator::Ideal;
        r.amplifier = AmplifierParams::ideal();
        r.sensor.flicker_corner = 0.0;
        r.creep.factor = 0.0;
        r.floor.velocity_rms = 0.0;
        r.noise_std = [0.0; 2];
        r.resolution = [0.0; 2];
        r
    }

    /// The linear twin in the linear rig (see [`Bench::linear_rig`]).
    pub fn linear_plant(&self, delay: usize) -> Result<RigPlant<TwinStage>> {
        let rig = self.linear_rig(delay);
        let stage = TwinStage::new(&self.twin.modal, None, rig.substep());
        Ok(RigPlant::new(rig, stage)?)
    }

    /// Margins of a linear candidate computed from its transfer function on the twin's
    /// sampled loop.
    pub fn analytic_margins(
        &self,
        c: Candidate,
        delay: usize,
    ) -> Result<Option<[flexstage_control::margins::Margins; 2]>> {
        let Some(p) = self.linear_params(c)? else {
            return Ok(None);
        };
        let plant = modal_plant(
            &self.twin,
            self.setup.rig.sample_time,
            delay,
            &self.setup.rig.sensor,
        )?;
        Ok(Some(loop_margins(&plant, &p, &self.tuning.margins)?))
    }
}
