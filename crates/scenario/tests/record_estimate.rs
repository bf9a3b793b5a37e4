//! Reference: the input-bounds and fault-handling requirements, "memory and time are estimated up front (… sample counts, record
//! lengths) and refused over a documented limit with a message giving the estimate".
//! Goal: a record's samples, plant steps, twin mode-steps and memory are the products they are
//! documented as (hand-computed below); each limit refuses just above it and passes just below
//! it, with the option named and the estimate in the message; the quick preset's own
//! trajectories pass.

use flexstage_scenario::{Preset, RecordEstimate, Scenario, TRACK_COLUMNS, limit};

#[test]
fn hand_computed_products() {
    let e = RecordEstimate::new(2.0, 1e-4, 20, 16, TRACK_COLUMNS);
    assert_eq!(e.samples, 2e4);
    assert_eq!(e.steps, 4e5);
    assert_eq!(e.mode_steps, 6.4e6);
    assert_eq!(e.bytes, 2e4 * 23.0 * 8.0);
    e.check("track.duration", 2.0, limit::MIN_TRACK_SAMPLES)
        .unwrap();
}

#[test]
fn each_limit_refuses_above_and_names_the_option() {
    let cases = [
        // samples: 600 s at 1e-7 s.
        (RecordEstimate::new(600.0, 1e-7, 1, 0, 7), "6.000e9 samples"),
        // plant steps: 1e7 samples × 21 substeps > 2e8.
        (
            RecordEstimate::new(1e3, 1e-4, 21, 0, 7),
            "2.100e8 plant steps",
        ),
        // mode-steps: 1e7 × 20 × 51 > 1e10.
        (
            RecordEstimate::new(1e3, 1e-4, 20, 51, 7),
            "1.020e10 mode-steps",
        ),
        // memory: 1e7 samples × 3000 columns × 8 bytes > 2 GiB.
        (RecordEstimate::new(1e3, 1e-4, 1, 0, 3000), "223.517 GiB"),
        // too short: 1e-308 s is 0 samples.
        (
            RecordEstimate::new(1e-308, 1e-4, 20, 16, 23),
            "at least 10 samples",
        ),
    ];
    for (e, what) in cases {
        let msg = e
            .check("track.duration", 1.0, limit::MIN_TRACK_SAMPLES)
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("track.duration") && msg.contains(what),
            "{what}: {msg}"
        );
    }
    // Just below every limit: 1e7 samples, 20 substeps, 50 modes, 20 columns.
    RecordEstimate::new(1e3, 1e-4, 20, 50, 20)
        .check("track.duration", 1e3, limit::MIN_TRACK_SAMPLES)
        .unwrap();
}

#[test]
fn quick_and_paper_preset_trajectories_pass() {
    for p in [Preset::Quick, Preset::Paper] {
        Scenario::preset(p).validate().unwrap();
    }
}
