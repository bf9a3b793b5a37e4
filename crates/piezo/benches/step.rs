//! Per-step costs for the 10 kHz loop: one model step, one model + compensation step, one
//! parallel-RLS sample (summed regression, moments update and two 5×5 solves). Budgets
//!: model + compensation ≤ 200 ns, parallel-RLS sample ≤ 300 ns; none allocates.
//! The generic RLS update is benchmarked in `flexstage-numerics`.

use divan::{Bencher, black_box};
use flexstage_piezo::{
    BoucWen, BoucWenParams, CompensatorParams, IdentifyParams, InverseCompensator, ParallelRls,
};

fn main() {
    divan::main();
}

const DT: f64 = 1e-4;

fn reference(k: usize) -> f64 {
    10.0 + 15.0 * (1.0 - (k as f64 * DT * 5.0 * std::f64::consts::TAU).cos())
}

#[divan::bench]
fn model_step(b: Bencher) {
    let mut pea = BoucWen::new(BoucWenParams::PEA1);
    let mut k = 0usize;
    b.bench_local(|| {
        k += 1;
        let u = 500.0 * (1.0 - (k as f64 * 1e-3).cos());
        black_box(pea.step(black_box(u), DT))
    });
}

#[divan::bench(sample_size = 1000)]
fn model_plus_compensation_step(b: Bencher) {
    let mut pea = BoucWen::new(BoucWenParams::PEA1);
    let mut comp =
        InverseCompensator::new(BoucWenParams::PEA1, CompensatorParams::default()).unwrap();
    let xd: Vec<f64> = (0..4096).map(reference).collect();
    let mut k = 0usize;
    b.bench_local(|| {
        k = (k + 1) & 4095;
        let u = comp.step(black_box(xd[k]), DT).u;
        black_box(pea.step(u, DT))
    });
}

#[divan::bench(sample_size = 1000)]
fn parallel_rls_sample(b: Bencher) {
    let data = flexstage_piezo::samples::identification_problem(BoucWenParams::PEA1, 0.0, 1)
        .unwrap()
        .data;
    let mut params = IdentifyParams::default();
    params.initial.d_p = 0.055;
    let mut id = ParallelRls::new(&params).unwrap();
    let n = data.len();
    let mut k = 0usize;
    b.bench_local(|| {
        k += 1;
        if k == n {
            k = 0;
            id.restart();
        }
        black_box(id.update(data.t()[k], data.u()[k], data.x()[k]))
    });
}
