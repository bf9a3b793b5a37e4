//! `analyze`: nonlinear statics of a design, for given actuator inputs or for the p_m samples
//! of the workspace (Eq. 4–5), with the output polygon, its area and a VTK file.
//!
//! Every analysis gets its own folder, named after what was analysed
//! ([`AnalyzeOptions::variant`]): `analyze/workspace/` for the workspace of the run's design,
//! `analyze/inputs_30_-30/` for one input pair, `analyze/uniform_workspace/` for the uniform
//! start design, and so on. Running the same analysis again replaces its folder (the summary
//! says so); different analyses never overwrite each other.

use std::path::PathBuf;
use std::time::Instant;

use flexstage_fem::Kinematics;
use flexstage_run::files::analyze::{AnalysisSummary, VERSION};
use flexstage_run::layout::Analysis;
use flexstage_topopt::{AnalysisParams, Evaluator, Problem, shoelace};

use crate::error::{Result, require};
use crate::figures::{cases_table, polygon_svg, write_vtu};
use crate::folder::RunFolder;
use crate::source::{DesignSource, load_design};

/// The largest |nominal stroke| accepted for an analysis \[m\] (1 mm, far beyond any PEA).
pub const MAX_INPUT: f64 = 1e-3;
/// The most input pairs of one analysis.
pub const MAX_CASES: usize = 1000;

/// Options of `analyze`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AnalyzeOptions {
    /// The design; `None`: the run's design if it has a finished one, else the uniform start
    /// design.
    pub design: Option<DesignSource>,
    /// Nominal strokes (x_nom1, x_nom2) \[m\], each |x| ≤ [`MAX_INPUT`], at most [`MAX_CASES`];
    /// empty: the p_m samples of the stroke-square perimeter.
    pub inputs: Vec<[f64; 2]>,
}

impl AnalyzeOptions {
    /// Checks every option.
    pub fn validate(&self) -> Result<()> {
        require(
            self.inputs.len() <= MAX_CASES,
            "analyze.inputs",
            format!("{} pairs", self.inputs.len()),
            "at most 1000 pairs",
        )?;
        for p in &self.inputs {
            require(
                p.iter().all(|x| x.is_finite() && x.abs() <= MAX_INPUT),
                "analyze.inputs",
                format!(
                    "({} µm, {} µm)",
                    flexstage_numerics::compact(p[0] * 1e6),
                    flexstage_numerics::compact(p[1] * 1e6)
                ),
                "strokes in [-1000, 1000] µm",
            )?;
        }
        Ok(())
    }

    /// The folder name of this analysis of `design`: `[<design tag>_]workspace` or
    /// `[<design tag>_]inputs_<x1>_<x2>[_<x1>_<x2>...]` (µm); long input lists are shortened
    /// to the first pair, their count and a hash.
    pub fn variant(&self, design: &DesignSource) -> String {
        let cases = if self.inputs.is_empty() {
            "workspace".to_string()
        } else {
            let um: Vec<String> = self
                .inputs
                .iter()
                .flat_map(|p| p.map(|x| format!("{}", (x * 1e9).round() / 1e3)))
                .collect();
            let full = format!("inputs_{}", um.join("_"));
            if full.len() <= 80 {
                full
            } else {
                format!(
                    "inputs_{}_{}_and_{}_more_{:08x}",
                    um[0],
                    um[1],
                    self.inputs.len() - 1,
                    crate::state::fnv1a(full.as_bytes()) as u32
                )
            }
        };
        let name = match design.tag() {
            Some(tag) => format!("{tag}_{cases}"),
            None => cases,
        };
        crate::source::plain(&name)
    }
}

/// What `analyze` computed.
#[derive(Debug, Clone)]
pub struct AnalyzeSummary {
    /// The design analysed.
    pub design: DesignSource,
    /// Nominal strokes and outputs of each load case \[m\].
    pub cases: Vec<([f64; 2], [f64; 2])>,
    /// Newton iterations over all cases.
    pub newton_iterations: usize,
    /// Wall-clock time \[s\].
    pub seconds: f64,
    /// Workspace analysis: the polygon's area \[m²\] and the outputs of the corners (+a, +a)
    /// and (+a, −a) \[m\].
    pub workspace: Option<(f64, [[f64; 2]; 2])>,
    /// The result folder.
    pub dir: PathBuf,
    /// Whether an earlier result of the same analysis was replaced.
    pub replaced: bool,
}

/// Runs `analyze`.
pub fn analyze(folder: &RunFolder, options: &AnalyzeOptions) -> Result<AnalyzeSummary> {
    options.validate()?;
    let s = folder.scenario();
    crate::design::two_pea_stage(s, "analyze")?;
    let mut problem = Problem::from_scenario(s, Some(Kinematics::TotalLagrangian))?;
    let workspace = options.inputs.is_empty();
    if !workspace {
        problem.cases = options.inputs.iter().map(|p| p.to_vec()).collect();
        // The stress constraint's case indexes belong to the optimizer's load cases.
        problem.stress = None;
    }
    let design = options
        .design
        .clone()
        .unwrap_or_else(|| DesignSource::run_or_uniform(folder));
    let rho = load_design(folder, &design, &problem)?;
    let out = Analysis::variant(&options.variant(&design));
    let replaced = folder.has_results(out.dir());
    let run = folder.dir();
    let t = Instant::now();
    let mut ev = Evaluator::new(&problem, AnalysisParams::default())?;
    let r = ev.solve_cases(&rho, None)?;
    if workspace {
        crate::error::require_area("analyze", shoelace(&r.outputs))?;
    }
    let seconds = t.elapsed().as_secs_f64();
    run.store(&out.cases(), cases_table(&problem, &r))?;
    // The deformed mesh at the compressive corner (workspace) or the first given case.
    let k_vtk = if workspace {
        problem.differential_corners().0
    } else {
        0
    };
    write_vtu(run, &out.vtu(), &problem, &rho, &ev.cases[k_vtk].u)?;
    let newton_iterations = r.newton_iterations.iter().sum::<usize>();
    let workspace = if workspace {
        let area = shoelace(&r.outputs);
        let svg = polygon_svg("Output workspace", &[("design".into(), &r.outputs)])?;
        run.write(&out.workspace_svg(), svg.as_bytes())?;
        let corners = [r.outputs[0], r.outputs[problem.cases.len() / 4]];
        Some((area, corners))
    } else {
        None
    };
    let summary = AnalysisSummary {
        version: VERSION,
        design: design.to_string(),
        cases: r.outputs.len(),
        newton_iterations,
        seconds,
        area_m2: workspace.map(|(a, _)| a),
    };
    run.store(&out.summary(), summary)?;
    Ok(AnalyzeSummary {
        design,
        cases: problem
            .cases
            .iter()
            .zip(&r.outputs)
            .map(|(c, o)| ([c[0], c.get(1).copied().unwrap_or(0.0)], *o))
            .collect(),
        newton_iterations,
        seconds,
        workspace,
        dir: run.path(out.dir()),
        replaced,
    })
}

/// The folder of the workspace analysis of the run's design (what `analyze` writes with no
/// options once the run has a finished design).
pub fn default_analysis() -> Analysis {
    Analysis::variant(&AnalyzeOptions::default().variant(&DesignSource::Run))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_analysis_has_its_own_folder() {
        // Goal: the cases the issue named never share a folder.
        let w = AnalyzeOptions::default();
        let one = AnalyzeOptions {
            design: None,
            inputs: vec![[30e-6, -30e-6]],
        };
        assert_eq!(w.variant(&DesignSource::Run), "workspace");
        assert_eq!(one.variant(&DesignSource::Run), "inputs_30_-30");
        assert_eq!(
            one.variant(&DesignSource::Uniform(None)),
            "uniform_inputs_30_-30"
        );
        assert_eq!(
            w.variant(&DesignSource::Uniform(Some(0.5))),
            "uniform-0.5_workspace"
        );
        let many = AnalyzeOptions {
            design: None,
            inputs: (0..40).map(|k| [k as f64 * 1e-6, 0.0]).collect(),
        };
        let mut other = many.clone();
        other.inputs[39][1] = 1e-6;
        let (a, b) = (
            many.variant(&DesignSource::Run),
            other.variant(&DesignSource::Run),
        );
        assert!(
            a.len() <= 100 && flexstage_run::layout::is_plain_name(&a),
            "{a}"
        );
        assert_ne!(a, b, "long lists differ by their hash");
        assert_eq!(default_analysis().dir(), "analyze/workspace");
    }

    #[test]
    fn inputs_are_bounded() {
        let bad = AnalyzeOptions {
            design: None,
            inputs: vec![[2e-3, 0.0]],
        };
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("analyze.inputs") && e.contains("2000 µm"), "{e}");
    }
}
