//! The simulated stage of a run: the designed mechanism once it is reduced.
//!
//! Stage identification and tracking run on a simulated stage ([`Setup::from_scenario`] takes
//! the plant from `stage.truth` and the controller's model from `stage.guess`). Once the run
//! has a reduced model of its design ([`layout::reduce::PARAMS`]), the plant is that design:
//! `stage.truth` becomes the reduced model, and the guess takes from it what the paper treats
//! as known (Section 4.2: the mass is weighed and α follows from Eq. 27); the stiffnesses and
//! dampings of the guess stay Table 4's. `reduce` records the derived scenario in
//! [`layout::PLANT`] once. Without a reduced model the plant is the scenario's own
//! `stage.truth`.
//!
//! [`Setup::from_scenario`]: flexstage_control::experiment::Setup::from_scenario

use std::path::{Path, PathBuf};

use flexstage_run::Format;
use flexstage_run::files::stage::StageParamsFile;
use flexstage_run::layout;
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
    /// scenario's truth. The reduced model `reduce` stored in this process is not read again.
    pub fn of_run(folder: &RunFolder) -> Result<Plant> {
        let path = folder.dir().path(layout::reduce::PARAMS);
        let Some(file) = folder
            .dir()
            .load::<StageParamsFile>(layout::reduce::PARAMS)?
        else {
            return Ok(Plant {
                scenario: folder.scenario().clone(),
                source: PlantSource::Scenario,
            });
        };
        Ok(Plant {
            scenario: designed(folder.scenario(), file.params.clone())?,
            source: PlantSource::Designed(path),
        })
    }
}

/// Records the run's simulated stage once it is the reduced model `reduced` ([`layout::PLANT`]).
pub(crate) fn store_designed(folder: &RunFolder, reduced: &StageParams) -> Result<()> {
    let plant = designed(folder.scenario(), reduced.clone())?;
    folder.dir().store(layout::PLANT, plant)?;
    Ok(())
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

impl From<&StageParamsFile> for ModelParams {
    fn from(f: &StageParamsFile) -> Self {
        ModelParams {
            params: f.params.clone(),
            coupling: f.coupling.unwrap_or(0.0),
        }
    }
}

/// Reads a stage parameter file with its optional `coupling` key (a finite stiffness in N/m).
pub fn read_model_params(path: &Path) -> Result<ModelParams> {
    let bytes = crate::error::read_bytes(path)?;
    let file = StageParamsFile::decode(&bytes).map_err(|reason| PipelineError::Format {
        path: path.display().to_string(),
        reason,
    })?;
    Ok(ModelParams::from(&file))
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
}
