// Reference: paper Eq. (A9)–(A11) (RLS with forgetting factor λ_f and weight W₀).
// Goal: with λ_f = 1 the recursion equals batch least squares on the same data (to 1e-9
// relative when started exactly, and to 1e-6 from a vague prior); with λ_f < 1 it equals the
// exponentially weighted batch solution and tracks a step change of the parameters.

use flexstage_piezo::{Rls, RlsParams, batch_least_squares, samples};

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
