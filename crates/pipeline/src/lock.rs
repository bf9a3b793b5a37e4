//! The exclusive lock of a run folder ([`layout::LOCK`], `run.lock`).
//!
//! Every command that writes into a run folder holds its lock for as long as it works there,
//! so two processes never mix their results in one folder. The lock is a small TOML file
//! created atomically (`create_new`: exactly one process can create it) that names its
//! holder ([`LockHolder`]: PID, host, start time, process start tick, command line). It is
//! removed when the holder is done ([`RunLock`]'s `Drop`).
//!
//! **A second process refuses** with [`PipelineError::Locked`], naming the holder; it does not
//! wait (a design of the paper preset holds a folder for minutes, and a refusal that says who
//! holds the folder is easier to act on than a silent wait).
//!
//! **Stale locks** (a holder killed with `kill -9`, a power cut) are detected and taken over:
//! on the holder's host, a holder whose PID no longer exists, is a zombie, or belongs to a
//! process started at another time (the PID was reused) is gone. The takeover is reported
//! ([`RunLock::took_over`]). Taking over is itself serialized by a second `create_new` file
//! (`run.lock.takeover`), so two processes that find the same stale lock cannot both take it.
//! A lock held from another host (a shared file system) cannot be checked and is refused,
//! with the path to remove by hand. Liveness is read from `/proc` (Linux); where there is no
//! `/proc`, every holder counts as alive.

use std::fs::{self, OpenOptions};
use std::io::{ErrorKind, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use flexstage_run::layout;
use serde::{Deserialize, Serialize};

use crate::error::{PipelineError, Result};

/// How many times [`RunLock::acquire`] looks again after a lock vanished, was taken over by
/// someone else, or was being written.
const ATTEMPTS: usize = 40;
/// The pause between two attempts.
const PAUSE: Duration = Duration::from_millis(50);
/// A lock file that still does not parse after this long was left by a process killed between
/// creating and writing it.
const UNREADABLE_GRACE: Duration = Duration::from_secs(2);
/// The longest command line recorded in the lock.
const COMMAND_CHARS: usize = 300;

/// Who holds a run folder's lock.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct LockHolder {
    /// Process id.
    pub pid: u32,
    /// Host name (`/proc/sys/kernel/hostname`, else `$HOSTNAME`, else `"unknown"`).
    pub host: String,
    /// Wall-clock start of the hold, seconds since 1970-01-01 UTC.
    pub since: u64,
    /// The process's start time in clock ticks since boot (`/proc/PID/stat`, field 22), to
    /// tell a reused PID from the holder; 0 when unknown.
    pub process_start: u64,
    /// The command line (at most 300 characters).
    pub command: String,
}

impl LockHolder {
    /// This process.
    pub fn this_process() -> LockHolder {
        let pid = std::process::id();
        let mut command = std::env::args_os()
            .map(|a| a.to_string_lossy().into_owned())
            .collect::<Vec<_>>()
            .join(" ");
        if let Some((cut, _)) = command.char_indices().nth(COMMAND_CHARS) {
            command.truncate(cut);
        }
        LockHolder {
            pid,
            host: host_name(),
            since: SystemTime::now()
                .duration_since(UNIX_EPOCH)
                .map_or(0, |d| d.as_secs()),
            process_start: process_status(pid).map_or(0, |s| s.start),
            command,
        }
    }

    fn to_text(&self) -> String {
        toml::to_string(self).expect("a lock holder serializes to TOML")
    }

    fn from_text(text: &str) -> Option<LockHolder> {
        toml::from_str(text).ok()
    }

    /// Whether the holder is known to be gone: on this host, its PID is free, a zombie, or a
    /// process started at another tick than the holder.
    pub fn is_gone(&self) -> bool {
        self.host == host_name() && pid_is_gone(self.pid, self.process_start)
    }
}

impl std::fmt::Display for LockHolder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "PID {} on host {}, since {}, `{}`",
            self.pid,
            self.host,
            utc(self.since),
            self.command
        )
    }
}

/// The held lock of a run folder; released (the file removed) on drop.
#[derive(Debug)]
pub struct RunLock {
    path: PathBuf,
    text: String,
    holder: LockHolder,
    took_over: Option<String>,
}

impl RunLock {
    /// Takes the lock of the run folder `root` (creating the folder if needed): refuses with
    /// [`PipelineError::Locked`] while another live process holds it, takes over a stale one.
    pub fn acquire(root: &Path) -> Result<RunLock> {
        flexstage_run::create_folder(root)?;
        let path = root.join(layout::LOCK);
        let holder = LockHolder::this_process();
        let text = holder.to_text();
        let mut took_over = None;
        for _ in 0..ATTEMPTS {
            if create_with(&path, &text)? {
                return Ok(RunLock {
                    path,
                    text,
                    holder,
                    took_over,
                });
            }
            let Some(found) = read(&path)? else {
                continue; // released meanwhile
            };
            let stale = match LockHolder::from_text(&found) {
                Some(other) if !other.is_gone() => {
                    return Err(PipelineError::Locked {
                        root: root.to_path_buf(),
                        holder: other.to_string(),
                        lock: path,
                        hint: if other.host == host_name() {
                            "wait for it to finish".into()
                        } else {
                            format!(
                                "flexstage cannot tell from host {} whether it still runs; if \
                                 it does not, remove the lock file",
                                host_name()
                            )
                        },
                    });
                }
                Some(other) => format!("the process that held it is gone ({other})"),
                None if modified_ago(&path) < UNREADABLE_GRACE => {
                    std::thread::sleep(PAUSE); // being written
                    continue;
                }
                None => "its file was left unreadable by a killed process".to_string(),
            };
            if take_over(&path, &found, &text)? {
                took_over = Some(stale);
                return Ok(RunLock {
                    path,
                    text,
                    holder,
                    took_over,
                });
            }
        }
        Err(PipelineError::Locked {
            root: root.to_path_buf(),
            holder: "processes that keep taking it".into(),
            lock: path,
            hint: format!("gave up after {ATTEMPTS} attempts"),
        })
    }

    /// This process, as recorded in the lock.
    pub fn holder(&self) -> &LockHolder {
        &self.holder
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Why a stale lock was taken over, if it was.
    pub fn took_over(&self) -> Option<&str> {
        self.took_over.as_deref()
    }
}

impl Drop for RunLock {
    fn drop(&mut self) {
        // Only our own lock: never one that someone took over from us.
        if fs::read_to_string(&self.path).is_ok_and(|t| t == self.text) {
            let _ = fs::remove_file(&self.path);
        }
    }
}

/// Creates `path` holding `text` if it does not exist; `false` if it does.
fn create_with(path: &Path, text: &str) -> Result<bool> {
    let err = |source| flexstage_run::RunError::Write {
        path: path.to_path_buf(),
        source,
    };
    match OpenOptions::new().write(true).create_new(true).open(path) {
        Ok(mut f) => {
            let written = f.write_all(text.as_bytes()).and_then(|()| f.sync_all());
            if let Err(e) = written {
                let _ = fs::remove_file(path);
                return Err(err(e).into());
            }
            Ok(true)
        }
        Err(e) if e.kind() == ErrorKind::AlreadyExists => Ok(false),
        Err(e) => Err(err(e).into()),
    }
}

/// The lock's text, `None` if it vanished.
fn read(path: &Path) -> Result<Option<String>> {
    match fs::read(path) {
        Ok(bytes) => Ok(Some(String::from_utf8_lossy(&bytes).into_owned())),
        Err(e) if e.kind() == ErrorKind::NotFound => Ok(None),
        Err(source) => Err(PipelineError::Read {
            path: path.to_path_buf(),
            source,
        }),
    }
}

/// How long ago `path` was modified (zero if unknown).
fn modified_ago(path: &Path) -> Duration {
    fs::metadata(path)
        .and_then(|m| m.modified())
        .ok()
        .and_then(|t| t.elapsed().ok())
        .unwrap_or_default()
}

/// Replaces the stale lock `path` (whose text was `stale`) by ours, under the takeover guard.
/// `false` when another process is taking it over or already did.
fn take_over(path: &Path, stale: &str, ours: &str) -> Result<bool> {
    let mut guard = path.as_os_str().to_owned();
    guard.push(".takeover");
    let guard = PathBuf::from(guard);
    if !create_with(&guard, ours)? {
        // Another process is taking over; a guard whose process died is removed.
        let dead = read(&guard)?.is_some_and(|t| {
            LockHolder::from_text(&t)
                .map_or(modified_ago(&guard) >= UNREADABLE_GRACE, |h| h.is_gone())
        });
        if dead {
            let _ = fs::remove_file(&guard);
        } else {
            std::thread::sleep(PAUSE);
        }
        return Ok(false);
    }
    let result = (|| {
        if read(path)?.as_deref() != Some(stale) {
            return Ok(false);
        }
        fs::remove_file(path).map_err(|source| flexstage_run::RunError::Write {
            path: path.to_path_buf(),
            source,
        })?;
        create_with(path, ours)
    })();
    let _ = fs::remove_file(&guard);
    result
}

/// The host name, as far as it can be found without system calls.
pub fn host_name() -> String {
    fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .or_else(|| std::env::var("HOSTNAME").ok())
        .map(|h| h.trim().to_string())
        .filter(|h| !h.is_empty())
        .unwrap_or_else(|| "unknown".into())
}

/// State and start tick of a process, from `/proc/PID/stat`.
struct ProcessStatus {
    /// Field 3: `R`, `S`, `D`, `Z` (zombie), `X` (dead), ...
    state: char,
    /// Field 22: start time in clock ticks after boot.
    start: u64,
}

/// `/proc/PID/stat` of `pid`, `None` if there is no such process (or no `/proc`).
fn process_status(pid: u32) -> Option<ProcessStatus> {
    let text = fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // "pid (comm) state ppid ...": comm may hold spaces and parentheses.
    let rest = &text[text.rfind(')')? + 1..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    Some(ProcessStatus {
        state: fields.first()?.chars().next()?,
        start: fields.get(19)?.parse().ok()?,
    })
}

/// Whether process `pid` (started at tick `start`, 0 if unknown) is known to be gone. Without
/// `/proc` nothing is known, so nothing is gone.
pub fn pid_is_gone(pid: u32, start: u64) -> bool {
    if !Path::new("/proc/self/stat").exists() {
        return false;
    }
    match process_status(pid) {
        None => true,
        Some(s) => matches!(s.state, 'Z' | 'X') || (start != 0 && s.start != start),
    }
}

/// Seconds since 1970 as `YYYY-MM-DD hh:mm:ss UTC` (the proleptic Gregorian calendar; days to
/// civil date by H. Hinnant's `civil_from_days`).
pub fn utc(seconds: u64) -> String {
    let days = (seconds / 86_400) as i64;
    let rem = seconds % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02}:{:02} UTC",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("flexstage-lock-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        d
    }

    /// The PID of a process that has exited (and been reaped).
    fn dead_pid() -> u32 {
        let mut c = std::process::Command::new("true").spawn().unwrap();
        let pid = c.id();
        c.wait().unwrap();
        pid
    }

    #[test]
    fn utc_matches_known_dates() {
        // Reference: the Unix epoch, the leap day 2000-02-29 (951 782 400 s) and 2038-01-19
        // 03:14:07 (2^31 − 1 s), as `date -u -d @N` prints them.
        assert_eq!(utc(0), "1970-01-01 00:00:00 UTC");
        assert_eq!(utc(951_782_400), "2000-02-29 00:00:00 UTC");
        assert_eq!(utc(2_147_483_647), "2038-01-19 03:14:07 UTC");
    }

    #[test]
    fn a_held_lock_is_refused_naming_its_holder_and_released_on_drop() {
        let root = tmp("held");
        let lock = RunLock::acquire(&root).unwrap();
        assert!(lock.took_over().is_none());
        let e = RunLock::acquire(&root).unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, PipelineError::Locked { .. }), "{msg}");
        assert!(
            msg.contains(&format!("PID {}", std::process::id())) && msg.contains(layout::LOCK),
            "{msg}"
        );
        drop(lock);
        assert!(!root.join(layout::LOCK).exists(), "released");
        drop(RunLock::acquire(&root).unwrap());
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_stale_lock_is_taken_over_with_a_reason() {
        // Goal: a holder killed with kill -9 (its PID gone), a reused PID (a live process
        // started at another tick) and a lock file left empty are all taken over.
        let root = tmp("stale");
        fs::create_dir_all(&root).unwrap();
        let lock_file = root.join(layout::LOCK);
        let mut gone = LockHolder::this_process();
        gone.pid = dead_pid();
        gone.command = "flexstage run (killed)".into();
        fs::write(&lock_file, gone.to_text()).unwrap();
        let lock = RunLock::acquire(&root).unwrap();
        let why = lock.took_over().expect("taken over");
        assert!(why.contains("gone") && why.contains("(killed)"), "{why}");
        assert_eq!(fs::read_to_string(&lock_file).unwrap(), lock.text);
        drop(lock);

        let mut reused = LockHolder::this_process();
        reused.process_start += 1;
        fs::write(&lock_file, reused.to_text()).unwrap();
        assert!(RunLock::acquire(&root).unwrap().took_over().is_some());

        fs::write(&lock_file, "").unwrap();
        let old = SystemTime::now() - Duration::from_secs(60);
        fs::File::options()
            .write(true)
            .open(&lock_file)
            .unwrap()
            .set_modified(old)
            .unwrap();
        let lock = RunLock::acquire(&root).unwrap();
        assert!(lock.took_over().unwrap().contains("unreadable"));
        drop(lock);
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_lock_from_another_host_is_refused() {
        // Goal: a holder whose liveness cannot be checked is never taken over silently.
        let root = tmp("host");
        fs::create_dir_all(&root).unwrap();
        let mut other = LockHolder::this_process();
        other.host = "elsewhere".into();
        other.pid = dead_pid();
        fs::write(root.join(layout::LOCK), other.to_text()).unwrap();
        let msg = RunLock::acquire(&root).unwrap_err().to_string();
        assert!(msg.contains("elsewhere") && msg.contains("remove"), "{msg}");
        fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn the_holder_of_this_process_is_alive() {
        let me = LockHolder::this_process();
        assert!(!me.is_gone());
        assert!(pid_is_gone(dead_pid(), 0));
        assert_eq!(LockHolder::from_text(&me.to_text()), Some(me));
    }
}
