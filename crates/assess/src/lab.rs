//! The twin measured as a lab measures its stage: the periodic multisine of
//! `flexstage_identify::measured` played through the twin's full rig at the controller's
//! sample time (zero-order hold, delay, amplifier, the hysteretic PEAs with creep, sensor
//! chain, the scenario's noise), the commands sent through the controllers' actuator stage
//! (the inverse hysteresis compensation by default), logged as a rig logs it, the response estimated from the
//! logs and fitted by a z-domain model. [`crate::Bench::measured`] designs the controllers
//! from this and nothing of the twin's truth.

use flexstage_control::actuator::{Actuator, Compensation};
use flexstage_control::experiment::Setup;
use flexstage_identify::measured::{
    FitParams, LabLog, MeasuredResponse, MultisinePlan, ZFit, run_log,
};
use flexstage_twin::Twin;

use crate::error::Result;

/// Settings of the lab measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct LabParams {
    /// The multisine; `None` for [`MultisinePlan::new`] at the rig's sample time.
    pub plan: Option<MultisinePlan>,
    /// The z-domain fit.
    pub fit: FitParams,
    /// Whether the rig's noise (white, 1/f, quantization, floor) is on, as the scenario says;
    /// `false` for a noise-free measurement (a reference).
    pub noise: bool,
    /// How a command becomes the amplifiers' voltage: the controllers' actuator stage with
    /// this compensation, so that the command is the x_nom the controllers write. Default
    /// [`Compensation::Inverse`], as `track` runs them.
    pub compensation: Compensation,
}

impl Default for LabParams {
    fn default() -> Self {
        LabParams {
            plan: None,
            fit: FitParams::default(),
            noise: true,
            compensation: Compensation::Inverse,
        }
    }
}

/// What the lab measured: the two logs' response and its loop model.
#[derive(Debug, Clone, PartialEq)]
pub struct LabMeasurement {
    /// The measured response.
    pub response: MeasuredResponse,
    /// Its z-domain fit, the loop model the designs tune on.
    pub model: ZFit,
}

/// The two multisine logs of `twin` in the rig of `setup` (one experiment per PEA, each
/// from rest, with noise seeds of their own).
pub fn lab_logs(twin: &Twin, setup: &Setup, p: &LabParams) -> Result<([LabLog; 2], MultisinePlan)> {
    let mut rig = setup.rig.clone();
    if !p.noise {
        rig.noise_std = [0.0; 2];
        rig.resolution = [0.0; 2];
        rig.sensor.flicker_corner = 0.0;
        rig.floor.velocity_rms = 0.0;
    }
    let plan = p
        .plan
        .clone()
        .unwrap_or_else(|| MultisinePlan::new(rig.sample_time));
    let log = |input: usize| -> Result<LabLog> {
        let mut r = rig.clone();
        r.seed = rig.seed.wrapping_add(101 * (input as u64 + 1));
        let mut plant = twin.plant(&r)?;
        let mut actuator = Actuator::new(setup.actuator(p.compensation))?;
        let t = r.sample_time;
        Ok(run_log(&mut plant, t, &plan.commands(input)?, |x| {
            actuator.command(x, t).voltage
        })?)
    };
    Ok(([log(0)?, log(1)?], plan))
}

/// Measures `twin` in the rig of `setup` (module docs).
pub fn measure(twin: &Twin, setup: &Setup, p: &LabParams) -> Result<LabMeasurement> {
    let ([a, b], plan) = lab_logs(twin, setup, p)?;
    let response = MeasuredResponse::from_multisine([&a, &b], &plan)?;
    let model = ZFit::fit(&response, &p.fit)?;
    Ok(LabMeasurement { response, model })
}
