//! The Monte-Carlo study one plant at a time, for a Dask cluster.
//!
//! A study travels as its *recipe*: the scenario, the bytes of the run-folder files it reads
//! ([`MonteCarloStudy::inputs`]), the controllers and the settings. A process that receives
//! it writes the files into a temporary run folder, sets the study up there with the
//! pipeline's own code ([`MonteCarloStudy::of_run`]) and keeps it for every later plant of
//! the same recipe. The set-up is deterministic, and plant `i` depends on the seed and `i`
//! alone, so results gathered from any number of workers equal the serial ones bitwise.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use flexstage_pipeline::{MonteCarloStudy, PipelineError, RunFolder, Scenario, TrackOptions};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors;
use crate::work::blocking;

/// The settings of a study (`flexstage_assess::montecarlo::MonteCarloParams`), each
/// optional (a dict with every key, None for the default).
#[derive(Debug, Clone, Default, FromPyObject)]
#[pyo3(from_item_all)]
pub struct Settings {
    plants: Option<usize>,
    duration: Option<f64>,
    rms_bound_pct: Option<f64>,
    seed: Option<u64>,
    spread: Option<f64>,
    coupling: Option<f64>,
    damping: Option<[f64; 2]>,
    max_delay: Option<usize>,
    noise: Option<f64>,
    design: Option<String>,
}

fn params(s: &Settings) -> PyResult<flexstage_assess::montecarlo::MonteCarloParams> {
    let d = flexstage_assess::montecarlo::MonteCarloParams::default();
    let design = match &s.design {
        Some(name) => flexstage_assess::montecarlo::PlantDesign::from_name(name).map_err(|_| {
            errors::pipeline(PipelineError::Option {
                option: "design",
                value: name.clone(),
                expected: "identified (each plant measured, the controllers designed from it) \
                           or nominal (the nominal designs on every plant)"
                    .into(),
            })
        })?,
        None => d.design,
    };
    Ok(flexstage_assess::montecarlo::MonteCarloParams {
        plants: s.plants.unwrap_or(d.plants),
        duration: s.duration.unwrap_or(d.duration),
        rms_bound_pct: s.rms_bound_pct.unwrap_or(d.rms_bound_pct),
        seed: s.seed.unwrap_or(d.seed),
        spread: s.spread.unwrap_or(d.spread),
        coupling: s.coupling.unwrap_or(d.coupling),
        damping: s.damping.unwrap_or(d.damping),
        max_delay: s.max_delay.unwrap_or(d.max_delay),
        noise: s.noise.unwrap_or(d.noise),
        design,
    })
}

/// A study set up in this process.
#[pyclass(module = "flexstage._native", name = "MonteCarloStudy", frozen)]
pub struct PyStudy {
    study: Arc<MonteCarloStudy>,
}

/// Studies set up in this process, by recipe key (a worker keeps the last few).
static STUDIES: Mutex<Vec<(String, Arc<MonteCarloStudy>)>> = Mutex::new(Vec::new());
const KEEP: usize = 4;

fn plant_dict<'py>(
    py: Python<'py>,
    p: &flexstage_assess::montecarlo::PlantResult,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let q = &p.perturbation;
    d.set_item("index", p.index)?;
    d.set_item("stiffness", q.stiffness)?;
    d.set_item("mass", q.mass)?;
    d.set_item("alpha", q.alpha)?;
    d.set_item("damping", q.damping)?;
    d.set_item("coupling", q.coupling)?;
    d.set_item("delay", q.delay)?;
    let rms: Vec<[f64; 2]> = p.results.iter().map(|r| r.1).collect();
    let passed: Vec<bool> = p.results.iter().map(|r| r.2).collect();
    d.set_item("rms", rms)?;
    d.set_item("passed", passed)?;
    Ok(d)
}

#[pymethods]
impl PyStudy {
    /// Sets a study up from its recipe (or takes it from this process's cache): `key`
    /// identifies the recipe, `files` maps run-folder paths to their bytes.
    #[staticmethod]
    #[pyo3(signature = (key, scenario_json, files, controllers, settings, reporter = None))]
    fn build(
        py: Python<'_>,
        key: String,
        scenario_json: &str,
        files: HashMap<String, Vec<u8>>,
        controllers: Vec<String>,
        settings: Settings,
        reporter: Option<Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        if let Some((_, s)) = STUDIES
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .iter()
            .find(|(k, _)| *k == key)
        {
            return Ok(PyStudy { study: s.clone() });
        }
        let scenario: Scenario =
            serde_json::from_str(scenario_json).map_err(|e| errors::scenario(&e))?;
        scenario.validate().map_err(|e| errors::scenario(&e))?;
        let options = TrackOptions {
            controllers: crate::run::variants(Some(controllers))?,
            ..TrackOptions::default()
        };
        let mp = params(&settings)?;

        let study = blocking(py, reporter.as_ref(), |p| {
            let dir = tempdir()?;
            let built = (|| {
                let folder = RunFolder::open(scenario, &dir, false)?;
                for (rel, bytes) in &files {
                    if !MonteCarloStudy::inputs().contains(rel) {
                        return Err(PipelineError::Format {
                            path: rel.clone(),
                            reason: "not an input of the Monte-Carlo study".into(),
                        });
                    }
                    folder.dir().write(rel, bytes)?;
                }
                MonteCarloStudy::of_run(&folder, &options, mp, p)
            })();
            let _ = std::fs::remove_dir_all(&dir);
            built
        })?;
        let study = Arc::new(study);
        let mut cache = STUDIES.lock().unwrap_or_else(|p| p.into_inner());
        cache.push((key, study.clone()));
        if cache.len() > KEEP {
            cache.remove(0);
        }
        Ok(PyStudy { study })
    }

    /// The number of plants.
    #[getter]
    fn plants(&self) -> usize {
        self.study.plants()
    }

    /// The controllers compared, in column order.
    #[getter]
    fn candidates(&self) -> Vec<&'static str> {
        self.study.candidates()
    }

    /// Plant `i`: its perturbation and every controller's RMS error [m] and pass.
    fn plant<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Bound<'py, PyDict>> {
        let study = self.study.clone();
        let p = py
            .detach(move || study.plant(i))
            .map_err(errors::pipeline)?;
        plant_dict(py, &p)
    }

    /// Every plant on this process's threads (a Ctrl-C raises `KeyboardInterrupt` once they
    /// are done: the plants do not poll for it).
    #[pyo3(signature = (reporter = None))]
    fn run<'py>(
        &self,
        py: Python<'py>,
        reporter: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let study = &self.study;
        let mc = blocking(py, reporter.as_ref(), |_| study.run())?;
        mc.plants.iter().map(|p| plant_dict(py, p)).collect()
    }

    /// The run-folder files a study reads (relative paths).
    #[staticmethod]
    fn inputs() -> Vec<String> {
        MonteCarloStudy::inputs()
    }
}

/// A fresh temporary folder for one set-up.
fn tempdir() -> Result<std::path::PathBuf, PipelineError> {
    static COUNT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = COUNT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("flexstage-study-{}-{n}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    Ok(dir)
}
