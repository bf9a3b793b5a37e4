//! One online identification update (four RLS rows, prefilter, regressors) and one
//! physical-parameter evaluation.

use flexstage_identify::{IdentifyParams, StageIdentifier, samples};

fn main() {
    divan::main();
}

#[divan::bench]
fn update(bencher: divan::Bencher) {
    let mut id = StageIdentifier::new(
        &samples::table4_guess(),
        0.0,
        1e-4,
        &IdentifyParams::default(),
    )
    .unwrap();
    let mut k = 0u64;
    bencher.bench_local(|| {
        k += 1;
        let t = k as f64 * 1e-4;
        let (s, c) = (t * 600.0).sin_cos();
        id.update(
            divan::black_box([1e-5 * s, 1e-5 * c]),
            [0.98e-5 * s, 0.98e-5 * c],
            [0.5e-5 * (s + c), 1e-5 * (s - c)],
        )
    });
}

#[divan::bench]
fn estimate(bencher: divan::Bencher) {
    let id = StageIdentifier::new(
        &samples::table4_guess(),
        0.0,
        1e-4,
        &IdentifyParams::default(),
    )
    .unwrap();
    bencher.bench_local(|| divan::black_box(&id).estimate());
}
