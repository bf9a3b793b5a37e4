//! Reference: Timoshenko beam theory for a cantilever with a tip load (Timoshenko & Gere,
//! "Mechanics of Materials"; Timoshenko & Goodier, "Theory of Elasticity", 1951, §21):
//! δ = P L³/(3 E I) + P L/(κ G A), κ = 5/6.
//! Goal: the linear Q4 tip deflection converges to the beam-theory value as the mesh is refined
//! (errors decrease monotonically, finest mesh within 1.5 %). Full-integration Q4 locks in
//! bending, so the coarse meshes are visibly too stiff — which is what makes the test meaningful.

use flexstage_fem::*;

#[test]
fn linear_tip_deflection_converges_to_timoshenko() {
    let mat = Material {
        e0: 2.0e11,
        e_min: 1.0,
        nu: 0.3,
        penalty: 3.0,
    };
    let (l, h, t) = (1.0, 0.1, 0.01);
    let p = -1000.0;
    let mut errors = Vec::new();
    for (nl, nw) in [(10, 1), (20, 2), (40, 4), (80, 8), (160, 16)] {
        let c = samples::Cantilever::new(mat, Kinematics::Linear, l, h, t, nl, nw).unwrap();
        let model = &c.model;
        let rho = vec![1.0; model.mesh().n_elements()];
        let design = Design::new(&rho);
        let sym = SymbolicFactor::new(model.pattern().clone()).unwrap();
        let mut ws = NewtonWorkspace::new(model, sym);
        let mut u = model.zero_vector();
        newton::solve(
            model,
            &design,
            &c.tip_load(0.0, p),
            &mut u,
            &NewtonParams::default(),
            &mut ws,
            None,
        )
        .unwrap();
        // Mean tip deflection over the end section.
        let tip: f64 = c.tip_weights.iter().map(|&(n, w)| w * u[2 * n + 1]).sum();
        let exact = c.timoshenko_tip_deflection(p);
        errors.push(((tip - exact) / exact).abs());
    }
    eprintln!("relative errors: {errors:?}");
    for w in errors.windows(2) {
        assert!(
            w[1] < w[0],
            "error must decrease with refinement: {errors:?}"
        );
    }
    assert!(
        errors[0] > 0.1,
        "coarse mesh should show locking: {errors:?}"
    );
    assert!(
        *errors.last().unwrap() < 0.015,
        "finest mesh error too large: {errors:?}"
    );
}
