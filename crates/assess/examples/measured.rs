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
    // Entry by entry: the measurement against the exact loop with the amplifier (the scoring
    // loop) and without it (the scoring loop before the amplifier joined it).
    let rig = &bench.setup.rig;
    let bare = flexstage_assess::bench::modal_plant(
        &bench.twin,
        rig.sample_time,
        rig.delay,
        &flexstage_sim::rig::AmplifierParams::ideal(),
        &rig.sensor,
    )?;
    let top = m
        .response
        .lines()
        .iter()
        .flat_map(|l| l.h.iter().flatten())
        .map(|v| v.norm())
        .fold(0.0, f64::max);
    for (name, plant) in [("with the amplifier", &truth), ("without it", &bare)] {
        let mut worst = [[(0.0f64, 0.0); 2]; 2];
        for l in m.response.lines() {
            let e = plant.response(l.f);
            for i in 0..2 {
                for j in 0..2 {
                    let d = (l.h[i][j] - e[i][j]).norm() / top;
                    if d > worst[i][j].0 {
                        worst[i][j] = (d, l.f);
                    }
                }
            }
        }
        println!(
            "measured − exact loop {name}, worst |Δ|/{top:.3} (at Hz): 11 {:.2e} ({:.0}), 12 {:.2e} ({:.0}), 21 {:.2e} ({:.0}), 22 {:.2e} ({:.0})",
            worst[0][0].0,
            worst[0][0].1,
            worst[0][1].0,
            worst[0][1].1,
            worst[1][0].0,
            worst[1][0].1,
            worst[1][1].0,
            worst[1][1].1
        );
    }
    println!("response fit: {:?}", bench.identified);
    for c in [
        &flexstage_control::pi_notch::PI_NOTCH_FF,
        &flexstage_control::pid::PID_FF,
    ] {
        if let Some(p) = bench.linear_params(c)? {
            let old = flexstage_control::tuning::loop_margins(&bare, &p, &bench.tuning.margins)?;
            println!(
                "{c} on the exact loop without the amplifier: q1 {:.2} dB / {:.1}°, q2 {:.2} dB / {:.1}°",
                old[0].gain_db, old[0].phase_deg, old[1].gain_db, old[1].phase_deg
            );
        }
    }
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
    // In the rig itself (full nonlinear twin loop, inverse compensation, the scenario's
    // noise): standstill and the slow Lissajous (3:1, 2 Hz base, 1 µm), errors on the truth.
    let slow =
        flexstage_sim::trajectory::Reference::new(flexstage_sim::trajectory::Shape::Lissajous {
            ratio: 3.0,
            amplitude: [1e-6; 2],
            frequency: 2.0,
        });
    let zero = flexstage_sim::trajectory::Reference::new(flexstage_sim::trajectory::Shape::Step {
        target: [0.0; 2],
    });
    println!("in the full rig: standstill steady RMS q1 q2 nm | slow Lissajous RMS, max q1 q2 nm");
    for c in CONTROLLERS.iter() {
        let run = |r| {
            flexstage_assess::track::track_on(
                &bench,
                &bench.setup,
                &bench.twin,
                &bench.setup.rig,
                c,
                r,
                0.5,
            )
        };
        let (Ok(still), Ok(liss)) = (run(zero), run(slow)) else {
            println!("{:<16} not built", c.name);
            continue;
        };
        println!(
            "{:<16} {:.2} {:.2} | {:.2} {:.2}, {:.1} {:.1}{}",
            c.name,
            still.steady_rms[0] * 1e9,
            still.steady_rms[1] * 1e9,
            liss.rms[0] * 1e9,
            liss.rms[1] * 1e9,
            liss.max[0] * 1e9,
            liss.max[1] * 1e9,
            if flexstage_assess::track::diverged(&still) || flexstage_assess::track::diverged(&liss)
            {
                "  DIVERGED"
            } else {
                ""
            }
        );
    }
    println!("in {:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}
