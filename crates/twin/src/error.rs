//! Typed errors of the twin: each names the field, the value and the accepted range, or the
//! stage of the build that failed.

use thiserror::Error;

/// Everything that can go wrong when building, verifying or running the twin.
#[derive(Debug, Error)]
pub enum TwinError {
    /// A parameter lies outside its accepted range.
    #[error("{field} = {value} is out of range: expected {expected}")]
    OutOfRange {
        /// Name of the parameter (its TOML path when it comes from the scenario).
        field: String,
        /// The value found.
        value: String,
        /// The accepted range in words.
        expected: String,
    },
    /// The design does not fit the scenario's mesh.
    #[error("the design has {got} densities, the scenario's mesh {expected} elements")]
    Design {
        /// Densities given.
        got: usize,
        /// Elements of the mesh.
        expected: usize,
    },
    /// The finite-element model rejected the input.
    #[error("finite-element model: {0}")]
    Fem(#[from] flexstage_fem::ParamError),
    /// A sparse factorization or solve failed.
    #[error("linear solver: {0}")]
    Solver(#[from] flexstage_fem::SolverError),
    /// A nonlinear static solve did not converge.
    #[error("nonlinear static solve at x_nom = [{x1:e}, {x2:e}] m did not converge: {source}")]
    Newton {
        /// Nominal stroke of PEA1 \[m\].
        x1: f64,
        /// Nominal stroke of PEA2 \[m\].
        x2: f64,
        /// Cause.
        #[source]
        source: flexstage_fem::NewtonError,
    },
    /// The full transient reference failed.
    #[error("full transient: {0}")]
    Transient(#[from] flexstage_fem::TransientError),
    /// The reduction (problem, modal analysis) failed.
    #[error("reduction: {0}")]
    Reduce(#[from] flexstage_reduce::ReduceError),
    /// The scenario's FE problem could not be built.
    #[error("problem: {0}")]
    Topopt(#[from] flexstage_topopt::TopoptError),
    /// The rig or the lumped model rejected its parameters.
    #[error("rig: {0}")]
    Sim(#[from] flexstage_sim::SimError),
    /// The reduced matrices are not usable (e.g. a massless interface).
    #[error("reduced model: {0}")]
    Reduced(String),
    /// A figure could not be drawn.
    #[error("figure: {0}")]
    Plot(#[from] flexstage_figures::plot::PlotError),
}

/// Result alias.
pub type Result<T> = std::result::Result<T, TwinError>;

/// `Ok` if `ok` and `value` is finite, else [`TwinError::OutOfRange`].
pub(crate) fn check(field: &str, value: f64, ok: bool, expected: &str) -> Result<()> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(TwinError::OutOfRange {
            field: field.to_string(),
            value: format!("{value:e}"),
            expected: expected.to_string(),
        })
    }
}
