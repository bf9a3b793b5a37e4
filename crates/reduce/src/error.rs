//! Typed errors: each names the field or port and, where it applies, the accepted range.

use flexstage_fem::{NewtonError, ParamError as FemParamError, SolverError};
use flexstage_numerics::RangeError;
use thiserror::Error;

/// Errors of the model reduction.
#[derive(Debug, Error)]
pub enum ReduceError {
    /// A parameter is outside its accepted range.
    #[error(transparent)]
    OutOfRange(#[from] RangeError),
    /// The model and the ports or the densities do not fit together.
    #[error("invalid reduction input: {0}")]
    Input(String),
    /// The finite-element model rejected the input.
    #[error(transparent)]
    Fem(#[from] FemParamError),
    /// A linear solve failed (e.g. `K_Tff` is singular: a mechanism).
    #[error(transparent)]
    Solver(#[from] SolverError),
    /// A nonlinear solve did not converge.
    #[error("nonlinear solve at x_nom = [{x1:e}, {x2:e}] m did not converge")]
    Newton {
        /// Nominal stroke of input 1 \[m\].
        x1: f64,
        /// Nominal stroke of input 2 \[m\].
        x2: f64,
        /// Cause.
        #[source]
        source: NewtonError,
    },
    /// The problem could not be built.
    #[error(transparent)]
    Topopt(#[from] flexstage_topopt::TopoptError),
    /// The Lanczos iteration did not converge.
    #[error(
        "modal analysis: {converged} of {wanted} modes converged in {steps} Lanczos steps \
         (raise `ModalParams::max_steps`, accepted range [10, 5000])"
    )]
    Eigen {
        /// Modes requested.
        wanted: usize,
        /// Modes converged.
        converged: usize,
        /// Steps taken.
        steps: usize,
    },
}

/// Result alias.
pub type Result<T> = std::result::Result<T, ReduceError>;

flexstage_numerics::range_checks!(ReduceError);
