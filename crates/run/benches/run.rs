//! The run folder's costs: the SHA-256 of a result file (what `run` records and checks for
//! every file of a finished stage) and the typed write of a numeric table.

use flexstage_run::hash::sha256_hex;
use flexstage_run::{Format, Table};

fn main() {
    divan::main();
}

/// SHA-256 of 16 MiB (a large time series of `track` is about 5 MB).
#[divan::bench]
fn sha256_16_mib(bencher: divan::Bencher) {
    let bytes: Vec<u8> = (0..16u32 << 20)
        .map(|i| (i.wrapping_mul(2654435761) >> 24) as u8)
        .collect();
    bencher
        .counter(divan::counter::BytesCount::new(bytes.len()))
        .bench(|| sha256_hex(divan::black_box(&bytes)));
}

/// A 100 000-sample table of 4 columns encoded as CSV (a PEA identification's `loop.csv`).
#[divan::bench]
fn table_encode_100k_x4(bencher: divan::Bencher) {
    let col = |k: f64| {
        (0..100_000)
            .map(|i| (i as f64 * 1e-4 + k).sin())
            .collect::<Vec<f64>>()
    };
    let table = Table::new(
        &["t", "U", "x", "x_model"],
        vec![col(0.0), col(1.0), col(2.0), col(3.0)],
    );
    bencher.bench(|| divan::black_box(&table).encode().unwrap().len());
}
