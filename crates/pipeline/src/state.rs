//! The resume state of `run` (`run_state.json`): which stages finished, with which scenario
//! and options.
//!
//! This module is the only place that reads or writes the file. Every finished stage records
//! the hash of the scenario and of the stage options it ran with; `run` resumes only when all
//! of them are the current ones. A file that does not parse, has another format version or
//! names an unknown stage is *damaged* ([`PipelineError::Damaged`]): it is reported, never
//! taken as "nothing finished" (that would silently start the run over).

use flexstage_report::{RunDir, layout};
use flexstage_scenario::Scenario;
use serde::{Deserialize, Serialize};

use crate::error::{PipelineError, Result};
use crate::run::Stage;

/// The format version of `run_state.json` this version writes and reads.
pub const STATE_VERSION: u32 = 2;

/// What `run_state.json` records.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunState {
    /// [`STATE_VERSION`].
    pub version: u32,
    /// [`scenario_hash`] of the scenario the run started with.
    pub scenario_hash: String,
    /// Hash of the stage options the run started with (`run::options_hash`).
    pub options_hash: String,
    /// The finished stages, in order.
    pub stages: Vec<FinishedStage>,
}

/// One finished stage of `run_state.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FinishedStage {
    /// [`Stage::name`].
    pub stage: String,
    /// Seconds it took.
    pub seconds: f64,
    /// [`scenario_hash`] of the scenario it ran with.
    pub scenario_hash: String,
    /// Hash of the stage options it ran with.
    pub options_hash: String,
}

/// Why a recorded state does not belong to the current call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mismatch {
    /// A stage ran with another scenario.
    Scenario,
    /// A stage ran with other stage options.
    Options,
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

    /// The state recorded in `run`: `None` if there is none, [`PipelineError::Damaged`] if
    /// the file cannot be trusted.
    pub fn load(run: &RunDir) -> Result<Option<Self>> {
        let path = run.path(layout::RUN_STATE);
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(source) => return Err(PipelineError::Read { path, source }),
        };
        let damaged = |reason: String| PipelineError::Damaged {
            path: path.clone(),
            reason,
            hint: "`run --restart` starts the run over".into(),
        };
        let state: RunState = serde_json::from_slice(&bytes)
            .map_err(|e| damaged(format!("not a run state of this version ({e})")))?;
        if state.version != STATE_VERSION {
            return Err(damaged(format!(
                "format version {} (this flexstage reads version {STATE_VERSION})",
                state.version
            )));
        }
        if let Some(f) = state
            .stages
            .iter()
            .find(|f| !Stage::ALL.iter().any(|s| s.name() == f.stage))
        {
            return Err(damaged(format!("unknown stage {:?}", f.stage)));
        }
        Ok(Some(state))
    }

    /// Records the state atomically.
    pub fn save(&self, run: &RunDir) -> Result<()> {
        run.write(layout::RUN_STATE, crate::error::to_json(self).as_bytes())?;
        Ok(())
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

    /// Whether `stage` finished.
    pub fn finished(&self, stage: Stage) -> bool {
        self.stages.iter().any(|f| f.stage == stage.name())
    }

    /// The finished stages, in the order of [`Stage::ALL`].
    pub fn finished_stages(&self) -> Vec<Stage> {
        Stage::ALL
            .into_iter()
            .filter(|&s| self.finished(s))
            .collect()
    }

    /// Records that `stage` finished after `seconds`, with the state's scenario and options.
    pub fn finish(&mut self, stage: Stage, seconds: f64) {
        self.stages.push(FinishedStage {
            stage: stage.name().to_string(),
            seconds,
            scenario_hash: self.scenario_hash.clone(),
            options_hash: self.options_hash.clone(),
        });
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

/// The 64-bit FNV-1a hash.
pub(crate) fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf29ce484222325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x100000001b3)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn state_round_trips_and_tracks_scenario_and_options() {
        // Goal: what `save` writes, `load` reads back; a changed scenario or options is
        // noticed, also when only one stage recorded it; a damaged file is an error.
        let root = std::env::temp_dir().join(format!("flexstage-state-{}", std::process::id()));
        let run = RunDir::create(&root).unwrap();
        assert_eq!(RunState::load(&run).unwrap(), None);
        let s = crate::folder::preset("quick").unwrap();
        let mut st = RunState::new(&s, "opts");
        st.finish(Stage::Design, 1.5);
        st.finish(Stage::Export, 0.1);
        st.save(&run).unwrap();
        let back = RunState::load(&run).unwrap().unwrap();
        assert_eq!(back, st);
        assert!(back.finished(Stage::Export) && !back.finished(Stage::Reduce));
        assert_eq!(back.finished_stages(), vec![Stage::Design, Stage::Export]);
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
            let e = RunState::load(&run).unwrap_err().to_string();
            assert!(
                e.contains("run_state.json") && e.contains("--restart"),
                "{e}"
            );
        }
        let mut v3 = st.clone();
        v3.version = 3;
        v3.save(&run).unwrap();
        assert!(
            RunState::load(&run)
                .unwrap_err()
                .to_string()
                .contains("version 3")
        );
        let mut unknown = st.clone();
        unknown.stages[0].stage = "desifn".into();
        unknown.save(&run).unwrap();
        assert!(
            RunState::load(&run)
                .unwrap_err()
                .to_string()
                .contains("\"desifn\"")
        );
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn fnv1a_matches_the_published_vectors() {
        // Reference: FNV-1a 64-bit test vectors (Fowler, Noll, Vo; IETF draft
        // draft-eastlake-fnv, appendix C): "" → cbf29ce484222325, "a" → af63dc4c8601ec8c.
        assert_eq!(fnv1a(b""), 0xcbf29ce484222325);
        assert_eq!(fnv1a(b"a"), 0xaf63dc4c8601ec8c);
        assert_eq!(fnv1a(b"foobar"), 0x85944171f73967e8);
    }
}
