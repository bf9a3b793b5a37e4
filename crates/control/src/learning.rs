//! Iterative learning control on top of any [`StageControl`] for periodic scans (beyond
//! Actuators 2022, 11(7), 179; what commercial stage controllers sell as an option).
//!
//! # Architecture: reference adjustment
//! [`Learning`] wraps a controller and shifts the measurement it sees by a learned,
//! period-long correction c_j: the controller regulates y − c_j to q_d, so the output tracks
//! q_d + c_j. The learning plant is then the closed-loop map T: q_d → y (the process
//! sensitivity of this architecture) and the error of period j is e_j = (1 − T) q_d − T c_j.
//! The update is that of `flexstage_control_core::ilc` (Bristow, Tharayil & Alleyne 2006,
//! Eq. (3); Longman 2000 for the phase-lead law):
//!
//! ```text
//! c_{j+1} = Q (c_j + γ z^λ e_j),   Q zero-phase Bartlett of half-width M
//! ```
//!
//! The kernel is the allocation-free one of the embeddable core, so the simulated and the
//! embedded learning layers are the same code.
//!
//! # Measured
//! 3:1 Lissajous at 2 Hz (N = 5000), error against the true output, on the twin of the
//! quick design in its rig, each shipped controller as `flexstage track --learning` sets it
//! up, RMS of the scored run after 20 trials, without → with learning: PI + notch + FF
//! 9.8/5.9 → 5.4/5.1 nm, backstepping robust 7.7/10.4 → 5.1/2.1 nm, tuned PID + FF
//! 20.8/10.5 → 5.1/2.4 nm (sensor noise floor ≈ 7.8/10.4 nm; docs/verification.md). The
//! learning plant from the readings, the lag from the datasheet: nothing fitted on the true
//! output.
//!
//! # The measurement's lag, from the datasheet
//! Learning drives the *measured* error to zero. The measurement lags the true output by the
//! sensor chain's delay (the 15 kHz sensor electronics: 0.11 sample at 10 kHz), so learning
//! that is not told the lag leaves the true output that far ahead. The lag the learning
//! layer corrects for is the group delay of the sensor chain as its *datasheet* gives it
//! ([`SensorDatasheet`]: the lab's own electronics and anti-aliasing filter, here the
//! scenario's sensor settings taken as datasheet values), never a fit on the true output:
//! [`SensorLag`] can only be made from a datasheet. [`Learning::with_sensor_lag`] learns
//! against the reference delayed by it. What the datasheet does not know (on the twin's q1,
//! the modes above Nyquist that the zero-order hold excites, seen at the sample instants but
//! filtered by the sensor) stays in the true-output error; docs/verification.md has the
//! numbers.
//!
//! # Readings only
//! [`measure_learning_plant`] sees the loop through [`Readings`]: the ADC readings and the
//! commands, what a lab records. The stage's true output is not reachable from it:
//!
//! ```compile_fail,E0599
//! fn peek(rig: &mut flexstage_control::learning::Readings) -> [f64; 2] {
//!     rig.output() // no such method: the true output never reaches the learning design
//! }
//! ```
//!
//! # Design from the loop's frequency response
//! The signals of a learning controller are N-periodic, so the only frequencies are the
//! harmonics k f_0 (f_0 = f_s/N) up to Nyquist. [`measure_learning_plant`] measures T at
//! every harmonic on the loop itself (the twin or the lumped plant), from the readings: runs
//! with the same seed, with and without a Schroeder multisine added to c (odd harmonics on
//! axis 1 and even on axis 2, then swapped), differenced so that the sensor noise cancels;
//! then again at half the amplitude, whose difference from the first bounds the
//! measurement's uncertainty δ_k (amplitude-dependent hysteresis, quantization). [`design`]
//! then picks the lead λ, gain γ and the widest Q passband (smallest M) for which the
//! monotone-convergence condition (Bristow et al. 2006, Eq. (24)) holds for every plant
//! within the uncertainty, |ΔT| ≤ δ_k (triangle inequality):
//!
//! ```text
//! ρ = max_k |Q(ω_k)| (|1 − γ e^{jω_kλ} T_ii(ω_k)| + γ δ_ik) < 1,   i = 1, 2
//! ```
//!
//! holds with a margin on every harmonic: checked on the complete set of frequencies the
//! learning loop has, not a sample of them. The axes are treated loop at a time (T_ii): the
//! cross terms of the designed stage are a few percent of the diagonal and are learned as
//! part of each axis's error.
//!
//! # Two laws
//! Because every harmonic of the period is measured, the model-inverse ("plant inversion")
//! law of Bristow et al. 2006 needs nothing beyond the measurement ([`InverseLaw`]):
//!
//! ```text
//! c_{j+1,k} = Q_k (c_{j,k} + γ e_{j,k} / T̂_k),   ρ = max_k Q_k (|1 − γ| + γ δ_k / |T̂_k|)
//! ```
//!
//! with Q_k = 1 where that contraction is ≤ 0.95 and |T̂_k| ≥ [`INVERSE_MIN_RESPONSE`],
//! else 0 ([`design_inverse`]). [`choose_law`] designs both and keeps the one that learns
//! better on the loop itself: each runs the trials on a fresh loop, and the smaller learning
//! error read over the last third wins ([`design_law`], the smaller ρ, is the choice without
//! a loop to try on). [`Learning::with_law`] runs either on the same period buffers (the
//! learned table, what is exported, has the same form).
//!
//! # The output at the samples
//! Learning drives the reading to the reading it expects, r_k (the reference delayed by the
//! datasheet lag, or the reading a measured model predicts); the output at the samples
//! then misses q_d by whatever that expectation misses the sensor's real excess over the
//! output, the ringing above Nyquist its filter sees included. A lab with a fast ADC on
//! the sensor's analog output (an oscilloscope or DAQ, L samples per controller sample)
//! measures that excess while the scan runs: one period of its record, the datasheet's
//! sensor filter divided out of every harmonic, gives the output at the samples q̂_k and the
//! analog output s_k there (`flexstage_identify::measured::FastPeriod`). After every trial
//! [`Learning::retarget`] moves the reading learned toward by the mean over the periods so
//! far of (s_k − q̂_k) − (r_k − q_d,k): then y = r + d means q = q_d at the samples. The
//! excess s − q̂ = (1 − S⁻¹) s carries the fast ADC's noise with the gain |1 − 1/S(f)|,
//! about f/15 kHz in the band the layer learns in, so the correction adds almost no noise.
//!
//! # The feedback under learning
//! The sensor's noise enters the loop like the correction (y ← y − n) and reaches the output
//! through T: with learning doing the tracking, that is the error's floor. The pipeline runs
//! the learning layer on designs tuned to wider margins
//! (`flexstage_control::registry::Designs::for_learning`,
//! `flexstage_control::tuning::TuningParams::learning_widening`).

use flexstage_control_core::{Ilc, IlcBuffers};
use flexstage_identify::measured::SampledOutput;
use flexstage_numerics::RangeError;

use crate::error::Result;
use flexstage_sim::experiment::{Command, StageControl};

pub use lab::Readings;

pub use flexstage_control_core::ilc::IlcParams as LearningParams;

/// A complex number (re, im).
pub type Complex = (f64, f64);

fn core_error(e: flexstage_control_core::CoreError) -> crate::ControlError {
    RangeError::new("learning", e.to_string(), "see the message").into()
}

/// A controller with the learning layer (module docs).
#[derive(Debug, Clone)]
pub struct Learning<C> {
    inner: C,
    ilc: Ilc<Vec<[f64; 2]>>,
    /// The measurement's lag behind the true output per axis \[samples\] (datasheet).
    lag: [f64; 2],
    /// The references of the last N samples (index: the sample's index in its period).
    references: Vec<[f64; 2]>,
    /// The model-inverse law when it is the one learning (`None`: the kernel's phase lead).
    inverse: Option<Box<InverseLaw>>,
    /// The shift of the reading learned toward, per sample of the period, from the output
    /// at the samples a fast ADC measured ([`Learning::retarget`]); zero until then.
    target: Vec<[f64; 2]>,
    /// The reading learned toward in the last N samples, before the shift.
    expected: Vec<[f64; 2]>,
    /// The periods averaged into `target`.
    retargets: usize,
}

impl<C: StageControl> Learning<C> {
    /// Wraps `inner` with the learning layer `params` (buffers of one period allocated here).
    pub fn new(inner: C, params: LearningParams) -> Result<Self> {
        let n = params.period;
        let buffers = IlcBuffers {
            learned: vec![[0.0; 2]; n],
            applied: vec![[0.0; 2]; n],
            error: vec![[0.0; 2]; n],
            error_now: vec![[0.0; 2]; n],
        };
        Ok(Learning {
            inner,
            ilc: Ilc::new(params, buffers).map_err(core_error)?,
            lag: [0.0; 2],
            references: vec![[0.0; 2]; n],
            inverse: None,
            target: vec![[0.0; 2]; n],
            expected: vec![[0.0; 2]; n],
            retargets: 0,
        })
    }

    /// Wraps `inner` with the learning `law` ([`choose_law`]): the phase-lead law as
    /// [`Learning::new`], or the model-inverse law on the same period buffers.
    pub fn with_law(inner: C, law: &Law) -> Result<Self> {
        match law {
            Law::PhaseLead(p) => Learning::new(inner, *p),
            Law::Inverse(l) => {
                let params = LearningParams {
                    period: l.period(),
                    gain: l.gain(),
                    lead: 0,
                    q_half_width: 0,
                };
                let mut learning = Learning::new(inner, params)?;
                learning.inverse = Some(Box::new(l.clone()));
                Ok(learning)
            }
        }
    }

    /// Learns the error against the reference delayed by the measurement's lag τ
    /// \[samples\] ([`SensorLag`], from the sensor chain's datasheet; |τ| < N/2): e =
    /// q_d(k − τ) − y(k), linear between samples (earlier period's samples for a lead; the
    /// reference is periodic). The learning drives the *measurement* to its reference; when
    /// the measurement lags the true output by τ, q_d(k − τ) = y(k) means q(k − τ) =
    /// q_d(k − τ), where without the shift the true output would end τ ahead. Where the
    /// inner controller's feedback expects the reading a measured model predicts
    /// (`StageControl::expected_reading`: the linear laws with a reading correction fitted
    /// to the fast ADC's lifted response), the layer learns against that reading instead,
    /// so that the output at the samples, not the reading, follows.
    pub fn with_sensor_lag(mut self, lag: SensorLag) -> Result<Self> {
        let half = (self.references.len() / 2) as f64;
        for (a, l) in lag.0.iter().enumerate() {
            if l.abs() >= half {
                return Err(RangeError::new(
                    format!("learning.sensor_lag[{a}]"),
                    l.to_string(),
                    format!("|τ| < {half} samples (half the period)"),
                )
                .into());
            }
        }
        self.lag = lag.0;
        Ok(self)
    }

    /// The reference at sample k − τ_a of axis a, k the current sample's index in its period
    /// (after `references[k]` was written).
    fn lagged_reference(&self, now: [f64; 2]) -> [f64; 2] {
        let n = self.references.len();
        let k = self.ilc.sample() as f64;
        let first_period = self.ilc.periods() == 0;
        core::array::from_fn(|a| {
            let p = k - self.lag[a];
            let i0 = p.floor();
            let frac = p - i0;
            let at = |i: f64| {
                // A sample ahead of now is the last period's (periodic reference); in the
                // first period there is none, and the current reference stands in.
                if i > k && first_period {
                    now[a]
                } else {
                    self.references[(i as i64).rem_euclid(n as i64) as usize][a]
                }
            };
            (1.0 - frac) * at(i0) + frac * at(i0 + 1.0)
        })
    }

    /// Corrects the reading the layer learns toward by what a fast ADC on the sensor's
    /// analog output measured in the period just run (`output`, [`SampledOutput`]): the
    /// reading exceeds the output at the samples by b_k = s(kT) − q̂(kT), where the
    /// learning's reading r_k assumed r_k − q_d(kT); the shift d_k is the mean of b_k − (r_k −
    /// q_d(kT)) over the periods so far, and the layer learns toward r_k + d_k, so that the
    /// output at the samples, not the predicted reading, follows (module docs, "The output at
    /// the samples"). Call at a period's end.
    pub fn retarget(&mut self, output: &SampledOutput) -> Result<()> {
        let n = self.references.len();
        crate::error::check(
            "learning.retarget samples",
            output.at().len() as f64,
            output.at().len() == n && self.ilc.sample() == 0 && self.ilc.periods() > 0,
            &format!("the period's {n} samples, at a period's end"),
        )?;
        self.retargets += 1;
        let w = 1.0 / self.retargets as f64;
        for (((d, b), r), q_d) in self
            .target
            .iter_mut()
            .zip(output.sensor_excess())
            .zip(&self.expected)
            .zip(&self.references)
        {
            for a in 0..2 {
                let shift = b[a] - (r[a] - q_d[a]);
                d[a] += w * (shift - d[a]);
            }
        }
        Ok(())
    }

    /// The learning kernel (periods done, learned correction, freeze).
    pub fn ilc(&mut self) -> &mut Ilc<Vec<[f64; 2]>> {
        &mut self.ilc
    }
}

impl<C: StageControl> StageControl for Learning<C> {
    #[inline]
    fn step(&mut self, y: [f64; 2]) -> Command {
        let c = match &self.inverse {
            None => self.ilc.correction(),
            Some(law) => {
                let c = law.correction(
                    self.ilc.learned(),
                    self.ilc.last_errors(),
                    self.ilc.sample(),
                );
                self.ilc.set_correction(c)
            }
        };
        let cmd = self.inner.step([y[0] - c[0], y[1] - c[1]]);
        self.references[self.ilc.sample()] = cmd.reference;
        // The reading the feedback expects where the controller predicts it from a
        // measured model (a reading correction), else the reference delayed by the lag.
        let r = match self.inner.expected_reading() {
            Some(r) => r,
            None => self.lagged_reference(cmd.reference),
        };
        let k = self.ilc.sample();
        self.expected[k] = r;
        let d = self.target[k];
        self.ilc.record(y, [r[0] + d[0], r[1] + d[1]]);
        cmd
    }

    fn estimate(&self) -> [f64; 10] {
        self.inner.estimate()
    }

    fn expected_reading(&self) -> Option<[f64; 2]> {
        self.inner.expected_reading()
    }
}

/// A controller that adds a fixed periodic signal to the measurement shift (used to measure
/// the learning plant).
struct Injected<'a> {
    inner: Box<dyn StageControl + 'a>,
    signal: &'a [[f64; 2]],
    k: usize,
}

impl StageControl for Injected<'_> {
    fn step(&mut self, y: [f64; 2]) -> Command {
        let c = self.signal[self.k % self.signal.len()];
        self.k += 1;
        self.inner.step([y[0] - c[0], y[1] - c[1]])
    }
    fn estimate(&self) -> [f64; 10] {
        self.inner.estimate()
    }
}

/// What a lab records of its loop, and nothing more (module docs, "Readings only").
mod lab {
    use flexstage_sim::experiment::Command;
    use flexstage_sim::rig::StagePlant;

    /// A stage in its rig seen as a lab sees it: the ADC readings it samples and the
    /// commands it applies. The stage inside is private to this module, so nothing that
    /// takes a `Readings` (the learning plant's measurement) can read the true output.
    pub struct Readings(Box<dyn StagePlant>);

    impl Readings {
        /// The readings of `plant` (a simulated stage in its rig, or a lab's driver).
        pub fn new(plant: impl StagePlant + 'static) -> Readings {
            Readings(Box::new(plant))
        }

        /// The readings of a boxed plant.
        pub fn boxed(plant: Box<dyn StagePlant>) -> Readings {
            Readings(plant)
        }

        /// Samples the sensors (the ADC reading \[m\]).
        pub fn reading(&mut self) -> [f64; 2] {
            self.0.measure()
        }

        /// Advances one sample with the command.
        pub fn apply(&mut self, cmd: &Command) {
            self.0.apply(cmd)
        }
    }
}

/// A fresh loop: the controller (owning its periodic reference) and the rig's readings,
/// identical (same seeds) at every call.
pub type LoopFactory<'a> = dyn FnMut() -> Result<(Box<dyn StageControl>, Readings)> + 'a;

/// The frequency response of the learning plant T_ii at the harmonics k f_0, k = 1..N/2,
/// measured from the readings.
#[derive(Debug, Clone, PartialEq)]
pub struct LearningPlant {
    /// Samples per period N.
    pub period: usize,
    /// T_11(k f_0), T_22(k f_0) for k = 1..=N/2 (index k − 1).
    pub response: [Vec<Complex>; 2],
    /// The bound δ_ik on the error of `response` per axis and harmonic (module docs): the
    /// difference between the measurements at full and at half amplitude; 0 where unknown.
    pub uncertainty: [Vec<f64>; 2],
}

/// The position sensors' chain as the lab's datasheets give it: the values the learning
/// layer's lag is computed from ([`SensorDatasheet::lag`]). Not fitted on any record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorDatasheet {
    /// Bandwidth of the sensor electronics \[Hz\], first order (datasheet); 0 = none.
    pub bandwidth: f64,
    /// Corner of the ADC's anti-aliasing filter \[Hz\], 2nd-order Butterworth
    /// (datasheet); 0 = none.
    pub anti_alias: f64,
}

impl SensorDatasheet {
    /// The scenario's sensor settings (`[rig.sensor]` bandwidth and anti-aliasing corner),
    /// taken as the lab's datasheet values; the simulated rig may differ from them.
    pub fn from_scenario(s: &flexstage_scenario::Scenario) -> SensorDatasheet {
        SensorDatasheet {
            bandwidth: s.rig.sensor.bandwidth,
            anti_alias: s.rig.sensor.anti_alias,
        }
    }

    /// The chain's group delay at low frequency in samples of `sample_time` \[s\]: 1/ω_b for
    /// the first-order electronics and √2/ω_a for the Butterworth filter (the limits of
    /// −arg H(jω)/ω as ω → 0), the same on both axes. The scans learning serves lie far
    /// below both corners (the 3:1 Lissajous's 6 Hz against 15 kHz: the phase delay there
    /// differs from the limit by (ω/ω_b)²/3 ≈ 5e-8 relative).
    pub fn lag(&self, sample_time: f64) -> Result<SensorLag> {
        let corner = |field: &str, f: f64| -> Result<f64> {
            if f.is_finite() && f >= 0.0 {
                Ok(f)
            } else {
                Err(RangeError::new(field, f.to_string(), "a frequency ≥ 0 [Hz] (0: none)").into())
            }
        };
        let b = corner("sensor_datasheet.bandwidth", self.bandwidth)?;
        let a = corner("sensor_datasheet.anti_alias", self.anti_alias)?;
        if !(sample_time.is_finite() && sample_time > 0.0) {
            return Err(RangeError::new(
                "sensor_datasheet.sample_time",
                sample_time.to_string(),
                "a time > 0 [s]",
            )
            .into());
        }
        let tau = |f: f64, k: f64| {
            if f > 0.0 {
                k / (std::f64::consts::TAU * f)
            } else {
                0.0
            }
        };
        let lag = (tau(b, 1.0) + tau(a, std::f64::consts::SQRT_2)) / sample_time;
        Ok(SensorLag([lag; 2]))
    }
}

/// The measurement's lag behind the true output per axis \[samples\] that the learning
/// layer corrects for. Made only from a [`SensorDatasheet`] (or [`SensorLag::NONE`]), so a
/// lag fitted on the true output cannot reach a [`Learning`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorLag([f64; 2]);

impl SensorLag {
    /// No lag (an ideal sensor).
    pub const NONE: SensorLag = SensorLag([0.0; 2]);

    /// The lag per axis \[samples\].
    pub fn samples(&self) -> [f64; 2] {
        self.0
    }
}

/// The learning law for the measured `plant`, chosen on the loop itself: each law that
/// [`design`] and [`design_inverse`] find (ρ ≤ `settings.max_factor`) learns `trials`
/// periods on a fresh loop of `factory` (same seeds: the same sensor noise), told the
/// datasheet `lag`; the one whose learning error (the reading against the reading the
/// feedback expects, what the layer drives to zero) is the smaller over the last third of
/// the trials, averaged per sample over those periods and relative to the first period's
/// per axis, is kept, with its ρ. What a lab would do: try both on the rig, from the
/// readings. The convergence factor alone does not rank the laws: the model-inverse law's
/// ρ is taken over its passband only, and what it leaves out of it (harmonics with
/// |T̂| < [`INVERSE_MIN_RESPONSE`]) is never learned. An error when neither law has a
/// design.
pub fn choose_law(
    factory: &mut LoopFactory<'_>,
    plant: &LearningPlant,
    settings: &DesignParams,
    lag: SensorLag,
    trials: usize,
) -> Result<(Law, f64)> {
    let lead = design(plant, settings).map(|(p, r)| (Law::PhaseLead(p), r));
    let inverse = design_inverse(plant, settings).map(|(l, r)| (Law::Inverse(l), r));
    let (a, b) = match (lead, inverse) {
        (Ok(a), Ok(b)) => (a, b),
        (Ok(a), Err(_)) | (Err(_), Ok(a)) => return Ok(a),
        (Err(e), Err(_)) => return Err(e),
    };
    let (sa, sb) = (
        trial_error(factory, &a.0, lag, trials)?,
        trial_error(factory, &b.0, lag, trials)?,
    );
    Ok(if sb < sa { b } else { a })
}

/// The learning error of `law` after `trials` periods on a fresh loop ([`choose_law`]):
/// Σ over the axes of the mean square of the error averaged per sample over the last third
/// of the periods, over the mean square of the first period's.
fn trial_error(
    factory: &mut LoopFactory<'_>,
    law: &Law,
    lag: SensorLag,
    trials: usize,
) -> Result<f64> {
    let (inner, mut rig) = factory()?;
    let mut c = Learning::with_law(inner, law)?.with_sensor_lag(lag)?;
    let n = c.references.len();
    let trials = trials.max(2);
    let last = (trials / 3).max(1);
    let mut first = [0.0; 2];
    let mut mean = vec![[0.0; 2]; n];
    run_periods(&mut c, &mut rig, n, trials, |j, c, _| {
        let e = c.ilc.last_errors();
        if j == 0 {
            first = core::array::from_fn(|a| e.iter().map(|x| x[a] * x[a]).sum::<f64>());
        }
        if j >= trials - last {
            for (m, x) in mean.iter_mut().zip(e) {
                m[0] += x[0] / last as f64;
                m[1] += x[1] / last as f64;
            }
        }
    });
    Ok((0..2)
        .map(|a| mean.iter().map(|x| x[a] * x[a]).sum::<f64>() / first[a].max(f64::MIN_POSITIVE))
        .sum())
}

/// Runs the loop `periods` periods and returns the readings of one period: those of the
/// last, or where `periods` > 3 their mean over every period after the first two (which
/// averages the part of the sensor's noise that does not cancel between runs).
fn period_readings(
    controller: &mut dyn StageControl,
    rig: &mut Readings,
    n: usize,
    periods: usize,
) -> Vec<[f64; 2]> {
    // The first two periods settle (one when there are only two); the rest are averaged.
    let settle = if periods > 2 { 2 } else { periods - 1 };
    let analysed = (periods - settle) as f64;
    let mut measured = vec![[0.0; 2]; n];
    run_periods(controller, rig, n, periods, |j, _, readings| {
        if j >= settle {
            for (m, y) in measured.iter_mut().zip(readings) {
                for a in 0..2 {
                    m[a] += y[a] / analysed;
                }
            }
        }
    });
    measured
}

/// Runs the loop of `controller` on `rig` for `periods` periods of `n` samples (each
/// sample: the reading, the controller's step on it, its command applied) and after each
/// period hands `per_period` the period's index, the controller and the period's readings.
fn run_periods<C: StageControl + ?Sized>(
    controller: &mut C,
    rig: &mut Readings,
    n: usize,
    periods: usize,
    mut per_period: impl FnMut(usize, &C, &[[f64; 2]]),
) {
    let mut readings = vec![[0.0; 2]; n];
    for j in 0..periods {
        for y in readings.iter_mut() {
            *y = rig.reading();
            let cmd = controller.step(*y);
            rig.apply(&cmd);
        }
        per_period(j, controller, &readings);
    }
}

/// The periods per run with which the pipeline measures the learning plant
/// ([`measure_learning_plant`]): two to settle and eight averaged. The runs of a measurement
/// share the sensor's noise sequence, which cancels in their difference where the loop is
/// linear; the quantizer (one resolution step, as large as the multisine's line) and the
/// hysteresis are not, and over one period what they leave of the noise inflates the
/// uncertainty δ and so slows the design's learning. Averaging eight periods cuts that part
/// of δ by about √8.
pub const MEASURE_PERIODS: usize = 10;

/// The DFT bin k of a real N-sample record, Σ x_n e^{−j2πkn/N}.
fn dft_bin(x: impl Iterator<Item = f64>, k: usize, n: usize) -> Complex {
    let w = std::f64::consts::TAU * k as f64 / n as f64;
    x.enumerate().fold((0.0, 0.0), |(re, im), (i, v)| {
        let a = w * i as f64;
        (re + v * a.cos(), im - v * a.sin())
    })
}

/// Measures T_ii of the learning plant at every harmonic of the period from the readings
/// (module docs): `periods` periods per run (the first two let the transient of the smooth
/// start and the injection settle, the rest are averaged; [`MEASURE_PERIODS`] is what the
/// pipeline uses), multisine of `amplitude` \[m\] RMS per axis, and again at half of it for
/// the uncertainty; five runs in all.
pub fn measure_learning_plant(
    factory: &mut LoopFactory<'_>,
    period: usize,
    periods: usize,
    amplitude: f64,
) -> Result<LearningPlant> {
    if period < 4 || periods < 2 || !(amplitude > 0.0 && amplitude.is_finite()) {
        return Err(RangeError::new(
            "measure_learning_plant",
            format!("period {period}, periods {periods}, amplitude {amplitude:e}"),
            "period ≥ 4 samples, periods ≥ 2, amplitude > 0 [m]",
        )
        .into());
    }
    let base = {
        let (mut c, mut rig) = factory()?;
        period_readings(c.as_mut(), &mut rig, period, periods)
    };
    let full = injected_response(factory, &base, period, periods, amplitude)?;
    let half = injected_response(factory, &base, period, periods, 0.5 * amplitude)?;
    let uncertainty = core::array::from_fn(|a| {
        full[a]
            .iter()
            .zip(&half[a])
            .map(|(f, h)| (f.0 - h.0).hypot(f.1 - h.1))
            .collect()
    });
    Ok(LearningPlant {
        period,
        response: full,
        uncertainty,
    })
}

/// T_ii at every harmonic from two injected runs (one per harmonic parity) against `base`,
/// the readings of the run without injection.
fn injected_response(
    factory: &mut LoopFactory<'_>,
    base: &[[f64; 2]],
    n: usize,
    periods: usize,
    amplitude: f64,
) -> Result<[Vec<Complex>; 2]> {
    let half = n / 2;
    let mut response = [vec![(0.0, 0.0); half], vec![(0.0, 0.0); half]];
    for parity in 0..2 {
        // Axis 1 on harmonics of one parity, axis 2 on the other; Schroeder phases.
        let mut signal = vec![[0.0; 2]; n];
        let count = (half / 2).max(1) as f64;
        let a = amplitude * (2.0 / count).sqrt();
        for k in 1..=half {
            let axis = (k + parity) % 2;
            let phase = std::f64::consts::PI * (k * k) as f64 / half as f64;
            let w = std::f64::consts::TAU * k as f64 / n as f64;
            for (i, s) in signal.iter_mut().enumerate() {
                s[axis] += a * (w * i as f64 + phase).cos();
            }
        }
        let (c, mut rig) = factory()?;
        let mut inj = Injected {
            inner: c,
            signal: &signal,
            k: 0,
        };
        let out = period_readings(&mut inj, &mut rig, n, periods);
        for k in 1..=half {
            let axis = (k + parity) % 2;
            let dc = dft_bin(signal.iter().map(|s| s[axis]), k, n);
            let d2 = dc.0 * dc.0 + dc.1 * dc.1;
            let dy = dft_bin(out.iter().zip(base).map(|(o, b)| o[axis] - b[axis]), k, n);
            response[axis][k - 1] = (
                (dy.0 * dc.0 + dy.1 * dc.1) / d2,
                (dy.1 * dc.0 - dy.0 * dc.1) / d2,
            );
        }
    }
    Ok(response)
}

/// The Bartlett Q-filter's frequency response at ω [rad/sample]: the Fejér kernel
/// (1/(M+1)²) sin²((M+1)ω/2)/sin²(ω/2), 1 at ω = 0.
pub fn q_response(half_width: usize, omega: f64) -> f64 {
    let w = (half_width + 1) as f64;
    let s = (0.5 * omega).sin();
    if s.abs() < 1e-12 {
        return 1.0;
    }
    let r = (0.5 * w * omega).sin() / (w * s);
    r * r
}

/// The monotone-convergence factor ρ = max over harmonics and axes of
/// |Q(ω_k)| (|1 − γ e^{jω_kλ} T_ii(ω_k)| + γ δ_ik) (module docs; δ the measurement's
/// uncertainty, 0 where the plant has none). Below 1: the ℓ² norm of the learned
/// correction's error contracts every period, for every plant within the uncertainty.
pub fn convergence_factor(plant: &LearningPlant, params: &LearningParams) -> f64 {
    let n = plant.period as f64;
    let mut rho = 0.0f64;
    for (axis, delta) in plant.response.iter().zip(&plant.uncertainty) {
        for (i, t) in axis.iter().enumerate() {
            let omega = std::f64::consts::TAU * (i + 1) as f64 / n;
            let (c, s) = (
                (omega * params.lead as f64).cos(),
                (omega * params.lead as f64).sin(),
            );
            // 1 − γ e^{jωλ} T
            let lt = (c * t.0 - s * t.1, c * t.1 + s * t.0);
            let re = 1.0 - params.gain * lt.0;
            let im = -params.gain * lt.1;
            let d = delta.get(i).copied().unwrap_or(0.0);
            let f = q_response(params.q_half_width, omega)
                * ((re * re + im * im).sqrt() + params.gain * d);
            rho = rho.max(f);
        }
    }
    rho
}

/// Settings of [`design`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DesignParams {
    /// Largest accepted convergence factor ρ, in (0, 1) (the robustness margin). Default 0.95.
    pub max_factor: f64,
    /// Learning gains tried, each in (0, 2). Default 0.3, 0.5, 0.7.
    pub gains: [f64; 3],
    /// Largest lead tried \[samples\]. Default 20.
    pub max_lead: usize,
}

impl Default for DesignParams {
    fn default() -> Self {
        DesignParams {
            max_factor: 0.95,
            gains: [0.3, 0.5, 0.7],
            max_lead: 20,
        }
    }
}

/// The learning layer with the widest Q passband (smallest M, from 1 up by ×2 to N/4) for
/// which some gain and lead give ρ ≤ `max_factor` on the measured plant; among those, the
/// smallest ρ. An error when none does.
pub fn design(plant: &LearningPlant, settings: &DesignParams) -> Result<(LearningParams, f64)> {
    if !(settings.max_factor > 0.0 && settings.max_factor < 1.0) {
        return Err(RangeError::new(
            "design.max_factor",
            settings.max_factor.to_string(),
            "a number in (0, 1)",
        )
        .into());
    }
    let n = plant.period;
    let mut m = 1;
    while 4 * m <= n {
        let mut best: Option<(LearningParams, f64)> = None;
        for &gain in &settings.gains {
            for lead in 0..=settings.max_lead.min(n - 1) {
                let p = LearningParams {
                    period: n,
                    gain,
                    lead,
                    q_half_width: m,
                };
                let rho = convergence_factor(plant, &p);
                if rho <= settings.max_factor && best.is_none_or(|(_, r)| rho < r) {
                    best = Some((p, rho));
                }
            }
        }
        if let Some(b) = best {
            return Ok(b);
        }
        m *= 2;
    }
    Err(crate::ControlError::Unstable {
        what: "learning design".into(),
        detail: format!(
            "no gain/lead/Q with ρ ≤ {} on the measured learning plant",
            settings.max_factor
        ),
    })
}

/// RMS per axis \[m\] of the true-output error of each period of a record (q − q_d, the
/// `error` columns of [`flexstage_sim::experiment::Record`]).
pub fn rms_per_period(error: &[Vec<f64>; 2], period: usize) -> Vec<[f64; 2]> {
    let periods = error[0].len() / period;
    (0..periods)
        .map(|j| {
            core::array::from_fn(|a| {
                let s = &error[a][j * period..(j + 1) * period];
                (s.iter().map(|e| e * e).sum::<f64>() / period as f64).sqrt()
            })
        })
        .collect()
}

/// The least |T̂_k| the model-inverse law learns at: below it the harmonic is left out of
/// its passband (Q_k = 0), so that no harmonic's learning gain γ/|T̂_k| exceeds 2 γ. The
/// per-axis measurement does not see the cross-axis terms T_12, T_21 at a harmonic, and
/// where the loop no longer follows they are no longer small against T_ii: with a floor of
/// 0.05 the law learned to 4/6 nm on the lumped rig with the PID + feed-forward and then
/// diverged after three periods (`tests/learning_inverse.rs`).
pub const INVERSE_MIN_RESPONSE: f64 = 0.5;

/// The model-inverse learning law in the harmonic domain (Bristow, Tharayil & Alleyne 2006,
/// "plant inversion"; module docs, "Two laws"): per harmonic k of the period and axis,
///
/// ```text
/// c_{j+1,k} = Q_k (c_{j,k} + γ e_{j,k} / T̂_k),   Q_k ∈ {0, 1}
/// ```
///
/// applied in the time domain as two circular convolutions over the period with the
/// kernels q = IDFT(Q) and l = IDFT(Q γ / T̂) (2 N multiply-adds per axis and sample).
/// For every plant T within the measured uncertainty |T − T̂_k| ≤ δ_k the harmonic
/// contracts by Q_k (|1 − γ| + γ δ_k/|T̂_k|) per period.
#[derive(Debug, Clone, PartialEq)]
pub struct InverseLaw {
    period: usize,
    gain: f64,
    /// Q_k per axis, k = 0..=N/2.
    passband: [Vec<f64>; 2],
    /// L_k = Q_k γ / T̂_k per axis, k = 0..=N/2.
    learning: [Vec<Complex>; 2],
    /// q\[m\], m = 0..N, per axis.
    q_kernel: [Vec<f64>; 2],
    /// l\[m\], m = 0..N, per axis.
    l_kernel: [Vec<f64>; 2],
}

/// The real N-periodic sequence whose DFT is `h` at k = 0..=N/2 (Hermitian beyond):
/// x\[m\] = (1/N) Σ_{k=0}^{N−1} H_k e^{j2πkm/N}; the imaginary parts of H_0 and, for even
/// N, of H_{N/2} are dropped (a real sequence has none).
fn real_idft(h: &[Complex], n: usize) -> Vec<f64> {
    (0..n)
        .map(|m| {
            let mut x = h[0].0;
            for (k, hk) in h.iter().enumerate().skip(1) {
                let a = std::f64::consts::TAU * (k * m) as f64 / n as f64;
                let (s, c) = a.sin_cos();
                let re = hk.0 * c - hk.1 * s;
                x += if 2 * k == n { re } else { 2.0 * re };
            }
            x / n as f64
        })
        .collect()
}

impl InverseLaw {
    /// The law of gain γ ∈ (0, 2) on the measured `plant` with the passband `passband`
    /// (Q_k per axis for k = 1..=N/2, each 0 or 1; index k − 1). DC, which the measurement
    /// does not cover, takes the first harmonic's Q and learns with 1/|T̂_1| (a loop with
    /// integral action has T(0) = 1 and no error there to learn).
    pub fn new(plant: &LearningPlant, gain: f64, passband: [Vec<f64>; 2]) -> Result<Self> {
        let n = plant.period;
        let half = n / 2;
        let ok = gain > 0.0
            && gain < 2.0
            && n >= 4
            && (0..2).all(|a| {
                passband[a].len() == half
                    && plant.response[a].len() == half
                    && passband[a].iter().all(|q| *q == 0.0 || *q == 1.0)
            });
        if !ok {
            return Err(RangeError::new(
                "inverse_law",
                format!("gain {gain}, period {n}"),
                "gain in (0, 2), period ≥ 4, N/2 responses and passband values 0 or 1 per axis",
            )
            .into());
        }
        let mut q_full: [Vec<f64>; 2] = Default::default();
        let mut l_full: [Vec<Complex>; 2] = Default::default();
        for a in 0..2 {
            let t1 = plant.response[a][0];
            q_full[a].push(passband[a][0]);
            l_full[a].push((passband[a][0] * gain / t1.0.hypot(t1.1), 0.0));
            for (q, t) in passband[a].iter().zip(&plant.response[a]) {
                let d = t.0 * t.0 + t.1 * t.1;
                q_full[a].push(*q);
                // Q γ / T = Q γ conj(T) / |T|².
                l_full[a].push(if *q > 0.0 {
                    (q * gain * t.0 / d, -q * gain * t.1 / d)
                } else {
                    (0.0, 0.0)
                });
            }
        }
        let q_kernel = core::array::from_fn(|a| {
            let h: Vec<Complex> = q_full[a].iter().map(|q| (*q, 0.0)).collect();
            real_idft(&h, n)
        });
        let l_kernel = core::array::from_fn(|a| real_idft(&l_full[a], n));
        Ok(InverseLaw {
            period: n,
            gain,
            passband: q_full,
            learning: l_full,
            q_kernel,
            l_kernel,
        })
    }

    /// Samples per period N.
    pub fn period(&self) -> usize {
        self.period
    }

    /// The learning gain γ.
    pub fn gain(&self) -> f64 {
        self.gain
    }

    /// Q_k of `axis` at harmonic k = 0..=N/2.
    pub fn passband(&self, axis: usize) -> &[f64] {
        &self.passband[axis]
    }

    /// L_k = Q_k γ / T̂_k of `axis` at harmonic k = 0..=N/2.
    pub fn learning_gain(&self, axis: usize) -> &[Complex] {
        &self.learning[axis]
    }

    /// The circular kernels (q, l) of `axis` over one period (m = 0..N).
    pub fn kernels(&self, axis: usize) -> (&[f64], &[f64]) {
        (&self.q_kernel[axis], &self.l_kernel[axis])
    }

    /// The harmonics learned (Q_k = 1, k ≥ 1) per axis.
    pub fn learned_harmonics(&self) -> [usize; 2] {
        core::array::from_fn(|a| self.passband[a][1..].iter().filter(|q| **q > 0.0).count())
    }

    /// c_{j+1}\[k\] = Σ_m q\[m\] c_j\[k − m\] + l\[m\] e_j\[k − m\] (indices mod N) from the
    /// last period's correction `learned` and errors `error` (each N long).
    pub fn correction(&self, learned: &[[f64; 2]], error: &[[f64; 2]], k: usize) -> [f64; 2] {
        let n = self.period;
        let mut c = [0.0; 2];
        for a in 0..2 {
            let (q, l) = (&self.q_kernel[a], &self.l_kernel[a]);
            let mut acc = 0.0;
            for m in 0..n {
                let i = (k + n - m) % n;
                acc += q[m] * learned[i][a] + l[m] * error[i][a];
            }
            c[a] = acc;
        }
        c
    }
}

/// The monotone-convergence factor of the model-inverse law on `plant`: the largest over
/// axes and harmonics k = 1..=N/2 of Q_k (|1 − γ| + γ δ_k/|T̂_k|) ([`InverseLaw`]).
pub fn inverse_convergence_factor(plant: &LearningPlant, law: &InverseLaw) -> f64 {
    let mut rho = 0.0f64;
    for a in 0..2 {
        for (i, t) in plant.response[a].iter().enumerate() {
            let d = plant.uncertainty[a].get(i).copied().unwrap_or(0.0);
            let f =
                law.passband[a][i + 1] * ((1.0 - law.gain).abs() + law.gain * d / t.0.hypot(t.1));
            rho = rho.max(f);
        }
    }
    rho
}

/// The model-inverse law on the measured `plant` (module docs, "Two laws"): for each gain
/// of `settings`, the passband is every harmonic where |T̂_k| ≥ [`INVERSE_MIN_RESPONSE`]
/// and |1 − γ| + γ δ_k/|T̂_k| ≤ `max_factor`; the gain kept is the smallest of those that
/// learn the most harmonics (`settings.gains` ascending). An error when no gain learns any
/// harmonic.
pub fn design_inverse(plant: &LearningPlant, settings: &DesignParams) -> Result<(InverseLaw, f64)> {
    let mut best: Option<(InverseLaw, f64, usize)> = None;
    for &gain in &settings.gains {
        let passband = core::array::from_fn(|a| {
            plant.response[a]
                .iter()
                .enumerate()
                .map(|(i, t)| {
                    let m = t.0.hypot(t.1);
                    let d = plant.uncertainty[a].get(i).copied().unwrap_or(0.0);
                    let f = (1.0 - gain).abs() + gain * d / m;
                    f64::from(m >= INVERSE_MIN_RESPONSE && f <= settings.max_factor)
                })
                .collect()
        });
        let law = InverseLaw::new(plant, gain, passband)?;
        let rho = inverse_convergence_factor(plant, &law);
        let count = law.learned_harmonics().iter().sum::<usize>();
        // The gains ascend: among those that learn the most harmonics, the smallest (the
        // least of the sensor noise learned into the correction).
        let better = best.as_ref().is_none_or(|(_, _, c)| count > *c);
        if count > 0 && better {
            best = Some((law, rho, count));
        }
    }
    best.map(|(l, r, _)| (l, r))
        .ok_or_else(|| crate::ControlError::Unstable {
            what: "model-inverse learning design".into(),
            detail: format!(
                "no harmonic with |T| ≥ {INVERSE_MIN_RESPONSE} and a contraction ≤ {} on the \
                 measured learning plant",
                settings.max_factor
            ),
        })
}

/// A learning law as designed ([`design_law`], [`choose_law`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Law {
    /// The phase-lead law with the Bartlett Q ([`design`]).
    PhaseLead(LearningParams),
    /// The model-inverse law in the harmonic domain ([`design_inverse`]).
    Inverse(InverseLaw),
}

impl Law {
    /// Its name in files and notes: `phase-lead` or `inverse`.
    pub fn name(&self) -> &'static str {
        match self {
            Law::PhaseLead(_) => "phase-lead",
            Law::Inverse(_) => "inverse",
        }
    }

    /// A one-line description of its settings.
    pub fn describe(&self) -> String {
        match self {
            Law::PhaseLead(p) => format!(
                "phase-lead γ = {}, lead {} samples, Q half-width {}",
                p.gain, p.lead, p.q_half_width
            ),
            Law::Inverse(l) => {
                let h = l.learned_harmonics();
                format!(
                    "inverse γ = {}, harmonics learned {}/{} of {}",
                    l.gain,
                    h[0],
                    h[1],
                    l.period / 2
                )
            }
        }
    }
}

/// The learning law for the measured `plant`, chosen by measurement (module docs, "Two
/// laws"): the phase-lead law ([`design`]) and the model-inverse law ([`design_inverse`]),
/// each with its convergence factor ρ for every plant within the uncertainty; the one with
/// the smaller ρ (the faster guaranteed contraction per period). An error when neither has
/// one.
pub fn design_law(plant: &LearningPlant, settings: &DesignParams) -> Result<(Law, f64)> {
    let lead = design(plant, settings);
    let inverse = design_inverse(plant, settings);
    match (lead, inverse) {
        (Ok((p, r)), Ok((l, ri))) => Ok(if ri < r {
            (Law::Inverse(l), ri)
        } else {
            (Law::PhaseLead(p), r)
        }),
        (Ok((p, r)), Err(_)) => Ok((Law::PhaseLead(p), r)),
        (Err(_), Ok((l, ri))) => Ok((Law::Inverse(l), ri)),
        (Err(e), Err(_)) => Err(e),
    }
}
