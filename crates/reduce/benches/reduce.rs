//! Benchmarks at the paper's 120 × 60 mesh: the static condensation (assembly, one Cholesky
//! of K_Tff, four solves) and the modal analysis (6 modes, shift-invert Lanczos).
//! Run: `cargo bench -p flexstage-reduce --bench reduce`.

use flexstage_fem::Design;
use flexstage_reduce::{Condenser, ModalParams, Ports, modal_analysis, samples};
use flexstage_scenario::Preset;

fn main() {
    divan::main();
}

#[divan::bench(sample_count = 20)]
fn condensation_120x60(bencher: divan::Bencher) {
    let (_s, problem) = samples::stage(Preset::Paper).unwrap();
    let rho = samples::random_design(&problem, 1e-3, 1.0, 1);
    let ports = Ports::from_problem(&problem).unwrap();
    let mut c = Condenser::new(&problem.model, ports).unwrap();
    bencher.bench_local(|| {
        c.condense(&problem.model, &Design::new(&rho), None)
            .unwrap()
    });
}

#[divan::bench(sample_count = 10)]
fn modal_6_modes_120x60(bencher: divan::Bencher) {
    let (s, problem) = samples::stage(Preset::Paper).unwrap();
    let rho = samples::random_design(&problem, 1e-3, 1.0, 1);
    let params = ModalParams::default();
    bencher.bench_local(|| {
        modal_analysis(&problem.model, &rho, s.material.density, &[], &params).unwrap()
    });
}
