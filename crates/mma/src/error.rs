//! Typed errors returned by the optimizer and the KKT check.

use thiserror::Error;

/// A parameter of [`crate::MmaParams`] outside its accepted range.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ParamError {
    /// A single field is outside its accepted range.
    #[error("parameter `{field}` = {value} is outside its accepted range {range}")]
    OutOfRange {
        /// Name of the offending field of [`crate::MmaParams`].
        field: &'static str,
        /// The rejected value.
        value: f64,
        /// Human-readable accepted range, e.g. `(0, 1]`.
        range: &'static str,
    },
    /// Two fields are individually valid but inconsistent with each other.
    #[error(
        "parameters `{field}` = {value} and `{other}` = {other_value} are inconsistent: {reason}"
    )]
    Inconsistent {
        /// First field.
        field: &'static str,
        /// Its value.
        value: f64,
        /// Second field.
        other: &'static str,
        /// Its value.
        other_value: f64,
        /// Which relation must hold.
        reason: &'static str,
    },
}

/// Errors of [`crate::Mma`], [`crate::kkt_residual`] and [`crate::minimize`].
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MmaError {
    /// A slice has the wrong length.
    #[error("dimension mismatch for `{name}`: expected length {expected}, got {got}")]
    DimensionMismatch {
        /// Name of the slice (`"x"`, `"df0dx"`, `"f"`, `"dfdx"`, `"xmin"`, ...).
        name: &'static str,
        /// Expected length.
        expected: usize,
        /// Actual length.
        got: usize,
    },
    /// A slice contains NaN or an infinity.
    #[error("non-finite value {value} in `{name}` at index {index}")]
    NonFinite {
        /// Name of the slice.
        name: &'static str,
        /// First offending index (row-major for `dfdx`).
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// `xmin[index] >= xmax[index]`.
    #[error("invalid bounds at index {index}: xmin = {lower} must be < xmax = {upper}")]
    InvalidBounds {
        /// Index of the variable.
        index: usize,
        /// Lower bound.
        lower: f64,
        /// Upper bound.
        upper: f64,
    },
    /// The current iterate lies outside the box `[xmin, xmax]`.
    #[error("x[{index}] = {value} lies outside its bounds [{lower}, {upper}]")]
    OutOfBounds {
        /// Index of the variable.
        index: usize,
        /// Its value.
        value: f64,
        /// Lower bound.
        lower: f64,
        /// Upper bound.
        upper: f64,
    },
    /// The problem has no design variables (`n == 0`).
    #[error("the problem has no design variables (n = 0)")]
    NoVariables,
    /// Invalid [`crate::MmaParams`].
    #[error(transparent)]
    InvalidParams(#[from] ParamError),
}
