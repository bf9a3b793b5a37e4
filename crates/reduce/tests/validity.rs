//! Reference: paper Section 3.2.1 — the reduced model is a tangent-space approximation
//! (Eq. 24, 29); the acceptance figure: within the stroke on the default design the
//! reduced static prediction agrees with nonlinear FE to within 2 %.
//! Goal: (1) on the default design (uniform initial density of `flexstage design`, quick
//! preset mesh) the kinematic prediction α_abs·x_in is within 2 % of the total-Lagrangian FE
//! output over the p_m perimeter samples at full stroke; (2) the error is a geometric
//! nonlinearity, so it scales linearly with the stroke amplitude (ratio of errors at ¼ and
//! full stroke ≈ ¼), which is what makes the map able to locate the breakdown.

use flexstage_reduce::{Ports, ValidityParams, condense, samples, validity_map};
use flexstage_scenario::Preset;

#[test]
fn default_design_within_two_percent_and_error_linear_in_stroke() {
    let (_s, problem) = samples::stage(Preset::Quick).unwrap();
    let rho = samples::default_design(&problem);
    let ports = Ports::from_problem(&problem).unwrap();
    let c = condense(
        &problem.model,
        &flexstage_fem::Design::new(&rho),
        ports,
        None,
    )
    .unwrap();
    let params = ValidityParams {
        scales: vec![0.25, 0.5, 1.0],
        ..ValidityParams::default()
    };
    let map = validity_map(&problem, &rho, &c, &params).unwrap();
    for s in &map.scales {
        println!(
            "scale {:.2}: radius {:.3} um, max error {:.4} %, rms {:.4} %, linear-FE max {:.4} %",
            s.scale,
            s.radius * 1e6,
            100.0 * s.max_error,
            100.0 * s.rms_error,
            100.0 * s.max_error_linear
        );
    }
    assert_eq!(map.samples.len(), 3 * problem.cases.len());
    let e = map.max_error_within_stroke();
    assert!(e < 0.02, "reduced vs nonlinear FE: {:.3} %", 100.0 * e);
    assert!(
        e > 1e-12,
        "no nonlinearity seen at all: the comparison is vacuous"
    );
    let ratio = map.scales[0].max_error / map.scales[2].max_error;
    assert!(
        (0.15..0.35).contains(&ratio),
        "error ratio ¼ / full stroke = {ratio}"
    );
    assert_eq!(map.valid_scale(0.02), 1.0);
}

#[test]
fn rejects_bad_scales() {
    let (_s, problem) = samples::stage(Preset::Quick).unwrap();
    let rho = samples::default_design(&problem);
    let ports = Ports::from_problem(&problem).unwrap();
    let c = condense(
        &problem.model,
        &flexstage_fem::Design::new(&rho),
        ports,
        None,
    )
    .unwrap();
    let params = ValidityParams {
        scales: vec![0.5, 0.25],
        ..ValidityParams::default()
    };
    let e = validity_map(&problem, &rho, &c, &params).unwrap_err();
    assert!(e.to_string().contains("ValidityParams::scales"), "{e}");
}
