//! `design/`: the finished design (`design.json`), its headline numbers (`summary.json`) and
//! the output polygons (tables of `x_out_um`, `y_out_um`).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::format::{Format, check_version, from_json, json, json_sorted};

/// The format version of `design.json`.
pub const DESIGN_VERSION: u32 = 1;

/// `design/design.json`: a finished design.
///
/// To rebuild the model of a design: load the run's `scenario.toml`, build the final-analysis
/// problem of `flexstage-topopt` (total Lagrangian, no additive material) and use
/// [`DesignFile::rho`] as the physical densities, in fem element order `e = i·n_w + j`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DesignFile {
    /// Format version ([`DESIGN_VERSION`]).
    pub version: u32,
    /// Scenario name.
    pub scenario: String,
    /// Elements along x.
    pub nl: usize,
    /// Elements along y.
    pub nw: usize,
    /// Physical densities ρ (after filter, projection and passive overrides), fem order
    /// `e = i·n_w + j` (column i from the left, row j from the bottom).
    pub rho: Vec<f64>,
    /// Design iterations performed.
    pub iterations: usize,
    /// Workspace area of the initial design, final nonlinear analysis \[m²\].
    pub area_initial: f64,
    /// Workspace area of this design, final nonlinear analysis \[m²\].
    pub area: f64,
    /// Fraction of design elements with 0.1 < ρ < 0.9.
    pub grey_fraction: f64,
    /// What the design delivers (absent in files of older versions).
    #[serde(default)]
    pub summary: Option<DesignRecord>,
}

impl Format for DesignFile {
    fn encode(&self) -> Result<Vec<u8>, String> {
        json(self)
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let d: DesignFile = from_json(bytes)?;
        check_version(d.version, DESIGN_VERSION)?;
        if d.rho.len() != d.nl * d.nw || d.rho.iter().any(|r| !(0.0..=1.0).contains(r)) {
            return Err(format!(
                "rho must have nl·nw = {} entries in [0, 1], it has {}",
                d.nl * d.nw,
                d.rho.len()
            ));
        }
        Ok(d)
    }
}

/// What a finished design delivers, in the units users compare (the final analysis of
/// `flexstage-topopt`, Actuators 2022, 11(7), 179, Eq. 4 and 24–27).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DesignRecord {
    /// Workspace area of the blueprint (Eq. 4) in the configuration's orientation, `sign · J`
    /// \[m²\].
    pub area: f64,
    /// `J / (2a)²`: the workspace in units of the input stroke square.
    pub area_ratio: f64,
    /// Differential amplification α (Eq. 24–27), with the optimizer's output load.
    pub alpha: f64,
    /// Direction of the differential output's axis from +y towards +x \[deg\].
    pub theta_deg: f64,
    /// Target θ of the scenario \[deg\].
    pub theta_target_deg: f64,
    /// Mass of the blueprint \[kg\].
    pub mass: f64,
    /// Volume fraction of the design elements of the blueprint.
    pub volume_fraction: f64,
    /// Workspace area of the eroded design \[m²\] (robust formulation).
    pub area_eroded: Option<f64>,
    /// Workspace area of the dilated design \[m²\] (robust formulation).
    pub area_dilated: Option<f64>,
    /// Largest Gauss-point von Mises stress of the solid design elements at the stroke
    /// corners, on the design mesh \[Pa\].
    pub peak_stress: f64,
    /// What the stress constraint bounds (relaxed, eroded design) \[Pa\].
    #[serde(default)]
    pub constrained_stress: Option<f64>,
    /// Allowable stress `fatigue_strength / safety_factor` \[Pa\].
    pub allowable_stress: f64,
    /// The design-mesh bound `allowable / mesh_stress_factor` \[Pa\].
    pub design_allowable: f64,
    /// Number of one-node hinges at ρ = ½.
    pub one_node_hinges: usize,
    /// Thinnest solid member at ρ = ½ \[m\].
    pub thinnest_member: Option<f64>,
    /// Where the thinnest member is: (x, y) \[m\].
    #[serde(default)]
    pub thinnest_member_at: Option<[f64; 2]>,
    /// Narrowest void gap at ρ = ½ \[m\].
    pub narrowest_gap: Option<f64>,
    /// Where the narrowest gap is: (x, y) \[m\].
    #[serde(default)]
    pub narrowest_gap_at: Option<[f64; 2]>,
    /// Minimum solid size the length scale guarantees \[m\].
    pub guaranteed_member: Option<f64>,
    /// Minimum void size the length scale guarantees \[m\].
    pub guaranteed_gap: Option<f64>,
    /// Largest |ρ − ρ_mirror| about x = l/2.
    pub mirror_asymmetry: f64,
    /// Lowest natural frequency of the stage \[Hz\]: the design with the PEA springs and
    /// input plates, the rollers and the payload, at rest.
    #[serde(default)]
    pub first_frequency_hz: Option<f64>,
    /// The stage's lowest natural frequencies \[Hz\].
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub frequencies_hz: Vec<f64>,
    /// What a general mechanism (`[[ports]]`) delivers; `None` for the two-PEA stage.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mechanism: Option<MechanismRecord>,
}

/// The output of a general mechanism problem (`[[ports]]`: inverter, gripper).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MechanismRecord {
    /// Unit output direction d.
    pub direction: [f64; 2],
    /// Output displacement along d of the blueprint \[m\].
    pub output_displacement: f64,
    /// The full output displacement (u_x, u_y) \[m\].
    pub output: [f64; 2],
    /// Displacement of each input port along its driven DOF \[m\].
    pub inputs: Vec<f64>,
    /// Geometric advantage `d · u_out / u_in` of the first port.
    pub geometric_advantage: f64,
    /// `d · u_out` of the eroded design \[m\].
    pub eroded: Option<f64>,
    /// `d · u_out` of the dilated design \[m\].
    pub dilated: Option<f64>,
}

/// The format version of `design/summary.json`.
pub const SUMMARY_VERSION: u32 = 1;

/// `design/summary.json`: how the design stage ended and what it delivered (keys sorted).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignSummaryFile {
    /// Format version ([`SUMMARY_VERSION`]).
    pub version: u32,
    /// Why the loop stopped (`Converged`, `Stagnated`, `MaxIterations`).
    pub stop: String,
    /// Design iterations (all sessions).
    pub iterations: usize,
    /// Wall-clock time of the last session \[s\].
    pub seconds: f64,
    /// Mean time per iteration \[s\].
    pub seconds_per_iteration: f64,
    /// What the design delivers.
    pub design: DesignRecord,
    /// Workspace area of the uniform start design \[m²\].
    pub area_initial_m2: f64,
    /// Workspace area of the design \[m²\].
    pub area_final_m2: f64,
    /// Grey fraction of the last iteration.
    pub grey_fraction: f64,
    /// Volume fraction of the last iteration.
    pub volume: f64,
    /// Constraint values g ≤ 0 of the last iteration, by name.
    pub constraints: BTreeMap<String, f64>,
    /// Load cases that needed a cutback retry.
    pub retried_load_cases: usize,
}

impl DesignSummaryFile {
    /// How the design stage ended, in words ([`DesignSummaryFile::stop`] spells the reason as
    /// `Converged`, `Stagnated` or `MaxIterations`).
    pub fn stop_in_words(&self) -> String {
        stop_in_words(&self.stop)
    }
}

/// A design stop reason (`Converged`, `Stagnated`, `MaxIterations`) in words; another word
/// is kept, in lower case.
pub fn stop_in_words(stop: &str) -> String {
    match stop {
        "Converged" => "converged".into(),
        "Stagnated" => "stopped when it no longer improved (stagnated)".into(),
        "MaxIterations" => "stopped at its iteration limit, not converged".into(),
        other => other.to_lowercase(),
    }
}

impl Format for DesignSummaryFile {
    fn encode(&self) -> Result<Vec<u8>, String> {
        json_sorted(self)
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let s: DesignSummaryFile = from_json(bytes)?;
        check_version(s.version, SUMMARY_VERSION)?;
        Ok(s)
    }
}

/// The header of an output polygon table (µm).
pub const POLYGON: [&str; 2] = ["x_out_um", "y_out_um"];
