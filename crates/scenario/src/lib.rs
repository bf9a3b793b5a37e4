//! The flexstage input deck.
//!
//! A run is described by one TOML *scenario*: the design domain and mesh, the material, the
//! actuators, supports, output port and passive regions (paper Section 2), the optimization
//! settings (Table 3), the piezo hysteresis (Table A1), the reduced stage model and the
//! controller (Table 4), the sensors and the reference trajectories (Section 4).
//!
//! [`Scenario::paper`] is the built-in default and reproduces the paper, with the defaults of
//! `DECISIONS.md` where the paper is silent. Every group has a `validate()` that names the field,
//! the value and the accepted range; unknown keys are rejected when parsing.
//!
//! # General mechanism problems
//! `[[ports]]` replace the two PEAs for other compliant mechanisms (Sigmund's displacement
//! inverter, a gripper; `examples/scenarios/`): each [`Port`] is one node, a direction along
//! x or y, an input spring `k_in` and either a `force` f or a free `displacement` x_nom of the
//! source (`f = k_in · x_nom`). `output.direction` ([`Output::direction`]) is the direction d
//! whose output displacement `d · u_out` the `displacement` objective maximizes, against
//! `optimization.output_spring` acting along d. Constraints switch off with
//! `optimization.energy_constraint`, `stress_constraint` (must be off with ports: it is
//! evaluated at the Table 2 corners of the two-PEA stage), `mirror_symmetry`, `robust` and
//! `volume_fraction = 1`. Groups a mechanism does not use (actuators, hysteresis, stage,
//! controller, sensors, simulation, trajectories) may be omitted; supports and regions default
//! to none. Validation names the field, value and range for a zero or oblique direction, a
//! non-positive spring, a missing or doubled load, more than two ports, and (in `bounds`) a
//! port on a support that fixes its DOF, an output held along d, coinciding nodes and a
//! floating structure.
//!
//! ```toml
//! [output]
//! tilt_deg = 0.0
//! direction = [-1.0, 0.0]
//! at = { kind = "nearest", point = [4.0, 2.0] }
//!
//! [[ports]]
//! at = { kind = "nearest", point = [0.0, 2.0] }
//! direction = [1.0, 0.0]
//! spring = 0.1
//! force = 1.0
//! ```
//!
//! ```
//! use flexstage_scenario::{Preset, Scenario};
//! let text = Scenario::preset(Preset::Paper).to_commented_toml();
//! let back = Scenario::from_toml_str(&text, "example").unwrap();
//! assert_eq!(back, Scenario::paper());
//! ```

mod bounds;
mod design;
mod docs;
pub use docs::field_doc;
mod error;
mod rig;
mod stage;
mod strict;

use std::path::Path;

use serde::{Deserialize, Serialize};

pub use bounds::{DesignEstimate, LIMITS, RecordEstimate, TRACK_COLUMNS, limit};
pub use design::{
    Actuators, Additive, Configuration, Edge, Fix, KinematicsKind, Limits, Material, Mesh,
    ObjectiveKind, Optimization, Output, Port, Projection, Region, RegionKind, Selector, Support,
};
pub(crate) use error::compact;
pub use error::{RangeError, Result, ScenarioError};
pub use rig::{Amplifier, Creep, FloorVibration, Rig, SensorDynamics, Twin};
pub use stage::{
    BoucWen, Controller, Hysteresis, Sensors, Simulation, Stage, StageParams, Trajectory,
};

/// A complete flexstage scenario. See the crate documentation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Name of the scenario, used in run-folder names.
    pub name: String,
    /// Design domain and mesh.
    pub mesh: Mesh,
    /// Solid material.
    pub material: Material,
    /// The two PEAs. Optional with `[[ports]]` (then unused; default: the paper's).
    #[serde(default = "default_actuators")]
    pub actuators: Actuators,
    /// The output port.
    pub output: Output,
    /// Optimization settings.
    pub optimization: Optimization,
    /// Fatigue strength, safety factor and the smallest hinge and slot.
    #[serde(default)]
    pub limits: Limits,
    /// Piezo hysteresis and amplifier (default: the paper's, Table A1).
    #[serde(default = "default_hysteresis")]
    pub hysteresis: Hysteresis,
    /// Reduced stage model: guess and truth (default: the paper's, Table 4).
    #[serde(default = "default_stage")]
    pub stage: Stage,
    /// Observer and controller gains (default: the paper's).
    #[serde(default = "default_controller")]
    pub controller: Controller,
    /// Position sensors (default: the paper's).
    #[serde(default = "default_sensors")]
    pub sensors: Sensors,
    /// Timing of the simulated experiment (default: the paper's).
    #[serde(default = "default_simulation")]
    pub simulation: Simulation,
    /// The loop around the simulated stage, as on a rig (delay, amplifiers, PEA truth and
    /// creep, sensor dynamics and noise, floor vibration).
    #[serde(default = "default_rig")]
    pub rig: Rig,
    /// How the digital twin is built from the design.
    #[serde(default)]
    pub twin: Twin,
    /// Supports (default: none; the checks refuse a structure nothing holds).
    #[serde(default)]
    pub supports: Vec<Support>,
    /// Passive regions (default: none).
    #[serde(default)]
    pub regions: Vec<Region>,
    /// Reference trajectories (default: the paper's).
    #[serde(default = "default_trajectories")]
    pub trajectories: Vec<Trajectory>,
    /// Input ports of a general mechanism problem (one or two; e.g. Sigmund's inverter, a
    /// gripper). Empty (the default): the two PEAs of `actuators` drive the stage. Non-empty:
    /// they replace the PEAs, the objective must be `displacement` along `output.direction`,
    /// and only `design`/`export`/`analyze` apply (the later stages model the two-PEA stage).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ports: Vec<Port>,
}

fn default_rig() -> Rig {
    Rig::realistic(&Scenario::paper().hysteresis)
}

// The groups a design-only scenario (e.g. `[[ports]]`) may leave out: the paper's values.
fn default_actuators() -> Actuators {
    Scenario::paper().actuators
}
fn default_hysteresis() -> Hysteresis {
    Scenario::paper().hysteresis
}
fn default_stage() -> Stage {
    Scenario::paper().stage
}
fn default_controller() -> Controller {
    Scenario::paper().controller
}
fn default_sensors() -> Sensors {
    Scenario::paper().sensors
}
fn default_simulation() -> Simulation {
    Scenario::paper().simulation
}
fn default_trajectories() -> Vec<Trajectory> {
    Scenario::paper().trajectories
}

/// Built-in scenarios.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Preset {
    /// The paper's settings (Tables 1, 3, 4, A1): 120 × 60 mesh, p_m = 40, up to 1000
    /// iterations.
    Paper,
    /// A coarse, fast variant for first contact and tests: 48 × 24 mesh (2.5 mm elements),
    /// p_m = 16, up to 100 iterations, β doubled every 10 iterations.
    Quick,
    /// The paper's domain at twice the resolution, 240 × 120 (0.5 mm elements), so that
    /// hinges of about a millimetre span several elements; p_m = 40.
    Fine,
}

impl Preset {
    /// The names [`Preset::from_name`] accepts.
    pub const NAMES: [&'static str; 3] = ["paper", "quick", "fine"];

    /// Parses a preset name ("paper", "quick" or "fine").
    pub fn from_name(name: &str) -> Option<Preset> {
        match name {
            "paper" => Some(Preset::Paper),
            "quick" => Some(Preset::Quick),
            "fine" => Some(Preset::Fine),
            _ => None,
        }
    }
}

impl Scenario {
    /// The paper's scenario (the built-in default).
    // fn-length: data literal (the paper's Tables 1, 3, 4 and A1 written out)
    pub fn paper() -> Scenario {
        let mesh = Mesh {
            length: 0.12,
            width: 0.06,
            thickness: 0.01,
            nl: 120,
            nw: 60,
        };
        let (l, w) = (mesh.length, mesh.width);
        let pea1 = [0.0, 0.5 * w];
        let pea2 = [l, 0.5 * w];
        let out = [0.5 * l, w];
        let guess = StageParams {
            k_qo1: 5e6,
            k_qo2: 5e6,
            mass: 0.046,
            alpha: 1.012,
            k_pea1: 2.5e8,
            k_pea2: 2.5e8,
            k_in1: 1e5,
            k_in2: 1e5,
            m_in1: 0.042,
            m_in2: 0.042,
            c_qo1: 0.0,
            c_qo2: 0.0,
            c_in1: 0.0,
            c_in2: 0.0,
        };
        let truth = StageParams {
            k_qo1: 3.78e6,
            k_qo2: 4.03e6,
            k_in1: 0.92e5,
            k_in2: 0.89e5,
            ..guess.clone()
        };
        let damping_ratio = 0.02;
        let hysteresis = Hysteresis {
            voltage_min: 0.0,
            voltage_max: 1000.0,
            pea1: BoucWen {
                d_p: 6.2e-2,
                a_bw: 1.2e-2,
                b_bw: 1.9e-3,
                gamma_bw: 1.6e-3,
                delta_bw: 5.015e-4,
            },
            pea2: BoucWen {
                d_p: 6.5e-2,
                a_bw: 2.5e-2,
                b_bw: 1.8e-3,
                gamma_bw: 5.3e-3,
                delta_bw: 1.973e-4,
            },
        };
        let mut scenario = Scenario {
            name: "paper".into(),
            regions: Vec::new(),
            mesh,
            material: Material {
                youngs_modulus: 73e9,
                min_modulus: 1e3,
                poisson_ratio: 0.33,
                density: 2710.0,
            },
            actuators: Actuators {
                stiffness: 2.5e8,
                max_stroke: 60e-6,
                blocking_force: 1.5e4,
                stroke_amplitude: 30e-6,
                configuration: Configuration::Regular,
                pea1: Selector::Nearest { point: pea1 },
                pea2: Selector::Nearest { point: pea2 },
            },
            output: Output {
                at: Selector::Nearest { point: out },
                tilt_deg: 0.0,
                direction: None,
                payload: 0.0,
            },
            optimization: Optimization {
                penalty: 3.0,
                rho_min: 1e-6,
                max_iterations: 1000,
                samples: 40,
                initial_density: 0.235,
                filter_radius: 2.0,
                volume_fraction: 0.235,
                change_tolerance: 1e-3,
                kinematics: KinematicsKind::Nonlinear,
                objective: ObjectiveKind::Workspace,
                output_spring: 4e6,
                min_frequency: 0.0,
                min_workspace: 0.0,
                min_volume_fraction: 0.0,
                strain_energy_limit: 0.0,
                tilt_tolerance_deg: 1.0,
                kkt_tolerance: 1e-3,
                stagnation_window: 20,
                stagnation_tolerance: 1e-3,
                mirror_symmetry: true,
                robust: true,
                energy_constraint: true,
                stress_constraint: true,
                projection: Projection {
                    enabled: true,
                    beta_max: 16.0,
                    interval: 30,
                    eta: 0.5,
                },
                additive: Additive {
                    enabled: false,
                    initial_coefficient: 1e-5,
                    strain_threshold: 0.5,
                },
            },
            limits: Limits::default(),
            rig: Rig::realistic(&hysteresis),
            twin: Twin::default(),
            hysteresis,
            stage: Stage {
                damping_ratio,
                guess: guess.with_damping_ratio(damping_ratio),
                truth: truth.with_damping_ratio(damping_ratio),
                coupling: 0.05,
            },
            controller: Controller {
                observer_gain: [1e5, 1e5],
                // Table 4 gives k_ε = (2e4, 1.5e4) and k = (1.2e4, 1.2e3); the sampled
                // loop at 10 kHz is unstable with them (flexstage-control docs), so the
                // preset uses the retuned values.
                error_gain: [3e3, 3e3],
                feedback_gain: [3e3, 3e3],
                disturbance_gain: 3e4,
                eta_gain: [3e3, 3e3],
                eta_bound: [0.1, 0.1],
                a_bound: [1e-6, 1e-6],
                boundary_layer: [1e-4, 1e-8],
                observer_velocity: false,
                // What 0–1000 V delivers around the 500 V bias with Table A1 (PEA1: +30.5/−24.9
                // µm, flexstage-control `deliverable_stroke`), not the ±30 µm of Section 4.1.
                stroke: 24e-6,
                pid: [0.0, 300.0, 0.0],
            },
            sensors: Sensors {
                resolution: [7.5e-9, 10e-9],
                noise_std: [7.5e-9, 10e-9],
            },
            simulation: Simulation {
                sample_time: 1e-4,
                substeps: 20,
                seed: 1,
                amplifier_bandwidth: 0.0,
            },
            supports: vec![
                Support {
                    fix: Fix::Y,
                    at: Selector::Nearest { point: pea1 },
                },
                Support {
                    fix: Fix::Y,
                    at: Selector::Nearest { point: pea2 },
                },
            ],
            trajectories: vec![
                Trajectory::Lissajous {
                    name: "lissajous-3".into(),
                    ratio: 3.0,
                    amplitude: [8e-6, 16e-6],
                    frequency: 2.0,
                    duration: 1.0,
                },
                Trajectory::Lissajous {
                    name: "lissajous-2".into(),
                    ratio: 2.0,
                    amplitude: [8e-6, 16e-6],
                    frequency: 2.0,
                    duration: 1.0,
                },
                Trajectory::Circle {
                    name: "circle".into(),
                    radius: 8e-6,
                    frequency: 2.0,
                    duration: 1.0,
                },
            ],
            ports: Vec::new(),
        };
        scenario.regions = port_patches(&scenario, 3);
        scenario
    }

    /// A built-in scenario.
    pub fn preset(preset: Preset) -> Scenario {
        match preset {
            Preset::Paper => Scenario::paper(),
            Preset::Quick => {
                let mut s = Scenario::paper();
                s.name = "quick".into();
                s.mesh.nl = 48;
                s.mesh.nw = 24;
                s.optimization.samples = 16;
                s.optimization.max_iterations = 100;
                s.optimization.projection.interval = 10;
                s.regions = port_patches(&s, 2);
                s
            }
            Preset::Fine => {
                let mut s = Scenario::paper();
                s.name = "fine".into();
                s.mesh.nl = 240;
                s.mesh.nw = 120;
                s.regions = port_patches(&s, 6);
                s
            }
        }
    }

    /// Checks every group and the relations between them.
    pub fn validate(&self) -> Result<()> {
        error::file_name("name", &self.name)?;
        self.mesh.validate()?;
        self.material.validate()?;
        if self.ports.is_empty() {
            // With [[ports]] the PEAs are unused (and their default nodes may lie elsewhere).
            self.actuators.validate(&self.mesh)?;
        }
        self.output.validate(&self.mesh)?;
        design::validate_supports(&self.supports, &self.mesh)?;
        design::validate_regions(&self.regions, &self.mesh)?;
        self.optimization.validate()?;
        self.limits.validate()?;
        design::validate_ports(self)?;
        if self.optimization.mirror_symmetry && self.output.tilt_deg != 0.0 {
            return Err(ScenarioError::Inconsistent {
                fields: "optimization.mirror_symmetry, output.tilt_deg".into(),
                reason: format!(
                    "a tilted output (tilt_deg = {}) is not mirror-symmetric: set \
                     optimization.mirror_symmetry = false",
                    compact(self.output.tilt_deg)
                ),
            });
        }
        self.hysteresis.validate()?;
        self.stage.validate()?;
        self.controller.validate()?;
        self.sensors.validate()?;
        self.simulation.validate()?;
        self.rig.validate()?;
        self.twin.validate()?;
        for (i, t) in self.trajectories.iter().enumerate() {
            t.validate(&format!("trajectories[{i}]"))?;
        }
        bounds::validate(self)
    }

    /// Parses and validates a scenario. `origin` names the source in error messages.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Scenario> {
        let scenario: Scenario = toml::from_str(text).map_err(|e| ScenarioError::Parse {
            path: origin.to_string(),
            source: Box::new(e),
        })?;
        scenario.validate()?;
        Ok(scenario)
    }

    /// Reads, parses and validates a scenario file.
    pub fn load(path: &Path) -> Result<Scenario> {
        let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Scenario::from_toml_str(&text, &path.display().to_string())
    }

    /// The scenario as TOML, without comments.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a scenario always serializes to TOML")
    }

    /// The scenario as TOML with one comment per field (meaning, unit, source), as written by
    /// `flexstage init`.
    pub fn to_commented_toml(&self) -> String {
        let mut out = String::from(
            "# flexstage scenario. Units are SI unless a comment says otherwise.\n\
             # Sources: tables and equations of the paper (Actuators 2022, 11(7), 179) and docs/DECISIONS.md.\n\
             # Check it with `flexstage check FILE`.\n\n",
        );
        out.push_str(&docs::annotate(&self.to_toml()));
        out
    }
}

/// Solid patches at the two input ports and the output port (DECISIONS.md): `n` elements deep
/// from the edge, and along the edge the elements whose centroids lie within `n/2 + 1/4`
/// element sizes of the port (the quarter element keeps centroids off the box edges, so the
/// selection does not depend on rounding and stays mirror-symmetric).
fn port_patches(s: &Scenario, n: usize) -> Vec<Region> {
    let (dx, dy) = s.mesh.element_size();
    let (l, w) = (s.mesh.length, s.mesh.width);
    let nf = n as f64;
    // Depth: centroids at (k + ½)·d, k < n, all at least ½ d inside the box.
    let (deep_x, deep_y) = (nf * dx, nf * dy);
    // Along the edge: half-widths with the quarter-element margin.
    let (half_x, half_y) = ((0.5 * nf + 0.25) * dx, (0.5 * nf + 0.25) * dy);
    let solid = |min: [f64; 2], max: [f64; 2]| Region {
        kind: RegionKind::Solid,
        at: Selector::Box { min, max },
    };
    vec![
        solid([0.0, 0.5 * w - half_y], [deep_x, 0.5 * w + half_y]),
        solid([l - deep_x, 0.5 * w - half_y], [l, 0.5 * w + half_y]),
        solid([0.5 * l - half_x, w - deep_y], [0.5 * l + half_x, w]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_key_has_a_comment() {
        for preset in [Preset::Paper, Preset::Quick, Preset::Fine] {
            let text = Scenario::preset(preset).to_commented_toml();
            let lines: Vec<&str> = text.lines().collect();
            for (i, line) in lines.iter().enumerate() {
                let t = line.trim();
                if t.is_empty() || t.starts_with('#') {
                    continue;
                }
                assert!(
                    i > 0 && lines[i - 1].trim_start().starts_with('#'),
                    "line {} has no comment above it: {t}",
                    i + 1
                );
            }
        }
    }
}
