//! Reference: the second hardening review, "Silent long work": with output not on a terminal, a design that
//! runs for hours printed nothing (619 iterations in 20 s, no line). Goal: with standard error
//! a pipe, a design prints plain lines (start, at least one intermediate position, done), and
//! a stage without steps (stage identification) prints "still working" lines at the period
//! (`FLEXSTAGE_PROGRESS_SECONDS=1` here; 30 s by default).

use std::process::{Command, Stdio};

const BIN: &str = env!("CARGO_BIN_EXE_flexstage");

fn stderr_of(args: &[&str], out: &std::path::Path) -> String {
    let o = Command::new(BIN)
        .args(args)
        .arg("--out")
        .arg(out)
        .env("FLEXSTAGE_PROGRESS_SECONDS", "1")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn plain_progress_lines_when_stderr_is_not_a_terminal() {
    let dir = std::env::temp_dir().join(format!("flexstage-progress-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let e = stderr_of(&["design", "--max-iterations", "40"], &dir);
    assert!(e.contains("design: started, 41 steps"), "{e}");
    let between = e
        .lines()
        .filter(|l| l.starts_with("design: ") && l.contains("/41 after") && !l.ends_with("(done)"))
        .count();
    assert!(between >= 1, "no intermediate line: {e}");
    assert!(
        e.lines()
            .any(|l| l.starts_with("design: ") && l.ends_with("(done)")),
        "{e}"
    );
    let e = stderr_of(&["identify", "stage"], &dir);
    assert!(e.contains("identify: still working after 1 s"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}
