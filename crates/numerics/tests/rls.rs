// Reference: paper Eq. (A9)–(A11) (RLS with forgetting factor λ_f and weight W₀).
// Goal: with λ_f = 1 the recursion equals batch least squares on the same data (to 1e-9
// relative when started exactly, and to 1e-6 from a vague prior); with λ_f < 1 it equals the
// exponentially weighted batch solution and tracks a step change of the parameters; the
// square-root form stays exact where the regressors span many decades; the information form
// (WeightedMoments + solve_spd) gives the same weighted solution for a re-mapped regressor.

use flexstage_numerics::dense::solve_spd;
use flexstage_numerics::rls::{Rls, RlsParams, WeightedMoments, batch_least_squares};
use flexstage_numerics::samples;

fn rel(a: &[f64; 4], b: &[f64; 4]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() / y.abs().max(1e-300))
        .fold(0.0, f64::max)
}

#[test]
fn lambda_one_equals_batch_least_squares() {
    let (phis, ys, truth) = samples::linear_regression(2000, 0.1, 3);
    let batch = batch_least_squares(&phis, &ys, 1.0).unwrap();
    assert!(rel(&batch, &truth) < 0.05, "noisy LS near truth: {batch:?}");
    // Exact start on the first 10 samples, then recursion.
    let params = RlsParams::default();
    let mut rls = Rls::<4>::from_batch(params, &phis[..10], &ys[..10]).unwrap();
    for (phi, &y) in phis[10..].iter().zip(&ys[10..]) {
        rls.update(phi, y);
    }
    assert!(
        rel(rls.theta(), &batch) < 1e-9,
        "{:?} vs {batch:?}",
        rls.theta()
    );
    // From a vague prior θ = 0, Cov = 1e8·I: equal up to the prior's weight.
    let mut rls = Rls::<4>::new(
        RlsParams {
            initial_covariance: 1e8,
            ..params
        },
        [0.0; 4],
    )
    .unwrap();
    for (phi, &y) in phis.iter().zip(&ys) {
        rls.update(phi, y);
    }
    assert!(
        rel(rls.theta(), &batch) < 1e-6,
        "{:?} vs {batch:?}",
        rls.theta()
    );
}

#[test]
fn forgetting_equals_weighted_batch_and_tracks_a_step() {
    let (phis, mut ys, truth) = samples::linear_regression(3000, 0.0, 5);
    let stepped = [2.0, -1.0, 1.5, 2.0];
    for (phi, y) in phis.iter().zip(ys.iter_mut()).skip(1500) {
        *y = phi.iter().zip(&stepped).map(|(a, b)| a * b).sum();
    }
    let params = RlsParams {
        forgetting: 0.98,
        ..RlsParams::default()
    };
    let mut rls = Rls::<4>::from_batch(params, &phis[..8], &ys[..8]).unwrap();
    for k in 8..3000 {
        rls.update(&phis[k], ys[k]);
        if k == 1499 {
            assert!(
                rel(rls.theta(), &truth) < 1e-9,
                "before the step: {:?}",
                rls.theta()
            );
        }
        if k == 1700 {
            let weighted = batch_least_squares(&phis[..=k], &ys[..=k], 0.98).unwrap();
            assert!(
                rel(rls.theta(), &weighted) < 1e-9,
                "{:?} vs {weighted:?}",
                rls.theta()
            );
        }
    }
    assert!(
        rel(rls.theta(), &stepped) < 1e-6,
        "after the step: {:?}",
        rls.theta()
    );
    // Without forgetting the estimate stays between the two parameter sets.
    let mut plain = Rls::<4>::from_batch(RlsParams::default(), &phis[..8], &ys[..8]).unwrap();
    for k in 8..3000 {
        plain.update(&phis[k], ys[k]);
    }
    assert!(rel(plain.theta(), &stepped) > 0.05, "{:?}", plain.theta());
}

#[test]
fn bad_settings_and_data_give_typed_errors() {
    let e = Rls::<2>::new(
        RlsParams {
            forgetting: 1.5,
            ..RlsParams::default()
        },
        [0.0; 2],
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("rls.forgetting") && e.contains("(0, 1]"), "{e}");
    let e = batch_least_squares(&[[1.0, 2.0], [2.0, 4.0], [3.0, 6.0]], &[1.0, 2.0, 3.0], 1.0)
        .unwrap_err()
        .to_string();
    assert!(e.contains("linearly dependent"), "{e}");
}

#[test]
fn square_root_form_survives_badly_scaled_regressors() {
    // Columns scaled by 1, 1e3, 1e6, 1e-3 (like the summed PEA regressors): the normal matrix
    // spans ~18 decades. The recursion must still match batch least squares on the rescaled
    // problem (solved well-conditioned) to 1e-6.
    let (phis, ys, _) = samples::linear_regression(3000, 0.1, 7);
    let scale = [1.0, 1e3, 1e6, 1e-3];
    let scaled: Vec<[f64; 4]> = phis
        .iter()
        .map(|p| {
            [
                p[0] * scale[0],
                p[1] * scale[1],
                p[2] * scale[2],
                p[3] * scale[3],
            ]
        })
        .collect();
    let batch = batch_least_squares(&phis, &ys, 1.0).unwrap();
    let expected = [
        batch[0] / scale[0],
        batch[1] / scale[1],
        batch[2] / scale[2],
        batch[3] / scale[3],
    ];
    let mut rls = Rls::<4>::new(
        RlsParams {
            initial_covariance: 1e12,
            ..RlsParams::default()
        },
        [0.0; 4],
    )
    .unwrap();
    for (phi, &y) in scaled.iter().zip(&ys) {
        rls.update(phi, y);
    }
    assert!(
        rel(rls.theta(), &expected) < 1e-6,
        "{:?} vs {expected:?}",
        rls.theta()
    );
}

#[test]
fn moments_give_the_weighted_solution_for_any_map() {
    // v = [φ, y]; the regressor A v for two different maps A, and after profiling out a
    // coefficient, equal the weighted batch solutions.
    let (phis, ys, _) = samples::linear_regression(1500, 0.1, 9);
    let lambda = 0.999;
    let mut m = WeightedMoments::<5>::new(lambda, 1.0).unwrap();
    for (p, &y) in phis.iter().zip(&ys) {
        m.add(&[p[0], p[1], p[2], p[3], y]);
    }
    let solve = |m: &WeightedMoments<5>, map: &[[f64; 4]; 4]| {
        let mm = m.matrix();
        let mut a = [[0.0; 4]; 4];
        let mut b = [0.0; 4];
        for i in 0..4 {
            for j in 0..4 {
                for k in 0..4 {
                    for l in 0..4 {
                        a[i][j] += map[i][k] * mm[k][l] * map[j][l];
                    }
                }
            }
            for k in 0..4 {
                b[i] += map[i][k] * mm[k][4];
            }
        }
        solve_spd(&a, &b).unwrap()
    };
    let identity = [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let weighted = batch_least_squares(&phis, &ys, lambda).unwrap();
    assert!(rel(&solve(&m, &identity), &weighted) < 1e-9);
    // A mixed regressor [φ0, φ1 + 2φ2, φ2, φ3 − φ0]:
    let map = [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 2.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [-1.0, 0.0, 0.0, 1.0],
    ];
    let mixed: Vec<[f64; 4]> = phis
        .iter()
        .map(|p| [p[0], p[1] + 2.0 * p[2], p[2], p[3] - p[0]])
        .collect();
    let expected = batch_least_squares(&mixed, &ys, lambda).unwrap();
    assert!(rel(&solve(&m, &map), &expected) < 1e-9);
    assert!((m.decay() - lambda.powi(1500)).abs() < 1e-12);
    // Profiling out φ0's coefficient leaves the solution of the other three unchanged.
    let full = solve(&m, &identity);
    let mut p = m.clone();
    p.eliminate(0);
    let mm = p.matrix();
    let a3 = [
        [mm[1][1], mm[1][2], mm[1][3]],
        [mm[2][1], mm[2][2], mm[2][3]],
        [mm[3][1], mm[3][2], mm[3][3]],
    ];
    let rest = solve_spd(&a3, &[mm[1][4], mm[2][4], mm[3][4]]).unwrap();
    for i in 0..3 {
        assert!(
            ((rest[i] - full[i + 1]) / full[i + 1]).abs() < 1e-9,
            "{rest:?} vs {full:?}"
        );
    }
    assert!(solve_spd(&[[1.0, 1.0], [1.0, 1.0]], &[1.0, 1.0]).is_none());
}
