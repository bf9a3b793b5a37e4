//! One design iteration (FE of every realization and case, adjoints, MMA): the paper preset
//! (120 × 60, p_m = 40, nonlinear, robust: eroded / blueprint / dilated, fatigue stress), the
//! `fine` preset (240 × 120) and the `quick` preset, after a few warm-up iterations; and the
//! linear inverter at 120 × 60. Allocations are counted (divan's allocation profiler).
//! Run: `cargo bench -p flexstage-topopt`. Peak memory of whole runs: `/usr/bin/time -v`
//! (docs/performance.md).

use divan::Bencher;
use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::{Optimizer, OptimizerParams, Problem, samples};

#[global_allocator]
static ALLOC: divan::AllocProfiler = divan::AllocProfiler::system();

fn main() {
    divan::main();
}

/// Iterations of a preset after `warmup` iterations (the first ones move the design most).
fn preset_iteration(b: Bencher, preset: Preset, warmup: usize) {
    let s = Scenario::preset(preset);
    let problem = Problem::from_scenario(&s, None).unwrap();
    let mut opt = Optimizer::new(&problem, OptimizerParams::from_scenario(&s)).unwrap();
    for _ in 0..warmup {
        opt.step().unwrap();
    }
    b.bench_local(|| opt.step().unwrap());
}

#[divan::bench(sample_count = 5)]
fn paper_preset_iteration(b: Bencher) {
    preset_iteration(b, Preset::Paper, 3);
}

#[divan::bench(sample_count = 3)]
fn fine_preset_iteration(b: Bencher) {
    preset_iteration(b, Preset::Fine, 2);
}

#[divan::bench(sample_count = 10)]
fn quick_preset_iteration(b: Bencher) {
    preset_iteration(b, Preset::Quick, 3);
}

#[divan::bench(sample_count = 20)]
fn linear_inverter_120x60_iteration(b: Bencher) {
    let problem = samples::inverter(120, 60).unwrap();
    let mut opt = Optimizer::new(&problem, samples::inverter_params(100_000)).unwrap();
    opt.step().unwrap();
    b.bench_local(|| opt.step().unwrap());
}
