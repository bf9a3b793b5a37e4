//! Long calls: the pipeline runs on a worker thread without the GIL while the calling
//! (main) thread shows its progress and watches for Ctrl-C.
//!
//! Every 100 ms the calling thread takes the GIL, hands what changed to the Python progress
//! reporter (a tqdm bar where installed) and calls `PyErr_CheckSignals`. On Ctrl-C it asks
//! the pipeline to stop ([`Progress::stop_requested`]); the stage stops at its next step
//! (a design iteration, a tracking phase, a stage of `run`), leaves the run folder as an
//! interrupted process would (a design writes its checkpoint), and the call raises
//! `KeyboardInterrupt` with the pipeline's message. Signals are only delivered to the main
//! thread, which is why the work runs on another one.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

use flexstage_pipeline::{PipelineError, Progress, RunEvent, Stage, StartOver};
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError};
use pyo3::prelude::*;

use crate::errors;

/// How often the calling thread looks at progress and signals.
const POLL: Duration = Duration::from_millis(100);

/// The worker thread's stack (the main thread's is 8 MiB; the FE ordering recurses).
const STACK: usize = 64 << 20;

/// What the pipeline reported, waiting to be shown.
#[derive(Debug, Default)]
struct State {
    /// The current task, its length, and a counter that changes with every new task.
    task: Option<(String, u64)>,
    generation: u64,
    position: u64,
    message: String,
    finished: bool,
    notes: Vec<String>,
}

/// The pipeline's [`Progress`]: records what happens for the calling thread to show, and
/// answers [`Progress::stop_requested`].
#[derive(Debug, Default)]
pub struct Bridge {
    state: Mutex<State>,
    stop: AtomicBool,
}

impl Bridge {
    fn with(&self, f: impl FnOnce(&mut State)) {
        f(&mut self.state.lock().unwrap_or_else(|p| p.into_inner()));
    }
}

impl Progress for Bridge {
    fn start(&self, task: &str, len: u64) {
        self.with(|s| {
            s.task = Some((task.to_string(), len));
            s.generation += 1;
            s.position = 0;
            s.message.clear();
            s.finished = false;
        });
    }
    fn set_position(&self, position: u64) {
        self.with(|s| s.position = position);
    }
    fn advance(&self, steps: u64) {
        self.with(|s| s.position += steps);
    }
    fn set_message(&self, message: &str) {
        self.with(|s| message.clone_into(&mut s.message));
    }
    fn finish(&self) {
        self.with(|s| s.finished = true);
    }
    fn note(&self, line: &str) {
        self.with(|s| s.notes.push(line.to_string()));
    }
    fn event(&self, event: &RunEvent) {
        if let Some(line) = event_line(event) {
            self.note(&line);
        }
    }
    fn stop_requested(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }
}

/// The line the CLI prints for a step of `run` (the stage's summary is the caller's).
fn event_line(event: &RunEvent) -> Option<String> {
    let n = Stage::ALL.len();
    Some(match event {
        RunEvent::StartingOver(StartOver::Requested) => "restart: starting over".into(),
        RunEvent::Resuming(done) => {
            let names: Vec<&str> = done.iter().map(|s| s.name()).collect();
            format!("resuming: finished {}", names.join(", "))
        }
        RunEvent::Skipped(s) => format!("[{}/{n}] {}: done earlier, skipped", s.number(), s.name()),
        RunEvent::Redoing { stage, why } => format!(
            "[{}/{n}] {}: done earlier, but {why}: doing it again (and every later stage)",
            stage.number(),
            stage.name()
        ),
        RunEvent::Started(s) => format!("[{}/{n}] {} ...", s.number(), s.name()),
        RunEvent::Finished { stage, seconds, .. } => format!(
            "[{}/{n}] {}: done in {seconds:.1} s",
            stage.number(),
            stage.name()
        ),
    })
}

/// What the reporter has been shown.
#[derive(Default)]
struct Shown {
    generation: u64,
    position: u64,
    message: String,
    finished: bool,
    notes: usize,
}

/// Hands what changed since `shown` to `reporter` (methods `start(task, total)`,
/// `update(position, message)`, `note(line)`, `finish()`).
fn show(bridge: &Bridge, reporter: &Bound<'_, PyAny>, shown: &mut Shown) -> PyResult<()> {
    let (task, notes, position, message, finished, generation) = {
        let s = bridge.state.lock().unwrap_or_else(|p| p.into_inner());
        (
            (s.generation != shown.generation)
                .then(|| s.task.clone())
                .flatten(),
            s.notes[shown.notes..].to_vec(),
            s.position,
            s.message.clone(),
            s.finished,
            s.generation,
        )
    };
    shown.notes += notes.len();
    for line in notes {
        reporter.call_method1("note", (line,))?;
    }
    if let Some((name, len)) = task {
        reporter.call_method1("start", (name, len))?;
        *shown = Shown {
            generation,
            notes: shown.notes,
            ..Shown::default()
        };
    }
    if position != shown.position || message != shown.message {
        reporter.call_method1("update", (position, &message))?;
        shown.position = position;
        shown.message = message;
    }
    if finished && !shown.finished {
        reporter.call_method0("finish")?;
        shown.finished = true;
    }
    Ok(())
}

/// Runs `work` on a worker thread without the GIL, showing its progress on `reporter` and
/// stopping it on Ctrl-C (module docs). A pipeline error becomes its Python exception; an
/// interruption a `KeyboardInterrupt`.
pub fn blocking<T: Send>(
    py: Python<'_>,
    reporter: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce(&Bridge) -> Result<T, PipelineError> + Send,
) -> PyResult<T> {
    let bridge = Bridge::default();
    let done = (Mutex::new(false), Condvar::new());
    let mut shown = Shown::default();
    let mut failure: Option<PyErr> = None;
    let result = std::thread::scope(|scope| {
        let worker = std::thread::Builder::new()
            .name("flexstage".into())
            .stack_size(STACK)
            .spawn_scoped(scope, || {
                let r = work(&bridge);
                *done.0.lock().unwrap_or_else(|p| p.into_inner()) = true;
                done.1.notify_all();
                r
            })
            .map_err(|e| PyRuntimeError::new_err(format!("cannot start a thread: {e}")))?;
        loop {
            let finished = py.detach(|| {
                let guard = done.0.lock().unwrap_or_else(|p| p.into_inner());
                let (guard, _) = done
                    .1
                    .wait_timeout_while(guard, POLL, |d| !*d)
                    .unwrap_or_else(|p| p.into_inner());
                *guard
            });
            if let Some(r) = reporter
                && let Err(e) = show(&bridge, r, &mut shown)
            {
                failure.get_or_insert(e);
                bridge.stop.store(true, Ordering::Relaxed);
            }
            if let Err(e) = py.check_signals() {
                failure.get_or_insert(e);
                bridge.stop.store(true, Ordering::Relaxed);
            }
            if finished {
                break;
            }
        }
        worker
            .join()
            .map_err(|_| PyRuntimeError::new_err("the flexstage worker thread panicked"))
    })?;
    match (result, failure) {
        (Err(e), _) => Err(errors::pipeline(e)),
        (Ok(_), Some(e)) if e.is_instance_of::<PyKeyboardInterrupt>(py) => {
            Err(PyKeyboardInterrupt::new_err(
                "interrupted: the call had finished when it could stop; its results are written",
            ))
        }
        (Ok(_), Some(e)) => Err(e),
        (Ok(v), None) => Ok(v),
    }
}
