// Reference: Svanberg's `subsolv` (2007 note, section on the primal–dual method) solves the
// (n+1)×(n+1) Newton system instead of the (m+1)×(m+1) one when n <= m. Problem constructed
// for this test: min (x1−2)² + (x2−2)² s.t. x1 + x2 <= 2, x1 <= 1.5, x2 <= 1.5, 0 <= x <= 3;
// x* = (1, 1), f* = 2 (projection of (2, 2) on x1 + x2 = 2), λ* = (2, 0, 0).
// Goal: the n <= m branch converges to x*, f*, λ* with a KKT residual below 1e-6.

use flexstage_mma::{MmaParams, StopCriteria, samples};

#[test]
fn more_constraints_than_variables() {
    let s = samples::few_variables();
    assert!(s.problem.n() <= s.problem.m());
    let sol = s
        .solve(
            MmaParams::default(),
            StopCriteria {
                max_iterations: 60,
                kkt_tolerance: 1e-6,
            },
        )
        .unwrap();
    assert!(
        sol.converged,
        "KKT {:?} after {} iterations",
        sol.kkt, sol.iterations
    );
    for (x, xs) in sol.x.iter().zip(&s.x_star) {
        assert!((x - xs).abs() < 1e-5, "x = {:?}", sol.x);
    }
    assert!((sol.f0 - s.f_star).abs() < 1e-5);
    assert!(
        (sol.lambda[0] - 2.0).abs() < 1e-4,
        "lambda = {:?}",
        sol.lambda
    );
    assert!(sol.lambda[1].abs() < 1e-4 && sol.lambda[2].abs() < 1e-4);
}
