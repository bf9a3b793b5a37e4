// Reference: the rig's true output, for scoring only: the choices below are made from the
// readings, and the tests check them against what the true output says.
// Goal: averaging the learning plant's measurement over periods shrinks its measured
// uncertainty; the law chosen by trial on the loop's readings (`choose_law`) is the one whose
// true-output error after the trials is the smaller.

mod common;

use common::LumpedRig;
use flexstage_control::learning::{
    DesignParams, Law, Learning, MEASURE_PERIODS, SensorDatasheet, choose_law, design,
    design_inverse,
};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Goal: with the sensor's noise in the rig, the uncertainty δ the measurement reports falls
/// when it averages [`MEASURE_PERIODS`] − 2 periods instead of analysing one: the part of δ
/// that is noise falls as 1/√8, so the median over the harmonics falls below 60 %.
#[test]
fn averaging_periods_shrinks_the_measured_uncertainty() {
    let rig = LumpedRig::paper();
    let one = rig.learning_plant(3);
    let averaged = rig.learning_plant(MEASURE_PERIODS);
    for a in 0..2 {
        let (d1, d8) = (
            median(one.uncertainty[a].clone()),
            median(averaged.uncertainty[a].clone()),
        );
        assert!(d8 < 0.6 * d1, "axis {a}: median δ {d1:.4} → {d8:.4}");
    }
}

/// Σ over the axes of (RMS of the last period / RMS of the first)² of the true output.
fn true_score(rig: &LumpedRig, law: &Law, trials: usize) -> f64 {
    let lag = SensorDatasheet::from_scenario(&flexstage_scenario::Scenario::paper())
        .lag(rig.t)
        .unwrap();
    let mut c = Learning::with_law(rig.baseline(), law)
        .unwrap()
        .with_sensor_lag(lag)
        .unwrap();
    let rms = rig.rms(&mut c, trials);
    let (first, last) = (rms[0], rms[trials - 1]);
    (0..2).map(|a| (last[a] / first[a]).powi(2)).sum()
}

/// Goal: where both laws have a design, the one [`choose_law`] keeps from the readings has
/// the smaller true-output error after the trials (within 5 %: the readings' error differs
/// from the output's by the noise the loop feeds back).
#[test]
fn the_law_chosen_on_the_readings_is_the_better_on_the_output() {
    let rig = LumpedRig::paper();
    let plant = rig.learning_plant(MEASURE_PERIODS);
    let settings = DesignParams::default();
    let lead = Law::PhaseLead(design(&plant, &settings).unwrap().0);
    let inverse = Law::Inverse(design_inverse(&plant, &settings).unwrap().0);
    let lag = SensorDatasheet::from_scenario(&flexstage_scenario::Scenario::paper())
        .lag(rig.t)
        .unwrap();
    let trials = 6;
    let (chosen, _) = choose_law(&mut rig.loops(), &plant, &settings, lag, trials).unwrap();
    let (s_lead, s_inverse) = (
        true_score(&rig, &lead, trials),
        true_score(&rig, &inverse, trials),
    );
    let (mine, other) = match chosen {
        Law::PhaseLead(_) => (s_lead, s_inverse),
        Law::Inverse(_) => (s_inverse, s_lead),
    };
    assert!(
        mine <= 1.05 * other,
        "chose {}: true score {mine:.4} against {other:.4}",
        chosen.name()
    );
}
