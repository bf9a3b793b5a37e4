//! Problems with known answers, for tests and examples.

#[cfg(feature = "noise")]
use crate::noise::GaussianNoise;

/// A linear regression y = φᵀθ* (+ noise) with known θ* = [1, −2, 0.5, 3], for RLS tests:
/// `n` samples of well-conditioned pseudo-random regressors, and Gaussian measurement noise
/// of standard deviation `noise_std`. Returns (φ, y, θ*).
#[cfg(feature = "noise")]
pub fn linear_regression(
    n: usize,
    noise_std: f64,
    seed: u64,
) -> (Vec<[f64; 4]>, Vec<f64>, [f64; 4]) {
    let theta = [1.0, -2.0, 0.5, 3.0];
    let mut g = GaussianNoise::new(1.0, seed);
    let mut phis = Vec::with_capacity(n);
    let mut ys = Vec::with_capacity(n);
    for _ in 0..n {
        let phi = [
            1.0 + 0.3 * g.sample(),
            g.sample(),
            g.sample(),
            0.5 * g.sample(),
        ];
        let y: f64 =
            phi.iter().zip(&theta).map(|(a, b)| a * b).sum::<f64>() + noise_std * g.sample();
        phis.push(phi);
        ys.push(y);
    }
    (phis, ys, theta)
}
