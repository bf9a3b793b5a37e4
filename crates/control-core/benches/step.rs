//! Controller step cost: the PID + feed-forward law alone and with the learning layer
//! (period 5000 samples, the 3:1 Lissajous at 2 Hz and 10 kHz; Q half-width 8).
//! `cargo bench -p flexstage-control-core`

use flexstage_control_core::{Controller, Ilc, IlcBuffers, IlcParams, PidGains, PidLaw};

fn main() {
    divan::main();
}

const N: usize = 5000;

fn law() -> PidLaw {
    let gains = PidGains {
        kp: 0.0,
        ki: 1500.0,
        kd: 2e-5,
    };
    PidLaw::new([gains; 2], [[1.1, 0.05], [0.04, 1.2]], 1e-4, 2e-5).unwrap()
}

fn reference(k: usize) -> [f64; 2] {
    let t = k as f64 * 1e-4;
    let w = core::f64::consts::TAU * 2.0 * t;
    [8e-6 * (3.0 * w).sin(), 16e-6 * w.sin()]
}

#[divan::bench]
fn pid_step(bencher: divan::Bencher) {
    let mut c: Controller<Vec<[f64; 2]>> = Controller {
        law: law(),
        learning: None,
    };
    let refs: Vec<[f64; 2]> = (0..N).map(reference).collect();
    let mut k = 0;
    bencher.bench_local(|| {
        k = (k + 1) % N;
        let r = refs[k];
        c.step(divan::black_box([r[0] * 0.99, r[1] * 0.99]), r)
    });
}

#[divan::bench(args = [0, 8, 32])]
fn pid_with_learning_step(bencher: divan::Bencher, q_half_width: usize) {
    let params = IlcParams {
        period: N,
        gain: 0.5,
        lead: 3,
        q_half_width,
    };
    let buffers = IlcBuffers {
        learned: vec![[0.0; 2]; N],
        applied: vec![[0.0; 2]; N],
        error: vec![[0.0; 2]; N],
        error_now: vec![[0.0; 2]; N],
    };
    let mut c = Controller {
        law: law(),
        learning: Some(Ilc::new(params, buffers).unwrap()),
    };
    let refs: Vec<[f64; 2]> = (0..N).map(reference).collect();
    // Past the first period, so the learning filter runs.
    for k in 0..N + 1 {
        c.step(refs[k % N], refs[k % N]);
    }
    let mut k = 0;
    bencher.bench_local(|| {
        k = (k + 1) % N;
        let r = refs[k];
        c.step(divan::black_box([r[0] * 0.99, r[1] * 0.99]), r)
    });
}
