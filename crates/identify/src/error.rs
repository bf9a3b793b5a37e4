//! Typed errors of the identification crate.

/// Everything that can go wrong in this crate.
///
/// Messages name the offending field (or CSV line and column), the value found and the
/// accepted range.
#[derive(Debug, thiserror::Error)]
pub enum IdentifyError {
    /// A parameter lies outside its accepted range.
    #[error("{field} = {value} is out of range: expected {expected}")]
    OutOfRange {
        /// The parameter, e.g. `identify.forgetting`.
        field: String,
        /// The value found, formatted.
        value: String,
        /// The accepted range in words.
        expected: String,
    },
    /// The record cannot be identified from (lengths, too few samples, sampling).
    #[error("{what}: {reason}")]
    Data {
        /// Which input.
        what: String,
        /// What is wrong.
        reason: String,
    },
    /// A CSV file lacks a required column.
    #[error(
        "{origin}: missing column {column:?} (found columns: {found}); expected a header with {expected}"
    )]
    MissingColumn {
        /// File name or other origin.
        origin: String,
        /// The column looked for.
        column: String,
        /// The columns present.
        found: String,
        /// The columns expected.
        expected: String,
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
    /// A regressor is (numerically) zero over the record: the excitation does not reach it.
    #[error(
        "no persistent excitation: regressor {regressor:?} of the {row} regression is zero over the record ({hint})"
    )]
    NotExcited {
        /// The regression row (`q_o1`, `q_o2`, `x_in1`, `x_in2`).
        row: &'static str,
        /// The regressor's name.
        regressor: &'static str,
        /// What to change.
        hint: &'static str,
    },
    /// The estimated parameters are not physical (e.g. a negative stiffness).
    #[error("{what}: {reason}")]
    Estimate {
        /// Which parameter.
        what: String,
        /// Why it was rejected.
        reason: String,
    },
    /// An error of the RLS estimator (flexstage-piezo).
    #[error(transparent)]
    Piezo(#[from] flexstage_piezo::PiezoError),
    /// An error of the plant or model (flexstage-control).
    #[error(transparent)]
    Control(#[from] flexstage_control::ControlError),
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, IdentifyError>;

/// Checks `value` (finite) against a predicate.
pub(crate) fn check(field: &str, value: f64, ok: bool, expected: &str) -> Result<()> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(IdentifyError::OutOfRange {
            field: field.to_string(),
            value: format!("{value:e}"),
            expected: expected.to_string(),
        })
    }
}

/// A [`IdentifyError::Data`] error.
pub(crate) fn data_error(what: &str, reason: impl Into<String>) -> IdentifyError {
    IdentifyError::Data {
        what: what.to_string(),
        reason: reason.into(),
    }
}
