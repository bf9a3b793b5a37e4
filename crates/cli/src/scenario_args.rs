//! How every subcommand gets its scenario: a file, or a built-in preset.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use flexstage_scenario::{Preset, Scenario};

/// Scenario selection shared by the subcommands.
#[derive(Debug, Args)]
pub struct ScenarioArgs {
    /// Scenario file (TOML). Without it, the built-in preset is used.
    pub scenario: Option<PathBuf>,
    /// Built-in scenario when no file is given: "paper", "quick" or "fine".
    #[arg(long, default_value = "paper", value_parser = flexstage_scenario::Preset::NAMES)]
    pub preset: String,
}

impl ScenarioArgs {
    /// Loads and validates the scenario.
    pub fn load(&self) -> anyhow::Result<Scenario> {
        match &self.scenario {
            Some(path) => Scenario::load(path).context("invalid scenario"),
            None => {
                let preset = Preset::from_name(&self.preset)
                    .with_context(|| format!("unknown preset {:?}", self.preset))?;
                Ok(Scenario::preset(preset))
            }
        }
    }

    /// Where the scenario comes from, for messages.
    pub fn describe(&self) -> String {
        match &self.scenario {
            Some(p) => p.display().to_string(),
            None => format!("built-in preset {:?}", self.preset),
        }
    }
}
