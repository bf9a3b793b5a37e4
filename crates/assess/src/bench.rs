//! The test bench: the twin of a design, the controllers of `flexstage-control`'s registry
//! designed for it (from a lab measurement of its loop, [`Bench::measured`]: tuned on the
//! measured loop model, the backstepping sized by its margins on that model run in the time
//! domain, [`MeasuredLoop`]; or, as a reference, on the twin's truth, [`Bench::new`]), its
//! linear loop for scoring margins ([`LinearLoop`]) and its full rig for tracking.

use std::sync::Arc;

use flexstage_control::ControlError;
use flexstage_control::actuator::{ActuatorParams, Compensation};
use flexstage_control::experiment::Setup;
use flexstage_control::feasibility::{Feasibility, feasibility_of, static_inverse};
use flexstage_control::margins::{MarginParams, Margins};
use flexstage_control::pi_notch::PiNotchParams;
use flexstage_control::registry::{Controller, Design, Designs, MarginProbe, Stage};
use flexstage_control::tuning::{FeedForwardFit, TuningParams, loop_margins};
use flexstage_identify::measured::{LiftedResponse, ZFilter, ZFit};
use flexstage_identify::response::{RESPONSE_SHARE, ResponseFit};
use flexstage_sim::experiment::StageControl;
use flexstage_sim::modal::{LoopPlant, ModalPlant};
use flexstage_sim::rig::{
    AmplifierParams, PlantActuator, RigParams, RigPlant, SensorParams, StagePlant,
};
use flexstage_sim::trajectory::Reference;
use flexstage_twin::{Twin, TwinStage};

use crate::error::{AssessError, Result};
use crate::inject::{InjectionLoop, InjectionParams, injected_margins};

/// The bench: the controllers' settings, the twin and the controllers designed for it.
#[derive(Debug, Clone)]
pub struct Bench {
    /// The scenario's settings of the controllers and the rig, with the controllers' lumped
    /// model fitted to the twin's response fit (`Stage::controller_model`).
    pub setup: Setup,
    /// The twin of the design.
    pub twin: Twin,
    /// The tuning settings used.
    pub tuning: TuningParams,
    /// The response fit the model-based designs come from: one identified on the stage
    /// (`flexstage_identify::response`), or `None` for the fit of the twin's exact modes
    /// ([`ResponseFit::from_modes`]).
    pub identified: Option<ResponseFit>,
    /// Every controller of the registry, designed for the twin.
    pub designs: Designs,
    /// What the linear designs' feed-forward is fitted to ([`FeedForwardFit::of`]).
    pub feedforward: FeedForwardFit,
}

/// The twin's modes as a [`ModalPlant`] sampled at `t` with `delay` samples of delay, the
/// amplifier's first-order small-signal response (`amplifier`'s bandwidth; its limits do not
/// enter a linear loop) after the hold and the rig's sensor chain `sensor` (electronics and
/// anti-aliasing filter) before the sampler: the loop the controller runs in, linearized.
pub fn modal_plant(
    twin: &Twin,
    t: f64,
    delay: usize,
    amplifier: &AmplifierParams,
    sensor: &SensorParams,
) -> Result<ModalPlant> {
    Ok(ModalPlant::with_chain(
        twin.modal.plant_modes(),
        t,
        delay,
        amplifier.bandwidth,
        sensor,
    )?)
}

impl Bench {
    /// Designs every controller on the twin's sampled loop with the rig's delay and sensor
    /// chain and returns the bench.
    pub fn new(setup: Setup, twin: Twin, tuning: TuningParams) -> Result<Bench> {
        Bench::with_identified(setup, twin, tuning, None)
    }

    /// [`Bench::new`] with the model-based designs from an `identified` response fit
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
            &setup.rig.amplifier,
            &setup.rig.sensor,
        )?;
        let nyquist = 0.5 / setup.controller.observer.sample_time;
        let fit = identified.unwrap_or_else(|| {
            ResponseFit::from_modes(&twin.modal.plant_modes(), nyquist, RESPONSE_SHARE)
        });
        Bench::designed(
            setup,
            twin,
            tuning,
            &plant,
            fit,
            Sizing::Twin,
            identified,
            None,
        )
    }

    /// The twin with the controllers of the scenario's settings alone (nothing tuned, no
    /// response, `Stage::scenario`): the nominal stage of a Monte-Carlo study that measures
    /// each perturbed twin and designs on it ([`crate::montecarlo::PlantDesign::Identified`]).
    pub fn scenario(setup: Setup, twin: Twin) -> Result<Bench> {
        let stage = Stage::scenario(&setup);
        let designs = Designs::for_stage(&stage)?;
        let feedforward = FeedForwardFit::of(&stage);
        drop(stage);
        Ok(Bench {
            setup,
            twin,
            tuning: TuningParams::default(),
            identified: None,
            designs,
            feedforward,
        })
    }

    /// Every controller designed from a lab measurement of the twin in its rig at the
    /// controller's sample time ([`crate::lab::measure`]) and from nothing of its truth: the
    /// PI + notch and the PID tuned on the measured loop model
    /// ([`crate::lab::LabMeasurement::loop_model`]: the z-domain fit
    /// `flexstage_identify::measured::ZFit` with the static gain read off the lowest lines),
    /// the backstepping's model fitted to that loop model's response fit
    /// ([`crate::lab::LabMeasurement::response_fit`]), and its gains sized by its margins on
    /// the measured loop model run in the time domain ([`MeasuredLoop`]). The designs
    /// allow for the measurement's
    /// uncertainty: `tuning`'s margin targets are raised by [`crate::lab::LabParams::allowing`]
    /// (the bench keeps the raised tuning). With a fast ADC (`lab.fast_adc`, on by default)
    /// the linear designs' feed-forward is fitted to the lifted response at the samples
    /// ([`Bench::from_measurement`]). The twin stays on the bench to score the designs.
    pub fn measured(
        setup: Setup,
        twin: Twin,
        tuning: TuningParams,
        lab: &crate::lab::LabParams,
    ) -> Result<(Bench, crate::lab::LabMeasurement)> {
        let measured = crate::lab::measure(&twin, &setup, lab)?;
        let bench = Bench::from_measurement(setup, twin, tuning, lab, &measured)?;
        Ok((bench, measured))
    }

    /// [`Bench::measured`] from a measurement already made (`measured`, e.g. read back from
    /// its files): the same designs, from `measured` and `lab`'s allowance alone. With the
    /// measurement's lifted response (a fast ADC's, [`crate::lab::LabMeasurement::lifted`])
    /// the linear designs' feed-forward is fitted to its phase 0
    /// ([`LiftedResponse::at_samples`]: the output at the samples, the sensor's datasheet
    /// filter divided out) and their feedback's reference to the reading its phases predict
    /// (`FeedForwardParams::reading`) under the default tuning; without it to the sampled
    /// response.
    pub fn from_measurement(
        setup: Setup,
        twin: Twin,
        tuning: TuningParams,
        lab: &crate::lab::LabParams,
        measured: &crate::lab::LabMeasurement,
    ) -> Result<Bench> {
        Bench::from_measurements(setup, twin, tuning, lab, measured, measured.lifted.as_ref())
    }

    /// [`Bench::from_measurement`] with the lifted response of the output measured by a
    /// fast ADC (`lifted`, [`crate::lab::measure_lifted`], all its phases as given; the
    /// measurement's own is not used), which a
    /// `flexstage_control::feedforward::FeedForward::Lifted` tuning fits its feed-forward to.
    pub fn from_measurements(
        setup: Setup,
        twin: Twin,
        tuning: TuningParams,
        lab: &crate::lab::LabParams,
        measured: &crate::lab::LabMeasurement,
        lifted: Option<&LiftedResponse>,
    ) -> Result<Bench> {
        let tuning = lab.allowing(&tuning)?;
        let response = measured.loop_model();
        let fit = measured.response_fit();
        let sizing = Sizing::Measured(&measured.model);
        Bench::designed(
            setup,
            twin,
            tuning,
            &response,
            fit,
            sizing,
            Some(fit),
            lifted,
        )
    }

    /// Every registry controller designed on the sampled loop `response` with its response
    /// fit `fit`, the backstepping sized by its margins on the loop `sizing` names; the
    /// bench's setup keeps the controllers' model fitted to `fit`.
    #[allow(clippy::too_many_arguments)]
    fn designed(
        mut setup: Setup,
        twin: Twin,
        tuning: TuningParams,
        response: &dyn LoopPlant,
        fit: ResponseFit,
        sizing: Sizing<'_>,
        identified: Option<ResponseFit>,
        lifted: Option<&LiftedResponse>,
    ) -> Result<Bench> {
        let linear = LinearLoop {
            twin: &twin,
            setup: &setup,
        };
        let measured;
        let probe: &dyn MarginProbe = match sizing {
            Sizing::Twin => &linear,
            Sizing::Measured(model) => {
                measured = MeasuredLoop {
                    model,
                    setup: &setup,
                };
                &measured
            }
        };
        let mut stage = Stage::new(
            &setup,
            Some(response),
            Some(fit),
            Some(probe),
            tuning.clone(),
        );
        stage.lifted = lifted;
        let designs = Designs::for_stage(&stage)?;
        let feedforward = FeedForwardFit::of(&stage);
        let (model, coupling) = stage.controller_model();
        drop(stage);
        (setup.controller.model, setup.controller.coupling) = (model, coupling);
        Ok(Bench {
            setup,
            twin,
            tuning,
            identified,
            designs,
            feedforward,
        })
    }

    /// The design of `c` on this bench.
    pub fn design(&self, c: &Controller) -> Result<&Arc<dyn Design>> {
        design_of(&self.designs, c)
    }

    /// The gains of `c` when it is a linear controller (margins from its transfer
    /// function), else `None`.
    pub fn linear_params(&self, c: &Controller) -> Result<Option<PiNotchParams>> {
        Ok(self.design(c)?.linear().copied())
    }

    /// Builds `c` for `reference` with `compensation`, using `setup` (the bench's or a
    /// perturbed copy) for the actuator stage and the delay it predicts over.
    pub fn controller_with(
        &self,
        setup: &Setup,
        c: &Controller,
        compensation: Compensation,
        reference: Reference,
    ) -> Result<Box<dyn StageControl>> {
        let actuator = setup.actuator(compensation);
        Ok(self
            .design(c)?
            .build(actuator, setup.controller.delay, reference)?)
    }

    /// [`Bench::controller_with`] on the bench's own setup.
    pub fn controller(
        &self,
        c: &Controller,
        compensation: Compensation,
        reference: Reference,
    ) -> Result<Box<dyn StageControl>> {
        self.controller_with(&self.setup, c, compensation, reference)
    }

    /// `c` as it runs under the learning layer (`Designs::for_learning`: tuned to the
    /// widened margin targets of `TuningParams::learning_widening`) following `reference`,
    /// with the bench's actuator stage under `compensation`.
    pub fn learning_controller(
        &self,
        c: &Controller,
        compensation: Compensation,
        reference: Reference,
    ) -> Result<Box<dyn StageControl>> {
        let design = self.designs.for_learning(c).ok_or_else(|| {
            AssessError::from(ControlError::Infeasible {
                what: format!("controller {}", c.name),
                detail: "not designed on this bench".into(),
            })
        })?;
        let actuator = self.setup.actuator(compensation);
        Ok(design.build(actuator, self.setup.controller.delay, reference)?)
    }

    /// What following `reference` over `duration` seconds takes from the rig with `c`'s
    /// feed-forward command: its own filter when it has one (the dynamic inverse with
    /// preview), else the static inverse through the measured static gain (the identified
    /// response fit's; the controllers' model's on a bench without one), never the twin's.
    pub fn feasibility(
        &self,
        c: &Controller,
        reference: &Reference,
        duration: f64,
    ) -> Result<Feasibility> {
        let dt = self.setup.controller.observer.sample_time;
        let (actuator, amplifier) = (&self.setup.controller.actuator, &self.setup.rig.amplifier);
        if let Some(ff) = self.design(c)?.feedforward() {
            let mut run = ff.runner(*reference, dt);
            return Ok(feasibility_of(
                reference,
                duration,
                dt,
                actuator,
                amplifier,
                |_| run.step().0,
            )?);
        }
        let gain = match &self.identified {
            Some(fit) => fit.dc_gain,
            None => self.setup.controller_dc_gain()?,
        };
        let inv = static_inverse(gain)?;
        Ok(feasibility_of(
            reference,
            duration,
            dt,
            actuator,
            amplifier,
            |k| {
                let q = reference.sample(k as f64 * dt).q;
                [0, 1].map(|i| inv[i][0] * q[0] + inv[i][1] * q[1])
            },
        )?)
    }

    /// The twin's linear loop, where margins are measured.
    pub fn probe(&self) -> LinearLoop<'_> {
        LinearLoop {
            twin: &self.twin,
            setup: &self.setup,
        }
    }

    /// Margins of a linear candidate computed from its transfer function on the twin's
    /// sampled loop.
    pub fn analytic_margins(&self, c: &Controller, delay: usize) -> Result<Option<[Margins; 2]>> {
        let Some(p) = self.linear_params(c)? else {
            return Ok(None);
        };
        Ok(Some(self.analytic_margins_of(&p, delay)?))
    }

    /// Margins of the linear controller `p` from its transfer function on the twin's sampled
    /// loop with `delay` samples.
    pub fn analytic_margins_of(&self, p: &PiNotchParams, delay: usize) -> Result<[Margins; 2]> {
        let plant = modal_plant(
            &self.twin,
            self.setup.rig.sample_time,
            delay,
            &self.setup.rig.amplifier,
            &self.setup.rig.sensor,
        )?;
        Ok(loop_margins(&plant, p, &self.tuning.margins)?)
    }
}

/// The design of `c` in `designs`; an error naming it when it was not designed.
pub(crate) fn design_of<'d>(designs: &'d Designs, c: &Controller) -> Result<&'d Arc<dyn Design>> {
    designs.get(c).ok_or_else(|| {
        AssessError::from(ControlError::Infeasible {
            what: format!("controller {}", c.name),
            detail: "not designed on this bench".into(),
        })
    })
}

/// Where the designs sized by their margins (the backstepping) are sized.
#[derive(Debug, Clone, Copy)]
enum Sizing<'m> {
    /// The twin's linear loop ([`LinearLoop`], its truth): the bench tuned on the truth.
    Twin,
    /// The measured loop model ([`MeasuredLoop`]).
    Measured(&'m ZFit),
}

/// The twin's linear loop: the linear rig (ideal amplifier, no PEA, the sensor chain without
/// noise, no creep or floor) around the twin without its geometric correction, with the
/// controllers' actuator stage and delay of `setup`. What margins are measured on.
#[derive(Debug, Clone, Copy)]
pub struct LinearLoop<'a> {
    /// The twin.
    pub twin: &'a Twin,
    /// The controllers' settings and the rig.
    pub setup: &'a Setup,
}

impl LinearLoop<'_> {
    /// The linear loop of the rig with `delay` samples: the amplifier's first-order
    /// small-signal response (its bandwidth, not its limits), no PEA (x_nom through the
    /// amplifier's response), the rig's sensor chain (electronics and anti-aliasing filter)
    /// without noise, no creep or floor.
    pub fn linear_rig(&self, delay: usize) -> RigParams {
        let mut r = self.setup.rig.clone();
        r.delay = delay;
        r.actuator = PlantActuator::Amplified;
        r.amplifier = AmplifierParams {
            bandwidth: self.setup.rig.amplifier.bandwidth,
            ..AmplifierParams::ideal()
        };
        r.sensor.flicker_corner = 0.0;
        r.creep.factor = 0.0;
        r.floor.velocity_rms = 0.0;
        r.noise_std = [0.0; 2];
        r.resolution = [0.0; 2];
        r
    }

    /// The linear twin in the linear rig (see [`LinearLoop::linear_rig`]).
    pub fn linear_plant(&self, delay: usize) -> Result<RigPlant<TwinStage>> {
        let rig = self.linear_rig(delay);
        let stage = TwinStage::new(&self.twin.modal, None, rig.substep());
        Ok(RigPlant::new(rig, stage)?)
    }

    /// `design` built for a zero reference with the ideal actuator stage (x_nom is the
    /// command), predicting over the controllers' delay.
    pub fn controller(&self, design: &dyn Design) -> Result<Box<dyn StageControl>> {
        at_rest(self.setup, design)
    }
}

/// `design` built for a zero reference with the ideal actuator stage of `setup` (x_nom is
/// the command), predicting over the controllers' delay.
fn at_rest(setup: &Setup, design: &dyn Design) -> Result<Box<dyn StageControl>> {
    let r = Reference::new(flexstage_sim::trajectory::Shape::Step { target: [0.0; 2] });
    // The linear loop's margins: without the rate limit, a nonlinearity that the small
    // injected signals must not meet.
    let actuator = ActuatorParams {
        max_voltage_step: 0.0,
        ..setup.actuator(Compensation::Ideal)
    };
    Ok(design.build(actuator, setup.controller.delay, r)?)
}

impl InjectionLoop for LinearLoop<'_> {
    fn controller(&self, design: &dyn Design) -> Result<Box<dyn StageControl>> {
        LinearLoop::controller(self, design)
    }

    fn plant(&self, delay: usize) -> Result<Box<dyn StagePlant>> {
        Ok(Box::new(self.linear_plant(delay)?))
    }

    fn sample_time(&self) -> f64 {
        self.setup.rig.sample_time
    }
}

/// Margins by sine injection on the twin's linear loop with the rig's delay.
impl MarginProbe for LinearLoop<'_> {
    fn margins(
        &self,
        design: &dyn Design,
        params: &MarginParams,
    ) -> flexstage_control::Result<Option<[Margins; 2]>> {
        probe_margins(
            self,
            self.setup.rig.delay,
            design,
            params,
            "the twin's linear loop",
        )
    }
}

/// The loop a lab measured: its z-domain loop model (`flexstage_identify::measured::ZFit`,
/// fitted to the response from the DAC command to the ADC reading through the full rig:
/// hold, the rig's delay, amplifier, PEAs under the compensation, stage, sensor chain) run
/// in the time domain ([`ZFit::filter`]), with the controllers' actuator stage of `setup`
/// (ideal compensation: the command is the x_nom the model takes). What the designs sized
/// by their margins are sized on: nothing of the twin's truth.
#[derive(Debug, Clone, Copy)]
pub struct MeasuredLoop<'a> {
    /// The measured loop model.
    pub model: &'a ZFit,
    /// The controllers' settings and the rig the model was measured in.
    pub setup: &'a Setup,
}

/// The measured loop model as a [`StagePlant`]: its reading is its output (no noise).
struct ModelPlant {
    filter: ZFilter,
    /// Commands still in the extra delay, oldest first.
    queue: std::collections::VecDeque<[f64; 2]>,
    x_nom: [f64; 2],
}

impl StagePlant for ModelPlant {
    fn measure(&mut self) -> [f64; 2] {
        self.filter.output()
    }

    fn output(&self) -> [f64; 2] {
        self.filter.output()
    }

    fn apply(&mut self, cmd: &flexstage_sim::experiment::Command) {
        self.queue.push_back(cmd.x_nom);
        if let Some(u) = self.queue.pop_front() {
            self.x_nom = u;
            self.filter.step(u);
        }
    }

    fn voltage(&self) -> [f64; 2] {
        [0.0; 2]
    }

    fn x_nom(&self) -> [f64; 2] {
        self.x_nom
    }
}

impl InjectionLoop for MeasuredLoop<'_> {
    fn controller(&self, design: &dyn Design) -> Result<Box<dyn StageControl>> {
        at_rest(self.setup, design)
    }

    /// The model with the delay it was measured with (the rig's) and `delay` − the rig's
    /// delay samples more; fewer than the rig's are refused naming the delay.
    fn plant(&self, delay: usize) -> Result<Box<dyn StagePlant>> {
        let measured = self.setup.rig.delay;
        let Some(extra) = delay.checked_sub(measured) else {
            return Err(flexstage_numerics::RangeError::new(
                "delay",
                delay.to_string(),
                format!("≥ {measured} samples (the measured loop's own delay)"),
            )
            .into());
        };
        Ok(Box::new(ModelPlant {
            filter: self.model.filter(),
            queue: std::iter::repeat_n([0.0; 2], extra).collect(),
            x_nom: [0.0; 2],
        }))
    }

    fn sample_time(&self) -> f64 {
        self.setup.rig.sample_time
    }
}

/// Margins by sine injection on the measured loop model, with the delay it was measured with.
impl MarginProbe for MeasuredLoop<'_> {
    fn margins(
        &self,
        design: &dyn Design,
        params: &MarginParams,
    ) -> flexstage_control::Result<Option<[Margins; 2]>> {
        probe_margins(
            self,
            self.setup.rig.delay,
            design,
            params,
            "the measured loop model",
        )
    }
}

/// [`injected_margins`] of `design` on `probe` with `delay`, its error a
/// [`ControlError::Measurement`] naming `what`.
fn probe_margins(
    probe: &dyn InjectionLoop,
    delay: usize,
    design: &dyn Design,
    params: &MarginParams,
    what: &str,
) -> flexstage_control::Result<Option<[Margins; 2]>> {
    injected_margins(probe, design, delay, params, &InjectionParams::default()).map_err(|e| {
        ControlError::Measurement {
            what: format!("margins by sine injection on {what}"),
            detail: e.to_string(),
        }
    })
}
