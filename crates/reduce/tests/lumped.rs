//! Reference: paper Eq. 31–35 / Appendix C (A13–A14) parameter set, Table 3 (2710 kg/m³),
//! Table 4 (input plates). Goal: the reduced `StageParams` validate, take K_pea / k_in /
//! m_in / damping from the scenario, and K_qo1, K_qo2, α and M from the design. (The
//! parameter file's round trip is `flexstage-run`'s test.)

use flexstage_reduce::{ReduceParams, reduce, samples};
use flexstage_scenario::Preset;

#[test]
fn reduce_writes_stage_params_the_control_stage_reads() {
    let (s, problem) = samples::stage(Preset::Quick).unwrap();
    let rho = samples::symmetric_random_design(&problem, 0.2, 1.0, 4);
    let params = ReduceParams {
        validity: None,
        ..ReduceParams::default()
    };
    let r = reduce(&s, &problem, &rho, &params).unwrap();
    let p = &r.params;
    let c = &r.condensation;
    assert_eq!(p.k_qo1, c.k_qo1());
    assert_eq!(p.k_qo2, c.k_qo2());
    assert_eq!(p.alpha, c.alpha_scalar());
    assert_eq!(p.k_pea1, s.actuators.stiffness);
    assert_eq!(p.k_in2, s.stage.guess.k_in2);
    assert_eq!(p.m_in1, s.stage.guess.m_in1);
    let want = p.clone().with_damping_ratio(s.stage.damping_ratio);
    assert_eq!(p.c_qo2, want.c_qo2);
    assert!(p.c_qo1 > 0.0 && p.c_in1 > 0.0);
    p.validate("params").unwrap();
    // Mass: Σρ ρ0 V.
    let m = problem.mesh();
    let v = m.dx() * m.dy() * m.thickness;
    let want = rho.iter().sum::<f64>() * 2710.0 * v;
    assert!((r.mass - want).abs() <= 1e-12 * want);
    // Assumption 2 is stated against the scenario's fastest trajectory (Lissajous 3 × 2 Hz).
    let a2 = r.assumption2.unwrap();
    assert_eq!(a2.input_frequency, 6.0);
    assert!(a2.holds, "{}", a2.statement());
}

#[test]
fn full_solid_mass_is_the_block_mass() {
    let (s, problem) = samples::stage(Preset::Quick).unwrap();
    let rho = vec![1.0; problem.mesh().n_elements()];
    let m = flexstage_reduce::design_mass(problem.mesh(), &rho, s.material.density);
    let block = 2710.0 * s.mesh.length * s.mesh.width * s.mesh.thickness;
    assert!((m - block).abs() <= 1e-12 * block, "{m} vs {block}");
    // The consistent mass matrix carries the whole mass in a rigid x translation when no x
    // DOF is fixed (the stage is held in x by the PEA springs only).
    let mm = flexstage_reduce::MassMatrix::assemble(
        &problem.model,
        &rho,
        s.material.density,
        flexstage_reduce::MassInterpolation::default(),
        flexstage_reduce::MassLumping::Consistent,
        &[],
    )
    .unwrap();
    let dofs = problem.model.dofs();
    let t: Vec<f64> = dofs
        .free_dofs()
        .iter()
        .map(|&d| if d % 2 == 0 { 1.0 } else { 0.0 })
        .collect();
    let mut mt = vec![0.0; t.len()];
    mm.matvec(&t, &mut mt);
    let total: f64 = mt.iter().zip(&t).map(|(a, b)| a * b).sum();
    assert!((total - block).abs() <= 1e-12 * block, "{total} vs {block}");
}

#[test]
fn operating_point_out_of_range_is_rejected() {
    let (s, problem) = samples::stage(Preset::Quick).unwrap();
    let rho = samples::default_design(&problem);
    let params = ReduceParams {
        operating_point: Some([2e-3, 0.0]),
        ..ReduceParams::default()
    };
    let e = reduce(&s, &problem, &rho, &params).unwrap_err();
    assert!(e.to_string().contains("operating_point"), "{e}");
}
