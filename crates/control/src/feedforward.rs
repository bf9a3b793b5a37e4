//! Feed-forward that inverts the loop's measured dynamics, with preview of the reference.
//!
//! The reference of a scan is known ahead (`flexstage_sim::trajectory::Reference` is a
//! function of time), so the feed-forward may use future samples. It is a 2 × 2 FIR filter
//! with `preview` non-causal taps:
//!
//! ```text
//! x_ff,k = Σ_{n = −p}^{m−1} F_n q_d,k−n         F(e^{jωT}) = Σ_n F_n e^{−jωnT}
//! ```
//!
//! fitted by least squares so that the sampled loop G (x_nom → reading, 2 × 2: the measured
//! response's z-domain fit, a [`LoopPlant`]) driven by it reads the target
//! D(ω) = T(ω) e^{−jωτ} I: T a zero-phase low-pass |T| = 1/(1 + (f/f_c)^{2N}) that rolls the
//! inversion off before the hold's images and the modes folded onto the sampled band, and
//! τ the sensor chain's datasheet lag (the reading lags the true output by τ, so the true
//! output then follows T q_d). Per column j of F, over a uniform grid of frequencies
//! ω_k ∈ (0, π/T):
//!
//! ```text
//! min Σ_k ‖G(ω_k) F_{:,j}(ω_k) − D(ω_k) e_j‖² + λ Σ_n ‖F_{:,j,n}‖²
//! ```
//!
//! (the error weighted where the loop responds, not the inverse's: no division by a small
//! |G|), with λ = ρ · (the mean diagonal of the normal matrix) a Tikhonov term on the taps
//! (by Parseval, on |F|² over the band). The normal matrix is block-Toeplitz in the tap lags,
//! so it costs O(grid · taps) to build. With T = 1, τ = 0, λ = 0 and a loop whose inverse is
//! itself such a FIR (a minimum-phase FIR loop with delay), the fit is that inverse exactly.
//!
//! The static inverse with a lead of ℓ samples is the same filter with one tap,
//! F_{−ℓ} = G_dc⁻¹ ([`FirFeedForward::static_lead`]): the baseline the dynamic inverse is
//! compared with. The feed-forward changes no loop margin: it acts outside the loop.
//!
//! # The feedback's reference
//!
//! The feedback compares the reading with q_d((k − τ) T): the reading the sensor gives when
//! the output follows and the sensor is its datasheet lag τ. When the lifted fit makes the
//! output follow at the samples, the sensor reads more than a lag (its filter sees the
//! hold's ringing of modes above Nyquist), and the feedback would pull the output off to
//! make the reading follow. [`FirFeedForward::fit_reading`] fits a second FIR C on the same
//! window so that the feedback's reference is the reading the measured loop predicts,
//! r_k = q_d((k − τ) T) + Σ_n C_n q_d,k−n, e^{−jωτT} I + C ≈ G_m G_0⁻¹ (G_m the sampled
//! response to the reading, G_0 the lifted response's phase 0, both measured). It too acts
//! outside the loop: no margin changes.

use std::sync::Arc;

use nalgebra::{Complex, DMatrix, DVector};

use flexstage_identify::measured::{LiftedResponse, harmonic_frequency};
use flexstage_sim::modal::LoopPlant;
use flexstage_sim::rig::SensorParams;
use flexstage_sim::trajectory::Reference;

use crate::error::{ControlError, Result, check};
use crate::feasibility::static_inverse;
use crate::learning::SensorDatasheet;
use crate::pi_notch::{PiNotchParams, WithFeedForward};
use crate::registry::{Design, Stage};

/// A 2 × 2 frequency response.
type Response = [[Complex<f64>; 2]; 2];

/// The feed-forward a tuned linear design (PI + notch, PID) gets
/// ([`crate::tuning::TuningParams::feedforward`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FeedForward {
    /// The static inverse G_dc⁻¹ q_d at the current sample.
    Static,
    /// The static inverse `lead` samples ahead (F_{−ℓ} = G_dc⁻¹), the feedback unchanged.
    StaticLead(usize),
    /// The inverse of the stage's sampled response fitted with these settings, their lag
    /// set from the sensor's datasheet ([`SensorDatasheet`]: the scenario's sensor chain).
    Inverse(FeedForwardParams),
    /// The inverse fitted to the lifted response of the output (the sensor recorded between
    /// the samples by a fast ADC, [`FirFeedForward::fit_lifted`]) with these settings, their
    /// lag set from the sensor's datasheet; [`FeedForward::Inverse`] where the stage has no
    /// lifted response.
    Lifted(FeedForwardParams),
}

impl Default for FeedForward {
    /// The fitted inverse with [`FeedForwardParams::default`].
    fn default() -> Self {
        FeedForward::Inverse(FeedForwardParams::default())
    }
}

/// The design of the linear controller `params` on `stage` with the feed-forward its tuning
/// asks for ([`FeedForward`]); the static inverse where the stage has no sampled response to
/// fit an inverse to. The fit is made once per stage and shared by the designs.
pub fn design_with(stage: &Stage<'_>, params: PiNotchParams) -> Result<Arc<dyn Design>> {
    let feedforward = match stage.tuning.feedforward {
        FeedForward::Static => return Ok(Arc::new(params)),
        FeedForward::StaticLead(lead) => {
            FirFeedForward::static_lead(static_inverse(params.static_gain)?, lead)
        }
        FeedForward::Inverse(p) | FeedForward::Lifted(p) => {
            let Some(response) = stage.response else {
                return Ok(Arc::new(params));
            };
            let sensor = &stage.setup.rig.sensor;
            let lag = SensorDatasheet {
                bandwidth: sensor.bandwidth,
                anti_alias: sensor.anti_alias,
            }
            .lag(response.sample_time())?
            .samples()[0];
            let p = FeedForwardParams { lag, ..p };
            match (stage.tuning.feedforward, stage.lifted) {
                (FeedForward::Lifted(_), Some(lifted)) => {
                    stage.shared("feedforward.lifted", || {
                        if p.reading && lifted.ratio() >= 2 {
                            FirFeedForward::fit_lifted(&lifted.at_samples(), &p)?
                                .fit_reading(lifted, sensor, &p)
                        } else {
                            FirFeedForward::fit_lifted(lifted, &p)
                        }
                    })?
                }
                _ => stage.shared("feedforward.inverse", || FirFeedForward::fit(response, &p))?,
            }
        }
    };
    Ok(Arc::new(WithFeedForward {
        params,
        feedforward,
    }))
}

/// Settings of the fitted inverse ([`FirFeedForward::fit`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeedForwardParams {
    /// Preview taps p (future reference samples), 0–64.
    pub preview: usize,
    /// Causal taps m (the current and past samples), 1–512.
    pub taps: usize,
    /// Corner of the target low-pass T \[Hz\], 0 < f_c < Nyquist; ∞: T = 1.
    pub cutoff: f64,
    /// Order N of the target low-pass, 1–8.
    pub order: u32,
    /// The sensor chain's datasheet lag τ the target includes \[samples\], ≥ 0.
    pub lag: f64,
    /// Relative Tikhonov weight ρ on the taps, ≥ 0.
    pub regularization: f64,
    /// Frequencies of the fit, ≥ 4 (p + m).
    pub grid: usize,
    /// With the lifted fit (default on): the filter fitted to the output at the samples (the
    /// lifted response's phase 0) and the feedback's reference the reading the measured
    /// loop predicts when it follows ([`FirFeedForward::fit_reading`] on every phase), not
    /// q_d delayed by the lag alone. Off, or with a lifted response of one phase: the
    /// filter fitted to every phase given, the reference delayed by the lag.
    pub reading: bool,
}

impl Default for FeedForwardParams {
    /// 10 preview and 54 causal taps, T of order 4 with its corner at 1.5 kHz, ρ = 1e-6,
    /// 2000 frequencies; no sensor lag (set from the datasheet by the design).
    fn default() -> Self {
        FeedForwardParams {
            preview: 10,
            taps: 54,
            cutoff: 1500.0,
            order: 4,
            lag: 0.0,
            regularization: 1e-6,
            grid: 2000,
            reading: true,
        }
    }
}

impl FeedForwardParams {
    /// Checks the fields at sample time `t` \[s\].
    pub fn validate(&self, t: f64) -> Result<()> {
        let nyquist = 0.5 / t;
        check(
            "feedforward.preview",
            self.preview as f64,
            self.preview <= 64,
            "0–64",
        )?;
        check(
            "feedforward.taps",
            self.taps as f64,
            (1..=512).contains(&self.taps),
            "1–512",
        )?;
        if self.cutoff != f64::INFINITY {
            check(
                "feedforward.cutoff",
                self.cutoff,
                self.cutoff > 0.0 && self.cutoff < nyquist,
                &format!("0 < f_c < {nyquist} Hz (Nyquist), or ∞"),
            )?;
        }
        check(
            "feedforward.order",
            self.order as f64,
            (1..=8).contains(&self.order),
            "1–8",
        )?;
        check("feedforward.lag", self.lag, self.lag >= 0.0, "≥ 0 samples")?;
        check(
            "feedforward.regularization",
            self.regularization,
            self.regularization >= 0.0,
            "≥ 0",
        )?;
        let len = self.preview + self.taps;
        check(
            "feedforward.grid",
            self.grid as f64,
            self.grid >= 4 * len,
            &format!("≥ 4 (preview + taps) = {}", 4 * len),
        )
    }

    /// The target T(f) e^{−j2πfτT} at `f` \[Hz\] and sample time `t`.
    pub fn target(&self, f: f64, t: f64) -> Complex<f64> {
        let mag = if self.cutoff.is_finite() {
            1.0 / (1.0 + (f / self.cutoff).powi(2 * self.order as i32))
        } else {
            1.0
        };
        Complex::from_polar(mag, -std::f64::consts::TAU * f * self.lag * t)
    }
}

/// A 2 × 2 FIR feed-forward with preview (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct FirFeedForward {
    preview: usize,
    /// F_n for n = −p, …, m − 1.
    taps: Vec<[[f64; 2]; 2]>,
    /// The lag the feedback's reference is delayed by \[samples\] (the target's τ).
    lag: f64,
    /// The reading correction C_n on the same window (n = −p, …, m − 1), added to the
    /// feedback's reference ([`FirFeedForward::fit_reading`]); `None`: q_d((k − τ) T) alone.
    reading: Option<Vec<[[f64; 2]; 2]>>,
}

impl FirFeedForward {
    /// The static inverse G_dc⁻¹ (`inverse`) applied `lead` samples ahead: one tap.
    pub fn static_lead(inverse: [[f64; 2]; 2], lead: usize) -> FirFeedForward {
        let mut taps = vec![[[0.0; 2]; 2]; lead + 1];
        taps[0] = inverse;
        FirFeedForward {
            preview: lead,
            taps,
            lag: 0.0,
            reading: None,
        }
    }

    /// Fits the inverse of `plant` (module docs).
    pub fn fit(plant: &dyn LoopPlant, p: &FeedForwardParams) -> Result<FirFeedForward> {
        let t = plant.sample_time();
        p.validate(t)?;
        let nyquist = 0.5 / t;
        // Per frequency: the response and the target.
        let grid: Vec<(f64, [Response; 1], Complex<f64>)> = (0..p.grid)
            .map(|k| {
                let f = (k as f64 + 0.5) / p.grid as f64 * nyquist;
                (f, [plant.response(f)], p.target(f, t))
            })
            .collect();
        let g0 = plant.static_gain();
        let g0 = g0.iter().flatten().map(|v| v * v).sum::<f64>();
        let points = grid.iter().map(|(f, g, d)| (*f, &g[..], *d));
        let taps = fit_points(points, g0, t, p)?;
        Ok(FirFeedForward {
            preview: p.preview,
            taps,
            lag: p.lag,
            reading: None,
        })
    }

    /// Fits the filter whose output follows the reference between the samples too: on
    /// every measured line of the lifted response of the output (`lifted`: G_p from the
    /// command to the output at kT + pT/L, the sensor divided out), the L phase equations
    /// G_p F = T e^{j2πf pT/L} are stacked in the least squares of the module docs (the
    /// output at kT + pT/L follows T q_d there). The sensor's lag stays in the feedback's
    /// reference (`p.lag`), not in the target: the lifted response is the output's.
    /// `p.grid` is not used (the lines are the grid); with L = 1 and the lines of a sampled
    /// response this is [`FirFeedForward::fit`] on those lines.
    pub fn fit_lifted(lifted: &LiftedResponse, p: &FeedForwardParams) -> Result<FirFeedForward> {
        let t = lifted.sample_time();
        let q = FeedForwardParams {
            grid: 4 * (p.preview + p.taps),
            ..*p
        };
        q.validate(t)?;
        let lines: Vec<(f64, Vec<Response>)> = lifted
            .lines()
            .iter()
            .map(|line| (line.f, line.phase.iter().map(|ph| ph.h).collect()))
            .collect();
        fit_phase_lines(&lines, t, p)
    }

    /// This filter with the reading correction fitted: the feedback's reference becomes
    /// the reading the measured loop predicts when the output at the samples follows q_d,
    /// q_d((k − τ) T) + Σ_n C_n q_d,k−n on the filter's window (module docs, "The
    /// feedback's reference"). On every line f of `lifted` (L ≥ 2 phases), G_0 is its phase
    /// 0 (command to output at the samples, the sensor divided out) and G_m the reading at
    /// the samples from the same record, G_m = Σ_m S_m H_m (the harmonics H_m with the
    /// sensor chain `datasheet`, S, put back on the baseband and the hold's two images
    /// f_s ∓ f, S_m = S(f_m): what the fast ADC recorded at phase 0, the sensor's filter
    /// acting on each, an image's correction S_m − e^{−j2πfτT} shrunk by its
    /// signal-to-noise share (1 − σ²/|H_m|²)⁺ per entry (σ² = Σ_p std_p²/L² from the
    /// phases' standard deviations); the harmonics beyond, under the fast ADC's noise floor,
    /// with the lag alone, S_m = e^{−j2πfτT}, lest their noise enter C). One experiment, so that
    /// G_m G_0⁻¹ → I at low frequency. C minimizes
    /// Σ_f w ‖C G_0 − T(f) (G_m − e^{−j2πfτT} G_0)‖² + λ ‖C‖²,
    /// w = 1/(1 + ‖G_0‖²/‖G_0(f_1)‖²), λ = ρ × the normal matrix's mean diagonal (T and ρ:
    /// `p`'s target low-pass and regularization; its lag is not used):
    /// e^{−j2πfτT} I + C ≈ G_m G_0⁻¹ in the band of T, rolled off beyond it like the
    /// filter's target (else the correction's size around the folded modes costs its
    /// accuracy at low frequency), the error weighted as the output's. An ideal sensor
    /// (G_m = e^{−j2πfτT} G_0) gives C = 0 exactly.
    pub fn fit_reading(
        self,
        lifted: &LiftedResponse,
        datasheet: &SensorParams,
        p: &FeedForwardParams,
    ) -> Result<FirFeedForward> {
        let t = lifted.sample_time();
        let l = lifted.ratio();
        check(
            "lifted response ratio",
            l as f64,
            l >= 2,
            "≥ 2 phases (the reading's harmonics)",
        )?;
        let lines: Vec<(f64, Response, Response)> = lifted
            .lines()
            .iter()
            .enumerate()
            .map(|(n, line)| {
                let lag = Complex::from_polar(1.0, -std::f64::consts::TAU * line.f * self.lag * t);
                // Each harmonic's noise variance Σ_p std_p²/L² per entry.
                let var = [0, 1].map(|i| {
                    [0, 1].map(|j| {
                        line.phase
                            .iter()
                            .map(|ph| ph.std[i][j].powi(2))
                            .sum::<f64>()
                            / (l * l) as f64
                    })
                });
                let mut gm = [[Complex::new(0.0, 0.0); 2]; 2];
                for (m, h) in lifted.harmonics(n).iter().enumerate() {
                    let s = datasheet.response(harmonic_frequency(line.f, m, l, t));
                    for i in 0..2 {
                        for j in 0..2 {
                            // The baseband and the two images, each shrunk by its
                            // signal-to-noise share (1 − var/|H|²)⁺; the lag on the rest.
                            let share = if m == 0 {
                                1.0
                            } else if m == 1 || m == l - 1 {
                                (1.0 - var[i][j] / h[i][j].norm_sqr().max(f64::MIN_POSITIVE))
                                    .max(0.0)
                            } else {
                                0.0
                            };
                            gm[i][j] += (lag + (s - lag) * share) * h[i][j];
                        }
                    }
                }
                (line.f, line.phase[0].h, gm)
            })
            .collect();
        self.fit_reading_lines(&lines, t, p)
    }

    /// [`FirFeedForward::fit_reading`] on `lines` (f, G_0, G_m) at sample time `t`.
    fn fit_reading_lines(
        mut self,
        lines: &[(f64, Response, Response)],
        t: f64,
        p: &FeedForwardParams,
    ) -> Result<FirFeedForward> {
        let len = self.taps.len();
        let regularization = p.regularization;
        check(
            "feedforward.regularization",
            regularization,
            regularization >= 0.0,
            "≥ 0",
        )?;
        let low_pass = FeedForwardParams { lag: 0.0, ..*p };
        check(
            "lifted response lines",
            lines.len() as f64,
            lines.len() >= 4 * len,
            &format!("≥ 4 (preview + taps) = {}", 4 * len),
        )?;
        let norm2 = |g: &Response| g.iter().flatten().map(|v| v.norm_sqr()).sum::<f64>();
        let g0 = norm2(&lines[0].1);
        let points: Vec<(f64, Response, Response, f64)> = lines
            .iter()
            .map(|(f, g, m)| {
                let e = Complex::from_polar(1.0, -std::f64::consts::TAU * f * self.lag * t);
                // C G_0 ≈ T D as G_0ᵀ Cᵀ ≈ T Dᵀ.
                let lp = low_pass.target(*f, t).re;
                let d = [0, 1].map(|i| [0, 1].map(|j| (m[j][i] - e * g[j][i]) * lp));
                let gt = [0, 1].map(|i| [0, 1].map(|j| g[j][i]));
                (*f, gt, d, 1.0 / (1.0 + norm2(g) / g0))
            })
            .collect();
        let c = fit_matrix_points(&points, self.preview, len, regularization, t)?;
        let mut taps: Vec<[[f64; 2]; 2]> = c
            .iter()
            .map(|c| [0, 1].map(|i| [0, 1].map(|j| c[j][i])))
            .collect();
        // At DC the sensor reads the output (S(0) = 1, the lag's phase 0), so C(1) = Σ_n C_n
        // = 0 exactly: the fit's residual there, times a slow scan's micrometres, would be a
        // reference error of tens of nanometres (measured: Σ C_11 = −0.0034, 19 nm RMS on
        // an 8 µm Lissajous). The sum is taken off the tap at n = 0.
        let sum = taps.iter().fold([[0.0; 2]; 2], |acc, c| {
            [0, 1].map(|i| [0, 1].map(|j| acc[i][j] + c[i][j]))
        });
        for (i, row) in taps[self.preview].iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v -= sum[i][j];
            }
        }
        self.reading = Some(taps);
        Ok(self)
    }

    /// This filter with the reading correction `taps` (C_n, n = −p, …, m − 1: as many as
    /// the filter's taps, finite), for a filter read back from a file.
    pub fn with_reading(mut self, taps: Vec<[[f64; 2]; 2]>) -> Result<FirFeedForward> {
        check(
            "feedforward.reading",
            taps.len() as f64,
            taps.len() == self.taps.len(),
            &format!("{} taps (as many as the filter's)", self.taps.len()),
        )?;
        for (n, tap) in taps.iter().enumerate() {
            for v in tap.iter().flatten() {
                check(
                    &format!("feedforward.reading[{n}]"),
                    *v,
                    true,
                    "finite entries",
                )?;
            }
        }
        self.reading = Some(taps);
        Ok(self)
    }

    /// The reading correction C_n, n = −p, …, m − 1 ([`FirFeedForward::fit_reading`]);
    /// `None`: the feedback's reference is q_d((k − τ) T).
    pub fn reading(&self) -> Option<&[[[f64; 2]; 2]]> {
        self.reading.as_deref()
    }

    /// The preview p \[samples\].
    pub fn preview(&self) -> usize {
        self.preview
    }

    /// The taps F_n, n = −p, …, m − 1.
    pub fn taps(&self) -> &[[[f64; 2]; 2]] {
        &self.taps
    }

    /// The lag the feedback's reference is delayed by \[samples\] (the target's τ).
    pub fn lag(&self) -> f64 {
        self.lag
    }

    /// The filter's response F(e^{j2πfT}) at `f` \[Hz\], sample time `t`.
    pub fn response(&self, f: f64, t: f64) -> [[Complex<f64>; 2]; 2] {
        let mut out = [[Complex::new(0.0, 0.0); 2]; 2];
        for (u, tap) in self.taps.iter().enumerate() {
            let n = u as f64 - self.preview as f64;
            let e = Complex::from_polar(1.0, -std::f64::consts::TAU * f * n * t);
            for i in 0..2 {
                for j in 0..2 {
                    out[i][j] += e * tap[i][j];
                }
            }
        }
        out
    }

    /// The filter running on `reference` sampled at `t` \[s\] (module docs).
    pub fn runner(&self, reference: Reference, t: f64) -> FeedForwardRunner {
        let mut r = FeedForwardRunner {
            buffer: FirBuffer::new(self),
            preview: self.preview,
            lag: self.lag,
            reference,
            t,
            k: 0,
        };
        // The samples before the first step's newest one: q_d((p − u) T), u = len − 1, …, 1.
        for time in self.prime_times(t) {
            r.buffer.push(reference.sample(time).q);
        }
        r
    }

    /// The filter of the taps `taps` (F_n for n = −`preview`, …; at least one, and more than
    /// `preview`) whose feedback's reference is delayed by `lag` \[samples\], checked: finite
    /// taps, 0 ≤ lag, preview ≤ 64, at most 576 taps ([`FeedForwardParams::validate`]'s
    /// ranges). For a filter read back from a file.
    pub fn from_taps(preview: usize, taps: Vec<[[f64; 2]; 2]>, lag: f64) -> Result<FirFeedForward> {
        check("feedforward.preview", preview as f64, preview <= 64, "0–64")?;
        check(
            "feedforward.taps",
            taps.len() as f64,
            taps.len() > preview && taps.len() <= 576,
            &format!("{} to 576 taps (more than the preview)", preview + 1),
        )?;
        check("feedforward.lag", lag, lag >= 0.0, "≥ 0 samples")?;
        for (n, tap) in taps.iter().enumerate() {
            for v in tap.iter().flatten() {
                check(
                    &format!("feedforward.taps[{n}]"),
                    *v,
                    true,
                    "finite entries",
                )?;
            }
        }
        Ok(FirFeedForward {
            preview,
            taps,
            lag,
            reading: None,
        })
    }

    /// The times \[s\] at sample time `t` of the reference samples that fill the filter's
    /// buffer before the first sample, oldest first: (p − u) T for u = L − 1, …, 1 (L the
    /// number of taps). A controller pushes them ([`FirBuffer::push`]) before its first step.
    pub fn prime_times(&self, t: f64) -> impl Iterator<Item = f64> + use<> {
        let p = self.preview as f64;
        (1..self.taps.len()).rev().map(move |u| (p - u as f64) * t)
    }
}

/// [`FirFeedForward::fit_lifted`] on `lines` (frequency, G_p for p = 0..L−1) at sample time
/// `t`.
fn fit_phase_lines(
    lines: &[(f64, Vec<Response>)],
    t: f64,
    p: &FeedForwardParams,
) -> Result<FirFeedForward> {
    let len = p.preview + p.taps;
    check(
        "lifted response lines",
        lines.len() as f64,
        lines.len() >= 4 * len,
        &format!("≥ 4 (preview + taps) = {}", 4 * len),
    )?;
    let g0 = lines[0].1[0]
        .iter()
        .flatten()
        .map(|v| v.norm_sqr())
        .sum::<f64>();
    let no_lag = FeedForwardParams { lag: 0.0, ..*p };
    let points = lines
        .iter()
        .map(|(f, g)| (*f, &g[..], no_lag.target(*f, t)));
    let taps = fit_points(points, g0, t, p)?;
    Ok(FirFeedForward {
        preview: p.preview,
        taps,
        lag: p.lag,
        reading: None,
    })
}

/// The taps of the least-squares fit of the module docs over `points` (frequency, the L ≥ 1
/// phase responses G_p, the target D): per phase p the equation G_p F = D e^{j2πf pT/L}
/// (p = 0: D itself), each frequency weighted by 1/(1 + mean_p ‖G_p‖²/`g0`) (`g0`: ‖G_dc‖²).
fn fit_points<'a>(
    points: impl Iterator<Item = (f64, &'a [Response], Complex<f64>)>,
    g0: f64,
    t: f64,
    p: &FeedForwardParams,
) -> Result<Vec<[[f64; 2]; 2]>> {
    let mut normal = NormalEquations::new(p.preview, p.preview + p.taps);
    let norm2 = |g: &[[Complex<f64>; 2]; 2]| g.iter().flatten().map(|v| v.norm_sqr()).sum::<f64>();
    for (f, phases, d0) in points {
        let w = std::f64::consts::TAU * f * t;
        let l = phases.len();
        // The weight 1/(1 + ‖G‖²/‖G_dc‖²): the output error where the loop responds no
        // more than statically, the inverse's error across a resonance.
        let weight = if l == 1 {
            1.0 / (1.0 + norm2(&phases[0]) / g0)
        } else {
            1.0 / (1.0 + phases.iter().map(norm2).sum::<f64>() / (l as f64 * g0))
        };
        for (ph, g) in phases.iter().enumerate() {
            let d = if ph == 0 {
                d0
            } else {
                d0 * Complex::from_polar(1.0, w * ph as f64 / l as f64)
            };
            // Σ_o conj(G_oi) D δ_oj = conj(G_ji) D.
            normal.add(w, weight, g, |i, j| weight * g[j][i].conj() * d);
        }
    }
    normal.solve(
        p.regularization,
        "feed-forward",
        "the loop's response vanishes: set feedforward.regularization > 0",
    )
}

/// The taps C_n, n = −`preview`, …, `len` − `preview` − 1, minimizing
/// Σ_k w_k ‖G_k C(ω_k) − D_k‖² + λ ‖C‖² over `points` (f_k, G_k, D_k, w_k), a 2 × 2 FIR with
/// a 2 × 2 target (the least squares of the module docs with a matrix target and one phase),
/// λ = `regularization` × the normal matrix's mean diagonal.
fn fit_matrix_points(
    points: &[(f64, Response, Response, f64)],
    preview: usize,
    len: usize,
    regularization: f64,
    t: f64,
) -> Result<Vec<[[f64; 2]; 2]>> {
    let mut normal = NormalEquations::new(preview, len);
    for &(f, g, d, weight) in points {
        let w = std::f64::consts::TAU * f * t;
        normal.add(w, weight, &g, |i, j| {
            weight * (g[0][i].conj() * d[0][j] + g[1][i].conj() * d[1][j])
        });
    }
    normal.solve(
        regularization,
        "reading correction",
        "set feedforward.regularization > 0",
    )
}

/// The normal equations of a weighted least-squares fit of a 2 × 2 FIR of `len` taps X_n,
/// n = −`preview`, …, `len` − `preview` − 1, to equations G X(ω) ≈ D (the fits of
/// [`fit_points`] and [`fit_matrix_points`]). The normal matrix is block-Toeplitz in the tap
/// lags: c\[i\]\[i'\]\[d + len − 1\] = Σ Re(w conj(G_oi) G_oi' e^{jω d T}), d = n_u − n_v;
/// the right-hand sides b\[i\]\[j\]\[u\] = Σ Re(w conj(G_oi) D_oj e^{jω n_u T}).
struct NormalEquations {
    len: usize,
    n0: i64,
    c: [[Vec<f64>; 2]; 2],
    b: [[Vec<f64>; 2]; 2],
    /// e^{jω d T} for d = 1 − len, …, len − 1 at the equation being added.
    rot_lag: Vec<Complex<f64>>,
}

impl NormalEquations {
    /// Zero sums for `len` taps from n = −`preview`.
    fn new(preview: usize, len: usize) -> NormalEquations {
        let lags = 2 * len - 1;
        NormalEquations {
            len,
            n0: -(preview as i64),
            c: [
                [vec![0.0; lags], vec![0.0; lags]],
                [vec![0.0; lags], vec![0.0; lags]],
            ],
            b: [
                [vec![0.0; len], vec![0.0; len]],
                [vec![0.0; len], vec![0.0; len]],
            ],
            rot_lag: vec![Complex::new(0.0, 0.0); lags],
        }
    }

    /// Adds the equation G X(ω) ≈ D at ωT = `w` with weight `weight` (`g`: G; `gd(i, j)`:
    /// `weight` × Σ_o conj(G_oi) D_oj, the caller's form of it).
    fn add(
        &mut self,
        w: f64,
        weight: f64,
        g: &Response,
        gd: impl Fn(usize, usize) -> Complex<f64>,
    ) {
        let len = self.len;
        for (l, r) in self.rot_lag.iter_mut().enumerate() {
            *r = Complex::from_polar(1.0, w * (l as f64 - (len as f64 - 1.0)));
        }
        for i in 0..2 {
            for i2 in 0..2 {
                let gg = weight * (g[0][i].conj() * g[0][i2] + g[1][i].conj() * g[1][i2]);
                for (v, r) in self.c[i][i2].iter_mut().zip(&self.rot_lag) {
                    *v += (gg * r).re;
                }
            }
            for j in 0..2 {
                let gd = gd(i, j);
                for (u, v) in self.b[i][j].iter_mut().enumerate() {
                    let n = (self.n0 + u as i64) as f64;
                    *v += (gd * Complex::from_polar(1.0, w * n)).re;
                }
            }
        }
    }

    /// The taps X_n of the normal equations with λ = `regularization` × the normal matrix's
    /// mean diagonal added to its diagonal; the errors name the fit (`name`) and, for a
    /// singular normal matrix, the remedy (`hint`).
    fn solve(self, regularization: f64, name: &str, hint: &str) -> Result<Vec<[[f64; 2]; 2]>> {
        let (len, c, b) = (self.len, self.c, self.b);
        let mut a = DMatrix::<f64>::zeros(2 * len, 2 * len);
        for i in 0..2 {
            for i2 in 0..2 {
                for u in 0..len {
                    for v in 0..len {
                        a[(i * len + u, i2 * len + v)] = c[i][i2][u + len - 1 - v];
                    }
                }
            }
        }
        let lambda = regularization * a.trace() / (2 * len) as f64;
        for k in 0..2 * len {
            a[(k, k)] += lambda;
        }
        let chol = a.cholesky().ok_or_else(|| ControlError::Singular {
            what: format!("{name} normal matrix ({hint})"),
        })?;
        let mut taps = vec![[[0.0; 2]; 2]; len];
        for j in 0..2 {
            let rhs = DVector::from_iterator(2 * len, b[0][j].iter().chain(&b[1][j]).copied());
            let x = chol.solve(&rhs);
            for (u, tap) in taps.iter_mut().enumerate() {
                tap[0][j] = x[u];
                tap[1][j] = x[len + u];
            }
        }
        if taps.iter().flatten().flatten().any(|v| !v.is_finite()) {
            return Err(ControlError::Singular {
                what: format!("{name} fit"),
            });
        }
        Ok(taps)
    }
}

/// The running state of a [`FirFeedForward`]: its taps and the last L reference samples in a
/// ring buffer. [`FirBuffer::push`] stores the newest sample q_d((k + p) T),
/// [`FirBuffer::output`] is x_ff,k = Σ_u F_{u−p} q_d((k + p − u) T). The one implementation
/// of the filter's arithmetic: the simulated controllers, the runner and the target law
/// ([`crate::target::TargetController`], whose C form repeats it operation by operation) run
/// it. No allocation per sample.
#[derive(Debug, Clone, PartialEq)]
pub struct FirBuffer {
    taps: Vec<[[f64; 2]; 2]>,
    /// The reading correction's taps ([`FirFeedForward::reading`]).
    reading: Option<Vec<[[f64; 2]; 2]>>,
    /// q_d at (k + p − u) T in slot (head − u) mod L.
    buffer: Vec<[f64; 2]>,
    head: usize,
}

impl FirBuffer {
    /// The filter `ff` with an empty (zero) buffer.
    pub fn new(ff: &FirFeedForward) -> FirBuffer {
        FirBuffer {
            taps: ff.taps.clone(),
            reading: ff.reading.clone(),
            buffer: vec![[0.0; 2]; ff.taps.len()],
            head: 0,
        }
    }

    /// Stores `q` \[m\] as the newest sample.
    #[inline]
    pub fn push(&mut self, q: [f64; 2]) {
        self.head = (self.head + 1) % self.buffer.len();
        self.buffer[self.head] = q;
    }

    /// The filter's output x_ff \[m\] on the stored samples.
    #[inline]
    pub fn output(&self) -> [f64; 2] {
        self.apply(&self.taps)
    }

    /// Whether the feedback's reference carries a reading correction.
    #[inline]
    pub fn has_reading(&self) -> bool {
        self.reading.is_some()
    }

    /// The feedback's reference \[m\]: `delayed` (q_d((k − τ) T)) plus the reading
    /// correction Σ_u C_{u−p} q_d((k + p − u) T) on the stored samples; `delayed` itself
    /// without a correction.
    #[inline]
    pub fn reference(&self, delayed: [f64; 2]) -> [f64; 2] {
        match &self.reading {
            Some(c) => {
                let x = self.apply(c);
                [delayed[0] + x[0], delayed[1] + x[1]]
            }
            None => delayed,
        }
    }

    /// Σ_u taps_u q_d((k + p − u) T) on the stored samples.
    #[inline]
    fn apply(&self, taps: &[[[f64; 2]; 2]]) -> [f64; 2] {
        let len = self.buffer.len();
        let mut x = [0.0; 2];
        for (u, tap) in taps.iter().enumerate() {
            let q = self.buffer[(self.head + len - u) % len];
            x[0] += tap[0][0] * q[0] + tap[0][1] * q[1];
            x[1] += tap[1][0] * q[0] + tap[1][1] * q[1];
        }
        x
    }
}

/// A [`FirFeedForward`] running on a reference: at sample k it reads q_d at (k + p) T and
/// gives x_ff,k and the feedback's reference q_d((k − τ) T). No allocation per step.
#[derive(Debug, Clone)]
pub struct FeedForwardRunner {
    buffer: FirBuffer,
    preview: usize,
    lag: f64,
    reference: Reference,
    t: f64,
    k: u64,
}

impl FeedForwardRunner {
    /// The next sample: (x_ff,k \[m\], the feedback's reference q_d((k − τ)T) \[m\]).
    #[inline]
    pub fn step(&mut self) -> ([f64; 2], [f64; 2]) {
        let (ahead, feedback) = sample_times(self.k, self.preview, self.lag, self.t);
        self.buffer.push(self.reference.sample(ahead).q);
        let x = self.buffer.output();
        let feedback = self.buffer.reference(self.reference.sample(feedback).q);
        self.k += 1;
        (x, feedback)
    }

    /// The preview p \[samples\].
    pub fn preview(&self) -> usize {
        self.preview
    }
}

/// The times \[s\] at sample `k` (sample time `t`) of the reference the filter reads,
/// (k + p) T, and of the feedback's reference, (k − τ) T (preview p, lag τ \[samples\]).
#[inline]
pub fn sample_times(k: u64, preview: usize, lag: f64, t: f64) -> (f64, f64) {
    ((k + preview as u64) as f64 * t, (k as f64 - lag) * t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexstage_sim::trajectory::Shape;

    /// A 2 × 2 loop y = z^{−d} B(z⁻¹) x with FIR entries (minimum phase on the diagonal).
    struct FirLoop {
        delay: usize,
        b: [[Vec<f64>; 2]; 2],
    }

    impl LoopPlant for FirLoop {
        fn response(&self, f: f64) -> [[Complex<f64>; 2]; 2] {
            let w = std::f64::consts::TAU * f * 1e-4;
            let h = |c: &[f64]| {
                c.iter()
                    .enumerate()
                    .map(|(n, v)| Complex::from_polar(*v, -w * (n + self.delay) as f64))
                    .sum::<Complex<f64>>()
            };
            [
                [h(&self.b[0][0]), h(&self.b[0][1])],
                [h(&self.b[1][0]), h(&self.b[1][1])],
            ]
        }
        fn static_gain(&self) -> [[f64; 2]; 2] {
            let s = |c: &[f64]| c.iter().sum();
            [
                [s(&self.b[0][0]), s(&self.b[0][1])],
                [s(&self.b[1][0]), s(&self.b[1][1])],
            ]
        }
        fn modes(&self) -> Vec<(f64, f64)> {
            Vec::new()
        }
        fn sample_time(&self) -> f64 {
            1e-4
        }
    }

    fn exact(preview: usize, taps: usize) -> FeedForwardParams {
        FeedForwardParams {
            preview,
            taps,
            cutoff: f64::INFINITY,
            order: 1,
            lag: 0.0,
            regularization: 0.0,
            grid: 400,
            reading: false,
        }
    }

    /// Reference: a pure delay of p samples, G = z^{−p} I, has the inverse z^{p} I, a
    /// p-sample lead: the fit with p preview taps is that lead (F_{−p} = I, every other tap
    /// 0) to 1e-9, and running it on a reference gives q_d((k + p) T).
    #[test]
    fn preview_of_p_samples_is_a_p_sample_lead() {
        for p in [1, 3] {
            let plant = FirLoop {
                delay: p,
                b: [[vec![1.0], vec![0.0]], [vec![0.0], vec![1.0]]],
            };
            let ff = FirFeedForward::fit(&plant, &exact(p, 4)).unwrap();
            for (u, tap) in ff.taps().iter().enumerate() {
                let want = if u == 0 { 1.0 } else { 0.0 };
                for i in 0..2 {
                    for j in 0..2 {
                        let w = if i == j { want } else { 0.0 };
                        assert!((tap[i][j] - w).abs() < 1e-9, "p {p} tap {u}: {tap:?}");
                    }
                }
            }
            let r = Reference::new(Shape::Lissajous {
                ratio: 3.0,
                amplitude: [1e-6, 2e-6],
                frequency: 50.0,
            });
            let mut run = ff.runner(r, 1e-4);
            for k in 0..200 {
                let (x, fb) = run.step();
                let ahead = r.sample((k + p) as f64 * 1e-4).q;
                assert!((x[0] - ahead[0]).abs() < 1e-15 && (x[1] - ahead[1]).abs() < 1e-15);
                assert_eq!(fb, r.sample(k as f64 * 1e-4).q);
            }
        }
    }

    /// Reference: a coupled minimum-phase loop with one sample of delay,
    /// G = z⁻¹ [[1 − 0.5 z⁻¹, 0.2], [0.1, 0.8]] (det = 0.78 − 0.4 z⁻¹: its zero 0.513 inside
    /// the unit circle), whose inverse z · adj(B)/det(B) is an IIR filter with a decay of
    /// 0.513 per sample: 40 causal taps and one preview tap reproduce it, F G = I, to 1e-6
    /// over the whole band.
    #[test]
    fn the_fit_reproduces_a_known_inverse_in_band() {
        let plant = FirLoop {
            delay: 1,
            b: [[vec![1.0, -0.5], vec![0.2]], [vec![0.1], vec![0.8]]],
        };
        let ff = FirFeedForward::fit(&plant, &exact(1, 40)).unwrap();
        for f in [1.0, 97.0, 500.0, 1010.0, 2500.0, 4900.0] {
            let g = plant.response(f);
            let h = ff.response(f, 1e-4);
            for i in 0..2 {
                for j in 0..2 {
                    let gf = g[i][0] * h[0][j] + g[i][1] * h[1][j];
                    let want = if i == j { 1.0 } else { 0.0 };
                    assert!((gf - want).norm() < 1e-6, "{f} Hz ({i},{j}): {gf}");
                }
            }
        }
    }

    /// Reference: the static inverse with a lead is one tap G_dc⁻¹ at n = −ℓ; its response
    /// is G_dc⁻¹ e^{jωℓT}.
    #[test]
    fn static_lead_is_one_tap_ahead() {
        let inv = [[2.0, 0.1], [-0.3, 1.5]];
        let ff = FirFeedForward::static_lead(inv, 1);
        let h = ff.response(250.0, 1e-4);
        let e = Complex::from_polar(1.0, std::f64::consts::TAU * 250.0 * 1e-4);
        for i in 0..2 {
            for j in 0..2 {
                assert!((h[i][j] - e * inv[i][j]).norm() < 1e-14);
            }
        }
    }

    /// The fit as it was before the lifted fit shared its normal equations (verbatim but
    /// for the error handling): the reference the L = 1 fit must reproduce bit for bit.
    fn fit_before_lifting(plant: &dyn LoopPlant, p: &FeedForwardParams) -> Vec<[[f64; 2]; 2]> {
        let t = plant.sample_time();
        let len = p.preview + p.taps;
        let n0 = -(p.preview as i64);
        let nyquist = 0.5 / t;
        // Per frequency: the response and the target.
        let grid: Vec<(f64, Response, Complex<f64>)> = (0..p.grid)
            .map(|k| {
                let f = (k as f64 + 0.5) / p.grid as f64 * nyquist;
                (f, plant.response(f), p.target(f, t))
            })
            .collect();
        // Block-Toeplitz normal matrix: c[i][i'][d + len − 1] = Σ_k Σ_o Re(conj(G_oi) G_oi'
        // e^{jω d T}), d = n_u − n_v.
        let lags = 2 * len - 1;
        let mut c = [
            [vec![0.0; lags], vec![0.0; lags]],
            [vec![0.0; lags], vec![0.0; lags]],
        ];
        let mut b = [
            [vec![0.0; len], vec![0.0; len]],
            [vec![0.0; len], vec![0.0; len]],
        ];
        let norm2 =
            |g: &[[Complex<f64>; 2]; 2]| g.iter().flatten().map(|v| v.norm_sqr()).sum::<f64>();
        let g0 = plant.static_gain();
        let g0 = g0.iter().flatten().map(|v| v * v).sum::<f64>();
        for (f, g, d) in &grid {
            let w = std::f64::consts::TAU * f * t;
            // The weight 1/(1 + ‖G‖²/‖G_dc‖²): the output error where the loop responds no
            // more than statically, the inverse's error across a resonance.
            let weight = 1.0 / (1.0 + norm2(g) / g0);
            for i in 0..2 {
                for i2 in 0..2 {
                    let gg = weight * (g[0][i].conj() * g[0][i2] + g[1][i].conj() * g[1][i2]);
                    for (l, v) in c[i][i2].iter_mut().enumerate() {
                        let dl = l as f64 - (len as f64 - 1.0);
                        *v += (gg * Complex::from_polar(1.0, w * dl)).re;
                    }
                }
                // b[i][j][u] = Σ Re(conj(G_oi e^{−jω n_u T}) D δ_oj) = Re(conj(G_ji) D e^{jω n_u T}).
                for j in 0..2 {
                    let gd = weight * g[j][i].conj() * d;
                    for (u, v) in b[i][j].iter_mut().enumerate() {
                        let n = (n0 + u as i64) as f64;
                        *v += (gd * Complex::from_polar(1.0, w * n)).re;
                    }
                }
            }
        }
        let mut a = DMatrix::<f64>::zeros(2 * len, 2 * len);
        for i in 0..2 {
            for i2 in 0..2 {
                for u in 0..len {
                    for v in 0..len {
                        a[(i * len + u, i2 * len + v)] = c[i][i2][u + len - 1 - v];
                    }
                }
            }
        }
        let lambda = p.regularization * a.trace() / (2 * len) as f64;
        for k in 0..2 * len {
            a[(k, k)] += lambda;
        }
        let chol = a.cholesky().unwrap();
        let mut taps = vec![[[0.0; 2]; 2]; len];
        for j in 0..2 {
            let rhs = DVector::from_iterator(2 * len, b[0][j].iter().chain(&b[1][j]).copied());
            let x = chol.solve(&rhs);
            for (u, tap) in taps.iter_mut().enumerate() {
                tap[0][j] = x[u];
                tap[1][j] = x[len + u];
            }
        }
        taps
    }

    /// Reference: the fit before the lifted fit existed. Goal: with one phase (L = 1) the
    /// shared normal equations give today's taps bit for bit, on a coupled loop with the
    /// default target (low-pass, lag, regularization).
    #[test]
    fn one_phase_reproduces_the_fit_before_lifting_bitwise() {
        let plant = FirLoop {
            delay: 1,
            b: [
                [vec![1.0, -0.5, 0.1], vec![0.2]],
                [vec![0.1, 0.05], vec![0.8]],
            ],
        };
        for p in [
            FeedForwardParams {
                lag: 0.106,
                ..FeedForwardParams::default()
            },
            exact(1, 40),
        ] {
            let new = FirFeedForward::fit(&plant, &p).unwrap();
            let old = fit_before_lifting(&plant, &p);
            assert_eq!(new.taps().len(), old.len());
            for (a, b) in new.taps().iter().zip(&old) {
                for (x, y) in a.iter().flatten().zip(b.iter().flatten()) {
                    assert_eq!(x.to_bits(), y.to_bits());
                }
            }
        }
    }

    /// Reference: a sampled plant with a mode above Nyquist seen through the hold: baseband
    /// a = e^{−jωT} (one sample late) and the hold's image at f − f_s excites a mode at
    /// 9 kHz (5 % damping), b(f) = 0.5 ω_n²/(ω_n² − ω_b² + 2jζω_nω_b) e^{−jωT},
    /// ω_b = 2π(f − f_s); its lifted response over L = 4 phases is G_p = a e^{jωpT/L} +
    /// b e^{j(ω−ω_s)pT/L} (the other harmonics 0). The least error of the output over the
    /// phases is |b|/√(|a|² + |b|²) per frequency (the single-harmonic bound). Goal: the
    /// lifted fit (no low-pass, no regularization) reaches it to 1e-6 from 200 Hz up, and
    /// the sampled-only fit (L = 1, the reading followed) stays above it near the fold.
    #[test]
    fn the_lifted_fit_reaches_the_single_image_bound() {
        use flexstage_identify::measured::{from_harmonics, intersample_bound};
        let t = 1e-4;
        let l = 4;
        let zero = Complex::new(0.0, 0.0);
        let harmonics = |f: f64| {
            let w = std::f64::consts::TAU * f * t;
            let a = Complex::from_polar(1.0, -w);
            let wn = std::f64::consts::TAU * 9000.0;
            let wb = std::f64::consts::TAU * (f - 1.0 / t);
            let b = 0.5 * wn * wn / Complex::new(wn * wn - wb * wb, 2.0 * 0.05 * wn * wb) * a;
            let mut h = vec![[[zero; 2]; 2]; l];
            h[0] = [[a, zero], [zero, a]];
            h[l - 1] = [[b, zero], [zero, b]];
            h
        };
        let lines: Vec<(f64, Vec<Response>)> = (1..2000)
            .map(|k| {
                let f = 2.5 * k as f64;
                (f, from_harmonics(&harmonics(f), f, t))
            })
            .collect();
        // The optimum conj(a)/(|a|² + |b|²) is a lead of one sample times a zero-phase
        // (two-sided) filter decaying by e^{−ζω_n T} = 0.75 per sample: 64 preview taps.
        let p = exact(64, 200);
        let ff = fit_phase_lines(&lines, t, &p).unwrap();
        let one: Vec<(f64, Vec<Response>)> = lines.iter().map(|(f, g)| (*f, vec![g[0]])).collect();
        let sampled = fit_phase_lines(&one, t, &p).unwrap();
        let error = |ff: &FirFeedForward, f: f64| {
            let h = harmonics(f);
            let x = ff.response(f, t)[0][0];
            let e: f64 = h
                .iter()
                .enumerate()
                .map(|(m, hm)| (hm[0][0] * x - if m == 0 { 1.0 } else { 0.0 }).norm_sqr())
                .sum();
            e.sqrt()
        };
        // From 200 Hz: with the one image (its partner f_s + f left out) the optimum is not
        // even about 0 Hz, a kink there that taps approach as 1/n² (1.7e-6 at 50 Hz).
        for f in [200.0, 330.0, 700.0, 1000.0, 1300.0, 2500.0, 4500.0] {
            let bound = intersample_bound(&harmonics(f))[0];
            let got = error(&ff, f);
            assert!((got - bound).abs() < 1e-6, "{f} Hz: {got} vs bound {bound}");
        }
        let (at, bound) = (1000.0, intersample_bound(&harmonics(1000.0))[0]);
        assert!(error(&sampled, at) > 1.3 * bound, "{}", error(&sampled, at));
    }

    /// Lines 2.5 Hz apart up to Nyquist at 10 kHz of the phase-0 response `g0` and the
    /// sampled response `gm`.
    fn reading_lines(
        g0: impl Fn(f64) -> Response,
        gm: impl Fn(f64, &Response) -> Response,
    ) -> Vec<(f64, Response, Response)> {
        (1..2000)
            .map(|k| {
                let f = 2.5 * k as f64;
                let g = g0(f);
                (f, g, gm(f, &g))
            })
            .collect()
    }

    /// A coupled loop with one sample of delay and a 1 % damped mode at 842 Hz on axis 1,
    /// G_0 = z⁻¹ (A + M(f)), A = [[1, 0.2], [0.1, 0.8]].
    fn coupled_output(f: f64) -> Response {
        let w = std::f64::consts::TAU * f * 1e-4;
        let z1 = Complex::from_polar(1.0, -w);
        let wn = std::f64::consts::TAU * 842.0;
        let wb = std::f64::consts::TAU * f;
        let m = 0.3 * wn * wn / Complex::new(wn * wn - wb * wb, 2.0 * 0.01 * wn * wb);
        let c = |v: f64| Complex::new(v, 0.0);
        [[z1 * (c(1.0) + m), z1 * c(0.2)], [z1 * c(0.1), z1 * c(0.8)]]
    }

    /// Reference: the reading G_m = S(z) G_0 of a loop G_0 = z⁻¹ A (A constant, coupled)
    /// seen through a sensor S = diag(0.7 z⁻¹ + 0.3 z⁻², 0.1 + 0.9 z⁻¹) has the predicted
    /// reading G_m G_0⁻¹ = S; with a lag of τ = 1 sample the correction is
    /// C = S − z⁻¹ I: C_0 = diag(0, 0.1), C_1 = diag(−0.3, −0.1), C_2 = diag(0.3, 0), every
    /// other tap 0. Goal: the fit (no regularization) gives these taps to 1e-9.
    #[test]
    fn the_reading_correction_is_a_known_sensor_filter() {
        let a = [[1.0, 0.2], [0.1, 0.8]];
        let c = |v: f64| Complex::new(v, 0.0);
        let g0 = |f: f64| {
            let z1 = Complex::from_polar(1.0, -std::f64::consts::TAU * f * 1e-4);
            [0, 1].map(|i| [0, 1].map(|j| z1 * a[i][j]))
        };
        let gm = |f: f64, g: &Response| {
            let z1 = Complex::from_polar(1.0, -std::f64::consts::TAU * f * 1e-4);
            let s = [c(0.7) * z1 + c(0.3) * z1 * z1, c(0.1) + c(0.9) * z1];
            [0, 1].map(|i| [0, 1].map(|j| s[i] * g[i][j]))
        };
        let lines = reading_lines(g0, gm);
        let ff = FirFeedForward::from_taps(3, vec![[[0.0; 2]; 2]; 20], 1.0).unwrap();
        let ff = ff.fit_reading_lines(&lines, 1e-4, &exact(3, 17)).unwrap();
        let want = |n: i64| match n {
            0 => [[0.0, 0.0], [0.0, 0.1]],
            1 => [[-0.3, 0.0], [0.0, -0.1]],
            2 => [[0.3, 0.0], [0.0, 0.0]],
            _ => [[0.0; 2]; 2],
        };
        for (u, tap) in ff.reading().unwrap().iter().enumerate() {
            let w = want(u as i64 - 3);
            for i in 0..2 {
                for j in 0..2 {
                    assert!((tap[i][j] - w[i][j]).abs() < 1e-9, "tap {u}: {tap:?}");
                }
            }
        }
    }

    /// Goal: the correction's DC gain Σ_n C_n is 0 whatever the lines say (the sensor reads
    /// the output at DC): a reading 0.3 % above the output at every line (a calibration
    /// error the lines cannot tell from dynamics) would otherwise fit C ≈ 0.003 at DC,
    /// 24 nm of reference error on an 8 µm scan.
    #[test]
    fn the_reading_correction_has_no_dc_gain() {
        let gm = |_f: f64, g: &Response| [0, 1].map(|i| [0, 1].map(|j| g[i][j] * 1.003));
        let lines = reading_lines(coupled_output, gm);
        let ff = FirFeedForward::from_taps(3, vec![[[0.0; 2]; 2]; 20], 0.0).unwrap();
        let ff = ff.fit_reading_lines(&lines, 1e-4, &exact(3, 17)).unwrap();
        let c = ff.reading().unwrap();
        for i in 0..2 {
            for j in 0..2 {
                let dc: f64 = c.iter().map(|t| t[i][j]).sum();
                assert!(dc.abs() < 1e-15, "C_{i}{j}(1) = {dc}");
            }
        }
    }

    /// Goal: with an ideal sensor (the reading the output delayed by the lag,
    /// G_m = e^{−j2πfτT} G_0, on a coupled loop with a resonance) the correction is 0 and
    /// the feedback's reference is today's q_d((k − τ) T), bitwise.
    #[test]
    fn an_ideal_sensor_gives_the_delayed_reference_bitwise() {
        let lag = 0.106;
        let gm = |f: f64, g: &Response| {
            let e = Complex::from_polar(1.0, -std::f64::consts::TAU * f * lag * 1e-4);
            [0, 1].map(|i| [0, 1].map(|j| g[i][j] * e))
        };
        let lines = reading_lines(coupled_output, gm);
        let taps = (0..64)
            .map(|n| [[0.01 * n as f64, 0.002], [-0.001, 0.5]])
            .collect();
        let plain = FirFeedForward::from_taps(10, taps, lag).unwrap();
        let ff = plain
            .clone()
            .fit_reading_lines(&lines, 1e-4, &FeedForwardParams::default())
            .unwrap();
        assert!(
            ff.reading()
                .unwrap()
                .iter()
                .flatten()
                .flatten()
                .all(|v| *v == 0.0)
        );
        let r = Reference::new(Shape::Lissajous {
            ratio: 3.0,
            amplitude: [1e-6, 2e-6],
            frequency: 300.0,
        });
        let (mut a, mut b) = (plain.runner(r, 1e-4), ff.runner(r, 1e-4));
        for _ in 0..500 {
            let (x, y) = (a.step(), b.step());
            assert_eq!(x.0.map(f64::to_bits), y.0.map(f64::to_bits));
            assert_eq!(x.1.map(f64::to_bits), y.1.map(f64::to_bits));
        }
    }

    /// Reference: the coupled loop with its 842 Hz mode seen through a second-order sensor
    /// S(f) = 1/(1 − (f/f_s)² + j√2 f/f_s), f_s = 15 kHz, applied to the continuous output
    /// (G_m = S G_0 on the sampled band: the folded-mode effect left out), lag τ = 0.106.
    /// Goal: e^{−j2πfτT} + C matches S to 6e-3 over 10 Hz–2 kHz, the scan band (measured
    /// 0.8–4.8e-3: S is not periodic across Nyquist, and 64 taps leave that ripple), where
    /// the lag alone is 0.056 off at 2 kHz.
    #[test]
    fn the_reading_correction_matches_a_second_order_sensor_in_band() {
        let lag = 0.106;
        let s = |f: f64| {
            let x = f / 15e3;
            Complex::new(1.0, 0.0) / Complex::new(1.0 - x * x, std::f64::consts::SQRT_2 * x)
        };
        let gm = |f: f64, g: &Response| [0, 1].map(|i| [0, 1].map(|j| g[i][j] * s(f)));
        let lines = reading_lines(coupled_output, gm);
        let plain = FirFeedForward::from_taps(10, vec![[[0.0; 2]; 2]; 64], lag).unwrap();
        let ff = plain
            .fit_reading_lines(&lines, 1e-4, &exact(10, 54))
            .unwrap();
        let c = FirFeedForward::from_taps(10, ff.reading().unwrap().to_vec(), lag).unwrap();
        let mut worst: f64 = 0.0;
        for f in [10.0, 97.0, 322.0, 700.0, 842.0, 1000.0, 2000.0] {
            let h = c.response(f, 1e-4);
            let e = Complex::from_polar(1.0, -std::f64::consts::TAU * f * lag * 1e-4);
            for i in 0..2 {
                for j in 0..2 {
                    let want = if i == j { s(f) } else { Complex::new(0.0, 0.0) };
                    let got = h[i][j] + if i == j { e } else { Complex::new(0.0, 0.0) };
                    worst = worst.max((got - want).norm());
                }
            }
        }
        assert!(worst < 6e-3, "{worst}");
        // Without the correction (the lag alone) the reference is 10 × further off at 2 kHz.
        let plain = (s(2000.0)
            - Complex::from_polar(1.0, -std::f64::consts::TAU * 2000.0 * lag * 1e-4))
        .norm();
        assert!(plain > 10.0 * 3e-3, "{plain}");
    }

    /// Goal: bad settings are refused naming the field.
    #[test]
    fn bad_settings_name_the_field() {
        let p = FeedForwardParams {
            cutoff: 6000.0,
            ..FeedForwardParams::default()
        };
        let e = p.validate(1e-4).unwrap_err().to_string();
        assert!(e.contains("feedforward.cutoff"), "{e}");
        let p = FeedForwardParams {
            grid: 10,
            ..FeedForwardParams::default()
        };
        let e = p.validate(1e-4).unwrap_err().to_string();
        assert!(e.contains("feedforward.grid"), "{e}");
    }
}
