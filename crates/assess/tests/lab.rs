//! The lab measurement of the twin (`flexstage_assess::lab`) against its known answer, on the
//! twin of the rhombus sample design (`flexstage_twin::samples::quick_rhombus`).

use std::sync::OnceLock;

use flexstage_assess::Bench;
use flexstage_assess::bench::{LinearLoop, modal_plant};
use flexstage_assess::lab::LabParams;
use flexstage_control::experiment::Setup;
use flexstage_control::pi_notch::PI_NOTCH_FF;
use flexstage_control::pid::PID_FF;
use flexstage_scenario::Scenario;
use flexstage_sim::modal::LoopPlant;
use flexstage_twin::Twin;

/// The twin of the rhombus sample design on the quick preset with its scenario, built once
/// per test binary (every test here measures this twin).
fn quick_twin() -> &'static (Scenario, Twin) {
    static TWIN: OnceLock<(Scenario, Twin)> = OnceLock::new();
    TWIN.get_or_init(|| {
        let (s, rho) = flexstage_twin::samples::quick_rhombus().unwrap();
        let twin = Twin::from_scenario(&s, &rho).unwrap();
        (s, twin)
    })
}

/// The scenario's settings with the rig `linear`: the twin's linear rig (ideal amplifier
/// of the scenario's bandwidth, no PEA, no noise) at 80 substeps, since the rig interpolates
/// its sensor chain within a substep at O(h³); otherwise the scenario's full rig.
fn setup(s: &Scenario, twin: &Twin, linear: bool) -> Setup {
    let mut setup = Setup::from_scenario(s);
    if linear {
        setup.rig = LinearLoop {
            twin,
            setup: &setup,
        }
        .linear_rig(setup.rig.delay);
        setup.rig.substeps = 80;
    }
    setup
}

/// The lab's default measurement without the sensor noise.
fn noise_free() -> LabParams {
    LabParams {
        noise: false,
        ..LabParams::default()
    }
}

/// Reference: the twin's exact sampled loop (`modal_plant`: every mode discretized exactly,
/// the rig's delay and sensor chain), the loop the margins are scored on. Goal: measured by
/// the multisine through the twin's linear rig (ideal amplifier, no PEA, no noise; 80
/// substeps, since the rig interpolates its sensor chain within a substep at O(h³)) at the
/// controller's 10 kHz, the response equals it at every line to 1e-3 of the largest entry
/// (measured 1.2e-4),
/// including the folded modes; and the PI + notch and PID designed from the measurement
/// alone are stable on the exact loop (their margins printed).
#[test]
fn lab_measurement_of_the_linear_loop_is_the_exact_sampled_loop() {
    let (s, twin) = quick_twin();
    let setup = setup(s, twin, true);
    let (bench, m) =
        Bench::measured(setup, twin.clone(), Default::default(), &noise_free()).unwrap();
    let rig = &bench.setup.rig;
    let exact = modal_plant(
        &bench.twin,
        rig.sample_time,
        rig.delay,
        &rig.amplifier,
        &rig.sensor,
    )
    .unwrap();
    let top = m
        .response
        .lines()
        .iter()
        .flat_map(|l| l.h.iter().flatten())
        .map(|v| v.norm())
        .fold(0.0, f64::max);
    let mut worst = 0.0f64;
    for l in m.response.lines() {
        let h = exact.response(l.f);
        for (row, exact_row) in l.h.iter().zip(&h) {
            for (v, e) in row.iter().zip(exact_row) {
                worst = worst.max((v - e).norm() / top);
            }
        }
    }
    println!("worst deviation from the exact loop {worst:.2e} of the largest entry {top:.2}");
    assert!(worst < 1e-3, "{worst:e}");
    for c in [&PI_NOTCH_FF, &PID_FF] {
        let margins = bench.analytic_margins(c, rig.delay).unwrap().unwrap();
        println!("{c}: {margins:?}");
        assert!(margins.iter().all(|m| m.gain_db > 0.0 && m.phase_deg > 0.0));
    }
}

/// The largest |measured − model| over every line and entry, over the largest measured entry.
fn worst_gap(m: &flexstage_identify::measured::MeasuredResponse, model: &dyn LoopPlant) -> f64 {
    let top = m
        .lines()
        .iter()
        .flat_map(|l| l.h.iter().flatten())
        .map(|v| v.norm())
        .fold(0.0, f64::max);
    let mut worst = 0.0f64;
    for l in m.lines() {
        let h = model.response(l.f);
        for (row, model_row) in l.h.iter().zip(&h) {
            for (v, e) in row.iter().zip(model_row) {
                worst = worst.max((v - e).norm() / top);
            }
        }
    }
    worst
}

/// Reference: the scoring loop (`modal_plant`: the twin's modes sampled exactly with the
/// amplifier's first-order response after the hold and the sensor chain before the sampler).
/// Goal: measured noise-free through the FULL rig (amplifier, hysteretic PEAs under the
/// inverse compensation, creep) at 10 kHz, the response is that loop to 3 % of the largest
/// entry at every line (the residual is the PEAs' small-signal gain under the compensation,
/// about 1–2 %), while the loop without the amplifier is more than 10 % off (the amplifier
/// attenuates the hold's image that excites the folded modes). The designs from the
/// measurement meet 6 dB / 40° on the scoring loop.
#[test]
fn full_rig_measurement_agrees_with_the_scoring_loop_only_with_the_amplifier() {
    let (s, twin) = quick_twin();
    let setup = setup(s, twin, false);
    assert!(setup.rig.amplifier.bandwidth > 0.0);
    let (bench, m) =
        Bench::measured(setup, twin.clone(), Default::default(), &noise_free()).unwrap();
    let rig = &bench.setup.rig;
    let exact = modal_plant(
        &bench.twin,
        rig.sample_time,
        rig.delay,
        &rig.amplifier,
        &rig.sensor,
    )
    .unwrap();
    let ideal = flexstage_sim::rig::AmplifierParams::ideal();
    let bare = modal_plant(&bench.twin, rig.sample_time, rig.delay, &ideal, &rig.sensor).unwrap();
    let (with, without) = (
        worst_gap(&m.response, &exact),
        worst_gap(&m.response, &bare),
    );
    println!("full rig − scoring loop {with:.2e}, − the loop without the amplifier {without:.2e}");
    assert!(with < 3e-2, "{with:e}");
    assert!(without > 0.1, "{without:e}");
    for c in [&PI_NOTCH_FF, &PID_FF] {
        let margins = bench.analytic_margins(c, rig.delay).unwrap().unwrap();
        println!("{c}: {margins:?}");
        assert!(
            margins
                .iter()
                .all(|m| m.gain_db >= 6.0 && m.phase_deg >= 40.0),
            "{c}: {margins:?}"
        );
    }
}

/// Reference: the twin's exact sampled loop with an ideal sensor (`modal_plant` with
/// `SensorParams::ideal`): the output itself at the samples. Goal: the lifted response
/// measured by a fast ADC at 10 × f_s on the sensor's output of the linear rig (noise-free, 80
/// substeps), with the sensor's datasheet filter divided out harmonic by harmonic, is at
/// phase 0 that loop to 1e-3 of the largest entry at every line, while the sampled response
/// through the sensor chain is further from it (the filter's phase on the folded modes;
/// measured 8.1e-5 and 0.37).
#[test]
fn lifted_response_at_phase_zero_is_the_output_at_the_samples() {
    let (s, twin) = quick_twin();
    let setup = setup(s, twin, true);
    let lab = noise_free();
    let lifted = flexstage_assess::lab::measure_lifted(twin, &setup, &lab, 10).unwrap();
    let m = flexstage_assess::lab::measure(twin, &setup, &lab).unwrap();
    let rig = &setup.rig;
    let ideal = flexstage_sim::rig::SensorParams::ideal();
    let output = modal_plant(twin, rig.sample_time, rig.delay, &rig.amplifier, &ideal).unwrap();
    let top = lifted
        .lines()
        .iter()
        .flat_map(|l| l.phase[0].h.iter().flatten())
        .map(|v| v.norm())
        .fold(0.0, f64::max);
    let mut worst = 0.0f64;
    for l in lifted.lines() {
        let h = output.response(l.f);
        for (row, exact_row) in l.phase[0].h.iter().zip(&h) {
            for (v, e) in row.iter().zip(exact_row) {
                worst = worst.max((v - e).norm() / top);
            }
        }
    }
    let sampled = worst_gap(&m.response, &output);
    println!(
        "lifted phase 0 − output loop {worst:.2e}, sampled reading − output loop {sampled:.2e}"
    );
    assert!(worst < 1e-3, "{worst:e}");
    assert!(sampled > 10.0 * worst, "{sampled:e}");
}
