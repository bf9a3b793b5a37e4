//! The piezo actuators as the controller sees them: preload bias, inverse hysteresis
//! compensation (Eq. 19–21, Figure 5, inside the loop as in Figure 7) and the amplifier range.
//!
//! The controller computes a desired nominal displacement x_nom,i \[m\] (the input u of
//! Eq. 36, measured from the preload bias). The actuator stage turns it into a voltage:
//!
//! * [`Compensation::Inverse`]: x_pea = x_bias + x_nom is inverted through the Bouc–Wen model
//!   of the PEA (flexstage-piezo's [`InverseCompensator`]), then clamped to the amplifier;
//! * [`Compensation::Off`]: a straight line U = U_b + x_nom/κ through the bias with the mean
//!   slope κ of the virgin curve over the amplifier range (no hysteresis model);
//! * [`Compensation::Ideal`]: the linear model's input directly (x_nom is the actuator's
//!   output; voltage reported through the same straight line). For tests on Eq. (36).
//!
//! **Preload** (Section 4.1): both the plant and the compensator bring the virgin PEA to the
//! bias voltage U_b along a slow ramp ([`flexstage_sim::pea::preload`]); x_bias = d_p U_b − h_b is the rest
//! displacement, so x_nom = 0 at rest and the nominal range is about ±30 µm.

use flexstage_piezo::{BoucWenParams, CompensatorParams, InverseCompensator, MICROMETRE};
use flexstage_sim::pea::{mean_slope, preload};

use flexstage_numerics::RangeError;

use crate::error::{Result, check, positive};

/// How x_nom becomes a voltage.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compensation {
    /// Inverse multiplicative compensation through the Bouc–Wen model (Eq. 21).
    Inverse,
    /// No hysteresis model: a straight line through the bias.
    Off,
    /// The linear model's input x_nom directly (no voltage stage).
    Ideal,
}

/// Settings of the actuator stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActuatorParams {
    /// Bouc–Wen parameters of PEA1 and PEA2 (µm, V, s; Table A1).
    pub hysteresis: [BoucWenParams; 2],
    /// Amplifier range \[V\] (DECISIONS.md: 0–1000).
    pub voltage_range: [f64; 2],
    /// Preload bias voltage U_b \[V\] (default: the middle of the range).
    pub bias_voltage: f64,
    /// Largest |x_nom| the controller may ask for \[m\] (Section 4.1: the ±30 µm nominal stroke).
    pub stroke: f64,
    /// The compensation mode.
    pub compensation: Compensation,
}

impl ActuatorParams {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        for p in &self.hysteresis {
            p.validate().map_err(|e| {
                RangeError::new("hysteresis", e.to_string(), "valid Bouc–Wen parameters")
            })?;
        }
        let [lo, hi] = self.voltage_range;
        check("hysteresis.voltage_min", lo, lo.is_finite(), "finite [V]")?;
        check("hysteresis.voltage_max", hi, hi > lo, "> voltage_min [V]")?;
        check(
            "bias_voltage",
            self.bias_voltage,
            self.bias_voltage > lo && self.bias_voltage < hi,
            "inside the amplifier range [V]",
        )?;
        positive("stroke", self.stroke)
    }
}

/// The result of one actuator command.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Actuated {
    /// Voltages sent to the amplifiers \[V\], inside the range.
    pub voltage: [f64; 2],
    /// The x_nom \[m\] the actuator model expects from them (the observer's input).
    pub x_nom: [f64; 2],
    /// True when a voltage or the stroke limit clipped the request.
    pub saturated: bool,
}

/// The actuator stage of the controller. No allocation per step.
#[derive(Debug, Clone)]
pub struct Actuator {
    params: ActuatorParams,
    comp: [InverseCompensator; 2],
    x_bias: [f64; 2],
    slope: [f64; 2],
}

impl Actuator {
    /// Builds the stage and preloads its models to the bias.
    pub fn new(params: ActuatorParams) -> Result<Actuator> {
        params.validate()?;
        let settings = CompensatorParams {
            u_min: params.voltage_range[0],
            u_max: params.voltage_range[1],
            ..CompensatorParams::default()
        };
        let make = |p: BoucWenParams| {
            let mut c = InverseCompensator::new(p, settings).map_err(|e| {
                RangeError::new("hysteresis", e.to_string(), "valid compensator settings")
            })?;
            let (u, h, _) = preload(&p, params.bias_voltage);
            c.set_state(u, h);
            Ok::<_, crate::error::ControlError>(c)
        };
        let comp = [make(params.hysteresis[0])?, make(params.hysteresis[1])?];
        let x_bias = [0, 1].map(|i| preload(&params.hysteresis[i], params.bias_voltage).2);
        let slope = [0, 1].map(|i| mean_slope(&params.hysteresis[i], params.voltage_range));
        Ok(Actuator {
            params,
            comp,
            x_bias,
            slope,
        })
    }

    /// The settings.
    pub fn params(&self) -> &ActuatorParams {
        &self.params
    }

    /// Rest displacements x_bias \[µm\] of the preloaded PEAs.
    pub fn x_bias(&self) -> [f64; 2] {
        self.x_bias
    }

    /// Turns the desired x_nom \[m\] into voltages, held for `dt` \[s\].
    #[inline]
    pub fn command(&mut self, x_nom: [f64; 2], dt: f64) -> Actuated {
        let [lo, hi] = self.params.voltage_range;
        let ub = self.params.bias_voltage;
        let mut out = Actuated::default();
        for i in 0..2 {
            let want = x_nom[i];
            let x = want.clamp(-self.params.stroke, self.params.stroke);
            out.saturated |= x != want;
            match self.params.compensation {
                Compensation::Inverse => {
                    let c = self.comp[i].step(self.x_bias[i] + x / MICROMETRE, dt);
                    out.voltage[i] = c.u;
                    out.saturated |= c.saturated;
                    let p = self.comp[i].model().params();
                    out.x_nom[i] = (p.d_p * c.u - c.h - self.x_bias[i]) * MICROMETRE;
                }
                Compensation::Off => {
                    let u = ub + x / MICROMETRE / self.slope[i];
                    let uc = u.clamp(lo, hi);
                    out.saturated |= uc != u;
                    out.voltage[i] = uc;
                    out.x_nom[i] = (uc - ub) * self.slope[i] * MICROMETRE;
                }
                Compensation::Ideal => {
                    out.voltage[i] = (ub + x / MICROMETRE / self.slope[i]).clamp(lo, hi);
                    out.x_nom[i] = x;
                }
            }
        }
        out
    }
}
