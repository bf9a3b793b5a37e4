//! Reference: the pipeline-library requirements (the pipeline library keeps `flexstage run` resumable), the run-and-report requirements
//! ("running it again resumes") and the input-bounds and fault-handling requirements (a mismatch refuses to resume, saying what
//! changed). Goal: on a short version of the quick scenario, `run` finishes every stage; a
//! second call with the same scenario skips all seven; a changed scenario is refused with the
//! changed field and leaves the folder as it was (on the tiny quick preset of `common`); other options are refused; `restart` starts
//! over on request. The events come through the `Progress` trait, in order.
//!
//! The tests share one first run (`first_run`, done once per process) and each works on a
//! copy of its folder, so that they run in parallel and the first run is paid once.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

use flexstage_pipeline::{
    Progress, RunEvent, RunOptions, RunState, RunSummary, Scenario, Stage, StartOver, run::run,
};

mod common;
use flexstage_run::RunDir;
use flexstage_run::layout::{self, Tracking};

/// Records the run events as short strings.
#[derive(Default)]
struct Recorder(Mutex<Vec<String>>);

impl Progress for Recorder {
    fn event(&self, e: &RunEvent) {
        let line = match e {
            RunEvent::StartingOver(StartOver::Requested) => "restart".to_string(),
            RunEvent::Resuming(done) => format!("resuming {}", done.len()),
            RunEvent::Skipped(s) => format!("skip {}", s.name()),
            RunEvent::Redoing { stage, why } => format!("redo {}: {why}", stage.name()),
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
/// map, no full-transient twin check, 0.2 s of identification, 0.05 s of tracking, one
/// Monte-Carlo plant.
fn short() -> RunOptions {
    common::short(4, 2, false)
}

/// The first run of [`common::tiny`] with [`short`] options, done once for every test of this
/// binary (they run in parallel threads; the first to get here runs it, the others wait):
/// its folder, its events and its summary. Each test works on its own copy ([`copy_of`]), so
/// this folder stays as the first run left it. It is kept in cargo's temporary folder of the
/// integration tests under a fixed name, replaced by the next process.
fn first_run() -> &'static (PathBuf, Vec<String>, RunSummary) {
    static FIRST: OnceLock<(PathBuf, Vec<String>, RunSummary)> = OnceLock::new();
    FIRST.get_or_init(|| {
        let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("run-resume-first");
        let _ = std::fs::remove_dir_all(&root);
        let rec = Recorder::default();
        let s = run(common::tiny(), &root, &short(), &rec).unwrap();
        (root, rec.take(), s)
    })
}

/// A fresh folder name of this process under the temporary directory.
fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "flexstage-run-resume-{}-{name}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// A copy of the first run's folder, every file byte for byte, in a folder of its own.
fn copy_of(name: &str) -> PathBuf {
    fn copy(from: &Path, to: &Path) {
        std::fs::create_dir_all(to).unwrap();
        for e in std::fs::read_dir(from).unwrap() {
            let e = e.unwrap();
            let target = to.join(e.file_name());
            if e.file_type().unwrap().is_dir() {
                copy(&e.path(), &target);
            } else {
                std::fs::copy(e.path(), &target).unwrap();
            }
        }
    }
    let root = tmp(name);
    copy(&first_run().0, &root);
    root
}

fn started(events: &[String]) -> usize {
    events.iter().filter(|e| e.starts_with("start ")).count()
}

#[test]
fn run_resumes_and_refuses_another_scenario_until_restarted() {
    let (first, ev, s) = first_run();
    assert_eq!(started(ev), Stage::ALL.len(), "{ev:?}");
    assert!(s.report.is_file(), "report written");
    // Checkpoints were written (every 2 of 4 iterations) and removed with the finished design.
    assert!(first.join(layout::design::DESIGN).is_file());
    assert!(!first.join(layout::design::CHECKPOINT).exists());
    let v = &s.verdict;
    assert!(v.design.is_some() && v.control.is_some(), "verdict: {v:?}");
    let names = Stage::ALL.map(Stage::name);
    let state = RunState::load(&RunDir::create(first).unwrap(), &names)
        .unwrap()
        .unwrap();
    assert!(names.iter().all(|n| state.finished(n)));

    let root = copy_of("resume");
    let quick: Scenario = common::tiny();
    let rec = Recorder::default();
    let options = short();
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
    let recorded = Scenario::load(&root.join(layout::SCENARIO)).unwrap();
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
    let recorded = Scenario::load(&root.join(layout::SCENARIO)).unwrap();
    assert_eq!(
        recorded, changed,
        "the folder records the scenario the stages ran with"
    );
    std::fs::remove_dir_all(&root).unwrap();
}

/// Reference: the second hardening round ("`run` trusts its state file, not its files"). Goal: after a
/// finished run, the damage `damage` does to a copy of its folder makes the next `run` redo
/// the stage `stage` that wrote the file `file` (saying so, with every later stage) and skip
/// the ones before, and the redone files equal the first run's byte for byte (but for the
/// folder's own path).
fn redoes(name: &str, stage: &str, file: &str, damage: impl Fn(&Path)) {
    let first = &first_run().0;
    let root = copy_of(name);
    let rec = Recorder::default();
    // A file's text with its folder's own path (the metrics' model column names the run's
    // parameter file) written as `<run>`.
    let read = |root: &Path, rel: &str| {
        std::fs::read_to_string(root.join(rel))
            .unwrap()
            .replace(&root.display().to_string(), "<run>")
    };
    let metrics = Tracking::variant("duration-0.05s").metrics();
    let kept = [
        layout::design::DESIGN,
        layout::reduce::PARAMS,
        layout::stage::TABLE,
        layout::stage::PARAMS,
        metrics.as_str(),
    ];
    damage(&root);
    run(common::tiny(), &root, &short(), &rec).unwrap();
    let ev = rec.take();
    let redo = ev
        .iter()
        .find(|e| e.starts_with("redo "))
        .cloned()
        .unwrap_or_default();
    assert!(
        redo.starts_with(&format!("redo {stage}: ")) && redo.contains(file),
        "{stage}: {ev:?}"
    );
    let at = Stage::ALL.iter().position(|s| s.name() == stage).unwrap();
    assert_eq!(
        ev.iter().filter(|e| e.starts_with("skip ")).count(),
        at,
        "the stages before {stage} are kept: {ev:?}"
    );
    assert_eq!(started(&ev), Stage::ALL.len() - at, "{ev:?}");
    for rel in kept {
        assert!(
            read(&root, rel) == read(first, rel),
            "{stage}: {rel} differs from the first run"
        );
    }
    std::fs::remove_dir_all(&root).unwrap();
}

/// [`redoes`]: the stage identification's folder and the tracking folder removed.
#[test]
fn run_redoes_the_stage_identification_whose_folder_is_gone() {
    redoes("pea", "pea", "identify/pea1/", |root| {
        std::fs::remove_dir_all(root.join(layout::stage::DIR).parent().unwrap()).unwrap();
        std::fs::remove_dir_all(root.join(Tracking::DIR)).unwrap();
    });
}

/// [`redoes`]: the reduced model's mass made NaN.
#[test]
fn run_redoes_the_reduction_whose_parameters_are_damaged() {
    redoes("reduce", "reduce", layout::reduce::PARAMS, |root| {
        let p = root.join(layout::reduce::PARAMS);
        let text = std::fs::read_to_string(&p).unwrap();
        let line = text.lines().find(|l| l.starts_with("mass = ")).unwrap();
        std::fs::write(&p, text.replace(line, "mass = nan")).unwrap();
    });
}

/// [`redoes`]: the design file cut in half.
#[test]
fn run_redoes_the_design_whose_file_is_truncated() {
    redoes("design", "design", layout::design::DESIGN, |root| {
        let p = root.join(layout::design::DESIGN);
        let bytes = std::fs::read(&p).unwrap();
        std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
    });
}

/// Reference: the second hardening round ("`run` trusts its state file, not its files"). Goal:
/// `report` refuses a folder whose scenario.toml was edited since the run, naming it.
#[test]
fn report_refuses_a_scenario_edited_after_the_run() {
    let root = copy_of("edited");
    let p = root.join(layout::SCENARIO);
    let mut edited = common::tiny();
    edited.simulation.seed += 1;
    std::fs::write(&p, edited.to_commented_toml()).unwrap();
    let folder = flexstage_pipeline::RunFolder::existing(&root).unwrap();
    let e = flexstage_pipeline::write_report(&folder)
        .unwrap_err()
        .to_string();
    assert!(e.contains(layout::SCENARIO) && e.contains("edited"), "{e}");
    drop(folder);
    std::fs::remove_dir_all(&root).unwrap();
}
