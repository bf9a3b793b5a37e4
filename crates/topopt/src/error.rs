//! Typed errors: each names the field or load case and, where it applies, the accepted range.

use flexstage_fem::{NewtonError, ParamError as FemParamError, SolverError};
use thiserror::Error;

/// Errors of the topology optimizer.
#[derive(Debug, Error)]
pub enum TopoptError {
    /// A parameter is outside its accepted range.
    #[error("parameter `{field}` = {value} is outside the accepted range {range}")]
    OutOfRange {
        /// Field name.
        field: &'static str,
        /// Rejected value.
        value: f64,
        /// Accepted range.
        range: &'static str,
    },
    /// The problem description is inconsistent (e.g. a selector picks no node).
    #[error("invalid problem: {0}")]
    Problem(String),
    /// The finite-element model rejected the input.
    #[error(transparent)]
    Fem(#[from] FemParamError),
    /// A linear solve failed.
    #[error(transparent)]
    Solver(#[from] SolverError),
    /// A load case did not converge even after the cutback retries.
    #[error(
        "load case {case} (x_nom = [{x1:e}, {x2:e}] m) did not converge after {attempts} \
         attempts"
    )]
    LoadCase {
        /// Load case index.
        case: usize,
        /// Nominal stroke of input 1 \[m\].
        x1: f64,
        /// Nominal stroke of input 2 \[m\] (0 if there is one input).
        x2: f64,
        /// Attempts made.
        attempts: usize,
        /// The last failure.
        #[source]
        source: NewtonError,
    },
    /// A value that must be finite is NaN or infinite.
    #[error("non-finite {what} at design iteration {iteration}")]
    NonFinite {
        /// What was not finite.
        what: &'static str,
        /// Iteration.
        iteration: usize,
    },
    /// MMA rejected its input.
    #[error("MMA design update failed")]
    Mma(#[from] flexstage_mma::MmaError),
    /// A design or checkpoint file is malformed.
    #[error("{what}: {reason}")]
    Format {
        /// What was read.
        what: String,
        /// Why it was rejected.
        reason: String,
    },
}

/// Result alias.
pub type Result<T> = std::result::Result<T, TopoptError>;

pub(crate) fn check_range(
    field: &'static str,
    value: f64,
    ok: bool,
    range: &'static str,
) -> Result<()> {
    if ok && !value.is_nan() {
        Ok(())
    } else {
        Err(TopoptError::OutOfRange {
            field,
            value,
            range,
        })
    }
}
