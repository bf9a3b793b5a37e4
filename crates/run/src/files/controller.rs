//! `track/[<conditions>/]controllers/<controller>.json`: a tuned linear controller as a
//! real-time target runs it — the PID + notch law with its feed-forward (the static inverse,
//! or the FIR inverse with preview), the PPF damping filters and a learned correction table
//! when it has them, and its inverse hysteresis actuator stage (Eq. 19–21 and 36 of
//! Actuators 2022, 11(7), 179), every coefficient as the simulation used it; or the
//! backstepping controller (`backstepping`: the K-filter observer, the prediction over the
//! rig's delay, the robust law of Appendix D, the input transformation of Eq. 44, the notches
//! on the reading) with the same actuator stage and learned table. Version 2 added
//! `damping`, `feedforward` and `learned_m`, version 3 `backstepping` (with which `axes` and
//! `inverse_static_gain` are absent) and the actuator's rate limit `max_voltage_step_v`,
//! version 4 the feed-forward's `reading_taps`; version 1 and 2 files (no rate limit) and
//! version 3 files still read.
//! `flexstage-control`'s `TargetLaw` and `BacksteppingLaw` are the same laws in memory; the C
//! source and header next to the file are generated from them.

use serde::{Deserialize, Serialize};

use crate::format::{Format, check_version, from_json, json};

/// The format version of a controller file.
pub const VERSION: u32 = 4;

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
    /// Feedback per output axis (q1, q2) of the linear law; absent for the backstepping.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axes: Option<[AxisFile; 2]>,
    /// G_dc⁻¹, row-major: x_nom = G_dc⁻¹ (q_d + N(c)) \[m\], of the linear law; absent for
    /// the backstepping.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inverse_static_gain: Option<[[f64; 2]; 2]>,
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
    /// The backstepping law in place of the linear one (version 3); absent: the linear law.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub backstepping: Option<BacksteppingFile>,
}

/// The backstepping controller's law (Section 3.2.2, Appendix D of Actuators 2022, 11(7),
/// 179, as `flexstage_control::controller` corrects it): every matrix row-major.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BacksteppingFile {
    /// Samples d of the rig's delay the estimate is predicted over (0–2).
    pub delay_samples: usize,
    /// The robust terms a_s, v_s on (`robust`) or off (`nonrobust`).
    pub robust: bool,
    /// Error gains k_ε \[1/s\] per axis.
    pub error_gain_per_s: [f64; 2],
    /// Linear feedback gains k_η \[1/s\] per axis (> 1).
    pub eta_gain_per_s: [f64; 2],
    /// Feedback gains k \[1/s\] per axis.
    pub feedback_gain_per_s: [f64; 2],
    /// Disturbance bounds ρ_η \[m/s²\] per axis.
    pub eta_bound_m_per_s2: [f64; 2],
    /// Disturbance bounds ρ_ε \[m/s\] per axis.
    pub a_bound_m_per_s: [f64; 2],
    /// Boundary layers φ_s \[m/s\], φ_a \[m\] (0: sgn).
    pub boundary_layer: [f64; 2],
    /// The output velocity without delay: `observer` (the estimate) or `finite-difference`.
    pub velocity: String,
    /// The law's inner state: `estimate` (ξ̂, ξ̂̇) or `command` (ξ_d and the last v).
    pub inner: String,
    /// Whether the law cancels the estimated model error Δ̂_η.
    pub disturbance_feedback: bool,
    /// Per axis, the two notch sections on the reading (the identity where there is none).
    pub notches: [[SectionFile; 2]; 2],
    /// Per axis, the notches' low-frequency delay τ_i \[s\] the reference is taken earlier.
    pub notch_delay_s: [f64; 2],
    /// B of the controller's model (Eq. 36, 8 × 8).
    pub model_b: [[f64; 8]; 8],
    /// G⁻¹ of the law (A24).
    pub g_inv: [[f64; 2]; 2],
    /// D⁻¹ of the input transformation (Eq. 44).
    pub d_inv: [[f64; 2]; 2],
    /// Φ of the observer's augmented model [z, d] sampled at T (10 × 10): the prediction.
    pub phi: [[f64; 10]; 10],
    /// Γ (10 × 2): the input filters and the prediction.
    pub gamma: [[f64; 2]; 10],
    /// The filter's error matrix F = Φ − L C (10 × 10).
    pub filter_f: [[f64; 10]; 10],
    /// The filter's injection gain L (10 × 2).
    pub filter_l: [[f64; 2]; 10],
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
    /// The reading correction C_n on the same window (version 4), added to the feedback's
    /// reference: q_d((k − τ) T) + Σ_n C_n q_d,k−n, the reading the measured loop predicts
    /// when the output follows; absent: q_d((k − τ) T) alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reading_taps: Option<Vec<[[f64; 2]; 2]>>,
    /// What the taps were fitted to: `lifted` (the lifted response of a fast ADC at the
    /// samples: the output, the sensor's datasheet filter divided out), `sampled` (the
    /// sampled response, command → reading) or `static-lead` (the static inverse ahead);
    /// absent in files written before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fitted_to: Option<String>,
}

impl Format for ControllerFile {
    fn encode(&self) -> Result<Vec<u8>, String> {
        json(self)
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let v: ControllerFile = from_json(bytes)?;
        if !(1..VERSION).contains(&v.version) {
            check_version(v.version, VERSION)?;
        }
        let linear = v.axes.is_some() && v.inverse_static_gain.is_some();
        let backstepping = v.backstepping.is_some() && v.version >= 3;
        if linear == backstepping || v.axes.is_some() != v.inverse_static_gain.is_some() {
            return Err(
                "a controller file holds either `axes` and `inverse_static_gain` (the linear \
                 law) or `backstepping` (version 3), not both and not neither"
                    .to_string(),
            );
        }
        Ok(v)
    }
}
