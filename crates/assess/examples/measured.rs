//! The controllers designed from a lab measurement of the twin, scored on its truth: the
//! twin of a design measured by the periodic multisine through its full rig at the
//! controller's sample time (with the scenario's noise), the response fitted by a z-domain
//! loop model, every controller designed from that alone (`Bench::measured`), and each
//! one's loop-at-a-time margins on the twin's exact sampled loop with one sample of delay
//! (`margins_table`: transfer function for the linear ones, sine injection for the others).
//!
//! ```text
//! cargo run --release -p flexstage-assess --example measured -- quick runs/quick/design/design.json [noisy|quiet|linear] [SETTLE_PERIODS [PEAK_M]]
//! ```
//!
//! `quiet` measures without the rig's noise, `linear` in the twin's linear loop (ideal
//! amplifier, no PEA, no noise: the loop the margins are scored on), both references;
//! `SETTLE_PERIODS` replaces the 2 periods played before the measured ones (at 10 kHz),
//! `PEAK_M` the multisine's 0.1 µm peak.

use flexstage_assess::Bench;
use flexstage_assess::inject::InjectionParams;
use flexstage_assess::lab::LabParams;
use flexstage_assess::margins::{MarginTargets, margins_table};
use flexstage_control::experiment::Setup;
use flexstage_control::registry::CONTROLLERS;
use flexstage_run::Format;
use flexstage_run::files::design::DesignFile;
use flexstage_scenario::{Preset, Scenario};
use flexstage_sim::modal::LoopPlant;
use flexstage_twin::DesignedStage;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let preset = args.get(1).and_then(|p| Preset::from_name(p)).ok_or(
        "usage: measured quick|paper DESIGN.json [noisy|quiet|linear] [SETTLE_PERIODS [PEAK_M]]",
    )?;
    let design = DesignFile::decode(&std::fs::read(args.get(2).ok_or("missing design")?)?)?;
    let DesignedStage {
        scenario: s, twin, ..
    } = DesignedStage::new(&Scenario::preset(preset), &design.rho)?;
    let mode = args.get(3).map_or("noisy", String::as_str);
    let mut lab = LabParams {
        noise: mode == "noisy",
        ..LabParams::default()
    };
    if let Some(settle) = args.get(4) {
        let mut plan = flexstage_identify::measured::MultisinePlan::new(1e-4);
        plan.settle = settle.parse()?;
        if let Some(a) = args.get(5) {
            plan.amplitude = a.parse()?;
        }
        lab.plan = Some(plan);
    }
    let mut setup = Setup::from_scenario(&s);
    if mode == "linear" {
        // The twin's linear loop as the rig (what the margins are scored on).
        setup.rig = flexstage_assess::bench::LinearLoop {
            twin: &twin,
            setup: &setup,
        }
        .linear_rig(setup.rig.delay);
    }
    let t0 = std::time::Instant::now();
    let (bench, m) = Bench::measured(setup, twin, Default::default(), &lab)?;
    let worst_coh = m
        .response
        .lines()
        .iter()
        .map(|l| l.coherence[0][0].min(l.coherence[1][1]))
        .fold(1.0, f64::min);
    println!(
        "measured {} lines (noise {}), least diagonal coherence {worst_coh:.4}; loop model order {}, delay {}, χ²/dof {:.2}, worst {:.1}σ",
        m.response.lines().len(),
        lab.noise,
        m.model.order(),
        m.model.delay(),
        m.model.reduced_chi2(),
        m.model.worst_deviation(&m.response, lab.fit.floor)
    );
    println!("loop model modes [Hz, ζ]: {:.3?}", m.model.modes());
    let truth = flexstage_assess::bench::modal_plant(
        &bench.twin,
        bench.setup.rig.sample_time,
        bench.setup.rig.delay,
        &bench.setup.rig.amplifier,
        &bench.setup.rig.sensor,
    )?;
    println!("f Hz | measured H11 H22 (std) | loop model | exact linear loop (score only)");
    for l in m.response.lines().iter().step_by(40) {
        let (z, t) = (m.model.response(l.f), truth.response(l.f));
        println!(
            "{:>7.1} | {:.3} {:.3} ({:.1e} {:.1e}) | {:.3} {:.3} | {:.3} {:.3}",
            l.f, l.h[0][0], l.h[1][1], l.std[0][0], l.std[1][1], z[0][0], z[1][1], t[0][0], t[1][1]
        );
    }
    println!("response fit: {:?}", bench.identified);
    let rows = margins_table(
        &bench,
        &CONTROLLERS,
        1,
        MarginTargets::default(),
        &InjectionParams::default(),
    )?;
    let ts = bench.setup.rig.sample_time;
    println!(
        "margins on the twin's exact loop, 1 sample of delay (q1 | q2: GM dB, PM °, crossover Hz, delay margin samples)"
    );
    for r in rows {
        println!(
            "{:<16} {} | {}  {}",
            r.candidate.name,
            r.loop_columns(0, ts),
            r.loop_columns(1, ts),
            if r.meets {
                "meets 6 dB / 40°"
            } else {
                "MISSES"
            }
        );
    }
    println!("in {:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}
