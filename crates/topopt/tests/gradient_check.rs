//! Reference: adjoint sensitivities of discretized nonlinear equilibrium (Buhl, Pedersen &
//! Sigmund 2000) through a density filter and Heaviside projection (Wang, Lazarov & Sigmund
//! 2011). Goal (issue #5): relative error ≤ 1e-5 between the adjoint gradients and central
//! finite differences for the workspace area J, the strain energy Σ and the input strokes,
//! on a small nonlinear mesh with the additive Yeoh material on, for a tilted reversed setup.

use flexstage_fem::AdditiveYeoh;
use flexstage_scenario::{Configuration, Preset, Scenario};
use flexstage_topopt::{Problem, Projection, check::check_gradients};

#[test]
fn adjoint_matches_central_differences_nonlinear_with_additive_material() {
    let mut s = Scenario::preset(Preset::Quick);
    s.mesh.nl = 16;
    s.mesh.nw = 8;
    s.regions.clear();
    s.optimization.samples = 8;
    s.output.tilt_deg = 20.0;
    s.actuators.configuration = Configuration::Reversed;
    // Large strokes so that the geometric nonlinearity matters.
    s.actuators.stroke_amplitude = 3e-4;
    s.actuators.max_stroke = 1e-3;
    let problem = Problem::from_scenario(&s, None).unwrap();
    let ne = problem.mesh().n_elements();
    let yeoh = AdditiveYeoh::uniform(ne, 1e5, 1e8);
    let n = problem.design_elements().len();
    let x: Vec<f64> = (0..n)
        .map(|j| 0.3 + 0.6 * (0.5 + 0.5 * (j as f64 * 0.77).sin()))
        .collect();
    let proj = Projection {
        beta: 2.0,
        eta: 0.5,
    };
    let checks = check_gradients(&problem, 1.5, proj, Some(&yeoh), &x, 10, 1e-6).unwrap();
    for c in &checks {
        println!(
            "{:>14}: relative error {:.2e} (scale {:.3e})",
            c.name, c.relative_error, c.scale
        );
    }
    assert_eq!(checks.len(), 5);
    for c in &checks {
        assert!(c.scale > 0.0, "{} has a zero gradient", c.name);
        assert!(c.relative_error <= 1e-5, "{c:?}");
    }
}
