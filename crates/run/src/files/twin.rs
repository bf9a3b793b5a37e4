//! `twin/`: the digital twin's validity (`validity.json`) and its modes against the FE modal
//! analysis (`modes.csv`).

use serde::{Deserialize, Serialize};

use crate::format::{Format, Row, check_version, from_json, json, num};

/// The format version of `validity.json`.
pub const VERSION: u32 = 1;

/// One step / sine case of the validity check, in % of the full model's range.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseRow {
    /// "step", "sine" or "fast step".
    pub name: String,
    /// Largest |q_twin − q_full| per axis (q1, q2) in % of the full model's range.
    pub error_pct: [f64; 2],
    /// The same for the twin without its nonlinear correction.
    pub linear_error_pct: [f64; 2],
    /// Range (peak to peak) of the full model's output per axis \[m\].
    pub range_m: [f64; 2],
    /// Wall-clock seconds of the full transient of this case.
    pub reference_seconds: f64,
    /// Free DOFs of the full model.
    pub dofs: usize,
    /// Time steps of the full transient.
    pub steps: usize,
}

/// The check against the full nonlinear transient.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransientCheck {
    /// Whether it ran.
    pub ran: bool,
    /// Why it ran or not.
    pub reason: String,
    /// The cases (empty when it did not run).
    pub cases: Vec<CaseRow>,
    /// Wall-clock seconds of the whole check (with the FE modal analysis).
    pub seconds: f64,
}

/// One claimed mode of the twin against the FE modal analysis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModeCheck {
    /// Mode number (1-based).
    pub index: usize,
    /// Twin \[Hz\].
    pub twin: f64,
    /// FE modal analysis of the assembled stage \[Hz\].
    pub fe: f64,
    /// (twin − fe)/fe.
    pub relative: f64,
    /// The twin's damping ratio of the mode.
    pub damping: f64,
}

/// `twin/validity.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TwinValidity {
    /// Format version ([`VERSION`]).
    pub version: u32,
    /// Number of modes of the twin.
    pub order: usize,
    /// Fixed-interface modes of the Craig–Bampton reduction.
    pub fixed_interface_modes: usize,
    /// The twin's natural frequencies \[Hz\], lowest first.
    pub frequencies_hz: Vec<f64>,
    /// The twin's damping ratios, per mode.
    pub damping_ratios: Vec<f64>,
    /// The twin's reach \[Hz\], the band whose modes it claims: the larger of coverage × the
    /// first resonance and the sampling rate + 0.3 × it (the hold's images and the folded
    /// modes of the sweep's fastest scan, 30 % of f1).
    pub covered_frequency_hz: f64,
    /// Whether the geometric-nonlinearity correction is in.
    pub nonlinear: bool,
    /// Seconds to build the twin.
    pub build_seconds: f64,
    /// Every claimed mode against the FE modal analysis of the same assembled stage.
    pub modes: Vec<ModeCheck>,
    /// Largest |relative mode error| in %.
    pub max_mode_error_pct: f64,
    /// Step and sine against the full nonlinear transient.
    pub transient: TransientCheck,
}

impl Format for TwinValidity {
    fn encode(&self) -> Result<Vec<u8>, String> {
        json(self)
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let v: TwinValidity = from_json(bytes)?;
        check_version(v.version, VERSION)?;
        Ok(v)
    }
}

/// A row of `twin/modes.csv`: the twin's frequency against the FE modal analysis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModeRow {
    /// Mode number (1-based).
    pub mode: usize,
    /// The twin \[Hz\].
    #[serde(rename = "frequency_Hz", serialize_with = "num::display")]
    pub frequency_hz: f64,
    /// The FE modal analysis \[Hz\].
    #[serde(rename = "fe_frequency_Hz", serialize_with = "num::display")]
    pub fe_frequency_hz: f64,
    /// (twin − FE)/FE.
    #[serde(serialize_with = "num::display")]
    pub relative_difference: f64,
}

impl Row for ModeRow {
    const HEADER: &'static [&'static str] = &[
        "mode",
        "frequency_Hz",
        "fe_frequency_Hz",
        "relative_difference",
    ];
}
