//! The run folder of a scenario and where scenarios come from.
//!
//! A run is one folder, `runs/<scenario name>/` unless the caller picks another. It records
//! the scenario exactly as used ([`layout::SCENARIO`]) and holds one sub-folder per stage
//! ([`flexstage_report::layout`]). Every stage receives the scenario *in memory* from
//! [`RunFolder`]; none re-reads the recorded copy, so two runs can never mix scenarios through
//! the file. A folder that records another scenario is refused unless the caller asks to
//! replace it.

use std::path::{Path, PathBuf};

use flexstage_report::{RunDir, layout};
use flexstage_scenario::{Preset, Scenario};

use crate::error::{PipelineError, Result};

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

/// If the folder `root` records a scenario other than `scenario`: its name, or why it cannot
/// be read.
pub fn other_scenario(root: &Path, scenario: &Scenario) -> Option<String> {
    let text = std::fs::read_to_string(root.join(layout::SCENARIO)).ok()?;
    match Scenario::from_toml_str(&text, layout::SCENARIO) {
        Ok(r) if r == *scenario => None,
        Ok(r) => Some(format!("{:?}", r.name)),
        Err(e) => Some(format!("unreadable: {e}")),
    }
}

/// A run folder and the scenario its stages run with.
#[derive(Debug, Clone)]
pub struct RunFolder {
    scenario: Scenario,
    dir: RunDir,
}

impl RunFolder {
    /// Opens (creating if needed) the run folder `root` for `scenario` and records the
    /// scenario in it. A folder that records a different scenario is refused with
    /// [`PipelineError::OtherScenario`] unless `replace_scenario`.
    pub fn open(
        scenario: Scenario,
        root: impl Into<PathBuf>,
        replace_scenario: bool,
    ) -> Result<Self> {
        let dir = RunDir::create(root.into())?;
        if !replace_scenario && let Some(recorded) = other_scenario(dir.root(), &scenario) {
            return Err(PipelineError::OtherScenario {
                root: dir.root().to_path_buf(),
                recorded,
            });
        }
        dir.write(layout::SCENARIO, scenario.to_commented_toml().as_bytes())?;
        Ok(RunFolder { scenario, dir })
    }

    /// Opens an existing run folder with the scenario recorded in it (to resume a design, or
    /// to work on a run someone else made).
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
        let scenario = Scenario::load(&file)?;
        Ok(RunFolder {
            scenario,
            dir: RunDir::create(root)?,
        })
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

    /// Whether the stage folder `rel` already holds files (a re-run replaces them).
    pub(crate) fn has_results(&self, rel: &str) -> bool {
        std::fs::read_dir(self.dir.path(rel))
            .map(|mut d| d.any(|e| e.is_ok_and(|e| e.path().is_file())))
            .unwrap_or(false)
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
        RunFolder::open(quick.clone(), &root, false).unwrap();
        // The same scenario again: accepted.
        RunFolder::open(quick.clone(), &root, false).unwrap();
        let mut other = quick.clone();
        other.mesh.nl = 40;
        let e = RunFolder::open(other.clone(), &root, false).unwrap_err();
        assert!(matches!(e, PipelineError::OtherScenario { .. }), "{e}");
        assert!(e.to_string().contains("\"quick\""), "{e}");
        let f = RunFolder::open(other.clone(), &root, true).unwrap();
        assert_eq!(RunFolder::existing(&root).unwrap().scenario(), f.scenario());
        std::fs::remove_dir_all(&root).unwrap();
    }
}
