//! `run`: the paper's whole scheme on one scenario, design → export → reduce → PEA
//! identification → stage identification → tracking → report, in one run folder.
//!
//! Every stage gets the scenario in memory (never the recorded `scenario.toml`) and reads
//! what earlier stages wrote through [`flexstage_report::layout`]. Finished stages are
//! recorded in `run_state.json` ([`RunState`]) with a hash of the scenario, so calling `run`
//! again resumes after the last finished stage (an interrupted design continues from its
//! checkpoint); a changed scenario or [`RunOptions::restart`] starts over, and says so through
//! [`Progress::event`].
//!
//! Stage identification and tracking run on the designed mechanism ([`crate::plant`]).

use std::path::{Path, PathBuf};
use std::time::Instant;

use flexstage_report::{RunDir, html, layout};
use flexstage_scenario::Scenario;

use crate::design::{DesignOptions, DesignStart, DesignSummary, design};
use crate::error::Result;
use crate::export::{ExportOptions, ExportSummary, export};
use crate::folder::RunFolder;
use crate::pea::{PeaIdOptions, PeaIdSummary, PeaOptions, simulate_and_identify_each};
use crate::progress::{Progress, RunEvent, StartOver};
use crate::reduce::{ReduceOptions, ReduceSummary, reduce};
use crate::stage_id::{ParameterRow, StageIdOptions, StageIdSummary, identify_stage, read_table};
use crate::state::RunState;
use crate::track::{TrackOptions, TrackSummary, track};

/// The stages of `run`, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Topology optimization.
    Design,
    /// Manufacturing outline.
    Export,
    /// Reduced model.
    Reduce,
    /// Simulated records of both PEAs and their Bouc–Wen identification.
    Pea,
    /// Stage identification on the designed stage.
    IdentifyStage,
    /// Tracking with every controller.
    Track,
    /// The HTML report.
    Report,
}

impl Stage {
    /// Every stage, in order.
    pub const ALL: [Stage; 7] = [
        Stage::Design,
        Stage::Export,
        Stage::Reduce,
        Stage::Pea,
        Stage::IdentifyStage,
        Stage::Track,
        Stage::Report,
    ];

    /// The name in `run_state.json` and messages.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Design => "design",
            Stage::Export => "export",
            Stage::Reduce => "reduce",
            Stage::Pea => "pea",
            Stage::IdentifyStage => "identify-stage",
            Stage::Track => "track",
            Stage::Report => "report",
        }
    }

    /// Position in [`Stage::ALL`], from 1.
    pub fn number(self) -> usize {
        Stage::ALL.iter().position(|&s| s == self).unwrap_or(0) + 1
    }
}

/// What a stage of `run` produced.
#[derive(Debug, Clone)]
pub enum StageSummary {
    /// [`Stage::Design`].
    Design(DesignSummary),
    /// [`Stage::Export`].
    Export(ExportSummary),
    /// [`Stage::Reduce`].
    Reduce(Box<ReduceSummary>),
    /// [`Stage::Pea`]: one summary per PEA.
    Pea(Vec<PeaIdSummary>),
    /// [`Stage::IdentifyStage`].
    IdentifyStage(Box<StageIdSummary>),
    /// [`Stage::Track`].
    Track(TrackSummary),
    /// [`Stage::Report`]: the report file.
    Report(PathBuf),
}

/// Options of every stage of `run`; the defaults are the stages' own.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Run every stage again, ignoring finished ones.
    pub restart: bool,
    /// The design stage.
    pub design: DesignOptions,
    /// The outline export.
    pub export: ExportOptions,
    /// The reduced model.
    pub reduce: ReduceOptions,
    /// The simulated PEA records (one per PEA; `pea.pea` is not used).
    pub pea: PeaOptions,
    /// Their identification (`identify_pea.pea` and `.data` are not used).
    pub identify_pea: PeaIdOptions,
    /// The stage identification.
    pub identify_stage: StageIdOptions,
    /// Tracking.
    pub track: TrackOptions,
}

impl RunOptions {
    /// Checks every stage's options before anything runs.
    pub fn validate(&self) -> Result<()> {
        self.design.validate()?;
        self.export.validate()?;
        self.reduce.validate()?;
        self.pea.validate()?;
        self.identify_pea.validate()?;
        self.identify_stage.validate()?;
        self.track.validate()
    }
}

/// What `run` produced.
#[derive(Debug, Clone)]
pub struct RunSummary {
    /// The run folder.
    pub root: PathBuf,
    /// Wall-clock time of this call \[s\].
    pub seconds: f64,
    /// The headline numbers (the report's summary table).
    pub headline: Vec<(String, String)>,
    /// The identified stage parameters against the truth (Table 4).
    pub identified: Vec<ParameterRow>,
    /// The report (absolute when it can be resolved).
    pub report: PathBuf,
}

/// Runs every stage of the scheme on `scenario` in the run folder `root`, resuming after the
/// stages a previous call finished with the same scenario.
pub fn run(
    scenario: Scenario,
    root: &Path,
    options: &RunOptions,
    progress: &dyn Progress,
) -> Result<RunSummary> {
    options.validate()?;
    let t0 = Instant::now();
    let dir = RunDir::create(root)?;
    let previous = RunState::load(&dir);
    let resume = !options.restart && previous.as_ref().is_some_and(|s| s.is_for(&scenario));
    let mut state = match previous {
        Some(st) if resume => {
            if !st.finished.is_empty() {
                progress.event(&RunEvent::Resuming(&st.finished_stages()));
            }
            st
        }
        previous => {
            let had_results = previous.is_some_and(|s| !s.finished.is_empty())
                || crate::folder::other_scenario(root, &scenario).is_some();
            if had_results {
                progress.event(&RunEvent::StartingOver(if options.restart {
                    StartOver::Requested
                } else {
                    StartOver::ScenarioChanged
                }));
            }
            RunState::new(&scenario)
        }
    };
    state.save(&dir)?;
    // `run` owns its folder: the state above decided what is kept.
    let folder = RunFolder::open(scenario, root, true)?;
    for stage in Stage::ALL {
        if state.finished(stage) {
            progress.event(&RunEvent::Skipped(stage));
            continue;
        }
        progress.event(&RunEvent::Started(stage));
        let ts = Instant::now();
        let summary = run_stage(stage, &folder, options, resume, progress)?;
        let seconds = ts.elapsed().as_secs_f64();
        progress.event(&RunEvent::Finished {
            stage,
            seconds,
            summary: &summary,
        });
        state.finish(stage, seconds);
        state.save(&dir)?;
    }
    let report = dir.path(layout::REPORT);
    Ok(RunSummary {
        root: root.to_path_buf(),
        seconds: t0.elapsed().as_secs_f64(),
        headline: html::summary_rows(root),
        identified: dir
            .read_to_string(layout::stage::TABLE)
            .map(|t| read_table(&t))
            .unwrap_or_default(),
        report: std::fs::canonicalize(&report).unwrap_or(report),
    })
}

/// One stage with the run's options.
fn run_stage(
    stage: Stage,
    folder: &RunFolder,
    options: &RunOptions,
    resume: bool,
    progress: &dyn Progress,
) -> Result<StageSummary> {
    let run = folder.dir();
    Ok(match stage {
        Stage::Design => {
            // Continue an interrupted design of this run; otherwise a new one.
            let interrupted =
                run.exists(layout::design::CHECKPOINT) && !run.exists(layout::design::DESIGN);
            let start = if resume && interrupted {
                DesignStart::Resume
            } else {
                DesignStart::Fresh { force: true }
            };
            StageSummary::Design(design(folder, &options.design, start, progress)?)
        }
        Stage::Export => StageSummary::Export(export(folder, &options.export)?),
        Stage::Reduce => StageSummary::Reduce(Box::new(reduce(folder, &options.reduce, progress)?)),
        Stage::Pea => StageSummary::Pea(simulate_and_identify_each(
            folder,
            &options.pea,
            &options.identify_pea,
        )?),
        Stage::IdentifyStage => StageSummary::IdentifyStage(Box::new(identify_stage(
            folder,
            &options.identify_stage,
            progress,
        )?)),
        Stage::Track => StageSummary::Track(track(folder, &options.track, progress)?),
        Stage::Report => StageSummary::Report(write_report(folder.root())?),
    })
}

/// Builds the HTML report of a run folder and writes it ([`layout::REPORT`]).
pub fn write_report(root: &Path) -> Result<PathBuf> {
    let html = html::build_report(root);
    Ok(RunDir::create(root)?.write(layout::REPORT, html.as_bytes())?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stage_names_are_the_state_files() {
        // Goal: run_state.json written by earlier versions still resumes.
        let names: Vec<&str> = Stage::ALL.iter().map(|s| s.name()).collect();
        assert_eq!(
            names,
            [
                "design",
                "export",
                "reduce",
                "pea",
                "identify-stage",
                "track",
                "report"
            ]
        );
        assert_eq!(Stage::Design.number(), 1);
        assert_eq!(Stage::Report.number(), 7);
        RunOptions::default().validate().unwrap();
    }
}
