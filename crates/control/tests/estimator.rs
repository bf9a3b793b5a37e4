//! Reference: the discrete Kalman filter (Kalman 1960; Anderson & Moore, *Optimal
//! Filtering*, 1979, ch. 4): the steady-state a-priori covariance solves the filter DARE,
//! P = Φ P Φᵀ − Φ P Cᵀ (C P Cᵀ + R)⁻¹ C P Φᵀ + Q, which for a scalar system has the closed
//! form of a quadratic; the estimation error of the steady-state filter on the model it was
//! designed for has covariance P.
//! Goal: the doubling solver of `flexstage_control::estimator` matches the scalar closed
//! forms to 1e-12, leaves a DARE residual ≤ 1e-9 (relative) on the 10-state stage model,
//! and a Monte Carlo of the linear model with the design's noise gives the error variances
//! of P within 10 %; the velocity estimate is less than half as noisy as the finite difference at the default noise levels.

use flexstage_control::estimator::{KalmanDesign, KalmanParams, dare, dare_residual};
use flexstage_numerics::noise::GaussianNoise;
use flexstage_scenario::Scenario;
use flexstage_sim::model::{StageModel, to_dyn};
use nalgebra::{DMatrix, DVector, SymmetricEigen};

/// Scalar DARE x = a² x r/(r + c² x) + q, positive root of
/// c² x² + (r − a² r − c² q) x − q r = 0.
fn scalar_closed_form(a: f64, c: f64, q: f64, r: f64) -> f64 {
    let (qa, qb, qc) = (c * c, r - a * a * r - c * c * q, -q * r);
    let root = (qb * qb - 4.0 * qa * qc).sqrt();
    // The form without cancellation for either sign of qb.
    if qb >= 0.0 {
        -2.0 * qc / (qb + root)
    } else {
        (-qb + root) / (2.0 * qa)
    }
}

#[test]
fn dare_matches_the_scalar_closed_form() {
    for &(a, c, q, r) in &[
        (1.0, 1.0, 1e-2, 1.0),
        (0.9, 1.0, 1.0, 1e-3),
        (1.2, 0.5, 0.3, 2.0),
        (-0.7, 2.0, 1e-6, 1.0),
    ] {
        let m = |v: f64| DMatrix::from_element(1, 1, v);
        let (p, _) = dare(&m(a), &m(c), &m(q), &m(r)).unwrap();
        let want = scalar_closed_form(a, c, q, r);
        assert!(
            (p[(0, 0)] - want).abs() <= 1e-12 * want,
            "a {a} c {c} q {q} r {r}: {} vs {want}",
            p[(0, 0)]
        );
    }
}

#[test]
fn dare_fails_clearly_when_not_detectable() {
    // An unstable state the output does not see: no stabilizing solution.
    let phi = DMatrix::from_row_slice(2, 2, &[1.5, 0.0, 0.0, 0.5]);
    let c = DMatrix::from_row_slice(1, 2, &[0.0, 1.0]);
    let q = DMatrix::identity(2, 2);
    let r = DMatrix::identity(1, 1);
    assert!(dare(&phi, &c, &q, &r).is_err());
}

fn stage() -> (StageModel, KalmanParams, f64) {
    let s = Scenario::paper();
    let m = StageModel::new(&s.stage.guess).unwrap();
    (
        m,
        KalmanParams::with_sensor_noise(s.sensors.noise_std),
        s.simulation.sample_time,
    )
}

/// The diagonal scaling of the estimator (σ, σ/T, σ/T²).
fn scaling(sigma: f64, t: f64) -> DVector<f64> {
    DVector::from_fn(10, |i, _| match i {
        0..=3 => sigma,
        4..=7 => sigma / t,
        _ => sigma / (t * t),
    })
}

#[test]
fn kalman_gain_solves_the_riccati_equation_on_the_stage_model() {
    let (m, p, t) = stage();
    let k = KalmanDesign::new(&m, t, &p).unwrap();
    let mut c = DMatrix::zeros(2, 10);
    c[(0, 0)] = 1.0;
    c[(1, 1)] = 1.0;
    // Residual in the scaled coordinates, relative to the largest entry of P there.
    let s = scaling(p.sensor_noise[0], t);
    let si = DMatrix::from_diagonal(&s.map(|v| 1.0 / v));
    let sd = DMatrix::from_diagonal(&s);
    let (phi, q, pp) = (to_dyn(&k.phi), to_dyn(&k.q), to_dyn(&k.p));
    let ps = &si * &pp * &si;
    let res = dare_residual(
        &(&si * &phi * &sd),
        &(&c * &sd),
        &(&si * &q * &si),
        &to_dyn(&k.r),
        &ps,
    );
    assert!(
        res <= 1e-9 * ps.amax(),
        "residual {res:e} vs {:e}",
        ps.amax()
    );
    // F = Φ − L C is Schur, and L = Φ M.
    let rho = flexstage_sim::linalg::spectral_radius(&to_dyn(&k.f)).unwrap();
    assert!(rho < 1.0, "spectral radius {rho}");
    assert!((k.l - k.phi * k.m).amax() <= 1e-12 * k.l.amax());
}

#[test]
fn kalman_velocity_is_far_less_noisy_than_the_finite_difference() {
    let (m, p, t) = stage();
    let k = KalmanDesign::new(&m, t, &p).unwrap();
    for i in 0..2 {
        // Backward difference of two noisy samples: std √2 σ / T.
        let fd = std::f64::consts::SQRT_2 * p.sensor_noise[i] / t;
        let kf = k.p_filtered[(4 + i, 4 + i)].sqrt();
        assert!(
            kf < 0.5 * fd,
            "axis {i}: Kalman {kf:e} m/s vs FD {fd:e} m/s"
        );
        // And the position estimate is better than the raw measurement.
        assert!(k.p_filtered[(i, i)].sqrt() < p.sensor_noise[i]);
    }
}

#[test]
fn monte_carlo_error_variance_matches_the_riccati_covariance() {
    let (m, p, t) = stage();
    let k = KalmanDesign::new(&m, t, &p).unwrap();
    let s = scaling(p.sensor_noise[0], t);
    let si = DMatrix::from_diagonal(&s.map(|v| 1.0 / v));
    // w = S V √Λ n, with S⁻¹ Q S⁻¹ = V Λ Vᵀ.
    let eig = SymmetricEigen::new(&si * to_dyn(&k.q) * &si);
    let root = DMatrix::from_diagonal(&s)
        * &eig.eigenvectors
        * DMatrix::from_diagonal(&eig.eigenvalues.map(|l| l.max(0.0).sqrt()));
    let (phi, l) = (to_dyn(&k.phi), to_dyn(&k.l));
    let mut w = GaussianNoise::new(1.0, 7);
    let mut v = [
        GaussianNoise::new(p.sensor_noise[0], 11),
        GaussianNoise::new(p.sensor_noise[1], 13),
    ];
    let (burn, n) = (5_000, 200_000);
    let mut x = DVector::zeros(10);
    let mut xh = DVector::zeros(10);
    let mut acc = DVector::zeros(10);
    for step in 0..burn + n {
        let e = &x - &xh;
        if step >= burn {
            acc += e.component_mul(&e);
        }
        let y = [x[0] + v[0].sample(), x[1] + v[1].sample()];
        let innov = DVector::from_column_slice(&[y[0] - xh[0], y[1] - xh[1]]);
        xh = &phi * &xh + &l * innov;
        let noise = DVector::from_fn(10, |_, _| w.sample());
        x = &phi * &x + &root * noise;
    }
    for i in [0, 1, 4, 5, 8, 9] {
        let mc = acc[i] / n as f64;
        let riccati = k.p[(i, i)];
        assert!(
            (mc / riccati - 1.0).abs() < 0.1,
            "state {i}: Monte Carlo {mc:e} vs Riccati {riccati:e}"
        );
    }
}

#[test]
fn bad_noise_levels_are_refused_with_their_name() {
    let (m, mut p, t) = stage();
    p.sensor_noise[1] = 0.0;
    let e = KalmanDesign::new(&m, t, &p).unwrap_err().to_string();
    assert!(e.contains("controller.kalman.sensor_noise[1]"), "{e}");
    let (_, mut p, _) = stage();
    p.disturbance_drift[0] = f64::NAN;
    let e = KalmanDesign::new(&m, t, &p).unwrap_err().to_string();
    assert!(e.contains("disturbance_drift[0]"), "{e}");
}
