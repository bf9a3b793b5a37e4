//! Iterative learning on the twin of the designed stage (flexstage-control's `learning`):
//! the learning plant T measured at every harmonic of the 3:1 Lissajous period on the twin
//! in its rig, the learning layer designed from it (monotone-convergence factor ρ < 1), then
//! 20 periods of learning on top of the PID + feed-forward baseline; RMS error against the
//! true output per period, beside the baseline without learning.
//!
//! `cargo run --release -p flexstage-twin --example learn -- quick runs/quick/design/design.json [PERIODS]`

use flexstage_control::ControlError;
use flexstage_control::actuator::Compensation;
use flexstage_control::controller::StageControl;
use flexstage_control::experiment::{Variant, run};
use flexstage_control::learning::{
    DesignParams, Learning, design, measure_learning_plant, rms_per_period,
};
use flexstage_control::rig::StagePlant;
use flexstage_control::trajectory::Reference;
use flexstage_scenario::{Preset, Scenario, Trajectory};
use flexstage_topopt::DesignFile;
use flexstage_twin::DesignedStage;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let preset = args
        .get(1)
        .and_then(|p| Preset::from_name(p))
        .ok_or("usage: learn quick|paper DESIGN.json [PERIODS]")?;
    let design_file = DesignFile::from_json(&std::fs::read(args.get(2).ok_or("missing design")?)?)?;
    let periods: usize = args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(20);
    let DesignedStage {
        scenario: s,
        setup,
        twin,
        ..
    } = DesignedStage::new(&Scenario::preset(preset), &design_file.rho)?;
    let trajectory = s
        .trajectories
        .iter()
        .find(|t| matches!(t, Trajectory::Lissajous { ratio, .. } if *ratio == 3.0))
        .ok_or("the scenario has no 3:1 Lissajous")?;
    let (reference, _) = Reference::from_scenario(trajectory);
    let Trajectory::Lissajous { frequency, .. } = trajectory else {
        unreachable!()
    };
    let t = setup.controller.observer.sample_time;
    let period = (1.0 / (frequency * t)).round() as usize;
    let make = || -> flexstage_control::Result<(Box<dyn StageControl>, Box<dyn StagePlant>)> {
        let c = setup.controller(Variant::PidFeedforward, Compensation::Inverse, reference)?;
        let plant = twin
            .plant(&setup.rig)
            .map_err(|e| ControlError::Infeasible {
                what: "twin plant".into(),
                detail: e.to_string(),
            })?;
        let p: Box<dyn StagePlant> = Box::new(plant);
        Ok((c, p))
    };
    let t0 = std::time::Instant::now();
    let plant = measure_learning_plant(&mut || make(), period, 3, 20e-9)?;
    let (learning, rho) = design(&plant, &DesignParams::default())?;
    println!(
        "twin f1 = {:.0} Hz; learning plant measured at {} harmonics of {} Hz in {:.1} s",
        twin.first_resonance(),
        plant.response[0].len(),
        frequency,
        t0.elapsed().as_secs_f64()
    );
    println!(
        "design: gain γ = {}, lead λ = {} samples, Q half-width M = {} (first zero {:.0} Hz); \
         monotone-convergence factor ρ = {rho:.3}",
        learning.gain,
        learning.lead,
        learning.q_half_width,
        1.0 / (t * (learning.q_half_width + 1) as f64)
    );
    let duration = periods as f64 * period as f64 * t;
    let (c, mut p) = make()?;
    let mut with = Learning::new(c, learning)?;
    let rec = run(&mut with, p.as_mut(), duration, t, |_| {});
    let (mut c0, mut p0) = make()?;
    let rec0 = run(c0.as_mut(), p0.as_mut(), duration, t, |_| {});
    println!(
        "period  pid-ff+learning q1/q2 [nm]   pid-ff q1/q2 [nm]   (error against the true output)"
    );
    for (j, (a, b)) in rms_per_period(&rec.error, period)
        .iter()
        .zip(rms_per_period(&rec0.error, period))
        .enumerate()
    {
        println!(
            "{:>6}  {:>12.1}/{:<12.1}  {:>8.1}/{:<8.1}",
            j + 1,
            a[0] * 1e9,
            a[1] * 1e9,
            b[0] * 1e9,
            b[1] * 1e9
        );
    }
    Ok(())
}
