//! Which part of the twin limits its reach, by measurement (docs/DECISIONS.md, the twin's
//! reach): one validity case against the full nonlinear transient with one setting changed
//! (`modes=` fixed-interface modes, `dt=` the reference's step, `amp=` the step's size, so
//! that the nonlinearity vanishes, `zeta=` the damping, `nl=0` the linear twin, `rise=`,
//! `coverage=`, `dur=`), the twin's modes against the FE modal analysis up to its reach
//! (`modes`), or the cost of one simulated second of the twin in the rig (`speed`).
//!
//! ```text
//! cargo run --release -p flexstage-twin --example reach -- RUN/design/design.json fast modes=24
//! cargo run --release -p flexstage-twin --example reach -- RUN/design/design.json modes coverage=5
//! ```
use flexstage_run::Format;
use flexstage_run::files::design::DesignFile;
use flexstage_scenario::{Preset, Scenario};
use flexstage_twin::reference::{agreement, full_response, twin_response};
use flexstage_twin::{ReferenceParams, Twin, TwinParams, ValidationParams};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: reach DESIGN.json fast|step|sine|modes|speed [key=value ...]";
    let design = DesignFile::decode(&std::fs::read(args.get(1).ok_or(usage)?)?)?;
    let variant = args.get(2).ok_or(usage)?.as_str();
    let mut scenario = Scenario::preset(Preset::Quick);
    let mut p = ValidationParams::default();
    let mut tp = TwinParams::from_scenario(&scenario);
    let mut twin_dt = None;
    for kv in args[3..].iter() {
        let (k, v) = kv.split_once('=').ok_or(usage)?;
        let x: f64 = v.parse()?;
        match k {
            "modes" => tp.min_modes = x as usize,
            "coverage" => tp.coverage = x,
            "dt" => p.reference.dt = x,
            "amp" => p.amplitude = x,
            "zeta" => tp.damping_ratio = x,
            "rise" => p.fast_rise = x,
            "nl" => tp.nonlinear = x > 0.0,
            "twin_dt" => twin_dt = Some(x),
            "dur" => p.duration = x,
            _ => return Err(format!("unknown setting {k}: {usage}").into()),
        }
    }
    scenario.twin.damping_ratio = tp.damping_ratio;
    let t0 = std::time::Instant::now();
    let fe = flexstage_twin::StageFe::from_scenario(&scenario, &design.rho)?;
    let twin = Twin::build(fe, &tp)?;
    let build = t0.elapsed().as_secs_f64();
    if variant == "speed" {
        let mut plant = twin.plant(&flexstage_sim::rig::RigParams::from_scenario(&scenario))?;
        use flexstage_sim::rig::StagePlant;
        let step = flexstage_sim::experiment::Command {
            voltage: [600.0, 500.0],
            ..Default::default()
        };
        let mut best = f64::INFINITY;
        for _ in 0..5 {
            let t0 = std::time::Instant::now();
            for _ in 0..10_000 {
                let _ = plant.measure();
                plant.apply(&step);
            }
            best = best.min(t0.elapsed().as_secs_f64());
        }
        println!(
            "modes {}: one simulated second in the rig {:.1} ms (best of 5)",
            twin.modal.modes.len(),
            1e3 * best
        );
        return Ok(());
    }
    if variant == "modes" {
        for m in flexstage_twin::reference::mode_check(&twin)? {
            println!(
                "mode {} twin {:.1} fe {:.1} rel {:+.5} %",
                m.index,
                m.twin,
                m.fe,
                100.0 * m.relative
            );
        }
        return Ok(());
    }
    let input: Box<dyn Fn(f64) -> [f64; 2] + Sync> = match variant {
        "fast" => Box::new(p.step(p.fast_rise)),
        "step" => Box::new(p.step(p.rise)),
        _ => Box::new(p.sine()),
    };
    let rp: ReferenceParams = p.reference;
    let (full, cost) = full_response(&twin, &*input, p.duration, &rp)?;
    let dt = twin_dt.unwrap_or(rp.dt);
    let tw = twin_response(&twin, &*input, p.duration, dt, tp.nonlinear);
    let step = (dt / rp.dt).round() as usize;
    let mut f2 = full.clone();
    if step > 1 {
        for i in 0..2 {
            f2.q[i] = full.q[i].iter().step_by(step).copied().collect();
        }
    }
    let a = agreement(&f2, &tw);
    let r = a.relative();
    println!(
        "{variant} {:?}: modes {} (top {:.0} Hz), build {build:.2} s, err {:.3} / {:.3} % (ref {:.1} s)",
        &args[3..],
        twin.modal.modes.len(),
        twin.modal.modes.last().unwrap().frequency,
        100.0 * r[0],
        100.0 * r[1],
        cost.seconds
    );
    // When the largest error on q1 occurs (ringing that dephases peaks late).
    let mut worst = (0, 0.0);
    for (k, (x, y)) in f2.q[0].iter().zip(&tw.q[0]).enumerate() {
        if (x - y).abs() > worst.1 {
            worst = (k, (x - y).abs());
        }
    }
    println!("  q1 worst at t = {:.1} µs", worst.0 as f64 * dt * 1e6);
    Ok(())
}
