//! Verifies the hand-made bridge sample and prints the summary.
//! Run: `cargo run --release -p flexstage-verify --example bridge -- [quick|paper]`.
use flexstage_scenario::Preset;
use flexstage_verify::{VerifyParams, samples, verify};

fn main() {
    let preset = std::env::args()
        .nth(1)
        .and_then(|p| Preset::from_name(&p))
        .unwrap_or(Preset::Quick);
    let fine = std::env::args().nth(2).is_some_and(|a| a == "fine");
    let mut s = flexstage_scenario::Scenario::preset(preset);
    if fine {
        s.mesh.nl *= 2;
        s.mesh.nw *= 2;
    }
    let (s, rho, loops) = samples::bridge_on(s, 0.05);
    let t = std::time::Instant::now();
    let v = verify(&s, &rho, &loops, &VerifyParams::default()).unwrap();
    for line in v.summary_lines() {
        println!("{line}");
    }
    println!("({:.2} s)", t.elapsed().as_secs_f64());
}
