//! Parameters of the verification ([`VerifyParams`]) with their accepted ranges.

use crate::error::{Result, check};

/// Al 6061-T6 fatigue strength \[Pa\]: 96.5 MPa at 5·10⁸ cycles, completely reversed stress
/// (ASM Aerospace Specification Metals, "Aluminum 6061-T6; 6061-T651" data sheet; the same
/// value as MatWeb's). The stress at the stroke corners is fully reversed (the corner
/// `(−a, +a)` is the negative of `(+a, −a)` in a linear model), so the amplitude is the peak.
pub const AL6061_T6_FATIGUE_STRENGTH: f64 = 96.5e6;

/// Al 6061-T6 tensile yield strength \[Pa\]: 276 MPa (same source).
pub const AL6061_T6_YIELD_STRENGTH: f64 = 276e6;

/// Default safety factor on the fatigue strength: 1.5, the lower end of the range that
/// machine-design texts give for well-known materials under well-known loads (e.g. Juvinall
/// & Marshek, *Fundamentals of Machine Component Design*, Sec. 6.12: 1.25–1.5).
pub const DEFAULT_SAFETY_FACTOR: f64 = 1.5;

/// Parameters of [`crate::verify()`]: the sign-off limits and the body-fitted mesh.
///
/// All lengths in metres, stresses in pascals.
#[derive(Debug, Clone, PartialEq)]
pub struct VerifyParams {
    /// Fatigue strength of the material \[Pa\], in (0, 10 GPa]. Default
    /// [`AL6061_T6_FATIGUE_STRENGTH`].
    pub fatigue_strength: f64,
    /// Yield strength of the material \[Pa\], in (0, 10 GPa]; reported beside the peak stress.
    /// Default [`AL6061_T6_YIELD_STRENGTH`].
    pub yield_strength: f64,
    /// Safety factor, in [1, 10]: allowable = fatigue strength / safety factor. Default
    /// [`DEFAULT_SAFETY_FACTOR`].
    pub safety_factor: f64,
    /// Minimum hinge (ligament) thickness \[m\], in [0, 50 mm]. Default 0.5 mm.
    pub min_ligament: f64,
    /// Minimum slot (gap) width \[m\], e.g. the wire-EDM kerf, in [0, 50 mm]. Default 0.4 mm.
    pub min_gap: f64,
    /// Diameter of a wire-EDM start hole \[m\], in (0, 20 mm]: a pocket (a hole inside the part)
    /// must fit one. Default 1 mm.
    pub start_hole_diameter: f64,
    /// Elements across the thinnest part of a ligament (quadratic triangles), in [1, 32].
    /// Default 4.
    pub elements_across: f64,
    /// Smallest element edge \[m\], in [1 µm, 10 mm] (bounds the work at very thin necks).
    /// Default 20 µm.
    pub min_element: f64,
    /// Largest element edge \[m\], in [min_element, 100 mm]; `None`: the design mesh's element
    /// size. Default `None`.
    pub max_element: Option<f64>,
    /// Largest angle a boundary segment may turn through \[deg\], in [2, 45]: sets the element
    /// size along curved boundaries (fillets, notches). Default 15.
    pub segment_angle_deg: f64,
    /// Size gradation along the boundary: neighbouring segment lengths differ by at most this
    /// fraction of their distance, in [0.05, 1]. Default 0.3.
    pub gradation: f64,
    /// Minimum angle of the refined Delaunay mesh \[deg\], in [5, 30]. Default 25.
    pub angle_limit_deg: f64,
    /// Radius \[m\] around a port's point within which the outline boundary is loaded by (or
    /// attached to) the port, in (0, 50 mm]; `None`: 1.5 design elements (the passive port
    /// patches are 3 elements wide). Default `None`.
    pub port_radius: Option<f64>,
    /// Attach each port to the one boundary node nearest its point instead of the distributing
    /// coupling (a point port, the idealization of a port at one node; for the comparison of
    /// the two port models, `docs/verification.md`). Default false.
    pub point_ports: bool,
    /// Node budget of the body-fitted mesh, in [100, 20,000,000]. Default 3,000,000.
    pub max_nodes: usize,
    /// Natural frequencies to compute, in [1, 20]. Default 3.
    pub modes: usize,
    /// Put the input-plate masses of the scenario (`stage.guess.m_in1/2`) on the input ports
    /// in the modal analysis, as `flexstage-reduce` does. Default true.
    pub plate_masses: bool,
    /// Also analyse the design mesh (Q4) for the side-by-side comparison. Default true.
    pub compare_design_mesh: bool,
    /// Re-check the peak stress on a mesh of half the element size everywhere (the verdict
    /// uses the larger value). Default true.
    pub refine_check: bool,
}

impl Default for VerifyParams {
    fn default() -> Self {
        Self {
            fatigue_strength: AL6061_T6_FATIGUE_STRENGTH,
            yield_strength: AL6061_T6_YIELD_STRENGTH,
            safety_factor: DEFAULT_SAFETY_FACTOR,
            min_ligament: 0.5e-3,
            min_gap: 0.4e-3,
            start_hole_diameter: 1e-3,
            elements_across: 4.0,
            min_element: 20e-6,
            max_element: None,
            segment_angle_deg: 15.0,
            gradation: 0.3,
            angle_limit_deg: 25.0,
            port_radius: None,
            point_ports: false,
            max_nodes: 3_000_000,
            modes: 3,
            plate_masses: true,
            compare_design_mesh: true,
            refine_check: true,
        }
    }
}

impl VerifyParams {
    /// The defaults with the sign-off limits of a scenario's `limits` group: fatigue and yield
    /// strength, safety factor, minimum hinge thickness (as the minimum ligament) and minimum
    /// slot width (as the minimum gap), so the verification checks the design against the
    /// limits the optimizer designed it for.
    pub fn from_limits(l: &flexstage_scenario::Limits) -> Self {
        VerifyParams {
            fatigue_strength: l.fatigue_strength,
            yield_strength: l.yield_strength,
            safety_factor: l.safety_factor,
            min_ligament: l.min_hinge_thickness,
            min_gap: l.min_slot_width,
            ..VerifyParams::default()
        }
    }

    /// Allowable von Mises stress \[Pa\]: fatigue strength / safety factor.
    pub fn allowable_stress(&self) -> f64 {
        self.fatigue_strength / self.safety_factor
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        let stress = |f, v: f64| check(f, v, v > 0.0 && v <= 1e10, "(0, 1e10] Pa");
        stress("VerifyParams::fatigue_strength", self.fatigue_strength)?;
        stress("VerifyParams::yield_strength", self.yield_strength)?;
        check(
            "VerifyParams::safety_factor",
            self.safety_factor,
            (1.0..=10.0).contains(&self.safety_factor),
            "[1, 10]",
        )?;
        let width = |f, v: f64| check(f, v, (0.0..=0.05).contains(&v), "[0, 0.05] m");
        width("VerifyParams::min_ligament", self.min_ligament)?;
        width("VerifyParams::min_gap", self.min_gap)?;
        check(
            "VerifyParams::start_hole_diameter",
            self.start_hole_diameter,
            self.start_hole_diameter > 0.0 && self.start_hole_diameter <= 0.02,
            "(0, 0.02] m",
        )?;
        check(
            "VerifyParams::elements_across",
            self.elements_across,
            (1.0..=32.0).contains(&self.elements_across),
            "[1, 32]",
        )?;
        check(
            "VerifyParams::min_element",
            self.min_element,
            (1e-6..=1e-2).contains(&self.min_element),
            "[1e-6, 1e-2] m",
        )?;
        if let Some(h) = self.max_element {
            check(
                "VerifyParams::max_element",
                h,
                h >= self.min_element && h <= 0.1,
                "[min_element, 0.1] m",
            )?;
        }
        check(
            "VerifyParams::segment_angle_deg",
            self.segment_angle_deg,
            (2.0..=45.0).contains(&self.segment_angle_deg),
            "[2, 45] deg",
        )?;
        check(
            "VerifyParams::gradation",
            self.gradation,
            (0.05..=1.0).contains(&self.gradation),
            "[0.05, 1]",
        )?;
        check(
            "VerifyParams::angle_limit_deg",
            self.angle_limit_deg,
            (5.0..=30.0).contains(&self.angle_limit_deg),
            "[5, 30] deg",
        )?;
        if let Some(r) = self.port_radius {
            check(
                "VerifyParams::port_radius",
                r,
                r > 0.0 && r <= 0.05,
                "(0, 0.05] m",
            )?;
        }
        check(
            "VerifyParams::max_nodes",
            self.max_nodes as f64,
            (100..=20_000_000).contains(&self.max_nodes),
            "[100, 20000000]",
        )?;
        check(
            "VerifyParams::modes",
            self.modes as f64,
            (1..=20).contains(&self.modes),
            "[1, 20]",
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_bad_values_name_the_field() {
        let p = VerifyParams::default();
        p.validate().unwrap();
        assert!((p.allowable_stress() - 96.5e6 / 1.5).abs() < 1.0);
        let bad = VerifyParams {
            safety_factor: 0.5,
            ..p.clone()
        };
        let msg = bad.validate().unwrap_err().to_string();
        assert!(
            msg.contains("VerifyParams::safety_factor") && msg.contains("[1, 10]"),
            "{msg}"
        );
        let bad = VerifyParams {
            max_element: Some(1e-6),
            ..p
        };
        assert!(
            bad.validate()
                .unwrap_err()
                .to_string()
                .contains("max_element")
        );
    }
}
