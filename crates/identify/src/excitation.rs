//! The built-in excitation of the simulated stage and the simulated identification record.
//!
//! # Excitation
//! Two multisines, one per PEA, on interleaved frequency lines k·f₀ (odd k on PEA 1, even k
//! on PEA 2, up to f_max) with Schroeder phases, so that x_in1 + x_in2 and x_in1 − x_in2
//! (hence q_o1 and q_o2) are excited independently. Each is scaled so that its peak is
//! `amplitude` (a fraction of the stroke), and faded in with a half-cosine over `ramp`
//! seconds so that the lightly damped modes (1.5–2 kHz output, ≈ 12 kHz plate) start
//! without a transient.
//!
//! # Simulated record
//! The plant of flexstage-control (truth parameters, cross terms, Bouc–Wen PEAs or the
//! ideal actuator, sensor noise and quantization on q_o) is run `oversample` times faster
//! than the record, with the excitation held at mid-step values, so that the input is smooth
//! on the record's time scale: the plate mode at ≈ 12 kHz is above the 5 kHz Nyquist
//! frequency of a 10 kHz record, and a 10 kHz staircase input would ring it by the size of a
//! step, swamping the small x_nom − x_in the plate rows need. Logged at each record instant:
//! t, x_nom (mean of the held values around the instant, i.e. the smooth input; with the
//! hysteretic actuator the true actuator output, as a perfect PEA model would give), U,
//! x_in (with the same noise and quantization as sensor 1: the plates are assumed measured
//! by capacitive sensors like the output's), q_o (the plant's sensors).

use flexstage_control::controller::Command;
use flexstage_control::plant::{Plant, PlantActuator, PlantParams};
use flexstage_numerics::noise::GaussianNoise;

use crate::data::StageRecord;
use crate::error::{Result, check};

/// Settings of the excitation.
#[derive(Debug, Clone, PartialEq)]
pub struct Excitation {
    /// Duration \[s\], > 0. Default 4 s (the length the noisy 5 % requirement needs, see the
    /// crate docs).
    pub duration: f64,
    /// Frequency resolution f₀ \[Hz\], > 0 (lines at k·f₀). Default 5 Hz.
    pub f_min: f64,
    /// Highest line \[Hz\], ≥ 2 f₀. Default 150 Hz (crate docs: K_in needs the plate's
    /// damping and inertial forces, which grow with frequency, to stay small).
    pub f_max: f64,
    /// Peak of each x_nom \[m\], > 0. Default 27 µm (90 % of the 30 µm stroke).
    pub amplitude: f64,
    /// Fade-in time \[s\], ≥ 0. Default 20 ms.
    pub ramp: f64,
}

impl Default for Excitation {
    fn default() -> Self {
        Excitation {
            duration: 4.0,
            f_min: 5.0,
            f_max: 150.0,
            amplitude: 27e-6,
            ramp: 0.02,
        }
    }
}

impl Excitation {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        check(
            "excitation.duration",
            self.duration,
            self.duration > 0.0,
            "a duration > 0 [s]",
        )?;
        check(
            "excitation.f_min",
            self.f_min,
            self.f_min > 0.0,
            "a frequency > 0 [Hz]",
        )?;
        check(
            "excitation.f_max",
            self.f_max,
            self.f_max >= 2.0 * self.f_min && self.f_max / self.f_min <= 10_000.0,
            "a frequency in [2 f_min, 10⁴ f_min] [Hz]",
        )?;
        check(
            "excitation.amplitude",
            self.amplitude,
            self.amplitude > 0.0,
            "a displacement > 0 [m]",
        )?;
        check(
            "excitation.ramp",
            self.ramp,
            self.ramp >= 0.0,
            "a time ≥ 0 [s]",
        )
    }
}

/// The two multisine signals of an [`Excitation`], ready to evaluate.
#[derive(Debug, Clone, PartialEq)]
pub struct Multisine {
    lines: [Vec<(f64, f64)>; 2],
    scale: [f64; 2],
    ramp: f64,
}

impl Multisine {
    /// Builds the signals (module docs).
    pub fn new(e: &Excitation) -> Result<Multisine> {
        e.validate()?;
        let k_max = (e.f_max / e.f_min).floor() as usize;
        let mut lines: [Vec<(f64, f64)>; 2] = Default::default();
        for k in 1..=k_max {
            lines[(k + 1) % 2].push((k as f64 * e.f_min, 0.0));
        }
        // Schroeder phases: φ_k = −π k(k−1)/n.
        for l in lines.iter_mut() {
            let n = l.len() as f64;
            for (j, line) in l.iter_mut().enumerate() {
                let k = (j + 1) as f64;
                line.1 = -std::f64::consts::PI * k * (k - 1.0) / n;
            }
        }
        let mut m = Multisine {
            lines,
            scale: [1.0; 2],
            ramp: e.ramp,
        };
        // Peak over one period 1/f₀, on a grid fine against f_max.
        let period = 1.0 / e.f_min;
        let n = ((period * e.f_max * 200.0) as usize).max(1000);
        for i in 0..2 {
            let peak = (0..n)
                .map(|j| m.raw(i, period * j as f64 / n as f64).abs())
                .fold(0.0, f64::max);
            m.scale[i] = e.amplitude / peak;
        }
        Ok(m)
    }

    fn raw(&self, i: usize, t: f64) -> f64 {
        self.lines[i]
            .iter()
            .map(|&(f, p)| (std::f64::consts::TAU * f * t + p).sin())
            .sum()
    }

    /// x_nom1, x_nom2 \[m\] at time `t` \[s\].
    pub fn value(&self, t: f64) -> [f64; 2] {
        let w = if self.ramp > 0.0 && t < self.ramp {
            0.5 * (1.0 - (std::f64::consts::PI * t.max(0.0) / self.ramp).cos())
        } else {
            1.0
        };
        [0, 1].map(|i| w * self.scale[i] * self.raw(i, t))
    }
}

/// Settings of a simulated identification experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationParams {
    /// The plant (truth, coupling, hysteresis, sensors, sample time = record sample time).
    pub plant: PlantParams,
    /// The excitation.
    pub excitation: Excitation,
    /// Plant steps per record sample, ≥ 1. Default 10.
    pub oversample: usize,
    /// Input-plate sensors: [resolution, noise std] \[m\], both ≥ 0.
    pub plate_sensor: [f64; 2],
    /// Mean slope κ [µm/V] of the PEAs, used to turn the x_nom excitation into voltages
    /// around the bias for the hysteretic actuator, > 0.
    pub slope: f64,
}

impl SimulationParams {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        self.plant.validate()?;
        self.excitation.validate()?;
        check(
            "oversample",
            self.oversample as f64,
            (1..=1000).contains(&self.oversample),
            "an integer in 1..=1000",
        )?;
        check(
            "plate_sensor.resolution",
            self.plate_sensor[0],
            self.plate_sensor[0] >= 0.0,
            "≥ 0 [m]",
        )?;
        check(
            "plate_sensor.noise_std",
            self.plate_sensor[1],
            self.plate_sensor[1] >= 0.0,
            "≥ 0 [m]",
        )?;
        check("slope", self.slope, self.slope > 0.0, "> 0 [µm/V]")
    }
}

/// Runs the excitation on the plant and logs the record (module docs).
pub fn simulate(sim: &SimulationParams) -> Result<StageRecord> {
    sim.validate()?;
    let ms = Multisine::new(&sim.excitation)?;
    let ts = sim.plant.sample_time;
    let r = sim.oversample;
    let dt = ts / r as f64;
    let mut pp = sim.plant.clone();
    pp.sample_time = dt;
    pp.substeps = sim.plant.substeps.div_ceil(r).max(1);
    let mut plant = Plant::new(pp.clone())?;
    let n = (sim.excitation.duration / ts).round() as usize + 1;
    let mut noise = [
        GaussianNoise::new(sim.plate_sensor[1], pp.seed.wrapping_mul(7).wrapping_add(3)),
        GaussianNoise::new(sim.plate_sensor[1], pp.seed.wrapping_mul(7).wrapping_add(4)),
    ];
    let quantize = |v: f64| {
        let res = sim.plate_sensor[0];
        if res > 0.0 {
            (v / res).round() * res
        } else {
            v
        }
    };
    let bias = pp.bias_voltage;
    let [lo, hi] = pp.voltage_range;
    let command = |t: f64| {
        let x = ms.value(t);
        let voltage = [0, 1].map(|i| (bias + x[i] * 1e6 / sim.slope).clamp(lo, hi));
        Command {
            voltage,
            x_nom: x,
            reference: [0.0; 2],
            saturated: false,
            dropout: false,
        }
    };
    let mut rec_t = Vec::with_capacity(n);
    let mut x_nom: [Vec<f64>; 2] = [Vec::with_capacity(n), Vec::with_capacity(n)];
    let mut x_in: [Vec<f64>; 2] = [Vec::with_capacity(n), Vec::with_capacity(n)];
    let mut q: [Vec<f64>; 2] = [Vec::with_capacity(n), Vec::with_capacity(n)];
    let mut volt: [Vec<f64>; 2] = [Vec::with_capacity(n), Vec::with_capacity(n)];
    let mut held = plant.x_nom();
    let mut held_v = plant.voltage();
    let mut j = 0usize;
    for k in 0..n {
        // The state at t_k = k T_s, then one fine step to know the held input after t_k.
        let z = plant.state();
        let y = plant.measure();
        let before = held;
        let before_v = held_v;
        let cmd = command((j as f64 + 0.5) * dt);
        plant.apply(&cmd);
        j += 1;
        held = plant.x_nom();
        held_v = if pp.actuator == PlantActuator::Ideal {
            cmd.voltage
        } else {
            plant.voltage()
        };
        rec_t.push(k as f64 * ts);
        for i in 0..2 {
            x_nom[i].push(0.5 * (before[i] + held[i]));
            volt[i].push(0.5 * (before_v[i] + held_v[i]));
            x_in[i].push(quantize(z[2 + i] + noise[i].sample()));
            q[i].push(y[i]);
        }
        for _ in 1..r {
            let cmd = command((j as f64 + 0.5) * dt);
            plant.apply(&cmd);
            j += 1;
        }
        held = plant.x_nom();
        held_v = plant.voltage();
        if pp.actuator == PlantActuator::Ideal {
            held_v = command((j as f64 - 0.5) * dt).voltage;
        }
    }
    StageRecord::new(rec_t, x_nom, x_in, q, Some(volt), 1e-6)
}
