//! Reference: the input-bounds and fault-handling requirements, "a *linear* solve whose increment is 1e-16 runs 330 iterations and
//! reports NotConverged"; the stopping rule of Newton's method at round-off (Dennis &
//! Schnabel, "Numerical Methods for Unconstrained Optimization and Nonlinear Equations",
//! 1996, §7.2: stop when the step is below the achievable relative precision).
//! Goal: on a linear model, a residual tolerance below round-off (1e-300) is unreachable, yet
//! the solve ends after the corrections that bring the step to machine precision (≤ 3), with
//! the linear solution; a tolerance below round-off with a non-converging step still fails.

use flexstage_fem::*;

#[test]
fn a_step_at_machine_precision_ends_a_linear_solve() {
    let stage = samples::Stage::paper(24, 12, Kinematics::Linear).unwrap();
    let model = &stage.model;
    let rho = stage.random_density(0.05, 0.9, 3, 1e-3);
    let design = Design::new(&rho);
    let load = stage.pea_load(30e-6, -30e-6);
    let solve = |residual_tol: f64| {
        let sym = SymbolicFactor::new(model.pattern().clone()).unwrap();
        let mut ws = NewtonWorkspace::new(model, sym);
        let mut u = model.zero_vector();
        let p = NewtonParams {
            residual_tol,
            displacement_tol: 1e-300,
            ..Default::default()
        };
        newton::solve(model, &design, &load, &mut u, &p, &mut ws, None).map(|r| (r, u))
    };
    let (loose, u_ref) = solve(1e-9).unwrap();
    let (strict, u) = solve(1e-300).expect("round-off must not make a linear solve fail");
    assert!(strict.iterations <= 3, "{} corrections", strict.iterations);
    assert!(loose.iterations <= 3, "{} corrections", loose.iterations);
    let diff: f64 = u
        .iter()
        .zip(&u_ref)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let scale: f64 = u_ref.iter().map(|a| a.abs()).fold(0.0, f64::max);
    assert!(
        diff <= 1e-12 * scale,
        "solutions differ by {diff:e} of {scale:e}"
    );
}
