//! The loop around a simulated stage, as on a rig: everything between the controller's
//! command and its next measurement except the mechanics. Each effect is a small part with
//! its own parameters, and the parts compose with any [`Mechanics`] (the lumped 8-state model
//! of [`crate::plant`] or the finite-element twin of `flexstage-twin`) into a
//! [`RigPlant`], which the experiment runner drives through [`StagePlant`].
//!
//! Per controller sample T (the command is held, ZOH), in this order:
//!
//! 1. **Delay** ([`RigParams::delay`], 0–2 samples): the command computed from the sample at
//!    t_k reaches the amplifiers at t_k + dT (computation and I/O time of a real-time target).
//! 2. **Amplifier** ([`AmplifierParams`]): a first-order small-signal response of bandwidth
//!    f_a, a voltage rate limited by the slew rate and by the output current,
//!    `|dU/dt| ≤ I_max/C_pea` (the PEA is a capacitor, `i = C dU/dt`), and the output range.
//! 3. **PEA** (Eq. 18, Table A1): the plant's own Bouc–Wen actuators ([`RigParams::hysteresis`],
//!    the truth, not the compensator's model), preloaded to the bias voltage, plus
//!    **creep** ([`CreepParams`]): the logarithmic law `Δx(t) = Δx(0.1 s)·(1 + γ lg(t/0.1 s))`
//!    realized as a sum of first-order relaxations, one per time decade.
//! 4. **Mechanics** ([`Mechanics`]): x_nom(t) (linear within a substep) and the **floor
//!    vibration** ([`FloorParams`], base acceleration) in, the output q out.
//! 5. **Sensor** ([`SensorParams`]): the analog chain from the true output to the sampler,
//!    a first-order low-pass (sensor electronics) and the ADC's anti-aliasing filter (2nd-order
//!    Butterworth), integrated exactly for an output linear within each substep
//!    ([`SensorParams::response`] is its transfer function); then white noise
//!    (`sensors.noise_std`, the level as sampled) plus 1/f noise above the corner where both
//!    spectra are equal, then quantization to the resolution (Section 4.1).
//!
//! Each sample is split into `substeps`; the amplifier, the mechanics and the sensor filter
//! advance per substep, the PEAs' Bouc–Wen state and the creep once per sample (exactly for
//! their inputs within it, and interpolated at the substeps). No allocation per sample.

use std::f64::consts::{FRAC_1_SQRT_2, TAU};

use flexstage_piezo::{BoucWen, BoucWenParams, GaussianNoise, MICROMETRE};
use nalgebra::Complex;

use crate::error::{Result, SimError, check, non_negative, positive};
use crate::experiment::Command;
use crate::pea::preload;

/// How the plant's actuators are driven.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlantActuator {
    /// Voltages through the amplifiers and the Bouc–Wen PEAs (the full plant).
    Hysteretic,
    /// The command's x_nom directly (no amplifier, no PEA: the linear plant of Eq. 36).
    Ideal,
    /// The command's x_nom through the amplifiers' first-order small-signal response
    /// ([`AmplifierParams::bandwidth`]; no slew, current or voltage limit) and no PEA: the
    /// linear plant of Eq. 36 with the amplifier the rig has.
    Amplified,
}

/// The high-voltage amplifier of one PEA.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AmplifierParams {
    /// Small-signal bandwidth f_a \[Hz\] of a first-order response; 0 = ideal (the voltage
    /// jumps at the start of the sample).
    pub bandwidth: f64,
    /// Slew-rate limit [V/s]; 0 = none.
    pub slew_rate: f64,
    /// Output current limit I_max \[A\]; 0 = none.
    pub current_limit: f64,
    /// PEA capacitance C_pea \[F\] (for `i = C dU/dt`), > 0 when a current limit is set.
    pub capacitance: f64,
}

impl AmplifierParams {
    /// An ideal amplifier (ZOH, no limits).
    pub fn ideal() -> Self {
        AmplifierParams {
            bandwidth: 0.0,
            slew_rate: 0.0,
            current_limit: 0.0,
            capacitance: 0.0,
        }
    }

    /// The largest |dU/dt| [V/s] (∞ without limits): min(slew rate, I_max/C).
    pub fn max_rate(&self) -> f64 {
        let mut r = f64::INFINITY;
        if self.slew_rate > 0.0 {
            r = r.min(self.slew_rate);
        }
        if self.current_limit > 0.0 && self.capacitance > 0.0 {
            r = r.min(self.current_limit / self.capacitance);
        }
        r
    }

    fn validate(&self) -> Result<()> {
        non_negative("rig.amplifier.bandwidth", self.bandwidth)?;
        non_negative("rig.amplifier.slew_rate", self.slew_rate)?;
        non_negative("rig.amplifier.current_limit", self.current_limit)?;
        non_negative("rig.amplifier.capacitance", self.capacitance)?;
        check(
            "rig.amplifier.capacitance",
            self.capacitance,
            self.current_limit == 0.0 || self.capacitance > 0.0,
            "> 0 [F] when a current limit is set",
        )
    }
}

/// The position sensors' dynamics and noise spectrum (white level and quantization come from
/// [`RigParams::noise_std`] and [`RigParams::resolution`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorParams {
    /// First-order bandwidth of the sensor electronics \[Hz\]; 0 = ideal.
    pub bandwidth: f64,
    /// 1/f corner \[Hz\]: below it the 1/f part dominates the white noise; 0 = white only.
    pub flicker_corner: f64,
    /// Corner f_aa \[Hz\] of the ADC's anti-aliasing filter, a 2nd-order Butterworth
    /// `ω_a²/(s² + √2 ω_a s + ω_a²)` after the sensor electronics; 0 = none.
    pub anti_alias: f64,
}

impl SensorParams {
    /// An ideal sensor (white noise only, no dynamics).
    pub fn ideal() -> Self {
        SensorParams {
            bandwidth: 0.0,
            flicker_corner: 0.0,
            anti_alias: 0.0,
        }
    }

    /// Whether the sensor has dynamics (a bandwidth or an anti-aliasing filter).
    pub fn is_filtered(&self) -> bool {
        self.bandwidth > 0.0 || self.anti_alias > 0.0
    }

    /// The poles \[rad/s\] of the chain's transfer function
    /// `H(s) = ω_s/(s + ω_s) · ω_a²/(s² + √2 ω_a s + ω_a²)` (factors absent when their
    /// frequency is 0): −ω_s and ω_a(−1 ± j)/√2. H has no zeros and H(0) = 1, so
    /// `H(s) = Π(−p)/Π(s − p)`.
    pub fn poles(&self) -> Vec<Complex<f64>> {
        let mut p = Vec::with_capacity(3);
        if self.bandwidth > 0.0 {
            p.push(Complex::new(-TAU * self.bandwidth, 0.0));
        }
        if self.anti_alias > 0.0 {
            let w = TAU * self.anti_alias * FRAC_1_SQRT_2;
            p.push(Complex::new(-w, w));
            p.push(Complex::new(-w, -w));
        }
        p
    }

    /// The chain's frequency response H(j2πf) (1 for an ideal sensor).
    pub fn response(&self, f: f64) -> Complex<f64> {
        let s = Complex::new(0.0, TAU * f);
        self.poles()
            .iter()
            .fold(Complex::new(1.0, 0.0), |h, &p| h * (-p) / (s - p))
    }

    /// The chain as a state space `ẋ = A x + B q`, `y = C x` (n ≤ 3 states: the
    /// electronics' output, then the filter's output and its rate), row-major.
    fn state_space(&self) -> (usize, [[f64; 3]; 3], [f64; 3], [f64; 3]) {
        let (mut a, mut b, mut c) = ([[0.0; 3]; 3], [0.0; 3], [0.0; 3]);
        let mut n = 0;
        if self.bandwidth > 0.0 {
            let w = TAU * self.bandwidth;
            a[0][0] = -w;
            b[0] = w;
            n = 1;
        }
        if self.anti_alias > 0.0 {
            let w = TAU * self.anti_alias;
            let (i, j) = (n, n + 1);
            a[i][j] = 1.0;
            a[j][i] = -w * w;
            a[j][j] = -std::f64::consts::SQRT_2 * w;
            if n == 1 {
                a[j][0] = w * w;
            } else {
                b[j] = w * w;
            }
            n += 2;
        }
        if n > 0 {
            c[if self.anti_alias > 0.0 { n - 2 } else { 0 }] = 1.0;
        }
        (n, a, b, c)
    }

    fn validate(&self) -> Result<()> {
        non_negative("rig.sensor.bandwidth", self.bandwidth)?;
        non_negative("rig.sensor.flicker_corner", self.flicker_corner)?;
        non_negative("rig.sensor.anti_alias", self.anti_alias)
    }
}

/// The sensor chain of [`SensorParams`] discretized exactly over one substep h for an input
/// that follows the parabola through the output at the previous node, the start and the end
/// of the substep, `q(s) = q₀ + v s + a s²/2` with `v = (q₁ − q₋₁)/(2h)` and
/// `a = (q₁ − 2q₀ + q₋₁)/h²` (Van Loan: `exp(M h)` of `M = [[A, B, 0, 0], [0, 0, 1, 0],
/// [0, 0, 0, 1], [0, 0, 0, 0]]` gives Φ and the responses Γ_q, Γ_v, Γ_a to q₀, v, a):
/// `x₊ = Φ x + Γ_q q₀ + Γ_v v + Γ_a a`. The interpolation error is O(h³) (a linear input
/// was O(h²): with 20 substeps it misplaced the stage's aliased 9 kHz content by ≈ 0.6 %,
/// 1.2° of loop phase at 700 Hz, DECISIONS.md). No allocation per step.
#[derive(Debug, Clone, Copy, PartialEq)]
struct SensorChain {
    n: usize,
    phi: [[f64; 3]; 3],
    g0: [f64; 3],
    /// Γ_v/(2h): per unit (q₁ − q₋₁).
    g1: [f64; 3],
    /// Γ_a/h²: per unit (q₁ − 2q₀ + q₋₁).
    g2: [f64; 3],
    c: [f64; 3],
    /// Per axis, the chain's state.
    x: [[f64; 3]; 2],
    /// The output at the node before the current substep.
    prev: [f64; 2],
}

impl SensorChain {
    fn new(p: &SensorParams, h: f64) -> Result<SensorChain> {
        let (n, a, b, c) = p.state_space();
        let mut chain = SensorChain {
            n,
            phi: [[0.0; 3]; 3],
            g0: [0.0; 3],
            g1: [0.0; 3],
            g2: [0.0; 3],
            c,
            x: [[0.0; 3]; 2],
            prev: [0.0; 2],
        };
        if n == 0 {
            return Ok(chain);
        }
        let mut m = nalgebra::DMatrix::zeros(n + 3, n + 3);
        for i in 0..n {
            for j in 0..n {
                m[(i, j)] = a[i][j] * h;
            }
            m[(i, n)] = b[i] * h;
        }
        m[(n, n + 1)] = h;
        m[(n + 1, n + 2)] = h;
        let e = crate::linalg::expm(&m)?;
        for i in 0..n {
            for j in 0..n {
                chain.phi[i][j] = e[(i, j)];
            }
            chain.g0[i] = e[(i, n)];
            chain.g1[i] = e[(i, n + 1)] / (2.0 * h);
            chain.g2[i] = e[(i, n + 2)] / (h * h);
        }
        Ok(chain)
    }

    /// Both axes at rest at the output `q`: every filter output at q, the filter's rate
    /// (the last state when the anti-aliasing filter is on) at 0.
    fn rest(&mut self, q: [f64; 2], anti_alias: bool) {
        let levels = if anti_alias { self.n - 1 } else { self.n };
        self.prev = q;
        for (x, qi) in self.x.iter_mut().zip(q) {
            *x = [0.0; 3];
            x[..levels].iter_mut().for_each(|v| *v = qi);
        }
    }

    /// One substep with the output moving from `q0` to `q1` (after `self.prev`).
    #[inline]
    fn step(&mut self, q0: [f64; 2], q1: [f64; 2]) {
        let n = self.n;
        for (ax, x) in self.x.iter_mut().enumerate() {
            let (p, a, b) = (self.prev[ax], q0[ax], q1[ax]);
            let (d1, d2) = (b - p, b - 2.0 * a + p);
            let mut y = [0.0; 3];
            for i in 0..n {
                let mut v = self.g0[i] * a + self.g1[i] * d1 + self.g2[i] * d2;
                for j in 0..n {
                    v += self.phi[i][j] * x[j];
                }
                y[i] = v;
            }
            *x = y;
        }
        self.prev = q0;
    }

    /// The sensed outputs.
    #[inline]
    fn output(&self) -> [f64; 2] {
        self.x.map(|x| (0..self.n).map(|k| self.c[k] * x[k]).sum())
    }
}

/// Logarithmic creep of the PEAs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CreepParams {
    /// Creep factor γ per time decade (PI: 0.01–0.02); 0 = off.
    pub factor: f64,
}

/// Floor vibration as a base acceleration: one sine per 1/3-octave band between
/// `bands[0]` and `bands[1]`, each with RMS velocity `velocity_rms` (the flat part of the
/// VC vibration criteria), random phases, both in-plane directions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FloorParams {
    /// RMS velocity per 1/3-octave band [m/s]; 0 = off. VC-C: 12.5e-6.
    pub velocity_rms: f64,
    /// Lowest and highest band centre \[Hz\].
    pub bands: [f64; 2],
}

/// Everything around the mechanics (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct RigParams {
    /// Computation + I/O delay in samples, 0–2.
    pub delay: usize,
    /// Actuator mode.
    pub actuator: PlantActuator,
    /// The amplifiers.
    pub amplifier: AmplifierParams,
    /// The plant's own Bouc–Wen PEAs (µm, V, s).
    pub hysteresis: [BoucWenParams; 2],
    /// Creep.
    pub creep: CreepParams,
    /// Amplifier output range \[V\].
    pub voltage_range: [f64; 2],
    /// Preload bias voltage \[V\].
    pub bias_voltage: f64,
    /// Floor vibration.
    pub floor: FloorParams,
    /// Sensor dynamics and spectrum.
    pub sensor: SensorParams,
    /// Quantization steps \[m\] (0: none).
    pub resolution: [f64; 2],
    /// White-noise standard deviations \[m\].
    pub noise_std: [f64; 2],
    /// Noise seed.
    pub seed: u64,
    /// Controller sample time T \[s\].
    pub sample_time: f64,
    /// Substeps per sample, ≥ 1.
    pub substeps: usize,
}

impl RigParams {
    /// The rig of a scenario: `[rig]` for the loop effects and the plant's PEAs, the amplifier
    /// range of `[hysteresis]` with the bias in its middle, `[sensors]` for the white noise and
    /// resolution, `[simulation]` for the timing and the seed.
    pub fn from_scenario(s: &flexstage_scenario::Scenario) -> RigParams {
        let r = &s.rig;
        let h = &s.hysteresis;
        RigParams {
            delay: r.delay,
            actuator: PlantActuator::Hysteretic,
            amplifier: AmplifierParams {
                bandwidth: r.amplifier.bandwidth,
                slew_rate: r.amplifier.slew_rate,
                current_limit: r.amplifier.current_limit,
                capacitance: r.amplifier.capacitance,
            },
            hysteresis: [BoucWenParams::from(&r.pea1), BoucWenParams::from(&r.pea2)],
            creep: CreepParams {
                factor: r.creep.factor,
            },
            voltage_range: [h.voltage_min, h.voltage_max],
            bias_voltage: 0.5 * (h.voltage_min + h.voltage_max),
            floor: FloorParams {
                velocity_rms: r.floor.velocity_rms,
                bands: r.floor.bands,
            },
            sensor: SensorParams {
                bandwidth: r.sensor.bandwidth,
                flicker_corner: r.sensor.flicker_corner,
                anti_alias: r.sensor.anti_alias,
            },
            resolution: s.sensors.resolution,
            noise_std: s.sensors.noise_std,
            seed: s.simulation.seed,
            sample_time: s.simulation.sample_time,
            substeps: s.simulation.substeps,
        }
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        check(
            "rig.delay",
            self.delay as f64,
            self.delay <= 2,
            "0, 1 or 2 samples",
        )?;
        self.amplifier.validate()?;
        for (i, p) in self.hysteresis.iter().enumerate() {
            p.validate().map_err(|e| {
                SimError::from(flexstage_numerics::RangeError::new(
                    format!("rig.pea{}", i + 1),
                    e.to_string(),
                    "valid Bouc–Wen parameters",
                ))
            })?;
        }
        check(
            "rig.creep.factor",
            self.creep.factor,
            (0.0..=0.1).contains(&self.creep.factor),
            "a number in [0, 0.1] per decade",
        )?;
        let [lo, hi] = self.voltage_range;
        check("hysteresis.voltage_max", hi, hi > lo, "> voltage_min [V]")?;
        check(
            "bias_voltage",
            self.bias_voltage,
            self.bias_voltage > lo && self.bias_voltage < hi,
            "inside the amplifier range [V]",
        )?;
        non_negative("rig.floor.velocity_rms", self.floor.velocity_rms)?;
        check(
            "rig.floor.bands",
            self.floor.bands[1],
            self.floor.bands[0] > 0.0 && self.floor.bands[1] >= self.floor.bands[0],
            "0 < bands[0] ≤ bands[1] [Hz]",
        )?;
        self.sensor.validate()?;
        for i in 0..2 {
            non_negative(&format!("sensors.resolution[{i}]"), self.resolution[i])?;
            non_negative(&format!("sensors.noise_std[{i}]"), self.noise_std[i])?;
        }
        positive("simulation.sample_time", self.sample_time)?;
        check(
            "simulation.substeps",
            self.substeps as f64,
            (1..=10_000).contains(&self.substeps),
            "an integer in [1, 10000]",
        )
    }

    /// The substep h = T / substeps \[s\].
    pub fn substep(&self) -> f64 {
        self.sample_time / self.substeps as f64
    }
}

/// The stage mechanics between the PEAs and the sensors. Advanced in fixed substeps of
/// [`Mechanics::substep_time`] with x_nom and the base acceleration varying linearly within
/// the substep. No allocation.
pub trait Mechanics: Send {
    /// The substep h \[s\] the model was discretized for.
    fn substep_time(&self) -> f64;
    /// Advances by h; `x_nom[0]` and `x_nom[1]` are the nominal PEA displacements \[m\] at the
    /// start and the end of the substep, `floor[0..2]` the base accelerations [m/s²] (x, y).
    fn advance(&mut self, x_nom: [[f64; 2]; 2], floor: [[f64; 2]; 2]);
    /// The true output q \[m\] (relative to the base).
    fn output(&self) -> [f64; 2];
    /// The input-plate displacements x_in \[m\].
    fn inputs(&self) -> [f64; 2];

    /// Advances one sample of `n = path.len() − 1` substeps: x_nom at the substep nodes
    /// `path`, the base acceleration linear from `floor[0]` to `floor[1]` over the sample;
    /// the output after substep k into `q[k]` when `q` is given (length ≥ n). The provided
    /// method calls [`Mechanics::advance`] per substep; a mechanics may override it with one
    /// loop that gives the same result.
    fn advance_sample(
        &mut self,
        path: &[[f64; 2]],
        floor: [[f64; 2]; 2],
        mut q: Option<&mut [[f64; 2]]>,
    ) {
        let n = path.len() - 1;
        for k in 0..n {
            self.advance([path[k], path[k + 1]], floor_at(floor, k, n));
            if let Some(q) = q.as_deref_mut() {
                q[k] = self.output();
            }
        }
    }
}

/// The base acceleration at the start and the end of substep `k` of `n`, linear from
/// `floor[0]` to `floor[1]` over the sample (every mechanics interpolates it alike).
#[inline]
pub fn floor_at(floor: [[f64; 2]; 2], k: usize, n: usize) -> [[f64; 2]; 2] {
    let [f0, f1] = floor;
    let (s0, s1) = (k as f64 / n as f64, (k + 1) as f64 / n as f64);
    [
        [f0[0] + s0 * (f1[0] - f0[0]), f0[1] + s0 * (f1[1] - f0[1])],
        [f0[0] + s1 * (f1[0] - f0[0]), f0[1] + s1 * (f1[1] - f0[1])],
    ]
}

/// A simulated stage as the experiment runner sees it: sensors sampled at t_k, a command
/// held until t_{k+1}.
pub trait StagePlant: Send {
    /// Samples the sensors at the current time.
    fn measure(&mut self) -> [f64; 2];
    /// The true output q \[m\].
    fn output(&self) -> [f64; 2];
    /// Advances one sample with the command (after the rig's delay).
    fn apply(&mut self, cmd: &Command);
    /// The voltages the amplifiers currently deliver \[V\].
    fn voltage(&self) -> [f64; 2];
    /// The PEAs' current nominal displacement x_nom \[m\] (creep included).
    fn x_nom(&self) -> [f64; 2];
}

/// Creep time constants [s]: one relaxation per decade from 0.1 s (PI's reference time).
const CREEP_TAU: [f64; 4] = [0.1, 1.0, 10.0, 100.0];

/// 1/f noise: a sum of Ornstein–Uhlenbeck processes with corner frequencies two per decade
/// from 0.01 Hz to ten times the 1/f corner and equal variances; their Lorentzian spectra add
/// up to `S(f) ≈ v/(f ln r)` (r the corner ratio), matched to the white level at the corner.
///
/// Multi-rate: process k is advanced exactly (`x ← a x + b z`, the OU transition over its
/// own step) only every `stride_k` samples, the largest power of two with
/// `f_k·stride_k·T ≤ 1/64`, and held in between. Holding a process whose corner lies that far
/// below its update rate changes its spectrum by < 0.1 % below the corner and adds images of
/// relative level ≈ (f_k·stride_k·T)² ≈ 2e-4 near multiples of the update rate, where the white
/// noise dominates by orders of magnitude; it draws ≈ 0.2 normal numbers per sample instead of
/// one per process.
#[derive(Debug, Clone)]
struct Flicker {
    x: [f64; Flicker::N],
    a: [f64; Flicker::N],
    b: [f64; Flicker::N],
    /// Update stride of each process in samples (a power of two) minus one: the process is
    /// updated when `count & mask == 0`.
    mask: [u32; Flicker::N],
    /// Σ x (of the held values).
    sum: f64,
    /// Samples drawn so far (mod the largest stride).
    count: u32,
    n: usize,
    noise: GaussianNoise,
}

impl Flicker {
    const N: usize = 16;
    /// Largest update stride \[samples\].
    const MAX_STRIDE: u32 = 1 << 12;

    /// `white_std` [m] over the Nyquist band of sample time `t`, corner `fc` [Hz].
    fn new(white_std: f64, fc: f64, t: f64, seed: u64) -> Flicker {
        let mut f = Flicker {
            x: [0.0; Flicker::N],
            a: [0.0; Flicker::N],
            b: [0.0; Flicker::N],
            mask: [0; Flicker::N],
            sum: 0.0,
            count: 0,
            n: 0,
            noise: GaussianNoise::new(1.0, seed),
        };
        if fc <= 0.0 || white_std <= 0.0 {
            return f;
        }
        let ratio = 10f64.sqrt();
        let s_white = white_std * white_std / (0.5 / t); // one-sided PSD [m²/Hz]
        let v = s_white * fc * ratio.ln();
        let mut corner = 0.01;
        while f.n < Flicker::N && corner <= (10.0 * fc).min(0.25 / t) {
            let mut stride = 1;
            while stride < Flicker::MAX_STRIDE && corner * (2 * stride) as f64 * t <= 1.0 / 64.0 {
                stride *= 2;
            }
            let lambda = std::f64::consts::TAU * corner;
            let a = (-lambda * stride as f64 * t).exp();
            f.a[f.n] = a;
            f.b[f.n] = (v * (1.0 - a * a)).sqrt();
            f.mask[f.n] = stride - 1;
            f.x[f.n] = v.sqrt() * f.noise.sample();
            f.sum += f.x[f.n];
            f.n += 1;
            corner *= ratio;
        }
        f
    }

    #[inline]
    fn sample(&mut self) -> f64 {
        if self.n == 0 {
            return 0.0;
        }
        let mut changed = false;
        for k in 0..self.n {
            if self.count & self.mask[k] == 0 {
                self.x[k] = self.a[k] * self.x[k] + self.b[k] * self.noise.sample();
                changed = true;
            }
        }
        if changed {
            self.sum = self.x[..self.n].iter().sum();
        }
        self.count = (self.count + 1) & (Flicker::MAX_STRIDE - 1);
        self.sum
    }
}

/// Floor acceleration: 1/3-octave sines as rotating phasors (one complex multiply per band
/// and sample).
#[derive(Debug, Clone)]
struct Floor {
    /// Per band and axis: amplitude·(cos, sin) of the current phase.
    phasor: [[[f64; 2]; 2]; Floor::N],
    /// Per band: (cos, sin) of ωT.
    rot: [[f64; 2]; Floor::N],
    n: usize,
}

impl Floor {
    const N: usize = 16;

    fn new(p: &FloorParams, t: f64, seed: u64) -> Floor {
        let mut f = Floor {
            phasor: [[[0.0; 2]; 2]; Floor::N],
            rot: [[1.0, 0.0]; Floor::N],
            n: 0,
        };
        if p.velocity_rms <= 0.0 {
            return f;
        }
        let mut noise = GaussianNoise::new(1.0, seed);
        let mut band = 0i32;
        loop {
            // Preferred 1/3-octave centres: 10^(k/10) Hz (1000 Hz · 10^(k/10)…), from bands[0].
            let fc = p.bands[0] * 10f64.powf(band as f64 / 10.0);
            if fc > p.bands[1] * (1.0 + 1e-9) || f.n == Floor::N {
                break;
            }
            let w = std::f64::consts::TAU * fc;
            let amp = std::f64::consts::SQRT_2 * p.velocity_rms * w; // acceleration amplitude
            for axis in 0..2 {
                // Uniform on (−π, π]: the angle of an isotropic Gaussian pair.
                let phase = noise.sample().atan2(noise.sample());
                f.phasor[f.n][axis] = [amp * phase.cos(), amp * phase.sin()];
            }
            f.rot[f.n] = [(w * t).cos(), (w * t).sin()];
            f.n += 1;
            band += 1;
        }
        f
    }

    /// The acceleration now [m/s²] (x, y).
    #[inline]
    fn value(&self) -> [f64; 2] {
        let mut a = [0.0; 2];
        for k in 0..self.n {
            a[0] += self.phasor[k][0][0];
            a[1] += self.phasor[k][1][0];
        }
        a
    }

    /// Advances by one sample.
    #[inline]
    fn advance(&mut self) {
        for k in 0..self.n {
            let [c, s] = self.rot[k];
            for axis in 0..2 {
                let [re, im] = self.phasor[k][axis];
                self.phasor[k][axis] = [re * c - im * s, re * s + im * c];
            }
        }
    }
}

/// The rig's state: delay line, amplifiers, PEAs with creep, floor and sensors.
#[derive(Debug, Clone)]
struct Rig {
    params: RigParams,
    /// Pending commands (voltages, x_nom), oldest first; `pending[delay]` is the newest.
    pending: [([f64; 2], [f64; 2]); 3],
    voltage: [f64; 2],
    pea: [BoucWen; 2],
    x_bias: [f64; 2],
    creep: [[f64; CREEP_TAU.len()]; 2],
    /// Per creep relaxation over one sample: e = exp(−T/τ).
    creep_decay: [f64; CREEP_TAU.len()],
    /// Per creep relaxation: the response to a unit ramp over one sample, 1 − (1 − e)τ/T.
    creep_ramp: [f64; CREEP_TAU.len()],
    x_nom: [f64; 2],
    floor: Floor,
    /// The sensor chain (electronics and anti-aliasing filter).
    sensor: SensorChain,
    white: [GaussianNoise; 2],
    flicker: [Flicker; 2],
    amp_decay: f64,
    /// `amp_decay^k`, k = 0..=substeps.
    amp_powers: Vec<f64>,
    /// The amplifier's largest |dU/dt| [V/s] ([`AmplifierParams::max_rate`]).
    amp_rate: f64,
    /// Whether the amplifier ramps within a substep (bandwidth or rate limit set).
    amp_ramps: bool,
    /// x_nom at the substep boundaries of the current sample (preallocated).
    path: Vec<[f64; 2]>,
    /// The amplifier voltage at the substep boundaries (preallocated).
    u_path: Vec<f64>,
    /// The true output after every substep (preallocated).
    q_path: Vec<[f64; 2]>,
    /// The sensor chain's analog output after every substep (empty unless recorded:
    /// [`RigPlant::record_substeps`]).
    s_path: Vec<[f64; 2]>,
}

impl Rig {
    fn new(params: RigParams) -> Result<Rig> {
        params.validate()?;
        let h = params.substep();
        let mut pea = [
            BoucWen::new(params.hysteresis[0]),
            BoucWen::new(params.hysteresis[1]),
        ];
        let mut x_bias = [0.0; 2];
        for i in 0..2 {
            let (u, hh, x) = preload(&params.hysteresis[i], params.bias_voltage);
            pea[i].set_state(u, hh);
            x_bias[i] = x;
        }
        let s = params.seed;
        let white = [
            GaussianNoise::new(params.noise_std[0], s.wrapping_mul(2).wrapping_add(1)),
            GaussianNoise::new(params.noise_std[1], s.wrapping_mul(2).wrapping_add(2)),
        ];
        let fc = params.sensor.flicker_corner;
        let t = params.sample_time;
        let flicker = [
            Flicker::new(
                params.noise_std[0],
                fc,
                t,
                s.wrapping_mul(11).wrapping_add(5),
            ),
            Flicker::new(
                params.noise_std[1],
                fc,
                t,
                s.wrapping_mul(11).wrapping_add(6),
            ),
        ];
        let floor = Floor::new(&params.floor, t, s.wrapping_mul(13).wrapping_add(7));
        let amp_decay = if params.amplifier.bandwidth > 0.0 {
            (-std::f64::consts::TAU * params.amplifier.bandwidth * h).exp()
        } else {
            0.0
        };
        let sensor = SensorChain::new(&params.sensor, h)?;
        let bias = params.bias_voltage;
        Ok(Rig {
            pending: [([bias; 2], [0.0; 2]); 3],
            voltage: [bias; 2],
            pea,
            x_bias,
            creep: [[0.0; CREEP_TAU.len()]; 2],
            creep_decay: CREEP_TAU.map(|tau| (-t / tau).exp()),
            creep_ramp: CREEP_TAU.map(|tau| 1.0 + (-t / tau).exp_m1() * tau / t),
            x_nom: [0.0; 2],
            floor,
            sensor,
            white,
            flicker,
            amp_decay,
            amp_powers: (0..=params.substeps as i32)
                .map(|k| amp_decay.powi(k))
                .collect(),
            amp_rate: params.amplifier.max_rate(),
            amp_ramps: params.amplifier.bandwidth > 0.0 || params.amplifier.max_rate().is_finite(),
            path: vec![[0.0; 2]; params.substeps + 1],
            u_path: vec![0.0; params.substeps + 1],
            q_path: vec![[0.0; 2]; params.substeps],
            s_path: Vec::new(),
            params,
        })
    }

    /// The command that acts during this sample (after the delay).
    fn take(&mut self, cmd: &Command) -> ([f64; 2], [f64; 2]) {
        let d = self.params.delay;
        self.pending[d] = (cmd.voltage, cmd.x_nom);
        let now = self.pending[0];
        for k in 0..d {
            self.pending[k] = self.pending[k + 1];
        }
        now
    }

    /// Creep over one sample with the PEA displacement deviation moving linearly from `dx0` to
    /// `dx1` \[m\]: every relaxation `ż = (dx − z)/τ` advanced exactly,
    /// `z₊ = e z + (1 − e) dx0 + (dx1 − dx0)(1 − (1 − e)τ/T)`, `e = exp(−T/τ)`. Returns the
    /// creep `γ Σ z` at the start and the end of the sample.
    #[inline]
    fn creep(&mut self, i: usize, dx0: f64, dx1: f64) -> (f64, f64) {
        let g = self.params.creep.factor;
        if g == 0.0 {
            return (0.0, 0.0);
        }
        let (mut c0, mut c1) = (0.0, 0.0);
        for (k, z) in self.creep[i].iter_mut().enumerate() {
            let e = self.creep_decay[k];
            c0 += *z;
            *z = e * *z + (1.0 - e) * dx0 + (dx1 - dx0) * self.creep_ramp[k];
            c1 += *z;
        }
        (g * c0, g * c1)
    }

    /// The actuators over one sample: x_nom at every substep boundary into `self.path`
    /// (`path[0]` = now). The amplifier's voltage is followed substep by substep (first-order
    /// response `U₊ = U_f + (U − U_f)e^{−2πf_a h}`, then the rate limit, then the range);
    /// within a sample it moves monotonically towards its target, and the rate-independent
    /// part of Bouc–Wen depends only on the voltage path, not its timing, so one exact
    /// Bouc–Wen step over the sample gives the end state and x_nom in between is interpolated
    /// in U along the branch (error ≈ h''(U)·ΔU²/8: picometres for the voltage steps of a
    /// sample). The creep (time constants ≥ 0.1 s ≫ T) is advanced once per sample
    /// ([`Rig::creep`]) and interpolated linearly in time within it. An ideal amplifier jumps
    /// at the start of the sample.
    fn actuate(&mut self, target: ([f64; 2], [f64; 2]), h: f64) {
        let n = self.params.substeps;
        if self.params.actuator == PlantActuator::Amplified && self.amp_decay > 0.0 {
            // x_nom follows the target as the amplifier's voltage does (first order).
            for i in 0..2 {
                let (goal, gap) = (target.1[i], self.x_nom[i] - target.1[i]);
                self.path[0][i] = self.x_nom[i];
                for k in 1..=n {
                    self.path[k][i] = goal + gap * self.amp_powers[k];
                }
                self.x_nom[i] = self.path[n][i];
            }
            return;
        }
        if self.params.actuator != PlantActuator::Hysteretic {
            self.x_nom = target.1;
            self.path.iter_mut().for_each(|p| *p = target.1);
            return;
        }
        let t = self.params.sample_time;
        let [lo, hi] = self.params.voltage_range;
        let jump = !self.amp_ramps;
        let max_step = self.amp_rate * h;
        let x_start = self.x_nom;
        for i in 0..2 {
            let goal = target.0[i].clamp(lo, hi);
            let u_start = self.voltage[i];
            let mut u = u_start;
            if (goal - u_start).abs() * (1.0 - self.amp_decay) <= max_step {
                // The first substep has the largest increment of the exponential approach: no
                // substep reaches the rate limit, and the approach stays between U and the
                // (in-range) target.
                let gap = u_start - goal;
                for (uk, e) in self.u_path[1..=n].iter_mut().zip(&self.amp_powers[1..=n]) {
                    *uk = goal + gap * e;
                }
                u = self.u_path[n];
            } else {
                for uk in &mut self.u_path[1..=n] {
                    let u1 = goal + (u - goal) * self.amp_decay;
                    u = u1.clamp(u - max_step, u + max_step).clamp(lo, hi);
                    *uk = u;
                }
            }
            let x_bw0 = self.pea[i].x();
            let x_bw1 = self.pea[i].step(u, if jump { 0.0 } else { t });
            self.voltage[i] = u;
            let du = u - u_start;
            let start = (x_bw0 - self.x_bias[i]) * MICROMETRE;
            let end = (x_bw1 - self.x_bias[i]) * MICROMETRE;
            let (c0, c1) = self.creep(i, if jump { end } else { start }, end);
            let dc = (c1 - c0) / n as f64;
            if du != 0.0 && !jump {
                let slope = (end - start) / du;
                for k in 1..=n {
                    self.path[k][i] =
                        start + slope * (self.u_path[k] - u_start) + c0 + dc * k as f64;
                }
            } else {
                for k in 1..=n {
                    self.path[k][i] = end + c0 + dc * k as f64;
                }
            }
            self.path[0][i] = if jump { self.path[1][i] } else { x_start[i] };
            self.x_nom[i] = self.path[n][i];
        }
    }

    /// Samples the sensors; `q` is the true output now (used when the sensor is ideal).
    fn measure(&mut self, q: [f64; 2]) -> [f64; 2] {
        let base = if self.params.sensor.is_filtered() {
            self.sensor.output()
        } else {
            q
        };
        let mut y = [0.0; 2];
        for (i, yi) in y.iter_mut().enumerate() {
            let v = base[i] + self.white[i].sample() + self.flicker[i].sample();
            let r = self.params.resolution[i];
            *yi = if r > 0.0 { (v / r).round() * r } else { v };
        }
        y
    }
}

/// A [`Mechanics`] inside the rig: a complete simulated stage. No allocation per sample.
#[derive(Debug, Clone)]
pub struct RigPlant<M> {
    rig: Rig,
    mechanics: M,
}

impl<M: Mechanics> RigPlant<M> {
    /// The plant at rest at the bias. `mechanics` must be discretized for the rig's substep.
    pub fn new(params: RigParams, mechanics: M) -> Result<RigPlant<M>> {
        let rig = Rig::new(params)?;
        let h = rig.params.substep();
        let hm = mechanics.substep_time();
        check(
            "mechanics substep",
            hm,
            ((hm - h) / h).abs() < 1e-9,
            &format!("equal to simulation.sample_time / substeps = {h:e} s"),
        )?;
        let mut plant = RigPlant { rig, mechanics };
        let q = plant.mechanics.output();
        let aa = plant.rig.params.sensor.anti_alias > 0.0;
        plant.rig.sensor.rest(q, aa);
        Ok(plant)
    }

    /// The rig's settings.
    pub fn params(&self) -> &RigParams {
        &self.rig.params
    }

    /// The mechanics.
    pub fn mechanics(&self) -> &M {
        &self.mechanics
    }

    /// The mechanics, mutably (e.g. to set an initial state).
    pub fn mechanics_mut(&mut self) -> &mut M {
        &mut self.mechanics
    }

    /// Records from now on, per sample, the sensor chain's analog output and the true output
    /// after every substep ([`RigPlant::sensed_substeps`], [`RigPlant::output_substeps`]).
    pub fn record_substeps(&mut self) {
        self.rig.s_path = vec![self.sensed(); self.rig.params.substeps];
    }

    /// The sensor chain's analog output now \[m\] (the true output through the sensor
    /// electronics and the anti-aliasing filter, before the ADC's noise and quantization):
    /// what a lab's fast ADC (an oscilloscope or DAQ on the sensor's output) digitizes.
    pub fn sensed(&self) -> [f64; 2] {
        if self.rig.params.sensor.is_filtered() {
            self.rig.sensor.output()
        } else {
            self.mechanics.output()
        }
    }

    /// The sensor chain's analog output ([`RigPlant::sensed`]) after every substep of the
    /// last sample, once recorded ([`RigPlant::record_substeps`]; empty before).
    pub fn sensed_substeps(&self) -> &[[f64; 2]] {
        &self.rig.s_path
    }

    /// The true output after every substep of the last sample, once recorded
    /// ([`RigPlant::record_substeps`]): the simulation's truth, to score a result only.
    pub fn output_substeps(&self) -> &[[f64; 2]] {
        if self.rig.s_path.is_empty() {
            &[]
        } else {
            &self.rig.q_path
        }
    }

    /// Advances one sample with `cmd` (after the delay).
    pub fn step(&mut self, cmd: &Command) {
        let target = self.rig.take(cmd);
        let n = self.rig.params.substeps;
        let h = self.rig.params.substep();
        let f0 = self.rig.floor.value();
        self.rig.floor.advance();
        let f1 = self.rig.floor.value();
        let filtered = self.rig.params.sensor.is_filtered();
        let recorded = !self.rig.s_path.is_empty();
        let mut q0 = if filtered {
            self.mechanics.output()
        } else {
            [0.0; 2]
        };
        self.rig.actuate(target, h);
        if filtered || recorded {
            self.mechanics.advance_sample(
                &self.rig.path,
                [f0, f1],
                Some(&mut self.rig.q_path[..n]),
            );
            for k in 0..n {
                let q1 = self.rig.q_path[k];
                if filtered {
                    self.rig.sensor.step(q0, q1);
                }
                if recorded {
                    self.rig.s_path[k] = if filtered {
                        self.rig.sensor.output()
                    } else {
                        q1
                    };
                }
                q0 = q1;
            }
        } else {
            self.mechanics
                .advance_sample(&self.rig.path, [f0, f1], None);
        }
    }
}

impl<M: Mechanics> StagePlant for RigPlant<M> {
    fn measure(&mut self) -> [f64; 2] {
        let q = self.mechanics.output();
        self.rig.measure(q)
    }
    fn output(&self) -> [f64; 2] {
        self.mechanics.output()
    }
    fn apply(&mut self, cmd: &Command) {
        self.step(cmd);
    }
    fn voltage(&self) -> [f64; 2] {
        self.rig.voltage
    }
    fn x_nom(&self) -> [f64; 2] {
        self.rig.x_nom
    }
}
