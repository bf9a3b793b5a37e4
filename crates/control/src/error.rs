//! Typed errors of the control crate.

use flexstage_numerics::RangeError;

/// Everything that can go wrong when building models, observers and controllers.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ControlError {
    /// A parameter lies outside its accepted range (named by its TOML path when it comes
    /// from the scenario).
    #[error(transparent)]
    OutOfRange(#[from] RangeError),
    /// The simulated stage, its lumped model or a reference (`flexstage-sim`).
    #[error(transparent)]
    Sim(#[from] flexstage_sim::SimError),
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
    /// A measurement a design asked for (e.g. margins by sine injection on the stage) failed.
    #[error("measuring {what}: {detail}")]
    Measurement {
        /// What was measured.
        what: String,
        /// Why it failed.
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

/// A setting the embeddable core refused (its message names the field and the range).
impl From<flexstage_control_core::CoreError> for ControlError {
    fn from(e: flexstage_control_core::CoreError) -> Self {
        use flexstage_control_core::CoreError;
        match e {
            CoreError::Range {
                field,
                value,
                expected,
            } => RangeError::number(field, value, expected).into(),
            CoreError::Buffer {
                field,
                len,
                expected,
            } => RangeError::new(field, len.to_string(), format!("length {expected}")).into(),
        }
    }
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, ControlError>;

flexstage_numerics::range_checks!(ControlError);
