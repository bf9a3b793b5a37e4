//! Typed errors of the piezo crate.

/// Everything that can go wrong in this crate.
///
/// Messages name the offending field (or CSV line and column), the value found and the
/// accepted range.
#[derive(Debug, thiserror::Error)]
pub enum PiezoError {
    /// A parameter lies outside its accepted range.
    #[error("{field} = {value} is out of range: expected {expected}")]
    OutOfRange {
        /// The parameter, e.g. `bouc_wen.d_p`.
        field: String,
        /// The value found, formatted.
        value: String,
        /// The accepted range in words.
        expected: String,
    },
    /// Input arrays do not fit together (lengths, too few samples, singular data).
    #[error("{what}: {reason}")]
    Data {
        /// Which input.
        what: String,
        /// What is wrong.
        reason: String,
    },
    /// A CSV file lacks a required column.
    #[error(
        "{origin}: missing column {column:?} (found columns: {found}); expected a header with t, U, x"
    )]
    MissingColumn {
        /// File name or other origin.
        origin: String,
        /// The column looked for.
        column: &'static str,
        /// The columns present.
        found: String,
    },
    /// A CSV cell is not a finite number, or a row is malformed.
    #[error("{origin}, line {line}: {reason}")]
    Csv {
        /// File name or other origin.
        origin: String,
        /// 1-based line number in the file.
        line: u64,
        /// What is wrong with the line.
        reason: String,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, PiezoError>;

/// Checks `value` (finite) against a predicate.
pub(crate) fn check(field: &str, value: f64, ok: bool, expected: &str) -> Result<()> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(PiezoError::OutOfRange {
            field: field.to_string(),
            value: format!("{value:e}"),
            expected: expected.to_string(),
        })
    }
}

/// A [`PiezoError::Data`] error.
pub(crate) fn data_error(what: &str, reason: impl Into<String>) -> PiezoError {
    PiezoError::Data {
        what: what.to_string(),
        reason: reason.into(),
    }
}
