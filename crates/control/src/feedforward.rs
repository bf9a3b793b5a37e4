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

use std::sync::Arc;

use nalgebra::{Complex, DMatrix, DVector};

use flexstage_sim::modal::LoopPlant;
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
        FeedForward::Inverse(p) => {
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
            stage.shared("feedforward.inverse", || {
                FirFeedForward::fit(response, &FeedForwardParams { lag, ..p })
            })?
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
        }
    }

    /// Fits the inverse of `plant` (module docs).
    pub fn fit(plant: &dyn LoopPlant, p: &FeedForwardParams) -> Result<FirFeedForward> {
        let t = plant.sample_time();
        p.validate(t)?;
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
        let chol = a.cholesky().ok_or_else(|| ControlError::Singular {
            what: "feed-forward normal matrix (the loop's response vanishes: set feedforward.regularization > 0)".into(),
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
                what: "feed-forward fit".into(),
            });
        }
        Ok(FirFeedForward {
            preview: p.preview,
            taps,
            lag: p.lag,
        })
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
        Ok(FirFeedForward { preview, taps, lag })
    }

    /// The times \[s\] at sample time `t` of the reference samples that fill the filter's
    /// buffer before the first sample, oldest first: (p − u) T for u = L − 1, …, 1 (L the
    /// number of taps). A controller pushes them ([`FirBuffer::push`]) before its first step.
    pub fn prime_times(&self, t: f64) -> impl Iterator<Item = f64> + use<> {
        let p = self.preview as f64;
        (1..self.taps.len()).rev().map(move |u| (p - u as f64) * t)
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
    /// q_d at (k + p − u) T in slot (head − u) mod L.
    buffer: Vec<[f64; 2]>,
    head: usize,
}

impl FirBuffer {
    /// The filter `ff` with an empty (zero) buffer.
    pub fn new(ff: &FirFeedForward) -> FirBuffer {
        FirBuffer {
            taps: ff.taps.clone(),
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
        let len = self.buffer.len();
        let mut x = [0.0; 2];
        for (u, tap) in self.taps.iter().enumerate() {
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
        let feedback = self.reference.sample(feedback).q;
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
