//! `front/front.json`: the workspace–first-resonance front of `flexstage front`, every design
//! with its checks and its controllers' tracking error at the named scan speed.

use serde::{Deserialize, Serialize};

use crate::files::design::DesignRecord;
use crate::format::{Format, check_version, from_json, json};

/// The format version of `front.json`.
pub const VERSION: u32 = 1;

/// `front/front.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrontFile {
    /// Format version ([`VERSION`]).
    pub version: u32,
    /// The scan speed named: the fast component of a 3:1 Lissajous \[Hz\].
    pub scan_hz: f64,
    /// The accepted tracking error at that speed \[% of each axis's range\].
    pub max_error_pct: f64,
    /// The designs, lowest bound first (d0: the workspace design).
    pub designs: Vec<FrontDesign>,
    /// Wall-clock time of the whole front \[s\].
    pub seconds: f64,
}

impl Format for FrontFile {
    fn encode(&self) -> Result<Vec<u8>, String> {
        json(self)
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let f: FrontFile = from_json(bytes)?;
        check_version(f.version, VERSION)?;
        Ok(f)
    }
}

impl FrontFile {
    /// The design the scan speed and the accepted error pick: the largest workspace among
    /// the verified-safe designs whose best controller tracks within `max_error_pct` on both
    /// axes.
    pub fn pick(&self) -> Option<&FrontDesign> {
        self.designs
            .iter()
            .filter(|d| d.safe && d.best().is_some_and(|b| b.worst() <= self.max_error_pct))
            .max_by(|a, b| a.design.area.total_cmp(&b.design.area))
    }
}

/// One design of the front and its checks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrontDesign {
    /// Its index k (0: the workspace design).
    pub index: usize,
    /// The first-frequency bound it was designed for \[Hz\] (0: none).
    pub min_frequency_hz: f64,
    /// Why its optimization stopped.
    pub stop: String,
    /// Design iterations.
    pub iterations: usize,
    /// Wall-clock time of its optimization \[s\].
    pub seconds: f64,
    /// The final analysis (area, α, mass, stresses, sizes, symmetry, the stage's frequencies).
    pub design: DesignRecord,
    /// The body-fitted verification's first frequency \[Hz\] (None: not verified).
    pub body_fitted_hz: Option<f64>,
    /// The body-fitted peak von Mises stress (the larger of the two meshes) \[Pa\].
    pub body_fitted_stress: Option<f64>,
    /// The verification's verdict.
    pub safe: bool,
    /// Why not safe, or why a check could not run.
    pub reasons: Vec<String>,
    /// The twin's first resonance \[Hz\] (None: no twin).
    pub twin_hz: Option<f64>,
    /// Each controller's error at the named scan speed (empty: beyond the sweep's reach, or no
    /// twin).
    pub scan: Vec<ScanError>,
}

impl FrontDesign {
    /// The controller with the smallest worse-axis error at the scan speed.
    pub fn best(&self) -> Option<&ScanError> {
        self.scan
            .iter()
            .filter(|e| e.percent.iter().all(|p| p.is_finite()))
            .min_by(|a, b| a.worst().total_cmp(&b.worst()))
    }
}

/// One controller's steady RMS tracking error at the scan speed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScanError {
    /// The controller (`track`'s name).
    pub controller: String,
    /// RMS error per axis \[m\] (∞: diverged; JSON has no ∞, so it is written as `null`).
    #[serde(deserialize_with = "null_is_diverged")]
    pub rms: [f64; 2],
    /// The same in % of each axis's range (∞ / `null`: diverged).
    #[serde(deserialize_with = "null_is_diverged")]
    pub percent: [f64; 2],
    /// The Lissajous amplitudes the rig could deliver at that speed \[m\].
    pub amplitude: [f64; 2],
}

/// A pair of errors as JSON writes them: a number, or `null` for the ∞ of a diverged run
/// (serde_json writes every non-finite number as `null`).
fn null_is_diverged<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f64; 2], D::Error> {
    let pair = <[Option<f64>; 2] as serde::Deserialize>::deserialize(d)?;
    Ok(pair.map(|x| x.unwrap_or(f64::INFINITY)))
}

impl ScanError {
    /// The worse axis's error \[% of range\].
    pub fn worst(&self) -> f64 {
        self.percent[0].max(self.percent[1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A diverged controller's ∞ errors are written as JSON `null` and read back as ∞.
    #[test]
    fn a_diverged_scan_error_reads_back() {
        let e = ScanError {
            controller: "robust".into(),
            rms: [f64::INFINITY, 1e-9],
            percent: [f64::INFINITY, 0.5],
            amplitude: [1e-6, 2e-6],
        };
        let text = serde_json::to_string(&e).unwrap();
        assert!(text.contains("null"), "{text}");
        let back: ScanError = serde_json::from_str(&text).unwrap();
        assert_eq!(back, e);
    }
}
