//! The run folder of a scenario and where scenarios come from.
//!
//! A run is one folder, `runs/<scenario name>/` unless the caller picks another. It records
//! the scenario exactly as used ([`layout::SCENARIO`]) and holds one sub-folder per stage
//! ([`flexstage_run::layout`]). Every stage receives the scenario *in memory* from
//! [`RunFolder`]; none re-reads the recorded copy. A folder that records another scenario is
//! refused (saying which fields changed) unless the caller asks to replace it. An open
//! `RunFolder` holds the folder's lock ([`crate::lock`]), so two processes never work in one
//! folder at the same time.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use flexstage_run::{RunDir, layout};
use flexstage_scenario::{Preset, Scenario};

use crate::diff::scenario_changes;
use crate::error::{PipelineError, Result};
use crate::lock::{RunLock, pid_is_gone};

/// The built-in scenario every command uses when given no scenario file: the coarse, fast
/// first-contact preset. The paper's settings are `"paper"`.
pub const DEFAULT_PRESET: &str = "quick";

/// The names of the built-in scenarios.
pub const PRESETS: [&str; 3] = ["quick", "paper", "fine"];

/// The parent of the default run folders.
pub const RUNS: &str = "runs";

/// A built-in scenario by name ([`PRESETS`]).
pub fn preset(name: &str) -> Result<Scenario> {
    Preset::from_name(name)
        .map(Scenario::preset)
        .ok_or_else(|| PipelineError::Option {
            option: "preset",
            value: format!("{name:?}"),
            expected: format!("one of {}", PRESETS.join(", ")),
        })
}

/// The scenario of a file (validated), or the named preset when `file` is `None`.
pub fn load_scenario(file: Option<&Path>, preset_name: &str) -> Result<Scenario> {
    match file {
        Some(path) => Ok(Scenario::load(path)?),
        None => preset(preset_name),
    }
}

/// The default run folder of a scenario: `runs/<name>`.
pub fn default_root(scenario: &Scenario) -> PathBuf {
    PathBuf::from(RUNS).join(&scenario.name)
}

/// The default run folder of the default preset (`runs/quick`).
pub fn default_run() -> PathBuf {
    PathBuf::from(RUNS).join(DEFAULT_PRESET)
}

/// If the folder `root` records a scenario other than `scenario`: what changed (field by
/// field, old → new), or why the record cannot be read. `None` when it records `scenario` or
/// nothing.
pub fn recorded_changes(root: &Path, scenario: &Scenario) -> Option<String> {
    let text = std::fs::read_to_string(root.join(layout::SCENARIO)).ok()?;
    match Scenario::from_toml_str(&text, layout::SCENARIO) {
        Ok(r) if r == *scenario => None,
        _ => Some(scenario_changes(&text, scenario).to_string()),
    }
}

/// A run folder, locked for this process, and the scenario its stages run with.
///
/// Opening one takes the folder's lock ([`RunLock`]; another process working in the folder
/// is refused, a stale lock taken over) and removes the temporary files of writes that a
/// killed process left behind; what was done is in [`RunFolder::notices`]. The lock is
/// released when the last clone is dropped.
#[derive(Debug, Clone)]
pub struct RunFolder {
    scenario: Scenario,
    dir: RunDir,
    lock: Arc<RunLock>,
    notices: Vec<String>,
}

impl RunFolder {
    /// Opens (creating if needed) and locks the run folder `root` for `scenario`, and records
    /// the scenario in it. A folder that records a different scenario is refused with
    /// [`PipelineError::OtherScenario`] (saying what changed) unless `replace_scenario`; a
    /// replaced scenario also drops the folder's `run` state, whose stages ran with the old
    /// one.
    pub fn open(
        scenario: Scenario,
        root: impl Into<PathBuf>,
        replace_scenario: bool,
    ) -> Result<Self> {
        let folder = RunFolder::locked(scenario, root.into())?;
        folder.record(
            replace_scenario,
            "give that scenario, another folder (--out), or --force to replace its scenario",
        )?;
        Ok(folder)
    }

    /// Opens and locks an existing run folder with the scenario recorded in it (to resume a
    /// design, or to work on a run someone else made).
    pub fn existing(root: impl Into<PathBuf>) -> Result<Self> {
        let root = root.into();
        let file = root.join(layout::SCENARIO);
        if !file.is_file() {
            return Err(PipelineError::Missing {
                what: "run folder",
                path: file,
                hint: "a run folder holds the scenario.toml its stages ran with".into(),
            });
        }
        let lock = RunLock::acquire(&root)?;
        let scenario = Scenario::load(&file)?;
        RunFolder::with_lock(scenario, root, lock)
    }

    /// Locks the folder (creating it) without recording the scenario yet.
    pub(crate) fn locked(scenario: Scenario, root: PathBuf) -> Result<Self> {
        let lock = RunLock::acquire(&root)?;
        RunFolder::with_lock(scenario, root, lock)
    }

    fn with_lock(scenario: Scenario, root: PathBuf, lock: RunLock) -> Result<Self> {
        let dir = RunDir::create(root)?;
        let mut notices = Vec::new();
        if let Some(why) = lock.took_over() {
            notices.push(format!(
                "took over the lock of {}: {why}",
                dir.root().display()
            ));
        }
        let me = std::process::id();
        let removed = dir.remove_stale_temporaries(|pid| pid == me || pid_is_gone(pid, 0))?;
        if !removed.is_empty() {
            let names: Vec<String> = removed.iter().map(|p| p.display().to_string()).collect();
            notices.push(format!(
                "removed {} temporary file(s) left by an interrupted write: {}",
                removed.len(),
                names.join(", ")
            ));
        }
        Ok(RunFolder {
            scenario,
            dir,
            lock: Arc::new(lock),
            notices,
        })
    }

    /// Records the scenario in the folder. One that records another scenario is refused
    /// (with `hint`) unless `replace`; replacing it drops the `run` state.
    pub(crate) fn record(&self, replace: bool, hint: &str) -> Result<()> {
        if let Some(changes) = recorded_changes(self.root(), &self.scenario) {
            if !replace {
                return Err(PipelineError::OtherScenario {
                    root: self.root().to_path_buf(),
                    what: "a run",
                    changes,
                    hint: hint.into(),
                });
            }
            self.dir.remove_file(layout::RUN_STATE)?;
        }
        self.dir.store(layout::SCENARIO, self.scenario.clone())?;
        Ok(())
    }

    /// The scenario every stage of this run uses.
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }

    /// The folder.
    pub fn dir(&self) -> &RunDir {
        &self.dir
    }

    /// The folder's path.
    pub fn root(&self) -> &Path {
        self.dir.root()
    }

    /// The held lock.
    pub fn lock(&self) -> &RunLock {
        &self.lock
    }

    /// What opening the folder did that the user should hear of: a stale lock taken over,
    /// temporary files of interrupted writes removed.
    pub fn notices(&self) -> &[String] {
        &self.notices
    }

    /// Whether the stage folder `rel` already holds files (a re-run replaces them).
    pub(crate) fn has_results(&self, rel: &str) -> bool {
        self.dir.has_files(rel)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_preset_is_a_preset() {
        // Goal: the one default of every command names a built-in scenario.
        assert!(PRESETS.contains(&DEFAULT_PRESET));
        for name in PRESETS {
            assert_eq!(preset(name).unwrap().name, name, "run folder runs/{name}");
        }
        let e = preset("fast").unwrap_err().to_string();
        assert!(e.contains("preset") && e.contains("\"fast\"") && e.contains("quick, paper"));
        assert_eq!(
            default_run(),
            default_root(&preset(DEFAULT_PRESET).unwrap())
        );
    }

    #[test]
    fn a_folder_of_another_scenario_is_refused_unless_replaced() {
        let root = std::env::temp_dir().join(format!("flexstage-folder-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let quick = preset("quick").unwrap();
        drop(RunFolder::open(quick.clone(), &root, false).unwrap());
        // The same scenario again: accepted.
        drop(RunFolder::open(quick.clone(), &root, false).unwrap());
        std::fs::write(root.join(layout::RUN_STATE), "{}").unwrap();
        let mut other = quick.clone();
        other.mesh.nl = 40;
        let e = RunFolder::open(other.clone(), &root, false).unwrap_err();
        assert!(matches!(e, PipelineError::OtherScenario { .. }), "{e}");
        assert!(e.to_string().contains("mesh.nl: 48 → 40"), "{e}");
        assert!(
            root.join(layout::RUN_STATE).exists(),
            "a refusal changes nothing"
        );
        let f = RunFolder::open(other.clone(), &root, true).unwrap();
        assert!(
            !root.join(layout::RUN_STATE).exists(),
            "the run state of the replaced scenario is dropped"
        );
        drop(f);
        assert_eq!(
            RunFolder::existing(&root).unwrap().scenario(),
            &other,
            "the replacement is recorded"
        );
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn an_open_folder_is_locked_and_cleans_killed_writes() {
        // Goal: a second opener is refused while the first holds the folder; temporaries of
        // dead processes are removed at opening and reported.
        let root =
            std::env::temp_dir().join(format!("flexstage-folder-lock-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let quick = preset("quick").unwrap();
        let first = RunFolder::open(quick.clone(), &root, false).unwrap();
        assert!(first.notices().is_empty(), "{:?}", first.notices());
        let e = RunFolder::existing(&root).unwrap_err();
        assert!(matches!(e, PipelineError::Locked { .. }), "{e}");
        let again = first.clone();
        drop(first);
        assert!(root.join(layout::LOCK).exists(), "a clone still holds it");
        drop(again);
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        let tmp = root.join("design").join(flexstage_run::temporary_name(
            layout::design::DESIGN.rsplit('/').next().unwrap(),
            dead,
        ));
        std::fs::create_dir_all(tmp.parent().unwrap()).unwrap();
        std::fs::write(&tmp, "half").unwrap();
        let f = RunFolder::existing(&root).unwrap();
        assert!(!tmp.exists());
        assert!(
            f.notices()[0].contains("1 temporary file"),
            "{:?}",
            f.notices()
        );
        drop(f);
        std::fs::remove_dir_all(&root).unwrap();
    }
}
