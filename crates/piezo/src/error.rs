//! Typed errors of the piezo crate.

use flexstage_numerics::records::RecordError;
use flexstage_numerics::{DataError, RangeError};

/// Everything that can go wrong in this crate.
///
/// Messages name the offending field (or CSV line and column), the value found and the
/// accepted range.
#[derive(Debug, thiserror::Error)]
pub enum PiezoError {
    /// A parameter lies outside its accepted range.
    #[error(transparent)]
    OutOfRange(#[from] RangeError),
    /// Input arrays do not fit together (lengths, too few samples, singular data).
    #[error(transparent)]
    Data(#[from] DataError),
    /// A CSV record cannot be read (missing column, bad line).
    #[error(transparent)]
    Record(#[from] RecordError),
}

impl From<flexstage_numerics::Error> for PiezoError {
    fn from(e: flexstage_numerics::Error) -> Self {
        match e {
            flexstage_numerics::Error::OutOfRange(e) => e.into(),
            flexstage_numerics::Error::Data(e) => e.into(),
            flexstage_numerics::Error::Record(e) => e.into(),
        }
    }
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, PiezoError>;

flexstage_numerics::range_checks!(PiezoError);
