//! Reference: the input-bounds and fault-handling requirements, "Two `run`s on one folder mix their results", "Random bit flips in
//! `checkpoint.bin` resume with exit 0", "A killed run resumes a checkpoint made under a
//! different scenario". Goal: on a real interrupted `run` (tiny quick preset, killed with SIGKILL
//! once its design has written a checkpoint), (1) a second `run` on a folder that another
//! live process is working in is refused, naming that process; (2) a checkpoint with a flipped
//! bit, a truncated checkpoint and the checkpoint of another scenario are each refused with
//! an error naming the file, never resumed; (3) the intact checkpoint does resume.
//!
//! The runs to be killed are child processes of this test binary (`child` below, active only
//! when `FLEXSTAGE_FAULT_CHILD` names a folder).

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use flexstage_pipeline::{PipelineError, RunOptions, Silent, run::run};
use flexstage_run::layout;

mod common;

/// 12 design iterations with a checkpoint every 2, every later stage short
/// ([`common::short`]) on [`common::tiny`].
fn options() -> RunOptions {
    common::short(12, 2, false)
}

const CHILD: &str = "FLEXSTAGE_FAULT_CHILD";
const CHECKPOINT: &str = layout::design::CHECKPOINT;

#[test]
fn child() {
    let Some(root) = std::env::var_os(CHILD) else {
        return;
    };
    println!("started");
    run(common::tiny(), Path::new(&root), &options(), &Silent).unwrap();
}

fn spawn(root: &Path) -> Child {
    let mut c = Command::new(std::env::current_exe().unwrap())
        .args(["--exact", "child", "--nocapture", "--test-threads=1"])
        .env(CHILD, root)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Drain the output so that the child never blocks on a full pipe.
    let out = c.stdout.take().unwrap();
    std::thread::spawn(move || BufReader::new(out).lines().for_each(drop));
    c
}

/// Waits until `cond` holds (or the child ended, or 120 s passed).
fn wait_for(child: &mut Child, cond: impl Fn() -> bool) -> bool {
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_secs(120) {
        if cond() {
            return true;
        }
        if child.try_wait().unwrap().is_some() {
            return false;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    false
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("flexstage-faults-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            copy_dir(&p, &to.join(e.file_name()));
        } else {
            std::fs::copy(&p, to.join(e.file_name())).unwrap();
        }
    }
}

#[test]
fn a_second_run_is_refused_and_damaged_or_foreign_checkpoints_are_never_resumed() {
    if std::env::var_os(CHILD).is_some() {
        return;
    }
    let root = tmp("killed");
    let mut child = spawn(&root);
    let ckpt = root.join(CHECKPOINT);
    assert!(
        wait_for(&mut child, || ckpt.is_file()),
        "no checkpoint was written"
    );

    // (1) Two runs on one folder: the second is refused, naming the live holder.
    let e = run(common::tiny(), &root, &options(), &Silent).unwrap_err();
    assert!(matches!(e, PipelineError::Locked { .. }), "{e}");
    assert!(e.to_string().contains(&child.id().to_string()), "{e}");

    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    let intact = std::fs::read(&ckpt).unwrap();

    // (2a) A flipped bit in the middle of the payload, and (2b) a truncation.
    let mut flipped = intact.clone();
    let k = flipped.len() - 17;
    flipped[k] ^= 0x10;
    let cases: [(&str, Vec<u8>, &str); 2] = [
        ("flipped", flipped, "CRC-32 mismatch"),
        (
            "truncated",
            intact[..intact.len() / 2].to_vec(),
            "truncated",
        ),
    ];
    for (name, bytes, reason) in cases {
        let r = tmp(name);
        copy_dir(&root, &r);
        std::fs::write(r.join(CHECKPOINT), &bytes).unwrap();
        let e = run(common::tiny(), &r, &options(), &Silent).unwrap_err();
        let m = e.to_string();
        assert!(matches!(e, PipelineError::Damaged { .. }), "{name}: {m}");
        assert!(m.contains(CHECKPOINT) && m.contains(reason), "{name}: {m}");
        assert!(
            !r.join(layout::design::DESIGN).exists(),
            "{name}: a design was made"
        );
        let _ = std::fs::remove_dir_all(&r);
    }

    // (2c) The checkpoint of another scenario (penalty 2 instead of 3) in this run's folder.
    let mut other = common::tiny();
    other.optimization.penalty = 2.0;
    let foreign = {
        // A checkpoint of `other` after two iterations, sealed as the design stage seals it
        // (a finished design removes its checkpoint, so it is made here directly).
        let problem = flexstage_topopt::Problem::from_scenario(&other, None).unwrap();
        let params = flexstage_topopt::OptimizerParams::from_scenario(&other);
        let mut opt = flexstage_topopt::Optimizer::new(&problem, params).unwrap();
        opt.step().unwrap();
        opt.step().unwrap();
        flexstage_pipeline::envelope::seal(&other, &opt.checkpoint())
    };
    let r = tmp("foreign");
    copy_dir(&root, &r);
    std::fs::write(r.join(CHECKPOINT), &foreign).unwrap();
    let e = run(common::tiny(), &r, &options(), &Silent).unwrap_err();
    let m = e.to_string();
    assert!(matches!(e, PipelineError::OtherScenario { .. }), "{m}");
    assert!(m.contains("optimization.penalty: 2.0 → 3.0"), "{m}");
    let _ = std::fs::remove_dir_all(&r);

    // (3) The intact checkpoint resumes to the end; the killed holder's lock is taken over.
    run(common::tiny(), &root, &options(), &Silent).unwrap();
    assert!(root.join(layout::design::DESIGN).is_file());
    assert!(!root.join(layout::LOCK).exists());
    let _ = std::fs::remove_dir_all(&root);
}
