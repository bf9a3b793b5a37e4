//! Reference: issue #17 (the pipeline library keeps `flexstage run` resumable), issue #10
//! ("running it again resumes") and issue #16 (a mismatch refuses to resume, saying what
//! changed). Goal: on a short version of the quick scenario, `run` finishes every stage; a
//! second call with the same scenario skips all seven; a changed scenario is refused with the
//! changed field and leaves the folder as it was (on the tiny quick preset of `common`); other options are refused; `restart` starts
//! over on request. The events come through the `Progress` trait, in order.

use std::sync::Mutex;

use flexstage_pipeline::{
    Progress, RunEvent, RunOptions, RunState, Scenario, Stage, StartOver, run::run,
};

mod common;
use flexstage_report::RunDir;

/// Records the run events as short strings.
#[derive(Default)]
struct Recorder(Mutex<Vec<String>>);

impl Progress for Recorder {
    fn event(&self, e: &RunEvent) {
        let line = match e {
            RunEvent::StartingOver(StartOver::Requested) => "restart".to_string(),
            RunEvent::Resuming(done) => format!("resuming {}", done.len()),
            RunEvent::Skipped(s) => format!("skip {}", s.name()),
            RunEvent::Started(s) => format!("start {}", s.name()),
            RunEvent::Finished { stage, .. } => format!("done {}", stage.name()),
        };
        self.0.lock().unwrap().push(line);
    }
}

impl Recorder {
    fn take(&self) -> Vec<String> {
        std::mem::take(&mut *self.0.lock().unwrap())
    }
}

/// Every stage, made short ([`common::short`]): 4 design iterations (a checkpoint every 2), no modes or validity
/// map, no full-transient twin check, 0.2 s of identification, 0.05 s of tracking.
fn short() -> RunOptions {
    common::short(4, 2, false)
}

fn started(events: &[String]) -> usize {
    events.iter().filter(|e| e.starts_with("start ")).count()
}

#[test]
fn run_resumes_and_refuses_another_scenario_until_restarted() {
    let root = std::env::temp_dir().join(format!("flexstage-run-resume-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let quick: Scenario = common::tiny();
    let rec = Recorder::default();
    let options = short();

    let s = run(quick.clone(), &root, &options, &rec).unwrap();
    let ev = rec.take();
    assert_eq!(started(&ev), Stage::ALL.len(), "{ev:?}");
    assert!(s.report.is_file(), "report written");
    // Checkpoints were written (every 2 of 4 iterations) and removed with the finished design.
    assert!(root.join("design/design.json").is_file());
    assert!(!root.join("design/checkpoint.bin").exists());
    assert!(!s.headline.is_empty(), "headline numbers");
    let state = RunState::load(&RunDir::create(&root).unwrap())
        .unwrap()
        .unwrap();
    assert_eq!(state.finished_stages(), Stage::ALL.to_vec());

    run(quick.clone(), &root, &options, &rec).unwrap();
    let ev = rec.take();
    assert_eq!(ev[0], format!("resuming {}", Stage::ALL.len()));
    assert_eq!(
        ev.iter().filter(|e| e.starts_with("skip ")).count(),
        Stage::ALL.len()
    );
    assert_eq!(started(&ev), 0, "{ev:?}");

    let mut changed = quick.clone();
    changed.simulation.seed += 1;
    let e = run(changed.clone(), &root, &options, &rec)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("simulation.seed: ") && e.contains("--restart"),
        "{e}"
    );
    assert!(rec.take().is_empty(), "nothing ran");
    let recorded = Scenario::load(&root.join("scenario.toml")).unwrap();
    assert_eq!(recorded, quick, "the refused call changed nothing");

    let mut other_options = short();
    other_options.design.max_iterations = Some(5);
    let e = run(quick.clone(), &root, &other_options, &rec)
        .unwrap_err()
        .to_string();
    assert!(e.contains("other stage options"), "{e}");

    let restart = RunOptions {
        restart: true,
        ..short()
    };
    run(changed.clone(), &root, &restart, &rec).unwrap();
    let ev = rec.take();
    assert_eq!(ev[0], "restart", "{ev:?}");
    assert_eq!(started(&ev), Stage::ALL.len(), "{ev:?}");
    let recorded = Scenario::load(&root.join("scenario.toml")).unwrap();
    assert_eq!(
        recorded, changed,
        "the folder records the scenario the stages ran with"
    );
    std::fs::remove_dir_all(&root).unwrap();
}
