//! Problems with known answers, for tests, benchmarks and examples.

use crate::data::PeaData;
use crate::error::Result;
use crate::hysteresis::{WaveShape, Waveform};
use crate::model::BoucWenParams;
use crate::synth::synthesize;

/// The virgin loading curve: PEA1 of Table A1 without asymmetry (δ = 0), ramped from 0 V.
/// For n = 1 and U̇ > 0 from (0, 0), Eq. (18) gives h(U) = A/(B+Γ)·(1 − e^{−(B+Γ)U}).
pub fn virgin_ramp() -> (BoucWenParams, fn(&BoucWenParams, f64) -> f64) {
    (
        BoucWenParams::PEA1.without_asymmetry(),
        BoucWenParams::virgin_h,
    )
}

/// The drive used for identification: a 0–1000 V sine whose amplitude decays from 1 to 0.3
/// over 10 cycles at 1 Hz (nested minor loops), 10 s in all.
pub fn identification_drive() -> Waveform {
    identification_drive_at(1.0)
}

/// The decaying 0–1000 V sine drive of [`identification_drive`] at `frequency` \[Hz\].
pub fn identification_drive_at(frequency: f64) -> Waveform {
    Waveform {
        shape: WaveShape::Decaying,
        low: 0.0,
        high: 1000.0,
        frequency,
        cycles: 10,
    }
}

/// The steady 0–1000 V, 1 Hz sine drive used for the loop metrics.
pub fn full_range_sine() -> Waveform {
    Waveform {
        shape: WaveShape::Sine,
        low: 0.0,
        high: 1000.0,
        frequency: 1.0,
        cycles: 1,
    }
}

/// An identification problem with a known answer.
#[derive(Debug, Clone)]
pub struct IdentificationProblem {
    /// The parameters that generated the record.
    pub truth: BoucWenParams,
    /// The record (t, U, x).
    pub data: PeaData,
}

/// `truth` driven by [`identification_drive`] at 10 kHz, with `noise_std` \[µm\] of Gaussian
/// sensor noise on x (seeded).
pub fn identification_problem(
    truth: BoucWenParams,
    noise_std: f64,
    seed: u64,
) -> Result<IdentificationProblem> {
    let data = synthesize(&truth, &identification_drive(), 1e-4, noise_std, seed)?;
    Ok(IdentificationProblem { truth, data })
}

/// A linear regression with known θ*, for RLS tests (moved to `flexstage-numerics`).
pub use flexstage_numerics::samples::linear_regression;

/// A single-amplitude 0–1000 V drive of `shape` (triangle or sine) at 1 Hz for 10 periods:
/// the record on which a narrow-valley d_p profile defeats a local search (see
/// `identify`'s module docs, "Global d_p").
pub fn single_amplitude_drive(shape: WaveShape) -> Waveform {
    Waveform {
        shape,
        low: 0.0,
        high: 1000.0,
        frequency: 1.0,
        cycles: 10,
    }
}
