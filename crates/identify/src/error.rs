//! Typed errors of the identification crate.

use flexstage_numerics::records::RecordError;
use flexstage_numerics::{DataError, RangeError};

/// Everything that can go wrong in this crate.
///
/// Messages name the offending field (or CSV line and column), the value found and the
/// accepted range.
#[derive(Debug, thiserror::Error)]
pub enum IdentifyError {
    /// A parameter lies outside its accepted range.
    #[error(transparent)]
    OutOfRange(#[from] RangeError),
    /// The record cannot be identified from (lengths, too few samples, sampling).
    #[error(transparent)]
    Data(#[from] DataError),
    /// A CSV record cannot be read (missing column, bad line).
    #[error(transparent)]
    Record(#[from] RecordError),
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
    /// An error of the PEA model (flexstage-piezo).
    #[error(transparent)]
    Piezo(#[from] flexstage_piezo::PiezoError),
    /// An error of the simulated plant or the lumped model (flexstage-sim).
    #[error(transparent)]
    Sim(#[from] flexstage_sim::SimError),
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, IdentifyError>;

flexstage_numerics::range_checks!(IdentifyError);
