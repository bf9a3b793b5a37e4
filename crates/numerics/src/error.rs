//! The error of the operations that can fail in more than one way.

use crate::validate::{DataError, RangeError};

/// An error of this crate: a setting out of range, data that do not fit, or a malformed
/// record. The stage crates flatten it into their own error enums,
/// which wrap each kind.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Error {
    /// A setting outside its accepted range.
    #[error(transparent)]
    OutOfRange(#[from] RangeError),
    /// Input data that do not fit together.
    #[error(transparent)]
    Data(#[from] DataError),
    /// A CSV record that cannot be read.
    #[error(transparent)]
    Record(#[from] crate::records::RecordError),
}
