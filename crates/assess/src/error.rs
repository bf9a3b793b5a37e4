//! Typed errors of the assessment.

/// Everything that can go wrong in an assessment.
#[derive(Debug, thiserror::Error)]
pub enum AssessError {
    /// A controller, tuning or margin setting (names the field, value and range).
    #[error(transparent)]
    Control(#[from] flexstage_control::ControlError),
    /// The simulated stage or a reference (`flexstage-sim`).
    #[error(transparent)]
    Sim(#[from] flexstage_sim::SimError),
    /// Building or running the twin.
    #[error(transparent)]
    Twin(#[from] flexstage_twin::TwinError),
    /// An error of the measured response (flexstage-identify).
    #[error(transparent)]
    Identify(#[from] flexstage_identify::IdentifyError),
    /// Drawing a figure.
    #[error(transparent)]
    Plot(#[from] flexstage_figures::plot::PlotError),
    /// A setting of the assessment itself out of range.
    #[error(transparent)]
    OutOfRange(#[from] flexstage_numerics::RangeError),
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, AssessError>;
flexstage_numerics::range_checks!(AssessError);
