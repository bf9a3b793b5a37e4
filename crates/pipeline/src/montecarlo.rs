//! The Monte-Carlo study of `track` on its own, one plant at a time, so that a caller can
//! spread the plants over processes or machines (the Python package sends them to a Dask
//! cluster) and gather the same results as [`MonteCarloStudy::run`], bitwise: plant `i`
//! depends on the study's seed and `i` alone (`flexstage_assess::montecarlo`).
//!
//! A study is set up from a run folder as `track` sets up its own study on the twin: the
//! nominal twin and the compensator from the identified PEAs ([`mod@crate::track`]); with
//! the default [`PlantDesign::Identified`] each plant is measured and designed on when it is
//! computed, with [`PlantDesign::Nominal`] the controllers are designed once, from the
//! nominal twin measured in its rig at the controller's sample time.
//! [`MonteCarloStudy::inputs`] lists the files it reads, so that another process can rebuild
//! it in a folder of its own.

use flexstage_assess::Bench;
use flexstage_assess::montecarlo::{
    MonteCarlo, MonteCarloParams, PlantDesign, PlantResult, one_plant,
};
use flexstage_control::experiment::Setup;
use flexstage_control::registry::Controller;
use flexstage_run::files::lifted::LiftedLineRow;
use flexstage_run::files::measured::MeasuredLineRow;
use flexstage_run::format::Rows;
use flexstage_run::layout::{self, PeaIdentification, Tracking};
use flexstage_sim::trajectory::Reference;

use crate::error::{PipelineError, Result};
use crate::folder::RunFolder;
use crate::progress::Progress;
use crate::track::{Prepared, Simulated, TrackOptions, prepare};

/// The Monte-Carlo study of a run's controllers on perturbed twins.
#[derive(Debug, Clone)]
pub struct MonteCarloStudy {
    bench: Bench,
    candidates: Vec<&'static Controller>,
    reference: Reference,
    params: MonteCarloParams,
}

impl MonteCarloStudy {
    /// Sets the study up from the run folder as `track` does (its [`TrackOptions`]: the
    /// controllers and the controllers' model; the plant must be the twin), on the
    /// scenario's first trajectory.
    pub fn of_run(
        folder: &RunFolder,
        options: &TrackOptions,
        params: MonteCarloParams,
        progress: &dyn Progress,
    ) -> Result<MonteCarloStudy> {
        params.validate()?;
        let Prepared {
            setup, sim, plant, ..
        } = prepare(folder, options, progress, None)?;
        let Simulated::Twin(twin) = sim else {
            return Err(PipelineError::Missing {
                what: "twin of the design",
                path: folder.dir().path(layout::design::DESIGN),
                hint: "the Monte-Carlo study perturbs the twin of the run's finished design \
                       (run `design` first)"
                    .into(),
            });
        };
        let Some(first) = plant.scenario.trajectories.first() else {
            return Err(PipelineError::Option {
                option: "trajectories",
                value: "none".into(),
                expected: "at least one trajectory (the study tracks the first)".into(),
            });
        };
        let (reference, _) = Reference::from_scenario(first);
        crate::progress::check_stop(progress, "the study stopped before tuning", "")?;
        let bench = match params.design {
            // Each plant is measured and designed on: the nominal stage as the scenario
            // gives it, nothing designed.
            PlantDesign::Identified => Bench::scenario(setup, *twin)?,
            PlantDesign::Nominal => nominal_bench(folder, options, &setup, &twin, progress)?,
        };
        Ok(MonteCarloStudy {
            bench,
            candidates: options.controllers.clone(),
            reference,
            params,
        })
    }

    /// The run-folder files [`MonteCarloStudy::of_run`] reads with the default options
    /// (relative paths; the measured and the lifted response only when `track` stored them,
    /// and read only for [`PlantDesign::Nominal`]): a folder
    /// holding these and the scenario sets up the same study.
    pub fn inputs() -> Vec<String> {
        let mut files = vec![
            layout::PLANT.to_string(),
            layout::design::DESIGN.to_string(),
            layout::stage::PARAMS.to_string(),
            Tracking::main().measured_response(),
            Tracking::main().lifted_response(),
        ];
        files.extend([1, 2].map(|pea| PeaIdentification { pea }.estimates()));
        files
    }

    /// The number of plants.
    pub fn plants(&self) -> usize {
        self.params.plants
    }

    /// The controllers compared, in column order (their `track` names).
    pub fn candidates(&self) -> Vec<&'static str> {
        self.candidates.iter().map(|c| c.name).collect()
    }

    /// The study's settings.
    pub fn params(&self) -> &MonteCarloParams {
        &self.params
    }

    /// Plant `i` (in `0..plants()`) and every controller's result on it.
    pub fn plant(&self, i: usize) -> Result<PlantResult> {
        if i >= self.params.plants {
            return Err(PipelineError::Option {
                option: "montecarlo.plant",
                value: i.to_string(),
                expected: format!("an index in [0, {})", self.params.plants),
            });
        }
        Ok(one_plant(
            &self.bench,
            &self.candidates,
            self.reference,
            &self.params,
            i,
        )?)
    }

    /// Every plant, in parallel on this process's threads.
    pub fn run(&self) -> Result<MonteCarlo> {
        Ok(flexstage_assess::montecarlo::monte_carlo(
            &self.bench,
            &self.candidates,
            self.reference,
            &self.params,
        )?)
    }
}

/// The bench with every controller designed from the nominal twin's measurement, as `track`
/// designs it: the run's own measurement when `track` stored one under these conditions
/// (with its lifted response when stored; the designs from them are bitwise those from
/// measuring again), else a new one.
fn nominal_bench(
    folder: &RunFolder,
    options: &TrackOptions,
    setup: &Setup,
    twin: &flexstage_twin::Twin,
    progress: &dyn Progress,
) -> Result<Bench> {
    let out = Tracking::variant(&options.conditions(folder));
    let stored = out.measured_response();
    Ok(match folder.dir().load::<Rows<MeasuredLineRow>>(&stored)? {
        Some(response) => {
            let lifted = folder
                .dir()
                .load::<Rows<LiftedLineRow>>(&out.lifted_response())?;
            progress.note(&format!("designing the controllers from {stored}"));
            let t0 = std::time::Instant::now();
            let files = crate::track::MeasuredFiles {
                response: (*response).clone(),
                lifted: lifted.map(|l| (*l).clone()),
            };
            crate::track::bench_from_rows(setup, twin, &files, false, progress, t0)?
        }
        None => {
            progress.note("designing the controllers from the twin measured in its rig");
            crate::track::measured_bench(setup, twin, false, progress)?.0
        }
    })
}
