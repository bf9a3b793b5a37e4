//! The simulated stage (digital twin): richer than the controller's model.
//!
//! * Mechanics: Eq. (36) with the **truth** parameters (Table 4 estimates) and the cross
//!   terms of Eq. (30) (a coupling spring k_c between the output directions).
//! * Actuators: PEA i pushes its input plate with K_pea,i (x_nom,i − x_in,i) (Eq. 2–3, rows
//!   7–8 of B and D), where x_nom,i = x_pea,i − x_bias,i comes from the Bouc–Wen model of the
//!   applied voltage (flexstage-piezo), preloaded to the bias voltage (Section 4.1).
//! * Amplifiers: the voltage is clamped to the range and held over the sample (ZOH), or
//!   follows the command with a first-order lag when a bandwidth is set.
//! * Sensors: Gaussian noise plus quantization to the sensor resolution (Section 4.1).
//! * Time: continuous. Each sample is split into `substeps`; on each substep the mechanics
//!   are advanced with the exact exponential (x_nom constant at its substep mean) and the
//!   Bouc–Wen state with its exact integrator, so the ≈ 12 kHz PEA mode is resolved even
//!   though the controller samples at 10 kHz (DECISIONS.md).

use flexstage_piezo::{BoucWen, BoucWenParams, GaussianNoise, MICROMETRE};
use flexstage_scenario::StageParams;

use crate::actuator::preload;
use crate::controller::Command;
use crate::error::{Result, check, non_negative, positive};
use crate::linalg::c2d;
use crate::model::{Matrix8, Matrix8x2, StageModel, Vector8, from_dyn};

/// How the plant's actuators are driven.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlantActuator {
    /// Voltages through the Bouc–Wen PEAs (the full plant).
    Hysteretic,
    /// The command's x_nom directly (the linear plant of Eq. 36).
    Ideal,
}

/// Settings of the simulated plant.
#[derive(Debug, Clone, PartialEq)]
pub struct PlantParams {
    /// True mechanical parameters.
    pub truth: StageParams,
    /// Cross-coupling stiffness k_c of Eq. (30) [N/m].
    pub coupling: f64,
    /// Bouc–Wen parameters of the two PEAs (µm, V, s).
    pub hysteresis: [BoucWenParams; 2],
    /// Amplifier range [V].
    pub voltage_range: [f64; 2],
    /// Preload bias voltage [V].
    pub bias_voltage: f64,
    /// Amplifier bandwidth [Hz] (first-order lag); 0 = ideal ZOH.
    pub amplifier_bandwidth: f64,
    /// Sensor quantization steps [m] (0: none).
    pub resolution: [f64; 2],
    /// Sensor noise standard deviations [m].
    pub noise_std: [f64; 2],
    /// Noise seed.
    pub seed: u64,
    /// Controller sample time T [s].
    pub sample_time: f64,
    /// Substeps per sample, ≥ 1.
    pub substeps: usize,
    /// Actuator mode.
    pub actuator: PlantActuator,
}

impl PlantParams {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        crate::model::validate(&self.truth)?;
        check("stage.coupling", self.coupling, true, "finite")?;
        non_negative("amplifier_bandwidth", self.amplifier_bandwidth)?;
        for i in 0..2 {
            non_negative(&format!("sensors.resolution[{i}]"), self.resolution[i])?;
            non_negative(&format!("sensors.noise_std[{i}]"), self.noise_std[i])?;
        }
        positive("simulation.sample_time", self.sample_time)?;
        check(
            "simulation.substeps",
            self.substeps as f64,
            self.substeps >= 1,
            "an integer ≥ 1",
        )
    }
}

/// The simulated stage. No allocation per sample.
#[derive(Debug, Clone)]
pub struct Plant {
    params: PlantParams,
    model: StageModel,
    phi: Matrix8,
    gamma: Matrix8x2,
    z: Vector8,
    pea: [BoucWen; 2],
    x_bias: [f64; 2],
    voltage: [f64; 2],
    x_nom: [f64; 2],
    noise: [GaussianNoise; 2],
}

impl Plant {
    /// A plant at rest at the bias (z = 0, x_nom = 0).
    pub fn new(params: PlantParams) -> Result<Plant> {
        params.validate()?;
        let model = StageModel::with_coupling(&params.truth, params.coupling)?;
        let dt = params.sample_time / params.substeps as f64;
        let (phi, gamma) = c2d(&model.b_dyn(), &model.input_dyn(), dt)?;
        let mut pea = [
            BoucWen::new(params.hysteresis[0]),
            BoucWen::new(params.hysteresis[1]),
        ];
        let mut x_bias = [0.0; 2];
        for i in 0..2 {
            let (u, h, x) = preload(&params.hysteresis[i], params.bias_voltage);
            pea[i].set_state(u, h);
            x_bias[i] = x;
        }
        let noise = [
            GaussianNoise::new(
                params.noise_std[0],
                params.seed.wrapping_mul(2).wrapping_add(1),
            ),
            GaussianNoise::new(
                params.noise_std[1],
                params.seed.wrapping_mul(2).wrapping_add(2),
            ),
        ];
        Ok(Plant {
            voltage: [params.bias_voltage; 2],
            model,
            phi: from_dyn(&phi),
            gamma: from_dyn(&gamma),
            z: Vector8::zeros(),
            pea,
            x_bias,
            x_nom: [0.0; 2],
            noise,
            params,
        })
    }

    /// The plant's model (truth + coupling).
    pub fn model(&self) -> &StageModel {
        &self.model
    }

    /// The true state z [SI].
    pub fn state(&self) -> [f64; 8] {
        let mut s = [0.0; 8];
        s.copy_from_slice(self.z.as_slice());
        s
    }

    /// Sets the true state z.
    pub fn set_state(&mut self, z: [f64; 8]) {
        self.z = Vector8::from_column_slice(&z);
    }

    /// The true output q_o [m].
    pub fn output(&self) -> [f64; 2] {
        [self.z[0], self.z[1]]
    }

    /// The actuators' current x_nom [m].
    pub fn x_nom(&self) -> [f64; 2] {
        self.x_nom
    }

    /// Samples the sensors: q_o + noise, quantized.
    pub fn measure(&mut self) -> [f64; 2] {
        let mut y = [0.0; 2];
        for (i, yi) in y.iter_mut().enumerate() {
            let v = self.z[i] + self.noise[i].sample();
            let r = self.params.resolution[i];
            *yi = if r > 0.0 { (v / r).round() * r } else { v };
        }
        y
    }

    /// Advances one sample with the command held (ZOH).
    pub fn apply(&mut self, cmd: &Command) {
        let n = self.params.substeps;
        let dt = self.params.sample_time / n as f64;
        let [lo, hi] = self.params.voltage_range;
        match self.params.actuator {
            PlantActuator::Ideal => {
                self.x_nom = cmd.x_nom;
                let u = nalgebra::Vector2::new(cmd.x_nom[0], cmd.x_nom[1]);
                for _ in 0..n {
                    self.z = self.phi * self.z + self.gamma * u;
                }
            }
            PlantActuator::Hysteretic => {
                let target = [cmd.voltage[0].clamp(lo, hi), cmd.voltage[1].clamp(lo, hi)];
                let bw = self.params.amplifier_bandwidth;
                let decay = if bw > 0.0 {
                    (-std::f64::consts::TAU * bw * dt).exp()
                } else {
                    0.0
                };
                for _ in 0..n {
                    let mut u = nalgebra::Vector2::zeros();
                    for i in 0..2 {
                        let x0 = self.x_nom[i];
                        let v1 = target[i] + (self.voltage[i] - target[i]) * decay;
                        // Ideal amplifier: a jump at the start of the sample (Δt = 0);
                        // otherwise a ramp over the substep.
                        let ramp = if bw > 0.0 { dt } else { 0.0 };
                        let x_pea = self.pea[i].step(v1, ramp);
                        self.voltage[i] = v1;
                        let x1 = (x_pea - self.x_bias[i]) * MICROMETRE;
                        self.x_nom[i] = x1;
                        u[i] = if bw > 0.0 { 0.5 * (x0 + x1) } else { x1 };
                    }
                    self.z = self.phi * self.z + self.gamma * u;
                }
            }
        }
    }

    /// The voltages currently applied [V].
    pub fn voltage(&self) -> [f64; 2] {
        self.voltage
    }
}
