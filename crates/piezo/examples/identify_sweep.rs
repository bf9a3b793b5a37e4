//! Identification over seeds on single-amplitude triangle and sine drives (10 nm noise): the
//! relative error [%] of [d_p, A_bw, B_bw, Γ_bw, δ_bw] of the parallel RLS and the batch fit.
//! `cargo run --release -p flexstage-piezo --example identify_sweep -- [cycles] [frequency]`
use flexstage_piezo::hysteresis::{WaveShape, Waveform};
use flexstage_piezo::identify::{IdentifyParams, fit_batch, identify};
use flexstage_piezo::model::BoucWenParams;
use flexstage_piezo::synth::synthesize;

fn errs(e: &BoucWenParams, t: &BoucWenParams) -> [f64; 5] {
    let r = |a: f64, b: f64| 100.0 * ((a - b) / b).abs();
    [
        r(e.d_p, t.d_p),
        r(e.a_bw, t.a_bw),
        r(e.b_bw, t.b_bw),
        r(e.gamma_bw, t.gamma_bw),
        r(e.delta_bw, t.delta_bw),
    ]
}
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let cycles: u32 = args.get(1).map(|s| s.parse().unwrap()).unwrap_or(10);
    let freq: f64 = args.get(2).map(|s| s.parse().unwrap()).unwrap_or(1.0);
    for (name, truth) in [("PEA1", BoucWenParams::PEA1), ("PEA2", BoucWenParams::PEA2)] {
        for shape in [WaveShape::Triangle, WaveShape::Sine] {
            let w = Waveform {
                shape,
                low: 0.0,
                high: 1000.0,
                frequency: freq,
                cycles,
            };
            for seed in 1..=10u64 {
                let d = synthesize(&truth, &w, 1e-4, 0.010, seed).unwrap();
                let r = identify(&d, &IdentifyParams::default()).unwrap();
                let b = fit_batch(&d).unwrap();
                let er = errs(&r.estimate, &truth);
                let eb = errs(&b.estimate, &truth);
                println!(
                    "{name} {shape:?} {seed}: dp {:.2e} {:.2e} rms {:.4} {:.4} rls {:?} batch {:?}",
                    r.estimate.d_p / truth.d_p - 1.0,
                    b.estimate.d_p / truth.d_p - 1.0,
                    r.rms_error,
                    b.rms_error,
                    er.map(|v| (v * 10.0).round() / 10.0),
                    eb.map(|v| (v * 10.0).round() / 10.0)
                );
            }
        }
    }
}
