//! Reference: the input-bounds and fault-handling requirements, "kill -9 at any point of `run`, then rerun: bitwise-identical final
//! design and identical report numbers". Goal: `run` on a tiny version of the quick preset
//! (`common::tiny`, `common::short`: 16 design iterations with a checkpoint every 3, a
//! one-scale validity map, short identification and tracking) is killed with SIGKILL in every
//! stage in turn — each rerun resumes the finished stages and is killed a seeded random
//! fraction into the next one, so one chain of kills hits all eight stages for about the cost
//! of two runs — and then run to its end; two chains with other fractions, at the same time
//! (one thread each). Every result file of the folder must equal, byte for byte, the one of an uninterrupted run; the only
//! exceptions are wall-clock times (`run_state.json`, the design's timing fields, the report's
//! time column, the DXF header's date, the last checkpoint's history) and the run folder's own
//! path inside files. The rerun also takes over the killed process's lock and removes the
//! temporaries of its interrupted writes, so the folder ends with neither.
//!
//! The runs are child processes of this test binary: the `child` test below does the run when
//! `FLEXSTAGE_KILL_CHILD` names a folder (and nothing otherwise), printing one `EVENT` line
//! per stage start and end.

mod common;

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

use flexstage_pipeline::{Progress, RunEvent, Stage, run::run};
use flexstage_run::layout::{self, Tracking};

const CHILD: &str = "FLEXSTAGE_KILL_CHILD";
/// Chains of kills, each with its own fractions.
const SEEDS: u64 = 2;
/// Longest wait for a child's event or end.
const PATIENCE: Duration = Duration::from_secs(120);

/// Prints the stage events for the parent.
struct Events;

impl Progress for Events {
    fn event(&self, e: &RunEvent) {
        let line = match e {
            RunEvent::Started(s) => format!("EVENT start {}", s.name()),
            RunEvent::Finished { stage, seconds, .. } => {
                format!("EVENT done {} {seconds}", stage.name())
            }
            _ => return,
        };
        let mut out = std::io::stdout().lock();
        let _ = writeln!(out, "{line}");
        let _ = out.flush();
    }

    fn note(&self, line: &str) {
        let _ = writeln!(std::io::stdout().lock(), "NOTE {line}");
    }
}

/// The child: one `run` into the folder `$FLEXSTAGE_KILL_CHILD`.
#[test]
fn child() {
    let Some(root) = std::env::var_os(CHILD) else {
        return;
    };
    run(
        common::tiny(),
        Path::new(&root),
        &common::short(16, 3, true),
        &Events,
    )
    .unwrap();
}

fn spawn(root: &Path) -> (Child, Receiver<String>) {
    let mut child = Command::new(std::env::current_exe().unwrap())
        .args(["--exact", "child", "--nocapture", "--test-threads=1"])
        .env(CHILD, root)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let stdout = child.stdout.take().unwrap();
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    (child, rx)
}

/// Runs a child to its end; the seconds of each stage.
fn complete(root: &Path) -> BTreeMap<String, f64> {
    let (mut child, rx) = spawn(root);
    let mut seconds = BTreeMap::new();
    for line in rx.iter() {
        if let Some(rest) = line.strip_prefix("EVENT done ") {
            let (stage, s) = rest.split_once(' ').unwrap();
            seconds.insert(stage.to_string(), s.parse().unwrap());
        }
    }
    assert!(
        child.wait().unwrap().success(),
        "the run failed in {root:?}"
    );
    seconds
}

/// Starts a child and kills it `delay` after `stage` (or a later one) starts; whether it was
/// killed before finishing.
fn kill_during(root: &Path, stage: Stage, delay: Duration) -> bool {
    let (mut child, rx) = spawn(root);
    let t0 = Instant::now();
    loop {
        match rx.recv_timeout(Duration::from_millis(20)) {
            Ok(line) => {
                let started = line
                    .strip_prefix("EVENT start ")
                    .and_then(|n| Stage::ALL.iter().position(|s| s.name() == n));
                if started.is_some_and(|i| i + 1 >= stage.number()) {
                    break;
                }
            }
            Err(_) if child.try_wait().unwrap().is_some() => return false,
            Err(_) => assert!(t0.elapsed() < PATIENCE, "no event from the child"),
        }
    }
    std::thread::sleep(delay);
    let killed = child.try_wait().unwrap().is_none();
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    killed
}

/// A small deterministic generator (64-bit LCG, Knuth's MMIX constants): a fraction in [0, 1).
fn fraction(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

/// Every file of a run folder, relative path → content with the folder's own path replaced
/// and wall-clock times removed.
fn results(root: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut dirs = vec![root.to_path_buf()];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                dirs.push(p);
                continue;
            }
            let rel = p
                .strip_prefix(root)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            if let Some(bytes) = comparable(&rel, &p, root) {
                out.insert(rel, bytes);
            }
        }
    }
    out
}

/// The content of one result file as compared, `None` for files of wall-clock times only.
fn comparable(rel: &str, path: &Path, root: &Path) -> Option<Vec<u8>> {
    let bytes = std::fs::read(path).unwrap();
    match rel {
        layout::RUN_STATE
        | layout::design::CHECKPOINT
        | layout::design::HISTORY_JSON
        | layout::REPORT
        | layout::export::DXF => return None,
        _ => {}
    }
    let Ok(text) = String::from_utf8(bytes.clone()) else {
        return Some(bytes);
    };
    let text = text.replace(&root.display().to_string(), "<run>");
    let text = match rel {
        layout::design::SUMMARY => {
            let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
            let m = v.as_object_mut().unwrap();
            m.remove("seconds");
            m.remove("seconds_per_iteration");
            v.to_string()
        }
        layout::design::HISTORY_CSV => drop_column(&text, "time_s"),
        layout::twin::VALIDITY => {
            let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
            drop_seconds(&mut v);
            v.to_string()
        }
        _ => text,
    };
    Some(text.into_bytes())
}

/// Removes every wall-clock field (`build_seconds`, `seconds`, `reference_seconds`, …).
fn drop_seconds(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(m) => {
            m.retain(|k, _| !k.ends_with("seconds"));
            m.values_mut().for_each(drop_seconds);
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(drop_seconds),
        _ => {}
    }
}

fn drop_column(csv: &str, name: &str) -> String {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let k = header.iter().position(|h| *h == name).unwrap();
    std::iter::once(header)
        .chain(lines.map(|l| l.split(',').collect()))
        .map(|cells: Vec<&str>| {
            let kept: Vec<&str> = cells
                .iter()
                .enumerate()
                .filter(|(i, _)| *i != k)
                .map(|(_, c)| *c)
                .collect();
            kept.join(",")
        })
        .collect::<Vec<_>>()
        .join("\n")
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("flexstage-kill9-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn kill_9_at_random_points_then_rerun_gives_the_uninterrupted_results() {
    if std::env::var_os(CHILD).is_some() {
        return;
    }
    let reference = tmp("reference");
    let seconds = complete(&reference);
    let expected = results(&reference);
    assert!(
        expected.contains_key(layout::design::DESIGN)
            && expected.contains_key(&Tracking::variant("duration-0.05s").metrics())
    );
    // The chains run at the same time, one thread each: each chain is a sequence of child
    // processes, so on two cores they take about the time of one.
    let chain = |seed: u64| {
        let root = tmp(&format!("seed{seed}"));
        let mut rng = seed + 1;
        let mut killed = 0;
        for stage in Stage::ALL {
            let f = fraction(&mut rng);
            let delay = Duration::from_secs_f64(f * seconds[stage.name()]);
            let hit = kill_during(&root, stage, delay);
            killed += hit as usize;
            println!(
                "seed {seed}: kill in {} after {:.3} s: {}",
                stage.name(),
                delay.as_secs_f64(),
                if hit { "killed" } else { "had finished" }
            );
        }
        complete(&root);
        let got = results(&root);
        let names = |m: &BTreeMap<String, Vec<u8>>| m.keys().cloned().collect::<Vec<_>>();
        assert_eq!(names(&got), names(&expected), "seed {seed}: other files");
        for (rel, bytes) in &expected {
            assert!(
                &got[rel] == bytes,
                "seed {seed}: {rel} differs from the uninterrupted run"
            );
        }
        assert!(!root.join(layout::LOCK).exists(), "seed {seed}: lock left");
        let _ = std::fs::remove_dir_all(&root);
        killed
    };
    let killed: usize = std::thread::scope(|scope| {
        let chains: Vec<_> = (0..SEEDS)
            .map(|seed| scope.spawn(move || chain(seed)))
            .collect();
        chains.into_iter().map(|c| c.join().unwrap()).sum()
    });
    // Most kills hit a running stage (a kill can come after a short stage has ended).
    assert!(
        killed >= SEEDS as usize * Stage::ALL.len() / 2,
        "only {killed} kills hit a running process"
    );
    let _ = std::fs::remove_dir_all(&reference);
}
