//! The controllers on the twin of a design: margins (loop-at-a-time, one sample of delay),
//! the tuned baselines, Monte-Carlo robustness and error against scan frequency. The
//! controllers' model is the design's reduced lumped model (`flexstage reduce`), as in
//! `flexstage-twin`'s `track` example.
//!
//! ```text
//! cargo run --release -p flexstage-assess --example assess -- quick runs/quick/design/design.json [SENSOR_HZ] [ANTI_ALIAS_HZ]
//! ```
//!
//! `SENSOR_HZ` replaces the rig's sensor bandwidth (its first-order low-pass) and
//! `ANTI_ALIAS_HZ` the corner of the ADC's anti-aliasing filter (2nd-order Butterworth,
//! 0 = none); every controller is tuned with them in the loop.

use flexstage_assess::{AssessParams, Assessment, Bench};
use flexstage_control::experiment::Setup;
use flexstage_run::Format;
use flexstage_run::files::design::DesignFile;
use flexstage_scenario::{Preset, Scenario};
use flexstage_twin::DesignedStage;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let preset = args
        .get(1)
        .and_then(|p| Preset::from_name(p))
        .ok_or("usage: assess quick|paper DESIGN.json [SENSOR_HZ] [ANTI_ALIAS_HZ]")?;
    let design = DesignFile::decode(&std::fs::read(args.get(2).ok_or("missing design")?)?)?;
    let DesignedStage {
        scenario: s, twin, ..
    } = DesignedStage::new(&Scenario::preset(preset), &design.rho)?;
    let mut setup = Setup::from_scenario(&s);
    if let Some(bw) = args.get(3) {
        setup.rig.sensor.bandwidth = bw.parse()?;
    }
    if let Some(aa) = args.get(4) {
        setup.rig.sensor.anti_alias = aa.parse()?;
    }
    let t0 = std::time::Instant::now();
    let bench = Bench::new(setup, twin, Default::default())?;
    let a = Assessment::run(&bench, &s, &AssessParams::default())?;
    print!("{}", a.summary());
    println!("assessed in {:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}
