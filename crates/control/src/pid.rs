//! The PID + inverse-hysteresis feed-forward baseline: the law of [`crate::pi_notch`]
//! (`flexstage_control_core::PidLaw`) without notches, on both axes.
//!
//! * [`PID_FF`]: tuned on the stage's sampled response by the procedure and budget of the
//!   PI + notch ([`crate::tuning`], structure [`Structure::Pid`]); where the stage offers no
//!   response to tune on (the lumped plant), the scenario's gains.
//! * [`PID_FF_SCENARIO`]: the scenario's gains (`controller.pid`) with the static gain of
//!   the controllers' model on the stage ([`Stage::controller_model`]), untuned; run only
//!   when asked for by name.

use std::sync::Arc;

use flexstage_scenario::StageParams;
use flexstage_sim::model::StageModel;

use crate::error::{Result, check};
use crate::pi_notch::{AxisGains, PiNotchParams};
use crate::registry::{Controller, Design, Stage};
use crate::tuning::{Structure, tuned};

/// PID + FF tuned on the stage's sampled response (module docs).
pub static PID_FF: Controller = Controller {
    name: "pid-ff",
    label: "PID + inverse-hysteresis feed-forward, tuned like the PI + notch",
    default: true,
    design: design_tuned,
};

/// PID + FF with the scenario's gains (module docs).
pub static PID_FF_SCENARIO: Controller = Controller {
    name: "pid-ff-scenario",
    label: "PID + inverse-hysteresis feed-forward with the scenario's gains, untuned",
    default: false,
    design: design_scenario,
};

fn design_tuned(stage: &Stage<'_>) -> Result<Option<Arc<dyn Design>>> {
    match tuned(stage, Structure::Pid)? {
        Some(t) => Ok(Some(crate::feedforward::design_with(stage, t.params)?)),
        None => design_scenario(stage),
    }
}

fn design_scenario(stage: &Stage<'_>) -> Result<Option<Arc<dyn Design>>> {
    let (model, _) = stage.controller_model();
    let t = stage.setup.controller.observer.sample_time;
    Ok(Some(Arc::new(stage.setup.pid.with_model(&model, t)?)))
}

/// Gains of the PID baseline (per axis, on the output error e = q_d − y).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidParams {
    /// Proportional gain (dimensionless).
    pub kp: f64,
    /// Integral gain [1/s].
    pub ki: f64,
    /// Derivative gain \[s\] (on the finite-difference derivative of e).
    pub kd: f64,
}

impl PidParams {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        check("controller.pid[0]", self.kp, self.kp >= 0.0, "kp ≥ 0")?;
        check("controller.pid[1]", self.ki, self.ki >= 0.0, "ki ≥ 0 [1/s]")?;
        check("controller.pid[2]", self.kd, self.kd >= 0.0, "kd ≥ 0 [s]")
    }

    /// These gains on both axes of the PID + feed-forward law without notches
    /// ([`crate::pi_notch`]), with the static gain of the controller's model `model` and the
    /// sample time `t` \[s\]: the industry-default baseline (feed-forward of the reference
    /// through the static inverse of the model, x_nom = G_dc⁻¹ q_d, and a PID on each output
    /// error mapped through the same inverse).
    pub fn with_model(&self, model: &StageParams, t: f64) -> Result<PiNotchParams> {
        self.validate()?;
        let g = StageModel::new(model)?.dc_gain()?;
        let axis = AxisGains {
            kp: self.kp,
            ki: self.ki,
            kd: self.kd,
            notches: [None, None],
        };
        Ok(PiNotchParams {
            axes: [axis; 2],
            static_gain: [[g[(0, 0)], g[(0, 1)]], [g[(1, 0)], g[(1, 1)]]],
            sample_time: t,
        })
    }
}
