//! Progress on standard error: `indicatif` bars for long tasks when standard error is a
//! terminal, plain lines when it is not (CI logs, pipes, files), one line per notable event,
//! and the stage lines of `flexstage run`.
//!
//! **Plain lines.** A bar draws nothing when standard error is not a terminal, so logs of a
//! design that runs for hours stayed empty. Instead, a task with steps (the design's
//! iterations, the tracking samples) prints a line when it starts, every 10 % of its steps (at
//! most one such line per 2 s) or every [`PLAIN_SECONDS`] seconds, whichever comes first, and
//! when it ends; and any command
//! prints "still working" every [`PLAIN_SECONDS`] seconds in which it printed no progress line
//! (stages without steps: export, reduce, the twin, identification). The period can be set
//! with the environment variable `FLEXSTAGE_PROGRESS_SECONDS` (whole seconds ≥ 1).

use std::io::IsTerminal;
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

use flexstage_pipeline::{Progress, RunEvent, Stage, StartOver};
use indicatif::{ProgressBar, ProgressStyle};

use crate::print;

/// Seconds between plain progress lines (default; `FLEXSTAGE_PROGRESS_SECONDS` overrides).
pub const PLAIN_SECONDS: u64 = 30;

/// Shortest time between two plain lines of a task's 10 % steps (a fast task prints few).
const MIN_GAP: Duration = Duration::from_secs(2);

/// The plain-line state of the process (set when standard error is not a terminal).
static PLAIN: OnceLock<Mutex<Plain>> = OnceLock::new();

/// What the plain lines report.
struct Plain {
    /// The command, or the stage of `run` in progress.
    what: String,
    /// The task with steps in progress, if any.
    task: Option<Task>,
    /// When the command started.
    started: Instant,
    /// When the last progress line was printed.
    last_line: Instant,
    /// Seconds between lines.
    period: Duration,
}

struct Task {
    name: String,
    len: u64,
    position: u64,
    /// Position at the last line.
    printed: u64,
    message: String,
    started: Instant,
}

impl Task {
    fn line(&self, now: Instant) -> String {
        let mut l = format!(
            "{}: {}/{} after {:.0} s",
            self.name,
            self.position,
            self.len,
            (now - self.started).as_secs_f64()
        );
        if !self.message.is_empty() {
            l.push_str(", ");
            l.push_str(&self.message);
        }
        l
    }
}

/// Switches to plain lines when standard error is not a terminal, for the command `what`, and
/// starts the "still working" lines.
pub fn plain_when_not_a_terminal(what: &str) {
    if std::io::stderr().is_terminal() {
        return;
    }
    let period = std::env::var("FLEXSTAGE_PROGRESS_SECONDS")
        .ok()
        .and_then(|v| v.parse::<u64>().ok())
        .filter(|&s| s >= 1)
        .unwrap_or(PLAIN_SECONDS);
    let now = Instant::now();
    let state = Plain {
        what: what.to_string(),
        task: None,
        started: now,
        last_line: now,
        period: Duration::from_secs(period),
    };
    if PLAIN.set(Mutex::new(state)).is_err() {
        return;
    }
    std::thread::spawn(|| {
        loop {
            std::thread::sleep(Duration::from_millis(250));
            with_plain(|p| {
                let now = Instant::now();
                if now - p.last_line < p.period {
                    return;
                }
                p.last_line = now;
                let line = match &p.task {
                    Some(t) => t.line(now),
                    None => format!(
                        "{}: still working after {:.0} s",
                        p.what,
                        (now - p.started).as_secs_f64()
                    ),
                };
                errln!("{line}");
            });
        }
    });
}

/// Runs `f` on the plain-line state; `false` when the lines are not plain.
fn with_plain(f: impl FnOnce(&mut Plain)) -> bool {
    match PLAIN.get() {
        Some(m) => {
            f(&mut m.lock().unwrap_or_else(|p| p.into_inner()));
            true
        }
        None => false,
    }
}

/// Moves the plain task to `position` (or by `steps`); prints a line every 10 % of the steps
/// or every period, whichever comes first.
fn plain_progress(update: impl FnOnce(&mut Task)) -> bool {
    with_plain(|p| {
        let Some(t) = p.task.as_mut() else {
            return;
        };
        update(t);
        let now = Instant::now();
        let step = t.len.div_ceil(10).max(1);
        let since = now - p.last_line;
        if (t.position >= t.printed + step && since >= MIN_GAP.min(p.period)) || since >= p.period {
            t.printed = t.position;
            p.last_line = now;
            errln!("{}", t.line(now));
        }
    })
}

/// The CLI's [`Progress`].
#[derive(Default)]
pub struct Bars {
    bar: Mutex<Option<ProgressBar>>,
}

impl Bars {
    fn with(&self, f: impl Fn(&ProgressBar)) {
        self.bar.lock().expect("progress lock").iter().for_each(f);
    }
}

impl Progress for Bars {
    fn start(&self, task: &str, len: u64) {
        let plain = with_plain(|p| {
            let now = Instant::now();
            errln!("{task}: started, {len} steps");
            p.last_line = now;
            p.task = Some(Task {
                name: task.to_string(),
                len,
                position: 0,
                printed: 0,
                message: String::new(),
                started: now,
            });
        });
        if plain {
            return;
        }
        let bar = ProgressBar::new(len);
        bar.set_style(
            ProgressStyle::with_template("{prefix:>10} [{bar:30}] {pos}/{len} {elapsed} {msg}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        bar.set_prefix(task.to_string());
        bar.enable_steady_tick(Duration::from_millis(250));
        *self.bar.lock().expect("progress lock") = Some(bar);
    }

    fn set_position(&self, position: u64) {
        if !plain_progress(|t| t.position = position) {
            self.with(|b| b.set_position(position));
        }
    }

    fn advance(&self, steps: u64) {
        if !plain_progress(|t| t.position += steps) {
            self.with(|b| b.inc(steps));
        }
    }

    fn set_message(&self, message: &str) {
        let plain = with_plain(|p| {
            if let Some(t) = p.task.as_mut() {
                t.message = message.to_string();
            }
        });
        if !plain {
            self.with(|b| b.set_message(message.to_string()));
        }
    }

    fn finish(&self) {
        let plain = with_plain(|p| {
            if let Some(t) = p.task.take() {
                let now = Instant::now();
                p.last_line = now;
                errln!("{} (done)", t.line(now));
            }
        });
        if plain {
            return;
        }
        if let Some(b) = self.bar.lock().expect("progress lock").take() {
            b.finish_and_clear();
        }
    }

    fn note(&self, line: &str) {
        match self.bar.lock().expect("progress lock").as_ref() {
            // A hidden bar (standard error not a terminal) would drop the line.
            Some(b) if !b.is_hidden() => b.println(line),
            _ => errln!("{line}"),
        }
    }

    fn event(&self, event: &RunEvent) {
        let n = Stage::ALL.len();
        match event {
            RunEvent::StartingOver(StartOver::Requested) => errln!("--restart: starting over"),
            RunEvent::Resuming(done) => {
                let names: Vec<&str> = done.iter().map(|s| s.name()).collect();
                errln!("resuming: finished {}", names.join(", "));
            }
            RunEvent::Skipped(s) => {
                errln!("[{}/{n}] {}: done earlier, skipped", s.number(), s.name())
            }
            RunEvent::Redoing { stage, why } => errln!(
                "[{}/{n}] {}: done earlier, but {why}: doing it again (and every later stage)",
                stage.number(),
                stage.name()
            ),
            RunEvent::Started(s) => {
                with_plain(|p| {
                    p.what = format!("[{}/{n}] {}", s.number(), s.name());
                    p.last_line = Instant::now();
                });
                errln!("[{}/{n}] {} ...", s.number(), s.name())
            }
            RunEvent::Finished {
                stage,
                seconds,
                summary,
            } => {
                print::summary(*summary);
                errln!(
                    "[{}/{n}] {}: done in {seconds:.1} s",
                    stage.number(),
                    stage.name()
                );
            }
        }
    }
}
