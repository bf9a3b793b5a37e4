//! `analyze/<analysis>/summary.json`: what one nonlinear analysis computed.

use serde::{Deserialize, Serialize};

use crate::format::{Format, check_version, from_json, json_sorted};

/// The format version of an analysis summary.
pub const VERSION: u32 = 1;

/// `analyze/<analysis>/summary.json` (keys sorted).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnalysisSummary {
    /// Format version ([`VERSION`]).
    pub version: u32,
    /// The design analysed, in words.
    pub design: String,
    /// Load cases.
    pub cases: usize,
    /// Newton iterations over all cases.
    pub newton_iterations: usize,
    /// Wall-clock time \[s\].
    pub seconds: f64,
    /// Workspace area \[m²\] (workspace analyses only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub area_m2: Option<f64>,
}

impl Format for AnalysisSummary {
    fn encode(&self) -> Result<Vec<u8>, String> {
        json_sorted(self)
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let s: AnalysisSummary = from_json(bytes)?;
        check_version(s.version, VERSION)?;
        Ok(s)
    }
}
