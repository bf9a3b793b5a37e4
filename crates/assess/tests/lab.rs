//! The lab measurement of the twin (`flexstage_assess::lab`) against its known answer, on the
//! twin of the rhombus sample design (`flexstage_twin::samples::quick_rhombus`).

use flexstage_assess::Bench;
use flexstage_assess::bench::{LinearLoop, modal_plant};
use flexstage_assess::lab::LabParams;
use flexstage_control::experiment::Setup;
use flexstage_control::pi_notch::PI_NOTCH_FF;
use flexstage_control::pid::PID_FF;
use flexstage_sim::modal::LoopPlant;

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
    let (s, rho) = flexstage_twin::samples::quick_rhombus().unwrap();
    let twin = flexstage_twin::Twin::from_scenario(&s, &rho).unwrap();
    let mut setup = Setup::from_scenario(&s);
    setup.rig = LinearLoop {
        twin: &twin,
        setup: &setup,
    }
    .linear_rig(setup.rig.delay);
    setup.rig.substeps = 80;
    let lab = LabParams {
        noise: false,
        ..LabParams::default()
    };
    let (bench, m) = Bench::measured(setup, twin, Default::default(), &lab).unwrap();
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
