//! `track/[<conditions>/]controllers/<controller>.json`: a tuned linear controller as a
//! real-time target runs it — the PID + notch law with its feed-forward (the static inverse,
//! or the FIR inverse with preview), the PPF damping filters and a learned correction table
//! when it has them, and its inverse hysteresis actuator stage (Eq. 19–21 and 36 of
//! Actuators 2022, 11(7), 179), every coefficient as the simulation used it. Version 2 added
//! `damping`, `feedforward` and `learned_m`, version 3 the actuator's rate limit
//! `max_voltage_step_v`; version 1 and 2 files (none of them: no rate limit) still read. `flexstage-control`'s `TargetLaw` is the same law
//! in memory; the C source and header next to the file are generated from it.

use serde::{Deserialize, Serialize};

use crate::format::{Format, check_version, from_json, json};

/// The format version of a controller file.
pub const VERSION: u32 = 3;

/// One second-order section y = (b₀ + b₁ z⁻¹ + b₂ z⁻²)/(1 + a₁ z⁻¹ + a₂ z⁻²) u.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SectionFile {
    /// Numerator [b₀, b₁, b₂].
    pub b: [f64; 3],
    /// Denominator [a₁, a₂] (a₀ = 1).
    pub a: [f64; 2],
}

/// The feedback of one output axis on e = q_d − y.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisFile {
    /// Proportional gain k_p (dimensionless).
    pub kp: f64,
    /// Integral gain k_i \[1/s\] (trapezoidal integral).
    pub ki_per_s: f64,
    /// Derivative gain k_d \[s\] (backward difference).
    pub kd_s: f64,
    /// Two sections in series on the PID's output (notches; the identity b = [1, 0, 0],
    /// a = [0, 0] where there is none).
    pub sections: [SectionFile; 2],
}

/// The actuator stage: x_nom \[m\] to amplifier voltages.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatorFile {
    /// `inverse` (Eq. 21 through the Bouc–Wen model), `off` (a straight line through the
    /// bias) or `ideal` (x_nom passed on; simulation only).
    pub compensation: String,
    /// Largest |x_nom| \[m\].
    pub stroke_m: f64,
    /// Amplifier range \[V\].
    pub voltage_range_v: [f64; 2],
    /// Preload bias voltage U_b \[V\].
    pub bias_voltage_v: f64,
    /// The compensator's accepted |d_p U − h − x_nom| \[µm\].
    pub compensator_tolerance_um: f64,
    /// The compensator's most model evaluations per sample.
    pub compensator_max_iterations: u32,
    /// Bouc–Wen parameters of PEA1 and PEA2 (Eq. 18; µm, V, s as in Table A1).
    pub hysteresis: [flexstage_scenario::BoucWen; 2],
    /// Largest change of a voltage per sample \[V\] (the amplifier's current and slew
    /// limits; the integrator holds on a sample it clips); absent or 0: no rate limit
    /// (version 1 and 2 files).
    #[serde(default)]
    pub max_voltage_step_v: f64,
}

/// A controller file (module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerFile {
    /// Format version ([`VERSION`]).
    pub version: u32,
    /// The controller's name in the registry (`track --variant`).
    pub controller: String,
    /// Its label for people.
    pub label: String,
    /// Sample time T \[s\] the coefficients are designed for.
    pub sample_time_s: f64,
    /// Feedback per output axis (q1, q2).
    pub axes: [AxisFile; 2],
    /// G_dc⁻¹, row-major: x_nom = G_dc⁻¹ (q_d + N(c)) \[m\].
    pub inverse_static_gain: [[f64; 2]; 2],
    /// The actuator stage.
    pub actuator: ActuatorFile,
    /// The PPF damping filters D_i on each axis's reading, added as G_dc⁻¹ D(y) (a zero
    /// section b = [0, 0, 0] on an axis without one); absent: no damping loop.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damping: Option<[SectionFile; 2]>,
    /// The FIR feed-forward with preview in place of the static inverse G_dc⁻¹ q_d;
    /// absent: the static inverse.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub feedforward: Option<FeedForwardFile>,
    /// The learned correction c\[k\] \[m\] per sample k of the period (q1, q2), subtracted
    /// from the reading; absent: no learning.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub learned_m: Option<Vec<[f64; 2]>>,
}

/// The FIR feed-forward: x_ff,k = Σ_n F_n q_d,k−n, n = −p, …, L − p − 1 \[m\].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeedForwardFile {
    /// Preview p: the future reference samples the filter reads.
    pub preview_samples: usize,
    /// The lag τ of the feedback's reference q_d((k − τ) T) \[samples\] (the sensor chain's
    /// datasheet lag).
    pub lag_samples: f64,
    /// The taps F_n (2 × 2, row-major) for n = −p, …, L − p − 1.
    pub taps: Vec<[[f64; 2]; 2]>,
}

impl Format for ControllerFile {
    fn encode(&self) -> Result<Vec<u8>, String> {
        json(self)
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let v: ControllerFile = from_json(bytes)?;
        if v.version != 1 && v.version != 2 {
            check_version(v.version, VERSION)?;
        }
        Ok(v)
    }
}
