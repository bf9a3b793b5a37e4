//! `export/verification.json`: what the body-fitted verification of the exported outline
//! found (`flexstage-verify`), every value in SI units.

use serde::{Deserialize, Serialize};

use crate::format::{Format, check_version, from_json, json};

/// The format version of `verification.json`.
pub const VERSION: u32 = 1;

/// `export/verification.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VerificationFile {
    /// Format version ([`VERSION`]).
    pub version: u32,
    /// Allowable stress = fatigue strength / safety factor \[Pa\].
    pub allowable: f64,
    /// Yield strength \[Pa\].
    pub yield_strength: f64,
    /// The body-fitted re-analysis.
    pub body_fitted: BodyFitted,
    /// The design mesh's values (if compared).
    pub design_mesh: Option<DesignMesh>,
    /// Manufacturability.
    pub manufacturing: Manufacturing,
    /// The verdict.
    pub verdict: Verdict,
}

impl Format for VerificationFile {
    fn encode(&self) -> Result<Vec<u8>, String> {
        json(self)
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let v: VerificationFile = from_json(bytes)?;
        check_version(v.version, VERSION)?;
        Ok(v)
    }
}

/// A peak von Mises stress: its value \[Pa\], where \[m\] and at which strokes \[m\].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StressPeak {
    /// Von Mises stress \[Pa\].
    pub von_mises: f64,
    /// Where (x, y) \[m\].
    pub at: [f64; 2],
    /// The stroke corner (x_nom1, x_nom2) \[m\].
    pub case: [f64; 2],
}

/// The transfer matrix α (Eq. 24–27): global and moving frame, scalar α and θ.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Transfer {
    /// ∂q/∂x_in, global frame.
    pub alpha_abs: [[f64; 2]; 2],
    /// α in the moving frame (Eq. 24).
    pub alpha: [[f64; 2]; 2],
    /// Scalar α (Eq. 27).
    pub alpha_scalar: f64,
    /// θ (Eq. 26) \[deg\].
    pub theta_deg: f64,
}

/// The body-fitted re-analysis of the outline.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodyFitted {
    /// Mesh nodes.
    pub nodes: usize,
    /// T6 elements.
    pub elements: usize,
    /// Unknowns.
    pub dofs: usize,
    /// Shortest and longest element edge \[m\].
    pub edge_range: [f64; 2],
    /// Area of the outline \[m²\].
    pub area: f64,
    /// Mass \[kg\].
    pub mass: f64,
    /// Peak von Mises stress at the stroke corners.
    pub stress: StressPeak,
    /// The same on a mesh of half the element size.
    pub stress_refined: Option<StressPeak>,
    /// Elements of the refined mesh.
    pub refined_elements: usize,
    /// The transfer matrix.
    pub transfer: Transfer,
    /// The lowest natural frequencies \[Hz\].
    pub frequencies: Vec<f64>,
}

/// The same quantities on the Q4 design mesh.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignMesh {
    /// Q4 elements.
    pub elements: usize,
    /// Element size \[m\].
    pub element_size: f64,
    /// Mass \[kg\].
    pub mass: f64,
    /// Peak von Mises stress (nonlinear kinematics).
    pub stress: StressPeak,
    /// Peak von Mises stress with linear kinematics \[Pa\].
    pub stress_linear: f64,
    /// The transfer matrix.
    pub transfer: Transfer,
    /// First natural frequency \[Hz\].
    pub first_frequency: f64,
}

/// The thinnest ligament or narrowest gap: its width \[m\] and where \[m\].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Width {
    /// Width \[m\].
    pub width: f64,
    /// Where (x, y) \[m\].
    pub at: [f64; 2],
}

/// One manufacturability finding.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Finding {
    /// `island`, `thin_ligament`, `narrow_gap`, `pocket`, `pocket_too_small`.
    pub kind: String,
    /// `error` or `note`.
    pub severity: String,
    /// Where (x, y) \[mm\].
    pub at_mm: [f64; 2],
    /// Its size \[m\].
    pub size: f64,
    /// In words.
    pub message: String,
}

/// Wire-EDM manufacturability of the outline.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manufacturing {
    /// The thinnest ligament.
    pub min_ligament: Option<Width>,
    /// The narrowest gap.
    pub min_gap: Option<Width>,
    /// Parts no port or support holds.
    pub islands: usize,
    /// Closed pockets (start holes).
    pub pockets: usize,
    /// Every finding.
    pub findings: Vec<Finding>,
    /// Pockets too small for the start hole, left solid in the part as made (the stress,
    /// frequencies and mass are of the filled part). Absent when none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub filled: Vec<FilledPocket>,
}

/// A pocket too small for the wire's start hole, filled (left solid) in the part as made.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilledPocket {
    /// Centre of its largest inscribed disc (x, y) \[m\].
    pub at: [f64; 2],
    /// Area \[m²\].
    pub area: f64,
    /// Diameter of its largest inscribed disc \[m\].
    pub inscribed: f64,
    /// Mass added by the filling \[kg\].
    pub mass: f64,
}

/// The verdict.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Verdict {
    /// Stress within the allowable and no manufacturability error.
    pub safe: bool,
    /// Stress within the allowable.
    pub stress_ok: bool,
    /// No manufacturability error.
    pub manufacturable: bool,
    /// Why not, in words.
    pub reasons: Vec<String>,
}
