//! The exported C of the backstepping controller against the Rust one, when a C compiler
//! (`cc`) is installed (CI runs the same check for every exported controller in
//! `.ci/c-check`); without `cc` the test says so and passes.

use std::path::Path;
use std::process::Command;

use flexstage_control::actuator::Compensation;
use flexstage_control::controller::ROBUST;
use flexstage_control::experiment::Setup;
use flexstage_control::target_backstepping::{BacksteppingLaw, recorded_sequence};

/// The `robust` design on the paper scenario over two decoupled 1 %-damped modes with one
/// sample of delay, inverse compensation, predicting over one sample.
fn law() -> BacksteppingLaw {
    let setup = Setup::from_scenario(&flexstage_scenario::Scenario::paper());
    let designs = flexstage_control::samples::decoupled_designs(&setup).unwrap();
    designs
        .get(&ROBUST)
        .unwrap()
        .backstepping(setup.actuator(Compensation::Inverse), 1)
        .unwrap()
        .unwrap()
}

/// Compiles `law` as C with the check harness and runs it on the sequence `sequence_of`
/// recorded; true when the check passed.
fn c_check(dir: &Path, prefix: &str, law: &BacksteppingLaw, sequence_of: &BacksteppingLaw) -> bool {
    let src = law.c_source(prefix, &format!("{prefix}.h")).unwrap();
    std::fs::write(dir.join(format!("{prefix}.h")), src.header).unwrap();
    std::fs::write(dir.join(format!("{prefix}.c")), src.source).unwrap();
    let seq = recorded_sequence(sequence_of, 11).unwrap();
    let csv = dir.join(format!("{prefix}.csv"));
    std::fs::write(&csv, seq.to_csv(sequence_of)).unwrap();
    let harness = Path::new(env!("CARGO_MANIFEST_DIR")).join("c/check_backstepping.c");
    let exe = dir.join(format!("{prefix}.check"));
    let built = Command::new("cc")
        .args([
            "-std=c99",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-pedantic",
            "-O2",
        ])
        .arg(format!("-I{}", dir.display()))
        .arg(format!("-DCONTROLLER={prefix}"))
        .arg(format!("-DCONTROLLER_H=\"{prefix}.h\""))
        .arg(&harness)
        .arg(dir.join(format!("{prefix}.c")))
        .arg("-lm")
        .arg("-o")
        .arg(&exe)
        .status()
        .unwrap();
    assert!(built.success(), "{prefix}: the C does not compile");
    Command::new(&exe).arg(&csv).status().unwrap().success()
}

/// Goal: the exported C of the backstepping controller gives the Rust law's commands to
/// 1e-12 relative (the reference times bitwise) on its recorded sequence, and a copy with
/// one entry of the filter matrix F changed by one part in 10⁹ is refused.
#[test]
fn the_c_backstepping_controller_matches_the_rust_one() {
    if Command::new("cc").arg("--version").output().is_err() {
        eprintln!("cc not found: the C check runs in CI (.ci/c-check)");
        return;
    }
    let dir = std::env::temp_dir().join(format!("flexstage-bs-c-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let l = law();
    assert!(c_check(&dir, "robust", &l, &l));
    let mut m = l.clone();
    m.f[(4, 0)] *= 1.0 + 1e-9;
    assert!(!c_check(&dir, "robust_mutated", &m, &l));
    std::fs::remove_dir_all(&dir).unwrap();
}
