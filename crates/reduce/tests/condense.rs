//! Reference: paper Eq. 22–26 (static condensation onto the input displacements and the
//! moving frame) and the exactness of static condensation for the linearized FE model
//! (Guyan 1965, AIAA J. 3:380).
//! Goal: (1) for a left–right symmetric design, α11 = −α12 and α21 = −α22 within round-off
//! in the moving frame of Eq. 22 (and α_abs11 = α_abs12 = ½ in the global frame); (2) the
//! condensed α reproduces the full linear FE output for arbitrary inputs within 1e-9 relative;
//! (3) the output stiffness with the inputs held matches an independent FE model whose inputs
//! (the PEA faces' weighted means) are held by a penalty spring, within 1e-4; (4) the rigid-translation relations hold at a deformed operating point too.

use flexstage_fem::{
    BoundaryConditions, Design, Factor, Kinematics, Model, NewtonParams, NewtonWorkspace,
    SolveWorkspace, SymbolicFactor, newton, samples::random_vector,
};
use flexstage_reduce::{Condenser, Ports, condense, samples};
use flexstage_scenario::Preset;

#[test]
fn symmetric_design_satisfies_eq26() {
    let (_s, problem) = samples::stage(Preset::Quick).unwrap();
    let rho = samples::symmetric_random_design(&problem, 0.05, 1.0, 3);
    let ports = Ports::from_problem(&problem).unwrap();
    let c = condense(&problem.model, &Design::new(&rho), ports, None).unwrap();
    let a = c.alpha;
    let scale = a[1][0].abs();
    println!("alpha_abs = {:?}\nalpha = {:?}", c.alpha_abs, c.alpha);
    assert!(scale > 1e-3, "no amplification: {a:?}");
    assert!(
        (a[0][0] + a[0][1]).abs() <= 1e-10 * scale,
        "α11 + α12: {a:?}"
    );
    assert!(
        (a[1][0] + a[1][1]).abs() <= 1e-10 * scale,
        "α21 + α22: {a:?}"
    );
    // Symmetry: no tilt, α11 = α12 = 0 in the moving frame, ½ in the global frame.
    assert!(a[0][0].abs() <= 1e-10 * scale && a[0][1].abs() <= 1e-10 * scale);
    assert!((c.alpha_abs[0][0] - 0.5).abs() <= 1e-10 && (c.alpha_abs[0][1] - 0.5).abs() <= 1e-10);
    assert!(c.tan_theta().abs() <= 1e-9);
    assert!(c.a_theta_residual() <= 1e-10);
    assert!((c.alpha_scalar() - a[1][0]).abs() <= 1e-12 * scale);
}

#[test]
fn asymmetric_design_tilts_but_keeps_the_moving_frame() {
    // A random design: Eq. 26 (condition i) still holds exactly, the tilt does not vanish.
    let (_s, problem) = samples::stage(Preset::Quick).unwrap();
    let rho = samples::random_design(&problem, 0.05, 1.0, 11);
    let ports = Ports::from_problem(&problem).unwrap();
    let c = condense(&problem.model, &Design::new(&rho), ports, None).unwrap();
    let r = c.eq26_residuals();
    assert!(r[0] <= 1e-9 && r[1] <= 1e-9, "{r:?}");
    assert!(c.tan_theta().abs() > 1e-4, "tan θ = {}", c.tan_theta());
    assert!(c.a_theta_residual() <= 1e-9);
}

#[test]
fn alpha_reproduces_full_linear_fe() {
    // Full linear FE with the PEA springs and forces: K u = P(x_nom). The input DOFs then take
    // some x_in, and the output must equal α_abs x_in exactly (the PEA acts on s only).
    let (_s, problem) = samples::stage(Preset::Quick).unwrap();
    let model = &problem.model;
    let rho = samples::random_design(&problem, 1e-3, 1.0, 5);
    let design = Design::new(&rho);
    let ports = Ports::from_problem(&problem).unwrap();
    let c = condense(model, &design, ports.clone(), None).unwrap();
    let mut k = model.new_matrix();
    let mut aws = model.new_workspace();
    model.assemble(&design, &model.zero_vector(), None, Some(&mut k), &mut aws);
    let sym = SymbolicFactor::new(model.pattern().clone()).unwrap();
    let mut f = Factor::new(sym.clone());
    f.factorize(&k).unwrap();
    let mut sws = SolveWorkspace::new(&sym);
    let mut tmp = vec![0.0; model.dofs().n_free()];
    let xs = random_vector(20, -60e-6, 60e-6, 9);
    let mut worst = 0.0f64;
    for pair in xs.chunks(2) {
        let mut p = model.zero_vector();
        for (port, &x) in problem.inputs.iter().zip(pair) {
            port.add_force(port.stiffness * x, &mut p);
        }
        let mut u = model.zero_vector();
        f.solve_full(model.dofs(), &p, &mut u, &mut tmp, &mut sws)
            .unwrap();
        let x_in = ports.input_displacements(&u);
        let q = [u[2 * ports.output], u[2 * ports.output + 1]];
        let pred = c.predict(x_in);
        let err = (pred[0] - q[0]).hypot(pred[1] - q[1]) / q[0].hypot(q[1]);
        worst = worst.max(err);
    }
    println!("worst relative error {worst:e}");
    assert!(worst < 1e-9, "{worst:e}");
}

#[test]
fn output_stiffness_matches_model_with_fixed_inputs() {
    let (_s, problem) = samples::stage(Preset::Quick).unwrap();
    let model = &problem.model;
    let rho = samples::random_design(&problem, 1e-3, 1.0, 8);
    let design = Design::new(&rho);
    let ports = Ports::from_problem(&problem).unwrap();
    let c = condense(model, &design, ports.clone(), None).unwrap();
    // Independent model: the inputs held (x_in = 0, each face's weighted mean) by a penalty
    // spring 1e4 times the PEA's instead of condensed (its error is of order 1e-5).
    let mut bcs: BoundaryConditions = model.bcs().clone();
    for port in &problem.inputs {
        bcs.add_link(&port.terms(1.0), 1e4 * port.stiffness);
    }
    let held = Model::new(
        model.mesh().clone(),
        *model.material(),
        Kinematics::Linear,
        bcs,
    )
    .unwrap();
    let sym = SymbolicFactor::new(held.pattern().clone()).unwrap();
    let mut ws = NewtonWorkspace::new(&held, sym);
    for d in 0..2 {
        let mut p = held.zero_vector();
        p[2 * ports.output + d] = 1.0;
        let mut u = held.zero_vector();
        newton::solve(
            &held,
            &design,
            &p,
            &mut u,
            &NewtonParams::default(),
            &mut ws,
            None,
        )
        .unwrap();
        for i in 0..2 {
            let reference = u[2 * ports.output + i];
            let got = c.compliance[i][d];
            let scale = c.compliance[d][d].abs();
            assert!(
                (got - reference).abs() <= 1e-4 * scale,
                "C[{i}][{d}] = {got:e}, independent {reference:e}"
            );
        }
    }
    assert!((c.k_qo1() - 0.5 / c.compliance[0][0]).abs() <= 1e-12 * c.k_qo1());
    assert!(c.k_qo1() > 0.0 && c.k_qo2() > 0.0);
}

#[test]
fn operating_point_tangent_keeps_rigid_translation() {
    // Total Lagrangian: a rigid translation on top of a deformed state is strain-free, so the
    // moving-frame relations of Eq. 26 hold for the tangent at any operating point, while α
    // itself changes with the state.
    let (_s, problem) = samples::stage(Preset::Quick).unwrap();
    let model = &problem.model;
    let rho = samples::random_design(&problem, 0.05, 1.0, 21);
    let design = Design::new(&rho);
    let ports = Ports::from_problem(&problem).unwrap();
    let sym = SymbolicFactor::new(model.pattern().clone()).unwrap();
    let mut ws = NewtonWorkspace::new(model, sym);
    let mut p = model.zero_vector();
    p[ports.inputs[0]] = problem.inputs[0].stiffness * 30e-6;
    p[ports.inputs[1]] = problem.inputs[1].stiffness * -30e-6;
    let mut u = model.zero_vector();
    newton::solve(
        model,
        &design,
        &p,
        &mut u,
        &NewtonParams::default(),
        &mut ws,
        None,
    )
    .unwrap();
    let mut cd = Condenser::new(model, ports).unwrap();
    let c0 = cd.condense(model, &design, None).unwrap();
    let c1 = cd.condense(model, &design, Some(&u)).unwrap();
    let r = c1.eq26_residuals();
    assert!(r[0] <= 1e-9 && r[1] <= 1e-9, "{r:?}");
    let change = (c1.alpha_scalar() - c0.alpha_scalar()).abs() / c0.alpha_scalar().abs();
    println!(
        "alpha0 {} alpha(u0) {} change {change:e}",
        c0.alpha_scalar(),
        c1.alpha_scalar()
    );
    assert!(change > 1e-8, "the tangent did not change with the state");
}
