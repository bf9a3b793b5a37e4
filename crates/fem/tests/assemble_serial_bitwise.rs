//! Reference: `Model::assemble` (parallel element kernels, then the scatter of the element
//! matrices in element order), the assembly every other test checks against analytical answers
//! and central differences.
//! Goal: `Model::assemble_serial` (one thread, each element's tangent scattered as soon as it is
//! computed) returns the same residual and tangent bit for bit, with and without the additive
//! material and for both kinematics, on the paper's stage with springs at the inputs, at a
//! finite-strain state; and the residual-only call matches too.

use flexstage_fem::*;

fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

#[test]
fn assemble_serial_is_bitwise_assemble() {
    for kinematics in [Kinematics::TotalLagrangian, Kinematics::Linear] {
        let stage = samples::Stage::paper(24, 12, kinematics).unwrap();
        let model = &stage.model;
        let rho = stage.random_density(0.01, 1.0, 7, 1e-3);
        // A large, non-smooth displacement field (finite strains everywhere).
        let u: Vec<f64> = samples::random_vector(model.n_dofs(), -2e-4, 2e-4, 11);
        let yeoh = AdditiveYeoh::paper(model.mesh().n_elements(), 73e9, 1e-6, 3.0);
        for design in [Design::new(&rho), Design::with_yeoh(&rho, &yeoh)] {
            let (mut r1, mut r2) = (model.zero_vector(), model.zero_vector());
            let (mut k1, mut k2) = (model.new_matrix(), model.new_matrix());
            let (mut w1, mut w2) = (model.new_workspace(), model.new_workspace());
            model.assemble(&design, &u, Some(&mut r1), Some(&mut k1), &mut w1);
            model.assemble_serial(&design, &u, Some(&mut r2), Some(&mut k2), &mut w2);
            assert!(same_bits(&r1, &r2), "{kinematics:?}: residual");
            assert!(
                same_bits(k1.values(), k2.values()),
                "{kinematics:?}: tangent"
            );
            assert!(
                w1.element_residuals()
                    .iter()
                    .zip(w2.element_residuals())
                    .all(|(a, b)| same_bits(a, b)),
                "{kinematics:?}: element residuals"
            );
            // The tangent must not be trivially zero (a test that cannot fail is a defect).
            assert!(k2.values().iter().any(|v| *v != 0.0));
            let mut r3 = model.zero_vector();
            model.assemble_serial(&design, &u, Some(&mut r3), None, &mut w2);
            assert!(same_bits(&r1, &r3), "{kinematics:?}: residual only");
        }
    }
}
