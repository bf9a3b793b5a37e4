//! Arguments shared by the subcommands: the scenario, the run folder, and value types whose
//! defaults come from `flexstage_pipeline`'s options.

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

use anyhow::Context;
use clap::Args;
use clap::builder::{PossibleValue, PossibleValuesParser};
use flexstage_pipeline::{
    CONTROLLERS, Controller, DEFAULT_PRESET, PRESETS, PlantKind, RunFolder, Scenario,
    TwinValidation, default_root, load_scenario,
};

/// Which scenario: a file, or a built-in preset.
#[derive(Debug, Args)]
pub struct ScenarioArgs {
    /// Scenario file (TOML). Without it, the built-in preset is used.
    pub scenario: Option<PathBuf>,
    /// Built-in scenario when no file is given: "quick" (coarse, seconds) or "paper"
    /// (Tables 1, 3, 4, A1).
    #[arg(long, default_value = DEFAULT_PRESET, value_parser = PRESETS)]
    pub preset: String,
}

impl ScenarioArgs {
    /// Loads and validates the scenario.
    pub fn load(&self) -> anyhow::Result<Scenario> {
        load_scenario(self.scenario.as_deref(), &self.preset).context("invalid scenario")
    }

    /// Where the scenario comes from, for messages.
    pub fn describe(&self) -> String {
        match &self.scenario {
            Some(p) => p.display().to_string(),
            None => format!("built-in preset {:?}", self.preset),
        }
    }
}

/// The scenario and the run folder its results go to.
#[derive(Debug, Args)]
pub struct Target {
    #[command(flatten)]
    pub scenario: ScenarioArgs,
    /// Run folder (default runs/<scenario name>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace what this command otherwise refuses to replace (a finished design, a run
    /// folder recorded with another scenario, an existing --output file).
    #[arg(long)]
    pub force: bool,
}

impl Target {
    /// Opens the run folder with the scenario (refusing one of another scenario unless
    /// --force).
    pub fn open(&self) -> anyhow::Result<RunFolder> {
        let s = self.scenario.load()?;
        let root = self.out.clone().unwrap_or_else(|| default_root(&s));
        Ok(opened(RunFolder::open(s, root, self.force)?))
    }
}

/// Shows what opening the folder did (a stale lock taken over, temporaries removed).
pub fn opened(folder: RunFolder) -> RunFolder {
    for line in folder.notices() {
        errln!("note: {line}");
    }
    folder
}

/// A pair "X1,X2" of numbers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pair(pub [f64; 2]);

impl FromStr for Pair {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let v = List::from_str(s)?.0;
        match v.as_slice() {
            [a, b] => Ok(Pair([*a, *b])),
            _ => Err(format!("expected two numbers \"X1,X2\", got {s:?}")),
        }
    }
}

/// A comma-separated list of numbers (the empty string is the empty list).
#[derive(Debug, Clone, PartialEq)]
pub struct List(pub Vec<f64>);

impl FromStr for List {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s.trim().is_empty() {
            return Ok(List(Vec::new()));
        }
        s.split(',')
            .map(|x| x.trim().parse::<f64>().map_err(|e| format!("{x:?}: {e}")))
            .collect::<Result<_, _>>()
            .map(List)
    }
}

impl fmt::Display for List {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v: Vec<String> = self.0.iter().map(f64::to_string).collect();
        write!(f, "{}", v.join(","))
    }
}

/// The value of `--variant` that selects the default controllers.
pub const ALL_VARIANTS: &str = "all";

/// The values of `--variant`: every controller of the registry by name, with its label, and
/// [`ALL_VARIANTS`].
pub fn variants() -> PossibleValuesParser {
    let all = PossibleValue::new(ALL_VARIANTS).help("the controllers that run by default");
    PossibleValuesParser::new(
        CONTROLLERS
            .iter()
            .map(|c| {
                let label = if c.default {
                    c.label.to_string()
                } else {
                    format!("{} (only when named)", c.label)
                };
                PossibleValue::new(c.name).help(label)
            })
            .chain([all]),
    )
}

/// The controllers of `--variant` (checked by clap against [`variants`]): one by name, or
/// the defaults.
pub fn controllers(name: &str) -> Vec<&'static Controller> {
    Controller::by_name(name).map_or_else(Controller::defaults, |c| vec![c])
}

/// The values of `--plant`.
pub const TRACK_PLANTS: [&str; 2] = ["twin", "lumped"];

/// The plant of a `--plant` value (checked by clap against [`TRACK_PLANTS`]).
pub fn plant(name: &str) -> PlantKind {
    PlantKind::from_name(name).unwrap_or_default()
}

/// The values of `--twin-validate`.
pub const TWIN_VALIDATIONS: [&str; 3] = ["auto", "on", "off"];

/// The check of a `--twin-validate` value (checked by clap against [`TWIN_VALIDATIONS`]).
pub fn twin_validation(name: &str) -> TwinValidation {
    match name {
        "on" => TwinValidation::On,
        "off" => TwinValidation::Off,
        _ => TwinValidation::Auto,
    }
}
