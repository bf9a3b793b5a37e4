//! The stage's output at the sample instants during operation, from a fast ADC on the
//! sensor's analog output: what a lab's oscilloscope or DAQ records while a periodic scan
//! runs, with the sensor's datasheet filter divided out.
//!
//! A periodic scan makes every signal of the loop periodic in its period of N samples. One
//! period of the fast record (L samples per controller sample, N L in all) then holds every
//! harmonic j/(N T) of the sensor's analog output s up to the fast ADC's Nyquist frequency
//! L/(2T). The sensor chain is linear and known from its datasheet (S(f), no zeros,
//! [`SensorParams::response`]), so the output is q = S⁻¹ s harmonic by harmonic:
//!
//! ```text
//! Q_j = X_j / S(f_j),   f_j = j/(N L h) folded to |f_j| ≤ 1/(2h),   h = T/L
//! ```
//!
//! and the output at the samples is every L-th point of the inverse transform. This is the
//! lifted identification's division by the sensor ([`crate::measured::LiftedResponse`]) on a
//! record taken during operation: exact for a periodic output whose content lies below the
//! fast ADC's Nyquist frequency, the fast ADC's noise amplified by |S⁻¹| (at most
//! √(1 + (f_N/f_s)²) for a first-order chain: 3.5 for 15 kHz electronics at 100 kHz).
//!
//! Only the analog sensor output enters ([`FastChannel::record`] reads
//! [`RigPlant::sensed_substeps`] and adds the fast ADC's own noise): a [`SampledOutput`] can
//! be made only from a [`FastPeriod`], never from the simulation's truth.

use std::sync::Arc;

use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};

use flexstage_numerics::noise::GaussianNoise;
use flexstage_sim::experiment::Command;
use flexstage_sim::rig::{Mechanics, RigPlant, SensorParams, StagePlant};

use crate::error::{IdentifyError, Result, check};
use crate::measured::FastAdc;

/// The fast ADC on the sensor's analog output while the loop runs ([`FastChannel::record`]
/// after every sample).
#[derive(Debug, Clone)]
pub struct FastChannel {
    ratio: usize,
    stride: usize,
    noise: [GaussianNoise; 2],
    fast: [Vec<f64>; 2],
}

impl FastChannel {
    /// The fast ADC `adc` on `plant`'s sensor chain (starts the plant's record of its
    /// substeps).
    pub fn attach<M: Mechanics>(adc: &FastAdc, plant: &mut RigPlant<M>) -> Result<FastChannel> {
        let substeps = plant.params().substeps;
        adc.validate(substeps)?;
        plant.record_substeps();
        let mut noise = [0, 1].map(|i| {
            GaussianNoise::new(
                adc.noise_std[i],
                adc.seed.wrapping_mul(2).wrapping_add(i as u64),
            )
        });
        let now = plant.sensed();
        Ok(FastChannel {
            ratio: adc.ratio,
            stride: substeps / adc.ratio,
            fast: [0, 1].map(|i| vec![now[i] + noise[i].sample()]),
            noise,
        })
    }

    /// Records the last sample interval of `plant` (call after each `apply`): the sensor's
    /// analog output at kT + pT/L, p = 1..=L, each with the fast ADC's noise.
    pub fn record<M: Mechanics>(&mut self, plant: &RigPlant<M>) {
        let path = plant.sensed_substeps();
        for p in 1..=self.ratio {
            let s = path[p * self.stride - 1];
            for i in 0..2 {
                self.fast[i].push(s[i] + self.noise[i].sample());
            }
        }
    }

    /// Forgets what was recorded but the last fast sample: now is the start of a period.
    pub fn clear(&mut self) {
        for f in &mut self.fast {
            let last = f.len() - 1;
            f.drain(..last);
        }
    }

    /// The first `n` samples' record since the channel was attached (`n` L fast samples,
    /// the sample instants k L from the attach on), as a [`crate::measured::FastLog`] holds it.
    pub(crate) fn into_samples(self, n: usize) -> [Vec<f64>; 2] {
        self.fast.map(|mut f| {
            f.truncate(n * self.ratio);
            f
        })
    }

    /// The record since the last [`FastChannel::clear`] (or [`FastChannel::attach`]) as one
    /// period of `n` samples at `sample_time`, from the period's first instant on; the
    /// channel then starts the next period.
    pub fn take_period(&mut self, n: usize, sample_time: f64) -> Result<FastPeriod> {
        check(
            "fast period samples",
            (self.fast[0].len() - 1) as f64,
            n >= 2 && self.fast[0].len() == n * self.ratio + 1,
            &format!(
                "{} (N = {n} ≥ 2 samples of L = {})",
                n * self.ratio,
                self.ratio
            ),
        )?;
        check(
            "fast period sample_time",
            sample_time,
            sample_time > 0.0 && sample_time.is_finite(),
            "> 0 [s]",
        )?;
        let end = [0, 1].map(|i| self.fast[i][n * self.ratio]);
        let fast = [0, 1].map(|i| {
            let mut period = std::mem::replace(&mut self.fast[i], vec![end[i]]);
            period.pop();
            period
        });
        Ok(FastPeriod {
            ratio: self.ratio,
            sample_time,
            fast,
            end,
        })
    }
}

/// A stage in its rig with the lab's fast ADC recording every sample interval
/// ([`FastChannel::record`] after each `apply`); otherwise the rig itself.
pub struct FastRecorded<'a, M: Mechanics> {
    /// The stage in its rig.
    pub plant: &'a mut RigPlant<M>,
    /// The fast ADC attached to it ([`FastChannel::attach`]).
    pub fast: &'a mut FastChannel,
}

impl<M: Mechanics> StagePlant for FastRecorded<'_, M> {
    fn measure(&mut self) -> [f64; 2] {
        self.plant.measure()
    }
    fn output(&self) -> [f64; 2] {
        self.plant.output()
    }
    fn apply(&mut self, cmd: &Command) {
        self.plant.apply(cmd);
        self.fast.record(self.plant);
    }
    fn voltage(&self) -> [f64; 2] {
        self.plant.voltage()
    }
    fn x_nom(&self) -> [f64; 2] {
        self.plant.x_nom()
    }
}

/// One period of a fast ADC's record of the sensor's analog output: `fast[i][k L + p]` is
/// axis i at kT + pT/L, p = 0..L; `end` the next period's first fast sample.
#[derive(Debug, Clone, PartialEq)]
pub struct FastPeriod {
    ratio: usize,
    sample_time: f64,
    fast: [Vec<f64>; 2],
    end: [f64; 2],
}

/// The stage's output at the N sample instants of one period, estimated from a
/// [`FastPeriod`] ([`FastPeriod::output_at_samples`]), beside the sensor's analog output
/// there.
#[derive(Debug, Clone, PartialEq)]
pub struct SampledOutput {
    at: Vec<[f64; 2]>,
    sensed: Vec<[f64; 2]>,
}

impl SampledOutput {
    /// The output at the sample instants \[m\]: `at()[k]` at kT.
    pub fn at(&self) -> &[[f64; 2]] {
        &self.at
    }

    /// The sensor's analog output at the sample instants \[m\] (the fast record there).
    pub fn sensed(&self) -> &[[f64; 2]] {
        &self.sensed
    }

    /// What the sensor's analog output exceeds the output by at the samples, s(kT) −
    /// q̂(kT) \[m\]: (1 − S⁻¹) applied to the record, whose noise gain |1 − 1/S(f)| is
    /// |f|/f_s ≪ 1 below a first-order chain's bandwidth f_s (the fast ADC's noise stays
    /// out of the band a learning layer acts in).
    pub fn sensor_excess(&self) -> impl Iterator<Item = [f64; 2]> + '_ {
        self.sensed
            .iter()
            .zip(&self.at)
            .map(|(s, q)| [s[0] - q[0], s[1] - q[1]])
    }
}

impl FastPeriod {
    /// The output at the samples (module docs): `datasheet`'s sensor chain divided out of
    /// every harmonic of the period, every L-th point of the result. Errors on a
    /// non-finite record.
    pub fn output_at_samples(&self, datasheet: &SensorParams) -> Result<SampledOutput> {
        let len = self.fast[0].len();
        let h = self.sample_time / self.ratio as f64;
        if let Some(v) = self.fast.iter().flatten().find(|v| !v.is_finite()) {
            return Err(IdentifyError::Data(flexstage_numerics::DataError::new(
                "fast period",
                format!("a non-finite fast sample ({v})"),
            )));
        }
        let mut planner = FftPlanner::<f64>::new();
        let forward: Arc<dyn Fft<f64>> = planner.plan_fft_forward(len);
        let inverse: Arc<dyn Fft<f64>> = planner.plan_fft_inverse(len);
        // S⁻¹(s) = Π(s − p)/Π(−p) ([`SensorParams::poles`]) at every harmonic, negative
        // frequencies above len/2.
        let poles: Vec<Complex<f64>> = datasheet
            .poles()
            .iter()
            .map(|p| Complex::new(p.re, p.im))
            .collect();
        let dc: Complex<f64> = poles.iter().map(|p| -p).product();
        let gain: Vec<Complex<f64>> = (0..len)
            .map(|j| {
                let f = if 2 * j <= len {
                    j as f64
                } else {
                    j as f64 - len as f64
                } / (len as f64 * h);
                let s = Complex::new(0.0, std::f64::consts::TAU * f);
                poles.iter().map(|p| s - p).product::<Complex<f64>>() / dc
            })
            .collect();
        let mut q = [Vec::new(), Vec::new()];
        for (i, qi) in q.iter_mut().enumerate() {
            // The drift over the period (creep, settling) taken off as a ramp and put back:
            // slow, so the sensor passes it unchanged (S(0) = 1).
            let ramp = (self.end[i] - self.fast[i][0]) / len as f64;
            let mut x: Vec<Complex<f64>> = self.fast[i]
                .iter()
                .enumerate()
                .map(|(j, &v)| Complex::new(v - ramp * j as f64, 0.0))
                .collect();
            forward.process(&mut x);
            x.iter_mut().zip(&gain).for_each(|(v, g)| *v *= g);
            inverse.process(&mut x);
            *qi = x
                .iter()
                .enumerate()
                .map(|(j, v)| v.re / len as f64 + ramp * j as f64)
                .collect::<Vec<f64>>();
        }
        let n = len / self.ratio;
        let at = (0..n)
            .map(|k| [q[0][k * self.ratio], q[1][k * self.ratio]])
            .collect();
        let sensed = (0..n)
            .map(|k| [self.fast[0][k * self.ratio], self.fast[1][k * self.ratio]])
            .collect();
        Ok(SampledOutput { at, sensed })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    /// Goal: a periodic output through a first-order 15 kHz chain and a 2nd-order 40 kHz
    /// anti-aliasing filter, in their analytic steady state s(t) = Σ a |S(f)| sin(2πft + φ +
    /// ∠S(f)), is recovered at the samples to rounding: the known answer of the division.
    /// Against the lag alone (the sensor's group delay at DC), the error would be percent
    /// level at the 9 kHz line.
    #[test]
    fn a_periodic_output_is_recovered_from_its_filtered_fast_record() {
        let sensor = SensorParams {
            bandwidth: 15e3,
            flicker_corner: 0.0,
            anti_alias: 40e3,
        };
        let (t, ratio, n) = (1e-4, 10, 100);
        let h = t / ratio as f64;
        let f0 = 1.0 / (n as f64 * t);
        // Lines at 1, 3 and 90 harmonics of the period (f0 = 100 Hz: the last at 9 kHz).
        let lines = [(1.0, 1, 0.3), (0.2, 3, -1.0), (0.05, 90, 0.7)];
        let value = |time: f64, filtered: bool| -> f64 {
            lines
                .iter()
                .map(|&(a, k, phi)| {
                    let f = k as f64 * f0;
                    let s = if filtered {
                        sensor.response(f)
                    } else {
                        nalgebra::Complex::new(1.0, 0.0)
                    };
                    a * s.norm() * (TAU * f * time + phi + s.arg()).sin()
                })
                .sum()
        };
        let fast = [0, 1].map(|i| {
            (0..n * ratio)
                .map(|j| (1.0 + i as f64) * value(j as f64 * h, true))
                .collect()
        });
        let end = [0, 1].map(|i| (1.0 + i as f64) * value((n * ratio) as f64 * h, true));
        let period = FastPeriod {
            ratio,
            sample_time: t,
            fast,
            end,
        };
        let q = period.output_at_samples(&sensor).unwrap();
        assert_eq!(q.at().len(), n);
        let mut worst = 0.0f64;
        for (k, v) in q.at().iter().enumerate() {
            for (i, vi) in v.iter().enumerate() {
                let truth = (1.0 + i as f64) * value(k as f64 * t, false);
                worst = worst.max((vi - truth).abs());
            }
        }
        assert!(worst < 1e-12, "worst error {worst:e}");
        // The record itself (the lag-free reading) is far off at the samples.
        let raw = (0..n)
            .map(|k| (period.fast[0][k * ratio] - value(k as f64 * t, false)).abs())
            .fold(0.0f64, f64::max);
        assert!(raw > 0.01, "raw error {raw}");
    }

    /// Goal: a record of the wrong length or with a non-finite sample is refused by name.
    #[test]
    fn a_wrong_record_is_refused() {
        let adc = FastAdc {
            ratio: 2,
            noise_std: [0.0; 2],
            seed: 1,
        };
        let mut channel = FastChannel {
            ratio: adc.ratio,
            stride: 1,
            noise: [GaussianNoise::new(0.0, 1), GaussianNoise::new(0.0, 2)],
            fast: [vec![0.0; 6], vec![0.0; 6]],
        };
        let e = channel.take_period(3, 1e-4).unwrap_err().to_string();
        assert!(e.contains("fast period samples"), "{e}");
        let mut period = FastPeriod {
            ratio: 2,
            sample_time: 1e-4,
            fast: [vec![0.0; 4], vec![0.0; 4]],
            end: [0.0; 2],
        };
        period.fast[1][3] = f64::NAN;
        let e = period
            .output_at_samples(&SensorParams::ideal())
            .unwrap_err()
            .to_string();
        assert!(e.contains("non-finite"), "{e}");
    }
}
