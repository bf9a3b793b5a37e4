//! Why the backstepping controllers fail on the twin, by measurement: the sampled closed
//! loop of each backstepping variant on the twin's linear rig, with one suspected cause
//! switched off at a time (issue #18, item 1). For each configuration it prints whether the
//! loop is stable after a 10 nm kick, the frequency and growth rate of the dominant
//! oscillation (zero crossings and envelope of q1, q2 over the run), and, when stable, the
//! loop-at-a-time margins by sine injection.
//!
//! ```text
//! cargo run --release -p flexstage-assess --example diagnose -- quick runs/quick/design/design.json
//! ```

use flexstage_assess::Bench;
use flexstage_assess::Candidate;
use flexstage_assess::inject::{InjectionParams, injected_margins, is_stable};
use flexstage_control::actuator::Compensation;
use flexstage_control::controller::Velocity;
use flexstage_control::model::StageModel;
use flexstage_control::plant::LumpedStage;
use flexstage_control::rig::{RigPlant, StagePlant};
use flexstage_control::trajectory::{Reference, Shape};
use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::DesignFile;
use flexstage_twin::DesignedStage;

/// Dominant oscillation of the kicked loop: (frequency of q_i from zero crossings over the
/// last half [Hz], growth rate of the envelope between the two halves [1/s], peak [m]).
fn kick(bench: &Bench, c: Candidate, delay: usize, duration: f64) -> [(f64, f64, f64); 2] {
    kick_on(bench, c, &mut bench.linear_plant(delay).unwrap(), duration)
}

/// [`kick`] on any plant.
fn kick_on(
    bench: &Bench,
    c: Candidate,
    plant: &mut dyn StagePlant,
    duration: f64,
) -> [(f64, f64, f64); 2] {
    let r = Reference::new(Shape::Step { target: [0.0; 2] });
    let mut ctrl = match bench.controller(c, Compensation::Ideal, r) {
        Ok(c) => c,
        Err(e) => {
            println!("    {e}");
            return [(f64::NAN, f64::NAN, f64::NAN); 2];
        }
    };
    let t = bench.setup.rig.sample_time;
    let n = (duration / t).round() as usize;
    let mut q = [Vec::with_capacity(n), Vec::with_capacity(n)];
    for k in 0..n {
        let mut y = plant.measure();
        if k == 0 {
            y = [y[0] + 1e-8, y[1] + 1e-8];
        }
        let cmd = ctrl.step(y);
        plant.apply(&cmd);
        let o = plant.output();
        if !(o[0].abs() < 1e-6 && o[1].abs() < 1e-6) {
            break;
        }
        q[0].push(o[0]);
        q[1].push(o[1]);
    }
    [0, 1].map(|i| {
        let x = &q[i];
        let m = x.len();
        let half = &x[m / 2..];
        let crossings = half.windows(2).filter(|w| w[0] * w[1] < 0.0).count();
        let f = crossings as f64 / 2.0 / (half.len() as f64 * t);
        let rms = |s: &[f64]| (s.iter().map(|v| v * v).sum::<f64>() / s.len() as f64).sqrt();
        let (a, b) = (rms(&x[m / 4..m / 2]), rms(&x[3 * m / 4..]));
        let growth = (b / a).ln() / (0.5 * m as f64 * t);
        let peak = x.iter().fold(0.0f64, |p, v| p.max(v.abs()));
        (f, growth, peak)
    })
}

fn report(name: &str, bench: &Bench, delay: usize) {
    let mut owned = bench.clone();
    owned.setup.controller.delay = delay;
    let bench = &owned;
    for c in [Candidate::Robust, Candidate::NonRobust] {
        let k = kick(bench, c, delay, 0.2);
        let stable = is_stable(bench, c, delay, 1.0).unwrap_or(false);
        let margins = if stable {
            let mut mp = bench.tuning.margins;
            mp.f_min = 10.0;
            mp.points = 40;
            mp.refine = 8;
            match injected_margins(bench, c, delay, &mp, &InjectionParams::default()).unwrap() {
                Some(m) => format!(
                    "GM {:.1}/{:.1} dB, PM {:.0}/{:.0}°, f_c {:.0}/{:.0} Hz",
                    m[0].gain_db,
                    m[1].gain_db,
                    m[0].phase_deg,
                    m[1].phase_deg,
                    m[0].gain_crossover,
                    m[1].gain_crossover
                ),
                None => "diverges under injection".into(),
            }
        } else {
            String::new()
        };
        println!(
            "{name:<34} {:<9} {:<8} q1 {:>6.0} Hz {:>+8.0}/s | q2 {:>6.0} Hz {:>+8.0}/s  {margins}",
            c.name(),
            if stable { "stable" } else { "UNSTABLE" },
            k[0].0,
            k[0].1,
            k[1].0,
            k[1].1,
        );
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let preset = args
        .get(1)
        .and_then(|p| Preset::from_name(p))
        .ok_or("usage: diagnose quick|paper DESIGN.json")?;
    let design = DesignFile::from_json(&std::fs::read(args.get(2).ok_or("missing design")?)?)?;
    let DesignedStage { setup, twin, .. } =
        DesignedStage::new(&Scenario::preset(preset), &design.rho)?;
    let bench = Bench::new(setup, twin, Default::default())?;
    let t = bench.setup.rig.sample_time;
    let delay = bench.setup.rig.delay;

    // Static gains and modes: the controller's lumped model against the twin.
    let model = StageModel::new(&bench.setup.controller.model)?;
    let gm = model.dc_gain()?;
    let gt = bench.twin.modal.dc_gain();
    println!("static gain x_nom → q   model                 twin");
    for i in 0..2 {
        println!(
            "  row {}   [{:+.4} {:+.4}]   [{:+.4} {:+.4}]",
            i + 1,
            gm[(i, 0)],
            gm[(i, 1)],
            gt[i][0],
            gt[i][1]
        );
    }
    println!("twin modes (f [Hz], ζ, aliased to [Hz], |out·in| q1, q2):");
    let fs = 1.0 / t;
    for m in bench.twin.modal.modes.iter().take(14) {
        let alias = (m.frequency - fs * (m.frequency / fs).round()).abs();
        let w2 = (std::f64::consts::TAU * m.frequency).powi(2);
        println!(
            "  {:>9.1}  {:.4}  {:>7.1}  {:+.3e} {:+.3e}",
            m.frequency,
            m.damping,
            alias,
            m.output[0] * (m.input[0] + m.input[1]) / w2,
            m.output[1] * (m.input[0] - m.input[1]) / w2
        );
    }
    let ev = model.b.complex_eigenvalues();
    let mut fm: Vec<f64> = ev
        .iter()
        .map(|z| z.im.abs() / std::f64::consts::TAU)
        .collect();
    fm.sort_by(f64::total_cmp);
    fm.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
    println!("controller model modes [Hz]: {fm:.0?}");
    println!(
        "\n{:<34} {:<9} {:<8} dominant oscillation of the kicked loop; margins when stable",
        "configuration", "variant", "loop"
    );

    for d in [delay, 0] {
        let mut rig = bench.linear_rig(d);
        rig.floor.velocity_rms = 0.0;
        let stage = LumpedStage::new(&bench.setup.plant.truth, 0.0, rig.substep())?;
        let mut lumped = RigPlant::new(rig, stage)?;
        for c in [Candidate::Robust, Candidate::NonRobust] {
            let k = kick_on(&bench, c, &mut lumped, 0.2);
            println!(
                "{:<34} {:<9} (kick) q1 {:>6.0} Hz {:>+8.0}/s | q2 {:>6.0} Hz {:>+8.0}/s",
                format!("lumped plant = model, delay {d}"),
                c.name(),
                k[0].0,
                k[0].1,
                k[1].0,
                k[1].1
            );
        }
    }
    report("as shipped", &bench, delay);
    report("no delay", &bench, 0);
    let mut b = bench.clone();
    for m in &mut b.twin.modal.modes {
        if m.frequency > 0.5 * fs {
            m.damping = 1.0;
        }
    }
    report("twin modes > f_s/2 overdamped", &b, delay);
    let mut b = bench.clone();
    b.setup.controller.velocity = Velocity::Observer;
    // With a delay the predictor always takes q̇ from the observer; without, the law's
    // finite difference is the paper's default.
    report("no delay, observer velocity (no FD)", &b, 0);
    let mut b = bench.clone();
    b.setup.controller.observer.disturbance_gain *= 0.1;
    report("disturbance observer κ_d / 10", &b, delay);
    let mut b = bench.clone();
    b.setup.controller.law.error_gain = b.setup.controller.law.error_gain.map(|g| 0.3 * g);
    b.setup.controller.law.eta_gain = b.setup.controller.law.eta_gain.map(|g| 0.3 * g);
    report("gains k_ε, k_η × 0.3", &b, delay);
    // The controller model's output mass fitted to the twin's q2 mode (3.2 kHz on the quick
    // design), keeping every stiffness (so the static gain stays).
    let fit = (2324.0f64 / 3220.0).powi(2);
    let mut fitted = bench.clone();
    fitted.setup.controller.model.mass *= fit;
    fitted.setup.controller.model.c_qo1 *= fit.sqrt();
    fitted.setup.controller.model.c_qo2 *= fit.sqrt();
    let f = StageModel::new(&fitted.setup.controller.model)?.natural_frequencies();
    report(
        &format!("model M × {fit:.2} ({:.0}/{:.0} Hz)", f[0], f[1]),
        &fitted,
        delay,
    );
    let mut b = fitted.clone();
    for m in &mut b.twin.modal.modes {
        if m.frequency > 0.5 * fs {
            m.damping = 1.0;
        }
    }
    report("  + twin modes > f_s/2 overdamped", &b, delay);
    let mut b = fitted.clone();
    b.setup.controller.observer.gain = b.setup.controller.observer.gain.map(|x| 0.3 * x);
    report("  + observer gains × 0.3", &b, delay);
    Ok(())
}
