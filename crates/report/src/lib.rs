//! flexstage output writers.
//!
//! Every result is written *atomically* ([`write_atomic`]): to a temporary file in the target
//! folder, flushed to disk, then renamed over the target. A crash or `kill -9` leaves either
//! the old file or the new one, never half a file.
//!
//! A run lives in one folder ([`RunDir`]) holding the scenario used and every result:
//!
//! ```text
//! runs/<scenario-name>/
//!   scenario.toml      the scenario exactly as used
//!   <stage>/...        one sub-folder per pipeline stage (design, reduce, identify, track)
//! ```

pub mod html;
pub mod image;
pub mod outline;
pub mod plot;
pub mod vtk;

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Errors of the output writers.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A file or folder could not be written.
    #[error("cannot write {path}: {source}")]
    Write {
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
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, ReportError>;

/// Writes `bytes` to `path` atomically: temporary file in the same folder, `fsync`, rename.
/// Creates the parent folder if needed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let err = |source| ReportError::Write {
        path: path.to_path_buf(),
        source,
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    fs::create_dir_all(&dir).map_err(err)?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    let result = (|| {
        let mut f = fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result.map_err(err)
}

/// The folder of one run: the scenario used and every result.
#[derive(Debug, Clone)]
pub struct RunDir {
    root: PathBuf,
}

impl RunDir {
    /// Opens (creating if needed) the run folder at `root`.
    pub fn create(root: impl Into<PathBuf>) -> Result<RunDir> {
        let root = root.into();
        fs::create_dir_all(&root).map_err(|source| ReportError::Write {
            path: root.clone(),
            source,
        })?;
        Ok(RunDir { root })
    }

    /// The folder itself.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The path of a result, relative to the run folder.
    pub fn path(&self, relative: impl AsRef<Path>) -> PathBuf {
        self.root.join(relative)
    }

    /// Writes a result atomically.
    pub fn write(&self, relative: impl AsRef<Path>, bytes: &[u8]) -> Result<PathBuf> {
        let path = self.path(relative);
        write_atomic(&path, bytes)?;
        Ok(path)
    }
}

/// Formats numeric columns as CSV text: one header row, then one row per sample. Columns of
/// unequal length are padded with empty cells. Numbers use Rust's shortest round-trip format,
/// so a spreadsheet or `numpy.loadtxt` reads back the exact values.
pub fn csv_columns(header: &[&str], columns: &[&[f64]]) -> String {
    assert_eq!(header.len(), columns.len(), "one header per column");
    let rows = columns.iter().map(|c| c.len()).max().unwrap_or(0);
    let mut out = header.join(",");
    out.push('\n');
    for r in 0..rows {
        for (j, c) in columns.iter().enumerate() {
            if j > 0 {
                out.push(',');
            }
            if let Some(v) = c.get(r) {
                out.push_str(&v.to_string());
            }
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temporary() {
        let dir = std::env::temp_dir().join(format!("flexstage-report-{}", std::process::id()));
        let path = dir.join("sub").join("a.txt");
        write_atomic(&path, b"first").unwrap();
        write_atomic(&path, b"second").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"second");
        let leftovers: Vec<_> = fs::read_dir(path.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .filter(|n| n.to_string_lossy().contains(".tmp-"))
            .collect();
        assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn csv_round_trips_exact_values() {
        let a = [0.1, 1e-9, -3.0];
        let b = [2.5];
        let text = csv_columns(&["a", "b"], &[&a, &b]);
        assert_eq!(text, "a,b\n0.1,2.5\n0.000000001,\n-3,\n");
        let parsed: f64 = text
            .lines()
            .nth(2)
            .unwrap()
            .split(',')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert_eq!(parsed, 1e-9);
    }
}
