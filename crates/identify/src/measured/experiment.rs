//! The lab experiment: a periodic multisine ([`MultisinePlan`]) or any command sequence played
//! through a stage in its rig at the controller's sample time, logged as a rig logs it
//! ([`run_log`] → [`LabLog`]).

use flexstage_sim::experiment::Command;
use flexstage_sim::rig::StagePlant;

use crate::error::{Result, check};
use crate::measured::LabLog;

/// A periodic multisine for the response at the controller's sample time: one period of
/// `period` samples, lines k·f₀ (f₀ = 1/(period·T)) for every k in `lines`, Schroeder phases
/// φ_k = −π k(k−1)/K (a low crest factor; Schroeder, IEEE Trans. Inf. Theory 16(1), 1970),
/// scaled to the peak `amplitude`. Experiment j drives input j alone; the two experiments
/// give every entry of the 2 × 2 response at the same lines
/// ([`crate::measured::MeasuredResponse::from_multisine`]).
#[derive(Debug, Clone, PartialEq)]
pub struct MultisinePlan {
    /// The controller's sample time T \[s\], > 0.
    pub sample_time: f64,
    /// Samples per period, ≥ 8.
    pub period: usize,
    /// The excited harmonics k, each in 1..period/2 (below Nyquist), ascending.
    pub lines: Vec<usize>,
    /// Peak command of the driven input \[m\], > 0.
    pub amplitude: f64,
    /// Periods played before the measured ones (the transient, the hysteresis settling).
    pub settle: usize,
    /// Periods measured, ≥ 2 (their spread is the uncertainty).
    pub periods: usize,
}

impl MultisinePlan {
    /// The default plan at `sample_time`: f₀ = 5 Hz lines from 5 Hz to just below Nyquist,
    /// 0.1 µm peak (the amplifier stays clear of its current limit: a PEA is a capacitor and
    /// the multisine reaches Nyquist), 2 settling and 12 measured periods per input
    /// (`docs/DECISIONS.md`, "The measured response").
    pub fn new(sample_time: f64) -> MultisinePlan {
        let period = (1.0 / (5.0 * sample_time)).round().max(8.0) as usize;
        MultisinePlan {
            sample_time,
            period,
            lines: (1..period.div_ceil(2)).collect(),
            amplitude: 0.1e-6,
            settle: 2,
            periods: 12,
        }
    }

    /// The frequency of line k \[Hz\].
    pub fn frequency(&self, k: usize) -> f64 {
        k as f64 / (self.period as f64 * self.sample_time)
    }

    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        check(
            "multisine.sample_time",
            self.sample_time,
            self.sample_time > 0.0 && self.sample_time.is_finite(),
            "a time > 0 [s]",
        )?;
        check(
            "multisine.period",
            self.period as f64,
            self.period >= 8,
            "≥ 8 samples",
        )?;
        check(
            "multisine.amplitude",
            self.amplitude,
            self.amplitude > 0.0 && self.amplitude.is_finite(),
            "a peak > 0 [m]",
        )?;
        check(
            "multisine.periods",
            self.periods as f64,
            self.periods >= 2,
            "≥ 2 measured periods",
        )?;
        check(
            "multisine.lines",
            self.lines.len() as f64,
            !self.lines.is_empty(),
            "at least one line",
        )?;
        for (n, &k) in self.lines.iter().enumerate() {
            check(
                &format!("multisine.lines[{n}]"),
                k as f64,
                k >= 1 && 2 * k < self.period && (n == 0 || k > self.lines[n - 1]),
                "ascending harmonics in 1..period/2",
            )?;
        }
        Ok(())
    }

    /// One period of the unit-peak multisine.
    fn one_period(&self) -> Vec<f64> {
        let count = self.lines.len() as f64;
        let n = self.period as f64;
        let mut u: Vec<f64> = (0..self.period)
            .map(|m| {
                self.lines
                    .iter()
                    .map(|&k| {
                        let kf = k as f64;
                        let phase = -std::f64::consts::PI * kf * (kf - 1.0) / count;
                        (std::f64::consts::TAU * kf * m as f64 / n + phase).cos()
                    })
                    .sum()
            })
            .collect();
        let peak = u.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        u.iter_mut().for_each(|v| *v /= peak);
        u
    }

    /// The commands of experiment `input` (0 or 1: that input driven, the other at 0), for
    /// `settle + periods` whole periods.
    pub fn commands(&self, input: usize) -> Result<Vec<[f64; 2]>> {
        self.validate()?;
        check("multisine.input", input as f64, input < 2, "0 or 1")?;
        let one = self.one_period();
        Ok((0..(self.settle + self.periods) * self.period)
            .map(|m| {
                let mut c = [0.0; 2];
                c[input] = self.amplitude * one[m % self.period];
                c
            })
            .collect())
    }
}

/// How a command x_nom becomes the amplifiers' voltage: around the bias, through the PEAs'
/// mean slope, within the amplifier's range (as the rig's open-loop experiments drive it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drive {
    /// Mean slope κ of the PEAs [µm/V], > 0.
    pub slope: f64,
    /// Bias voltage \[V\].
    pub bias_voltage: f64,
    /// Amplifier range [lo, hi] \[V\].
    pub voltage_range: [f64; 2],
}

impl Drive {
    /// The voltages of the command `x` \[m\] (around the bias, through the mean slope,
    /// clamped to the range).
    pub fn voltage(&self, x: [f64; 2]) -> [f64; 2] {
        let [lo, hi] = self.voltage_range;
        [0, 1].map(|i| (self.bias_voltage + x[i] * 1e6 / self.slope).clamp(lo, hi))
    }
}

/// Plays `commands` on `plant` at its sample time `sample_time` \[s\] and logs what a rig
/// records: at sample k the readings y_k, then the command u_k (held until k + 1, after
/// the rig's own delay), sent to the amplifiers as the voltages `voltage(u_k)` (the
/// controllers' actuator stage, or a [`Drive`]). The plant is the whole simulated rig
/// (zero-order hold, delay, amplifier, the plant's PEAs, sensor chain, noise), so its folded
/// modes appear in the log as the controller sees them.
pub fn run_log(
    plant: &mut impl StagePlant,
    sample_time: f64,
    commands: &[[f64; 2]],
    mut voltage: impl FnMut([f64; 2]) -> [f64; 2],
) -> Result<LabLog> {
    let n = commands.len();
    let mut command = [Vec::with_capacity(n), Vec::with_capacity(n)];
    let mut reading = [Vec::with_capacity(n), Vec::with_capacity(n)];
    for &x in commands {
        let y = plant.measure();
        for i in 0..2 {
            command[i].push(x[i]);
            reading[i].push(y[i]);
        }
        plant.apply(&Command {
            voltage: voltage(x),
            x_nom: x,
            reference: [0.0; 2],
            saturated: false,
            dropout: false,
        });
    }
    LabLog::new(sample_time, command, reading)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Goal: the unit multisine peaks at the amplitude and holds exactly the planned lines
    /// (its DFT is zero at every other harmonic).
    #[test]
    fn the_multisine_holds_its_lines_only_and_keeps_the_peak() {
        let mut p = MultisinePlan::new(1e-3);
        p.lines = vec![3, 7, 20];
        p.periods = 2;
        p.settle = 0;
        let c = p.commands(1).unwrap();
        assert!(c.iter().all(|v| v[0] == 0.0));
        let peak = c.iter().fold(0.0f64, |a, v| a.max(v[1].abs()));
        assert!((peak - p.amplitude).abs() < 1e-18);
        let x: Vec<f64> = c[..p.period].iter().map(|v| v[1]).collect();
        for k in 1..p.period / 2 {
            let d = crate::measured::dft(&x, k).norm() / p.amplitude;
            if p.lines.contains(&k) {
                assert!(d > 1.0, "line {k}: {d}");
            } else {
                assert!(d < 1e-9, "harmonic {k}: {d}");
            }
        }
    }
}
