//! Reference: adjoint sensitivity of a discretized nonlinear equilibrium (Buhl, Pedersen &
//! Sigmund 2000, "Stiffness design of geometrically nonlinear structures using topology
//! optimization", SMO 19; paper Eq. (9)–(13) with the exact ∂R/∂ρ as required by DECISIONS.md).
//! Goal: d u_out/dρ_e = −λᵀ ∂R/∂ρ_e with K_T λ = L_o (factor of the converged tangent) matches
//! central finite differences of full Newton re-solves, with the additive Yeoh material on, and
//! the same gradient obtained with PCG (a factor of another design as preconditioner) agrees.

use flexstage_fem::*;

#[test]
fn adjoint_output_gradient_matches_finite_differences() {
    let stage = samples::Stage::paper(12, 6, Kinematics::TotalLagrangian).unwrap();
    let model = &stage.model;
    let ne = model.mesh().n_elements();
    let rho = stage.random_density(0.2, 0.9, 5, 1e-3);
    let yeoh = AdditiveYeoh::uniform(ne, 1e5, 1e8);
    let design = Design::with_yeoh(&rho, &yeoh);
    let load = stage.pea_load(600e-6, -600e-6); // large enough to be clearly nonlinear
    let sym = SymbolicFactor::new(model.pattern().clone()).unwrap();
    let mut ws = NewtonWorkspace::new(model, sym.clone());
    let params = NewtonParams {
        residual_tol: 1e-13,
        displacement_tol: 1e-12,
        ..Default::default()
    };
    let out = 2 * stage.output + 1;
    let solve = |rho: &[f64], ws: &mut NewtonWorkspace| {
        let mut u = model.zero_vector();
        newton::solve(
            model,
            &Design::with_yeoh(rho, &yeoh),
            &load,
            &mut u,
            &params,
            ws,
            None,
        )
        .unwrap();
        u
    };
    let u = solve(&rho, &mut ws);
    // Factor of the converged tangent for the exact adjoint.
    ws.factorize_tangent().unwrap();
    let mut l_o = model.zero_vector();
    l_o[out] = 1.0;
    let mut lambda = model.zero_vector();
    let mut tmp = vec![0.0; model.dofs().n_free()];
    ws.factor
        .solve_full(model.dofs(), &l_o, &mut lambda, &mut tmp, &mut ws.solve_ws)
        .unwrap();
    let mut grad = vec![0.0; ne];
    model.contract_drho(&design, &u, &lambda, &mut grad);
    grad.iter_mut().for_each(|g| *g = -*g);

    // Same adjoint by PCG preconditioned with the factor of a different design.
    let rho2: Vec<f64> = rho.iter().map(|r| (r * 1.2).min(1.0)).collect();
    let d2 = Design::with_yeoh(&rho2, &yeoh);
    let mut k2 = model.new_matrix();
    let mut aws = model.new_workspace();
    model.assemble(&d2, &model.zero_vector(), None, Some(&mut k2), &mut aws);
    let mut f2 = Factor::new(sym.clone());
    f2.factorize(&k2).unwrap();
    let mut b = vec![0.0; model.dofs().n_free()];
    model.dofs().gather(&l_o, &mut b);
    let mut x = vec![0.0; b.len()];
    let mut pws = PcgWorkspace::new(b.len());
    let rep = pcg(
        &ws.tangent,
        &f2,
        &b,
        &mut x,
        PcgParams {
            rel_tol: 1e-12,
            max_iter: 100,
        },
        &mut pws,
        &mut ws.solve_ws,
    )
    .unwrap();
    assert!(rep.iterations > 1 && rep.iterations < 60, "{rep:?}");
    let mut lambda2 = model.zero_vector();
    model.dofs().scatter(&x, &mut lambda2);
    let err: f64 = lambda
        .iter()
        .zip(&lambda2)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let scale = lambda.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    assert!(
        err < 1e-8 * scale,
        "PCG adjoint differs: {err:e} vs {scale:e}"
    );

    // Central differences on a handful of design elements.
    let h = 1e-5;
    let mut checked = 0;
    let design_elems: Vec<usize> = (0..ne)
        .filter(|&e| model.mesh().passive[e] == Passive::Design)
        .collect();
    for &e in design_elems.iter().step_by(design_elems.len() / 8) {
        let mut rp = rho.clone();
        let mut rm = rho.clone();
        rp[e] += h;
        rm[e] -= h;
        let fd = (solve(&rp, &mut ws)[out] - solve(&rm, &mut ws)[out]) / (2.0 * h);
        let scale = grad.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        assert!(
            (fd - grad[e]).abs() < 1e-5 * scale,
            "element {e}: adjoint {} vs FD {fd}",
            grad[e]
        );
        checked += 1;
    }
    assert!(checked >= 6);
}
