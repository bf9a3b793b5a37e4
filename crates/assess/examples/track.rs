//! The existing controllers on three plants, for one design: the finite-element twin in the
//! scenario's rig, the lumped 8-state model in the same rig, and the lumped model in the ideal
//! loop (what `flexstage track` simulates today). The controller's model is the design's
//! reduced lumped model (`flexstage reduce`), i.e. a perfect identification of the lumped
//! parameters. Then, for the 3:1 Lissajous, the twin with one rig effect at a time (the others
//! off) shows which effect the controllers are sensitive to.
//!
//! ```text
//! cargo run --release -p flexstage-assess --example track -- quick runs/quick/design/design.json
//! ```
//!
//! Prints one row per plant, trajectory and controller: RMS and maximum error per axis in nm
//! and in % of the range, the peak voltage, saturated samples and whether the run diverged.

use flexstage_control::actuator::Compensation;
use flexstage_control::controller::ROBUST;
use flexstage_control::experiment::{Setup, experiment, experiment_on};
use flexstage_control::pid::PID_FF;
use flexstage_control::registry::Controller;
use flexstage_run::Format;
use flexstage_run::files::design::DesignFile;
use flexstage_scenario::{Preset, Scenario};
use flexstage_sim::rig::StagePlant;
use flexstage_sim::trajectory::Reference;
use flexstage_twin::{DesignedStage, Twin};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let preset = args
        .get(1)
        .and_then(|p| Preset::from_name(p))
        .ok_or("usage: track quick|paper DESIGN.json [SECONDS]")?;
    let design = DesignFile::decode(&std::fs::read(args.get(2).ok_or("missing design")?)?)?;
    let seconds: Option<f64> = args.get(3).map(|s| s.parse()).transpose()?;
    let t0 = std::time::Instant::now();
    let DesignedStage {
        scenario: s, twin, ..
    } = DesignedStage::new(&Scenario::preset(preset), &design.rho)?;
    let setup = Setup::from_scenario(&s);
    println!(
        "twin: {} modes (f1 = {:.0} Hz), reduced and built in {:.1} s; lumped model f = {:?} Hz",
        twin.modal.modes.len(),
        twin.first_resonance(),
        t0.elapsed().as_secs_f64(),
        flexstage_sim::model::StageModel::with_coupling(&setup.plant.truth, setup.plant.coupling)?
            .natural_frequencies()
            .map(|f| f.round())
    );
    let lumped =
        flexstage_sim::model::StageModel::with_coupling(&setup.plant.truth, setup.plant.coupling)?
            .dc_gain()?;
    println!(
        "static gain x_nom → q: twin {:?}, lumped [[{:.4}, {:.4}], [{:.4}, {:.4}]]",
        twin.dc_gain().map(|r| r.map(|x| (x * 1e4).round() / 1e4)),
        lumped[(0, 0)],
        lumped[(0, 1)],
        lumped[(1, 0)],
        lumped[(1, 1)]
    );
    println!(
        "{:<7} {:<13} {:<10} {:>21} {:>17} {:>21} {:>8} {:>5} note",
        "plant",
        "trajectory",
        "variant",
        "RMS q1/q2 [nm]",
        "RMS [% range]",
        "max q1/q2 [nm]",
        "peak V",
        "sat",
    );
    for t in &s.trajectories {
        let (reference, duration) = Reference::from_scenario(t);
        let duration = seconds.unwrap_or(duration);
        let half = reference.half_range(duration, s.simulation.sample_time);
        match setup.check_reference(&reference, duration, Some(twin.dc_gain())) {
            Ok(f) => println!(
                "{}: needs {:.0} % of the deliverable stroke, {:.0}–{:.0} V, {:.1} mA",
                t.name(),
                100.0 * f.stroke_usage,
                f.voltage[0][0].min(f.voltage[1][0]),
                f.voltage[0][1].max(f.voltage[1][1]),
                1e3 * f.peak_current
            ),
            Err(e) => println!("{}: refused: {e}", t.name()),
        }
        // The controllers set up from the scenario alone (the PI + notch is tuned on the
        // twin's response by `flexstage-assess`, so it is not among them).
        for (variant, design) in Controller::defaults()
            .into_iter()
            .filter_map(|c| Some((c, setup.design(c).ok()?)))
        {
            for plant in ["twin", "lumped", "ideal"] {
                let rec = if plant == "ideal" {
                    experiment(&setup, variant, Compensation::Inverse, reference, duration)?
                } else {
                    let mut p: Box<dyn StagePlant> = if plant == "twin" {
                        Box::new(twin.plant(&setup.rig)?)
                    } else {
                        Box::new(setup.lumped_plant()?)
                    };
                    let c = Compensation::Inverse;
                    let d = &*design;
                    experiment_on(&setup, d, c, reference, duration, p.as_mut(), |_| {})?
                };
                let m = rec.metrics(half);
                let diverged = !m.rms[0].is_finite() || m.max[0] > 1e-4 || m.max[1] > 1e-4;
                println!(
                    "{:<7} {:<13} {:<10} {:>10.1}/{:<10.1} {:>8.3}/{:<8.3} {:>10.1}/{:<10.1} {:>8.0} {:>5} {}",
                    plant,
                    t.name(),
                    variant.name,
                    m.rms[0] * 1e9,
                    m.rms[1] * 1e9,
                    m.rms_pct[0],
                    m.rms_pct[1],
                    m.max[0] * 1e9,
                    m.max[1] * 1e9,
                    m.peak_voltage,
                    m.saturated,
                    if diverged { "UNSTABLE" } else { "" }
                );
            }
        }
    }
    ablation(&s, &setup, &twin, seconds)?;
    Ok(())
}

/// The twin with one rig effect at a time.
fn ablation(
    s: &Scenario,
    setup: &Setup,
    twin: &Twin,
    seconds: Option<f64>,
) -> Result<(), Box<dyn std::error::Error>> {
    let (reference, duration) = Reference::from_scenario(&s.trajectories[0]);
    let duration = seconds.unwrap_or(duration);
    let half = reference.half_range(duration, s.simulation.sample_time);
    let ideal = {
        let mut q = s.clone();
        q.rig = flexstage_scenario::Rig::ideal(&s.hysteresis);
        flexstage_sim::rig::RigParams::from_scenario(&q)
    };
    let full = setup.rig.clone();
    let mut cases: Vec<(&str, flexstage_sim::rig::RigParams)> = vec![("none", ideal.clone())];
    let mut one = |name: &'static str, f: &dyn Fn(&mut flexstage_sim::rig::RigParams)| {
        let mut r = ideal.clone();
        f(&mut r);
        cases.push((name, r));
    };
    one("delay", &|r| r.delay = full.delay);
    one("amplifier", &|r| r.amplifier = full.amplifier);
    one("PEA truth", &|r| r.hysteresis = full.hysteresis);
    one("creep", &|r| r.creep = full.creep);
    one("sensor", &|r| r.sensor = full.sensor);
    one("floor", &|r| r.floor = full.floor);
    cases.push(("all", full.clone()));
    println!(
        "\nthe twin with one rig effect at a time ({}):",
        s.trajectories[0].name()
    );
    for (name, rig) in cases {
        for variant in [&ROBUST, &PID_FF] {
            let mut p = twin.plant(&rig)?;
            let rec = experiment_on(
                setup,
                &*setup.design(variant)?,
                Compensation::Inverse,
                reference,
                duration,
                &mut p as &mut dyn StagePlant,
                |_| {},
            )?;
            let m = rec.metrics(half);
            println!(
                "  {:<10} {:<10} RMS {:>9.1}/{:<9.1} nm  max {:>9.1}/{:<9.1} nm",
                name,
                variant.name,
                m.rms[0] * 1e9,
                m.rms[1] * 1e9,
                m.max[0] * 1e9,
                m.max[1] * 1e9
            );
        }
    }
    Ok(())
}
