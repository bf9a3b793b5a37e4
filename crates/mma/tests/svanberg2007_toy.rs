// Reference: K. Svanberg, "MMA and GCMMA – two methods for nonlinear optimization" (KTH, 2007),
// toy problem (`toy2` of the MMA distribution): min x1²+x2²+x3² s.t. two spheres of radius 3,
// 0 <= x <= 5, x0 = (4, 3, 2).
// Goal: MMA with Svanberg's default parameters reaches the published x* ≈ (2.0175, 1.7800,
// 1.2375), f* ≈ 8.7702 with both constraints active, and the KKT residual (kktcheck) of the
// original problem falls below 1e-6; the iterates stay within the bounds.

use flexstage_mma::{Mma, MmaParams, StopCriteria, samples};

#[test]
fn toy_reaches_published_optimum_with_small_kkt_residual() {
    let s = samples::toy();
    let sol = s
        .solve(
            MmaParams::default(),
            StopCriteria {
                max_iterations: 50,
                kkt_tolerance: 1e-6,
            },
        )
        .unwrap();
    assert!(
        sol.converged,
        "KKT residual {:?} after {} iterations",
        sol.kkt, sol.iterations
    );
    assert!(sol.kkt.norm < 1e-6);
    assert!(sol.iterations <= 20, "took {} iterations", sol.iterations);
    for (j, (x, xs)) in sol.x.iter().zip(&s.x_star).enumerate() {
        assert!((x - xs).abs() < 1e-3, "x[{j}] = {x}, expected {xs}");
    }
    assert!(
        (sol.f0 - s.f_star).abs() < 1e-3,
        "f0 = {}, expected {}",
        sol.f0,
        s.f_star
    );
    // Both constraints active, both multipliers positive.
    for (i, fi) in sol.f.iter().enumerate() {
        assert!(fi.abs() < 1e-5, "constraint {i} not active: f = {fi}");
        assert!(sol.lambda[i] > 0.1, "lambda[{i}] = {}", sol.lambda[i]);
    }
}

#[test]
fn toy_iterates_stay_in_bounds_and_objective_settles() {
    let s = samples::toy();
    let p = s.problem.as_ref();
    let mut mma = Mma::new(3, 2, s.xmin.clone(), s.xmax.clone(), MmaParams::default()).unwrap();
    let mut x = s.x0.clone();
    let (mut g, mut f, mut dfdx) = (vec![0.0; 3], vec![0.0; 2], vec![0.0; 6]);
    let mut f0 = p.evaluate(&x, &mut g, &mut f, &mut dfdx);
    for _ in 0..30 {
        let rep = mma.update(&mut x, f0, &g, &f, &dfdx).unwrap();
        assert!(x.iter().all(|v| (0.0..=5.0).contains(v)), "x = {x:?}");
        assert!(rep.subproblem_iterations > 0 && rep.subproblem_iterations < 200);
        f0 = p.evaluate(&x, &mut g, &mut f, &mut dfdx);
    }
    assert!((f0 - 8.7702).abs() < 1e-3);
    // With a tighter subproblem tolerance the KKT residual goes much lower.
    let params = MmaParams {
        subproblem_tolerance: 1e-10,
        ..MmaParams::default()
    };
    let sol = s
        .solve(
            params,
            StopCriteria {
                max_iterations: 60,
                kkt_tolerance: 1e-9,
            },
        )
        .unwrap();
    assert!(sol.converged, "KKT {:?}", sol.kkt);
}
