//! Reference: the same twin in the same rig at twice the time resolution (40 instead of the
//! scenario's 20 substeps per 10 kHz sample). The modes are discretized exactly for an input
//! linear within a substep, so what the substeps resolve is the rig around them (amplifier
//! approach and rate limit, x_nom between the substep nodes, the sensor filter, the
//! stiffening term held per substep); the error of such a scheme falls as h², and halving h
//! must change the output by far less than the sensor resolution.
//! Goal: on a voltage step (rate-limited by the amplifier current), a large step and a 200 Hz
//! sine, the true output at 20 and 40 substeps differs by < 1e-4 of its range (< 5 nm);
//! and a plant is bit-for-bit deterministic for its seed (the pipeline's resume test compares
//! reports bitwise).

// Loops over the two axes index several arrays at once.
#![allow(clippy::needless_range_loop)]

use flexstage_sim::experiment::Command;
use flexstage_sim::rig::{RigParams, StagePlant};
use flexstage_twin::{Twin, samples};

/// Voltages per sample.
type Drive<'a> = &'a dyn Fn(usize) -> [f64; 2];

/// True outputs and measurements of `n` samples with the voltages `v(k)`.
fn run(twin: &Twin, rig: &RigParams, v: Drive, n: usize) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let mut p = twin.plant(rig).unwrap();
    let (mut q, mut y) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for k in 0..n {
        y.push(p.measure());
        p.apply(&Command {
            voltage: v(k),
            ..Command::default()
        });
        q.push(p.output());
    }
    (q, y)
}

#[test]
fn twin_in_the_rig_converges_in_the_substeps() {
    let (s, rho) = samples::quick_rhombus().unwrap();
    let twin = Twin::from_scenario(&s, &rho).unwrap();
    let base = RigParams::from_scenario(&s);
    assert_eq!(base.substeps, 20);
    let mut fine = base.clone();
    fine.substeps = 40;
    let sine = |k: usize| {
        let a = 200.0 * (std::f64::consts::TAU * 200.0 * k as f64 * 1e-4).sin();
        [500.0 + a, 500.0 - a]
    };
    let cases: [(&str, Drive); 3] = [
        ("step 100 V", &|k| {
            if k < 5 { [500.0; 2] } else { [600.0, 550.0] }
        }),
        ("step 500 V", &|k| {
            if k < 5 { [500.0; 2] } else { [1000.0, 250.0] }
        }),
        ("sine 200 Hz", &sine),
    ];
    for (name, v) in cases {
        let (q, _) = run(&twin, &base, v, 2000);
        let (qf, _) = run(&twin, &fine, v, 2000);
        for i in 0..2 {
            let hi = qf.iter().map(|q| q[i]).fold(f64::MIN, f64::max);
            let lo = qf.iter().map(|q| q[i]).fold(f64::MAX, f64::min);
            let err = q
                .iter()
                .zip(&qf)
                .map(|(a, b)| (a[i] - b[i]).abs())
                .fold(0.0, f64::max);
            println!(
                "{name}, axis {i}: |q20 − q40| ≤ {err:.2e} m, {:.1e} of the range {:.2e} m",
                err / (hi - lo),
                hi - lo
            );
            assert!(
                err < 1e-4 * (hi - lo) && err < 5e-9,
                "{name} axis {i}: {err:e}"
            );
        }
    }
}

#[test]
fn twin_in_the_rig_is_deterministic_for_its_seed() {
    let (s, rho) = samples::quick_rhombus().unwrap();
    let twin = Twin::from_scenario(&s, &rho).unwrap();
    let rig = RigParams::from_scenario(&s);
    let v = |k: usize| [500.0 + 100.0 * (k as f64 * 1e-2).sin(), 480.0];
    let (q1, y1) = run(&twin, &rig, &v, 3000);
    let (q2, y2) = run(&twin, &rig, &v, 3000);
    let bits = |x: &[[f64; 2]]| -> Vec<u64> { x.iter().flatten().map(|v| v.to_bits()).collect() };
    assert_eq!(bits(&q1), bits(&q2));
    assert_eq!(bits(&y1), bits(&y2));
    // A different seed draws other noise.
    let mut other = rig.clone();
    other.seed += 1;
    let (_, y3) = run(&twin, &other, &v, 3000);
    assert_ne!(bits(&y1), bits(&y3));
}
