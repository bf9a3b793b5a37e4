//! Reference: the pipeline-library requirements "A pipeline library, a thin CLI, and a newcomer's path that never
//! surprises". Goal: the README's subcommand path on a fresh folder keeps every result in the
//! one run folder of the default scenario (`runs/quick`), analyses the run's design, gives
//! variants their own folders, refuses to replace a finished design without `--force`, refuses
//! a parameter file of another run, and prints each error (and each cause) exactly once.

use flexstage_run::layout::{self, Analysis, Tracking};
use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_flexstage");

/// Runs flexstage in `dir`; returns (success, stdout, stderr).
fn flexstage(dir: &Path, args: &[&str]) -> (bool, String, String) {
    let out = Command::new(BIN)
        .current_dir(dir)
        .args(args)
        .output()
        .expect("flexstage runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn ok(dir: &Path, args: &[&str]) -> String {
    let (success, stdout, stderr) = flexstage(dir, args);
    assert!(success, "flexstage {args:?} failed:\n{stderr}");
    stdout
}

fn fails(dir: &Path, args: &[&str]) -> String {
    let (success, _, stderr) = flexstage(dir, args);
    assert!(!success, "flexstage {args:?} should fail");
    assert_eq!(
        stderr.matches("error:").count(),
        1,
        "one error line:\n{stderr}"
    );
    stderr
}

fn fresh(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("flexstage-newcomer-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn errors_are_printed_once_with_their_cause_once() {
    let dir = fresh("errors");
    let e = fails(&dir, &["check", "missing.toml"]);
    assert!(e.contains("cannot read scenario missing.toml"), "{e}");
    // The OS error of the cause, once (it used to be repeated by every layer).
    assert_eq!(e.matches("(os error 2)").count(), 1, "cause once: {e}");
    let help = ok(&dir, &["--help"]);
    assert!(!help.contains("\\\""), "escaped quotes in --help:\n{help}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_subcommands_share_one_run_folder_and_never_overwrite_silently() {
    let dir = fresh("path");
    let run = dir.join("runs/quick");
    ok(&dir, &["design", "--max-iterations", "6"]);
    assert!(
        run.join(layout::design::DESIGN).is_file(),
        "design in runs/quick"
    );
    // A finished design is not replaced without --force.
    let e = fails(&dir, &["design", "--max-iterations", "6"]);
    assert!(
        e.contains("finished design") && e.contains("--force"),
        "{e}"
    );

    let e = fails(&dir, &["design", "--resume", "runs/quick"]);
    assert!(e.contains("nothing to resume"), "{e}");

    // analyze: the run's design by default, each analysis in its own folder.
    let out = ok(&dir, &["analyze"]);
    assert!(out.contains("the run's design"), "{out}");
    assert!(run.join(Analysis::variant("workspace").vtu()).is_file());
    let out = ok(&dir, &["analyze", "--inputs", "30,-30"]);
    assert!(out.contains("the run's design"), "{out}");
    assert!(run.join(Analysis::variant("inputs_30_-30").vtu()).is_file());
    assert!(
        run.join(Analysis::variant("workspace").workspace_svg())
            .is_file(),
        "kept"
    );

    // track: compensation off in its own folder, the default folder kept.
    // (one Monte-Carlo plant: the study's rates are not what this test checks.)
    let quick = [
        "--trajectory",
        "circle",
        "--variant",
        "robust",
        "--montecarlo-plants",
        "1",
    ];
    let out = ok(&dir, &[&["track"][..], &quick].concat());
    assert!(
        out.contains("plant: twin") || out.contains("stage.truth"),
        "which plant: {out}"
    );
    let off = ok(
        &dir,
        &[&["track", "--compensation", "off"][..], &quick].concat(),
    );
    assert!(off.contains("compensation: off"), "{off}");
    let main = std::fs::read_to_string(run.join(Tracking::main().metrics())).unwrap();
    let other =
        std::fs::read_to_string(run.join(Tracking::variant("compensation-off").metrics())).unwrap();
    assert!(
        main.contains(",inverse,") && !main.contains(",off,"),
        "{main}"
    );
    assert!(other.contains(",off,"), "{other}");

    // A parameter file of another run folder is refused (no silent jump between runs).
    let foreign = dir.join("elsewhere");
    std::fs::create_dir_all(foreign.join("reduce")).unwrap();
    std::fs::write(foreign.join(layout::SCENARIO), "").unwrap();
    std::fs::write(foreign.join(layout::reduce::PARAMS), "").unwrap();
    let e = fails(
        &dir,
        &[
            "track",
            "--params",
            &format!("elsewhere/{}", layout::reduce::PARAMS),
        ],
    );
    assert!(e.contains("belongs to the run folder"), "{e}");

    // report: the default run folder.
    let out = ok(&dir, &["report"]);
    assert!(
        out.contains(&format!("runs/quick/{}", layout::REPORT)),
        "{out}"
    );
    // Nothing went anywhere else.
    let runs: Vec<_> = std::fs::read_dir(dir.join("runs")).unwrap().collect();
    assert_eq!(runs.len(), 1, "one run folder");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn check_summarizes_a_mechanism_without_the_two_pea_stage() {
    // Goal: `check` on a [[ports]] mechanism says what it is and which stages apply, and does
    // not print the two-PEA stage's stroke samples and trajectories (which it has none of).
    let dir = fresh("check-mechanism");
    let scenario =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/scenarios/inverter.toml");
    let out = ok(&dir, &["check", scenario.to_str().unwrap()]);
    assert!(
        out.contains("mechanism:") && out.contains("1 input port(s)"),
        "{out}"
    );
    assert!(out.contains("output along (-1, 0)"), "{out}");
    assert!(
        !out.contains("trajectories") && !out.contains("p_m ="),
        "{out}"
    );
    let out = ok(&dir, &["check"]);
    assert!(
        out.contains("p_m = ") && out.contains("trajectories"),
        "{out}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
