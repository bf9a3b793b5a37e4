//! Verifies the hand-made bridge sample and prints the summary.
//! Run: `cargo run --release -p flexstage-verify --example bridge -- [quick|paper]`.
use flexstage_scenario::Preset;
use flexstage_verify::{VerifyParams, samples, verify};

fn main() {
    let preset = std::env::args()
        .nth(1)
        .and_then(|p| Preset::from_name(&p))
        .unwrap_or(Preset::Quick);
    let (s, rho, loops) = samples::bridge_design(preset);
    let t = std::time::Instant::now();
    let v = verify(&s, &rho, &loops, &VerifyParams::default()).unwrap();
    for line in v.summary_lines() {
        println!("{line}");
    }
    println!("({:.2} s)", t.elapsed().as_secs_f64());
}
