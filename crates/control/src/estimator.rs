//! The noise-aware state estimate of the backstepping controller: a steady-state discrete
//! Kalman filter of the controller's model, in place of the finite-difference velocity and
//! the pole-placed K-filter gains.
//!
//! # Model (the observer's augmented model, [`crate::observer::augmented`])
//! x = [z, d] (10 numbers: the 8 states of Eq. 36 and the model error Δ_η on the output
//! accelerations), sampled with a zero-order hold at T:
//!
//! ```text
//! ẋ = A x + B_u u + G w,      w = [w_a1, w_a2, w_d1, w_d2] white, E[w wᵀ] = Q_c δ(t − s)
//! y_k = C x_k + v_k,          v_k white, E[v vᵀ] = R = diag(σ₁², σ₂²)
//! ```
//!
//! w_a is an unmodelled acceleration on each output axis (intensity q_a [m/s²/√Hz]), w_d
//! drives the disturbance as a random walk (intensity q_d [m/s³/√Hz]), σ is the sensor
//! noise per sample \[m\]. The discrete process covariance is exact (Van Loan 1978,
//! "Computing integrals involving the matrix exponential", IEEE TAC 23(3)):
//! `expm([[−A, G Q_c Gᵀ], [0, Aᵀ]] T) = [[·, Φ⁻¹ Q_d], [0, Φᵀ]]`.
//!
//! # Steady-state gain (discrete algebraic Riccati equation)
//! The a-priori error covariance P solves
//!
//! ```text
//! P = Φ P Φᵀ − Φ P Cᵀ (C P Cᵀ + R)⁻¹ C P Φᵀ + Q_d                               (DARE)
//! ```
//!
//! solved by the structure-preserving doubling algorithm (Chu, Fan, Lin, Wang 2004,
//! "Structure-preserving algorithms for periodic discrete-time algebraic Riccati
//! equations", Int. J. Control 77(8)) on the dual (control) form with A = Φᵀ, B = Cᵀ; it
//! converges quadratically, also for the slow random-walk state d. The state is scaled
//! (positions by σ, velocities by σ/T, the disturbance by σ/T²) so that every entry of the
//! doubling iteration is of order one. The filter gain is M = P Cᵀ (C P Cᵀ + R)⁻¹ and the
//! one-step predictor gain L = Φ M, so that
//!
//! ```text
//! x̂_{k+1|k} = Φ x̂_{k|k−1} + Γ u_k + L (y_k − C x̂_{k|k−1}),     F = Φ − L C Schur
//! ```
//!
//! which is exactly the form of the discrete K-filter ([`crate::observer::KFilter`]): the
//! controller runs the same filters with L from the Riccati equation instead of from the
//! pole placement of Eq. (38).
//!
//! # The noise levels (documented choice, DECISIONS.md)
//! σ is the sensor's (scenario `sensors.noise_std`, 7.5/10 nm). q_d is sized from the
//! disturbance the estimate must follow: a model error of amplitude Δ [m/s²] that changes
//! at the scan frequency f has a rate ≈ 2π f Δ; with the twin's Δ ≈ 100 m/s² and scans of
//! tens of Hz this is ≈ 1e4 m/s³, and as a random walk over one sample that is an intensity
//! q_d ≈ 2π f Δ √T. q_a (an acceleration the model does not explain at all) is small: it
//! mainly sets how much the velocity estimate trusts the measurement over the model.
//! [`KalmanParams::default`] holds the values; `tests/estimator.rs` verifies the gain (DARE
//! residual, scalar closed form) and the error covariance (Monte Carlo on the linear model).

use nalgebra::{DMatrix, Matrix2};

use crate::error::{ControlError, Result, check, non_negative};
use crate::observer::{DISTURBANCE, Matrix10, Matrix10x2, NX, augmented};
use flexstage_sim::linalg::{expm, spectral_radius};
use flexstage_sim::model::state::{Q_O, Q_O_DOT};
use flexstage_sim::model::{StageModel, from_dyn, to_dyn};

/// Noise levels of the Kalman design (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KalmanParams {
    /// Sensor noise standard deviation per axis and sample \[m\], in (0, 1e-3]. Scenario
    /// `sensors.noise_std`: 7.5e-9, 10e-9.
    pub sensor_noise: [f64; 2],
    /// Intensity q_a of the unmodelled acceleration on each output axis [m/s²/√Hz], ≥ 0.
    pub acceleration_noise: [f64; 2],
    /// Intensity q_d of the drift of the model error Δ_η (random walk) [m/s³/√Hz], > 0
    /// (without it the disturbance estimate would freeze).
    pub disturbance_drift: [f64; 2],
}

impl Default for KalmanParams {
    /// σ = 7.5/10 nm (the scenario's sensors), q_a = 1 m/s²/√Hz, q_d = 1e3 m/s³/√Hz
    /// (≈ 2π · 20 Hz · 100 m/s² · √(1e-4 s), module docs).
    fn default() -> Self {
        KalmanParams {
            sensor_noise: [7.5e-9, 10e-9],
            acceleration_noise: [1e-4, 1e-4],
            disturbance_drift: [30.0, 30.0],
        }
    }
}

impl KalmanParams {
    /// The default noise levels with the given sensor noise \[m\].
    pub fn with_sensor_noise(sensor_noise: [f64; 2]) -> Self {
        KalmanParams {
            sensor_noise,
            ..KalmanParams::default()
        }
    }

    /// Checks the fields (name, value and accepted range in the error).
    pub fn validate(&self) -> Result<()> {
        for i in 0..2 {
            let s = self.sensor_noise[i];
            check(
                &format!("controller.kalman.sensor_noise[{i}]"),
                s,
                s > 0.0 && s <= 1e-3,
                "a standard deviation in (0, 1e-3] m",
            )?;
            non_negative(
                &format!("controller.kalman.acceleration_noise[{i}]"),
                self.acceleration_noise[i],
            )?;
            check(
                &format!("controller.kalman.acceleration_noise[{i}]"),
                self.acceleration_noise[i],
                self.acceleration_noise[i] <= 1e6,
                "an intensity in [0, 1e6] m/s²/√Hz",
            )?;
            let d = self.disturbance_drift[i];
            check(
                &format!("controller.kalman.disturbance_drift[{i}]"),
                d,
                d > 0.0 && d <= 1e9,
                "an intensity in (0, 1e9] m/s³/√Hz",
            )?;
        }
        Ok(())
    }
}

/// The steady-state Kalman design of the augmented model (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct KalmanDesign {
    /// Φ = e^{A T}.
    pub phi: Matrix10,
    /// Γ = ∫₀ᵀ e^{As} ds B_u.
    pub gamma: Matrix10x2,
    /// Discrete process covariance Q_d (Van Loan).
    pub q: Matrix10,
    /// Measurement covariance R.
    pub r: Matrix2<f64>,
    /// A-priori error covariance P of x̂_{k|k−1} (the DARE solution).
    pub p: Matrix10,
    /// A-posteriori covariance (I − M C) P of x̂_{k|k}.
    pub p_filtered: Matrix10,
    /// Filter gain M = P Cᵀ (C P Cᵀ + R)⁻¹.
    pub m: Matrix10x2,
    /// Predictor gain L = Φ M.
    pub l: Matrix10x2,
    /// Error matrix F = Φ − L C (Schur).
    pub f: Matrix10,
    /// Doubling steps the Riccati solution took.
    pub iterations: usize,
}

impl KalmanDesign {
    /// The design for `model` sampled at `t` \[s\] with the noise levels `params`.
    pub fn new(model: &StageModel, t: f64, params: &KalmanParams) -> Result<KalmanDesign> {
        params.validate()?;
        check(
            "simulation.sample_time",
            t,
            t > 0.0 && t.is_finite(),
            "a finite number > 0 s",
        )?;
        let (a, b_u) = augmented(model)?;
        let mut qc = Matrix10::zeros();
        for i in 0..2 {
            qc[(Q_O_DOT[i], Q_O_DOT[i])] = params.acceleration_noise[i].powi(2);
            qc[(DISTURBANCE[i], DISTURBANCE[i])] = params.disturbance_drift[i].powi(2);
        }
        let (phi, gamma, q) = van_loan(&to_dyn(&a), &to_dyn(&b_u), &to_dyn(&qc), t)?;
        let mut c = DMatrix::zeros(2, NX);
        c[(0, Q_O[0])] = 1.0;
        c[(1, Q_O[1])] = 1.0;
        let r = DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(
            &params.sensor_noise.map(|s| s * s),
        ));
        // Scaling x = S x̃ (module docs).
        let sigma = params.sensor_noise[0].min(params.sensor_noise[1]);
        let mut s = vec![sigma; NX];
        for i in 4..8 {
            s[i] = sigma / t;
        }
        for i in DISTURBANCE {
            s[i] = sigma / (t * t);
        }
        let sd = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(s.clone()));
        let si = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(
            s.iter().map(|v| 1.0 / v).collect(),
        ));
        let phi_s = &si * &phi * &sd;
        let q_s = &si * &q * &si;
        let c_s = &c * &sd;
        let (p_s, iterations) = dare(&phi_s, &c_s, &q_s, &r)?;
        let residual = dare_residual(&phi_s, &c_s, &q_s, &r, &p_s);
        let tolerance = 1e-8 * p_s.amax().max(1.0);
        if residual.is_nan() || residual > tolerance {
            return Err(ControlError::Unstable {
                what: "Kalman Riccati equation".into(),
                detail: format!("residual {residual:e} after {iterations} doubling steps"),
            });
        }
        let p = &sd * &p_s * &sd;
        let innovation = &c * &p * c.transpose() + &r;
        let inv = innovation
            .try_inverse()
            .ok_or_else(|| ControlError::Singular {
                what: "Kalman innovation covariance C P Cᵀ + R".into(),
            })?;
        let m = &p * c.transpose() * inv;
        let l = &phi * &m;
        let f = &phi - &l * &c;
        let rho = spectral_radius(&f)?;
        if rho >= 1.0 {
            return Err(ControlError::Unstable {
                what: "Kalman error matrix F = Φ − L C".into(),
                detail: format!("spectral radius {rho} ≥ 1"),
            });
        }
        let p_filtered = (DMatrix::identity(NX, NX) - &m * &c) * &p;
        Ok(KalmanDesign {
            phi: from_dyn(&phi),
            gamma: from_dyn(&gamma),
            q: from_dyn(&q),
            r: from_dyn(&r),
            p: from_dyn(&p),
            p_filtered: from_dyn(&p_filtered),
            m: from_dyn(&m),
            l: from_dyn(&l),
            f: from_dyn(&f),
            iterations,
        })
    }
}

/// Exact ZOH discretization with process noise (Van Loan 1978): returns (Φ, Γ, Q_d) of
/// ẋ = A x + B u + w, E[w wᵀ] = W δ, sampled at `t`: Q_d = ∫₀ᵀ e^{As} W e^{Aᵀs} ds.
pub fn van_loan(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    w: &DMatrix<f64>,
    t: f64,
) -> Result<(DMatrix<f64>, DMatrix<f64>, DMatrix<f64>)> {
    let n = a.nrows();
    let (phi, gamma) = flexstage_sim::linalg::c2d(a, b, t)?;
    let mut big = DMatrix::zeros(2 * n, 2 * n);
    big.view_mut((0, 0), (n, n)).copy_from(&(-a * t));
    big.view_mut((0, n), (n, n)).copy_from(&(w * t));
    big.view_mut((n, n), (n, n)).copy_from(&(a.transpose() * t));
    let e = expm(&big)?;
    let q = &phi * e.view((0, n), (n, n));
    let q = 0.5 * (&q + q.transpose());
    Ok((phi, gamma, q))
}

/// Largest number of doubling steps of [`dare`] (each squares the horizon: 60 steps cover
/// 2⁶⁰ samples).
pub const MAX_DOUBLING: usize = 60;

/// The stabilizing solution P of the filter DARE
/// P = Φ P Φᵀ − Φ P Cᵀ (C P Cᵀ + R)⁻¹ C P Φᵀ + Q by structure-preserving doubling
/// (module docs). Returns P and the number of doubling steps. Errors when a step is singular
/// or the iteration has not converged after [`MAX_DOUBLING`] steps ((Φ, C) not detectable
/// or (Φ, Q) not stabilizable on the unit circle).
pub fn dare(
    phi: &DMatrix<f64>,
    c: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
) -> Result<(DMatrix<f64>, usize)> {
    let n = phi.nrows();
    let r_inv = r
        .clone()
        .try_inverse()
        .ok_or_else(|| ControlError::Singular {
            what: "measurement covariance R".into(),
        })?;
    let eye = DMatrix::<f64>::identity(n, n);
    let mut a = phi.transpose();
    let mut g = c.transpose() * r_inv * c;
    let mut h = q.clone();
    for k in 1..=MAX_DOUBLING {
        let w = (&eye + &g * &h)
            .lu()
            .try_inverse()
            .ok_or_else(|| ControlError::Singular {
                what: "doubling step I + G H of the Riccati solver".into(),
            })?;
        let wa = &w * &a;
        let h_next = &h + a.transpose() * &h * &wa;
        let g_next = &g + &a * &w * &g * a.transpose();
        a = &a * &wa;
        let change = (&h_next - &h).amax();
        h = 0.5 * (&h_next + h_next.transpose());
        g = 0.5 * (&g_next + g_next.transpose());
        if !h.iter().all(|v| v.is_finite()) {
            break;
        }
        if change <= 1e-14 * h.amax() {
            return Ok((h, k));
        }
    }
    Err(ControlError::Unstable {
        what: "Kalman Riccati equation".into(),
        detail: format!("no convergence in {MAX_DOUBLING} doubling steps"),
    })
}

/// ‖Φ P Φᵀ − Φ P Cᵀ (C P Cᵀ + R)⁻¹ C P Φᵀ + Q − P‖_max, the DARE residual.
pub fn dare_residual(
    phi: &DMatrix<f64>,
    c: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    p: &DMatrix<f64>,
) -> f64 {
    let s = c * p * c.transpose() + r;
    let Some(s_inv) = s.try_inverse() else {
        return f64::INFINITY;
    };
    let pc = phi * p * c.transpose();
    (phi * p * phi.transpose() - &pc * s_inv * pc.transpose() + q - p).amax()
}
