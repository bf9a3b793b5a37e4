//! Reference: objectivity of the total Lagrangian formulation (e.g. Belytschko, Liu & Moran,
//! "Nonlinear Finite Elements for Continua and Structures", 2000, §3.x; Bonet & Wood 2008 §6).
//! Goal: rigid translations (both kinematics) and finite rigid rotations (TL, SVK + additive Yeoh)
//! produce zero internal force and zero strain energy; a control check shows the linear
//! kinematics does *not* pass the finite-rotation case (so the test can fail).

use flexstage_fem::*;

fn setup(kin: Kinematics) -> (Model, Vec<f64>, AdditiveYeoh) {
    let mesh = Mesh::new(0.12, 0.06, 0.01, 12, 6).unwrap();
    let n = mesh.n_elements();
    let model = Model::new(mesh, Material::paper(), kin, BoundaryConditions::new()).unwrap();
    let rho = samples::random_vector(n, 0.0, 1.0, 7);
    let yeoh = AdditiveYeoh::uniform(n, 1e5, 3e6);
    (model, rho, yeoh)
}

fn rigid(model: &Model, t: [f64; 2], angle: f64) -> Vec<f64> {
    let (s, c) = angle.sin_cos();
    let mut u = model.zero_vector();
    for n in 0..model.mesh().n_nodes() {
        let x = model.mesh().node_coords(n);
        u[2 * n] = t[0] + (c - 1.0) * x[0] - s * x[1];
        u[2 * n + 1] = t[1] + s * x[0] + (c - 1.0) * x[1];
    }
    u
}

fn max_force(model: &Model, design: &Design, u: &[f64]) -> f64 {
    let mut r = model.zero_vector();
    let mut ws = model.new_workspace();
    model.residual(design, u, &mut r, &mut ws);
    r.iter().fold(0.0f64, |a, b| a.max(b.abs()))
}

#[test]
fn rigid_translation_gives_no_force_both_kinematics() {
    for kin in [Kinematics::Linear, Kinematics::TotalLagrangian] {
        let (model, rho, yeoh) = setup(kin);
        let design = Design::with_yeoh(&rho, &yeoh);
        let u = rigid(&model, [1e-3, -2e-3], 0.0);
        let f = max_force(&model, &design, &u);
        // Scale: force of a 1e-3 strain on one element edge.
        let scale = 73e9 * 1e-3 * 0.006 * 0.01;
        assert!(f <= 1e-12 * scale, "{kin:?}: {f}");
    }
}

#[test]
fn finite_rigid_rotation_gives_no_force_total_lagrangian() {
    let (model, rho, yeoh) = setup(Kinematics::TotalLagrangian);
    let design = Design::with_yeoh(&rho, &yeoh);
    let scale = 73e9 * 0.006 * 0.01; // force of a unit strain on one element edge
    for angle in [0.3, 1.0, 2.5] {
        let u = rigid(&model, [0.01, 0.02], angle);
        let f = max_force(&model, &design, &u);
        assert!(f <= 1e-12 * scale, "angle {angle}: max force {f}");
        let w = model.strain_energy(&design, &u);
        assert!(w.abs() <= 1e-12 * scale * 0.1, "angle {angle}: energy {w}");
    }
}

#[test]
fn control_linear_kinematics_is_not_rotation_invariant() {
    let (model, rho, _) = setup(Kinematics::Linear);
    let design = Design::new(&rho);
    let u = rigid(&model, [0.0, 0.0], 0.3);
    let scale = 73e9 * 0.006 * 0.01;
    assert!(max_force(&model, &design, &u) > 1e-4 * scale);
}
