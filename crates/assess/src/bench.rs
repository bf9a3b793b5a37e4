//! The test bench: the twin of a design, the controllers compared on it and how to build
//! each one, its linear loop for margins and its full rig for tracking.

use flexstage_control::actuator::Compensation;
use flexstage_control::controller::{PidController, StageControl};
use flexstage_control::experiment::{Setup, Variant};
use flexstage_control::model::ResponseFit;
use flexstage_control::pi_notch::{AxisGains, PiNotchController, PiNotchParams};
use flexstage_control::rig::{AmplifierParams, PlantActuator, RigParams, RigPlant, SensorParams};
use flexstage_control::trajectory::Reference;
use flexstage_control::tuning::{
    ModalPlant, PlantMode, Structure, Tuned, TuningParams, loop_margins, tune,
};
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
    /// ([`flexstage_control::model::ResponseFit::from_modes`]).
    pub identified: Option<ResponseFit>,
    /// The backstepping's gain scale, sized by the margins
    /// ([`crate::inject::size_backstepping`]).
    pub backstepping_scale: f64,
}

/// What setting a bench up tunes and sizes (its slow part: frequency sweeps and sine
/// injections): enough to set the same bench up again with [`Bench::with_gains`], e.g. in
/// another process.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BenchGains {
    /// The tuned PID + FF.
    pub pid: PiNotchParams,
    /// The tuned PI + notch + FF.
    pub pi_notch: PiNotchParams,
    /// The backstepping's gain scale.
    pub backstepping_scale: f64,
}

/// The twin's modes (PEA inputs and outputs only).
pub fn plant_modes(twin: &Twin) -> Vec<PlantMode> {
    twin.modal
        .modes
        .iter()
        .map(|m| PlantMode {
            frequency: m.frequency,
            damping: m.damping,
            input: [m.input[0], m.input[1]],
            output: m.output,
        })
        .collect()
}

/// The twin's modes as a [`ModalPlant`] sampled at `t` with `delay` samples of delay and the
/// rig's sensor chain `sensor` (electronics and anti-aliasing filter) before the sampler.
pub fn modal_plant(twin: &Twin, t: f64, delay: usize, sensor: &SensorParams) -> Result<ModalPlant> {
    Ok(ModalPlant::with_sensor(
        plant_modes(twin),
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
            backstepping_scale: 1.0,
        };
        // The backstepping set up from the twin's sampled response, gains sized by the
        // margins (issue #18).
        bench.backstepping_scale = crate::inject::size_backstepping(&mut bench)?;
        Ok(bench)
    }

    /// What [`Bench::with_identified`] tuned and sized.
    pub fn gains(&self) -> BenchGains {
        BenchGains {
            pid: self.pid.params,
            pi_notch: self.pi_notch.params,
            backstepping_scale: self.backstepping_scale,
        }
    }

    /// The bench [`Bench::with_identified`] sets up from the same `setup`, `twin`, `tuning`
    /// and `identified`, with the `gains` it found ([`Bench::gains`]) instead of tuning and
    /// sizing again: the margins of the linear controllers are recomputed, the backstepping
    /// is set up at the recorded scale as the sizing leaves it.
    pub fn with_gains(
        setup: Setup,
        twin: Twin,
        tuning: TuningParams,
        identified: Option<ResponseFit>,
        gains: BenchGains,
    ) -> Result<Bench> {
        let plant = modal_plant(
            &twin,
            setup.rig.sample_time,
            setup.rig.delay,
            &setup.rig.sensor,
        )?;
        let tuned = |params: PiNotchParams| -> Result<Tuned> {
            let margins = loop_margins(&plant, &params, &tuning.margins)?;
            Ok(Tuned { params, margins })
        };
        let (pid, pi_notch) = (tuned(gains.pid)?, tuned(gains.pi_notch)?);
        let base = setup.controller.clone();
        let mut bench = Bench {
            setup,
            twin,
            pid,
            pi_notch,
            tuning,
            identified,
            backstepping_scale: gains.backstepping_scale,
        };
        let notches = bench.pi_notch.params.axes.map(|a| a.notches);
        let scale = gains.backstepping_scale;
        bench.setup.controller = match &bench.identified {
            Some(fit) => base.for_response(fit, notches, scale),
            None => base.for_sampled_plant(&plant_modes(&bench.twin), notches, scale),
        };
        Ok(bench)
    }

    /// The linear-controller parameters of a linear candidate (the scenario's PID as a
    /// PI-notch structure with the controller model's static gain).
    pub fn linear_params(&self, c: Candidate) -> Result<Option<PiNotchParams>> {
        Ok(match c {
            Candidate::PidTuned => Some(self.pid.params),
            Candidate::PiNotch => Some(self.pi_notch.params),
            Candidate::PidScenario => {
                let m = flexstage_control::model::StageModel::new(&self.setup.controller.model)?
                    .dc_gain()?;
                let p = self.setup.pid;
                let axis = AxisGains {
                    kp: p.kp,
                    ki: p.ki,
                    kd: p.kd,
                    notches: [None, None],
                };
                Some(PiNotchParams {
                    axes: [axis; 2],
                    static_gain: [[m[(0, 0)], m[(0, 1)]], [m[(1, 0)], m[(1, 1)]]],
                    sample_time: self.setup.rig.sample_time,
                })
            }
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
            Candidate::PidScenario => Box::new(PidController::new(
                &setup.controller.model,
                setup.pid,
                actuator,
                setup.rig.sample_time,
                reference,
            )?),
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
