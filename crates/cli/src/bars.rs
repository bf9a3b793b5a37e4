//! Progress on standard error: `indicatif` bars for long tasks, one line per notable event,
//! and the stage lines of `flexstage run`. Bars draw nothing when standard error is not a
//! terminal (CI logs, pipes).

use std::sync::Mutex;
use std::time::Duration;

use flexstage_pipeline::{Progress, RunEvent, Stage, StartOver};
use indicatif::{ProgressBar, ProgressStyle};

use crate::print;

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
        self.with(|b| b.set_position(position));
    }

    fn advance(&self, steps: u64) {
        self.with(|b| b.inc(steps));
    }

    fn set_message(&self, message: &str) {
        self.with(|b| b.set_message(message.to_string()));
    }

    fn finish(&self) {
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
            RunEvent::Started(s) => errln!("[{}/{n}] {} ...", s.number(), s.name()),
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
