//! The run-folder convention and progress bars shared by the subcommands.
//!
//! A run is one folder, `runs/<scenario name>/` unless `--out` says otherwise. It holds the
//! scenario exactly as used (`scenario.toml`) and one sub-folder per stage (`design/`,
//! `reduce/`, `identify/`, `track/`). Re-running a stage overwrites that stage's files only;
//! every file is written atomically.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::Context;
use flexstage_report::RunDir;
use flexstage_scenario::Scenario;
use indicatif::{ProgressBar, ProgressStyle};

/// Opens the run folder (`out`, or `runs/<scenario name>`) and records the scenario in it.
pub fn open_run(out: Option<PathBuf>, scenario: &Scenario) -> anyhow::Result<RunDir> {
    let root = out.unwrap_or_else(|| PathBuf::from("runs").join(&scenario.name));
    let run = RunDir::create(&root).context("cannot create the run folder")?;
    run.write("scenario.toml", scenario.to_commented_toml().as_bytes())?;
    Ok(run)
}

/// A progress bar on standard error with `len` steps. It draws nothing when standard error is
/// not a terminal (CI logs, pipes).
pub fn progress(len: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template("{prefix:>10} [{bar:30}] {pos}/{len} {elapsed} {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_prefix(what.to_string());
    bar.enable_steady_tick(Duration::from_millis(250));
    bar
}
