//! The resume state of `run` (`run_state.json`): which stages finished, with which scenario
//! and options, and the files each wrote with their SHA-256.
//!
//! Every finished stage records the hash of the scenario and of the stage options it ran
//! with, and every file it wrote ([`WrittenFile`]); `run` resumes only when the hashes are
//! the current ones, and skips a finished stage only when each of its files is present and
//! unchanged ([`RunState::check_files`]). A file that does not parse, has another format
//! version or names an unknown stage is *damaged*: it is reported, never taken as "nothing
//! finished" (that would silently start the run over).

use flexstage_scenario::Scenario;
use serde::{Deserialize, Serialize};

use crate::dir::{RunDir, WrittenFile};
use crate::format::{Format, check_version, from_json, json};
use crate::hash::{fnv1a, sha256_hex};
use crate::{Result, RunError, layout};

/// The format version of `run_state.json` this version writes and reads (3: with the files
/// of every finished stage).
pub const STATE_VERSION: u32 = 3;

/// What `run_state.json` records.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunState {
    /// [`STATE_VERSION`].
    pub version: u32,
    /// [`scenario_hash`] of the scenario the run started with.
    pub scenario_hash: String,
    /// Hash of the stage options the run started with.
    pub options_hash: String,
    /// The finished stages, in order.
    pub stages: Vec<FinishedStage>,
}

/// One finished stage of `run_state.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FinishedStage {
    /// The stage's name.
    pub stage: String,
    /// Seconds it took.
    pub seconds: f64,
    /// [`scenario_hash`] of the scenario it ran with.
    pub scenario_hash: String,
    /// Hash of the stage options it ran with.
    pub options_hash: String,
    /// The files it wrote (and that no later stage rewrote), with their SHA-256.
    pub files: Vec<WrittenFile>,
}

/// Why a recorded state does not belong to the current call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mismatch {
    /// A stage ran with another scenario.
    Scenario,
    /// A stage ran with other stage options.
    Options,
}

/// What is wrong with a finished stage's files.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FileProblem {
    /// The file is gone.
    Missing(String),
    /// The file's content is not what the stage wrote.
    Changed(String),
}

impl std::fmt::Display for FileProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FileProblem::Missing(p) => write!(f, "{p} is missing"),
            FileProblem::Changed(p) => {
                write!(f, "{p} was changed or damaged (its SHA-256 differs)")
            }
        }
    }
}

impl Format for RunState {
    fn encode(&self) -> std::result::Result<Vec<u8>, String> {
        json(self)
    }

    fn decode(bytes: &[u8]) -> std::result::Result<Self, String> {
        let state: RunState =
            from_json(bytes).map_err(|e| format!("not a run state of this version ({e})"))?;
        check_version(state.version, STATE_VERSION)?;
        Ok(state)
    }
}

impl RunState {
    /// A fresh state: nothing finished.
    pub fn new(scenario: &Scenario, options_hash: &str) -> Self {
        RunState {
            version: STATE_VERSION,
            scenario_hash: scenario_hash(scenario),
            options_hash: options_hash.to_string(),
            stages: Vec::new(),
        }
    }

    /// The state recorded in `run`: `None` if there is none, [`RunError::Damaged`] if the
    /// file cannot be trusted (does not parse, another version, a stage not in `stages`).
    pub fn load(run: &RunDir, stages: &[&str]) -> Result<Option<Self>> {
        let path = run.path(layout::RUN_STATE);
        let Some(bytes) = run.read(layout::RUN_STATE)? else {
            return Ok(None);
        };
        let damaged = |reason: String| RunError::Damaged {
            path: path.clone(),
            reason,
        };
        let state = RunState::decode(&bytes).map_err(damaged)?;
        if let Some(f) = state
            .stages
            .iter()
            .find(|f| !stages.contains(&f.stage.as_str()))
        {
            return Err(damaged(format!("unknown stage {:?}", f.stage)));
        }
        Ok(Some(state))
    }

    /// Records the state atomically (not in the journal of the stage's files).
    pub fn save(&self, run: &RunDir) -> Result<()> {
        let bytes = self.encode().map_err(|reason| RunError::Encode {
            path: run.path(layout::RUN_STATE),
            reason,
        })?;
        crate::write_atomic(&run.path(layout::RUN_STATE), &bytes)
    }

    /// Why the state does not belong to `scenario` and the options of hash `options_hash`
    /// (the run's own hashes and every finished stage's are compared), or `None`.
    pub fn mismatch(&self, scenario: &Scenario, options_hash: &str) -> Option<Mismatch> {
        let hash = scenario_hash(scenario);
        if self.scenario_hash != hash || self.stages.iter().any(|f| f.scenario_hash != hash) {
            Some(Mismatch::Scenario)
        } else if self.options_hash != options_hash
            || self.stages.iter().any(|f| f.options_hash != options_hash)
        {
            Some(Mismatch::Options)
        } else {
            None
        }
    }

    /// Whether the stage named `stage` finished.
    pub fn finished(&self, stage: &str) -> bool {
        self.stages.iter().any(|f| f.stage == stage)
    }

    /// Records that `stage` finished after `seconds`, having written `files`, with the
    /// state's scenario and options. A file it rewrote is no longer an earlier stage's.
    pub fn finish(&mut self, stage: &str, seconds: f64, files: Vec<WrittenFile>) {
        for earlier in &mut self.stages {
            earlier
                .files
                .retain(|f| !files.iter().any(|g| g.path == f.path));
        }
        self.stages.push(FinishedStage {
            stage: stage.to_string(),
            seconds,
            scenario_hash: self.scenario_hash.clone(),
            options_hash: self.options_hash.clone(),
            files,
        });
    }

    /// Forgets `stage` and every stage recorded after it (they are to be done again).
    pub fn forget_from(&mut self, stage: &str) {
        if let Some(i) = self.stages.iter().position(|f| f.stage == stage) {
            self.stages.truncate(i);
        }
    }

    /// The first file of the finished stage `stage` that is missing or no longer what the
    /// stage wrote, or `None` when every one is in place (or the stage did not finish).
    pub fn check_files(&self, run: &RunDir, stage: &str) -> Result<Option<FileProblem>> {
        let Some(done) = self.stages.iter().find(|f| f.stage == stage) else {
            return Ok(None);
        };
        for f in &done.files {
            match run.read(&f.path)? {
                None => return Ok(Some(FileProblem::Missing(f.path.clone()))),
                Some(bytes) if sha256_hex(&bytes) != f.sha256 => {
                    return Ok(Some(FileProblem::Changed(f.path.clone())));
                }
                Some(_) => {}
            }
        }
        Ok(None)
    }
}

/// The scenario as hashed and recorded: its TOML without comments (so that a reworded
/// comment in a newer version does not count as a change).
pub fn scenario_text(scenario: &Scenario) -> String {
    scenario.to_toml()
}

/// FNV-1a (64 bit) of [`scenario_text`].
pub fn scenario_hash_u64(scenario: &Scenario) -> u64 {
    fnv1a(scenario_text(scenario).as_bytes())
}

/// [`scenario_hash_u64`] as 16 hex digits.
pub fn scenario_hash(scenario: &Scenario) -> String {
    format!("{:016x}", scenario_hash_u64(scenario))
}

#[cfg(test)]
mod tests {
    use super::*;

    const STAGES: [&str; 3] = ["design", "export", "reduce"];

    fn quick() -> Scenario {
        Scenario::preset(flexstage_scenario::Preset::Quick)
    }

    #[test]
    fn state_round_trips_and_tracks_scenario_and_options() {
        // Goal: what `save` writes, `load` reads back; a changed scenario or options is
        // noticed, also when only one stage recorded it; a damaged file is an error.
        let root = std::env::temp_dir().join(format!("flexstage-state-{}", std::process::id()));
        let run = RunDir::create(&root).unwrap();
        assert_eq!(RunState::load(&run, &STAGES).unwrap(), None);
        let s = quick();
        let mut st = RunState::new(&s, "opts");
        st.finish("design", 1.5, Vec::new());
        st.finish("export", 0.1, Vec::new());
        st.save(&run).unwrap();
        let back = RunState::load(&run, &STAGES).unwrap().unwrap();
        assert_eq!(back, st);
        assert!(back.finished("export") && !back.finished("reduce"));
        assert_eq!(back.mismatch(&s, "opts"), None);
        assert_eq!(back.mismatch(&s, "other"), Some(Mismatch::Options));
        let mut other = s.clone();
        other.optimization.max_iterations += 1;
        assert_eq!(back.mismatch(&other, "opts"), Some(Mismatch::Scenario));
        let mut one = back.clone();
        one.stages[1].scenario_hash = scenario_hash(&other);
        assert_eq!(one.mismatch(&s, "opts"), Some(Mismatch::Scenario));
        for bad in [
            "{ not json",
            r#"{"scenario_hash":"x","finished":["design"],"seconds":[1.0]}"#,
        ] {
            run.write(layout::RUN_STATE, bad.as_bytes()).unwrap();
            let e = RunState::load(&run, &STAGES).unwrap_err().to_string();
            assert!(e.contains(layout::RUN_STATE), "{e}");
        }
        let mut v2 = st.clone();
        v2.version = 2;
        v2.save(&run).unwrap();
        let e = RunState::load(&run, &STAGES).unwrap_err().to_string();
        assert!(e.contains("version 2"), "{e}");
        let mut unknown = st.clone();
        unknown.stages[0].stage = "desifn".into();
        unknown.save(&run).unwrap();
        let e = RunState::load(&run, &STAGES).unwrap_err().to_string();
        assert!(e.contains("\"desifn\""), "{e}");
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_stage_owns_what_it_wrote_until_a_later_stage_rewrites_it() {
        // Goal: the journal of a stage becomes its files; a missing or changed file is
        // found by name; a file rewritten by a later stage belongs to that stage.
        let root = std::env::temp_dir().join(format!("flexstage-files-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let run = RunDir::create(&root).unwrap();
        let mut st = RunState::new(&quick(), "opts");
        run.begin_journal();
        run.write(layout::design::DESIGN, b"{}").unwrap();
        run.write(layout::design::CHECKPOINT, b"x").unwrap();
        run.remove_file(layout::design::CHECKPOINT).unwrap();
        run.write(layout::PLANT, b"a").unwrap();
        st.finish("design", 1.0, run.end_journal());
        let paths: Vec<&str> = st.stages[0].files.iter().map(|f| f.path.as_str()).collect();
        assert_eq!(paths, [layout::design::DESIGN, layout::PLANT]);
        run.begin_journal();
        run.write(layout::PLANT, b"b").unwrap();
        st.finish("export", 1.0, run.end_journal());
        assert_eq!(st.stages[0].files.len(), 1, "plant.toml is export's now");
        assert_eq!(st.check_files(&run, "design").unwrap(), None);
        std::fs::write(run.path(layout::design::DESIGN), b"{ }").unwrap();
        assert_eq!(
            st.check_files(&run, "design").unwrap(),
            Some(FileProblem::Changed(layout::design::DESIGN.into()))
        );
        std::fs::remove_file(run.path(layout::PLANT)).unwrap();
        let p = st.check_files(&run, "export").unwrap().unwrap();
        assert_eq!(p, FileProblem::Missing(layout::PLANT.into()));
        assert!(p.to_string().contains("plant.toml is missing"));
        st.forget_from("design");
        assert!(st.stages.is_empty());
        std::fs::remove_dir_all(&root).unwrap();
    }
}
