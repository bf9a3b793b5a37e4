// Reference: the chunked reduction design in src/subsolv.rs (fixed chunks, ordered sums).
// Goal: the rayon code path (n >= parallel_threshold) gives bit-for-bit the same iterates,
// multipliers and subproblem iteration counts as the serial path, on a problem with m = 3.

mod common;

use common::synthetic;
use flexstage_mma::MmaParams;

fn run(parallel_threshold: usize) -> (Vec<f64>, Vec<f64>, Vec<usize>) {
    let params = MmaParams {
        parallel_threshold,
        ..MmaParams::default()
    };
    let (x, lam, reports) = synthetic(20_000, params);
    let its = reports.iter().map(|r| r.subproblem_iterations).collect();
    (x, lam, its)
}

#[test]
fn parallel_and_serial_paths_agree_bitwise() {
    let serial = run(usize::MAX);
    let parallel = run(0);
    assert_eq!(serial.2, parallel.2, "subproblem iteration counts differ");
    assert_eq!(serial.1, parallel.1, "multipliers differ");
    assert!(serial.0 == parallel.0, "iterates differ");
    assert!(
        serial.1.iter().any(|&l| l > 1e-6),
        "no active constraint: {:?}",
        serial.1
    );
}
