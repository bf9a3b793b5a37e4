//! The resume state of `run` (`run_state.json`): which stages finished, with which scenario.
//!
//! This module is the only place that reads or writes the file, so hardening it (locks,
//! checksums, per-stage input hashes) changes one type and two functions.

use flexstage_report::{RunDir, layout};
use flexstage_scenario::Scenario;
use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::run::Stage;

/// What `run_state.json` records.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RunState {
    /// FNV-1a hash of the scenario TOML the stages ran with ([`scenario_hash`]).
    pub scenario_hash: String,
    /// Finished stages, in order (their [`Stage::name`]).
    pub finished: Vec<String>,
    /// Seconds each finished stage took.
    pub seconds: Vec<f64>,
}

impl RunState {
    /// A fresh state for `scenario`: nothing finished.
    pub fn new(scenario: &Scenario) -> Self {
        RunState {
            scenario_hash: scenario_hash(scenario),
            ..RunState::default()
        }
    }

    /// The state recorded in `run`, if any. An unreadable or malformed file counts as none
    /// (the run then starts over, which is always safe).
    pub fn load(run: &RunDir) -> Option<Self> {
        serde_json::from_str(&run.read_to_string(layout::RUN_STATE)?).ok()
    }

    /// Records the state atomically.
    pub fn save(&self, run: &RunDir) -> Result<()> {
        run.write(layout::RUN_STATE, crate::error::to_json(self).as_bytes())?;
        Ok(())
    }

    /// Whether the state belongs to `scenario`.
    pub fn is_for(&self, scenario: &Scenario) -> bool {
        self.scenario_hash == scenario_hash(scenario)
    }

    /// Whether `stage` finished.
    pub fn finished(&self, stage: Stage) -> bool {
        self.finished.iter().any(|s| s == stage.name())
    }

    /// The finished stages that are known to this version.
    pub fn finished_stages(&self) -> Vec<Stage> {
        Stage::ALL
            .into_iter()
            .filter(|&s| self.finished(s))
            .collect()
    }

    /// Records that `stage` finished after `seconds`.
    pub fn finish(&mut self, stage: Stage, seconds: f64) {
        self.finished.push(stage.name().to_string());
        self.seconds.push(seconds);
    }
}

/// FNV-1a (64 bit) of the scenario's commented TOML, as 16 hex digits.
pub fn scenario_hash(scenario: &Scenario) -> String {
    format!("{:016x}", fnv1a(scenario.to_commented_toml().as_bytes()))
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
    fn state_round_trips_and_tracks_the_scenario() {
        // Goal: what `save` writes, `load` reads back; a changed scenario is noticed.
        let root = std::env::temp_dir().join(format!("flexstage-state-{}", std::process::id()));
        let run = RunDir::create(&root).unwrap();
        assert_eq!(RunState::load(&run), None);
        let s = crate::folder::preset("quick").unwrap();
        let mut st = RunState::new(&s);
        st.finish(Stage::Design, 1.5);
        st.finish(Stage::Export, 0.1);
        st.save(&run).unwrap();
        let back = RunState::load(&run).unwrap();
        assert_eq!(back, st);
        assert!(back.finished(Stage::Export) && !back.finished(Stage::Reduce));
        assert_eq!(back.finished_stages(), vec![Stage::Design, Stage::Export]);
        assert!(back.is_for(&s));
        let mut other = s.clone();
        other.optimization.max_iterations += 1;
        assert!(!back.is_for(&other));
        // A damaged file reads as no state.
        run.write(layout::RUN_STATE, b"{ not json").unwrap();
        assert_eq!(RunState::load(&run), None);
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
