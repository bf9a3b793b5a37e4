// Reference: analytic. For min ½ Σ hj (xj − tj)² s.t. Σ aj xj <= b, l <= x <= u (hj > 0), the
// minimiser is xj(λ) = clamp(tj − λ aj / hj, lj, uj) with λ = 0 if feasible and otherwise the
// root of Σ aj xj(λ) = b, found by a 1-D bisection on the multiplier.
// Goal (property test over random feasible instances): every MMA iterate stays inside the
// box, and the final objective matches the analytic optimum (relative 1e-5), the final point
// is feasible (to 1e-6) and λ matches the analytic multiplier, with either subproblem solver.

use flexstage_mma::samples::{SeparableQuadratic, separable_quadratic};
use flexstage_mma::{Mma, MmaParams, Subsolver};
use proptest::prelude::*;

fn instance() -> impl Strategy<Value = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, f64, f64)> {
    (2usize..24).prop_flat_map(|n| {
        (
            prop::collection::vec(0.5f64..4.0, n),  // h
            prop::collection::vec(-2.0f64..3.0, n), // t
            prop::collection::vec(0.2f64..2.0, n),  // a (positive: a resource constraint)
            prop::collection::vec(-1.0f64..0.0, n), // l
            0.05f64..0.95,                          // where b lies between min and max of a·x
            0.5f64..2.0,                            // box width scale
        )
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn mma_matches_dual_bisection((h, t, a, l, frac, width) in instance(), dual in any::<bool>()) {
        let n = h.len();
        let u: Vec<f64> = l.iter().map(|l| l + 1.0 + width).collect();
        let lo: f64 = a.iter().zip(&l).map(|(a, l)| a * l).sum();
        let hi: f64 = a.iter().zip(&u).map(|(a, u)| a * u).sum();
        let b = lo + frac * (hi - lo);
        let x0: Vec<f64> = l.iter().zip(&u).map(|(l, u)| 0.5 * (l + u)).collect();
        let q = SeparableQuadratic { h, t, linear: Some((a, b)) };
        let (_, lam_star) = q.analytic_optimum(&l, &u);
        let s = separable_quadratic(q, x0, l.clone(), u.clone());
        let p = s.problem.as_ref();

        let subsolver = if dual { Subsolver::Dual } else { Subsolver::PrimalDual };
        let params = MmaParams { raa0: 0.1, subsolver, ..MmaParams::default() };
        let mut mma = Mma::new(n, 1, l.clone(), u.clone(), params).unwrap();
        let mut x = s.x0.clone();
        let (mut g, mut f, mut dfdx) = (vec![0.0; n], vec![0.0; 1], vec![0.0; n]);
        let mut f0 = p.evaluate(&x, &mut g, &mut f, &mut dfdx);
        for _ in 0..150 {
            let rep = mma.update(&mut x, f0, &g, &f, &dfdx).unwrap();
            for j in 0..n {
                prop_assert!(l[j] <= x[j] && x[j] <= u[j], "x[{}] = {} outside [{}, {}]", j, x[j], l[j], u[j]);
            }
            f0 = p.evaluate(&x, &mut g, &mut f, &mut dfdx);
            if rep.max_change < 1e-10 {
                break;
            }
        }
        let scale = s.f_star.abs().max(1.0);
        prop_assert!((f0 - s.f_star).abs() <= 1e-5 * scale, "f0 = {}, f* = {}", f0, s.f_star);
        prop_assert!(f[0] <= 1e-6, "constraint violated: {}", f[0]);
        prop_assert!((mma.lambda()[0] - lam_star).abs() <= 1e-3 * lam_star.max(1.0),
            "lambda = {}, analytic {}", mma.lambda()[0], lam_star);
    }
}
