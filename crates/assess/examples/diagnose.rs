//! Backstepping on the twin: why the controller as shipped with the design
//! guess is unstable, what makes it stable, the gains sized by the margins, ρ_η sized from
//! the twin's measured disturbance, and what each part buys.
//!
//! 1. The controller's lumped model against the twin (static gain, modes, aliases).
//! 2. Kick test and loop-at-a-time margins (sine injection, one sample of delay) of the
//!    backstepping variants: the design guess with the K-filter (the paper's estimator), the
//!    guess with the Kalman estimate, and the model fitted to the twin's response below
//!    Nyquist ("what identification would give", `response::ResponseFit::from_modes`).
//! 3. The law's gains k_ε = k_η = k scaled down until both loops keep 6 dB / 40°.
//! 4. The disturbance bound max|Δ̂_η| measured on the twin in the full rig (non-robust,
//!    default Lissajous), ρ_η of A25 set to it, and the tracking table: robust, non-robust,
//!    without the disturbance observer, each with the Kalman estimate, on the twin and on the
//!    lumped plant.
//!
//! ```text
//! cargo run --release -p flexstage-assess --example diagnose -- quick runs/quick/design/design.json
//! ```

use flexstage_assess::Bench;
use flexstage_assess::inject::{InjectionParams, injected_margins, is_stable};
use flexstage_control::actuator::Compensation;
use flexstage_control::backstepping::LawParams;
use flexstage_control::controller::{Backstepping, Estimator, NONROBUST, ROBUST};
use flexstage_control::experiment::Setup;
use flexstage_control::fit::fit_to_response;
use flexstage_control::margins::Margins;
use flexstage_control::pi_notch::PI_NOTCH_FF;
use flexstage_control::registry::Design;
use flexstage_identify::response::ResponseFit;
use flexstage_run::Format;
use flexstage_run::files::design::DesignFile;
use flexstage_scenario::{Preset, Scenario, StageParams};
use flexstage_sim::experiment::run;
use flexstage_sim::model::StageModel;
use flexstage_sim::rig::StagePlant;
use flexstage_sim::trajectory::Reference;
use flexstage_twin::DesignedStage;

/// Margins of a backstepping design (None: unstable).
fn margins_of(bench: &Bench, design: &dyn Design) -> Option<[Margins; 2]> {
    let delay = bench.setup.rig.delay;
    let probe = bench.probe();
    if !is_stable(&probe, design, delay, 1.0).unwrap_or(false) {
        return None;
    }
    let mut mp = bench.tuning.margins;
    mp.f_min = 10.0;
    mp.points = 40;
    mp.refine = 8;
    injected_margins(&probe, design, delay, &mp, &InjectionParams::default()).unwrap_or(None)
}

/// Margins of the backstepping with the bench's settings (`bench.setup.controller`), robust
/// or not (None: unstable).
fn margins(bench: &Bench, robust: bool) -> Option<[Margins; 2]> {
    margins_of(
        bench,
        &Backstepping::new(bench.setup.controller.clone(), robust),
    )
}

fn show(m: &Option<[Margins; 2]>) -> String {
    match m {
        None => "UNSTABLE".into(),
        Some(m) => format!(
            "GM {:.1}/{:.1} dB, PM {:.0}/{:.0}°, f_c {:.0}/{:.0} Hz",
            m[0].gain_db,
            m[1].gain_db,
            m[0].phase_deg,
            m[1].phase_deg,
            m[0].gain_crossover,
            m[1].gain_crossover
        ),
    }
}

fn meets(m: &Option<[Margins; 2]>) -> bool {
    m.as_ref()
        .is_some_and(|m| m.iter().all(|m| m.meets(6.0, 40.0)))
}

fn report(name: &str, bench: &Bench) {
    for (c, robust) in [(&ROBUST, true), (&NONROBUST, false)] {
        println!("{name:<44} {:<9} {}", c.name, show(&margins(bench, robust)));
    }
}

/// One tracking run of a backstepping variant on `plant`: RMS error against the true
/// output per axis and max|Δ̂_η| per axis.
fn track(
    setup: &Setup,
    robust: bool,
    plant: &mut dyn StagePlant,
    reference: Reference,
    duration: f64,
) -> ([f64; 2], [f64; 2]) {
    let design = Backstepping::new(setup.controller.clone(), robust);
    let actuator = setup.actuator(Compensation::Inverse);
    let mut c = design
        .build(actuator, setup.controller.delay, reference)
        .unwrap();
    let t = setup.rig.sample_time;
    let rec = run(c.as_mut(), plant, duration, t, |_| {});
    let m = rec.metrics(reference.half_range(duration, t));
    if let Ok(path) = std::env::var("BS_DUMP") {
        let mut out = String::new();
        for k in 0..rec.t.len() {
            out += &format!(
                "{} {} {} {} {} {} {}\n",
                rec.t[k],
                rec.error[0][k],
                rec.error[1][k],
                rec.reference[0][k],
                rec.reference[1][k],
                rec.estimate[8][k],
                rec.estimate[9][k]
            );
        }
        static N: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        std::fs::write(format!("{path}-{n}"), out).unwrap();
    }
    let n = rec.t.len();
    let bound = [8, 9].map(|j| {
        rec.estimate[j][n / 10..]
            .iter()
            .fold(0.0f64, |a, v| a.max(v.abs()))
    });
    (m.rms, bound)
}

/// Section 1: the scenario's model against the twin (static gain, modes, aliases) and the
/// model fitted to the twin's response below Nyquist.
fn model_against_twin(
    bench: &Bench,
    guess: &StageParams,
) -> Result<StageParams, Box<dyn std::error::Error>> {
    let fs = 1.0 / bench.setup.rig.sample_time;
    let gm = StageModel::new(guess)?.dc_gain()?;
    let gt = bench.twin.modal.dc_gain();
    println!("static gain x_nom → q   model (guess)         twin");
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
    println!("twin modes (f [Hz], ζ, aliased to [Hz], share of static gain q1, q2):");
    for m in bench.twin.modal.modes.iter().take(10) {
        let alias = (m.frequency - fs * (m.frequency / fs).round()).abs();
        let w2 = (std::f64::consts::TAU * m.frequency).powi(2);
        println!(
            "  {:>9.1}  {:.4}  {:>7.1}  {:+.3} {:+.3}",
            m.frequency,
            m.damping,
            alias,
            m.output[0] * (m.input[0] + m.input[1]) / w2 / (gt[0][0] + gt[0][1]),
            m.output[1] * (m.input[0] - m.input[1]) / w2 / (gt[1][0] - gt[1][1])
        );
    }
    let mut fit = ResponseFit::from_modes(&bench.twin.modal.plant_modes(), 0.5 * fs, 0.1);
    if let Some(f) = env("BS_F1") {
        fit.frequency[0] = Some(f);
    }
    let fitted = fit_to_response(guess, &fit)?;
    println!(
        "fit (identification below Nyquist): q1 mode {:?} Hz, q2 mode {:?} Hz ζ {:.3}; \
         M {:.3e} → {:.3e} kg, K_qo1 {:.3e} → {:.3e} N/m, K_in {:.3e} → {:.3e} N/m, \
         α {:.3} → {:.3}; model modes {:.0?} Hz",
        fit.frequency[0],
        fit.frequency[1],
        fit.damping[1],
        guess.mass,
        fitted.mass,
        guess.k_qo1,
        fitted.k_qo1,
        guess.k_in1,
        fitted.k_in1,
        guess.alpha,
        fitted.alpha,
        StageModel::new(&fitted)?.natural_frequencies(),
    );
    Ok(fitted)
}

/// An exploration knob from the environment: BS_QD, BS_QA (Kalman drift and acceleration
/// intensities), BS_NOTCH=0 (without the tuned PI + notch's notches on the measurement),
/// BS_F1 (a q1 mode [Hz] for the fit), BS_GUESS=1 (no fit); BS_DUMP=PATH writes each
/// tracking run's time, errors, references and Δ̂_η to PATH-n (n in run order).
fn env(k: &str) -> Option<f64> {
    std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok())
}

/// Section 2: stability and margins of each set-up with one sample of delay; returns the
/// bench with the fitted model, notches and Kalman estimate (scenario gains).
fn stability(bench: &Bench, fitted: &StageParams) -> Bench {
    let mut bench = bench.clone();
    if let Estimator::Kalman(k) = &mut bench.setup.controller.estimator {
        if let Some(q) = env("BS_QD") {
            k.disturbance_drift = [q; 2];
        }
        if let Some(q) = env("BS_QA") {
            k.acceleration_noise = [q; 2];
        }
    }
    println!("\nconfiguration (1 sample delay, margins by sine injection)");
    let mut b = bench.clone();
    b.setup.controller.estimator = Estimator::KFilter;
    report("guess model, K-filter (paper)", &b);
    report("guess model, Kalman", &bench);
    if env("BS_NOTCH") != Some(0.0) {
        let pi_notch = bench.linear_params(&PI_NOTCH_FF).ok().flatten();
        bench.setup.controller.measurement_notches =
            pi_notch.map_or([[None; 2]; 2], |p| p.axes.map(|a| a.notches));
    }
    report("guess model, Kalman, notches", &bench);
    if env("BS_GUESS") != Some(1.0) {
        bench.setup.controller.model = fitted.clone();
    }
    let mut b = bench.clone();
    b.setup.controller.estimator = Estimator::KFilter;
    report("fitted model, K-filter (paper), notches", &b);
    report("fitted model, Kalman, notches", &bench);
    bench
}

/// Section 3: the largest common scale of k_ε, k_η − 1, k that keeps 6 dB / 40° on both
/// loops for both variants.
fn size_gains(fb: &Bench) -> Option<(f64, Bench)> {
    let base = fb.setup.controller.law;
    for scale in [1.0, 0.7, 0.5, 0.35, 0.25, 0.18, 0.12, 0.08, 0.05] {
        let mut b = fb.clone();
        let law = &mut b.setup.controller.law;
        law.error_gain = base.error_gain.map(|g| scale * g);
        law.eta_gain = base.eta_gain.map(|g| 1.0 + scale * (g - 1.0));
        law.feedback_gain = base.feedback_gain.map(|g| scale * g);
        let m = [true, false].map(|robust| margins(&b, robust));
        println!(
            "gains × {scale:<5} robust {} | non-robust {}",
            show(&m[0]),
            show(&m[1])
        );
        if m.iter().all(meets) {
            return Some((scale, b));
        }
    }
    None
}

/// The robust-term settings of one row of the table: ρ_η and, optionally, φ_s.
fn set_rho(law: &mut LawParams, rho: Option<[f64; 2]>, phi_s: Option<f64>) {
    if let Some(r) = rho {
        law.eta_bound = r;
    }
    if let Some(phi) = phi_s {
        law.boundary_layer[0] = phi;
    }
}

/// Section 4: ρ_η from the twin's measured disturbance, and what each part buys.
fn what_each_part_buys(
    sized: &Bench,
    scenario: &Scenario,
) -> Result<(), Box<dyn std::error::Error>> {
    let (reference, duration) = Reference::from_scenario(&scenario.trajectories[0]);
    let s = &sized.setup;
    let (_, bound) = track(
        s,
        false,
        &mut sized.twin.plant(&s.rig)?,
        reference,
        duration,
    );
    println!(
        "\nmeasured max|Δ̂_η| on the twin (non-robust, {duration} s Lissajous): {:.1}/{:.1} m/s²",
        bound[0], bound[1]
    );
    let mut sized_rho = sized.clone();
    sized_rho.setup.controller.law.eta_bound = bound;
    report("robust with ρ_η = measured bound", &sized_rho);
    // The boundary layer widened so that the layer's slope ρ_η/φ_s is a quarter of k_η:
    // inside it the robust term is then a 25 % higher linear gain.
    let phi_s = bound[0].max(bound[1]) / (0.25 * s.controller.law.eta_gain[0]);
    sized_rho.setup.controller.law.boundary_layer[0] = phi_s;
    report(
        &format!("  + boundary layer φ_s = {phi_s:.3} m/s"),
        &sized_rho,
    );
    println!("\nvariant (Kalman estimate)            twin RMS q1/q2 [nm]   lumped RMS q1/q2 [nm]");
    type Case<'a> = (&'a str, bool, bool, Option<[f64; 2]>, Option<f64>);
    let cases: [Case; 5] = [
        (
            "robust, ρ_η = measured bound",
            true,
            true,
            Some(bound),
            None,
        ),
        (
            "robust, ρ_η measured, wide φ_s",
            true,
            true,
            Some(bound),
            Some(phi_s),
        ),
        ("robust, scenario ρ_η", true, true, None, None),
        ("non-robust", false, true, None, None),
        ("without disturbance observer", false, false, None, None),
    ];
    for (name, robust, dob, rho, phi) in cases {
        let mut st = sized.setup.clone();
        st.controller.disturbance_feedback = dob;
        set_rho(&mut st.controller.law, rho, phi);
        let (tw, _) = track(
            &st,
            robust,
            &mut sized.twin.plant(&st.rig)?,
            reference,
            duration,
        );
        // The lumped plant in the rig as `track --plant lumped` runs it: the scenario's
        // setup (controller model = design guess, scenario gains), Kalman estimate, the
        // same robust / disturbance-observer settings.
        let mut sl = Setup::from_scenario(scenario);
        sl.controller.disturbance_feedback = dob;
        set_rho(&mut sl.controller.law, rho, phi);
        let (lu, _) = track(&sl, robust, &mut sl.lumped_plant()?, reference, duration);
        println!(
            "{name:<36} {:>7.1}/{:<7.1}          {:>7.1}/{:<7.1}",
            tw[0] * 1e9,
            tw[1] * 1e9,
            lu[0] * 1e9,
            lu[1] * 1e9
        );
    }
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let preset = args
        .get(1)
        .and_then(|p| Preset::from_name(p))
        .ok_or("usage: diagnose quick|paper DESIGN.json")?;
    let scenario = Scenario::preset(preset);
    let design = DesignFile::decode(&std::fs::read(args.get(2).ok_or("missing design")?)?)?;
    let DesignedStage {
        scenario: s, twin, ..
    } = DesignedStage::new(&scenario, &design.rho)?;
    let setup = Setup::from_scenario(&s);
    // The scenario's backstepping settings (design guess, scenario gains, no notches);
    // `Bench::new` sets the shipped ones up from the twin's response.
    let original = setup.controller.clone();
    let shipped = Bench::new(setup, twin, Default::default())?;
    let mut bench = shipped.clone();
    bench.setup.controller = original.clone();

    let fitted = model_against_twin(&bench, &original.model)?;
    let fb = stability(&bench, &fitted);
    let Some((scale, sized)) = size_gains(&fb) else {
        println!("no gain scale down to 0.05 meets 6 dB / 40° on both loops");
        return Ok(());
    };
    for c in [&ROBUST, &NONROBUST] {
        let m = margins_of(&shipped, &**shipped.design(c)?);
        let name = "shipped (Bench::new, controller::sized)";
        println!("{name:<44} {:<9} {}", c.name, show(&m));
    }
    let law = sized.setup.controller.law;
    println!(
        "chosen: gains × {scale}: k_ε {:.0?}, k_η {:.0?}, k {:.0?}",
        law.error_gain, law.eta_gain, law.feedback_gain
    );
    what_each_part_buys(&sized, &scenario)
}
