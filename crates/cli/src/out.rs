//! Standard output and standard error that a closed pipe cannot kill.
//!
//! `println!` panics when the write fails (`flexstage check | head -1`, output to
//! `/dev/full`), which would end a run in the middle. Every line of the CLI goes through
//! [`write`] instead (the `outln!`, `out!` and `errln!` macros): the first failed write closes
//! that stream for the rest of the process, and the command itself goes on (a run completes
//! and writes its results; only printing stops). A broken pipe is the reader's choice and
//! stays quiet; any other failure of standard output is reported once at the end
//! ([`finish`]) and makes the exit status non-zero.

use std::fmt;
use std::io::{self, ErrorKind, Write};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

/// The two streams.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    /// Standard output: results.
    Out,
    /// Standard error: progress, notes, errors.
    Err,
}

static OUT_CLOSED: AtomicBool = AtomicBool::new(false);
static ERR_CLOSED: AtomicBool = AtomicBool::new(false);
/// The first failure of standard output other than a broken pipe.
static OUT_FAILURE: Mutex<Option<String>> = Mutex::new(None);

fn closed(stream: Stream) -> &'static AtomicBool {
    match stream {
        Stream::Out => &OUT_CLOSED,
        Stream::Err => &ERR_CLOSED,
    }
}

/// Writes `args` to `stream` unless it is closed; a failed write closes it.
pub fn write(stream: Stream, args: fmt::Arguments) {
    if closed(stream).load(Ordering::Relaxed) {
        return;
    }
    let result = match stream {
        Stream::Out => io::stdout().lock().write_fmt(args),
        Stream::Err => io::stderr().lock().write_fmt(args),
    };
    if let Err(e) = result {
        fail(stream, &e);
    }
}

fn fail(stream: Stream, e: &io::Error) {
    closed(stream).store(true, Ordering::Relaxed);
    if stream == Stream::Out && e.kind() != ErrorKind::BrokenPipe {
        let mut first = OUT_FAILURE.lock().unwrap_or_else(|p| p.into_inner());
        first.get_or_insert_with(|| e.to_string());
    }
}

/// Flushes standard output and returns its first failure other than a broken pipe, if any
/// (to be reported once, with a non-zero exit status).
pub fn finish() -> Option<String> {
    if !OUT_CLOSED.load(Ordering::Relaxed)
        && let Err(e) = io::stdout().lock().flush()
    {
        fail(Stream::Out, &e);
    }
    OUT_FAILURE
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .clone()
}

/// `println!` to standard output through [`write`].
macro_rules! outln {
    () => {
        $crate::out::write($crate::out::Stream::Out, format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::out::write($crate::out::Stream::Out, format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `print!` to standard output through [`write`].
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::out::write($crate::out::Stream::Out, format_args!($($arg)*))
    };
}

/// `eprintln!` to standard error through [`write`].
macro_rules! errln {
    ($($arg:tt)*) => {
        $crate::out::write($crate::out::Stream::Err, format_args!("{}\n", format_args!($($arg)*)))
    };
}
