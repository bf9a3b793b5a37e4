//! The results of a run folder as Python data, read through `flexstage-run`'s typed files
//! (never by parsing result files here): documents as dicts (pythonize of their serde types),
//! tables of named columns as dicts of zero-copy numpy views ([`crate::arrays`]), tables of
//! typed rows as lists of dicts with numbers as floats.
//!
//! Each function returns `None` when the stage has not written its result.

use std::collections::HashMap;
use std::sync::Arc;

use flexstage_run::files::design::{DesignFile, DesignSummaryFile};
use flexstage_run::files::export::VerificationFile;
use flexstage_run::files::pea::PeaEstimates;
use flexstage_run::files::reduce::ReduceSummaryJson;
use flexstage_run::files::stage::{ParameterRow, ResponseFitFile, ResponseRow, StageParamsFile};
use flexstage_run::files::track::{MarginRow, MetricsRow, MonteCarloRow, ScanRow};
use flexstage_run::files::twin::{ModeRow, TwinValidity};
use flexstage_run::format::{Format, Row, Rows};
use flexstage_run::layout::{self, Analysis, PeaIdentification, Tracking};
use flexstage_run::{RunDir, Table};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use pythonize::pythonize;
use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::{Map, Value};

use crate::arrays::{owned2, view1, view2};
use crate::errors;

fn load<F: Format>(dir: &RunDir, rel: &str) -> PyResult<Option<Arc<F>>> {
    dir.load::<F>(rel).map_err(errors::run)
}

/// A table of named columns as {name: read-only view}.
pub fn columns<'py>(py: Python<'py>, table: &Arc<Table>) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (i, name) in table.header.iter().enumerate() {
        d.set_item(name, view1(py, table, |t| t.columns[i].as_slice())?)?;
    }
    Ok(d)
}

fn table<'py>(py: Python<'py>, dir: &RunDir, rel: &str) -> PyResult<Option<Bound<'py, PyDict>>> {
    load::<Table>(dir, rel)?
        .map(|t| columns(py, &t))
        .transpose()
}

/// An output polygon table (µm) as an (n, 2) array in metres.
fn polygon<'py>(py: Python<'py>, dir: &RunDir, rel: &str) -> PyResult<Option<Bound<'py, PyAny>>> {
    let Some(t) = load::<Table>(dir, rel)? else {
        return Ok(None);
    };
    let pairs = t
        .pairs(layout_polygon::X, layout_polygon::Y)
        .map_err(|reason| {
            errors::run(flexstage_run::RunError::Damaged {
                path: dir.path(rel),
                reason,
            })
        })?;
    let rows: Vec<[f64; 2]> = pairs.iter().map(|(x, y)| [x * 1e-6, y * 1e-6]).collect();
    Ok(Some(owned2(py, &rows).into_any()))
}

mod layout_polygon {
    use flexstage_run::files::design::POLYGON;
    pub const X: &str = POLYGON[0];
    pub const Y: &str = POLYGON[1];
}

/// The keys of a row type whose cells are numbers (written as text by the CSV formats):
/// those whose text parses as a number and that the type reads back as numbers.
fn numeric_keys<T: DeserializeOwned>(row: &Map<String, Value>) -> Vec<String> {
    let candidates: Vec<&String> = row
        .iter()
        .filter(|(_, v)| matches!(v, Value::String(s) if s.is_empty() || s.parse::<f64>().is_ok()))
        .map(|(k, _)| k)
        .collect();
    let reads = |keys: &[&String]| {
        let mut m = row.clone();
        for k in keys {
            let Value::String(s) = &m[k.as_str()] else {
                continue;
            };
            m[k.as_str()] = if s.is_empty() {
                Value::Null
            } else {
                Value::from(0.0)
            };
        }
        serde_json::from_value::<T>(Value::Object(m)).is_ok()
    };
    if reads(&candidates) {
        return candidates.into_iter().cloned().collect();
    }
    // A text field that looks like a number (a trajectory named "1"): leave it text.
    let mut keys = candidates.clone();
    for k in &candidates {
        let without: Vec<&String> = keys.iter().copied().filter(|x| x != k).collect();
        if reads(&without) {
            keys = without;
        }
    }
    keys.into_iter().cloned().collect()
}

/// Typed rows as a list of dicts, numbers as floats (NaN and ∞ kept).
pub fn rows<'py, T: Row + Serialize + DeserializeOwned>(
    py: Python<'py>,
    rows: &[T],
) -> PyResult<Bound<'py, PyList>> {
    let list = PyList::empty(py);
    let mut numeric: Option<Vec<String>> = None;
    for r in rows {
        let Value::Object(map) =
            serde_json::to_value(r).map_err(|e| errors::FlexstageError::new_err(e.to_string()))?
        else {
            continue;
        };
        let keys = numeric.get_or_insert_with(|| numeric_keys::<T>(&map));
        let d = PyDict::new(py);
        for (k, v) in &map {
            match v {
                Value::String(s) if keys.contains(k) => {
                    if s.is_empty() {
                        d.set_item(k, py.None())?;
                    } else {
                        d.set_item(k, s.parse::<f64>().unwrap_or(f64::NAN))?;
                    }
                }
                other => d.set_item(k, pythonize(py, other)?)?,
            }
        }
        list.append(d)?;
    }
    Ok(list)
}

fn rows_file<'py, T: Row + Serialize + DeserializeOwned>(
    py: Python<'py>,
    dir: &RunDir,
    rel: &str,
) -> PyResult<Option<Bound<'py, PyList>>> {
    load::<Rows<T>>(dir, rel)?
        .map(|r| rows(py, &r.0))
        .transpose()
}

fn doc<'py, F: Format + Serialize>(
    py: Python<'py>,
    dir: &RunDir,
    rel: &str,
) -> PyResult<Option<Bound<'py, PyAny>>> {
    load::<F>(dir, rel)?
        .map(|v| Ok(pythonize(py, &*v)?))
        .transpose()
}

/// A stage parameter file: `params` (Eq. 31–35), `coupling` k_c \[N/m\] and its header lines.
fn params_file<'py>(
    py: Python<'py>,
    dir: &RunDir,
    rel: &str,
) -> PyResult<Option<Bound<'py, PyDict>>> {
    let Some(f) = load::<StageParamsFile>(dir, rel)? else {
        return Ok(None);
    };
    let d = PyDict::new(py);
    d.set_item("params", pythonize(py, &f.params)?)?;
    d.set_item("coupling", f.coupling)?;
    d.set_item("header", f.header.clone())?;
    d.set_item("path", dir.path(rel))?;
    Ok(Some(d))
}

/// `design/`: densities (nl, nw), polygons, history, summary.
pub fn design<'py>(py: Python<'py>, dir: &RunDir) -> PyResult<Option<Bound<'py, PyDict>>> {
    use layout::design as f;
    let Some(file) = load::<DesignFile>(dir, f::DESIGN)? else {
        return Ok(None);
    };
    let d = PyDict::new(py);
    d.set_item("density", view2(py, &file, file.nl, file.nw, |f| &f.rho)?)?;
    d.set_item("iterations", file.iterations)?;
    d.set_item("area_initial", file.area_initial)?;
    d.set_item("area", file.area)?;
    d.set_item("grey_fraction", file.grey_fraction)?;
    d.set_item("record", pythonize(py, &file.summary)?)?;
    d.set_item("summary", doc::<DesignSummaryFile>(py, dir, f::SUMMARY)?)?;
    d.set_item("workspace_initial", polygon(py, dir, f::WORKSPACE_INITIAL)?)?;
    d.set_item("workspace_final", polygon(py, dir, f::WORKSPACE_FINAL)?)?;
    d.set_item("history", table(py, dir, f::HISTORY_CSV)?)?;
    d.set_item("cases", table(py, dir, f::CASES)?)?;
    d.set_item("folder", dir.path(f::DIR))?;
    Ok(Some(d))
}

/// `analyze/<variant>/`.
pub fn analysis<'py>(
    py: Python<'py>,
    dir: &RunDir,
    variant: &str,
) -> PyResult<Option<Bound<'py, PyDict>>> {
    let a = Analysis::variant(variant);
    let Some(summary) =
        doc::<flexstage_run::files::analyze::AnalysisSummary>(py, dir, &a.summary())?
    else {
        return Ok(None);
    };
    let d = PyDict::new(py);
    d.set_item("summary", summary)?;
    d.set_item("cases", table(py, dir, &a.cases())?)?;
    d.set_item("folder", dir.path(a.dir()))?;
    Ok(Some(d))
}

/// `export/`: the verification and the outline files.
pub fn export<'py>(py: Python<'py>, dir: &RunDir) -> PyResult<Option<Bound<'py, PyDict>>> {
    use layout::export as f;
    if !dir.exists(f::DXF) {
        return Ok(None);
    }
    let d = PyDict::new(py);
    d.set_item(
        "verification",
        doc::<VerificationFile>(py, dir, f::VERIFICATION_JSON)?,
    )?;
    let files = PyDict::new(py);
    for (k, rel) in [("dxf", f::DXF), ("svg", f::SVG), ("stl", f::STL)] {
        files.set_item(k, dir.path(rel))?;
    }
    d.set_item("files", files)?;
    d.set_item("folder", dir.path(f::DIR))?;
    Ok(Some(d))
}

/// `reduce/`: summary, parameters, modes and mode shapes, validity map.
pub fn reduce<'py>(py: Python<'py>, dir: &RunDir) -> PyResult<Option<Bound<'py, PyDict>>> {
    use layout::reduce as f;
    let Some(summary) = load::<ReduceSummaryJson>(dir, f::SUMMARY_JSON)? else {
        return Ok(None);
    };
    let d = PyDict::new(py);
    d.set_item("summary", pythonize(py, &summary.0)?)?;
    d.set_item("params", params_file(py, dir, f::PARAMS)?)?;
    d.set_item("modes", table(py, dir, f::MODES_CSV)?)?;
    d.set_item("mode_shapes", table(py, dir, f::MODE_SHAPES_CSV)?)?;
    d.set_item("validity", table(py, dir, f::VALIDITY_CSV)?)?;
    d.set_item("validity_scale", table(py, dir, f::VALIDITY_SCALE_CSV)?)?;
    d.set_item("folder", dir.path(f::DIR))?;
    Ok(Some(d))
}

/// `twin/`: validity, modes, Bode data.
pub fn twin<'py>(py: Python<'py>, dir: &RunDir) -> PyResult<Option<Bound<'py, PyDict>>> {
    use layout::twin as f;
    let Some(validity) = doc::<TwinValidity>(py, dir, f::VALIDITY)? else {
        return Ok(None);
    };
    let d = PyDict::new(py);
    d.set_item("validity", validity)?;
    d.set_item("modes", rows_file::<ModeRow>(py, dir, f::MODES)?)?;
    d.set_item("bode", table(py, dir, f::BODE)?)?;
    d.set_item("folder", dir.path(f::DIR))?;
    Ok(Some(d))
}

/// `identify/pea<N>/`.
pub fn pea_identification<'py>(
    py: Python<'py>,
    dir: &RunDir,
    pea: u8,
) -> PyResult<Option<Bound<'py, PyDict>>> {
    let out = PeaIdentification { pea };
    let Some(estimates) = doc::<PeaEstimates>(py, dir, &out.estimates())? else {
        return Ok(None);
    };
    let d = PyDict::new(py);
    d.set_item("pea", pea)?;
    d.set_item("estimates", estimates)?;
    d.set_item("convergence", table(py, dir, &out.convergence_csv())?)?;
    d.set_item("loop", table(py, dir, &out.loop_csv())?)?;
    d.set_item("compensation", table(py, dir, &out.compensation_csv())?)?;
    d.set_item("folder", dir.path(out.dir()))?;
    Ok(Some(d))
}

/// `identify/stage/` (and its `twin/` part).
pub fn stage_identification<'py>(
    py: Python<'py>,
    dir: &RunDir,
) -> PyResult<Option<Bound<'py, PyDict>>> {
    use layout::stage as f;
    let params = params_file(py, dir, f::PARAMS)?;
    let twin_params = params_file(py, dir, f::TWIN_PARAMS)?;
    if params.is_none() && twin_params.is_none() {
        return Ok(None);
    }
    let d = PyDict::new(py);
    d.set_item("params", params)?;
    d.set_item("table", rows_file::<ParameterRow>(py, dir, f::TABLE)?)?;
    d.set_item("convergence", table(py, dir, f::CONVERGENCE_CSV)?)?;
    d.set_item("twin_params", twin_params)?;
    d.set_item(
        "twin_table",
        rows_file::<ParameterRow>(py, dir, f::TWIN_TABLE)?,
    )?;
    d.set_item(
        "response",
        rows_file::<ResponseRow>(py, dir, f::RESPONSE_CSV)?,
    )?;
    d.set_item(
        "response_fit",
        doc::<ResponseFitFile>(py, dir, f::RESPONSE_FIT)?,
    )?;
    d.set_item("folder", dir.path(f::DIR))?;
    Ok(Some(d))
}

/// `margins.csv` as [`rows`], its gain margin a float too: the file writes an unstable
/// loop's as `unstable`, which keeps the column text for a generic reader; here it is `None`
/// (no margin), as an empty optional cell of the other columns.
fn margin_rows<'py>(
    py: Python<'py>,
    dir: &RunDir,
    rel: &str,
) -> PyResult<Option<Bound<'py, PyList>>> {
    let Some(file) = load::<Rows<MarginRow>>(dir, rel)? else {
        return Ok(None);
    };
    let list = rows(py, &file.0)?;
    for (d, r) in list.iter().zip(&file.0) {
        d.set_item("gain_margin_dB", r.gain_margin_db)?;
    }
    Ok(Some(list))
}

/// `track/[<conditions>/]`: metrics, margins, Monte-Carlo, scan, and every time series.
pub fn tracking<'py>(
    py: Python<'py>,
    dir: &RunDir,
    conditions: &str,
) -> PyResult<Option<Bound<'py, PyDict>>> {
    let out = Tracking::variant(conditions);
    let Some(metrics) = load::<Rows<MetricsRow>>(dir, &out.metrics())? else {
        return Ok(None);
    };
    let d = PyDict::new(py);
    d.set_item("metrics", rows(py, &metrics.0)?)?;
    d.set_item("margins", margin_rows(py, dir, &out.margins())?)?;
    d.set_item(
        "montecarlo",
        rows_file::<MonteCarloRow>(py, dir, &out.montecarlo())?,
    )?;
    d.set_item(
        "scan",
        rows_file::<ScanRow>(py, dir, &out.scan_frequency_csv())?,
    )?;
    let series = PyDict::new(py);
    let mut seen: HashMap<(String, String), ()> = HashMap::new();
    for m in &metrics.0 {
        let key = (m.trajectory.clone(), m.variant.clone());
        if seen.insert(key, ()).is_some() {
            continue;
        }
        let rel = out.record(&m.trajectory, &m.variant);
        if let Some(t) = table(py, dir, &rel)? {
            series.set_item((m.trajectory.as_str(), m.variant.as_str()), t)?;
        }
    }
    d.set_item("series", series)?;
    d.set_item("folder", dir.path(out.dir()))?;
    Ok(Some(d))
}
