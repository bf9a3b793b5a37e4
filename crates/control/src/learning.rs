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
//! quick design in its rig, each shipped controller as `track` sets it up (`cargo run
//! --release -p flexstage-assess --example learn -- quick runs/quick/design/design.json`),
//! last of 20 periods, without → with learning: PI + notch + FF 10.3/5.9 → 2.6/6.5 nm, tuned
//! PID + FF 21.7/10.9 → 1.4/2.8 nm, backstepping robust 3.8/11.4 → 2.8/2.5 nm (sensor noise
//! floor ≈ 7.8/10.4 nm). On the lumped stage in the rig (tests/learning.rs) the PID with the
//! scenario's gains goes from 23/46 nm to 2.8/2.7 nm after 10 periods.
//!
//! # The measurement's lag
//! Learning drives the *measured* error to zero. On the twin the measurement lags the true
//! output by 0.34/0.09 sample: the 15 kHz sensor electronics (0.11 sample) and, on q1, the
//! modes above Nyquist, which the sensor filter sees at their real frequency (a component
//! of the sampled output proportional to the input's velocity). Learning that is not told
//! the lag leaves the true output that far ahead: 7.5 nm RMS on q1 for every controller.
//! [`measure_learning_plant`] therefore also fits the lag on the loop's own motion
//! ([`sensor_lag`]; this uses the true output, which the twin has and a rig would take from
//! its model), and [`Learning::with_sensor_lag`] learns against the reference delayed by it.
//!
//! # Design from the loop's frequency response
//! The signals of a learning controller are N-periodic, so the only frequencies are the
//! harmonics k f_0 (f_0 = f_s/N) up to Nyquist. [`measure_learning_plant`] measures T at
//! every harmonic on the loop itself (the twin or the lumped plant): two runs with the same
//! seed, one with a Schroeder multisine added to c (odd harmonics on axis 1 and even on axis
//! 2, then swapped), differenced so that the sensor noise cancels. [`design`] then picks the
//! lead λ, gain γ and the widest Q passband (smallest M) for which the monotone-convergence
//! condition (Bristow et al. 2006, Eq. (24))
//!
//! ```text
//! ρ = max_k |Q(ω_k) (1 − γ e^{jω_kλ} T_ii(ω_k))| < 1,   i = 1, 2
//! ```
//!
//! holds with a margin on every harmonic: checked on the complete set of frequencies the
//! learning loop has, not a sample of them. The axes are treated loop at a time (T_ii): the
//! cross terms of the designed stage are a few percent of the diagonal and are learned as
//! part of each axis's error.

use flexstage_control_core::{Ilc, IlcBuffers};
use flexstage_numerics::RangeError;

use crate::error::Result;
use flexstage_sim::experiment::{Command, StageControl};
use flexstage_sim::rig::StagePlant;

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
    /// The measurement's lag behind the true output per axis \[samples\].
    lag: [f64; 2],
    /// The references of the last N samples (index: the sample's index in its period).
    references: Vec<[f64; 2]>,
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
        })
    }

    /// Learns the error against the reference delayed by the measurement's lag τ_i
    /// \[samples\] per axis (|τ_i| < N/2; [`LearningPlant::sensor_lag`]): e = q_d(k − τ) − y(k),
    /// linear between samples (earlier period's samples for a lead; the reference is
    /// periodic). The learning drives the *measurement* to its reference; when the
    /// measurement lags the true output by τ, q_d(k − τ) = y(k) means q(k − τ) = q_d(k − τ),
    /// where without the shift the true output would end τ ahead (on the twin of the quick
    /// design τ ≈ 0.3 sample on q1: 7.5 nm RMS of the Lissajous 3:1).
    pub fn with_sensor_lag(mut self, lag: [f64; 2]) -> Result<Self> {
        let half = (self.references.len() / 2) as f64;
        for (a, l) in lag.iter().enumerate() {
            if !(l.is_finite() && l.abs() < half) {
                return Err(RangeError::new(
                    format!("learning.sensor_lag[{a}]"),
                    l.to_string(),
                    format!("|τ| < {half} samples (half the period)"),
                )
                .into());
            }
        }
        self.lag = lag;
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

    /// The learning kernel (periods done, learned correction, freeze).
    pub fn ilc(&mut self) -> &mut Ilc<Vec<[f64; 2]>> {
        &mut self.ilc
    }
}

impl<C: StageControl> StageControl for Learning<C> {
    #[inline]
    fn step(&mut self, y: [f64; 2]) -> Command {
        let c = self.ilc.correction();
        let cmd = self.inner.step([y[0] - c[0], y[1] - c[1]]);
        self.references[self.ilc.sample()] = cmd.reference;
        let r = self.lagged_reference(cmd.reference);
        self.ilc.record(y, r);
        cmd
    }

    fn estimate(&self) -> [f64; 10] {
        self.inner.estimate()
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

/// A fresh loop: the controller (owning its periodic reference) and the plant, identical
/// (same seeds) at every call.
pub type LoopFactory<'a> = dyn FnMut() -> Result<(Box<dyn StageControl>, Box<dyn StagePlant>)> + 'a;

/// The frequency response of the learning plant T_ii at the harmonics k f_0, k = 1..N/2.
#[derive(Debug, Clone, PartialEq)]
pub struct LearningPlant {
    /// Samples per period N.
    pub period: usize,
    /// T_11(k f_0), T_22(k f_0) for k = 1..=N/2 (index k − 1).
    pub response: [Vec<Complex>; 2],
    /// The lag of the measurement behind the true output per axis \[samples\] (negative: a
    /// lead) on the loop's own motion, without injection ([`sensor_lag`]); 0 where unknown.
    pub sensor_lag: [f64; 2],
}

/// The lag τ \[samples\] of the measurement behind the true output on axis `axis` of one
/// period of the loop (periodic records): the least-squares fit of y − q − mean = −τ q̇ with
/// q̇ the central difference, τ = −Σ (y − q) q̇ / Σ q̇²; 0 when q does not move. Records of
/// different lengths are cut to the shorter.
pub fn sensor_lag(truth: &[[f64; 2]], measured: &[[f64; 2]], axis: usize) -> f64 {
    let n = truth.len().min(measured.len());
    let truth = &truth[..n];
    let mean = truth
        .iter()
        .zip(measured)
        .map(|(q, y)| y[axis] - q[axis])
        .sum::<f64>()
        / n.max(1) as f64;
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..n {
        let dq = 0.5 * (truth[(i + 1) % n][axis] - truth[(i + n - 1) % n][axis]);
        num += (measured[i][axis] - truth[i][axis] - mean) * dq;
        den += dq * dq;
    }
    if den > 0.0 { -num / den } else { 0.0 }
}

/// Runs the loop `periods` periods and returns the true outputs and the measurements of the
/// last period.
fn last_period(
    controller: &mut dyn StageControl,
    plant: &mut dyn StagePlant,
    n: usize,
    periods: usize,
) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let mut out = Vec::with_capacity(n);
    let mut measured = Vec::with_capacity(n);
    for k in 0..n * periods {
        let y = plant.measure();
        let cmd = controller.step(y);
        if k >= n * (periods - 1) {
            out.push(plant.output());
            measured.push(y);
        }
        plant.apply(&cmd);
    }
    (out, measured)
}

/// The DFT bin k of a real N-sample record, Σ x_n e^{−j2πkn/N}.
fn dft_bin(x: impl Iterator<Item = f64>, k: usize, n: usize) -> Complex {
    let w = std::f64::consts::TAU * k as f64 / n as f64;
    x.enumerate().fold((0.0, 0.0), |(re, im), (i, v)| {
        let a = w * i as f64;
        (re + v * a.cos(), im - v * a.sin())
    })
}

/// Measures T_ii of the learning plant at every harmonic of the period (module docs):
/// `periods` periods per run (the last one is analysed, the others let the transient of the
/// smooth start and the injection settle), multisine of `amplitude` \[m\] RMS per axis.
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
    let n = period;
    let half = n / 2;
    let base = {
        let (mut c, mut p) = factory()?;
        last_period(c.as_mut(), p.as_mut(), n, periods)
    };
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
        let (c, mut p) = factory()?;
        let mut inj = Injected {
            inner: c,
            signal: &signal,
            k: 0,
        };
        let (out, _) = last_period(&mut inj, p.as_mut(), n, periods);
        for k in 1..=half {
            let axis = (k + parity) % 2;
            let dc = dft_bin(signal.iter().map(|s| s[axis]), k, n);
            let d2 = dc.0 * dc.0 + dc.1 * dc.1;
            let dy = dft_bin(
                out.iter().zip(&base.0).map(|(o, b)| o[axis] - b[axis]),
                k,
                n,
            );
            response[axis][k - 1] = (
                (dy.0 * dc.0 + dy.1 * dc.1) / d2,
                (dy.1 * dc.0 - dy.0 * dc.1) / d2,
            );
        }
    }
    let sensor_lag = [0, 1].map(|a| sensor_lag(&base.0, &base.1, a));
    Ok(LearningPlant {
        period: n,
        response,
        sensor_lag,
    })
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
/// |Q(ω_k)(1 − γ e^{jω_kλ} T_ii(ω_k))| (module docs). Below 1: the ℓ² norm of the learned
/// correction's error contracts every period.
pub fn convergence_factor(plant: &LearningPlant, params: &LearningParams) -> f64 {
    let n = plant.period as f64;
    let mut rho = 0.0f64;
    for axis in &plant.response {
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
            let f = q_response(params.q_half_width, omega) * (re * re + im * im).sqrt();
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
