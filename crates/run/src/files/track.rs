//! `track/[<conditions>/]`: the tables of a tracking folder — the metrics per trajectory and
//! controller (`metrics.csv`), the controllers' margins (`margins.csv`), the Monte-Carlo
//! study (`montecarlo.csv`) and the error against scan frequency (`scan_frequency.csv`).
//! The time series of one run (`<trajectory>_<controller>.csv`) is a [`crate::Table`].

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::format::{Row, num};

/// The suffix of a controller's row with the iterative-learning layer on top
/// (`<controller>+learning` in [`MetricsRow::variant`] and the record's file name).
pub const LEARNING_SUFFIX: &str = "+learning";

/// One row of `metrics.csv`: the errors of one (trajectory, controller) pair against the true
/// output, under the conditions of the folder.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MetricsRow {
    /// Trajectory name.
    pub trajectory: String,
    /// Controller name; `<controller>+learning` ([`LEARNING_SUFFIX`]) for the controller
    /// with the learning layer.
    pub variant: String,
    /// Hysteresis compensation (`inverse`, `off`).
    pub compensation: String,
    /// The controller's model (a parameter file, or `guess`).
    pub model: String,
    /// The simulated stage (`twin`, `lumped`).
    pub plant: String,
    /// RMS error of q1 \[nm\].
    #[serde(serialize_with = "num::display")]
    pub rms1_nm: f64,
    /// RMS error of q2 \[nm\].
    #[serde(serialize_with = "num::display")]
    pub rms2_nm: f64,
    /// RMS error of q1 \[% of range\].
    #[serde(serialize_with = "num::display")]
    pub rms1_pct: f64,
    /// RMS error of q2 \[% of range\].
    #[serde(serialize_with = "num::display")]
    pub rms2_pct: f64,
    /// Largest error of q1 \[nm\].
    #[serde(serialize_with = "num::display")]
    pub max1_nm: f64,
    /// Largest error of q2 \[nm\].
    #[serde(serialize_with = "num::display")]
    pub max2_nm: f64,
    /// Largest error of q1 \[% of range\].
    #[serde(serialize_with = "num::display")]
    pub max1_pct: f64,
    /// Largest error of q2 \[% of range\].
    #[serde(serialize_with = "num::display")]
    pub max2_pct: f64,
    /// Settling time \[s\].
    #[serde(serialize_with = "num::display")]
    pub settling_s: f64,
    /// Peak voltage \[V\].
    #[serde(rename = "peak_voltage_V", serialize_with = "num::display")]
    pub peak_voltage_v: f64,
    /// Samples at the amplifier's limits.
    pub saturated_samples: usize,
    /// Sensor dropouts.
    pub dropouts: usize,
    /// Largest fraction of the designed workspace the reference uses.
    #[serde(serialize_with = "num::display")]
    pub workspace_usage: f64,
    /// What the result is worth: `ok`, `saturated` (flagged), `error-above-bound` or
    /// `diverged` (refused: the command failed after writing it). Empty in a file written
    /// before the column existed.
    #[serde(default)]
    pub status: String,
    /// The status with its reason, e.g. `diverged: stopped at t = 0.0541 s: a non-finite
    /// state`.
    #[serde(default)]
    pub status_detail: String,
}

impl Row for MetricsRow {
    const HEADER: &'static [&'static str] = &[
        "trajectory",
        "variant",
        "compensation",
        "model",
        "plant",
        "rms1_nm",
        "rms2_nm",
        "rms1_pct",
        "rms2_pct",
        "max1_nm",
        "max2_nm",
        "max1_pct",
        "max2_pct",
        "settling_s",
        "peak_voltage_V",
        "saturated_samples",
        "dropouts",
        "workspace_usage",
        "status",
        "status_detail",
    ];
}

/// One row of `margins.csv`: loop-at-a-time margins of one controller's loop on the twin's
/// sampled loop with the rig's delay (values to the stated decimals).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MarginRow {
    /// Controller name.
    pub controller: String,
    /// Delay of the loop \[samples\].
    pub delay_samples: usize,
    /// `q1` or `q2`.
    #[serde(rename = "loop")]
    pub axis: String,
    /// Gain margin \[dB\], 2 decimals; `None` (written `unstable`) for an unstable loop.
    #[serde(
        rename = "gain_margin_dB",
        serialize_with = "gain_margin",
        deserialize_with = "unstable_or_number"
    )]
    pub gain_margin_db: Option<f64>,
    /// Phase crossover \[Hz\], 1 decimal.
    #[serde(rename = "phase_crossover_Hz", serialize_with = "num::opt_fixed1")]
    pub phase_crossover_hz: Option<f64>,
    /// Phase margin \[deg\], 1 decimal.
    #[serde(serialize_with = "num::opt_fixed1")]
    pub phase_margin_deg: Option<f64>,
    /// Gain crossover \[Hz\], 1 decimal.
    #[serde(rename = "gain_crossover_Hz", serialize_with = "num::opt_fixed1")]
    pub gain_crossover_hz: Option<f64>,
    /// Delay margin \[samples\], 2 decimals.
    #[serde(serialize_with = "num::opt_fixed2")]
    pub delay_margin_samples: Option<f64>,
    /// How the margins were measured (transfer function or sine injection).
    pub method: String,
    /// Whether the loop keeps ≥ 6 dB / 40°.
    pub meets_targets: bool,
    /// Monte-Carlo pass rate \[%\], 0 decimals.
    #[serde(serialize_with = "num::opt_fixed0")]
    pub montecarlo_pass_pct: Option<f64>,
}

impl Row for MarginRow {
    const HEADER: &'static [&'static str] = &[
        "controller",
        "delay_samples",
        "loop",
        "gain_margin_dB",
        "phase_crossover_Hz",
        "phase_margin_deg",
        "gain_crossover_Hz",
        "delay_margin_samples",
        "method",
        "meets_targets",
        "montecarlo_pass_pct",
    ];
    const EXACT: bool = false;
}

fn gain_margin<S: Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    match v {
        Some(v) => num::fixed2(v, s),
        None => s.serialize_str("unstable"),
    }
}

fn unstable_or_number<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    let text = String::deserialize(d)?;
    if text == "unstable" {
        return Ok(None);
    }
    text.parse()
        .map(Some)
        .map_err(|_| serde::de::Error::custom(format!("{text:?} is not a gain margin")))
}

/// One row of `montecarlo.csv`: one perturbed plant (factors on its parameters, 4 decimals)
/// and one controller's RMS errors on it (2 decimals) and verdict.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MonteCarloRow {
    /// Plant index.
    pub plant: usize,
    /// Stiffness factor.
    #[serde(serialize_with = "num::fixed4")]
    pub stiffness: f64,
    /// Mass factor.
    #[serde(serialize_with = "num::fixed4")]
    pub mass: f64,
    /// α factor.
    #[serde(serialize_with = "num::fixed4")]
    pub alpha: f64,
    /// Damping ratio.
    #[serde(serialize_with = "num::fixed4")]
    pub damping: f64,
    /// Cross coupling of axis 1.
    #[serde(serialize_with = "num::fixed4")]
    pub coupling1: f64,
    /// Cross coupling of axis 2.
    #[serde(serialize_with = "num::fixed4")]
    pub coupling2: f64,
    /// Loop delay \[samples\].
    pub delay: usize,
    /// Controller name.
    pub controller: String,
    /// RMS error of q1 \[nm\].
    #[serde(serialize_with = "num::fixed2")]
    pub rms1_nm: f64,
    /// RMS error of q2 \[nm\].
    #[serde(serialize_with = "num::fixed2")]
    pub rms2_nm: f64,
    /// Whether the controller passed on this plant.
    pub pass: bool,
}

impl Row for MonteCarloRow {
    const HEADER: &'static [&'static str] = &[
        "plant",
        "stiffness",
        "mass",
        "alpha",
        "damping",
        "coupling1",
        "coupling2",
        "delay",
        "controller",
        "rms1_nm",
        "rms2_nm",
        "pass",
    ];
    const EXACT: bool = false;
}

/// What reduced a scan's amplitude below the scenario's (`scan_frequency.csv`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ScanLimit {
    /// Nothing: the scenario's amplitude.
    None,
    /// The controller's stroke.
    ControllerStroke,
    /// The amplifier's voltage range.
    AmplifierRange,
    /// The amplifier's output current into the PEA's capacitance.
    AmplifierCurrent,
    /// The amplifier's slew rate.
    AmplifierSlew,
}

impl ScanLimit {
    /// Its name in the file.
    pub fn name(self) -> &'static str {
        match self {
            ScanLimit::None => "none",
            ScanLimit::ControllerStroke => "controller-stroke",
            ScanLimit::AmplifierRange => "amplifier-range",
            ScanLimit::AmplifierCurrent => "amplifier-current",
            ScanLimit::AmplifierSlew => "amplifier-slew",
        }
    }
}

/// What limits a controller's error at a scan frequency (`scan_frequency.csv`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ScanCause {
    /// The loop's lag at the reference's own lines.
    Bandwidth,
    /// Error at other frequencies (hysteresis residual, excited modes).
    Distortion,
    /// The largest error line at a mode above Nyquist folded by the sampling.
    Aliasing,
    /// The run did not stay finite or its error grew.
    Unstable,
}

impl ScanCause {
    /// Its name in the file.
    pub fn name(self) -> &'static str {
        match self {
            ScanCause::Bandwidth => "bandwidth",
            ScanCause::Distortion => "distortion",
            ScanCause::Aliasing => "aliasing",
            ScanCause::Unstable => "unstable",
        }
    }
}

/// One row of `scan_frequency.csv`: one controller on the Lissajous 3:1 whose fast component
/// runs at a fraction of the twin's first resonance, with its steady RMS and peak error (no
/// cut-off), the limit that reduced the amplitude and what limits the error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScanRow {
    /// The fast component's frequency / the first resonance.
    #[serde(serialize_with = "num::display")]
    pub fraction_of_f1: f64,
    /// The fast component's frequency \[Hz\], 2 decimals.
    #[serde(rename = "fast_frequency_Hz", serialize_with = "num::fixed2")]
    pub fast_frequency_hz: f64,
    /// Amplitude of q1 \[m\].
    #[serde(serialize_with = "num::exp")]
    pub amplitude1_m: f64,
    /// Amplitude of q2 \[m\].
    #[serde(serialize_with = "num::exp")]
    pub amplitude2_m: f64,
    /// The limit that reduced the amplitude from the scenario's.
    pub amplitude_limit: ScanLimit,
    /// The factor it was reduced by (1: not reduced).
    #[serde(serialize_with = "num::display")]
    pub amplitude_factor: f64,
    /// Controller name.
    pub controller: String,
    /// RMS error of q1 \[nm\], 3 decimals.
    #[serde(serialize_with = "num::fixed3")]
    pub rms1_nm: f64,
    /// RMS error of q2 \[nm\], 3 decimals.
    #[serde(serialize_with = "num::fixed3")]
    pub rms2_nm: f64,
    /// RMS error of q1 \[% of range\], 5 decimals.
    #[serde(serialize_with = "num::fixed5")]
    pub rms1_pct_range: f64,
    /// RMS error of q2 \[% of range\], 5 decimals.
    #[serde(serialize_with = "num::fixed5")]
    pub rms2_pct_range: f64,
    /// Largest error of q1 \[nm\], 3 decimals.
    #[serde(serialize_with = "num::fixed3")]
    pub peak1_nm: f64,
    /// Largest error of q2 \[nm\], 3 decimals.
    #[serde(serialize_with = "num::fixed3")]
    pub peak2_nm: f64,
    /// Largest error of q1 \[% of range\], 5 decimals.
    #[serde(serialize_with = "num::fixed5")]
    pub peak1_pct_range: f64,
    /// Largest error of q2 \[% of range\], 5 decimals.
    #[serde(serialize_with = "num::fixed5")]
    pub peak2_pct_range: f64,
    /// What limits the error.
    pub cause: ScanCause,
    /// Frequency of the largest error line \[Hz\], 2 decimals.
    #[serde(rename = "dominant_Hz", serialize_with = "num::fixed2")]
    pub dominant_hz: f64,
    /// RMS error of q1 on every substep of the simulation, between the samples too
    /// \[% of range\], 5 decimals (NaN in a file written before the column existed).
    #[serde(default = "not_recorded", serialize_with = "num::fixed5")]
    pub rms1_between_pct_range: f64,
    /// RMS error of q2 on every substep \[% of range\], 5 decimals.
    #[serde(default = "not_recorded", serialize_with = "num::fixed5")]
    pub rms2_between_pct_range: f64,
    /// Learning trials (periods) before the scored run of a `<controller>+learning` row
    /// ([`LEARNING_SUFFIX`]); 0 for the controller alone (and in a file written before the
    /// column existed).
    #[serde(default)]
    pub learning_periods: usize,
    /// The learning layer's monotone-convergence factor ρ on the measured learning plant,
    /// 4 decimals; NaN for the controller alone.
    #[serde(default = "not_recorded", serialize_with = "num::fixed4")]
    pub learning_rho: f64,
    /// The learning law chosen by measurement, `phase-lead` or `inverse`; empty for the
    /// controller alone.
    #[serde(default)]
    pub learning_law: String,
}

/// The value of a column a file written before it existed lacks.
fn not_recorded() -> f64 {
    f64::NAN
}

impl Row for ScanRow {
    const HEADER: &'static [&'static str] = &[
        "fraction_of_f1",
        "fast_frequency_Hz",
        "amplitude1_m",
        "amplitude2_m",
        "amplitude_limit",
        "amplitude_factor",
        "controller",
        "rms1_nm",
        "rms2_nm",
        "rms1_pct_range",
        "rms2_pct_range",
        "peak1_nm",
        "peak2_nm",
        "peak1_pct_range",
        "peak2_pct_range",
        "cause",
        "dominant_Hz",
        "rms1_between_pct_range",
        "rms2_between_pct_range",
        "learning_periods",
        "learning_rho",
        "learning_law",
    ];
    const EXACT: bool = false;
}
