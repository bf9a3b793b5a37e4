//! `reduce/`: the reduced model's summary (`summary.toml` and `summary.json`, the same
//! record) and its tables.

use serde::{Deserialize, Serialize};

use crate::format::{Format, check_version, from_json, from_toml, json};

/// The format version of the reduce summary.
pub const VERSION: u32 = 1;

/// `reduce/summary.toml` and `reduce/summary.json`: α in the global and the moving frame
/// (Eq. 22–24), θ, A(θ), stiffnesses, mass, the modal analysis and the validity map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReduceSummaryFile {
    /// Format version ([`VERSION`]).
    pub version: u32,
    /// The design reduced, in words.
    pub design: String,
    /// Elements (n_l, n_w).
    pub mesh: [usize; 2],
    /// The state of the tangent (undeformed or an operating point).
    pub state: String,
    /// ∂q/∂x_in, global frame (FE output, rigid translation included).
    pub alpha_global: [[f64; 2]; 2],
    /// Paper's α (Eq. 24): moving frame u_o = q − [½(x_in1 + x_in2), 0].
    pub alpha_moving_frame: [[f64; 2]; 2],
    /// Residuals of Eq. 26.
    pub eq26_residuals: [f64; 2],
    /// tan θ (Eq. 26).
    pub tan_theta: f64,
    /// θ \[deg\].
    pub theta_deg: f64,
    /// Scalar α (Eq. 27), output free.
    pub alpha_scalar: f64,
    /// A(θ) (Eq. 28).
    pub a_theta: [[f64; 2]; 2],
    /// |A(θ) − α|.
    pub a_theta_residual: f64,
    /// Output compliance \[m/N\].
    pub output_compliance_m_per_n: [[f64; 2]; 2],
    /// Output stiffness \[N/m\].
    pub output_stiffness_n_per_m: [[f64; 2]; 2],
    /// K_qo1 \[N/m\].
    pub k_qo1: f64,
    /// K_qo2 \[N/m\].
    pub k_qo2: f64,
    /// Moving mass M \[kg\].
    pub mass_kg: f64,
    /// Volume fraction of the design.
    pub volume_fraction: f64,
    /// Output at the operating point \[µm\].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub operating_output_um: Option<[f64; 2]>,
    /// The modal analysis.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub modal: Option<ModalSummary>,
    /// The validity map.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub validity: Option<ValiditySummary>,
}

/// The modal analysis of the design (Assumption 2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModalSummary {
    /// The mass matrix, in words.
    pub mass: String,
    /// Whether the plate masses are in.
    pub plate_masses: bool,
    /// Natural frequencies \[Hz\].
    pub frequencies_hz: Vec<f64>,
    /// Relative residuals of the eigenpairs.
    pub residuals: Vec<f64>,
    /// The input mode of Assumption 2 \[Hz\].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub input_frequency_hz: Option<f64>,
    /// The ratio Assumption 2 bounds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub assumption2_ratio: Option<f64>,
    /// Whether Assumption 2 holds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub assumption2_holds: Option<bool>,
    /// Assumption 2 in words.
    pub assumption2: String,
}

/// The validity map of the tangent model against nonlinear FE.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ValiditySummary {
    /// The error measure, in words.
    pub metric: String,
    /// Stroke scales.
    pub scales: Vec<f64>,
    /// Stroke amplitude per scale \[µm\].
    pub amplitude_um: Vec<f64>,
    /// Largest error per scale.
    pub max_error: Vec<f64>,
    /// RMS error per scale.
    pub rms_error: Vec<f64>,
    /// Largest error of linear FE per scale.
    pub max_error_linear_fe: Vec<f64>,
    /// Largest error up to the full stroke.
    pub max_error_within_stroke: f64,
    /// Largest scale within 2 %.
    pub largest_scale_within_2_percent: f64,
}

/// `reduce/summary.json`.
#[derive(Debug, Clone, PartialEq)]
pub struct ReduceSummaryJson(pub ReduceSummaryFile);

/// `reduce/summary.toml`.
#[derive(Debug, Clone, PartialEq)]
pub struct ReduceSummaryToml(pub ReduceSummaryFile);

impl Format for ReduceSummaryJson {
    fn encode(&self) -> Result<Vec<u8>, String> {
        json(&self.0)
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let s: ReduceSummaryFile = from_json(bytes)?;
        check_version(s.version, VERSION)?;
        Ok(ReduceSummaryJson(s))
    }
}

impl Format for ReduceSummaryToml {
    fn encode(&self) -> Result<Vec<u8>, String> {
        toml::to_string(&self.0)
            .map(String::into_bytes)
            .map_err(|e| e.to_string())
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let s: ReduceSummaryFile = from_toml(bytes)?;
        check_version(s.version, VERSION)?;
        Ok(ReduceSummaryToml(s))
    }
}
