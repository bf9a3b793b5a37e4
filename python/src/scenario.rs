//! The scenario: built-in presets, TOML, and field-by-field edits that are validated at once
//! with the messages of `flexstage check`.
//!
//! A [`PyScenario`] is always valid: an edit is applied to a copy, the copy is deserialized
//! (types, unknown keys) and validated ([`Scenario::validate`], every group and the relations
//! between them), and only then replaces the scenario. A refused edit changes nothing.

use std::path::PathBuf;

use flexstage_scenario::Scenario;
use pyo3::exceptions::{PyAttributeError, PyIndexError};
use pyo3::prelude::*;
use pythonize::{depythonize, pythonize};
use serde_json::Value;

use crate::errors;

/// One step of a field path: a key of a table or an index into an array of tables.
#[derive(Debug, Clone, FromPyObject, IntoPyObject)]
pub enum Key {
    /// An array index.
    Index(usize),
    /// A table key.
    Name(String),
}

/// The dotted TOML path of `path` (`trajectories[0].frequency`).
fn dotted(path: &[Key]) -> String {
    let mut s = String::new();
    for k in path {
        match k {
            Key::Index(i) => s.push_str(&format!("[{i}]")),
            Key::Name(n) => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(n);
            }
        }
    }
    s
}

/// The path without indices, as the field documentation names it.
fn doc_path(path: &[Key]) -> String {
    let names: Vec<&str> = path
        .iter()
        .filter_map(|k| match k {
            Key::Name(n) => Some(n.as_str()),
            Key::Index(_) => None,
        })
        .collect();
    names.join(".")
}

/// A flexstage scenario (the TOML input deck), always valid.
#[pyclass(module = "flexstage._native", name = "Scenario", eq)]
#[derive(Debug, Clone, PartialEq)]
pub struct PyScenario {
    pub inner: Scenario,
}

impl PyScenario {
    fn value(&self) -> Value {
        serde_json::to_value(&self.inner).expect("a scenario serializes")
    }

    /// Replaces the scenario by `v` once it deserializes and validates; `edited` names the
    /// fields changed, for a value of the wrong type (validation messages name their field).
    fn adopt(&mut self, v: Value, edited: &str) -> PyResult<()> {
        let s: Scenario = serde_json::from_value(v).map_err(|e| {
            errors::ScenarioError::new_err(format!("invalid scenario: {edited}: {e}"))
        })?;
        s.validate().map_err(|e| errors::scenario(&e))?;
        self.inner = s;
        Ok(())
    }
}

/// The value at `path` in `v`, or why there is none.
fn at<'a>(v: &'a Value, path: &[Key]) -> PyResult<&'a Value> {
    let mut cur = v;
    for (depth, k) in path.iter().enumerate() {
        let next = match (k, cur) {
            (Key::Name(n), Value::Object(map)) => map.get(n),
            (Key::Index(i), Value::Array(items)) => {
                let found = items.get(*i);
                if found.is_none() {
                    return Err(PyIndexError::new_err(format!(
                        "{} has {} entries, no index {i}",
                        dotted(&path[..depth]),
                        items.len()
                    )));
                }
                found
            }
            _ => None,
        };
        cur = next.ok_or_else(|| missing(cur, &path[..=depth]))?;
    }
    Ok(cur)
}

fn missing(parent: &Value, path: &[Key]) -> PyErr {
    let fields = match parent {
        Value::Object(map) => map.keys().cloned().collect::<Vec<_>>().join(", "),
        _ => "none (not a table)".into(),
    };
    PyAttributeError::new_err(format!(
        "the scenario has no field {} (fields here: {fields})",
        dotted(path)
    ))
}

/// Sets `path` in `v` to `new` (a table key may be added: an optional field; the
/// deserialization refuses unknown keys).
fn set_at(v: &mut Value, path: &[Key], new: Value) -> PyResult<()> {
    let Some((last, parent)) = path.split_last() else {
        *v = new;
        return Ok(());
    };
    let mut cur = v;
    for (depth, k) in parent.iter().enumerate() {
        let next = match k {
            Key::Name(n) => cur.get_mut(n.as_str()),
            Key::Index(i) => cur.get_mut(*i),
        };
        cur = next.ok_or_else(|| PyAttributeError::new_err(dotted(&path[..=depth])))?;
    }
    match (last, cur) {
        (Key::Name(n), Value::Object(map)) => {
            map.insert(n.clone(), new);
            Ok(())
        }
        (Key::Index(i), Value::Array(items)) if *i < items.len() => {
            items[*i] = new;
            Ok(())
        }
        _ => Err(PyAttributeError::new_err(format!(
            "the scenario has no field {}",
            dotted(path)
        ))),
    }
}

#[pymethods]
impl PyScenario {
    /// A built-in scenario: "quick" (48 × 24, seconds), "paper" (Tables 1, 3, 4, A1) or
    /// "fine" (240 × 120).
    #[staticmethod]
    fn preset(name: &str) -> PyResult<Self> {
        let inner = flexstage_pipeline::folder::preset(name).map_err(errors::pipeline)?;
        Ok(PyScenario { inner })
    }

    /// Parses and validates TOML text; `origin` names it in messages.
    #[staticmethod]
    #[pyo3(signature = (text, origin = "<string>"))]
    fn from_toml(text: &str, origin: &str) -> PyResult<Self> {
        let inner = Scenario::from_toml_str(text, origin).map_err(|e| errors::scenario(&e))?;
        Ok(PyScenario { inner })
    }

    /// Reads, parses and validates a scenario file.
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        let inner = Scenario::load(&path).map_err(|e| errors::scenario(&e))?;
        Ok(PyScenario { inner })
    }

    /// The scenario from `to_json` (exact floats; pickling).
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        let v: Value = serde_json::from_str(text).map_err(|e| errors::scenario(&e))?;
        let mut s = PyScenario::preset("quick")?;
        s.adopt(v, "scenario")?;
        Ok(s)
    }

    /// The scenario as JSON (every float exact).
    fn to_json(&self) -> String {
        serde_json::to_string(&self.inner).expect("a scenario serializes")
    }

    /// The scenario as TOML; `commented`: one comment per field (meaning, unit, source), as
    /// `flexstage init` writes it.
    #[pyo3(signature = (commented = false))]
    fn to_toml(&self, commented: bool) -> String {
        if commented {
            self.inner.to_commented_toml()
        } else {
            self.inner.to_toml()
        }
    }

    /// Writes the commented TOML to `path` atomically.
    fn save(&self, path: PathBuf) -> PyResult<()> {
        flexstage_run::write_atomic(&path, self.inner.to_commented_toml().as_bytes())
            .map_err(errors::run)
    }

    /// Checks every group and the relations between them (always passes: a scenario is
    /// validated when made and at every edit).
    fn validate(&self) -> PyResult<()> {
        self.inner.validate().map_err(|e| errors::scenario(&e))
    }

    /// The value at a field path as plain Python data (tables as dicts).
    fn get<'py>(&self, py: Python<'py>, path: Vec<Key>) -> PyResult<Bound<'py, PyAny>> {
        let v = self.value();
        let found = at(&v, &path);
        let found = match found {
            Err(e) if e.is_instance_of::<PyAttributeError>(py) => {
                // An optional field that is unset reads as None.
                if flexstage_scenario::field_doc(&doc_path(&path)).is_some() {
                    return Ok(py.None().into_bound(py));
                }
                return Err(e);
            }
            other => other?,
        };
        Ok(pythonize(py, found)?)
    }

    /// Whether the value at `path` is a table (an object with fields), an array of tables,
    /// or a plain value: "table", "tables" or "value".
    fn kind(&self, path: Vec<Key>) -> PyResult<&'static str> {
        let v = self.value();
        Ok(match at(&v, &path) {
            Ok(Value::Object(_)) => "table",
            Ok(Value::Array(items)) if items.iter().all(Value::is_object) && !items.is_empty() => {
                "tables"
            }
            _ => "value",
        })
    }

    /// The field names of the table at `path`.
    fn fields(&self, path: Vec<Key>) -> PyResult<Vec<String>> {
        let v = self.value();
        Ok(match at(&v, &path)? {
            Value::Object(map) => map.keys().cloned().collect(),
            _ => Vec::new(),
        })
    }

    /// The number of entries of the array at `path`.
    fn length(&self, path: Vec<Key>) -> PyResult<usize> {
        let v = self.value();
        Ok(match at(&v, &path)? {
            Value::Array(items) => items.len(),
            _ => 0,
        })
    }

    /// Sets several fields at once (one validation for all: for fields that must change
    /// together). A refused edit changes nothing.
    fn set_many(&mut self, items: Vec<(Vec<Key>, Bound<'_, PyAny>)>) -> PyResult<()> {
        let mut v = self.value();
        let edited: Vec<String> = items.iter().map(|(p, _)| dotted(p)).collect();
        for (path, value) in items {
            let new: Value = depythonize(&value).map_err(|e| {
                errors::ScenarioError::new_err(format!(
                    "invalid scenario: {}: {e} (expected numbers, strings, booleans, lists \
                     or dicts)",
                    dotted(&path)
                ))
            })?;
            set_at(&mut v, &path, new)?;
        }
        self.adopt(v, &edited.join(", "))
    }

    /// The documentation of a field (meaning, unit, source), by its path without indices.
    #[staticmethod]
    fn field_doc(path: &str) -> Option<&'static str> {
        flexstage_scenario::field_doc(path)
    }

    /// The scenario's name (its run folder is runs/<name>).
    #[getter]
    fn name(&self) -> &str {
        &self.inner.name
    }

    fn __copy__(&self) -> Self {
        self.clone()
    }

    fn __deepcopy__(&self, _memo: Bound<'_, PyAny>) -> Self {
        self.clone()
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let f = py.get_type::<PyScenario>().getattr("from_json")?;
        Ok((f, (self.to_json(),)))
    }
}
