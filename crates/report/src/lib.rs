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
//!
//! [`layout`] names every file of a run folder; the pipeline writes and the HTML report
//! reads through it.

pub mod cloud;
pub mod html;
pub mod image;
pub mod layout;
pub mod outline;
pub mod plot;
pub mod simplify;
pub mod vtk;

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Errors of the output writers.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
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
    /// The target exists and overwriting was not asked for.
    #[error("{path} already exists (use --force to overwrite)")]
    Exists {
        /// The path.
        path: PathBuf,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, ReportError>;

/// Creates the folder `path` and its parents ([`fs::create_dir_all`]); when that fails, says
/// what is in the way: a symbolic link whose target does not exist (`create_dir_all` reports
/// "File exists" for it), or a file where a folder should be.
pub fn create_folder(path: &Path) -> Result<()> {
    let Err(source) = fs::create_dir_all(path) else {
        return Ok(());
    };
    let in_the_way = path.ancestors().find_map(|p| {
        let meta = fs::symlink_metadata(p).ok()?;
        if meta.file_type().is_symlink() && fs::metadata(p).is_err() {
            let target = fs::read_link(p).map_or_else(|_| "?".into(), |t| t.display().to_string());
            Some(format!(
                "{} is a symbolic link to {target}, which does not exist (create that folder, \
                 remove the link, or choose another folder)",
                p.display()
            ))
        } else if !meta.is_dir() && !meta.file_type().is_symlink() {
            Some(format!("{} is a file, not a folder", p.display()))
        } else {
            None
        }
    });
    Err(match in_the_way {
        Some(reason) => ReportError::Folder {
            path: path.to_path_buf(),
            reason,
        },
        None => ReportError::Write {
            path: path.to_path_buf(),
            source,
        },
    })
}

/// Writes `bytes` to `path` atomically: temporary file in the same folder
/// ([`temporary_name`]), `fsync`, rename, `fsync` of the folder (so the rename itself
/// survives a power cut). Creates the parent folder if needed. A process killed in the middle
/// leaves the old file untouched and at most a temporary file, which
/// [`RunDir::remove_stale_temporaries`] removes later.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let err = |source| ReportError::Write {
        path: path.to_path_buf(),
        source,
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    create_folder(&dir)?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let tmp = dir.join(temporary_name(&name, std::process::id()));
    let result = (|| {
        let mut f = fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result.map_err(err)?;
    sync_dir(&dir);
    Ok(())
}

/// `fsync` of a folder, so that a rename into it is durable. Best effort: not every platform
/// or file system lets a folder be opened and synced, and the file itself is already synced.
fn sync_dir(dir: &Path) {
    if let Ok(d) = fs::File::open(dir) {
        let _ = d.sync_all();
    }
}

/// The temporary file name [`write_atomic`] uses for `name` in process `pid`:
/// `.NAME.tmp-PID` (hidden, in the target's folder).
pub fn temporary_name(name: &str, pid: u32) -> String {
    format!(".{name}.tmp-{pid}")
}

/// The process id of a [`temporary_name`], or `None` if `file_name` is not one.
pub fn temporary_pid(file_name: &str) -> Option<u32> {
    let (head, pid) = file_name.strip_prefix('.')?.rsplit_once(".tmp-")?;
    if head.is_empty() || pid.is_empty() || !pid.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    pid.parse().ok()
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
        create_folder(&root)?;
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

    /// Whether a result file exists.
    pub fn exists(&self, relative: impl AsRef<Path>) -> bool {
        self.path(relative).is_file()
    }

    /// A result file as text, if it exists and reads.
    pub fn read_to_string(&self, relative: impl AsRef<Path>) -> Option<String> {
        fs::read_to_string(self.path(relative)).ok()
    }

    /// Removes the temporary files of [`write_atomic`] that a killed process left behind in
    /// this folder and its sub-folders (down to [`TEMPORARY_SEARCH_DEPTH`] levels; symbolic
    /// links are not followed). A temporary is stale when `is_stale(pid)` says so for the
    /// process id in its name; the caller holds the folder's lock, so no live writer of this
    /// folder can own one. Returns the files removed.
    pub fn remove_stale_temporaries(&self, is_stale: impl Fn(u32) -> bool) -> Result<Vec<PathBuf>> {
        let mut removed = Vec::new();
        let mut folders = vec![(self.root.clone(), 0)];
        while let Some((dir, depth)) = folders.pop() {
            let Ok(entries) = fs::read_dir(&dir) else {
                continue;
            };
            for entry in entries.flatten() {
                let Ok(kind) = entry.file_type() else {
                    continue;
                };
                let path = entry.path();
                if kind.is_dir() && depth < TEMPORARY_SEARCH_DEPTH {
                    folders.push((path, depth + 1));
                } else if kind.is_file()
                    && temporary_pid(&entry.file_name().to_string_lossy()).is_some_and(&is_stale)
                {
                    fs::remove_file(&path).map_err(|source| ReportError::Write {
                        path: path.clone(),
                        source,
                    })?;
                    removed.push(path);
                }
            }
        }
        removed.sort();
        Ok(removed)
    }
}

/// How deep [`RunDir::remove_stale_temporaries`] looks below the run folder: the deepest
/// result folders are `track/<variant>/` and `identify/stage/` (2 levels).
pub const TEMPORARY_SEARCH_DEPTH: usize = 4;

/// Reads numeric CSV columns by header name from text written by [`csv_columns`]; missing or
/// unparsable cells become NaN. `None` when the text has no header or lacks a column.
pub fn read_csv_columns(text: &str, names: &[&str]) -> Option<Vec<Vec<f64>>> {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header: Vec<&str> = lines.next()?.split(',').map(str::trim).collect();
    let idx: Vec<usize> = names
        .iter()
        .map(|n| header.iter().position(|h| h == n))
        .collect::<Option<_>>()?;
    let mut out = vec![Vec::new(); names.len()];
    for l in lines {
        let cells: Vec<&str> = l.split(',').collect();
        for (k, &i) in idx.iter().enumerate() {
            out[k].push(
                cells
                    .get(i)
                    .and_then(|c| c.trim().parse().ok())
                    .unwrap_or(f64::NAN),
            );
        }
    }
    Some(out)
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

    /// Reference: the second hardening review, "a dangling `--out` symlink gives 'File exists'". Goal: a folder
    /// behind a dangling symbolic link, or under a file, is refused saying what is in the way.
    #[cfg(unix)]
    #[test]
    fn a_dangling_link_or_a_file_in_the_way_is_named() {
        let dir = std::env::temp_dir().join(format!("flexstage-folder-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let link = dir.join("link");
        std::os::unix::fs::symlink(dir.join("missing"), &link).unwrap();
        let e = RunDir::create(&link).unwrap_err().to_string();
        assert!(
            e.contains("symbolic link") && e.contains("does not exist"),
            "{e}"
        );
        let file = dir.join("file");
        fs::write(&file, b"x").unwrap();
        let e = write_atomic(&file.join("a.txt"), b"x")
            .unwrap_err()
            .to_string();
        assert!(e.contains("is a file, not a folder"), "{e}");
        fs::remove_dir_all(&dir).unwrap();
    }

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
    fn temporary_names_parse_back_to_their_process() {
        // Goal: the cleaner recognises exactly the names the writer makes.
        let name = temporary_name("params.toml", 4242);
        assert_eq!(name, ".params.toml.tmp-4242");
        assert_eq!(temporary_pid(&name), Some(4242));
        for other in [
            "params.toml",
            ".params.toml",
            ".tmp-12",
            "params.toml.tmp-12",
            ".a.tmp-",
            ".a.tmp-12x",
            ".a.tmp-99999999999",
        ] {
            assert_eq!(temporary_pid(other), None, "{other:?}");
        }
    }

    #[test]
    fn stale_temporaries_are_removed_and_nothing_else() {
        // Goal: what a kill -9 during write_atomic leaves behind is removed at the next start;
        // results and the temporaries of live processes stay.
        let root = std::env::temp_dir().join(format!("flexstage-tmpclean-{}", std::process::id()));
        let _ = fs::remove_dir_all(&root);
        let run = RunDir::create(&root).unwrap();
        run.write("design/design.json", b"{}").unwrap();
        run.write("track/compensation-off/metrics.csv", b"a\n")
            .unwrap();
        let dead = [
            "design/.design.json.tmp-7",
            "track/compensation-off/.metrics.csv.tmp-8",
            ".scenario.toml.tmp-7",
        ];
        for rel in dead {
            fs::write(run.path(rel), b"half a fi").unwrap();
        }
        fs::write(run.path("design/.checkpoint.bin.tmp-9"), b"live").unwrap();
        let removed = run.remove_stale_temporaries(|pid| pid != 9).unwrap();
        assert_eq!(removed.len(), 3, "{removed:?}");
        for rel in dead {
            assert!(!run.path(rel).exists(), "{rel} left");
        }
        assert!(
            run.exists("design/.checkpoint.bin.tmp-9"),
            "a live writer's file"
        );
        assert!(
            run.exists("design/design.json") && run.exists("track/compensation-off/metrics.csv")
        );
        fs::remove_dir_all(&root).unwrap();
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
        let cols = read_csv_columns(&text, &["b", "a"]).unwrap();
        assert_eq!(cols[1], a);
        assert_eq!(cols[0][0], 2.5);
        assert!(cols[0][1].is_nan(), "padding reads as NaN");
        assert!(read_csv_columns(&text, &["c"]).is_none());
    }
}
