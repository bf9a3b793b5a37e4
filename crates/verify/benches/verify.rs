//! Benchmarks of the body-fitted verification on the paper-size (120 × 60 mm) bridge sample.
//! Run: `cargo bench -p flexstage-verify --bench verify`.

use flexstage_scenario::Preset;
use flexstage_verify::{VerifyParams, samples, verify};

fn main() {
    divan::main();
}

fn bench(bencher: divan::Bencher, refine_check: bool) {
    let (s, rho, loops) = samples::bridge_design(Preset::Paper);
    let p = VerifyParams {
        compare_design_mesh: false,
        refine_check,
        ..VerifyParams::default()
    };
    bencher.bench_local(|| verify(&s, &rho, &loops, &p).unwrap());
}

/// Outline → medial discs → manufacturability → body-fitted T6 mesh → statics at the four
/// stroke corners, transfer matrix and three frequencies (no design-mesh comparison).
#[divan::bench(sample_count = 5)]
fn verify_paper_bridge(bencher: divan::Bencher) {
    bench(bencher, false);
}

/// The same plus the re-check of the peak stress on a mesh of half the size (the default).
#[divan::bench(sample_count = 3)]
fn verify_paper_bridge_with_recheck(bencher: divan::Bencher) {
    bench(bencher, true);
}
