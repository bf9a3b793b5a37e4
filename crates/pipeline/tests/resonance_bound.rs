//! Reference: the design stage's promise that a run which does not deliver what the scenario
//! asked for says so (DECISIONS.md, "Design for bandwidth"). Goal, on a 24 × 12 quick stage:
//! a first-frequency bound the loop cannot reach in three iterations ends with one warning
//! that names `optimization.min_frequency`, the bound and the design's frequency in Hz; a bound far
//! below the design's frequency, and no bound, end without one.

mod common;

use flexstage_pipeline::design::BOUND_TOLERANCE;
use flexstage_pipeline::{DesignOptions, DesignStart, RunFolder, Silent, design};

/// The warnings about the first-frequency bound of a 3-iteration design of the tiny stage with
/// `min_frequency` \[Hz\], and its first natural frequency.
fn warnings(min_frequency: f64, tag: &str) -> (Vec<String>, f64) {
    let dir = std::env::temp_dir().join(format!("flexstage-bound-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut s = common::tiny();
    s.optimization.min_frequency = min_frequency;
    let folder = RunFolder::open(s, &dir, false).unwrap();
    let options = DesignOptions {
        max_iterations: Some(3),
        ..DesignOptions::default()
    };
    let d = design(
        &folder,
        &options,
        DesignStart::Fresh { force: false },
        &Silent,
    )
    .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    let bound = d
        .warnings
        .into_iter()
        .filter(|w| w.contains("optimization.min_frequency"))
        .collect();
    (bound, d.design.first_frequency_hz.unwrap())
}

#[test]
fn an_unmet_first_frequency_bound_is_reported() {
    let (none, f) = warnings(0.0, "none");
    assert!(none.is_empty(), "{none:?}");
    let (met, _) = warnings(0.5 * f, "met");
    assert!(met.is_empty(), "{met:?}");
    let (unmet, g) = warnings(3.0 * f, "unmet");
    assert!(
        g < (1.0 - BOUND_TOLERANCE) * 3.0 * f,
        "{g} Hz met the bound"
    );
    assert_eq!(unmet.len(), 1, "{unmet:?}");
    assert!(
        unmet[0].contains("optimization.min_frequency")
            && unmet[0].contains(&format!("{:.0} Hz", 3.0 * f))
            && unmet[0].contains(&format!("{g:.0} Hz")),
        "{}",
        unmet[0]
    );
}
