//! Parameter groups of the piezo actuators, the reduced stage model, the controller, the
//! sensors and the tracking experiment (Sections 3–4, Table 4, Table A1, DECISIONS.md).

use serde::{Deserialize, Serialize};

use crate::error::{Result, check, count, file_name, non_negative, positive};

/// Bouc–Wen hysteresis of one PEA, Eq. (18) with n = 1, in the paper's units (x in µm, U in V,
/// t in s), as identified in Table A1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoucWen {
    /// Piezoelectric coefficient d_p [µm/V], > 0.
    pub d_p: f64,
    /// A_bw [µm/V].
    pub a_bw: f64,
    /// B_bw [1/V], ≥ 0.
    pub b_bw: f64,
    /// Γ_bw [1/V].
    pub gamma_bw: f64,
    /// Asymmetry factor δ_bw [µm/(V·s)].
    pub delta_bw: f64,
}

impl BoucWen {
    pub(crate) fn validate(&self, field: &str) -> Result<()> {
        positive(&format!("{field}.d_p"), self.d_p)?;
        check(&format!("{field}.a_bw"), self.a_bw, true, "a finite number")?;
        non_negative(&format!("{field}.b_bw"), self.b_bw)?;
        check(
            &format!("{field}.gamma_bw"),
            self.gamma_bw,
            self.b_bw + self.gamma_bw > 0.0,
            "a number with b_bw + gamma_bw > 0 (bounded hysteresis)",
        )?;
        check(
            &format!("{field}.delta_bw"),
            self.delta_bw,
            true,
            "a finite number",
        )
    }
}

/// The piezo actuators' hysteresis and the amplifier (Section 3.1, Table A1, DECISIONS.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Hysteresis {
    /// Lowest amplifier voltage \[V\]. DECISIONS.md: 0.
    pub voltage_min: f64,
    /// Highest amplifier voltage \[V\]. DECISIONS.md: 1000.
    pub voltage_max: f64,
    /// PEA1, Table A1.
    pub pea1: BoucWen,
    /// PEA2, Table A1.
    pub pea2: BoucWen,
}

impl Hysteresis {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        check(
            "hysteresis.voltage_min",
            self.voltage_min,
            self.voltage_min >= -2000.0,
            "a number ≥ -2000 V",
        )?;
        // A span below a volt drives no PEA (Table A1's d_p: 0.06 µm/V).
        check(
            "hysteresis.voltage_max",
            self.voltage_max,
            self.voltage_max >= self.voltage_min + 1.0 && self.voltage_max <= 2000.0,
            "a number in [voltage_min + 1, 2000] V",
        )?;
        self.pea1.validate("hysteresis.pea1")?;
        self.pea2.validate("hysteresis.pea2")
    }
}

/// Parameters of the reduced 8-state stage model, Eq. (31)–(35) and Appendix C, in SI.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageParams {
    /// Horizontal output stiffness K_qo1 [N/m].
    pub k_qo1: f64,
    /// Vertical output stiffness K_qo2 [N/m].
    pub k_qo2: f64,
    /// Moving mass of the mechanism M \[kg\].
    pub mass: f64,
    /// Amplification ratio α, Eq. (27).
    pub alpha: f64,
    /// PEA1 stiffness K_pea1 [N/m].
    pub k_pea1: f64,
    /// PEA2 stiffness K_pea2 [N/m].
    pub k_pea2: f64,
    /// Input plate 1 stiffness K_in1 [N/m].
    pub k_in1: f64,
    /// Input plate 2 stiffness K_in2 [N/m].
    pub k_in2: f64,
    /// Input plate 1 mass m_in1 \[kg\].
    pub m_in1: f64,
    /// Input plate 2 mass m_in2 \[kg\].
    pub m_in2: f64,
    /// Horizontal output damping C_qo1 [N·s/m].
    pub c_qo1: f64,
    /// Vertical output damping C_qo2 [N·s/m].
    pub c_qo2: f64,
    /// Input plate 1 damping C_in1 [N·s/m].
    pub c_in1: f64,
    /// Input plate 2 damping C_in2 [N·s/m].
    pub c_in2: f64,
}

impl StageParams {
    /// Checks every field; `group` is the TOML path of this table.
    pub fn validate(&self, group: &str) -> Result<()> {
        for (name, v) in [
            ("k_qo1", self.k_qo1),
            ("k_qo2", self.k_qo2),
            ("mass", self.mass),
            ("k_pea1", self.k_pea1),
            ("k_pea2", self.k_pea2),
            ("k_in1", self.k_in1),
            ("k_in2", self.k_in2),
            ("m_in1", self.m_in1),
            ("m_in2", self.m_in2),
        ] {
            positive(&format!("{group}.{name}"), v)?;
        }
        check(
            &format!("{group}.alpha"),
            self.alpha,
            self.alpha != 0.0 && self.alpha.abs() <= 100.0,
            "a non-zero number with |alpha| ≤ 100",
        )?;
        for (name, v) in [
            ("c_qo1", self.c_qo1),
            ("c_qo2", self.c_qo2),
            ("c_in1", self.c_in1),
            ("c_in2", self.c_in2),
        ] {
            non_negative(&format!("{group}.{name}"), v)?;
        }
        Ok(())
    }

    /// Damping coefficients for a critical-damping ratio ζ of each mode of the reduced model:
    /// horizontal output (stiffness 2K_qo1, mass M), vertical output (K_qo2, M) and input
    /// plates (K_in + K_pea + K_qo1, m_in). c = 2ζ√(k m); the input-plate damper shares the
    /// mode with C_qo1, so C_in = 2ζ√(k m) − C_qo1 (Eq. 35).
    pub fn with_damping_ratio(mut self, zeta: f64) -> Self {
        let c = |k: f64, m: f64| 2.0 * zeta * (k * m).sqrt();
        // 2C_qo1 damps the mode of stiffness 2K_qo1 (Eq. 32).
        self.c_qo1 = 0.5 * c(2.0 * self.k_qo1, self.mass);
        self.c_qo2 = c(self.k_qo2, self.mass);
        self.c_in1 = c(self.k_in1 + self.k_pea1 + self.k_qo1, self.m_in1) - self.c_qo1;
        self.c_in2 = c(self.k_in2 + self.k_pea2 + self.k_qo1, self.m_in2) - self.c_qo1;
        self
    }
}

/// The stage parameters: Table 4's guess (the controller's starting model) and its estimate
/// (the simulated plant's truth, DECISIONS.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stage {
    /// Damping ratio used to set the damping coefficients of the defaults (DECISIONS.md: 1–3 %).
    pub damping_ratio: f64,
    /// Table 4 "Guess".
    pub guess: StageParams,
    /// Table 4 "Estimate" (entries marked "—" keep the guess).
    pub truth: StageParams,
    /// Cross terms of Eq. (30) in the simulated plant: a coupling spring between the two
    /// output directions, as a fraction of √(2K_qo1·K_qo2) of the truth. 0 switches it off.
    #[serde(default = "default_coupling")]
    pub coupling: f64,
}

fn default_coupling() -> f64 {
    0.05
}

impl Stage {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        check(
            "stage.damping_ratio",
            self.damping_ratio,
            self.damping_ratio >= 0.0 && self.damping_ratio < 1.0,
            "a number in [0, 1)",
        )?;
        self.guess.validate("stage.guess")?;
        self.truth.validate("stage.truth")?;
        check(
            "stage.coupling",
            self.coupling,
            self.coupling.abs() < 1.0,
            "a number in (-1, 1)",
        )
    }
}

/// Observer and backstepping gains (Table 4, Appendix D).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Controller {
    /// K-filter observer gains k_e1, k_e2 (Eq. 37–38). Table 4: 1e5.
    #[serde(deserialize_with = "crate::strict::array")]
    pub observer_gain: [f64; 2],
    /// Error gains k_ε1, k_ε2 of s = ε̇ + k_ε ε. Table 4: 2e4, 1.5e4 (retuned to 3e3 for the
    /// sampled loop).
    #[serde(deserialize_with = "crate::strict::array")]
    pub error_gain: [f64; 2],
    /// Feedback gains k1, k2 of Eq. (A34). Table 4: 1.2e4, 1.2e3 (retuned to 3e3).
    #[serde(deserialize_with = "crate::strict::array")]
    pub feedback_gain: [f64; 2],
    /// Bandwidth κ_d of the observer's estimate of the model error Δ_η [1/s] (flexstage-control
    /// docs).
    #[serde(default = "default_disturbance_gain")]
    pub disturbance_gain: f64,
    /// Linear feedback gains k_η1, k_η2 > 1 of Eq. (A21) [1/s] (not in Table 4).
    #[serde(
        default = "default_eta_gain",
        deserialize_with = "crate::strict::array"
    )]
    pub eta_gain: [f64; 2],
    /// Disturbance bounds max|Δ_η| of Eq. (A22, A25) [m/s²].
    #[serde(
        default = "default_eta_bound",
        deserialize_with = "crate::strict::array"
    )]
    pub eta_bound: [f64; 2],
    /// Disturbance bounds max|Δ_ε| of Eq. (A36–A37) [m/s].
    #[serde(default = "default_a_bound", deserialize_with = "crate::strict::array")]
    pub a_bound: [f64; 2],
    /// Boundary layers (φ_s [m/s], φ_a \[m\]) of the robust terms; 0 selects sgn().
    #[serde(
        default = "default_boundary_layer",
        deserialize_with = "crate::strict::array"
    )]
    pub boundary_layer: [f64; 2],
    /// Take q̇ from the observer instead of finite differences of the positions.
    #[serde(default)]
    pub observer_velocity: bool,
    /// Largest nominal displacement |x_nom| the controller may command \[m\].
    #[serde(default = "default_stroke")]
    pub stroke: f64,
    /// PID baseline gains [kp, ki [1/s], kd \[s\]] on the output error.
    #[serde(default = "default_pid", deserialize_with = "crate::strict::array")]
    pub pid: [f64; 3],
}

fn default_disturbance_gain() -> f64 {
    3e4
}

fn default_eta_gain() -> [f64; 2] {
    [3e3, 3e3]
}

fn default_eta_bound() -> [f64; 2] {
    [0.1, 0.1]
}

fn default_a_bound() -> [f64; 2] {
    [1e-6, 1e-6]
}

fn default_boundary_layer() -> [f64; 2] {
    [1e-4, 1e-8]
}

fn default_stroke() -> f64 {
    24e-6
}

fn default_pid() -> [f64; 3] {
    [0.0, 300.0, 0.0]
}

impl Controller {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        for i in 0..2 {
            positive(
                &format!("controller.observer_gain[{i}]"),
                self.observer_gain[i],
            )?;
            positive(&format!("controller.error_gain[{i}]"), self.error_gain[i])?;
            positive(
                &format!("controller.feedback_gain[{i}]"),
                self.feedback_gain[i],
            )?;
            check(
                &format!("controller.eta_gain[{i}]"),
                self.eta_gain[i],
                self.eta_gain[i] > 1.0,
                "a finite number > 1 (A21)",
            )?;
            non_negative(&format!("controller.eta_bound[{i}]"), self.eta_bound[i])?;
            non_negative(&format!("controller.a_bound[{i}]"), self.a_bound[i])?;
            non_negative(
                &format!("controller.boundary_layer[{i}]"),
                self.boundary_layer[i],
            )?;
        }
        positive("controller.stroke", self.stroke)?;
        positive("controller.disturbance_gain", self.disturbance_gain)?;
        for (i, g) in self.pid.iter().enumerate() {
            non_negative(&format!("controller.pid[{i}]"), *g)?;
        }
        Ok(())
    }
}

/// Capacitive position sensors (Section 4.1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sensors {
    /// Quantization step of the q1 and q2 sensors \[m\]. Section 4.1: 7.5e-9, 10e-9.
    #[serde(deserialize_with = "crate::strict::array")]
    pub resolution: [f64; 2],
    /// Standard deviation of white measurement noise \[m\].
    #[serde(deserialize_with = "crate::strict::array")]
    pub noise_std: [f64; 2],
}

impl Sensors {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        for i in 0..2 {
            non_negative(&format!("sensors.resolution[{i}]"), self.resolution[i])?;
            non_negative(&format!("sensors.noise_std[{i}]"), self.noise_std[i])?;
        }
        Ok(())
    }
}

/// Timing of the simulated experiment (Section 4.1, DECISIONS.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Simulation {
    /// Controller sample time T_s \[s\]. Section 4.1: 1e-4.
    pub sample_time: f64,
    /// Plant integration substeps per sample (DECISIONS.md: much finer than T_s).
    pub substeps: usize,
    /// Seed of the noise generator, for reproducible runs.
    pub seed: u64,
    /// Amplifier bandwidth \[Hz\] (first-order lag of the voltage); 0 = ideal zero-order hold.
    #[serde(default)]
    pub amplifier_bandwidth: f64,
}

impl Simulation {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        check(
            "simulation.sample_time",
            self.sample_time,
            self.sample_time > 0.0 && self.sample_time <= 0.1,
            "a number in (0, 0.1] s",
        )?;
        non_negative("simulation.amplifier_bandwidth", self.amplifier_bandwidth)?;
        count("simulation.substeps", self.substeps, 1, 10_000)
    }
}

/// A reference trajectory of the output q (Section 4.2), centred on the rest position.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Trajectory {
    /// q1 = A1 sin(r·2πft), q2 = A2 sin(2πft): a Lissajous curve with frequency ratio r.
    Lissajous {
        /// Name used for output files.
        name: String,
        /// Frequency ratio r of q1 to q2 (3 and 2 in the paper).
        ratio: f64,
        /// Amplitudes (A1, A2) \[m\].
        #[serde(deserialize_with = "crate::strict::array")]
        amplitude: [f64; 2],
        /// Base frequency f \[Hz\].
        frequency: f64,
        /// Duration \[s\].
        duration: f64,
    },
    /// A circle of the given radius.
    Circle {
        /// Name used for output files.
        name: String,
        /// Radius \[m\].
        radius: f64,
        /// Frequency \[Hz\].
        frequency: f64,
        /// Duration \[s\].
        duration: f64,
    },
}

impl Trajectory {
    /// The name used for output files.
    pub fn name(&self) -> &str {
        match self {
            Trajectory::Lissajous { name, .. } | Trajectory::Circle { name, .. } => name,
        }
    }

    /// Checks every field; `field` is the TOML path of this entry.
    pub fn validate(&self, field: &str) -> Result<()> {
        /// A trajectory amplitude: 0 (a still axis, if `zero`) or at least a nanometre, below
        /// every sensor's resolution (a subnormal amplitude gave an error of ∞ % of range).
        fn amplitude_range(field: &str, a: f64, zero: bool) -> Result<()> {
            let min = crate::design::MIN_STROKE;
            if zero {
                check(
                    field,
                    a,
                    a == 0.0 || a >= min,
                    &format!("0 or a number ≥ {min:e} m"),
                )
            } else {
                check(field, a, a >= min, &format!("a number ≥ {min:e} m"))
            }
        }
        let name_ok = |name: &str| file_name(&format!("{field}.name"), name);
        match self {
            Trajectory::Lissajous {
                name,
                ratio,
                amplitude,
                frequency,
                duration,
            } => {
                name_ok(name)?;
                positive(&format!("{field}.ratio"), *ratio)?;
                for (i, a) in amplitude.iter().enumerate() {
                    amplitude_range(&format!("{field}.amplitude[{i}]"), *a, true)?;
                }
                positive(&format!("{field}.frequency"), *frequency)?;
                positive(&format!("{field}.duration"), *duration)
            }
            Trajectory::Circle {
                name,
                radius,
                frequency,
                duration,
            } => {
                name_ok(name)?;
                amplitude_range(&format!("{field}.radius"), *radius, false)?;
                positive(&format!("{field}.frequency"), *frequency)?;
                positive(&format!("{field}.duration"), *duration)
            }
        }
    }
}
