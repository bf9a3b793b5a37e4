//! Per-call costs of the generic numerics used in 10 kHz loops: one RLS update (1, 4 and 8
//! parameters), one equilibrated SPD factorization and solve (5 × 5, as in the parallel RLS
//! of `flexstage-piezo`), one Gaussian noise sample. None allocates.
//!
//! Run with `cargo bench -p flexstage-numerics`.

use divan::{Bencher, black_box};
use flexstage_numerics::dense::SpdFactor;
use flexstage_numerics::noise::GaussianNoise;
use flexstage_numerics::rls::{Rls, RlsParams};

fn main() {
    divan::main();
}

#[divan::bench(consts = [1, 4, 8])]
fn rls_update<const P: usize>(b: Bencher) {
    let params = RlsParams {
        forgetting: 0.999,
        ..RlsParams::default()
    };
    let mut rls = Rls::<P>::new(params, [0.0; P]).unwrap();
    let mut k = 0u64;
    b.bench_local(|| {
        k += 1;
        let mut phi = [0.0; P];
        for (i, v) in phi.iter_mut().enumerate() {
            *v = ((k + i as u64 * 7) % 13) as f64 - 6.0;
        }
        black_box(rls.update(black_box(&phi), black_box(k as f64 * 1e-3)))
    });
}

#[divan::bench]
fn spd_factor_and_solve_5x5(b: Bencher) {
    // A Hilbert-like normal matrix with columns of very different scale.
    let d = [1.0, 1e2, 1e-2, 1e3, 1e-1];
    let a: [[f64; 5]; 5] =
        std::array::from_fn(|i| std::array::from_fn(|j| d[i] * d[j] / (i + j + 1) as f64));
    let rhs = [1.0, 2.0, 3.0, 4.0, 5.0];
    b.bench_local(|| {
        let f = SpdFactor::new(black_box(&a)).unwrap();
        black_box(f.solve(black_box(&rhs)))
    });
}

#[divan::bench]
fn gaussian_noise_sample(b: Bencher) {
    let mut g = GaussianNoise::new(1.0, 7);
    b.bench_local(|| black_box(g.sample()));
}
