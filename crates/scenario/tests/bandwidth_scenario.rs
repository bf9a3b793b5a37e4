//! The shipped scenario of the design for bandwidth (`examples/scenarios/paper-bandwidth.toml`)
//! is the paper preset with the fields its header names changed, and nothing else: the result
//! recorded in docs/verification.md is reproducible from the preset and those fields.

use flexstage_scenario::{Preset, Scenario};

const BANDWIDTH: &str = include_str!("../../../examples/scenarios/paper-bandwidth.toml");

#[test]
fn the_bandwidth_example_is_the_paper_preset_with_four_fields_changed() {
    let s = Scenario::from_toml_str(BANDWIDTH, "paper-bandwidth.toml").unwrap();
    let mut expected = Scenario::preset(Preset::Paper);
    expected.name = "paper-bandwidth".into();
    expected.optimization.min_frequency = 6350.0;
    expected.optimization.max_iterations = 500;
    expected.limits.min_hinge_thickness = 1.5e-3;
    expected.limits.mesh_stress_factor = 2.2;
    assert_eq!(s, expected);
}
