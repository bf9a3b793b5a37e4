// Reference: analytic. A separable convex quadratic ½ Σ hj (xj − tj)² over the box [0, 1]^n
// with n = 10^5 and no constraint (m = 0) has the minimiser x* = clamp(t, 0, 1).
// Goal: MMA with m = 0 (no dummy constraint) reaches x* — about half of the components at a
// bound — with f0 − f* below 1e-8 relative and every component within 2e-5 (a component whose
// bound is only weakly active, tj slightly below 0, sits ε/|∂f0/∂xj| inside the bound), and the KKT residual norm over all 3n + 2 entries drops below 1e-6
// (which needs a subproblem tolerance near 1e-6 / sqrt(n)); the large-n code path is the
// rayon one.
// Note: with the default raa0 = 1e-5 the curvature of the MMA approximation is proportional
// to |∂f0/∂xj|, so at an interior unconstrained optimum (gradient -> 0) plain MMA keeps
// oscillating with an amplitude of about asymin·(xmax − xmin) (the limitation that GCMMA
// removes). raa0 = 0.1 gives the approximation a gradient-independent curvature ≈ 4·raa0/δ,
// and MMA then converges; the test documents this setting.

use flexstage_mma::{MmaParams, StopCriteria, samples};

#[test]
fn box_quadratic_with_100k_variables_and_no_constraint() {
    let n = 100_000;
    let s = samples::box_quadratic(n);
    assert_eq!(s.problem.m(), 0);
    let at_bounds = s.x_star.iter().filter(|&&v| v == 0.0 || v == 1.0).count();
    assert!(
        at_bounds > n / 4 && at_bounds < 3 * n / 4,
        "{at_bounds} at bounds"
    );

    let params = MmaParams {
        subproblem_tolerance: 1e-10,
        raa0: 0.1,
        ..MmaParams::default()
    };
    assert!(n >= params.parallel_threshold);
    let sol = s
        .solve(
            params,
            StopCriteria {
                max_iterations: 40,
                kkt_tolerance: 1e-6,
            },
        )
        .unwrap();
    assert!(
        sol.converged,
        "KKT {:?} after {} iterations",
        sol.kkt, sol.iterations
    );
    let err = sol
        .x
        .iter()
        .zip(&s.x_star)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(err < 2e-5, "max |x - x*| = {err}");
    let mean_err = sol
        .x
        .iter()
        .zip(&s.x_star)
        .map(|(a, b)| (a - b).abs())
        .sum::<f64>()
        / n as f64;
    assert!(mean_err < 1e-8, "mean |x - x*| = {mean_err}");
    assert!(
        (sol.f0 - s.f_star).abs() <= 1e-8 * s.f_star.max(1.0),
        "f0 = {}, f* = {}",
        sol.f0,
        s.f_star
    );
    assert!(sol.x.iter().all(|v| (0.0..=1.0).contains(v)));
}
