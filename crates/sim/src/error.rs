//! Typed errors of the simulation crate.

use flexstage_numerics::RangeError;

/// Everything that can go wrong when building the simulated stage, its models and its
/// references.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// A parameter lies outside its accepted range (named by its TOML path when it comes
    /// from the scenario).
    #[error(transparent)]
    OutOfRange(#[from] RangeError),
    /// A matrix that must be invertible is singular (or numerically so).
    #[error("{what} is singular")]
    Singular {
        /// Which matrix.
        what: String,
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
pub type Result<T> = std::result::Result<T, SimError>;

flexstage_numerics::range_checks!(SimError);
