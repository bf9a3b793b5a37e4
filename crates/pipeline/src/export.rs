//! `export`: the manufacturing outline of a design (paper Section 4.1, wire-cut from a
//! plate): the ρ = level iso-contour as DXF and SVG closed polylines, and a binary STL extruded
//! by the plate thickness; then the verification of that outline (`flexstage-verify`:
//! body-fitted stress, α and first frequency beside the design mesh's, manufacturability
//! findings, the verdict).

use std::path::PathBuf;

use flexstage_fem::Kinematics;
use flexstage_run::layout::export as files;
use flexstage_topopt::Problem;
use flexstage_verify::outline::{Outline, Unit};
use flexstage_verify::{Verification, VerifyParams};

use crate::error::{PipelineError, Result, require};
use crate::folder::RunFolder;
use crate::source::{DesignSource, load_design};

/// Options of `export`.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportOptions {
    /// The design. Default: the run's finished design.
    pub design: DesignSource,
    /// Length unit of the files. Default millimetres.
    pub unit: Unit,
    /// Density level of the contour, in (0, 1). Default 0.5.
    pub level: f64,
    /// Taubin smoothing passes, in [0, 1000] (0: the raw marching-squares polygon).
    /// Default 10.
    pub smoothing: usize,
    /// Longest chord of the exported curve \[m\], in [0, 10 mm] (a centripetal Catmull–Rom
    /// curve through the smoothed contour; 0: the polygon itself). Default 0.05 mm.
    pub max_chord: f64,
    /// The verification of the exported outline (`None`: skipped). Default: the scenario's
    /// `limits` ([`VerifyParams::from_limits`]) with no override.
    pub verify: Option<LimitOverrides>,
}

/// Sign-off limits of the verification that replace the scenario's `limits` group (`None`:
/// the scenario's value). Lengths in metres, stresses in pascals.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LimitOverrides {
    /// Fatigue strength \[Pa\] (else `limits.fatigue_strength`).
    pub fatigue_strength: Option<f64>,
    /// Safety factor (else `limits.safety_factor`).
    pub safety_factor: Option<f64>,
    /// Minimum ligament \[m\] (else `limits.min_hinge_thickness`).
    pub min_ligament: Option<f64>,
    /// Minimum gap \[m\] (else `limits.min_slot_width`).
    pub min_gap: Option<f64>,
    /// Wire-EDM start-hole diameter \[m\] (else [`VerifyParams`]' default, 1 mm).
    pub start_hole_diameter: Option<f64>,
}

impl LimitOverrides {
    /// The verification parameters: the scenario's limits, then these overrides.
    pub fn params(&self, limits: &flexstage_scenario::Limits) -> VerifyParams {
        let base = VerifyParams::from_limits(limits);
        VerifyParams {
            fatigue_strength: self.fatigue_strength.unwrap_or(base.fatigue_strength),
            safety_factor: self.safety_factor.unwrap_or(base.safety_factor),
            min_ligament: self.min_ligament.unwrap_or(base.min_ligament),
            min_gap: self.min_gap.unwrap_or(base.min_gap),
            start_hole_diameter: self.start_hole_diameter.unwrap_or(base.start_hole_diameter),
            ..base
        }
    }
}

impl Default for ExportOptions {
    fn default() -> Self {
        ExportOptions {
            design: DesignSource::Run,
            unit: Unit::Millimetres,
            level: 0.5,
            smoothing: 10,
            max_chord: 0.05e-3,
            verify: Some(LimitOverrides::default()),
        }
    }
}

impl ExportOptions {
    /// Checks every option.
    pub fn validate(&self) -> Result<()> {
        require(
            self.level > 0.0 && self.level < 1.0,
            "export.level",
            self.level,
            "a density in (0, 1)",
        )?;
        require(
            self.smoothing <= 1000,
            "export.smoothing",
            self.smoothing,
            "an integer in [0, 1000]",
        )?;
        require(
            (0.0..=10e-3).contains(&self.max_chord),
            "export.max_chord",
            self.max_chord,
            "a length in [0, 0.01] m",
        )?;
        if let Some(v) = &self.verify {
            // The overrides by their option names (SI units, as the other options).
            v.params(&flexstage_scenario::Limits::default())
                .validate()
                .map_err(|e| match e {
                    flexstage_verify::VerifyError::OutOfRange {
                        field,
                        value,
                        range,
                    } => PipelineError::Option {
                        option: match field {
                            "VerifyParams::fatigue_strength" => "export.fatigue_strength",
                            "VerifyParams::safety_factor" => "export.safety_factor",
                            "VerifyParams::min_ligament" => "export.min_ligament",
                            "VerifyParams::min_gap" => "export.min_gap",
                            "VerifyParams::start_hole_diameter" => "export.start_hole_diameter",
                            other => other,
                        },
                        value: flexstage_numerics::compact(value),
                        expected: format!("a value in {range}"),
                    },
                    e => e.into(),
                })?;
        }
        Ok(())
    }
}

/// What `export` wrote.
#[derive(Debug, Clone)]
pub struct ExportSummary {
    /// The design exported.
    pub design: DesignSource,
    /// Number of closed loops (outer boundaries and holes).
    pub loops: usize,
    /// Area enclosed by the outline \[m²\].
    pub area: f64,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// Whether earlier export files were replaced.
    pub replaced: bool,
    /// The verification (`None` if skipped or failed).
    pub verification: Option<Box<Verification>>,
    /// Why the verification could not be done (the design is then not called safe).
    pub verify_error: Option<String>,
}

impl ExportSummary {
    /// Is the design verified safe?
    pub fn safe(&self) -> bool {
        self.verification.as_ref().is_some_and(|v| v.verdict.safe)
    }
}

/// Exports the outline to [`files::DXF`], [`files::SVG`] and [`files::STL`].
pub fn export(folder: &RunFolder, options: &ExportOptions) -> Result<ExportSummary> {
    options.validate()?;
    let s = folder.scenario();
    let problem = Problem::from_scenario(s, Some(Kinematics::TotalLagrangian))?;
    let rho = load_design(folder, &options.design, &problem)?;
    let (nl, nw) = (s.mesh.nl, s.mesh.nw);
    let (dx, dy) = (s.mesh.length / nl as f64, s.mesh.width / nw as f64);
    let outline = Outline::from_fem_order(nl, nw, dx, dy, options.level, options.smoothing, &rho)?
        .refined(options.max_chord);
    let replaced = folder.has_results(files::DIR);
    let run = folder.dir();
    let unit = options.unit;
    let (mut verification, mut verify_error) = (None, None);
    if Problem::is_mechanism(s) && options.verify.is_some() {
        verify_error = Some(
            "not applicable: the body-fitted verification loads the two PEA ports at the \
             stroke corners; a [[ports]] mechanism gets its outline only"
                .into(),
        );
    } else if let Some(o) = &options.verify {
        let p = o.params(&s.limits);
        p.validate()?;
        match flexstage_verify::verify(s, &rho, &outline.loops, &p) {
            Ok(v) => verification = Some(Box::new(v)),
            Err(e) => verify_error = Some(e.to_string()),
        }
    }
    // The drawing of the part as made: pockets too small for the start hole left solid, as
    // the verification checked it.
    let filled: Vec<usize> = verification
        .as_ref()
        .map(|v| {
            v.manufacturing
                .filled
                .iter()
                .map(|f| f.outline_loop)
                .collect()
        })
        .unwrap_or_default();
    let outline = outline.with_filled(&filled);
    let mut files = vec![
        run.write(files::DXF, &outline.to_dxf(unit)?)?,
        run.write(files::SVG, outline.to_svg(unit).as_bytes())?,
        run.write(files::STL, &outline.to_stl(s.mesh.thickness, unit))?,
    ];
    if let Some(v) = &verification {
        let mut text = v.summary_lines().join("\n");
        text.push('\n');
        run.store(files::VERIFICATION_JSON, crate::convert::verification(v))?;
        files.push(run.path(files::VERIFICATION_JSON));
        files.push(run.write(files::VERIFICATION_TXT, text.as_bytes())?);
        files.push(run.write(files::BODY_FITTED_VTU, v.to_vtu().as_bytes())?);
    }
    Ok(ExportSummary {
        design: options.design.clone(),
        loops: outline.loops.len(),
        area: outline.area(),
        files,
        replaced,
        verification,
        verify_error,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexstage_scenario::Limits;

    /// Goal: the verification signs off against the scenario's `limits` (the ones the optimizer
    /// designed for) unless an option overrides a field.
    #[test]
    fn verification_limits_default_to_the_scenario_and_options_override_them() {
        let limits = Limits {
            fatigue_strength: 120e6,
            safety_factor: 2.0,
            min_hinge_thickness: 0.7e-3,
            min_slot_width: 0.3e-3,
            ..Limits::default()
        };
        let p = LimitOverrides::default().params(&limits);
        assert_eq!(p.fatigue_strength, 120e6);
        assert_eq!(p.safety_factor, 2.0);
        assert_eq!(p.allowable_stress(), limits.allowable_stress());
        assert_eq!(p.min_ligament, 0.7e-3);
        assert_eq!(p.min_gap, 0.3e-3);
        let o = LimitOverrides {
            safety_factor: Some(3.0),
            min_gap: Some(0.5e-3),
            ..LimitOverrides::default()
        };
        let p = o.params(&limits);
        assert_eq!((p.fatigue_strength, p.safety_factor), (120e6, 3.0));
        assert_eq!((p.min_ligament, p.min_gap), (0.7e-3, 0.5e-3));
    }
}
