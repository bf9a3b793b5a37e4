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

/// The frequency-response identification of a 16 s record at 50 kHz (the twin's default
/// experiment: 80 periods of the two-band multisine, 615 lines, both outputs).
#[divan::bench(sample_count = 10)]
fn response_16s(bencher: divan::Bencher) {
    use flexstage_identify::response::{ResponseParams, identify_response, response_excitation};
    use flexstage_identify::{Excitation, Multisine, StageRecord};
    use flexstage_sim::rig::SensorParams;
    let ts = 2e-5;
    let e = response_excitation(&Excitation::default(), 5000.0);
    let ms = Multisine::new(&e).unwrap();
    let n = (1.0 / (e.f_min * ts)).round() as usize;
    let period: Vec<[f64; 2]> = (0..n).map(|m| ms.value(m as f64 * ts)).collect();
    let len = 80 * n + 1;
    let x: [Vec<f64>; 2] = [0, 1].map(|i| (0..len).map(|m| period[m % n][i]).collect());
    let q = [
        x[0].iter().zip(&x[1]).map(|(a, b)| 0.5 * (a + b)).collect(),
        x[0].iter().zip(&x[1]).map(|(a, b)| 2.0 * (a - b)).collect(),
    ];
    let t = (0..len).map(|m| m as f64 * ts).collect();
    let zeros = [vec![0.0; len], vec![0.0; len]];
    let record = StageRecord::new(t, x, zeros, q, None, 1e-6).unwrap();
    let p = ResponseParams::new(1e-4, SensorParams::ideal());
    bencher.bench_local(|| identify_response(divan::black_box(&record), &e, &p).unwrap());
}

/// The output at the samples from one period of a fast ADC's record (both axes): the 2 Hz
/// Lissajous' period at 10 kHz with L = 10 (N L = 50 000 points), what `track --learning`
/// does after every trial of a slow scan.
#[divan::bench(sample_count = 20)]
fn fast_period_output(bencher: divan::Bencher) {
    use flexstage_identify::measured::{FastAdc, FastChannel};
    use flexstage_sim::plant::{LumpedStage, PlantParams};
    use flexstage_sim::rig::{RigPlant, StagePlant};
    let params = PlantParams::from_scenario(&flexstage_scenario::Scenario::paper());
    let mut rig = params.rig();
    rig.sensor.bandwidth = 15e3;
    let mech = LumpedStage::new(&params.truth, params.coupling, rig.substep()).unwrap();
    let mut plant = RigPlant::new(rig.clone(), mech).unwrap();
    let adc = FastAdc {
        ratio: 10,
        noise_std: [1e-8; 2],
        seed: 1,
    };
    let mut channel = FastChannel::attach(&adc, &mut plant).unwrap();
    let n = 5000;
    for k in 0..n {
        let w = std::f64::consts::TAU * k as f64 / n as f64;
        plant.apply(&flexstage_sim::experiment::Command {
            voltage: [50.0 + 20.0 * (3.0 * w).sin(), 50.0 + 20.0 * w.cos()],
            ..Default::default()
        });
        channel.record(&plant);
    }
    let period = channel.take_period(n, rig.sample_time).unwrap();
    bencher.bench_local(|| divan::black_box(&period).output_at_samples(&rig.sensor));
}
