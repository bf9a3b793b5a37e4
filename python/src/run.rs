//! A run folder and the pipeline's stages on it, each a call into `flexstage-pipeline` with
//! its typed options (defaults from the options' `Default`, as the CLI's), run without the
//! GIL ([`crate::work`]). A stage returns its summary as the CLI prints it, its warnings and
//! what it wrote; the results themselves are read back through the typed files
//! ([`crate::results`]).

use std::path::PathBuf;

use flexstage_pipeline::names::{self, COMPENSATIONS, SCHEMES, SHAPES, UNITS};
use flexstage_pipeline::summary::Summary;
use flexstage_pipeline::{
    AnalyzeOptions, CONTROLLERS, Controller, DesignOptions, DesignSource, DesignStart,
    ExportOptions, LimitOverrides, PeaIdOptions, PeaOptions, PipelineError, PlantKind,
    ReduceOptions, RunFolder, RunOptions, Simulation, StageData, StageIdOptions, TrackOptions,
    TwinOptions, TwinValidation,
};
use numpy::PyArray1;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors;
use crate::results;
use crate::scenario::PyScenario;
use crate::work::blocking;

/// What a stage call returns: its summary text, warnings and written paths.
type Outcome = (String, Vec<String>, Vec<PathBuf>);

/// What `run` returns: its summary text, the report's path and the verdict's text.
type RunOutcome = (String, PathBuf, String);

fn outcome(s: &impl Summary) -> Outcome {
    let (written, _) = s.written();
    (
        s.to_string(),
        s.warnings().to_vec(),
        written.into_iter().map(PathBuf::from).collect(),
    )
}

/// A named option value, or the option error naming the accepted ones.
fn named<T: Copy>(table: &[(&'static str, T)], option: &'static str, value: &str) -> PyResult<T> {
    names::parse(table, value).ok_or_else(|| {
        let accepted: Vec<&str> = table.iter().map(|(n, _)| *n).collect();
        errors::pipeline(PipelineError::Option {
            option,
            value: format!("{value:?}"),
            expected: format!("one of {}", accepted.join(", ")),
        })
    })
}

fn design_source(text: Option<&str>) -> PyResult<Option<DesignSource>> {
    text.map(|t| t.parse().map_err(errors::pipeline))
        .transpose()
}

fn plant_kind(option: &'static str, name: &str) -> PyResult<PlantKind> {
    PlantKind::from_name(name).ok_or_else(|| {
        errors::pipeline(PipelineError::Option {
            option,
            value: format!("{name:?}"),
            expected: "one of twin, lumped".into(),
        })
    })
}

pub(crate) fn variants(names: Option<Vec<String>>) -> PyResult<Vec<&'static Controller>> {
    let Some(names) = names else {
        return Ok(Controller::defaults());
    };
    names
        .iter()
        .map(|n| {
            Controller::by_name(n).ok_or_else(|| {
                let all: Vec<&str> = CONTROLLERS.iter().map(|c| c.name).collect();
                errors::pipeline(PipelineError::Option {
                    option: "track.controllers",
                    value: format!("{n:?}"),
                    expected: format!("controllers among {}", all.join(", ")),
                })
            })
        })
        .collect()
}

/// A run folder, locked by this object until `close()` (or until it is collected).
#[pyclass(module = "flexstage._native", name = "Run")]
pub struct PyRun {
    folder: Option<RunFolder>,
}

impl PyRun {
    fn folder(&self) -> PyResult<&RunFolder> {
        self.folder.as_ref().ok_or_else(|| {
            errors::RunFolderError::new_err("this run is closed (its lock was released)")
        })
    }
}

#[pymethods]
impl PyRun {
    /// Opens (creating) the run folder `path` (default `runs/<scenario name>`) for
    /// `scenario`; a folder of another scenario is refused unless `replace`.
    #[new]
    #[pyo3(signature = (scenario, path = None, replace = false))]
    fn new(scenario: &PyScenario, path: Option<PathBuf>, replace: bool) -> PyResult<Self> {
        let s = scenario.inner.clone();
        let root = path.unwrap_or_else(|| flexstage_pipeline::default_root(&s));
        let folder = RunFolder::open(s, root, replace).map_err(errors::pipeline)?;
        Ok(PyRun {
            folder: Some(folder),
        })
    }

    /// Opens an existing run folder with the scenario recorded in it.
    #[staticmethod]
    fn existing(path: PathBuf) -> PyResult<Self> {
        let folder = RunFolder::existing(path).map_err(errors::pipeline)?;
        Ok(PyRun {
            folder: Some(folder),
        })
    }

    /// Releases the folder's lock.
    fn close(&mut self) {
        self.folder = None;
    }

    /// The folder.
    #[getter]
    fn path(&self) -> PyResult<PathBuf> {
        Ok(self.folder()?.root().to_path_buf())
    }

    /// The scenario of the run.
    #[getter]
    fn scenario(&self) -> PyResult<PyScenario> {
        Ok(PyScenario {
            inner: self.folder()?.scenario().clone(),
        })
    }

    /// What opening the folder did (a stale lock taken over, temporaries removed).
    #[getter]
    fn notices(&self) -> PyResult<Vec<String>> {
        Ok(self.folder()?.notices().to_vec())
    }

    #[pyo3(signature = (reporter, force, resume, max_iterations, checkpoint_every, snapshot_every))]
    #[allow(clippy::too_many_arguments)]
    fn design(
        &self,
        py: Python<'_>,
        reporter: Option<Bound<'_, PyAny>>,
        force: bool,
        resume: bool,
        max_iterations: Option<usize>,
        checkpoint_every: Option<usize>,
        snapshot_every: Option<usize>,
    ) -> PyResult<Outcome> {
        let folder = self.folder()?;
        let d = DesignOptions::default();
        let options = DesignOptions {
            checkpoint_every: checkpoint_every.unwrap_or(d.checkpoint_every),
            snapshot_every: snapshot_every.unwrap_or(d.snapshot_every),
            max_iterations,
        };
        let start = if resume {
            DesignStart::Resume
        } else {
            DesignStart::Fresh { force }
        };
        let s = blocking(py, reporter.as_ref(), |p| {
            flexstage_pipeline::design(folder, &options, start, p)
        })?;
        Ok(outcome(&s))
    }

    /// Returns the outcome and the analysis folder's variant name.
    #[pyo3(signature = (reporter, design, inputs))]
    fn analyze(
        &self,
        py: Python<'_>,
        reporter: Option<Bound<'_, PyAny>>,
        design: Option<String>,
        inputs: Vec<[f64; 2]>,
    ) -> PyResult<(Outcome, String)> {
        let folder = self.folder()?;
        let options = AnalyzeOptions {
            design: design_source(design.as_deref())?,
            inputs,
        };
        let s = blocking(py, reporter.as_ref(), |_| {
            flexstage_pipeline::analyze(folder, &options)
        })?;
        let variant = s
            .dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        Ok((outcome(&s), variant))
    }

    #[pyo3(signature = (reporter, design, unit, level, smoothing, max_chord, verify, limits))]
    #[allow(clippy::too_many_arguments)]
    fn export(
        &self,
        py: Python<'_>,
        reporter: Option<Bound<'_, PyAny>>,
        design: Option<String>,
        unit: &str,
        level: Option<f64>,
        smoothing: Option<usize>,
        max_chord: Option<f64>,
        verify: bool,
        limits: [Option<f64>; 5],
    ) -> PyResult<(Outcome, bool)> {
        let folder = self.folder()?;
        let d = ExportOptions::default();
        let [
            fatigue_strength,
            safety_factor,
            min_ligament,
            min_gap,
            start_hole_diameter,
        ] = limits;
        let options = ExportOptions {
            design: design_source(design.as_deref())?.unwrap_or(DesignSource::Run),
            unit: named(&UNITS, "export.unit", unit)?,
            level: level.unwrap_or(d.level),
            smoothing: smoothing.unwrap_or(d.smoothing),
            max_chord: max_chord.unwrap_or(d.max_chord),
            verify: verify.then_some(LimitOverrides {
                fatigue_strength,
                safety_factor,
                min_ligament,
                min_gap,
                start_hole_diameter,
            }),
        };
        let s = blocking(py, reporter.as_ref(), |_| {
            flexstage_pipeline::export(folder, &options)
        })?;
        Ok((outcome(&s), s.safe()))
    }

    #[pyo3(signature = (reporter, design, operating_point, modes, lumped, plate_masses, scales, keep_output_spring))]
    #[allow(clippy::too_many_arguments)]
    fn reduce(
        &self,
        py: Python<'_>,
        reporter: Option<Bound<'_, PyAny>>,
        design: Option<String>,
        operating_point: Option<[f64; 2]>,
        modes: Option<usize>,
        lumped: bool,
        plate_masses: bool,
        scales: Option<Vec<f64>>,
        keep_output_spring: bool,
    ) -> PyResult<Outcome> {
        let folder = self.folder()?;
        let d = ReduceOptions::default();
        let options = ReduceOptions {
            design: design_source(design.as_deref())?,
            operating_point,
            modes: modes.unwrap_or(d.modes),
            lumped,
            plate_masses,
            scales: scales.unwrap_or(d.scales),
            keep_output_spring,
        };
        let s = blocking(py, reporter.as_ref(), |p| {
            flexstage_pipeline::reduce(folder, &options, p)
        })?;
        Ok(outcome(&s))
    }

    #[pyo3(signature = (reporter, validation))]
    fn twin(
        &self,
        py: Python<'_>,
        reporter: Option<Bound<'_, PyAny>>,
        validation: &str,
    ) -> PyResult<Outcome> {
        let folder = self.folder()?;
        let validation = named(
            &[
                ("auto", TwinValidation::Auto),
                ("on", TwinValidation::On),
                ("off", TwinValidation::Off),
            ],
            "twin.validation",
            validation,
        )?;
        let options = TwinOptions { validation };
        let s = blocking(py, reporter.as_ref(), |p| {
            flexstage_pipeline::write_twin(folder, &options, p)
        })?;
        Ok(outcome(&s))
    }

    /// Simulates a PEA record; writes it to the run folder when `write`. Returns the
    /// summary text, the arrays t [s], U [V], x [µm] (moved into numpy, not copied) and the
    /// written paths.
    #[pyo3(signature = (pea, shape, frequency, cycles, noise_nm, dt, seed, write))]
    #[allow(clippy::too_many_arguments)]
    fn simulate_pea<'py>(
        &self,
        py: Python<'py>,
        pea: u8,
        shape: &str,
        frequency: Option<f64>,
        cycles: Option<u32>,
        noise_nm: Option<f64>,
        dt: Option<f64>,
        seed: Option<u64>,
        write: bool,
    ) -> PyResult<(String, Bound<'py, PyDict>, Vec<PathBuf>)> {
        let folder = self.folder()?;
        let d = PeaOptions::default();
        let options = PeaOptions {
            pea,
            shape: named(&SHAPES, "pea.shape", shape)?,
            frequency: frequency.unwrap_or(d.frequency),
            cycles: cycles.unwrap_or(d.cycles),
            noise_nm: noise_nm.unwrap_or(d.noise_nm),
            dt,
            seed,
        };
        let (rec, written) = blocking(py, None, |_| {
            let rec = flexstage_pipeline::simulate_pea(folder.scenario(), &options)?;
            let written = if write {
                flexstage_pipeline::write_pea_record(folder, &rec)?.0
            } else {
                Vec::new()
            };
            Ok((rec, written))
        })?;
        let text = rec.to_string();
        let (t, u, x) = rec.data.into_columns();
        let arrays = PyDict::new(py);
        arrays.set_item("t", PyArray1::from_vec(py, t))?;
        arrays.set_item("u", PyArray1::from_vec(py, u))?;
        arrays.set_item("x", PyArray1::from_vec(py, x))?;
        Ok((text, arrays, written))
    }

    /// Identifies PEA `pea` from the run's record, a CSV file (`path`), or arrays
    /// (`t` [s], `u` [V], `x` [µm]).
    #[pyo3(signature = (pea, path, arrays, forgetting, passes))]
    fn identify_pea(
        &self,
        py: Python<'_>,
        pea: u8,
        path: Option<PathBuf>,
        arrays: Option<(Vec<f64>, Vec<f64>, Vec<f64>)>,
        forgetting: Option<f64>,
        passes: Option<u32>,
    ) -> PyResult<Outcome> {
        let folder = self.folder()?;
        let d = PeaIdOptions::default();
        let options = PeaIdOptions {
            pea,
            data: path,
            forgetting: forgetting.unwrap_or(d.forgetting),
            passes: passes.unwrap_or(d.passes),
        };
        let s = blocking(py, None, |_| match arrays {
            Some((t, u, x)) => {
                let data = flexstage_piezo::PeaData::new(t, u, x)?;
                let origin = PathBuf::from("<arrays>");
                flexstage_pipeline::pea::identify_pea_data(folder, &options, &origin, &data)
            }
            None => flexstage_pipeline::identify_pea(folder, &options),
        })?;
        Ok(outcome(&s))
    }

    /// Identifies the stage: by a simulated multisine (`data` None), from a record file
    /// (`path`), or from arrays (`columns`: t, input pair, x_in pair, q pair; `voltage`:
    /// whether the input pair is U1, U2 [V] instead of x_nom1, x_nom2 [m]).
    #[pyo3(signature = (reporter, path, columns, voltage, plant, duration, f_max, resonance_amplitude, linear, noise, estimator))]
    #[allow(clippy::too_many_arguments)]
    fn identify_stage(
        &self,
        py: Python<'_>,
        reporter: Option<Bound<'_, PyAny>>,
        path: Option<PathBuf>,
        columns: Option<[Vec<f64>; 7]>,
        voltage: bool,
        plant: &str,
        duration: Option<f64>,
        f_max: Option<f64>,
        resonance_amplitude: Option<f64>,
        linear: bool,
        noise: bool,
        estimator: (
            Option<f64>,
            Option<f64>,
            Option<usize>,
            Option<String>,
            bool,
        ),
    ) -> PyResult<Outcome> {
        use flexstage_identify::data::{Columns, Input};
        let folder = self.folder()?;
        let d = Simulation::default();
        let data = match (path, columns) {
            (Some(p), _) => StageData::Record(p),
            (None, Some([t, i1, i2, x1, x2, q1, q2])) => StageData::Columns {
                t,
                input: if voltage {
                    Input::Voltage([i1, i2])
                } else {
                    Input::Nominal([i1, i2])
                },
                columns: Columns {
                    x_in: [x1, x2],
                    q: [q1, q2],
                },
                origin: "<arrays>".into(),
            },
            (None, None) => StageData::Simulate(Simulation {
                plant: plant_kind("identify_stage.plant", plant)?,
                duration,
                f_max: f_max.unwrap_or(d.f_max),
                resonance_amplitude: resonance_amplitude.unwrap_or(d.resonance_amplitude),
                linear,
                noise,
            }),
        };
        let mut options = StageIdOptions {
            data,
            ..StageIdOptions::default()
        };
        let (forgetting, prefilter, decimation, scheme, coupling) = estimator;
        let e = &mut options.estimator;
        e.forgetting = forgetting.unwrap_or(e.forgetting);
        e.prefilter = prefilter.unwrap_or(e.prefilter);
        e.decimation = decimation.unwrap_or(e.decimation);
        if let Some(s) = scheme {
            e.scheme = named(&SCHEMES, "identify_stage.scheme", &s)?;
        }
        e.coupling = coupling;
        let s = blocking(py, reporter.as_ref(), |p| {
            flexstage_pipeline::identify_stage(folder, &options, p)
        })?;
        Ok(outcome(&s))
    }

    /// Tracking; returns the outcome and the folder's conditions name ("" for `track/`).
    #[pyo3(signature = (reporter, plant, trajectory, controllers, compensation, params, allow_foreign_params, duration, learning, montecarlo_plants = None))]
    #[allow(clippy::too_many_arguments)]
    fn track(
        &self,
        py: Python<'_>,
        reporter: Option<Bound<'_, PyAny>>,
        plant: &str,
        trajectory: Option<String>,
        controllers: Option<Vec<String>>,
        compensation: &str,
        params: Option<PathBuf>,
        allow_foreign_params: bool,
        duration: Option<f64>,
        learning: Option<usize>,
        montecarlo_plants: Option<usize>,
    ) -> PyResult<(Outcome, String)> {
        let folder = self.folder()?;
        let options = TrackOptions {
            plant: plant_kind("track.plant", plant)?,
            trajectory,
            controllers: variants(controllers)?,
            compensation: named(&COMPENSATIONS, "track.compensation", compensation)?,
            params,
            allow_foreign_params,
            duration,
            learning,
            montecarlo_plants: montecarlo_plants
                .unwrap_or(TrackOptions::default().montecarlo_plants),
        };
        let s = blocking(py, reporter.as_ref(), |p| {
            flexstage_pipeline::track(folder, &options, p)
        })?;
        let conditions = options.conditions(folder);
        let mut o = outcome(&s);
        o.0.push_str(&s.margins_table());
        Ok((o, conditions))
    }

    /// Writes report.html; returns its path.
    fn report(&self, py: Python<'_>) -> PyResult<PathBuf> {
        let folder = self.folder()?;
        blocking(py, None, |_| flexstage_pipeline::write_report(folder))
    }

    /// Every stage in order, resuming after the finished ones (`flexstage run`). Returns the
    /// summary text, the report's path and the verdict (what was designed, whether it is safe,
    /// which controller to use, what was limited).
    #[pyo3(signature = (reporter, restart))]
    fn run(
        &self,
        py: Python<'_>,
        reporter: Option<Bound<'_, PyAny>>,
        restart: bool,
    ) -> PyResult<RunOutcome> {
        let folder = self.folder()?;
        let options = RunOptions {
            restart,
            ..RunOptions::default()
        };
        let s = blocking(py, reporter.as_ref(), |p| {
            flexstage_pipeline::run_in(folder, &options, p)
        })?;
        Ok((s.to_string(), s.report.clone(), s.verdict.to_string()))
    }

    /// The recipe of the run's Monte-Carlo study: the scenario as JSON and the bytes of the
    /// files the study reads (those the folder has).
    fn study_recipe(&self) -> PyResult<(String, std::collections::HashMap<String, Vec<u8>>)> {
        let folder = self.folder()?;
        let mut files = std::collections::HashMap::new();
        for rel in flexstage_pipeline::MonteCarloStudy::inputs() {
            if let Some(bytes) = folder.dir().read(&rel).map_err(errors::run)? {
                files.insert(rel, bytes);
            }
        }
        let json = serde_json::to_string(folder.scenario()).expect("a scenario serializes");
        Ok((json, files))
    }

    /// The run's finished design, or None.
    fn load_design<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        results::design(py, self.folder()?.dir())
    }

    /// The analysis in `analyze/<variant>/`, or None.
    fn load_analysis<'py>(
        &self,
        py: Python<'py>,
        variant: &str,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        if !flexstage_run::layout::is_plain_name(variant) {
            return Err(errors::pipeline(PipelineError::Option {
                option: "analysis",
                value: format!("{variant:?}"),
                expected: "a folder name of analyze/ (letters, digits, -, _, .)".into(),
            }));
        }
        results::analysis(py, self.folder()?.dir(), variant)
    }

    fn load_export<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        results::export(py, self.folder()?.dir())
    }

    fn load_reduction<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        results::reduce(py, self.folder()?.dir())
    }

    fn load_twin<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        results::twin(py, self.folder()?.dir())
    }

    fn load_pea_identification<'py>(
        &self,
        py: Python<'py>,
        pea: u8,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        results::pea_identification(py, self.folder()?.dir(), pea)
    }

    /// The run's PEA record `pea/pea<N>.csv` as arrays t, u, x, or None.
    fn load_pea_record<'py>(
        &self,
        py: Python<'py>,
        pea: u8,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        let path = self
            .folder()?
            .dir()
            .path(flexstage_run::layout::pea::record(pea));
        if !path.is_file() {
            return Ok(None);
        }
        let file = std::fs::File::open(&path).map_err(|source| {
            errors::pipeline(PipelineError::Read {
                path: path.clone(),
                source,
            })
        })?;
        let data = flexstage_piezo::PeaData::from_csv(
            std::io::BufReader::new(file),
            &path.display().to_string(),
        )
        .map_err(|e| errors::pipeline(e.into()))?;
        let (t, u, x) = data.into_columns();
        let d = PyDict::new(py);
        d.set_item("t", PyArray1::from_vec(py, t))?;
        d.set_item("u", PyArray1::from_vec(py, u))?;
        d.set_item("x", PyArray1::from_vec(py, x))?;
        Ok(Some(d))
    }

    fn load_stage_identification<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        results::stage_identification(py, self.folder()?.dir())
    }

    fn load_tracking<'py>(
        &self,
        py: Python<'py>,
        conditions: &str,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        if !(conditions.is_empty() || flexstage_run::layout::is_plain_name(conditions)) {
            return Err(errors::pipeline(PipelineError::Option {
                option: "conditions",
                value: format!("{conditions:?}"),
                expected: "a folder name of track/ (letters, digits, -, _, .)".into(),
            }));
        }
        results::tracking(py, self.folder()?.dir(), conditions)
    }
}
