//! Typed errors: each names the field, the value and the accepted range, or the place (mm)
//! where the geometry is at fault.

use thiserror::Error;

/// Errors of the verification.
#[derive(Debug, Error)]
pub enum VerifyError {
    /// A parameter is outside its accepted range.
    #[error("parameter `{field}` = {} is outside the accepted range {range}", flexstage_numerics::compact(*.value))]
    OutOfRange {
        /// Field name.
        field: &'static str,
        /// Rejected value.
        value: f64,
        /// Accepted range.
        range: &'static str,
    },
    /// The outline cannot be meshed as given.
    #[error("outline: {0}")]
    Outline(String),
    /// A port or support of the scenario does not touch the outline.
    #[error(
        "{what} at ({x_mm:.2}, {y_mm:.2}) mm has no outline boundary within {radius_mm:.2} mm \
         (is the port region void in the design?)"
    )]
    Port {
        /// Which port.
        what: String,
        /// x \[mm\].
        x_mm: f64,
        /// y \[mm\].
        y_mm: f64,
        /// Search radius \[mm\].
        radius_mm: f64,
    },
    /// A solid part that carries a port or support is not held against rigid motion.
    #[error(
        "the solid part around ({x_mm:.2}, {y_mm:.2}) mm is not held against {motion}: \
         the outline is a mechanism, not a compliant structure"
    )]
    Mechanism {
        /// x of the part's centroid \[mm\].
        x_mm: f64,
        /// y of the part's centroid \[mm\].
        y_mm: f64,
        /// "translation" or "rotation".
        motion: &'static str,
    },
    /// The mesh would exceed the node budget.
    #[error(
        "the body-fitted mesh needs more than {limit} nodes (raise `VerifyParams::max_nodes` or \
         `min_element`, or lower `elements_across`)"
    )]
    Budget {
        /// The budget.
        limit: usize,
    },
    /// The sparse factorization failed.
    #[error("linear solver: {0}")]
    Solver(String),
    /// The eigen-solver did not converge.
    #[error("modal analysis: {converged} of {wanted} modes converged in {steps} Lanczos steps")]
    Eigen {
        /// Modes wanted.
        wanted: usize,
        /// Modes converged.
        converged: usize,
        /// Steps taken.
        steps: usize,
    },
    /// The design-mesh model could not be built or solved.
    #[error("design mesh: {0}")]
    DesignMesh(String),
}

/// Result alias.
pub type Result<T> = std::result::Result<T, VerifyError>;

/// `Ok` if `ok` and `value` is finite, else [`VerifyError::OutOfRange`].
pub(crate) fn check(field: &'static str, value: f64, ok: bool, range: &'static str) -> Result<()> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(VerifyError::OutOfRange {
            field,
            value,
            range,
        })
    }
}
