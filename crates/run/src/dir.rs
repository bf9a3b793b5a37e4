//! The folder of one run ([`RunDir`]): atomic writes, typed reads and writes with a
//! per-process cache (a value stored or loaded once is not parsed again), and a journal of
//! the files written with their SHA-256, from which `run` records what each stage wrote.

use std::any::Any;
use std::collections::{BTreeMap, HashMap};
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};

use crate::format::Format;
use crate::{Result, RunError};

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
        Some(reason) => RunError::Folder {
            path: path.to_path_buf(),
            reason,
        },
        None => RunError::Write {
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
    let err = |source| RunError::Write {
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

/// A file written through a [`RunDir`]: its path relative to the run folder and the SHA-256
/// of its content.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WrittenFile {
    /// Relative path, with `/`.
    pub path: String,
    /// SHA-256 of the content, lower-case hex ([`crate::hash::sha256_hex`]).
    pub sha256: String,
}

/// What one process knows about a run folder: the typed values stored or loaded (so that a
/// file is parsed at most once), and the journal of files written since
/// [`RunDir::begin_journal`].
#[derive(Default)]
struct Session {
    cache: Mutex<HashMap<String, Arc<dyn Any + Send + Sync>>>,
    journal: Mutex<Option<BTreeMap<String, String>>>,
}

impl std::fmt::Debug for Session {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Session")
    }
}

/// The folder of one run: the scenario used and every result. Clones share one session
/// (cache and journal).
#[derive(Debug, Clone)]
pub struct RunDir {
    root: PathBuf,
    session: Arc<Session>,
}

impl RunDir {
    /// Opens (creating if needed) the run folder at `root`.
    pub fn create(root: impl Into<PathBuf>) -> Result<RunDir> {
        let root = root.into();
        create_folder(&root)?;
        Ok(RunDir {
            root,
            session: Arc::default(),
        })
    }

    /// The folder itself.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The path of a result, relative to the run folder.
    pub fn path(&self, relative: impl AsRef<Path>) -> PathBuf {
        self.root.join(relative)
    }

    /// Whether a result file exists.
    pub fn exists(&self, relative: impl AsRef<Path>) -> bool {
        self.path(relative).is_file()
    }

    /// Whether the folder `relative` holds at least one file.
    pub fn has_files(&self, relative: &str) -> bool {
        fs::read_dir(self.path(relative))
            .map(|mut d| d.any(|e| e.is_ok_and(|e| e.path().is_file())))
            .unwrap_or(false)
    }

    /// The names of the files in the folder `relative`, sorted (none if it does not exist).
    pub fn files_in(&self, relative: &str) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(self.path(relative))
            .map(|d| {
                d.flatten()
                    .filter(|e| e.path().is_file())
                    .map(|e| e.file_name().to_string_lossy().into_owned())
                    .collect()
            })
            .unwrap_or_default();
        names.sort();
        names
    }

    /// Writes a result atomically; records it in the journal and forgets a cached value of
    /// the same file.
    pub fn write(&self, relative: &str, bytes: &[u8]) -> Result<PathBuf> {
        let path = self.path(relative);
        write_atomic(&path, bytes)?;
        self.forget(relative);
        if let Some(j) = lock(&self.session.journal).as_mut() {
            j.insert(relative.to_string(), crate::hash::sha256_hex(bytes));
        }
        Ok(path)
    }

    /// The bytes of a result: `None` if it does not exist.
    pub fn read(&self, relative: &str) -> Result<Option<Vec<u8>>> {
        let path = self.path(relative);
        match fs::read(&path) {
            Ok(b) => Ok(Some(b)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(source) => Err(RunError::Read { path, source }),
        }
    }

    /// Stores `value` in its format ([`Format::encode`]) at `relative` and keeps it for
    /// [`RunDir::load`] (as read back from the bytes when the format is not exact).
    pub fn store<F: Format>(&self, relative: &str, value: F) -> Result<Arc<F>> {
        let bytes = value.encode().map_err(|reason| RunError::Encode {
            path: self.path(relative),
            reason,
        })?;
        self.write(relative, &bytes)?;
        let value = if F::EXACT {
            value
        } else {
            F::decode(&bytes).map_err(|reason| RunError::Encode {
                path: self.path(relative),
                reason: format!("does not read back: {reason}"),
            })?
        };
        let value = Arc::new(value);
        lock(&self.session.cache).insert(relative.to_string(), value.clone());
        Ok(value)
    }

    /// The typed value of a result: the one stored or loaded earlier by this process, else
    /// the file parsed ([`Format::decode`]); `None` if the file does not exist;
    /// [`RunError::Damaged`] if it exists and does not parse.
    pub fn load<F: Format>(&self, relative: &str) -> Result<Option<Arc<F>>> {
        if let Some(v) = lock(&self.session.cache).get(relative)
            && let Ok(v) = v.clone().downcast::<F>()
        {
            return Ok(Some(v));
        }
        let Some(bytes) = self.read(relative)? else {
            return Ok(None);
        };
        let value = Arc::new(F::decode(&bytes).map_err(|reason| RunError::Damaged {
            path: self.path(relative),
            reason,
        })?);
        lock(&self.session.cache).insert(relative.to_string(), value.clone());
        Ok(Some(value))
    }

    /// Removes a result file (nothing if it does not exist).
    pub fn remove_file(&self, relative: &str) -> Result<()> {
        let path = self.path(relative);
        match fs::remove_file(&path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(RunError::Write { path, source: e });
            }
            _ => {}
        }
        self.forget(relative);
        if let Some(j) = lock(&self.session.journal).as_mut() {
            j.remove(relative);
        }
        Ok(())
    }

    /// Removes a result folder and everything in it (nothing if it does not exist).
    pub fn remove_dir(&self, relative: &str) -> Result<()> {
        let path = self.path(relative);
        if path.is_dir() {
            fs::remove_dir_all(&path).map_err(|source| RunError::Write { path, source })?;
        }
        let prefix = format!("{}/", relative.trim_end_matches('/'));
        lock(&self.session.cache).retain(|k, _| !k.starts_with(&prefix));
        if let Some(j) = lock(&self.session.journal).as_mut() {
            j.retain(|k, _| !k.starts_with(&prefix));
        }
        Ok(())
    }

    fn forget(&self, relative: &str) {
        lock(&self.session.cache).remove(relative);
    }

    /// Starts recording the files written (and removed) from now on.
    pub fn begin_journal(&self) {
        *lock(&self.session.journal) = Some(BTreeMap::new());
    }

    /// The files written since [`RunDir::begin_journal`] and still present, in path order;
    /// stops recording.
    pub fn end_journal(&self) -> Vec<WrittenFile> {
        lock(&self.session.journal)
            .take()
            .unwrap_or_default()
            .into_iter()
            .map(|(path, sha256)| WrittenFile { path, sha256 })
            .collect()
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
                    fs::remove_file(&path).map_err(|source| RunError::Write {
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

/// A poisoned lock only means another thread panicked while holding it; the map is still
/// consistent (every operation is one insert or remove).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

/// How deep [`RunDir::remove_stale_temporaries`] looks below the run folder: the deepest
/// result folders are `track/<variant>/` and `identify/stage/` (2 levels).
pub const TEMPORARY_SEARCH_DEPTH: usize = 4;

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
}
