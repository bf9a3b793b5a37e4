//! Reference: consistency of the geometrically nonlinear model with linear elasticity in the
//! small-displacement limit (e.g. Bathe, "Finite Element Procedures", 2014, §6.2).
//! Goal: on the paper's stage problem (PEA springs, rollers, random SIMP densities), the TL
//! Newton solution approaches the linear FE solution as the load decreases, and the relative
//! difference scales linearly with the load (halving the load halves the difference).

use flexstage_fem::*;

fn solve(stage: &samples::Stage, model: &Model, rho: &[f64], scale: f64) -> Vec<f64> {
    let design = Design::new(rho);
    let sym = SymbolicFactor::new(model.pattern().clone()).unwrap();
    let mut ws = NewtonWorkspace::new(model, sym);
    let load = stage.pea_load(30e-6 * scale, -30e-6 * scale);
    let mut u = model.zero_vector();
    let p = NewtonParams {
        residual_tol: 1e-12,
        displacement_tol: 1e-11,
        ..Default::default()
    };
    newton::solve(model, &design, &load, &mut u, &p, &mut ws, None).unwrap();
    u
}

#[test]
fn nonlinear_solution_tends_to_linear_with_load() {
    let tl = samples::Stage::paper(24, 12, Kinematics::TotalLagrangian).unwrap();
    let lin = samples::Stage::paper(24, 12, Kinematics::Linear).unwrap();
    // Soft design so that geometric nonlinearity is visible at the largest load.
    let rho = tl.random_density(0.05, 0.3, 3, 1e-3);
    let mut diffs = Vec::new();
    for scale in [4.0, 2.0, 1.0, 0.5] {
        let un = solve(&tl, &tl.model, &rho, scale);
        let ul = solve(&lin, &lin.model, &rho, scale);
        let num: f64 = un
            .iter()
            .zip(&ul)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt();
        let den: f64 = ul.iter().map(|b| b * b).sum::<f64>().sqrt();
        diffs.push(num / den);
    }
    eprintln!("relative differences: {diffs:?}");
    // Visible nonlinearity at the largest load, and linear scaling of the difference.
    assert!(diffs[0] > 1e-4, "nonlinearity not visible: {diffs:?}");
    for w in diffs.windows(2) {
        let ratio = w[0] / w[1];
        assert!(
            (1.8..2.2).contains(&ratio),
            "difference should halve with the load: {diffs:?}"
        );
    }
    assert!(diffs[3] < diffs[0] / 6.0);
}
