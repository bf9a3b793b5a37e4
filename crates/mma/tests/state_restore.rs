//! Reference: Svanberg (2007), the MMA history (xᵏ⁻¹, xᵏ⁻², asymptotes) fully determines the
//! next subproblem. Goal: an optimizer restored from `Mma::state()` after k updates continues
//! bitwise identically to the uninterrupted one (checkpoint/resume of topology optimization),
//! and a state of the wrong size is rejected.

use flexstage_mma::{Mma, MmaError, MmaParams};

fn eval(x: &[f64]) -> (f64, Vec<f64>, Vec<f64>, Vec<f64>) {
    // min Σ (x_j − 0.3 j)²  s.t.  Σ x_j − 2 ≤ 0
    let f0 = x
        .iter()
        .enumerate()
        .map(|(j, v)| (v - 0.3 * j as f64).powi(2))
        .sum();
    let df0 = x
        .iter()
        .enumerate()
        .map(|(j, v)| 2.0 * (v - 0.3 * j as f64))
        .collect();
    (
        f0,
        df0,
        vec![x.iter().sum::<f64>() - 2.0],
        vec![1.0; x.len()],
    )
}

fn step(mma: &mut Mma, x: &mut [f64]) {
    let (f0, df0, f, dfdx) = eval(x);
    mma.update(x, f0, &df0, &f, &dfdx).unwrap();
}

#[test]
fn restored_optimizer_continues_bitwise() {
    let n = 5;
    let new = || Mma::new(n, 1, vec![0.0; n], vec![1.0; n], MmaParams::default()).unwrap();
    let mut a = new();
    let mut xa = vec![0.9; n];
    for _ in 0..4 {
        step(&mut a, &mut xa);
    }
    let saved = (a.state(), xa.clone());
    for _ in 0..6 {
        step(&mut a, &mut xa);
    }
    let mut b = new();
    b.restore(&saved.0).unwrap();
    assert_eq!(b.state(), saved.0);
    let mut xb = saved.1;
    for _ in 0..6 {
        step(&mut b, &mut xb);
    }
    assert_eq!(xa, xb);
    assert_eq!(a.state(), b.state());
    let (_, df0, f, dfdx) = eval(&xa);
    assert_eq!(
        a.kkt_residual(&xa, &df0, &f, &dfdx).unwrap(),
        b.kkt_residual(&xb, &df0, &f, &dfdx).unwrap()
    );

    let mut bad = a.state();
    bad.low.pop();
    assert!(matches!(
        new().restore(&bad),
        Err(MmaError::DimensionMismatch { .. })
    ));
}
