//! The scan-frequency sweep of the PI + notch and the PID designed from a stored measured
//! response, with a chosen feed-forward: the comparison of the fitted inverse with preview
//! against the static inverse (with and without a one-sample lead), each with the same
//! feedback, on the twin in the full rig.
//!
//! ```text
//! cargo run --release -p flexstage-assess --example scan -- quick RUN/design/design.json RUN/track/measured_response.csv|measure static|lead|inverse|lifted|lifted0|lifted0r[:CUTOFF_HZ[:PREVIEW[:TAPS[:RHO]]]] [FRACTION ...]
//! ```
//!
//! `SCAN_LEARNING=TRIALS` (1..=30) also runs every candidate with the learning layer at every
//! point and prints its rows instead of the intersample analysis (learning corrected after
//! every trial by the lab's fast ADC, as `track` runs it; `SCAN_NO_FAST` learns toward the
//! predicted reading alone). `SCAN_MARGINS=GM_DB,PM_DEG`
//! tunes the linear designs to other margin targets (the learning layer's designs are those
//! widened by `TuningParams::learning_widening`).
//!
//! `measure` measures the twin here as `track` does; the lifted response (a fast ADC on the
//! sensor, `FAST_ADC_RATIO` samples per controller sample, default 10) is always measured:
//! for `lifted` and for the intersample bound printed per point. `lifted0` fits the lifted
//! feed-forward to phase 0 alone (the output at the samples); `lifted0r` adds the feedback's
//! reference the measured loop predicts the reading to be when the output follows
//! (`FirFeedForward::fit_reading`).

use flexstage_assess::Bench;
use flexstage_assess::lab::{LabMeasurement, LabParams};
use flexstage_assess::sweep::{SweepParams, sweep};
use flexstage_control::experiment::Setup;
use flexstage_control::feedforward::{FeedForward, FeedForwardParams};
use flexstage_control::registry::Controller;
use flexstage_control::tuning::TuningParams;
use flexstage_identify::measured::MeasuredResponse;
use flexstage_run::Format;
use flexstage_run::files::design::DesignFile;
use flexstage_scenario::{Preset, Scenario};
use flexstage_twin::DesignedStage;

fn feedforward(mode: &str) -> Result<FeedForward, Box<dyn std::error::Error>> {
    let mut parts = mode.split(':');
    Ok(match parts.next() {
        Some("static") => FeedForward::Static,
        Some("lead") => FeedForward::StaticLead(1),
        Some(name @ ("inverse" | "lifted" | "lifted0" | "lifted0r")) => {
            let mut p = FeedForwardParams::default();
            if let Some(c) = parts.next() {
                p.cutoff = c.parse()?;
            }
            if let Some(v) = parts.next() {
                p.preview = v.parse()?;
            }
            if let Some(v) = parts.next() {
                p.taps = v.parse()?;
                p.grid = p.grid.max(4 * (p.preview + p.taps));
            }
            if let Some(v) = parts.next() {
                p.regularization = v.parse()?;
            }
            // `lifted0r`: the feedback's reference the predicted reading.
            p.reading = name == "lifted0r";
            if name.starts_with("lifted") {
                FeedForward::Lifted(p)
            } else {
                FeedForward::Inverse(p)
            }
        }
        _ => {
            return Err(
                "feed-forward: static, lead, inverse, lifted, lifted0 or lifted0r[:CUTOFF[:PREVIEW[:TAPS[:RHO]]]]"
                    .into(),
            );
        }
    })
}

/// Per point and candidate: the true error on the substeps (RMS, % of range) against the
/// error at the samples, its q1 and q2 content at the axis's line f and at the hold's images
/// f_s − f and f_s + f, and the intersample bound of the measured lifted response at f.
fn between(
    bench: &Bench,
    points: &[flexstage_assess::sweep::SweepPoint],
    lifted: &flexstage_identify::measured::LiftedResponse,
) -> Result<(), Box<dyn std::error::Error>> {
    let fs = 1.0 / bench.setup.rig.sample_time;
    println!(
        "f/f1   controller    RMS between % q1/q2   at samples % q1/q2   q1 nm at f, fs-f, fs+f   q2 nm at f, fs-f, fs+f   bound (f, f_s ∓ f) % of amplitude q1/q2 (RMS % range)"
    );
    let lines = lifted.lines();
    let nearest = |f: f64| {
        lines
            .iter()
            .enumerate()
            .min_by(|a, b| (a.1.f - f).abs().total_cmp(&(b.1.f - f).abs()))
            .map_or(0, |(n, _)| n)
    };
    for f in [33.0, 99.0, 330.0, 990.0] {
        let h = lifted.harmonics(nearest(f));
        let mags: Vec<String> = h.iter().map(|m| format!("{:.4}", m[0][0].norm())).collect();
        let l = h.len();
        let (a, b, c) = (h[0][0][0].norm(), h[l - 1][0][0].norm(), h[1][0][0].norm());
        println!(
            "lifted q1/x1 at {:.0} Hz: |H_m| m = 0..L-1: {}; single image |b|/sqrt(|a|²+|b|²) {:.4} (f_s − f), {:.4} (f_s + f)",
            lines[nearest(f)].f,
            mags.join(" "),
            b / (a * a + b * b).sqrt(),
            c / (a * a + c * c).sqrt()
        );
    }
    for pt in points {
        let base = pt.frequency / 3.0;
        let axis_f = [pt.frequency, base];
        // The bound over the baseband and the two images f_s ∓ f, each image's power less
        // its noise (the higher harmonics are under the fast ADC's noise floor, about 0.02
        // of |H_0|, measured).
        let bound = [0, 1].map(|i| lifted.image_bound(nearest(axis_f[i]))[i]);
        for r in &pt.results {
            let reference = flexstage_sim::trajectory::Reference::new(
                flexstage_sim::trajectory::Shape::Lissajous {
                    ratio: 3.0,
                    amplitude: r.amplitude,
                    frequency: base,
                },
            );
            let duration = (2.0 / base).max(0.05);
            let (rec, b) =
                flexstage_assess::sweep::run_between(bench, r.controller, reference, duration)?;
            // Check: the substep error at the sample instants is the record's error.
            let s = bench.setup.rig.substeps;
            let gap = (1..rec.t.len())
                .map(|k| (b.error[0][k * s - 1] - rec.error[0][k]).abs())
                .fold(0.0, f64::max);
            if std::env::var("SCAN_DUMP").is_ok() {
                let k0 = rec.t.len() / 2;
                for k in k0 - 3..k0 + 4 {
                    println!(
                        "  k {k} x_nom {:.1} nm voltage {:.3} V reference {:.1} nm measured {:.1} truth {:.1}",
                        rec.x_nom[0][k] * 1e9,
                        rec.voltage[0][k],
                        rec.reference[0][k] * 1e9,
                        rec.measured[0][k] * 1e9,
                        rec.truth[0][k] * 1e9
                    );
                }
                for j in k0 * s..(k0 + 3) * s {
                    println!("  {j} {:.3} nm", b.error[0][j] * 1e9);
                }
            }
            if gap > 1e-12 {
                println!("  (substep error at the samples differs from the record's by {gap:e} m)");
            }
            let amp = |i: usize| {
                let f = axis_f[i];
                [f, fs - f, fs + f].map(|x| b.amplitude(i, x) * 1e9)
            };
            let (a1, a2) = (amp(0), amp(1));
            let range = r.amplitude.map(|a| 2.0 * a);
            println!(
                "{:.3}  {:<12} {:7.3} {:7.3}        {:7.3} {:7.3}        {:6.2} {:6.2} {:6.2}     {:6.2} {:6.2} {:6.2}     {:.2} {:.2} ({:.3} {:.3})",
                pt.fraction,
                r.controller.name,
                100.0 * r.rms_between[0] / range[0],
                100.0 * r.rms_between[1] / range[1],
                r.rms_pct[0],
                r.rms_pct[1],
                a1[0],
                a1[1],
                a1[2],
                a2[0],
                a2[1],
                a2[2],
                100.0 * bound[0],
                100.0 * bound[1],
                100.0 * bound[0] / (2.0 * std::f64::consts::SQRT_2),
                100.0 * bound[1] / (2.0 * std::f64::consts::SQRT_2),
            );
        }
    }
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: scan quick|paper DESIGN.json MEASURED.csv MODE [FRACTION ...]";
    let preset = args
        .get(1)
        .and_then(|p| Preset::from_name(p))
        .ok_or(usage)?;
    let design = DesignFile::decode(&std::fs::read(args.get(2).ok_or(usage)?)?)?;
    let measured_path = args.get(3).ok_or(usage)?;
    let mode = feedforward(args.get(4).ok_or(usage)?)?;
    let fractions: Vec<f64> = args[5..]
        .iter()
        .map(|a| a.parse())
        .collect::<Result<_, _>>()?;
    let DesignedStage {
        scenario: s, twin, ..
    } = DesignedStage::new(&Scenario::preset(preset), &design.rho)?;
    let lab = LabParams::default();
    // `measure`: the twin measured here as `track` measures it.
    let m = if measured_path == "measure" {
        flexstage_assess::lab::measure(&twin, &Setup::from_scenario(&s), &lab)?
    } else {
        let measured = std::fs::read(measured_path)?;
        let response = MeasuredResponse::from_csv(&measured[..], "measured response")?;
        LabMeasurement::from_response(response, &lab.fit)?
    };
    let mut tuning = TuningParams {
        feedforward: mode,
        ..TuningParams::default()
    };
    // `SCAN_MARGINS=GM_DB,PM_DEG`: the linear designs tuned to other margins.
    if let Ok(v) = std::env::var("SCAN_MARGINS") {
        let mut it = v.split(',');
        tuning.gain_margin_db = it.next().ok_or("SCAN_MARGINS")?.parse()?;
        tuning.phase_margin_deg = it.next().ok_or("SCAN_MARGINS")?.parse()?;
    }
    let t0 = std::time::Instant::now();
    let setup = Setup::from_scenario(&s);
    let ratio: usize = std::env::var("FAST_ADC_RATIO").map_or(Ok(10), |v| v.parse())?;
    let lifted = flexstage_assess::lab::measure_lifted(&twin, &setup, &lab, ratio)?;
    println!(
        "lifted response measured (L = {ratio}) in {:.2} s",
        t0.elapsed().as_secs_f64()
    );
    // `lifted0`: the lifted fit on phase 0 alone (the output at the samples).
    // `lifted0r` takes every phase: the design fits the filter to phase 0 and the
    // reading's prediction to all of them.
    let fitted = if args[4].starts_with("lifted0") && !args[4].starts_with("lifted0r") {
        lifted.at_samples()
    } else {
        lifted.clone()
    };
    let bench = Bench::from_measurements(setup, twin, tuning, &lab, &m, Some(&fitted))?;
    println!("designed in {:.2} s ({mode:?})", t0.elapsed().as_secs_f64());
    let cands: Vec<&'static Controller> = ["pi-notch-ff", "pid-ff"]
        .iter()
        .filter_map(|n| Controller::by_name(n))
        .collect();
    for c in &cands {
        if let Some(mg) = bench.analytic_margins(c, 1)? {
            println!(
                "{c}: margins (twin, 1 sample) q1 {:.2} dB / {:.1}°, q2 {:.2} dB / {:.1}°",
                mg[0].gain_db, mg[0].phase_deg, mg[1].gain_db, mg[1].phase_deg
            );
        }
    }
    if let Some(ff) = bench.design(cands[0])?.feedforward() {
        // Scoring only: how far G F is from the target on the loop model and on the twin.
        let truth = flexstage_assess::bench::modal_plant(
            &bench.twin,
            1e-4,
            1,
            &bench.setup.rig.amplifier,
            &bench.setup.rig.sensor,
        )?;
        use flexstage_sim::modal::LoopPlant;
        // The true output's sampled response: no sensor chain.
        let output = flexstage_assess::bench::modal_plant(
            &bench.twin,
            1e-4,
            1,
            &bench.setup.rig.amplifier,
            &flexstage_sim::rig::SensorParams::ideal(),
        )?;
        println!(
            "sensor {:?}, lag {:.3} samples",
            bench.setup.rig.sensor,
            ff.lag()
        );
        let target = match mode {
            FeedForward::Inverse(p) => Some(FeedForwardParams { lag: ff.lag(), ..p }),
            FeedForward::Lifted(p) => Some(FeedForwardParams { lag: ff.lag(), ..p }),
            _ => None,
        };
        if let Some(c) = ff.reading() {
            // The reading correction: |C(f)| per entry (the predicted reading less the lag).
            let c = flexstage_control::feedforward::FirFeedForward::from_taps(
                ff.preview(),
                c.to_vec(),
                ff.lag(),
            )?;
            for f in [33.0, 99.0, 329.0, 657.0, 986.0, 1500.0] {
                let h = c.response(f, 1e-4);
                println!(
                    "reading correction |C| at {f:.0} Hz: {:.4} {:.4} {:.4} {:.4}",
                    h[0][0].norm(),
                    h[0][1].norm(),
                    h[1][0].norm(),
                    h[1][1].norm()
                );
            }
        }
        // Scoring only: the twin's reading over its output at the samples, less the lag.
        for f in [33.0, 99.0, 329.0, 657.0, 986.0, 1500.0] {
            let (g, o) = (truth.response(f), output.response(f));
            let e =
                nalgebra::Complex::from_polar(1.0, -std::f64::consts::TAU * f * ff.lag() * 1e-4);
            let c = [0, 1].map(|i| (g[i][i] / o[i][i] - e).norm());
            println!(
                "twin reading/output − lag at {f:.0} Hz (diagonal): {:.4} {:.4}",
                c[0], c[1]
            );
        }
        println!("f Hz   |GF - D| (loop model) q1 q2   (twin) q1 q2   |T|");
        for f in [32.0, 97.0, 322.0, 500.0, 965.0, 1010.0, 1500.0, 3000.0] {
            let h = ff.response(f, 1e-4);
            let d = target.map_or(nalgebra::Complex::new(1.0, 0.0), |p| p.target(f, 1e-4));
            let err = |g: [[nalgebra::Complex<f64>; 2]; 2]| {
                [0, 1].map(|i| {
                    (0..2)
                        .map(|j| {
                            let gf = g[i][0] * h[0][j] + g[i][1] * h[1][j];
                            let want = if i == j {
                                d
                            } else {
                                nalgebra::Complex::new(0.0, 0.0)
                            };
                            (gf - want).norm()
                        })
                        .fold(0.0, f64::max)
                })
            };
            let (a, b) = (err(m.model.response(f)), err(truth.response(f)));
            let d0 = nalgebra::Complex::new(d.norm(), 0.0);
            let o = {
                let g = output.response(f);
                [0, 1].map(|i| {
                    (0..2)
                        .map(|j| {
                            let gf = g[i][0] * h[0][j] + g[i][1] * h[1][j];
                            let want = if i == j {
                                d0
                            } else {
                                nalgebra::Complex::new(0.0, 0.0)
                            };
                            (gf - want).norm()
                        })
                        .fold(0.0, f64::max)
                })
            };
            println!(
                "{f:6.0}  {:.4} {:.4}   {:.4} {:.4}   output {:.4} {:.4}   {:.4}",
                a[0],
                a[1],
                b[0],
                b[1],
                o[0],
                o[1],
                d.norm()
            );
        }
    }
    if let Ok(level) = std::env::var("SCAN_STATIC") {
        // The true output between the samples under a constant command.
        use flexstage_sim::rig::StagePlant;
        let level: f64 = level.parse()?;
        let mut plant = bench.twin.plant(&bench.setup.rig)?;
        plant.record_substeps();
        let mut act = flexstage_control::actuator::Actuator::new(
            bench
                .setup
                .actuator(flexstage_control::actuator::Compensation::Inverse),
        )?;
        for k in 0..3000 {
            let x = [level, 0.0];
            let v = act.command(x, 1e-4).voltage;
            plant.measure();
            plant.apply(&flexstage_sim::experiment::Command {
                voltage: v,
                x_nom: x,
                reference: [0.0; 2],
                saturated: false,
                dropout: false,
            });
            if k >= 2997 {
                let q: Vec<String> = plant
                    .output_substeps()
                    .iter()
                    .map(|q| format!("{:.1}", q[0] * 1e9))
                    .collect();
                println!("sample {k}: q1 nm {}", q.join(" "));
                println!("  x_nom {:?} voltage {:?}", plant.x_nom(), plant.voltage());
            }
        }
    }
    // Truth knobs to diagnose the error (never to design): `SCAN_TRUTH=quiet,creep,sensor`
    // runs the scans without the rig's noise and floor, without creep, with an ideal sensor.
    let mut bench = bench;
    if let Ok(knobs) = std::env::var("SCAN_TRUTH") {
        let rig = &mut bench.setup.rig;
        for k in knobs.split(',') {
            match k {
                "quiet" => {
                    rig.noise_std = [0.0; 2];
                    rig.resolution = [0.0; 2];
                    rig.sensor.flicker_corner = 0.0;
                    rig.floor.velocity_rms = 0.0;
                }
                "creep" => rig.creep.factor = 0.0,
                "sensor" => {
                    rig.sensor.bandwidth = 0.0;
                    rig.sensor.anti_alias = 0.0;
                }
                _ => return Err(format!("SCAN_TRUTH: quiet, creep, sensor; not {k}").into()),
            }
        }
        println!("truth knobs (diagnosis only): {knobs}");
    }
    let mut p = SweepParams::default();
    if !fractions.is_empty() {
        p.fractions = fractions;
    }
    // `SCAN_LEARNING=TRIALS`: every candidate also learns at every point (≤ 30 trials).
    if let Ok(v) = std::env::var("SCAN_LEARNING") {
        let lag = flexstage_control::learning::SensorDatasheet::from_scenario(&s)
            .lag(bench.setup.rig.sample_time)?;
        p.learning = Some(flexstage_assess::sweep::SweepLearning {
            trials: v.parse()?,
            amplitude: 20e-9,
            lag,
            // `SCAN_NO_FAST`: learning toward the predicted reading alone.
            fast_adc: std::env::var("SCAN_NO_FAST")
                .is_err()
                .then(|| flexstage_assess::lab::operating_fast_adc(&bench.setup.rig, ratio)),
        });
    }
    let amplitude = match s.trajectories.first() {
        Some(flexstage_scenario::Trajectory::Lissajous { amplitude, .. }) => *amplitude,
        Some(flexstage_scenario::Trajectory::Circle { radius, .. }) => [*radius; 2],
        None => return Err("no trajectory".into()),
    };
    let t0 = std::time::Instant::now();
    let points = sweep(&bench, &cands, amplitude, &p)?;
    println!("swept in {:.1} s", t0.elapsed().as_secs_f64());
    println!(
        "f/f1   fast Hz  A1 [µm]  limit (factor)            controller   RMS % q1/q2       peak % q1/q2      cause (dominant Hz)"
    );
    for pt in &points {
        for r in &pt.results {
            let limit = r.reduced.map_or("none".to_string(), |(l, f)| {
                format!("{} ({f:.3})", l.name())
            });
            println!(
                "{:.3}  {:7.1}  {:7.3}  {:<26} {:<12} {:7.3} {:7.3}   {:7.3} {:7.3}   {} ({:.0})",
                pt.fraction,
                pt.frequency,
                r.amplitude[0] * 1e6,
                limit,
                r.controller.name,
                r.rms_pct[0],
                r.rms_pct[1],
                r.peak_pct[0],
                r.peak_pct[1],
                r.cause.name(),
                r.dominant
            );
        }
    }
    for pt in &points {
        for r in &pt.learning {
            let l = r.learned.expect("learning rows carry their law");
            println!(
                "{:.3}  {:7.1}  {:<12}+learning ({} ρ {:.3}, {} periods): RMS % q1/q2 at the samples {:.3} {:.3}, between {:.3} {:.3}, read {:.3} {:.3}; peak % {:.3} {:.3}",
                pt.fraction,
                pt.frequency,
                r.controller.name,
                l.law,
                l.rho,
                l.periods,
                r.rms_pct[0],
                r.rms_pct[1],
                r.rms_between_pct[0],
                r.rms_between_pct[1],
                r.rms_read_pct[0],
                r.rms_read_pct[1],
                r.peak_pct[0],
                r.peak_pct[1],
            );
        }
        for (name, why) in &pt.refused {
            println!("{:.3}  {name}: no learning ({why})", pt.fraction);
        }
    }
    if std::env::var("SCAN_LEARNING").is_ok() {
        return Ok(());
    }
    between(&bench, &points, &lifted)?;
    Ok(())
}
