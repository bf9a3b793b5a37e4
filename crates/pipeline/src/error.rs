//! Typed errors of the pipeline.
//!
//! Display strings never repeat their `source`: a caller that prints the whole chain
//! (`anyhow`'s `{:#}`) shows every cause exactly once.

use std::fmt::Display;
use std::path::PathBuf;

/// Everything that can stop a pipeline stage.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// A stage option is out of its accepted range.
    #[error("{option} = {value} is out of range: expected {expected}")]
    Option {
        /// The option, as `<stage>.<field>` (e.g. `reduce.modes`).
        option: &'static str,
        /// The value given, formatted.
        value: String,
        /// The accepted range in words.
        expected: String,
    },
    /// A result exists and replacing it was not asked for.
    #[error("{path} already holds {what}; {hint}")]
    Exists {
        /// The file or folder.
        path: PathBuf,
        /// What it holds.
        what: &'static str,
        /// How to go on.
        hint: String,
    },
    /// An input a stage needs is missing.
    #[error("{what} not found: {path} does not exist; {hint}")]
    Missing {
        /// What is missing.
        what: &'static str,
        /// Where it was looked for.
        path: PathBuf,
        /// How to produce it.
        hint: String,
    },
    /// The run folder (or a checkpoint in it) records another scenario than the one given.
    #[error("{root} holds {what} made with another scenario ({changes}); {hint}")]
    OtherScenario {
        /// The run folder or file.
        root: PathBuf,
        /// What it holds ("a run", "finished stages", "an interrupted design").
        what: &'static str,
        /// What changed, field by field (old → new), or why the record cannot be read.
        changes: String,
        /// How to go on.
        hint: String,
    },
    /// Another process works in the run folder.
    #[error("{root} is in use by another flexstage process ({holder}); {hint} (lock file {lock})")]
    Locked {
        /// The run folder.
        root: PathBuf,
        /// The lock holder, in words.
        holder: String,
        /// The lock file.
        lock: PathBuf,
        /// How to go on.
        hint: String,
    },
    /// A file of the run folder is damaged (checksum, length, format) and is not used.
    #[error("{path} is damaged: {reason}; {hint}")]
    Damaged {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
        /// How to go on.
        hint: String,
    },
    /// An input file could not be read.
    #[error("cannot read {path}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// An input file has the wrong content.
    #[error("{path}: {reason}")]
    Format {
        /// The file (or design source) read.
        path: String,
        /// What is wrong.
        reason: String,
    },
    /// A `--params` file that lives in another run folder than the one written to.
    #[error(
        "{params} belongs to the run folder {owner}, but the results would go to {target}; \
         give that run's scenario ({owner}/scenario.toml) or choose the folder with --out"
    )]
    ForeignParams {
        /// The parameter file.
        params: PathBuf,
        /// Its run folder.
        owner: PathBuf,
        /// The run folder written to.
        target: PathBuf,
    },
    /// The caller asked the stage to stop ([`crate::Progress::stop_requested`]).
    #[error("interrupted: {what}; {hint}")]
    Interrupted {
        /// What was stopped, and where.
        what: String,
        /// How to go on.
        hint: String,
    },
    /// The adjoint gradients disagree with central differences.
    #[error("gradient check failed: {failed} of {checked} responses above {tolerance:e}")]
    GradientCheck {
        /// Responses above the tolerance.
        failed: usize,
        /// Responses checked.
        checked: usize,
        /// The tolerance on the relative error.
        tolerance: f64,
    },
    /// A computed result is not physical (NaN, ∞ or outside its possible range): the command
    /// fails rather than report it.
    #[error("{what} = {value} is not a valid result (expected {expected}); {hint}")]
    Unphysical {
        /// The result, with the command that computed it.
        what: String,
        /// Its value, formatted.
        value: String,
        /// The possible range in words.
        expected: &'static str,
        /// The likely cause and how to go on.
        hint: String,
    },
    /// The work needs more of a resource than the process may use.
    #[error("{what} needs an estimated {need}, more than {available}; {hint}")]
    Resources {
        /// The work and the resource.
        what: &'static str,
        /// The estimate, formatted.
        need: String,
        /// What the process may use, formatted.
        available: String,
        /// How to go on.
        hint: &'static str,
    },
    /// Scenario errors (also of the derived plant).
    #[error(transparent)]
    Scenario(#[from] flexstage_scenario::ScenarioError),
    /// Topology optimization and nonlinear analysis.
    #[error(transparent)]
    Topopt(#[from] flexstage_topopt::TopoptError),
    /// Model reduction.
    #[error(transparent)]
    Reduce(#[from] flexstage_reduce::ReduceError),
    /// Bouc–Wen model and PEA identification.
    #[error(transparent)]
    Piezo(#[from] flexstage_piezo::PiezoError),
    /// Stage identification.
    #[error(transparent)]
    Identify(#[from] flexstage_identify::IdentifyError),
    /// Controllers and the simulated experiment.
    #[error(transparent)]
    Control(#[from] flexstage_control::ControlError),
    /// The simulated stage, its lumped model or a reference.
    #[error(transparent)]
    Sim(#[from] flexstage_sim::SimError),
    /// Margins and tuning of the controllers on the twin.
    #[error(transparent)]
    Assess(#[from] flexstage_assess::AssessError),

    #[error(transparent)]
    Twin(#[from] flexstage_twin::TwinError),
    /// Reading and writing the run folder.
    #[error(transparent)]
    Run(#[from] flexstage_run::RunError),
    /// The report could not read files that exist (it was written, showing the errors).
    #[error("{report} was written, but {} file(s) of the run could not be read: {}", errors.len(), errors.join("; "))]
    Report {
        /// The report.
        report: PathBuf,
        /// What could not be read, and why.
        errors: Vec<String>,
    },
    /// Figures.
    #[error(transparent)]
    Plot(#[from] flexstage_figures::plot::PlotError),
    /// VTK files.
    #[error(transparent)]
    Vtk(#[from] flexstage_figures::vtk::VtkError),
    /// Outline export.
    #[error(transparent)]
    Outline(#[from] flexstage_verify::outline::OutlineError),
    /// Density images.
    #[error(transparent)]
    Image(#[from] flexstage_figures::image::ImageError),
    /// Verification of the exported outline.
    #[error(transparent)]
    Verify(#[from] flexstage_verify::VerifyError),
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, PipelineError>;

/// The bytes of `path`, or [`PipelineError::Read`] naming it.
pub(crate) fn read_bytes(path: &std::path::Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|source| PipelineError::Read {
        path: path.to_path_buf(),
        source,
    })
}

/// `Ok` when `ok`, else [`PipelineError::Option`] naming the option, the value and the
/// accepted range. Non-finite floats never pass (callers include `value.is_finite()`). A
/// value that is one number is shown compactly (`1e308`, not 309 digits).
pub(crate) fn require(
    ok: bool,
    option: &'static str,
    value: impl Display,
    expected: &str,
) -> Result<()> {
    if ok {
        return Ok(());
    }
    let value = value.to_string();
    Err(PipelineError::Option {
        option,
        value: value
            .parse::<f64>()
            .map_or(value, flexstage_numerics::compact),
        expected: expected.to_string(),
    })
}

/// `Ok` when the workspace `area` \[m²\] of `what` (e.g. `analyze`), in the configuration's
/// orientation (`flexstage_topopt::Problem::workspace_area`), is finite and ≥ 0, else
/// [`PipelineError::Unphysical`]. A NaN area comes from non-finite outputs (a singular
/// structure); a negative one from an output polygon traversed against the configuration
/// (Table 2): a mechanism that moves the output the other way than the configuration asks, or
/// outputs dominated by round-off. Callers write what they computed first.
pub(crate) fn require_area(what: &str, area: f64) -> Result<()> {
    if area.is_finite() && area >= 0.0 {
        return Ok(());
    }
    Err(PipelineError::Unphysical {
        what: format!("{what}: workspace area"),
        value: format!("{area:e} m²"),
        expected: "a finite area ≥ 0 in the configuration's orientation",
        hint: "the outputs of the stroke-square corners do not trace a workspace the way \
               actuators.configuration asks (Table 2; the files computed are written, a \
               design's as design/rejected.json): check that the structure is held \
               (`flexstage check` on the scenario: [[supports]], optimization.output_spring), \
               that the design connects the inputs to the output, and the configuration"
            .into(),
    })
}

/// `Ok` when no tracking row is refused ([`flexstage_sim::experiment::Status::refused`]:
/// diverged, or an error above that of a stage at rest), else [`PipelineError::Unphysical`]
/// naming the first (trajectory, controller) pair with its status and cause, and every other.
/// Called after every record and the metrics table are written, so the refused series can be
/// inspected.
pub(crate) fn require_converged_tracking(rows: &[crate::track::TrackRow]) -> Result<()> {
    let mut refused = rows.iter().filter(|r| r.metrics.status().refused());
    let Some(first) = refused.next() else {
        return Ok(());
    };
    let names = std::iter::once(first)
        .chain(refused)
        .map(|r| {
            format!(
                "{}/{} ({})",
                r.trajectory,
                r.variant(),
                r.metrics.status().name()
            )
        })
        .collect::<Vec<_>>()
        .join(", ");
    let m = &first.metrics;
    Err(PipelineError::Unphysical {
        what: format!(
            "track: {}, {}: max error",
            first.trajectory,
            first.variant()
        ),
        value: format!(
            "[{:.3e}, {:.3e}] m, {}",
            m.max[0],
            m.max[1],
            m.status_detail()
        ),
        expected: "a finished run, finite, with an RMS error below that of a stage at rest",
        hint: format!(
            "refused: {names}. Their series and metrics.csv (column status) are written; check \
             the controller's model and gains, the rig, the sample time and the trajectory"
        ),
    })
}

/// A serialization failure of our own summary types is a bug, not an input error.
pub(crate) fn to_json(value: &impl serde::Serialize) -> String {
    serde_json::to_string_pretty(value).expect("summaries serialize to JSON")
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexstage_control::controller::ROBUST;
    use flexstage_control::pid::PID_FF;
    use flexstage_control::registry::Controller;
    use flexstage_sim::experiment::Metrics;

    #[test]
    fn area_refused_when_nan_infinite_or_negative() {
        // Reference: the input-bounds and fault-handling requirements ("`analyze` on it exits 0 with a negative area", "a 1 × 1 mesh
        // gives a NaN area with exit 0"). Goal: only a finite area ≥ 0 passes.
        for ok in [0.0, 1e-12, 3.5e-9] {
            require_area("analyze", ok).unwrap();
        }
        for bad in [f64::NAN, f64::INFINITY, -1e-12, -2.0e-9] {
            let m = require_area("analyze", bad).unwrap_err().to_string();
            assert!(
                m.contains("analyze: workspace area") && m.contains("≥ 0"),
                "{m}"
            );
        }
    }

    #[test]
    fn diverged_tracking_rows_are_named() {
        // Reference: the input-bounds and fault-handling requirements ("metrics show a maximum error of 0 when the series is NaN").
        // Goal: a row whose metrics diverged fails the command, naming it; finite rows pass.
        let row =
            |t: &str, v: &'static Controller, non_finite: usize, max: f64| crate::track::TrackRow {
                trajectory: t.into(),
                controller: v,
                learning: false,
                metrics: Metrics {
                    max: [max, 1e-9],
                    non_finite,
                    ..Metrics::default()
                },
                usage: 0.5,
            };
        let good = [row("circle", &ROBUST, 0, 2e-9)];
        require_converged_tracking(&good).unwrap();
        let bad = [
            row("circle", &ROBUST, 0, 2e-9),
            row("lissajous-2", &PID_FF, 7, f64::NAN),
        ];
        let m = require_converged_tracking(&bad).unwrap_err().to_string();
        assert!(
            m.contains("lissajous-2") && m.contains("7 non-finite"),
            "{m}"
        );
        assert!(!m.contains("circle/"), "{m}");
    }
}
