//! Typed errors of the scenario crate.

use std::path::PathBuf;

/// Everything that can be wrong with a scenario.
///
/// Messages name the offending field by its TOML path (e.g. `material.youngs_modulus`),
/// the value found and the accepted range.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// A numeric field lies outside its accepted range.
    #[error("{field} = {value} is out of range: expected {expected}")]
    OutOfRange {
        /// TOML path of the field.
        field: String,
        /// The value found, formatted.
        value: String,
        /// The accepted range in words, e.g. "a finite number > 0".
        expected: String,
    },
    /// Two fields contradict each other.
    #[error("{fields}: {reason}")]
    Inconsistent {
        /// The TOML paths involved.
        fields: String,
        /// What is wrong.
        reason: String,
    },
    /// The TOML text does not parse or does not match the schema (unknown key, wrong type).
    #[error("cannot parse {path}")]
    Parse {
        /// Where the text came from.
        path: String,
        /// The parser's diagnosis, with line and column.
        #[source]
        source: Box<toml::de::Error>,
    },
    /// The scenario file could not be read.
    #[error("cannot read scenario {path}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, ScenarioError>;

/// Checks `value` against a predicate and builds an [`ScenarioError::OutOfRange`] otherwise.
pub(crate) fn check(field: &str, value: f64, ok: bool, expected: &str) -> Result<()> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(ScenarioError::OutOfRange {
            field: field.to_string(),
            value: format!("{value:e}"),
            expected: expected.to_string(),
        })
    }
}

/// `value` is finite and strictly positive.
pub(crate) fn positive(field: &str, value: f64) -> Result<()> {
    check(field, value, value > 0.0, "a finite number > 0")
}

/// `value` is finite and non-negative.
pub(crate) fn non_negative(field: &str, value: f64) -> Result<()> {
    check(field, value, value >= 0.0, "a finite number ≥ 0")
}

/// `lo ≤ value ≤ hi`.
pub(crate) fn within(field: &str, value: f64, lo: f64, hi: f64) -> Result<()> {
    check(
        field,
        value,
        (lo..=hi).contains(&value),
        &format!("a number in [{lo}, {hi}]"),
    )
}

/// An integer at least `min` (and at most `max`).
pub(crate) fn count(field: &str, value: usize, min: usize, max: usize) -> Result<()> {
    if (min..=max).contains(&value) {
        Ok(())
    } else {
        Err(ScenarioError::OutOfRange {
            field: field.to_string(),
            value: value.to_string(),
            expected: format!("an integer in [{min}, {max}]"),
        })
    }
}
