//! Reference: adjoint sensitivities of discretized nonlinear equilibrium (Buhl, Pedersen &
//! Sigmund 2000) through a density filter and Heaviside projection (Wang, Lazarov & Sigmund
//! 2011), for every response of the eroded, blueprint and dilated designs of the robust
//! formulation, including the aggregated qp-relaxed von Mises stress (Le et al. 2010) and the
//! volume, with mirror-symmetric design variables.
//! Goal: relative error ≤ 1e-5 between the adjoint gradients and central
//! finite differences, on small nonlinear meshes: a tilted reversed set-up (tilt, no symmetry)
//! with the additive Yeoh material on, and the robust, symmetric, stress-constrained default
//! without it.

use flexstage_fem::AdditiveYeoh;
use flexstage_scenario::{Configuration, Preset, Scenario};
use flexstage_topopt::check::{CheckSetup, check_gradients};
use flexstage_topopt::{DesignSpace, Problem, RobustThresholds};

fn small(mut s: Scenario) -> Scenario {
    s.mesh.nl = 16;
    s.mesh.nw = 8;
    s.regions.clear();
    s.optimization.samples = 8;
    // Large strokes so that the geometric nonlinearity matters.
    s.actuators.stroke_amplitude = 3e-4;
    s.actuators.max_stroke = 1e-3;
    s
}

fn check(s: &Scenario, robust: Option<RobustThresholds>, additive: bool, expected: usize) {
    let problem = Problem::from_scenario(s, None).unwrap();
    let ne = problem.mesh().n_elements();
    let yeoh = additive.then(|| AdditiveYeoh::uniform(ne, 1e5, 1e8));
    let n = DesignSpace::new(problem.mesh(), problem.mirror_symmetry)
        .unwrap()
        .n();
    let x: Vec<f64> = (0..n)
        .map(|j| 0.3 + 0.6 * (0.5 + 0.5 * (j as f64 * 0.77).sin()))
        .collect();
    let setup = CheckSetup {
        filter_radius: 1.5,
        robust,
        eta: 0.5,
        beta: 2.0,
    };
    let checks = check_gradients(&problem, &setup, yeoh.as_ref(), &x, 10, 1e-6).unwrap();
    for c in &checks {
        println!(
            "{:>24}: relative error {:.2e} (scale {:.3e})",
            c.name, c.relative_error, c.scale
        );
    }
    assert_eq!(checks.len(), expected);
    for c in &checks {
        assert!(c.scale > 0.0, "{} has a zero gradient", c.name);
        assert!(c.relative_error <= 1e-5, "{c:?}");
    }
}

#[test]
fn adjoint_matches_central_differences_tilted_reversed() {
    let mut s = small(Scenario::preset(Preset::Quick));
    s.output.tilt_deg = 20.0;
    s.optimization.mirror_symmetry = false;
    s.actuators.configuration = Configuration::Reversed;
    // objective, energy, stroke, tilt, stress, volume on the blueprint.
    check(&s, None, true, 6);
}

#[test]
fn adjoint_matches_central_differences_robust_symmetric_with_stress() {
    let s = small(Scenario::preset(Preset::Quick));
    let robust = RobustThresholds {
        eroded: 0.6,
        dilated: 0.4,
    };
    // eroded: objective, stress; blueprint: objective, energy, stroke; dilated: objective,
    // volume. Without the additive material (the default): the contraction with the stored
    // element forces.
    check(&s, Some(robust), false, 7);
}

/// A general mechanism from TOML (`examples/scenarios/gripper.toml` at 16 × 8), nonlinear,
/// robust, with the energy bound on and an oblique output direction (the output spring a link
/// spring on d · u_out): eroded, blueprint and dilated d · u_out, the blueprint's energy and
/// the dilated volume.
#[test]
fn adjoint_matches_central_differences_nonlinear_mechanism_from_toml() {
    let text = include_str!("../../../examples/scenarios/gripper.toml");
    let mut s = Scenario::from_toml_str(text, "gripper.toml").unwrap();
    s.mesh.nl = 16;
    s.mesh.nw = 8;
    s.optimization.kinematics = flexstage_scenario::KinematicsKind::Nonlinear;
    s.optimization.energy_constraint = true;
    s.output.direction = Some([0.6, 0.8]);
    // u_out ≈ 0.2 on the 4 × 2 domain: geometric nonlinearity matters.
    s.ports[0].force = Some(0.2);
    s.validate().unwrap();
    let robust = RobustThresholds {
        eroded: 0.6,
        dilated: 0.4,
    };
    check(&s, Some(robust), false, 5);
}

/// The robust, symmetric, stress-constrained default with a first-frequency bound: the
/// resonance aggregate of the eroded design and the blueprint (the stage's eigenproblem with
/// the PEA plates and a payload, on each realization's factorization through the spring
/// update) through the
/// projection, the filter and the symmetric design variables, besides every other response.
#[test]
fn adjoint_matches_central_differences_with_a_resonance_bound() {
    let mut s = small(Scenario::preset(Preset::Quick));
    s.optimization.min_frequency = 3000.0;
    s.output.payload = 0.02;
    let robust = RobustThresholds {
        eroded: 0.6,
        dilated: 0.4,
    };
    check(&s, Some(robust), false, 9);
}

/// The PEA ports over their faces (the port patches of the presets, here 2 elements of 7.5 mm
/// beside each input): the PEA springs are link springs on the faces' weighted means, the
/// loads uniform tractions, the strokes and the workspace read the faces' means; with the
/// resonance bound (the plates' springs and masses over the faces).
#[test]
fn adjoint_matches_central_differences_with_pea_faces() {
    use flexstage_scenario::{Region, RegionKind, Selector};
    let mut s = small(Scenario::preset(Preset::Quick));
    let (l, w, h) = (s.mesh.length, s.mesh.width, s.mesh.length / 16.0);
    let solid = |min: [f64; 2], max: [f64; 2]| Region {
        kind: RegionKind::Solid,
        at: Selector::Box { min, max },
    };
    s.regions = vec![
        solid([0.0, 0.5 * w - 1.25 * h], [2.0 * h, 0.5 * w + 1.25 * h]),
        solid([l - 2.0 * h, 0.5 * w - 1.25 * h], [l, 0.5 * w + 1.25 * h]),
    ];
    s.optimization.min_frequency = 3000.0;
    let problem = Problem::from_scenario(&s, None).unwrap();
    assert!(problem.inputs.iter().all(|p| p.face.len() == 3));
    let robust = RobustThresholds {
        eroded: 0.6,
        dilated: 0.4,
    };
    check(&s, Some(robust), false, 9);
}
