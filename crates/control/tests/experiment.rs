//! Reference: Section 4.2 and Figures 9–11 (robust vs non-robust on the 3:1 Lissajous curve),
//! Section 3.1 (hysteresis compensation), DECISIONS.md (baselines: non-robust controller, PID
//! with inverse-hysteresis feedforward).
//! Goal: on the full simulated plant with the default scenario and 3:1 Lissajous curve, the
//! robust controller's RMS error is within 10 % of the non-robust one's (the scenario's
//! ρ_η = 0.1 m/s² is tiny next to what the disturbance observer leaves, so Figure 9's gap
//! is not reproduced: DECISIONS.md) and well below the PID + feedforward
//! baseline's, and switching the hysteresis compensation off makes the error grow. The
//! margins are printed (run with --nocapture).

use flexstage_control::actuator::Compensation;
use flexstage_control::controller::{NONROBUST, ROBUST};
use flexstage_control::experiment::{Setup, experiment};
use flexstage_control::pid::PID_FF;
use flexstage_control::registry::Controller;
use flexstage_scenario::Scenario;
use flexstage_sim::experiment::Metrics;
use flexstage_sim::trajectory::Reference;

const DURATION: f64 = 0.5;

fn metrics(variant: &Controller, compensation: Compensation) -> Metrics {
    let s = Scenario::paper();
    let setup = Setup::from_scenario(&s);
    let (r, _) = Reference::from_scenario(&s.trajectories[0]);
    let rec = experiment(&setup, variant, compensation, r, DURATION).unwrap();
    let m = rec.metrics(r.half_range(DURATION, 1e-4));
    eprintln!(
        "{:9} {:?}: RMS {:.1} / {:.1} nm, max {:.1} / {:.1} nm, combined RMS {:.2} nm, V {:.0}–{:.0}",
        variant.name,
        compensation,
        m.rms[0] * 1e9,
        m.rms[1] * 1e9,
        m.max[0] * 1e9,
        m.max[1] * 1e9,
        m.rms_total() * 1e9,
        m.min_voltage,
        m.peak_voltage
    );
    m
}

#[test]
fn robust_matches_non_robust_and_beats_pid_feedforward() {
    let robust = metrics(&ROBUST, Compensation::Inverse);
    let nonrobust = metrics(&NONROBUST, Compensation::Inverse);
    let pid = metrics(&PID_FF, Compensation::Inverse);
    let margin = |other: &Metrics| 100.0 * (1.0 - robust.rms_total() / other.rms_total());
    eprintln!(
        "robust RMS lower by {:.1} % than non-robust, {:.1} % than PID + FF",
        margin(&nonrobust),
        margin(&pid)
    );
    assert!(robust.rms_total() < 1.1 * nonrobust.rms_total());
    // 0.6 with the K-filter's fast disturbance estimate (κ_d = 3e4 s⁻¹); the Kalman
    // estimate's slower, noise-aware one gives ≈ 0.61 here (20.9 vs 34.1 nm).
    assert!(robust.rms_total() < 0.7 * pid.rms_total());
    for m in [&robust, &nonrobust, &pid] {
        assert_eq!(m.saturated, 0);
        assert!(m.peak_voltage <= 1000.0 && m.min_voltage >= 0.0);
    }
}

#[test]
fn without_hysteresis_compensation_the_error_grows() {
    for variant in [&ROBUST, &PID_FF] {
        let on = metrics(variant, Compensation::Inverse);
        let off = metrics(variant, Compensation::Off);
        eprintln!(
            "{}: compensation off multiplies the RMS error by {:.1}",
            variant.name,
            off.rms_total() / on.rms_total()
        );
        assert!(off.rms_total() > 2.0 * on.rms_total());
    }
}
