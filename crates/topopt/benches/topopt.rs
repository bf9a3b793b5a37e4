//! One design iteration (FE of all cases, adjoints, MMA, c2 update): the paper preset
//! (120 × 60, p_m = 40, nonlinear) and the linear inverter at 120 × 60.
//! Run: `cargo bench -p flexstage-topopt`.

use divan::Bencher;
use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::{Optimizer, OptimizerParams, Problem, samples};

fn main() {
    divan::main();
}

#[divan::bench(sample_count = 5)]
fn paper_preset_iteration(b: Bencher) {
    let s = Scenario::preset(Preset::Paper);
    let problem = Problem::from_scenario(&s, None).unwrap();
    let mut opt = Optimizer::new(&problem, OptimizerParams::from_scenario(&s)).unwrap();
    opt.step().unwrap();
    b.bench_local(|| opt.step().unwrap());
}

#[divan::bench(sample_count = 20)]
fn linear_inverter_120x60_iteration(b: Bencher) {
    let problem = samples::inverter(120, 60).unwrap();
    let mut opt = Optimizer::new(&problem, samples::inverter_params(100_000)).unwrap();
    opt.step().unwrap();
    b.bench_local(|| opt.step().unwrap());
}
