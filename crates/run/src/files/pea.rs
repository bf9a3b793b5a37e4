//! `identify/pea<N>/estimates.toml`: the Bouc–Wen estimates of one PEA (Eq. 18 with n = 1,
//! Table A1), by parallel RLS (Algorithm A1) and a batch fit, against the scenario's values.

use flexstage_scenario::BoucWen;
use serde::{Deserialize, Serialize};

use crate::format::{Format, check_version, from_toml};

/// The format version of `estimates.toml`.
pub const VERSION: u32 = 1;

/// The comment at the head of the file.
const HEADER: &str = "# Bouc–Wen estimates, Eq. (18) with n = 1: x, h in µm, U in V, t in s\n\
                      # (d_p, a_bw in µm/V; b_bw, gamma_bw in 1/V; delta_bw in µm/(V·s)).\n";

/// `identify/pea<N>/estimates.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PeaEstimates {
    /// Format version ([`VERSION`]).
    pub version: u32,
    /// The record identified.
    pub data: String,
    /// Samples of the record.
    pub samples: usize,
    /// Which estimate is recommended (`batch` or `parallel_rls`: the lower RMS error of the
    /// simulated model along the record).
    pub recommended: String,
    /// Hysteresis of the record: loop width, % of range.
    pub record_width_pct: f64,
    /// Hysteresis of the record: largest deviation from linear, % of range.
    pub record_max_deviation_pct: f64,
    /// The recommended parameters (what the compensator of `track` uses).
    pub recommended_params: BoucWen,
    /// Parallel RLS (Algorithm A1).
    pub parallel_rls: Method,
    /// Batch least squares.
    pub batch: Method,
    /// The scenario's parameters of this PEA, for comparison.
    pub scenario: BoucWen,
}

/// One estimate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Method {
    /// RMS of x − x_model along the record \[µm\].
    pub rms_error_um: f64,
    /// The parameters.
    pub params: BoucWen,
    /// Relative difference to the scenario's parameters \[%\], per parameter.
    pub difference_to_scenario_pct: BoucWen,
}

impl Format for PeaEstimates {
    fn encode(&self) -> Result<Vec<u8>, String> {
        let body = toml::to_string_pretty(self).map_err(|e| e.to_string())?;
        Ok(format!("{HEADER}{body}").into_bytes())
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let e: PeaEstimates = from_toml(bytes)?;
        check_version(e.version, VERSION)?;
        Ok(e)
    }
}
