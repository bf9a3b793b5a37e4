//! Reference: the second hardening review, "Messages": refusals named internal types
//! (`ValidityParams::scales`, `VerifyParams::fatigue_strength`), printed 1e308 with 309 digits,
//! and `design --resume` after a design killed before its first checkpoint said only "cannot
//! read …/checkpoint.bin". Goal: each names the option in the scenario's words, prints the
//! number compactly, and the resume says what happened and how to start over.

use std::path::Path;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_flexstage");

/// The error line of a refused command (with `--out out`, if given).
fn refusal(args: &[&str], out: Option<&Path>) -> String {
    let mut c = Command::new(BIN);
    c.args(args);
    if let Some(out) = out {
        c.arg("--out").arg(out);
    }
    let o = c.output().unwrap();
    assert_eq!(o.status.code(), Some(1), "{args:?}");
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!e.contains("::"), "an internal name: {e}");
    assert!(!e.contains("0000000000"), "a long number: {e}");
    e
}

#[test]
fn refusals_name_the_option_compactly_and_resume_says_how_to_start_over() {
    let dir = std::env::temp_dir().join(format!("flexstage-messages-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let e = refusal(&["reduce", "--scales", "1e308"], Some(&dir));
    assert!(e.contains("reduce.scales = 1e308"), "{e}");
    let e = refusal(&["export", "--safety-factor", "1e308"], Some(&dir));
    assert!(e.contains("export.safety_factor = 1e308"), "{e}");
    let e = refusal(&["track", "--duration", "1e308"], Some(&dir));
    assert!(e.contains("track.duration = 1e308"), "{e}");
    // A run folder without a design checkpoint (a design killed before its first one).
    let o = Command::new(BIN)
        .args(["pea", "simulate", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(o.status.success());
    let e = refusal(&["design", "--resume", dir.to_str().unwrap()], None);
    assert!(
        e.contains("nothing to resume") && e.contains("start it over with `flexstage design --out"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Goal: `flexstage controller` takes a scenario only for a design from a measurement, and
/// says so; a scenario file that does not read is named as the scenario.
#[test]
fn controller_scenario_options_need_a_measurement_and_name_a_bad_scenario() {
    let o = Command::new(BIN)
        .args(["controller", "pi-notch-ff.json", "--preset", "quick"])
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("--response") && e.contains("--log"), "{e}");
    let dir = std::env::temp_dir().join(format!("flexstage-ctl-msg-{}", std::process::id()));
    let e = refusal(
        &[
            "controller",
            "--response",
            "measured.csv",
            "--scenario",
            dir.join("missing.toml").to_str().unwrap(),
        ],
        None,
    );
    assert!(
        e.contains("invalid scenario") && e.contains("missing.toml"),
        "{e}"
    );
}
