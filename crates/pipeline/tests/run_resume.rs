//! Reference: the pipeline-library requirements (the pipeline library keeps `flexstage run` resumable), the run-and-report requirements
//! ("running it again resumes") and the input-bounds and fault-handling requirements (a mismatch refuses to resume, saying what
//! changed). Goal: on a short version of the quick scenario, `run` finishes every stage; a
//! second call with the same scenario skips all seven; a changed scenario is refused with the
//! changed field and leaves the folder as it was (on the tiny quick preset of `common`); other options are refused; `restart` starts
//! over on request. The events come through the `Progress` trait, in order.

use std::sync::Mutex;

use flexstage_pipeline::{
    Progress, RunEvent, RunOptions, RunState, Scenario, Stage, StartOver, run::run,
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
    assert!(root.join(layout::design::DESIGN).is_file());
    assert!(!root.join(layout::design::CHECKPOINT).exists());
    assert!(!s.headline.is_empty(), "headline numbers");
    let names = Stage::ALL.map(Stage::name);
    let state = RunState::load(&RunDir::create(&root).unwrap(), &names)
        .unwrap()
        .unwrap();
    assert!(names.iter().all(|n| state.finished(n)));

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
/// finished run, each damage the issue names makes the next `run` redo the stage that wrote
/// the file (saying so, with every later stage) and skip the ones before, and the redone
/// files equal the first run's byte for byte; `report` refuses a folder whose scenario.toml
/// was edited since the run.
#[test]
fn run_redoes_a_stage_whose_files_are_gone_or_damaged() {
    let root = std::env::temp_dir().join(format!("flexstage-run-damage-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let quick: Scenario = common::tiny();
    let rec = Recorder::default();
    let options = short();
    run(quick.clone(), &root, &options, &rec).unwrap();
    rec.take();
    let read = |rel: &str| std::fs::read(root.join(rel)).unwrap();
    let metrics = Tracking::variant("duration-0.05s").metrics();
    let kept = [
        layout::design::DESIGN,
        layout::reduce::PARAMS,
        layout::stage::TABLE,
        layout::stage::PARAMS,
        metrics.as_str(),
    ]
    .map(|rel| (rel, read(rel)));
    let first_redone = |ev: &[String]| {
        ev.iter()
            .find(|e| e.starts_with("redo "))
            .cloned()
            .unwrap_or_default()
    };
    // (the stage redone, the file it names, the damage)
    type Case<'a> = (&'a str, &'a str, Box<dyn Fn() + 'a>);
    let cases: [Case; 3] = [
        (
            "pea",
            "identify/pea1/",
            Box::new(|| {
                std::fs::remove_dir_all(root.join(layout::stage::DIR).parent().unwrap()).unwrap();
                std::fs::remove_dir_all(root.join(Tracking::DIR)).unwrap();
            }),
        ),
        (
            "reduce",
            layout::reduce::PARAMS,
            Box::new(|| {
                let p = root.join(layout::reduce::PARAMS);
                let text = std::fs::read_to_string(&p).unwrap();
                let line = text.lines().find(|l| l.starts_with("mass = ")).unwrap();
                std::fs::write(&p, text.replace(line, "mass = nan")).unwrap();
            }),
        ),
        (
            "design",
            layout::design::DESIGN,
            Box::new(|| {
                let p = root.join(layout::design::DESIGN);
                let bytes = std::fs::read(&p).unwrap();
                std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
            }),
        ),
    ];
    for (stage, file, damage) in cases {
        damage();
        run(quick.clone(), &root, &options, &rec).unwrap();
        let ev = rec.take();
        let redo = first_redone(&ev);
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
        for (rel, bytes) in &kept {
            assert!(
                read(rel) == *bytes,
                "{stage}: {rel} differs from the first run"
            );
        }
    }
    // The report refuses a scenario.toml edited after the run, naming it.
    let p = root.join(layout::SCENARIO);
    let mut edited = quick.clone();
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
