//! Progress reporting: the pipeline never prints; it tells a [`Progress`] what happens and the
//! caller decides how to show it (the CLI draws `indicatif` bars on standard error).

use crate::error::{PipelineError, Result};
use crate::run::{Stage, StageSummary};

/// Receives progress from the stages. Every method has a do-nothing default, so an
/// implementation overrides only what it shows. Implementations must be `Sync`: tracking runs
/// its controllers in parallel and advances one task from several threads.
pub trait Progress: Sync {
    /// A task of `len` steps begins (e.g. `"design"` with `max_iterations + 1` steps).
    fn start(&self, _task: &str, _len: u64) {}
    /// The current task reached step `position`.
    fn set_position(&self, _position: u64) {}
    /// The current task advanced by `steps`.
    fn advance(&self, _steps: u64) {}
    /// A short status of the current task (e.g. the objective of the last iteration).
    fn set_message(&self, _message: &str) {}
    /// The current task is done.
    fn finish(&self) {}
    /// A line worth showing now: a warning or a notable event (a retried load case, a
    /// resumed checkpoint).
    fn note(&self, _line: &str) {}
    /// A step of `flexstage run` ([`crate::run::run`]).
    fn event(&self, _event: &RunEvent) {}
    /// Whether the caller asks the stage to stop (e.g. Ctrl-C in a Python session). Stages
    /// ask between steps (a design iteration, a tracking phase, a stage of `run`) and then
    /// end with [`PipelineError::Interrupted`], leaving the folder as an interrupted process
    /// would (a design writes its checkpoint first). Default: never.
    fn stop_requested(&self) -> bool {
        false
    }
}

/// `Err(`[`PipelineError::Interrupted`]`)` when `progress` asks to stop, naming what was
/// stopped (`what`) and how to go on (`hint`).
pub(crate) fn check_stop(progress: &dyn Progress, what: &str, hint: &str) -> Result<()> {
    if progress.stop_requested() {
        return Err(PipelineError::Interrupted {
            what: what.to_string(),
            hint: hint.to_string(),
        });
    }
    Ok(())
}

/// Shows nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Progress for Silent {}

/// Why `run` starts over instead of resuming. (A folder of another scenario is refused, not
/// started over: see [`crate::run::run`].)
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StartOver {
    /// The caller asked for it (`--restart`).
    Requested,
}

/// The steps of [`crate::run::run`].
#[derive(Debug)]
pub enum RunEvent<'a> {
    /// Finished stages are discarded.
    StartingOver(StartOver),
    /// Resuming after these finished stages.
    Resuming(&'a [Stage]),
    /// A stage finished earlier is skipped (its files are present and unchanged).
    Skipped(Stage),
    /// A stage finished earlier is done again (with every later one) because one of its
    /// files is missing or changed.
    Redoing {
        /// The stage.
        stage: Stage,
        /// The file and what is wrong with it.
        why: String,
    },
    /// A stage begins.
    Started(Stage),
    /// A stage ended.
    Finished {
        /// The stage.
        stage: Stage,
        /// Wall-clock time \[s\].
        seconds: f64,
        /// What it produced.
        summary: &'a StageSummary,
    },
}
