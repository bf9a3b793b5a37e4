//! Cost of the twin. Target: the twin with ≥ 6 modes runs ≥ 20× faster than real
//! time at 10 kHz on one core (≤ 50 ms per simulated second, rig included), allocation-free per
//! step (`tests/allocation.rs`): `twin_plant_one_second` (the twin in the scenario's rig),
//! beside it `twin_mechanics_one_second` (the twin's modes alone, as the rig drives them) and
//! `lumped_plant_one_second` (the lumped 8-state model in the same rig). Reported without a
//! target: building the twin and one step of the full nonlinear transient reference.
//!
//! Where one simulated second goes (instruction counts, `valgrind --tool=callgrind`, quick
//! twin with 16 modes, 20 substeps): the modes ≈ 70 % (≈ 350 instructions per substep for
//! 16 modes, output and nonlinear correction included), the amplifier, Bouc–Wen and creep
//! ≈ 20 %, the substep loop with the sensor filter ≈ 8 %, noise and quantization ≈ 3 %.
//!
//! Designs: the rhombus amplifier (`samples::rhombus`) on the quick (48 × 24) and the paper
//! (120 × 60) meshes. Run: `cargo bench -p flexstage-twin`.

use divan::{Bencher, black_box};
use flexstage_fem::{Transient, TransientParams};
use flexstage_scenario::{Preset, Scenario};
use flexstage_sim::experiment::Command;
use flexstage_sim::plant::PlantParams;
use flexstage_sim::rig::{Mechanics, RigParams, StagePlant};
use flexstage_twin::{StageFe, Twin, TwinParams, samples};

fn main() {
    divan::main();
}

fn scenario(preset: Preset) -> (Scenario, Vec<f64>) {
    let s = Scenario::preset(preset);
    let problem = flexstage_reduce::reduction_problem(&s, false).unwrap();
    let dx = problem.mesh().dx();
    let rho = samples::rhombus(&problem, 3.0 * dx);
    (s, rho)
}

fn twin(preset: Preset) -> (Scenario, Twin) {
    let (s, rho) = scenario(preset);
    let t = Twin::from_scenario(&s, &rho).unwrap();
    (s, t)
}

/// Voltages of a 3:1 Lissajous-like drive around the bias, one per sample.
fn drive(n: usize) -> Vec<Command> {
    (0..n)
        .map(|k| {
            let t = k as f64 * 1e-4;
            let a = 200.0 * (std::f64::consts::TAU * 6.0 * t).sin();
            let b = 200.0 * (std::f64::consts::TAU * 2.0 * t).sin();
            Command {
                voltage: [500.0 + a + b, 500.0 + a - b],
                ..Command::default()
            }
        })
        .collect()
}

/// One simulated second (10 000 samples: measure + apply) of the twin in the scenario's
/// realistic rig.
#[divan::bench(args = [Preset::Quick, Preset::Paper], sample_count = 10)]
fn twin_plant_one_second(b: Bencher, preset: Preset) {
    let (s, t) = twin(preset);
    let rig = RigParams::from_scenario(&s);
    let cmds = drive(10_000);
    println!("{preset:?}: {} modes", t.modal.modes.len());
    b.with_inputs(|| t.plant(&rig).unwrap())
        .bench_local_values(|mut p| {
            for c in &cmds {
                black_box(p.measure());
                p.apply(c);
            }
            black_box(p.output())
        });
}

/// The twin's mechanics alone, without the rig, driven as the rig drives it: one simulated
/// second of `TwinStage::advance_sample` (10 000 samples of the scenario's 20 substeps, the
/// output after every substep for the sensor filter), x_nom a 3:1 Lissajous of ±10 µm,
/// linear within each sample, a floor acceleration of 1 mm/s².
#[divan::bench(args = [Preset::Quick, Preset::Paper], sample_count = 10)]
fn twin_mechanics_one_second(b: Bencher, preset: Preset) {
    let (s, t) = twin(preset);
    let rig = RigParams::from_scenario(&s);
    let (n, h) = (rig.substeps, rig.substep());
    let x: Vec<[f64; 2]> = (0..=10_000)
        .map(|k| {
            let t = k as f64 * 1e-4;
            let a = 5e-6 * (std::f64::consts::TAU * 6.0 * t).sin();
            let b = 5e-6 * (std::f64::consts::TAU * 2.0 * t).sin();
            [a + b, a - b]
        })
        .collect();
    let mut path = vec![[0.0; 2]; n + 1];
    let mut q = vec![[0.0; 2]; n];
    b.with_inputs(|| t.stage(h)).bench_local_values(|mut m| {
        for w in x.windows(2) {
            for (j, p) in path.iter_mut().enumerate() {
                let s = j as f64 / n as f64;
                *p = [
                    w[0][0] + s * (w[1][0] - w[0][0]),
                    w[0][1] + s * (w[1][1] - w[0][1]),
                ];
            }
            m.advance_sample(&path, [[1e-3, 0.0], [1e-3, 0.0]], Some(&mut q));
            black_box(&q);
        }
        black_box(m.output())
    });
}

/// The same second on the lumped 8-state plant in the same rig.
#[divan::bench(sample_count = 10)]
fn lumped_plant_one_second(b: Bencher) {
    let s = Scenario::paper();
    let (plant, rig) = (PlantParams::from_scenario(&s), RigParams::from_scenario(&s));
    let cmds = drive(10_000);
    b.with_inputs(|| plant.in_rig(rig.clone()).unwrap())
        .bench_local_values(|mut p| {
            for c in &cmds {
                black_box(p.measure());
                p.apply(c);
            }
            black_box(p.output())
        });
}

/// Building the twin (Craig–Bampton, modal form, 24 nonlinear static solves).
#[divan::bench(args = [Preset::Quick, Preset::Paper], sample_count = 3)]
fn build(b: Bencher, preset: Preset) {
    let (s, rho) = scenario(preset);
    b.bench_local(|| {
        let fe = StageFe::from_scenario(&s, &rho).unwrap();
        black_box(Twin::build(fe, &TwinParams::from_scenario(&s)).unwrap())
    });
}

/// One step (Δt = 2 µs) of the full nonlinear transient reference under a 24 µm PEA load.
#[divan::bench(args = [Preset::Quick, Preset::Paper], sample_count = 20)]
fn full_transient_step(b: Bencher, preset: Preset) {
    let (_, t) = twin(preset);
    let fe = &t.fe;
    let mut tr = Transient::new(
        &fe.model,
        fe.design(),
        fe.mass_matrix().unwrap(),
        t.modal.damping,
        TransientParams {
            dt: 2e-6,
            ..TransientParams::default()
        },
    )
    .unwrap();
    let mut k = 0usize;
    let mut p = fe.model.zero_vector();
    b.bench_local(|| {
        k += 1;
        let w = (k as f64 / 200.0).min(1.0);
        fe.pea_load_into([24e-6 * w, -12e-6 * w], &mut p);
        tr.step(&p).unwrap();
    });
}
