//! `reduce`: the reduced spring–mass model of a design (Section 3.2.1): transfer matrix α by
//! static condensation (Eq. 23–24), the lumped stage parameters (Eq. 31–35) that `track` and
//! the simulated plant read, modal analysis with the Assumption-2 check, and the validity map
//! of the tangent model against nonlinear FE. The files are written by the private `reduce_files` module.

use std::path::PathBuf;

use flexstage_reduce::{
    MassLumping, ModalParams, ReduceParams, Reduction, ValidityParams, reduction_problem,
};
use flexstage_run::layout::reduce as files;

use crate::error::{Result, require};
use crate::folder::RunFolder;
use crate::progress::Progress;
use crate::source::{DesignSource, load_design};

/// Options of `reduce`.
#[derive(Debug, Clone, PartialEq)]
pub struct ReduceOptions {
    /// The design; `None`: the run's design if it has a finished one, else the uniform start
    /// design.
    pub design: Option<DesignSource>,
    /// Take the tangent at these nominal strokes \[m\] (each |x| ≤ 1 mm) instead of the
    /// undeformed state.
    pub operating_point: Option<[f64; 2]>,
    /// Natural frequencies and mode shapes to compute, in [0, 50] (0 skips the modal
    /// analysis). Default 6.
    pub modes: usize,
    /// Lumped (diagonal) instead of consistent mass matrices. Default false.
    pub lumped: bool,
    /// Put the input-plate masses (`stage.guess.m_in`) into the modal analysis. Default true.
    pub plate_masses: bool,
    /// Stroke scales of the validity map, each in (0, 2], increasing, at most 20 (empty skips
    /// the map). Default 0.1, 0.25, 0.5, 0.75, 1.
    pub scales: Vec<f64>,
    /// Keep the optimizer's output spring (`optimization.output_spring`) in the model.
    /// Default false.
    pub keep_output_spring: bool,
}

impl Default for ReduceOptions {
    fn default() -> Self {
        ReduceOptions {
            design: None,
            operating_point: None,
            modes: ModalParams::default().modes,
            lumped: false,
            plate_masses: true,
            scales: ValidityParams::default().scales,
            keep_output_spring: false,
        }
    }
}

impl ReduceOptions {
    /// Checks the options (the reduction's own parameters are checked by
    /// [`ReduceParams::validate`], which names them).
    pub fn validate(&self) -> Result<()> {
        require(
            self.modes <= 50,
            "reduce.modes",
            self.modes,
            "an integer in [0, 50]",
        )?;
        require(
            self.scales.len() <= 20,
            "reduce.scales",
            format!("{} scales", self.scales.len()),
            "at most 20 scales",
        )?;
        // The reduction's parameters by their option names.
        self.params().validate().map_err(|e| match e {
            flexstage_reduce::ReduceError::OutOfRange(mut r) => {
                r.field = match r.field.as_str() {
                    "ReduceParams::operating_point" => "reduce.operating_point",
                    "ValidityParams::scales" => "reduce.scales",
                    "ModalParams::modes" => "reduce.modes",
                    other => other,
                }
                .to_string();
                flexstage_reduce::ReduceError::OutOfRange(r).into()
            }
            e => e.into(),
        })
    }

    /// The reduction's parameters.
    pub fn params(&self) -> ReduceParams {
        ReduceParams {
            operating_point: self.operating_point,
            modal: (self.modes > 0).then(|| ModalParams {
                modes: self.modes,
                lumping: if self.lumped {
                    MassLumping::Lumped
                } else {
                    MassLumping::Consistent
                },
                ..ModalParams::default()
            }),
            plate_masses: self.plate_masses,
            validity: (!self.scales.is_empty()).then(|| ValidityParams {
                scales: self.scales.clone(),
                ..ValidityParams::default()
            }),
            ..ReduceParams::default()
        }
    }
}

/// What `reduce` computed.
#[derive(Debug, Clone)]
pub struct ReduceSummary {
    /// The design reduced.
    pub design: DesignSource,
    /// The reduction (α, stiffnesses, mass, modes, validity map).
    pub reduction: Reduction,
    /// The stage folder.
    pub dir: PathBuf,
    /// The stage parameter file ([`files::PARAMS`]).
    pub params_file: PathBuf,
    /// Whether earlier results were replaced.
    pub replaced: bool,
}

/// Runs `reduce` and writes every result file.
pub fn reduce(
    folder: &RunFolder,
    options: &ReduceOptions,
    progress: &dyn Progress,
) -> Result<ReduceSummary> {
    options.validate()?;
    let s = folder.scenario();
    crate::design::two_pea_stage(s, "reduce")?;
    let problem = reduction_problem(s, options.keep_output_spring)?;
    let design = options
        .design
        .clone()
        .unwrap_or_else(|| DesignSource::run_or_uniform(folder));
    let rho = load_design(folder, &design, &problem)?;
    let params = options.params();
    progress.note(&format!(
        "reducing {design} ({} x {} mesh){}",
        problem.mesh().nl,
        problem.mesh().nw,
        if params.validity.is_some() {
            ": condensation, modes, validity map (nonlinear FE)"
        } else {
            ""
        }
    ));
    let reduction = flexstage_reduce::reduce(s, &problem, &rho, &params)?;
    let replaced = folder.has_results(files::DIR);
    let out = crate::reduce_files::Outputs {
        run: folder.dir(),
        design: &design,
        problem: &problem,
        rho: &rho,
        reduction: &reduction,
        params: &params,
    };
    out.write()?;
    // From now on the run's simulated stage is the designed one (`plant.toml`).
    crate::plant::store_designed(folder, &reduction.params)?;
    Ok(ReduceSummary {
        design,
        reduction,
        dir: folder.dir().path(files::DIR),
        params_file: folder.dir().path(files::PARAMS),
        replaced,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_reduction_crates_and_validate() {
        let o = ReduceOptions::default();
        o.validate().unwrap();
        assert_eq!(
            o.params().modal.unwrap().modes,
            ModalParams::default().modes
        );
        assert_eq!(
            o.params().validity.unwrap().scales,
            ValidityParams::default().scales
        );
        let e = ReduceOptions {
            modes: 51,
            ..o.clone()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("reduce.modes = 51") && e.contains("[0, 50]"),
            "{e}"
        );
        let e = ReduceOptions {
            scales: vec![0.5, 0.25],
            ..o
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(e.contains("scales"), "{e}");
    }
}
