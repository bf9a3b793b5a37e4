//! Typed errors of the control crate.

/// Everything that can go wrong when building models, observers and controllers.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ControlError {
    /// A parameter lies outside its accepted range.
    #[error("{field} = {value} is out of range: expected {expected}")]
    OutOfRange {
        /// Name of the parameter (its TOML path when it comes from the scenario).
        field: String,
        /// The value found, formatted.
        value: String,
        /// The accepted range in words.
        expected: String,
    },
    /// A matrix that must be invertible is singular (or numerically so).
    #[error("{what} is singular")]
    Singular {
        /// Which matrix.
        what: String,
    },
    /// A matrix that must be Hurwitz (continuous) or Schur (discrete) is not.
    #[error("{what} is not stable: {detail}")]
    Unstable {
        /// Which matrix.
        what: String,
        /// The offending eigenvalue or margin.
        detail: String,
    },
    /// A reference the rig cannot follow (frequency, amplifier range or current, stroke).
    #[error("{what}: {detail}")]
    Infeasible {
        /// What is exceeded.
        what: String,
        /// By how much, and what to change.
        detail: String,
    },
    /// Matrices of incompatible sizes.
    #[error("{what}: dimension mismatch ({detail})")]
    Dimension {
        /// Which operation.
        what: String,
        /// The sizes.
        detail: String,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, ControlError>;

/// `ok && value.is_finite()`, or an [`ControlError::OutOfRange`].
pub(crate) fn check(field: &str, value: f64, ok: bool, expected: &str) -> Result<()> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(ControlError::OutOfRange {
            field: field.to_string(),
            value: format!("{value:e}"),
            expected: expected.to_string(),
        })
    }
}

/// `value` is finite and > 0.
pub(crate) fn positive(field: &str, value: f64) -> Result<()> {
    check(field, value, value > 0.0, "a finite number > 0")
}

/// `value` is finite and ≥ 0.
pub(crate) fn non_negative(field: &str, value: f64) -> Result<()> {
    check(field, value, value >= 0.0, "a finite number ≥ 0")
}
