//! Reference: the checkpoint-and-resume requirement: "After a `kill -9`, `flexstage design --resume
//! RUN_DIR` continues and reaches the same result." Goal: a quick-preset design run killed with
//! SIGKILL (`Child::kill`) right after its first checkpoint appears, resumed with `--resume`,
//! ends with the same density as an uninterrupted run: bitwise in practice (printed), asserted
//! to 1e-9 — the checkpoint stores every state the future depends on (design, MMA history, β,
//! c2, warm starts, scales), the load cases are solved in fixed groups independent of the
//! thread count and reduced in a fixed order, and faer's results do not depend on the buffers'
//! alignment here; the tolerance only guards against a last-bit difference from a platform
//! whose SIMD kernels round differently with alignment.

use flexstage_run::layout;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_flexstage");
const ITERATIONS: &str = "16";

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("flexstage-kill-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn design(args: &[&str]) -> Command {
    let mut c = Command::new(BIN);
    c.arg("design")
        .args(args)
        .args(["--max-iterations", ITERATIONS])
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    c
}

fn density(dir: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(dir.join(layout::design::DESIGN)).expect("the design file");
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["rho"]
        .as_array()
        .expect("rho array")
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

#[test]
fn kill_9_then_resume_reaches_the_uninterrupted_result() {
    let (a, b) = (tmp_dir("a"), tmp_dir("b"));
    // Uninterrupted reference run.
    let st = design(&["--preset", "quick", "--out", a.to_str().unwrap()])
        .status()
        .unwrap();
    assert!(st.success(), "reference run failed");

    // Interrupted run: SIGKILL as soon as the first checkpoint (iteration 3) is on disk.
    let ck = b.join(layout::design::CHECKPOINT);
    let mut child = design(&[
        "--preset",
        "quick",
        "--checkpoint-every",
        "3",
        "--out",
        b.to_str().unwrap(),
    ])
    .spawn()
    .unwrap();
    let t0 = Instant::now();
    while !ck.exists() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before its first checkpoint"
        );
        assert!(t0.elapsed() < Duration::from_secs(60), "no checkpoint");
        std::thread::sleep(Duration::from_millis(5));
    }
    let running = child.try_wait().unwrap().is_none();
    child.kill().unwrap(); // SIGKILL on Unix
    child.wait().unwrap();
    assert!(running, "the run finished before it could be killed");
    assert!(
        !b.join(layout::design::DESIGN).exists(),
        "the killed run must not have finished"
    );

    let st = design(&["--resume", b.to_str().unwrap(), "--checkpoint-every", "3"])
        .status()
        .unwrap();
    assert!(st.success(), "resume failed");

    let (ra, rb) = (density(&a), density(&b));
    assert_eq!(ra.len(), rb.len());
    let dmax = ra
        .iter()
        .zip(&rb)
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f64::max);
    let bitwise = ra.iter().zip(&rb).all(|(p, q)| p.to_bits() == q.to_bits());
    println!("max |rho_uninterrupted − rho_resumed| = {dmax:e}, bitwise equal: {bitwise}");
    assert!(dmax <= 1e-9, "resumed design differs by {dmax:e}");
    let _ = std::fs::remove_dir_all(&a);
    let _ = std::fs::remove_dir_all(&b);
}
