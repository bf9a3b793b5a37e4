//! Benchmarks of the body-fitted verification.
//! Run: `cargo bench -p flexstage-verify --bench verify`.

use flexstage_scenario::Preset;
use flexstage_verify::{VerifyParams, samples, verify};

fn main() {
    divan::main();
}

/// Outline → medial discs → mesh → statics at the four corners, transfer matrix and three
/// frequencies, on the paper-size (120 × 60 mm) bridge sample; no design-mesh comparison.
#[divan::bench(sample_count = 5)]
fn verify_bridge_paper(bencher: divan::Bencher) {
    let (s, rho, loops) = samples::bridge_design(Preset::Paper);
    let p = VerifyParams {
        compare_design_mesh: false,
        ..VerifyParams::default()
    };
    bencher.bench_local(|| verify(&s, &rho, &loops, &p).unwrap());
}
