//! What each part of the backstepping controller buys: on the lumped
//! plant of a scenario inside the scenario's rig (delay, amplifier, the plant's own PEAs,
//! noise; the controller predicts over the delay), the default Lissajous run with
//!
//! * the non-robust law with the disturbance observer (the measured disturbance bound is
//!   read from its estimate d̂ = Δ̂_η over the run, after the first tenth);
//! * the robust law with the scenario's ρ_η;
//! * the robust law with ρ_η sized from that measured bound (× 1.2 margin; A25);
//! * the non-robust law without the observer's disturbance estimate (κ_d = 1 s⁻¹).
//!
//! ```text
//! cargo run --release -p flexstage-control --example robust_terms -- quick
//! ```

use flexstage_control::actuator::Compensation;
use flexstage_control::controller::{NONROBUST, ROBUST};
use flexstage_control::experiment::Setup;
use flexstage_control::observer::DISTURBANCE;
use flexstage_control::registry::Controller;
use flexstage_scenario::{Preset, Scenario};
use flexstage_sim::experiment::StageControl;
use flexstage_sim::rig::StagePlant;
use flexstage_sim::trajectory::Reference;

/// RMS error per axis over the second half \[m\] and the largest |d̂| per axis after the
/// first tenth \[m/s²\]; `None` when the run diverges (|error| > 10 µm).
fn run(
    setup: &Setup,
    v: &Controller,
    reference: Reference,
    duration: f64,
) -> Option<([f64; 2], [f64; 2])> {
    let mut c = setup
        .controller(v, Compensation::Inverse, reference)
        .expect("controller");
    let mut plant = setup.lumped_plant().expect("plant");
    let t = setup.rig.sample_time;
    let n = (duration / t).round() as usize;
    let (mut sum, mut count, mut dmax) = ([0.0; 2], 0usize, [0.0f64; 2]);
    for k in 0..n {
        let y = plant.measure();
        let q = plant.output();
        let cmd = c.step(y);
        plant.apply(&cmd);
        let d = c.estimate();
        for i in 0..2 {
            let e = q[i] - cmd.reference[i];
            if !e.is_finite() || e.abs() >= 1e-5 {
                return None;
            }
            if k >= n / 2 {
                sum[i] += e * e;
            }
            if k >= n / 10 {
                dmax[i] = dmax[i].max(d[DISTURBANCE[i]].abs());
            }
        }
        if k >= n / 2 {
            count += 1;
        }
    }
    Some((sum.map(|s| (s / count as f64).sqrt()), dmax))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let preset = std::env::args()
        .nth(1)
        .and_then(|p| Preset::from_name(&p))
        .ok_or("usage: robust_terms quick|paper")?;
    let s = Scenario::preset(preset);
    let setup = Setup::from_scenario(&s);
    let (reference, duration) = Reference::from_scenario(&s.trajectories[0]);
    let show = |name: &str, r: Option<([f64; 2], [f64; 2])>| match r {
        Some((rms, d)) => println!(
            "{name:<44} RMS {:>8.1}/{:<8.1} nm   max|d̂| {:>7.1}/{:<7.1} m/s²",
            rms[0] * 1e9,
            rms[1] * 1e9,
            d[0],
            d[1]
        ),
        None => println!("{name:<44} diverges"),
    };
    let base = run(&setup, &NONROBUST, reference, duration);
    show("non-robust + observer", base);
    show(
        &format!(
            "robust, scenario ρ_η = {:?}",
            setup.controller.law.eta_bound
        ),
        run(&setup, &ROBUST, reference, duration),
    );
    if let Some((_, d)) = base {
        let mut sized = setup.clone();
        sized.controller.law.eta_bound = d.map(|x| 1.2 * x);
        show(
            &format!(
                "robust, ρ_η = 1.2 max|d̂| = {:.0?}",
                sized.controller.law.eta_bound
            ),
            run(&sized, &ROBUST, reference, duration),
        );
    }
    let mut blind = setup.clone();
    blind.controller.observer.disturbance_gain = 1.0;
    show(
        "non-robust, no disturbance estimate (κ_d = 1)",
        run(&blind, &NONROBUST, reference, duration),
    );
    Ok(())
}
