//! Typed errors of the scenario crate.

use std::path::PathBuf;

pub use flexstage_numerics::RangeError;
pub(crate) use flexstage_numerics::compact;

/// Everything that can be wrong with a scenario.
///
/// Messages name the offending field by its TOML path (e.g. `material.youngs_modulus`),
/// the value found and the accepted range.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// A field lies outside its accepted range (named by its TOML path).
    #[error(transparent)]
    OutOfRange(#[from] RangeError),
    /// Two fields contradict each other.
    #[error("{fields}: {reason}")]
    Inconsistent {
        /// The TOML paths involved.
        fields: String,
        /// What is wrong.
        reason: String,
    },
    /// The TOML text does not parse or does not match the schema (unknown key, wrong type).
    #[error("cannot parse {path}")]
    Parse {
        /// Where the text came from.
        path: String,
        /// The parser's diagnosis, with line and column.
        #[source]
        source: Box<toml::de::Error>,
    },
    /// The scenario file could not be read.
    #[error("cannot read scenario {path}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, ScenarioError>;

flexstage_numerics::range_checks!(ScenarioError);

/// A name used in file and folder names: 1 to 64 ASCII letters, digits, `-` and `_`.
pub(crate) fn file_name(field: &str, name: &str) -> Result<()> {
    if !name.is_empty()
        && name.len() <= crate::limit::NAME_CHARS
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
    {
        Ok(())
    } else {
        let shown: String = name.chars().take(80).collect();
        let more = if name.chars().count() > 80 { "…" } else { "" };
        Err(RangeError::new(
            field,
            format!("{shown:?}{more} ({} characters)", name.chars().count()),
            "a name of 1 to 64 letters, digits, '-' and '_' (it names a folder)",
        )
        .into())
    }
}
