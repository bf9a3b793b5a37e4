//! Reference: recursive least squares (Ljung, *System Identification*, 2nd ed., §11.2): with
//! an initial covariance P₀ → 0 the gain P φ/(1 + φᵀPφ) vanishes and θ never leaves θ₀; a
//! record in the wrong unit (µm read as m) scales every stiffness estimate by the unit factor.
//! Goal: an identification stuck at its guess, non-finite or outside physical
//! bounds (a stiffness more than `PLAUSIBLE_FACTOR` from its guess) is refused with a message,
//! never written; the same record identified normally passes (so the guards can fail).

use flexstage_identify::{IdentifyError, IdentifyParams, identify, samples, simulate};

fn message(r: Result<flexstage_identify::Identification, IdentifyError>) -> String {
    match r {
        Ok(id) => panic!("expected a refusal, got {:?}", id.raw.params),
        Err(e) => e.to_string(),
    }
}

#[test]
fn ljung_sound_record_passes_the_guards() {
    let record = simulate(&samples::paper_simulation(0.5, true, false)).unwrap();
    identify(
        &record,
        &samples::table4_guess(),
        &IdentifyParams::default(),
    )
    .unwrap();
}

#[test]
fn ljung_zero_initial_covariance_is_stuck_at_the_guess() {
    let record = simulate(&samples::paper_simulation(0.5, true, false)).unwrap();
    let params = IdentifyParams {
        initial_covariance: 1e-300,
        ..IdentifyParams::default()
    };
    let msg = message(identify(&record, &samples::table4_guess(), &params));
    assert!(msg.contains("initial guess to round-off"), "{msg}");
}

#[test]
fn ljung_wrong_unit_record_is_outside_physical_bounds_or_refused() {
    // The outputs recorded in µm (×1e6) against inputs in m: the gains of the output rows
    // change by 1e6, and the stiffness estimates leave the plausible band around the guess.
    let mut record = simulate(&samples::paper_simulation(0.5, true, false)).unwrap();
    for q in record.q.iter_mut() {
        q.iter_mut().for_each(|v| *v *= 1e6);
    }
    let msg = message(identify(
        &record,
        &samples::table4_guess(),
        &IdentifyParams::default(),
    ));
    assert!(
        msg.contains("either side of the guess") || msg.contains("not a positive stiffness"),
        "{msg}"
    );
}

#[test]
fn ljung_non_finite_estimate_is_refused() {
    // A record whose outputs overflow to ∞ in the regression (finite, but 1e300 m).
    let mut record = simulate(&samples::paper_simulation(0.5, true, false)).unwrap();
    for q in record.q.iter_mut() {
        q.iter_mut().for_each(|v| *v *= 1e300);
    }
    let r = identify(
        &record,
        &samples::table4_guess(),
        &IdentifyParams::default(),
    );
    let msg = message(r);
    assert!(
        msg.contains("diverged")
            || msg.contains("not a positive")
            || msg.contains("not finite")
            || msg.contains("guess"),
        "{msg}"
    );
}

/// The second hardening review: stage identification on a record whose x_nom1 is 1e300 times too large returned
/// k_in1, k_pea1 and c_in1 exactly at the guess with exit 0 (only the x_in1 row was stuck; the
/// guard needed every row stuck). The record itself is now refused by its range, and a row
/// stuck at the guess is refused by name even when the others moved.
#[test]
fn ljung_one_row_stuck_at_the_guess_is_refused_by_name() {
    let mut record = simulate(&samples::paper_simulation(0.5, true, false)).unwrap();
    record.x_nom[0].iter_mut().for_each(|v| *v *= 1e300);
    let msg = message(identify(
        &record,
        &samples::table4_guess(),
        &IdentifyParams::default(),
    ));
    assert!(
        msg.contains("x_in1") && msg.contains("initial guess"),
        "{msg}"
    );
    assert!(!msg.contains("q_o1") && !msg.contains("x_in2"), "{msg}");
    let e = flexstage_identify::StageRecord::new(
        record.t.clone(),
        record.x_nom.clone(),
        record.x_in.clone(),
        record.q.clone(),
        None,
        1e-3,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("x_nom1[0]") && e.contains("beyond ±1 m"), "{e}");
}
