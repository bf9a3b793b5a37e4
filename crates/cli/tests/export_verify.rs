//! Reference: the design-quality requirements. Goal: `flexstage export` prints the verification of the
//! exported outline and its verdict as the last line; it writes the files either way; with
//! `--require-safe` a design that is not verified safe exits with status 2, a safe one with 0.

use flexstage_run::layout;
use std::path::Path;
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_flexstage");

fn export(dir: &Path, extra: &[&str]) -> (Output, String) {
    let out = Command::new(BIN)
        .args([
            "export",
            "--preset",
            "quick",
            "--design",
            "uniform:1",
            "--out",
        ])
        .arg(dir)
        .args(extra)
        .output()
        .expect("flexstage runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    (out, stdout)
}

#[test]
fn export_prints_the_verdict_and_require_safe_sets_the_exit_status() {
    let dir = std::env::temp_dir().join(format!("flexstage-export-verify-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    // A solid block at the quick preset's stroke: tens of MPa at the PEA contact patches.
    let (out, text) = export(&dir, &["--fatigue-strength-mpa", "1", "--require-safe"]);
    assert_eq!(out.status.code(), Some(2), "{text}");
    assert!(
        text.lines()
            .last()
            .unwrap()
            .starts_with("verdict: NOT safe"),
        "{text}"
    );
    assert!(
        text.contains("body-fitted mesh:") && text.contains("design mesh ("),
        "{text}"
    );
    for f in [
        layout::export::DXF,
        layout::export::VERIFICATION_JSON,
        layout::export::VERIFICATION_TXT,
        layout::export::BODY_FITTED_VTU,
    ] {
        assert!(dir.join(f).is_file(), "{f} missing");
    }
    // Without --require-safe the verdict is printed and the command succeeds.
    let (out, text) = export(&dir, &["--fatigue-strength-mpa", "1"]);
    assert!(
        out.status.success() && text.contains("verdict: NOT safe"),
        "{text}"
    );
    // A generous allowable: safe, status 0 with --require-safe.
    let (out, text) = export(&dir, &["--fatigue-strength-mpa", "5000", "--require-safe"]);
    assert!(out.status.success(), "{text}");
    assert!(
        text.lines().last().unwrap().starts_with("verdict: safe"),
        "{text}"
    );
    // --no-verify: the outline only.
    let (out, text) = export(&dir, &["--no-verify"]);
    assert!(out.status.success() && !text.contains("verdict"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}
