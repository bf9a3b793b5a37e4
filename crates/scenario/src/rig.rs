//! The simulated rig around the stage (`[rig]`) and the digital twin of the designed
//! mechanism (`[twin]`), DECISIONS.md "Digital twin and rig".
//!
//! Every loop effect is on by default at a realistic value and switched off by setting it
//! to 0 (or `delay = 0`). Where a value comes from a data sheet or a standard, its field
//! comment names the source; where none was available to us, the comment says so.

use serde::{Deserialize, Serialize};

use crate::error::{Result, check, non_negative, within};
use crate::stage::BoucWen;

/// The high-voltage amplifiers (Section 4.1: PI E-472.20, linear).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Amplifier {
    /// Small-signal bandwidth with the PEA as load \[Hz\], first order; 0 = ideal.
    pub bandwidth: f64,
    /// Slew-rate limit [V/s]; 0 = none.
    pub slew_rate: f64,
    /// Peak output current \[A\]; 0 = none. With `capacitance` it limits |dU/dt| to I/C.
    pub current_limit: f64,
    /// Capacitance of one PEA \[F\].
    pub capacitance: f64,
}

/// The capacitive position sensors' dynamics and noise spectrum (white level and
/// resolution are in `[sensors]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorDynamics {
    /// Bandwidth of the sensor electronics \[Hz\], first order; 0 = ideal.
    pub bandwidth: f64,
    /// 1/f corner \[Hz\] (where the 1/f and white spectra are equal); 0 = white only.
    pub flicker_corner: f64,
    /// Corner \[Hz\] of the ADC's anti-aliasing filter (2nd-order Butterworth after the
    /// sensor electronics); 0 = none. Absent in a file: 0 (none).
    #[serde(default = "default_anti_alias")]
    pub anti_alias: f64,
}

/// The default anti-aliasing corner \[Hz\] for 10 kHz sampling (DECISIONS.md, "Anti-aliasing
/// filter": chosen by measurement on the twin's Monte-Carlo study).
pub const ANTI_ALIAS_CORNER: f64 = 0.0;

fn default_anti_alias() -> f64 {
    ANTI_ALIAS_CORNER
}

/// Logarithmic creep of the PEAs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Creep {
    /// Creep factor γ per time decade; 0 = off.
    pub factor: f64,
}

/// Floor vibration (base acceleration in both in-plane directions).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FloorVibration {
    /// RMS velocity per 1/3-octave band [m/s]; 0 = off.
    pub velocity_rms: f64,
    /// Lowest and highest 1/3-octave band centre \[Hz\].
    #[serde(deserialize_with = "crate::strict::array")]
    pub bands: [f64; 2],
}

/// The loop around the simulated stage, as on a rig.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rig {
    /// Computation + I/O delay in controller samples, 0–2.
    pub delay: usize,
    /// The amplifiers.
    pub amplifier: Amplifier,
    /// Sensor dynamics and spectrum.
    pub sensor: SensorDynamics,
    /// PEA creep.
    pub creep: Creep,
    /// Floor vibration.
    pub floor: FloorVibration,
    /// The plant's own PEA1 (Bouc–Wen truth; the compensator uses `[hysteresis]`).
    pub pea1: BoucWen,
    /// The plant's own PEA2.
    pub pea2: BoucWen,
}

impl Rig {
    /// The default rig: every effect on (DECISIONS.md), PEAs with a modest mismatch to
    /// Table A1 (`hysteresis` is the compensator's identified model).
    pub fn realistic(hysteresis: &crate::Hysteresis) -> Rig {
        // Rounded to 6 significant digits so that the TOML shows the intended numbers.
        let round = |x: f64| format!("{x:.5e}").parse::<f64>().unwrap_or(x);
        let mismatch = |b: &BoucWen| BoucWen {
            d_p: round(b.d_p * 1.03),
            a_bw: round(b.a_bw * 1.10),
            ..b.clone()
        };
        Rig {
            delay: 1,
            amplifier: Amplifier {
                bandwidth: 3000.0,
                slew_rate: 1e7,
                current_limit: 0.1,
                capacitance: 1.5e-6,
            },
            sensor: SensorDynamics {
                bandwidth: 15_000.0,
                flicker_corner: 1.0,
                anti_alias: ANTI_ALIAS_CORNER,
            },
            creep: Creep { factor: 0.01 },
            floor: FloorVibration {
                velocity_rms: 12.5e-6,
                bands: [8.0, 80.0],
            },
            pea1: mismatch(&hysteresis.pea1),
            pea2: mismatch(&hysteresis.pea2),
        }
    }

    /// The ideal loop of the controller's own model: no delay, ideal amplifiers and sensors,
    /// no creep, no floor vibration, PEAs equal to the compensator's model.
    pub fn ideal(hysteresis: &crate::Hysteresis) -> Rig {
        Rig {
            delay: 0,
            amplifier: Amplifier {
                bandwidth: 0.0,
                slew_rate: 0.0,
                current_limit: 0.0,
                capacitance: 1.5e-6,
            },
            sensor: SensorDynamics {
                bandwidth: 0.0,
                flicker_corner: 0.0,
                anti_alias: 0.0,
            },
            creep: Creep { factor: 0.0 },
            floor: FloorVibration {
                velocity_rms: 0.0,
                bands: [8.0, 80.0],
            },
            pea1: hysteresis.pea1.clone(),
            pea2: hysteresis.pea2.clone(),
        }
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        if self.delay > 2 {
            return Err(crate::RangeError::new(
                "rig.delay",
                self.delay.to_string(),
                "0, 1 or 2 samples",
            )
            .into());
        }
        let a = &self.amplifier;
        within("rig.amplifier.bandwidth", a.bandwidth, 0.0, 1e6)?;
        non_negative("rig.amplifier.slew_rate", a.slew_rate)?;
        within("rig.amplifier.current_limit", a.current_limit, 0.0, 100.0)?;
        check(
            "rig.amplifier.capacitance",
            a.capacitance,
            a.capacitance > 0.0 && a.capacitance <= 1e-3,
            "a number in (0, 1e-3] F",
        )?;
        within("rig.sensor.bandwidth", self.sensor.bandwidth, 0.0, 1e7)?;
        within(
            "rig.sensor.flicker_corner",
            self.sensor.flicker_corner,
            0.0,
            1e4,
        )?;
        within("rig.sensor.anti_alias", self.sensor.anti_alias, 0.0, 1e7)?;
        within("rig.creep.factor", self.creep.factor, 0.0, 0.1)?;
        within("rig.floor.velocity_rms", self.floor.velocity_rms, 0.0, 1e-2)?;
        let [lo, hi] = self.floor.bands;
        check(
            "rig.floor.bands[0]",
            lo,
            lo > 0.0 && lo <= 1e4,
            "a number in (0, 1e4] Hz",
        )?;
        check(
            "rig.floor.bands[1]",
            hi,
            hi >= lo && hi <= 1e4,
            "a number in [bands[0], 1e4] Hz",
        )?;
        self.pea1.validate("rig.pea1")?;
        self.pea2.validate("rig.pea2")
    }
}

/// How the digital twin is built from the design (flexstage-twin).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Twin {
    /// The retained fixed-interface modes cover this multiple of the first resonance.
    pub coverage: f64,
    /// At least this many fixed-interface modes.
    pub min_modes: usize,
    /// Modal damping ratio ζ of the stage (Rayleigh: ζ at the first resonance and at
    /// `coverage` times it).
    pub damping_ratio: f64,
    /// Geometric nonlinearity from nonlinear FE static solves (false: the linear twin).
    pub nonlinear: bool,
    /// Grid points per axis of the static solves over the stroke square.
    pub fit_points: usize,
    /// The grid spans ± this multiple of `actuators.stroke_amplitude`.
    pub fit_span: f64,
}

impl Default for Twin {
    fn default() -> Twin {
        Twin {
            coverage: 3.0,
            min_modes: 40,
            damping_ratio: 0.01,
            nonlinear: true,
            fit_points: 5,
            fit_span: 1.2,
        }
    }
}

impl Twin {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        within("twin.coverage", self.coverage, 1.0, 20.0)?;
        crate::error::count("twin.min_modes", self.min_modes, 1, 160)?;
        check(
            "twin.damping_ratio",
            self.damping_ratio,
            (0.0..0.5).contains(&self.damping_ratio),
            "a number in [0, 0.5)",
        )?;
        crate::error::count("twin.fit_points", self.fit_points, 3, 15)?;
        within("twin.fit_span", self.fit_span, 0.1, 3.0)
    }
}
