//! # flexstage-run
//!
//! The run folder of flexstage, in one place: every file's name ([`layout`]), the folder
//! type with atomic writes and typed reads ([`RunDir`]), one serde type per structured file
//! ([`files`], each with its format version), and the resume state that records every
//! finished stage's files with their SHA-256 ([`state`]).
//!
//! ```text
//! runs/<scenario-name>/
//!   scenario.toml      the scenario exactly as used
//!   <stage>/...        one sub-folder per pipeline stage (design, reduce, identify, track)
//! ```
//!
//! The stage crates return values; the pipeline converts them into these types and stores
//! them here, and the report reads them back from here. Nothing else names a run file (CI
//! greps for the names outside this crate). Numbers round-trip: a value stored is the value
//! loaded (serde_json with `float_roundtrip`, TOML floats, CSV cells in Rust's shortest
//! round-trip form or a stated fixed precision).
//!
//! Every write is *atomic* ([`write_atomic`]): a temporary file in the target folder,
//! flushed, renamed over the target. A crash or `kill -9` leaves the old file or the new
//! one, never half a file.

mod dir;
pub mod files;
pub mod format;
pub mod hash;
pub mod layout;
pub mod state;

pub use dir::{
    RunDir, TEMPORARY_SEARCH_DEPTH, WrittenFile, create_folder, temporary_name, temporary_pid,
    write_atomic,
};
pub use format::{Format, Table};
pub use state::RunState;

/// The scenario types the files hold (the input deck, `flexstage-scenario`).
pub use flexstage_scenario as scenario;

use std::path::PathBuf;

/// Errors of the run folder.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// A file or folder could not be written.
    #[error("cannot write {path}")]
    Write {
        /// The path.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A folder cannot be created because of what is in its place.
    #[error("cannot create the folder {path}: {reason}")]
    Folder {
        /// The folder asked for.
        path: PathBuf,
        /// What is in the way, in words.
        reason: String,
    },
    /// A file could not be read.
    #[error("cannot read {path}")]
    Read {
        /// The path.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The target exists and overwriting was not asked for.
    #[error("{path} already exists (use --force to overwrite)")]
    Exists {
        /// The path.
        path: PathBuf,
    },
    /// A file exists but is not what its name says (does not parse, wrong version, values
    /// out of range).
    #[error("{path} is damaged: {reason}")]
    Damaged {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A value could not be encoded into its file format (a bug, or a non-finite number
    /// where the format has none).
    #[error("cannot encode {path}: {reason}")]
    Encode {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, RunError>;
