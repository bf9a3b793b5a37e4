//! Problems with known answers, for tests and examples.

use nalgebra::DMatrix;

/// The harmonic oscillator ẋ = [[0, 1], [−ω², 0]] x: e^{At} = [[cos ωt, sin ωt/ω],
/// [−ω sin ωt, cos ωt]].
pub fn oscillator(omega: f64) -> DMatrix<f64> {
    DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -omega * omega, 0.0])
}

/// The closed form of e^{At} for [`oscillator`].
pub fn oscillator_exp(omega: f64, t: f64) -> DMatrix<f64> {
    let (s, c) = (omega * t).sin_cos();
    DMatrix::from_row_slice(2, 2, &[c, s / omega, -omega * s, c])
}

/// The double integrator ẋ = [[0, 1], [0, 0]] x + [0, 1] u: its ZOH discretization is
/// Φ = [[1, T], [0, 1]], Γ = [T²/2, T].
pub fn double_integrator() -> (DMatrix<f64>, DMatrix<f64>) {
    (
        DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]),
        DMatrix::from_row_slice(2, 1, &[0.0, 1.0]),
    )
}

/// A first-order lag ẋ = −a x + b u: Φ = e^{−aT}, Γ = b(1 − e^{−aT})/a.
pub fn first_order(a: f64, b: f64, t: f64) -> (f64, f64) {
    let e = (-a * t).exp();
    (e, b * (1.0 - e) / a)
}

/// The Lyapunov equation of a diagonal Hurwitz A = diag(−λ_i) with Q = I: X = diag(1/(2λ_i)).
pub fn diagonal_lyapunov(lambda: &[f64]) -> (DMatrix<f64>, DMatrix<f64>) {
    let n = lambda.len();
    let a = DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
        n,
        lambda.iter().map(|l| -l),
    ));
    let x = DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
        n,
        lambda.iter().map(|l| 0.5 / l),
    ));
    (a, x)
}

/// Two decoupled axes, one 1 %-damped mode each at 2.7 kHz (q1, driven by PEA1) and
/// 3.9 kHz (q2, driven by PEA2), scaled to unit static gain: a modal plant whose sampled
/// response, peaks and tuning are known by hand.
pub fn decoupled_modes() -> Vec<crate::modal::PlantMode> {
    let mode = |f: f64, axis: usize| {
        let w2 = (std::f64::consts::TAU * f).powi(2);
        let mut m = crate::modal::PlantMode {
            frequency: f,
            damping: 0.01,
            input: [0.0; 2],
            output: [0.0; 2],
        };
        m.input[axis] = w2;
        m.output[axis] = 1.0;
        m
    };
    vec![mode(2700.0, 0), mode(3900.0, 1)]
}
