//! The lumped simulated stage: the 8-state model of Eq. (36) with the truth parameters and
//! the cross terms of Eq. (30), inside the loop effects of [`crate::rig`].
//!
//! * [`LumpedStage`] is the [`Mechanics`]: Eq. (36) (truth parameters, a coupling spring k_c
//!   between the output directions) advanced per substep with the exact exponential, x_nom
//!   held at its substep mean; the floor acceleration acts on every mass (relative
//!   coordinates).
//! * [`Plant`] is the lumped stage in the minimal loop of [`PlantParams`]: amplifier range and
//!   optional first-order lag, the Bouc–Wen PEAs, white sensor noise and quantization, no
//!   delay. It is the plant of the identification experiment and of the controller's
//!   ideal-loop tests. The same mechanics in a realistic rig is
//!   [`PlantParams::in_rig`].
//! * Time: continuous. Each sample is split into `substeps` so that the ≈ 12 kHz PEA mode is
//!   resolved although the controller samples at 10 kHz (DECISIONS.md).

use flexstage_piezo::BoucWenParams;
use flexstage_scenario::{Scenario, StageParams};

use crate::error::{Result, check, non_negative, positive};
use crate::experiment::Command;
use crate::linalg::c2d;
use crate::model::{Matrix8, Matrix8x2, StageModel, Vector8, from_dyn};
pub use crate::rig::PlantActuator;
use crate::rig::{
    AmplifierParams, CreepParams, FloorParams, Mechanics, RigParams, RigPlant, SensorParams,
    StagePlant,
};

/// Settings of the lumped plant in its minimal loop.
#[derive(Debug, Clone, PartialEq)]
pub struct PlantParams {
    /// True mechanical parameters.
    pub truth: StageParams,
    /// Cross-coupling stiffness k_c of Eq. (30) [N/m].
    pub coupling: f64,
    /// Bouc–Wen parameters of the two PEAs (µm, V, s).
    pub hysteresis: [BoucWenParams; 2],
    /// Amplifier range \[V\].
    pub voltage_range: [f64; 2],
    /// Preload bias voltage \[V\].
    pub bias_voltage: f64,
    /// Amplifier bandwidth \[Hz\] (first-order lag); 0 = ideal ZOH.
    pub amplifier_bandwidth: f64,
    /// Sensor quantization steps \[m\] (0: none).
    pub resolution: [f64; 2],
    /// Sensor noise standard deviations \[m\].
    pub noise_std: [f64; 2],
    /// Noise seed.
    pub seed: u64,
    /// Controller sample time T \[s\].
    pub sample_time: f64,
    /// Substeps per sample, ≥ 1.
    pub substeps: usize,
    /// Actuator mode.
    pub actuator: PlantActuator,
}

impl PlantParams {
    /// The lumped plant of a scenario: `stage.truth` with the cross terms of
    /// `stage.coupling` (k_c = coupling·√(2 K_qo1 K_qo2)), the PEAs and amplifier range of
    /// `[hysteresis]` with the bias in its middle, `[sensors]`, and the timing, amplifier
    /// bandwidth and seed of `[simulation]`.
    pub fn from_scenario(s: &Scenario) -> PlantParams {
        let h = &s.hysteresis;
        let t = s.stage.truth.clone();
        let coupling = s.stage.coupling * (2.0 * t.k_qo1 * t.k_qo2).sqrt();
        PlantParams {
            truth: t,
            coupling,
            hysteresis: [BoucWenParams::from(&h.pea1), BoucWenParams::from(&h.pea2)],
            voltage_range: [h.voltage_min, h.voltage_max],
            bias_voltage: 0.5 * (h.voltage_min + h.voltage_max),
            amplifier_bandwidth: s.simulation.amplifier_bandwidth,
            resolution: s.sensors.resolution,
            noise_std: s.sensors.noise_std,
            seed: s.simulation.seed,
            sample_time: s.simulation.sample_time,
            substeps: s.simulation.substeps,
            actuator: PlantActuator::Hysteretic,
        }
    }

    /// The lumped stage of these settings (truth parameters and cross terms) inside the rig
    /// `rig`: delay, amplifier limits, the rig's own PEAs with creep, sensor dynamics and
    /// noise, floor vibration.
    pub fn in_rig(&self, rig: RigParams) -> Result<RigPlant<LumpedStage>> {
        let mech = LumpedStage::new(&self.truth, self.coupling, rig.substep())?;
        RigPlant::new(rig, mech)
    }

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

    /// The minimal loop of these settings as [`RigParams`]: no delay, the amplifier lag of
    /// `amplifier_bandwidth` without rate limits, ideal sensor dynamics with white noise,
    /// no creep, no floor vibration.
    pub fn rig(&self) -> RigParams {
        RigParams {
            delay: 0,
            actuator: self.actuator,
            amplifier: AmplifierParams {
                bandwidth: self.amplifier_bandwidth,
                ..AmplifierParams::ideal()
            },
            hysteresis: self.hysteresis,
            creep: CreepParams { factor: 0.0 },
            voltage_range: self.voltage_range,
            bias_voltage: self.bias_voltage,
            floor: FloorParams {
                velocity_rms: 0.0,
                bands: [8.0, 80.0],
            },
            sensor: SensorParams::ideal(),
            resolution: self.resolution,
            noise_std: self.noise_std,
            seed: self.seed,
            sample_time: self.sample_time,
            substeps: self.substeps,
        }
    }
}

/// Eq. (36) with cross terms as [`Mechanics`] (module docs). No allocation per substep.
#[derive(Debug, Clone)]
pub struct LumpedStage {
    model: StageModel,
    phi: Matrix8,
    gamma: Matrix8x2,
    gamma_floor: Matrix8x2,
    z: Vector8,
    h: f64,
}

impl LumpedStage {
    /// The stage with parameters `truth` and coupling spring `k_c` [N/m], discretized for
    /// substeps of `h` seconds, at rest.
    pub fn new(truth: &StageParams, k_c: f64, h: f64) -> Result<LumpedStage> {
        let model = StageModel::with_coupling(truth, k_c)?;
        let (phi, gamma) = c2d(&model.b_dyn(), &model.input_dyn(), h)?;
        // Base acceleration a_g in relative coordinates: −a_g on every mass (q̈_o1, q̈_o2,
        // ẍ_in1, ẍ_in2 along x, x, y… as the DOFs point).
        let mut bf = nalgebra::DMatrix::zeros(8, 2);
        bf[(4, 0)] = -1.0;
        bf[(5, 1)] = -1.0;
        bf[(6, 0)] = -1.0;
        bf[(7, 0)] = -1.0;
        let (_, gamma_floor) = c2d(&model.b_dyn(), &bf, h)?;
        Ok(LumpedStage {
            model,
            phi: from_dyn(&phi),
            gamma: from_dyn(&gamma),
            gamma_floor: from_dyn(&gamma_floor),
            z: Vector8::zeros(),
            h,
        })
    }

    /// The model (truth + coupling).
    pub fn model(&self) -> &StageModel {
        &self.model
    }

    /// The state z \[SI\].
    pub fn state(&self) -> [f64; 8] {
        let mut s = [0.0; 8];
        s.copy_from_slice(self.z.as_slice());
        s
    }

    /// Sets the state z.
    pub fn set_state(&mut self, z: [f64; 8]) {
        self.z = Vector8::from_column_slice(&z);
    }
}

impl Mechanics for LumpedStage {
    fn substep_time(&self) -> f64 {
        self.h
    }

    #[inline]
    fn advance(&mut self, x_nom: [[f64; 2]; 2], floor: [[f64; 2]; 2]) {
        let u = nalgebra::Vector2::new(
            0.5 * (x_nom[0][0] + x_nom[1][0]),
            0.5 * (x_nom[0][1] + x_nom[1][1]),
        );
        self.z = self.phi * self.z + self.gamma * u;
        let f = [
            0.5 * (floor[0][0] + floor[1][0]),
            0.5 * (floor[0][1] + floor[1][1]),
        ];
        if f != [0.0; 2] {
            self.z += self.gamma_floor * nalgebra::Vector2::new(f[0], f[1]);
        }
    }

    fn output(&self) -> [f64; 2] {
        [self.z[0], self.z[1]]
    }

    fn inputs(&self) -> [f64; 2] {
        [self.z[2], self.z[3]]
    }
}

/// The lumped stage in the minimal loop of [`PlantParams`] (module docs). No allocation per
/// sample.
#[derive(Debug, Clone)]
pub struct Plant {
    inner: RigPlant<LumpedStage>,
}

impl Plant {
    /// A plant at rest at the bias (z = 0, x_nom = 0).
    pub fn new(params: PlantParams) -> Result<Plant> {
        params.validate()?;
        let rig = params.rig();
        let mech = LumpedStage::new(&params.truth, params.coupling, rig.substep())?;
        Ok(Plant {
            inner: RigPlant::new(rig, mech)?,
        })
    }

    /// The plant's model (truth + coupling).
    pub fn model(&self) -> &StageModel {
        self.inner.mechanics().model()
    }

    /// The true state z \[SI\].
    pub fn state(&self) -> [f64; 8] {
        self.inner.mechanics().state()
    }

    /// Sets the true state z.
    pub fn set_state(&mut self, z: [f64; 8]) {
        self.inner.mechanics_mut().set_state(z);
    }

    /// The true output q_o \[m\].
    pub fn output(&self) -> [f64; 2] {
        self.inner.output()
    }

    /// The actuators' current x_nom \[m\].
    pub fn x_nom(&self) -> [f64; 2] {
        self.inner.x_nom()
    }

    /// Samples the sensors: q_o + noise, quantized.
    pub fn measure(&mut self) -> [f64; 2] {
        self.inner.measure()
    }

    /// Advances one sample with the command held (ZOH).
    pub fn apply(&mut self, cmd: &Command) {
        self.inner.step(cmd);
    }

    /// The voltages currently applied \[V\].
    pub fn voltage(&self) -> [f64; 2] {
        self.inner.voltage()
    }
}

impl StagePlant for Plant {
    fn measure(&mut self) -> [f64; 2] {
        self.inner.measure()
    }
    fn output(&self) -> [f64; 2] {
        self.inner.output()
    }
    fn apply(&mut self, cmd: &Command) {
        self.inner.step(cmd);
    }
    fn voltage(&self) -> [f64; 2] {
        self.inner.voltage()
    }
    fn x_nom(&self) -> [f64; 2] {
        self.inner.x_nom()
    }
}
