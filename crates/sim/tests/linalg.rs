//! Reference: python-control's `c2d(…, "zoh")`, `lyap`, `dlyap`, `poles`; closed forms of
//! `samples`. Goal: the textbook helpers used to build the observer and check the loop are
//! exact on problems with known answers.

use flexstage_sim::linalg::{c2d, dlyap, expm, is_positive_definite, lyap, poles, spectral_radius};
use flexstage_sim::samples::{
    diagonal_lyapunov, double_integrator, first_order, oscillator, oscillator_exp,
};
use nalgebra::DMatrix;

#[test]
fn expm_matches_the_oscillator_closed_form() {
    for (omega, t) in [
        (1.0, 0.3),
        (2.0 * std::f64::consts::PI * 12e3, 1e-4),
        (50.0, 2.0),
    ] {
        let e = expm(&(oscillator(omega) * t)).unwrap();
        let want = oscillator_exp(omega, t);
        let scale = want.amax();
        assert!((e - &want).amax() <= 1e-12 * scale, "ω = {omega}, t = {t}");
    }
}

#[test]
fn c2d_matches_the_double_integrator_and_first_order_lag() {
    let (a, b) = double_integrator();
    let t = 1e-4;
    let (phi, gamma) = c2d(&a, &b, t).unwrap();
    assert!((phi - DMatrix::from_row_slice(2, 2, &[1.0, t, 0.0, 1.0])).amax() < 1e-18);
    assert!((gamma - DMatrix::from_row_slice(2, 1, &[0.5 * t * t, t])).amax() < 1e-18);
    let (phi1, gamma1) = c2d(
        &DMatrix::from_element(1, 1, -1e5),
        &DMatrix::from_element(1, 1, 3.0),
        t,
    )
    .unwrap();
    let (p, g) = first_order(1e5, 3.0, t);
    assert!(
        (phi1[(0, 0)] - p).abs() < 1e-15 && (gamma1[(0, 0)] - g).abs() < 1e-15 * g.abs().max(1e-5)
    );
    assert!(c2d(&a, &b, 0.0).is_err());
}

#[test]
fn lyap_solves_a_diagonal_case_and_a_coupled_case() {
    let (a, x) = diagonal_lyapunov(&[1.0, 2.5, 1e5]);
    let p = lyap(&a, &DMatrix::identity(3, 3)).unwrap();
    assert!((&p - &x).amax() < 1e-15 + 1e-12 * x.amax());
    // A non-normal Hurwitz matrix: residual and symmetry.
    let a = DMatrix::from_row_slice(3, 3, &[-1.0, 50.0, 0.0, 0.0, -2.0, 3.0, 0.01, 0.0, -4.0]);
    let q = DMatrix::identity(3, 3);
    let p = lyap(&a, &q).unwrap();
    let res = &a * &p + &p * a.transpose() + &q;
    assert!(res.amax() < 1e-10 * p.amax());
    assert!((&p - p.transpose()).amax() < 1e-12 * p.amax());
    assert!(is_positive_definite(&p));
}

#[test]
fn dlyap_residual_and_poles_of_the_oscillator() {
    let a = DMatrix::from_row_slice(2, 2, &[0.5, 0.4, -0.3, 0.2]);
    let q = DMatrix::identity(2, 2);
    let x = dlyap(&a, &q).unwrap();
    assert!((&a * &x * a.transpose() - &x + &q).amax() < 1e-13);
    assert!(is_positive_definite(&x));
    let p = poles(&oscillator(3.0)).unwrap();
    assert_eq!(p.len(), 2);
    for z in p {
        assert!(z.re.abs() < 1e-12 && (z.im.abs() - 3.0).abs() < 1e-12);
    }
    assert!(
        (spectral_radius(&a).unwrap() - a.clone().complex_eigenvalues()[0].norm()).abs() < 1e-12
    );
}
