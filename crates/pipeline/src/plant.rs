//! The simulated stage of a run: the designed mechanism once it is reduced.
//!
//! Stage identification and tracking run on a simulated stage ([`Setup::from_scenario`] takes
//! the plant from `stage.truth` and the controller's model from `stage.guess`). Once the run
//! has a reduced model of its design ([`layout::reduce::PARAMS`]), the plant is that design:
//! `stage.truth` becomes the reduced model, and the guess takes from it what the paper treats
//! as known (Section 4.2: the mass is weighed and α follows from Eq. 27); the stiffnesses and
//! dampings of the guess stay Table 4's. The derived scenario is recorded in
//! [`layout::PLANT`]. Without a reduced model the plant is the scenario's own `stage.truth`.
//!
//! [`Setup::from_scenario`]: flexstage_control::experiment::Setup::from_scenario

use std::path::{Path, PathBuf};

use flexstage_report::layout;
use flexstage_scenario::{Scenario, StageParams};

use crate::error::{PipelineError, Result};
use crate::folder::RunFolder;

/// Which stage the simulation runs on.
#[derive(Debug, Clone, PartialEq)]
pub enum PlantSource {
    /// The reduced model of the run's design (the file it was read from).
    Designed(PathBuf),
    /// The scenario's `stage.truth` (Table 4 for the built-in scenarios).
    Scenario,
}

impl std::fmt::Display for PlantSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PlantSource::Designed(p) => write!(f, "the designed stage ({})", p.display()),
            PlantSource::Scenario => write!(f, "the scenario's stage.truth (no reduced design)"),
        }
    }
}

/// The scenario of the simulated stage and where its truth comes from.
#[derive(Debug, Clone)]
pub struct Plant {
    /// The scenario with the plant's `stage.truth` and the controller's `stage.guess`.
    pub scenario: Scenario,
    /// Where `stage.truth` comes from.
    pub source: PlantSource,
}

impl Plant {
    /// The plant of a run folder: the designed stage if the run has a reduced model, else the
    /// scenario's truth. Writes [`layout::PLANT`] for the designed stage.
    pub fn of_run(folder: &RunFolder) -> Result<Plant> {
        let path = folder.dir().path(layout::reduce::PARAMS);
        if !path.is_file() {
            return Ok(Plant {
                scenario: folder.scenario().clone(),
                source: PlantSource::Scenario,
            });
        }
        let truth = read_stage_params(&path)?;
        let scenario = designed(folder.scenario(), truth)?;
        folder
            .dir()
            .write(layout::PLANT, scenario.to_commented_toml().as_bytes())?;
        Ok(Plant {
            scenario,
            source: PlantSource::Designed(path),
        })
    }
}

/// `scenario` with `stage.truth = reduced` and the guess's mass and α from it.
pub fn designed(scenario: &Scenario, reduced: StageParams) -> Result<Scenario> {
    let mut plant = scenario.clone();
    plant.stage.guess.mass = reduced.mass;
    plant.stage.guess.alpha = reduced.alpha;
    plant.stage.truth = reduced;
    plant.validate()?;
    Ok(plant)
}

/// Reads and checks a stage parameter file (as written by `reduce` or `identify stage`); a
/// `coupling` key (written by `identify stage`) is accepted and ignored here (see
/// [`read_model_params`]).
pub fn read_stage_params(path: &Path) -> Result<StageParams> {
    Ok(read_model_params(path)?.params)
}

/// The key of the identified cross-axis coupling stiffness k_c \[N/m\] in a parameter file.
pub const COUPLING_KEY: &str = "coupling";

/// A controller's model read from a parameter file: the stage parameters and the cross-axis
/// coupling stiffness k_c of Eq. (30) (`flexstage_sim::model::StageModel::with_coupling`).
#[derive(Debug, Clone, PartialEq)]
pub struct ModelParams {
    /// The stage parameters.
    pub params: StageParams,
    /// k_c \[N/m\]: the file's `coupling` key (written by `identify stage`), 0 without one (a
    /// `reduce` file: the design model has no cross terms).
    pub coupling: f64,
}

/// Reads a stage parameter file with its optional `coupling` key (a finite stiffness in N/m).
pub fn read_model_params(path: &Path) -> Result<ModelParams> {
    let text = crate::error::read_text(path)?;
    parse_model_params(&text, &path.display().to_string())
}

/// [`read_model_params`] on the text of a file named `path` (for messages).
pub fn parse_model_params(text: &str, path: &str) -> Result<ModelParams> {
    let format = |reason: String| PipelineError::Format {
        path: path.to_string(),
        reason,
    };
    let mut table: toml::Table =
        toml::from_str(text).map_err(|e| format(format!("not a stage parameter table: {e}")))?;
    let coupling = match table.remove(COUPLING_KEY) {
        None => 0.0,
        Some(v) => match v.as_float().or_else(|| v.as_integer().map(|i| i as f64)) {
            Some(k) if k.is_finite() => k,
            _ => {
                return Err(format(format!(
                    "{COUPLING_KEY} = {v} is not a finite stiffness [N/m] (the cross-axis \
                     coupling k_c of Eq. 30)"
                )));
            }
        },
    };
    let params: StageParams = toml::Value::Table(table)
        .try_into()
        .map_err(|e| format(format!("not a stage parameter table: {e}")))?;
    params.validate("params")?;
    Ok(ModelParams { params, coupling })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_designed_plant_takes_truth_mass_and_alpha_from_the_reduced_model() {
        // Goal: Section 4.2's split between known (M, α) and identified parameters.
        let s = crate::folder::preset("quick").unwrap();
        let mut reduced = s.stage.truth.clone();
        reduced.mass *= 1.5;
        reduced.alpha *= 0.9;
        reduced.k_qo1 *= 2.0;
        let p = designed(&s, reduced.clone()).unwrap();
        assert_eq!(p.stage.truth, reduced);
        assert_eq!(p.stage.guess.mass, reduced.mass);
        assert_eq!(p.stage.guess.alpha, reduced.alpha);
        assert_eq!(
            p.stage.guess.k_qo1, s.stage.guess.k_qo1,
            "stiffness stays a guess"
        );
        let mut bad = reduced;
        bad.mass = -1.0;
        assert!(designed(&s, bad).is_err());
    }

    #[test]
    fn a_parameter_file_keeps_its_coupling() {
        // Goal: the identified k_c is a real field of params.toml and reads back; a file
        // without it (reduce) has none; a bad value is refused with the key and the value.
        let p = crate::folder::preset("quick").unwrap().stage.truth;
        let body = toml::to_string(&p).unwrap();
        let with = format!("{COUPLING_KEY} = 1234.5\n{body}");
        let m = parse_model_params(&with, "params.toml").unwrap();
        assert_eq!((m.params.clone(), m.coupling), (p.clone(), 1234.5));
        assert_eq!(parse_model_params(&body, "p").unwrap().coupling, 0.0);
        let e = parse_model_params(&format!("{COUPLING_KEY} = \"x\"\n{body}"), "p")
            .unwrap_err()
            .to_string();
        assert!(e.contains("coupling") && e.contains("\"x\""), "{e}");
        let e = parse_model_params(&format!("typo = 1\n{body}"), "p")
            .unwrap_err()
            .to_string();
        assert!(e.contains("typo"), "unknown keys stay refused: {e}");
    }
}
