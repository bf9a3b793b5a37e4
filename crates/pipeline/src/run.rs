//! `run`: the paper's whole scheme on one scenario, design → export → reduce → twin → PEA
//! identification (both PEAs) → stage identification → tracking → report, in one run folder.
//!
//! Every stage gets the scenario in memory (never the recorded `scenario.toml`) and reads
//! what earlier stages stored through `flexstage-run` (from memory when they ran in this
//! call). Finished stages are recorded in `run_state.json` ([`RunState`]) with hashes of the
//! scenario and the options and every file they wrote with its SHA-256, so calling `run` again
//! resumes after the last finished stage whose files are all present and unchanged; a stage
//! with a missing or changed file is done again, with every later stage, and `run` says so
//! ([`RunEvent::Redoing`]). An interrupted design continues from its checkpoint, which carries
//! the scenario's hash and a CRC. A folder of another
//! scenario is refused with the list of changed fields; [`RunOptions::restart`] starts over,
//! and says so through [`Progress::event`]. The folder is locked while `run` works in it.
//!
//! Stage identification runs on the designed mechanism's lumped model ([`crate::plant`]);
//! tracking on the digital twin of the design ([`crate::twin`], [`crate::track`](mod@crate::track)), with the
//! compensator on the identified PEA parameters.

use std::path::{Path, PathBuf};
use std::time::Instant;

use flexstage_run::files::stage::ParameterRow as TableRow;
use flexstage_run::format::Rows;
use flexstage_run::layout;
use flexstage_scenario::Scenario;

use crate::design::{DesignOptions, DesignStart, DesignSummary, design};
use crate::error::{PipelineError, Result};
use crate::export::{ExportOptions, ExportSummary, export};
use crate::folder::{RunFolder, recorded_changes};
use crate::pea::{PeaIdOptions, PeaIdSummary, PeaOptions, simulate_and_identify_each};
use crate::progress::{Progress, RunEvent, StartOver};
use crate::reduce::{ReduceOptions, ReduceSummary, reduce};
use crate::stage_id::{
    MIN_TWIN_DURATION, ParameterRow, Simulation, StageData, StageIdOptions, StageIdSummary,
    identify_stage_on, table_rows,
};
use crate::state::{Mismatch, RunState, fnv1a, scenario_hash};
use crate::summary::verdict::Verdict;
use crate::track::{PlantKind, TrackOptions, TrackSummary, TwinBuild, track_on, try_build};
use crate::twin::{TwinOptions, TwinSummary, write_twin_of};

/// The stages of `run`, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Topology optimization.
    Design,
    /// Manufacturing outline.
    Export,
    /// Reduced model.
    Reduce,
    /// The digital twin of the design: its modes, frequency response and validity.
    Twin,
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
    pub const ALL: [Stage; 8] = [
        Stage::Design,
        Stage::Export,
        Stage::Reduce,
        Stage::Twin,
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
            Stage::Twin => "twin",
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
    Design(Box<DesignSummary>),
    /// [`Stage::Export`].
    Export(ExportSummary),
    /// [`Stage::Reduce`].
    Reduce(Box<ReduceSummary>),
    /// [`Stage::Twin`] (`None`: the twin of this design could not be built; a warning said
    /// why).
    Twin(Option<Box<TwinSummary>>),
    /// [`Stage::Pea`]: PEA1, then PEA2.
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
    /// The twin's report data.
    pub twin: TwinOptions,
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
        self.twin.validate()?;
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
    /// What was designed, whether it is safe, which controller to use, what was limited.
    pub verdict: Verdict,
    /// The identified stage parameters against the truth (Table 4).
    pub identified: Vec<ParameterRow>,
    /// The report (absolute when it can be resolved).
    pub report: PathBuf,
}

/// How to go on when a run folder holds stages of another scenario.
const RESTART_HINT: &str = "give that scenario again to resume, --restart to start over with \
                            this one, or another folder (--out)";

/// Runs every stage of the scheme on `scenario` in the run folder `root`, resuming after the
/// stages a previous call finished with the same scenario and options.
///
/// The folder is locked for the whole call ([`crate::lock`]). A folder whose finished stages
/// (or whose recorded scenario) belong to another scenario is refused with
/// [`PipelineError::OtherScenario`], which lists the changed fields; other stage options
/// are refused with [`PipelineError::Exists`]; a damaged `run_state.json` with
/// [`PipelineError::Damaged`]. [`RunOptions::restart`] starts over in every case.
pub fn run(
    scenario: Scenario,
    root: &Path,
    options: &RunOptions,
    progress: &dyn Progress,
) -> Result<RunSummary> {
    options.validate()?;
    crate::design::two_pea_stage(&scenario, "run")?;
    let folder = RunFolder::locked(scenario, root.to_path_buf())?;
    run_in(&folder, options, progress)
}

/// [`run`] in a run folder the caller holds open (with its scenario): records the scenario in
/// it (refusing a folder of another scenario's finished stages, as [`run`]) and runs, resumes
/// or redoes every stage.
pub fn run_in(
    folder: &RunFolder,
    options: &RunOptions,
    progress: &dyn Progress,
) -> Result<RunSummary> {
    options.validate()?;
    crate::design::two_pea_stage(folder.scenario(), "run")?;
    let t0 = Instant::now();
    let root = folder.root();
    for line in folder.notices() {
        progress.note(line);
    }
    let (mut state, resume) = start_state(folder, options, progress)?;
    state.save(folder.dir())?;
    // The twin of the design, built once by the twin stage and used by identify-stage and
    // track (a run resumed after the twin stage builds it in identify-stage or track).
    let mut twin: Option<TwinBuild> = None;
    for stage in Stage::ALL {
        if state.finished(stage.name()) {
            match state.check_files(folder.dir(), stage.name())? {
                None => {
                    progress.event(&RunEvent::Skipped(stage));
                    continue;
                }
                Some(problem) => {
                    progress.event(&RunEvent::Redoing {
                        stage,
                        why: problem.to_string(),
                    });
                    // This stage and every later one are done again.
                    state.forget_from(stage.name());
                }
            }
        }
        crate::progress::check_stop(
            progress,
            &format!("run stopped before its {} stage", stage.name()),
            "run again to resume after the last finished stage",
        )?;
        progress.event(&RunEvent::Started(stage));
        let ts = Instant::now();
        folder.dir().begin_journal();
        let summary = run_stage(stage, folder, options, resume, &mut twin, progress)?;
        let files = folder.dir().end_journal();
        let seconds = ts.elapsed().as_secs_f64();
        progress.event(&RunEvent::Finished {
            stage,
            seconds,
            summary: &summary,
        });
        state.finish(stage.name(), seconds, files);
        state.save(folder.dir())?;
    }
    let dir = folder.dir();
    let report = dir.path(layout::REPORT);
    let table = dir.load::<Rows<TableRow>>(layout::stage::TABLE)?;
    Ok(RunSummary {
        root: root.to_path_buf(),
        seconds: t0.elapsed().as_secs_f64(),
        verdict: Verdict::of(
            folder.dir(),
            &layout::Tracking::variant(&options.track.conditions(folder)),
        )?,
        identified: table.map(|t| table_rows(&t)).unwrap_or_default(),
        report: std::fs::canonicalize(&report).unwrap_or(report),
    })
}

/// The state `run` starts from, and whether it resumes: records the scenario in the locked
/// folder, or refuses a folder of another scenario or options (see [`run`]).
fn start_state(
    folder: &RunFolder,
    options: &RunOptions,
    progress: &dyn Progress,
) -> Result<(RunState, bool)> {
    let s = folder.scenario();
    let opts = options_hash(options);
    if options.restart {
        let had_results = folder.dir().exists(layout::RUN_STATE)
            || folder.dir().exists(layout::design::CHECKPOINT)
            || folder.dir().exists(layout::design::DESIGN)
            || recorded_changes(folder.root(), s).is_some();
        if had_results {
            progress.event(&RunEvent::StartingOver(StartOver::Requested));
        }
        folder.record(true, RESTART_HINT)?;
        return Ok((RunState::new(s, &opts), false));
    }
    let Some(state) = RunState::load(folder.dir(), &Stage::ALL.map(Stage::name))? else {
        folder.record(false, RESTART_HINT)?;
        return Ok((RunState::new(s, &opts), false));
    };
    match state.mismatch(s, &opts) {
        None => {
            folder.record(false, RESTART_HINT)?;
            if !state.stages.is_empty() {
                let done: Vec<Stage> = Stage::ALL
                    .into_iter()
                    .filter(|s| state.finished(s.name()))
                    .collect();
                progress.event(&RunEvent::Resuming(&done));
            }
            Ok((state, true))
        }
        Some(Mismatch::Scenario) => Err(PipelineError::OtherScenario {
            root: folder.root().to_path_buf(),
            what: if state.stages.is_empty() {
                "an unfinished run"
            } else {
                "finished stages"
            },
            changes: recorded_changes(folder.root(), s).unwrap_or_else(|| {
                "its scenario.toml was since replaced by this scenario, but not its \
                 run_state.json"
                    .into()
            }),
            hint: RESTART_HINT.into(),
        }),
        Some(Mismatch::Options) => Err(PipelineError::Exists {
            path: folder.dir().path(layout::RUN_STATE),
            what: "stages that ran with other stage options (another flexstage version or \
                   library call)",
            hint: "--restart starts over with these options".into(),
        }),
    }
}

/// FNV-1a of the stage options (`Debug`, which prints floats exactly), without
/// [`RunOptions::restart`]: the options a run's finished stages must share to be resumed.
pub fn options_hash(options: &RunOptions) -> String {
    let o = RunOptions {
        restart: false,
        ..options.clone()
    };
    format!("{:016x}", fnv1a(format!("{o:?}").as_bytes()))
}

/// One stage with the run's options.
fn run_stage(
    stage: Stage,
    folder: &RunFolder,
    options: &RunOptions,
    resume: bool,
    twin: &mut Option<TwinBuild>,
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
            StageSummary::Design(Box::new(design(folder, &options.design, start, progress)?))
        }
        Stage::Export => StageSummary::Export(export(folder, &options.export)?),
        Stage::Reduce => StageSummary::Reduce(Box::new(reduce(folder, &options.reduce, progress)?)),
        Stage::Twin => {
            // The twin is report data and `track`'s plant; a design it cannot model (e.g. solid
            // islands of an unconverged design) must not stop the run: `track` then runs on
            // the lumped model and says so.
            match twin.insert(try_build(folder, progress)?) {
                Ok(built) => StageSummary::Twin(Some(Box::new(write_twin_of(
                    folder,
                    &options.twin,
                    progress,
                    built,
                )?))),
                Err(e) => {
                    progress.note(&format!(
                        "warning: the twin of this design could not be built: {e}"
                    ));
                    StageSummary::Twin(None)
                }
            }
        }
        Stage::Pea => StageSummary::Pea(simulate_and_identify_each(
            folder,
            &options.pea,
            &options.identify_pea,
        )?),
        Stage::IdentifyStage => {
            // A run resumed after the twin stage builds the twin here (then hands it to track).
            if twin.is_none() && run.exists(layout::design::DESIGN) {
                *twin = Some(try_build(folder, progress)?);
            }
            let mut s =
                identify_stage_on(folder, &options.identify_stage, progress, twin.as_ref())?;
            // Then on the twin, by its response: the fit `track` sets the backstepping up from.
            if let (StageData::Simulate(sim), Some(Ok(_))) = (&options.identify_stage.data, &twin)
                && sim.plant == PlantKind::Lumped
            {
                let o = StageIdOptions {
                    data: StageData::Simulate(Simulation {
                        plant: PlantKind::Twin,
                        duration: sim.duration.map(|d| d.max(MIN_TWIN_DURATION)),
                        ..*sim
                    }),
                    ..options.identify_stage.clone()
                };
                let t = identify_stage_on(folder, &o, progress, twin.as_ref())?;
                s.warnings.extend(t.warnings.iter().cloned());
                s.on_twin = Some(Box::new(t));
            }
            StageSummary::IdentifyStage(Box::new(s))
        }
        Stage::Track => {
            StageSummary::Track(track_on(folder, &options.track, progress, twin.take())?)
        }
        Stage::Report => StageSummary::Report(write_report(folder)?),
    })
}

/// Builds the HTML report of a run folder and writes it ([`layout::REPORT`]). A folder whose
/// `scenario.toml` is not the scenario its `run` stages ran with (edited since) is refused, as
/// `run` refuses it; files that exist but cannot be read are errors on the page and
/// [`PipelineError::Report`] after the page is written.
pub fn write_report(folder: &RunFolder) -> Result<PathBuf> {
    let dir = folder.dir();
    if let Some(state) = RunState::load(dir, &Stage::ALL.map(Stage::name))?
        && state.scenario_hash != scenario_hash(folder.scenario())
    {
        return Err(PipelineError::OtherScenario {
            root: folder.root().to_path_buf(),
            what: "results of `flexstage run`",
            changes: format!(
                "its {} is not the scenario the run's stages ran with (recorded in {}): it \
                 was edited since",
                layout::SCENARIO,
                layout::RUN_STATE
            ),
            hint: "restore it, or run the stages again with it (`flexstage run --restart`)".into(),
        });
    }
    let report = flexstage_report::build_report(dir);
    let path = dir.write(layout::REPORT, report.html.as_bytes())?;
    if report.errors.is_empty() {
        Ok(path)
    } else {
        Err(PipelineError::Report {
            report: path,
            errors: report.errors,
        })
    }
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
                "twin",
                "pea",
                "identify-stage",
                "track",
                "report"
            ]
        );
        assert_eq!(Stage::Design.number(), 1);
        assert_eq!(Stage::Report.number(), 8);
        RunOptions::default().validate().unwrap();
    }
}
