//! The K-filter state observer, Eq. (37)–(42), discretized exactly for the sample time.
//!
//! # Continuous design (Eq. 37–39)
//! With output injection on the two measured positions,
//! B0 = B − k_e1 e₁ᵀ − k_e2 e₂ᵀ (Eq. 38). Table 4 gives scalar gains; the injection vectors
//! are read as k_ei = g_i e_i (each measured position corrects its own estimate), so B0 is B
//! with −g₁, −g₂ added to its first two diagonal entries. B0 must be Hurwitz; this is verified
//! as Eq. (39) asks, by solving P B0 + B0ᵀ P = −I ([`flexstage_sim::linalg::lyap`]) and checking
//! P = Pᵀ > 0 ([`ObserverDesign::lyapunov`]). The continuous error obeys ε̇ = B0 ε (Eq. 42).
//!
//! # Why not forward Euler
//! With g = 1e5 s⁻¹ and T = 1e-4 s, forward Euler maps the pole −g to 1 − gT = −9: unstable
//! (DECISIONS.md). The continuous observer needs y(t) between samples, which a sampled controller
//! does not have, so it is discretized in the form that is *exact for sampled
//! measurements*:
//!
//! ```text
//! ẑ_{k+1} = Φ ẑ_k + Γ u_k + L (y_k − C ẑ_k),   Φ = e^{BT}, Γ = ∫₀ᵀ e^{Bs} ds b   (ZOH, c2d)
//! ε_{k+1} = F ε_k,                              F = Φ − L C                      (42, discrete)
//! ```
//!
//! L is chosen so that F equals Φ0 = e^{B0 T}, the exact sampled flow of Eq. (42), in every
//! entry that output injection can reach: L C only touches the columns of the measured states,
//! so L = (Φ − Φ0)[:, 1..2] makes F[:, 1..2] = Φ0[:, 1..2] (the closest F to Φ0 in the
//! Frobenius norm). The construction fails unless F is Schur stable. On the noise-free linear
//! plant the estimation error then follows ε_k = F^k ε_0 to rounding (`tests/observer.rs`).
//!
//! # Model-error state
//! The observer state is [z, d] (10 numbers): d is the model error Δ_η of Eq. (36)/(43) on
//! the output accelerations (rows 5–6), modelled as constant, with continuous injection
//! κ_d S⁻¹ (S the static gain from d to q) in B0. Mismatched stiffness, cross terms and
//! residual hysteresis all show up at low frequency as such a force; the law cancels the
//! estimate, which gives the loop its integral action (crate docs). Everything above
//! (Eq. 39 check, exact discretization, F) applies to the 10 × 10 matrices.
//!
//! # K-filter form (Eq. 40–41)
//! ẑ = ζ + Ω₁ + Ω₂, with ζ_{k+1} = F ζ_k + L y_k (the filter of the output) and
//! Ω_{i,k+1} = F Ω_{i,k} + Γ e_i u_{i,k} (the filters of each input). Eq. (40) writes
//! ẑ = ζ + Ωᵀb while Eq. (41) already feeds d_ii u_i into Ωᵀ, which would apply D twice; the
//! input filters here carry D (inside Γ), and the estimate is their plain sum.

use nalgebra::DMatrix;

use crate::error::{ControlError, Result, positive};
use flexstage_sim::linalg::{
    c2d, expm, is_positive_definite, lyap, spectral_abscissa, spectral_radius,
};
use flexstage_sim::model::{StageModel, from_dyn, to_dyn};
use nalgebra::{SMatrix, SVector};

/// Size of the observer state: z (8) and the input disturbance d (2).
pub const NX: usize = 10;
/// Where the input disturbance d is in the observer state (after z).
pub const DISTURBANCE: [usize; 2] = [8, 9];
/// 10 × 10 matrix.
pub type Matrix10 = SMatrix<f64, NX, NX>;
/// 10 × 2 matrix.
pub type Matrix10x2 = SMatrix<f64, NX, 2>;
/// 10-vector.
pub type Vector10 = SVector<f64, NX>;

/// Settings of the observer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObserverParams {
    /// Injection gains g₁, g₂ [1/s], > 0. Table 4: 1e5, 1e5.
    pub gain: [f64; 2],
    /// Sample time T \[s\], > 0. Section 4.1: 1e-4.
    pub sample_time: f64,
    /// Bandwidth κ_d [1/s] of the input-disturbance estimate d̂, > 0 (see the module docs).
    pub disturbance_gain: f64,
}

impl ObserverParams {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        positive("controller.observer_gain[0]", self.gain[0])?;
        positive("controller.observer_gain[1]", self.gain[1])?;
        positive("simulation.sample_time", self.sample_time)?;
        positive("controller.disturbance_gain", self.disturbance_gain)
    }
}

/// The augmented model of the observer: ż = B z + b u + E d, ḋ = 0, with d = Δ_η
/// (Eq. 36, 43) entering the output accelerations (rows 5–6). Returns the 10 × 10 system
/// matrix and the 10 × 2 input matrix.
pub fn augmented(model: &StageModel) -> Result<(Matrix10, Matrix10x2)> {
    let mut b = Matrix10::zeros();
    b.fixed_view_mut::<8, 8>(0, 0).copy_from(&model.b);
    b[(4, DISTURBANCE[0])] = 1.0;
    b[(5, DISTURBANCE[1])] = 1.0;
    let mut b_in = Matrix10x2::zeros();
    b_in.fixed_view_mut::<8, 2>(0, 0)
        .copy_from(&model.input_matrix());
    Ok((b, b_in))
}

/// The matrices of the observer design, with their checks.
#[derive(Debug, Clone, PartialEq)]
pub struct ObserverDesign {
    /// B0 of Eq. (38) for the augmented state [z, d] (10 × 10).
    pub b0: Matrix10,
    /// P of Eq. (39): P B0 + B0ᵀ P = −I.
    pub p: Matrix10,
    /// Φ = e^{B T} of the augmented model.
    pub phi: Matrix10,
    /// Γ = ∫₀ᵀ e^{Bs} ds b (10 × 2).
    pub gamma: Matrix10x2,
    /// Φ0 = e^{B0 T}, the sampled flow of Eq. (42).
    pub phi0: Matrix10,
    /// Discrete injection gain L (10 × 2).
    pub l: Matrix10x2,
    /// Discrete error matrix F = Φ − L C.
    pub f: Matrix10,
}

impl ObserverDesign {
    /// Builds and checks the design: B0 Hurwitz (Eq. 39 solvable with P > 0) and F Schur.
    pub fn new(model: &StageModel, params: &ObserverParams) -> Result<ObserverDesign> {
        ObserverDesign::build(model, params, true)
    }

    /// The design without its stability checks, for a controller whose injection gain comes
    /// from elsewhere (the Kalman estimate, [`crate::estimator`]): only Φ and Γ are used then,
    /// and a K-filter injection that would not be stable on this model must not refuse it.
    /// P is zero when B0 is not Hurwitz (Eq. 39 has no positive definite solution).
    pub fn sampled_model(model: &StageModel, params: &ObserverParams) -> Result<ObserverDesign> {
        ObserverDesign::build(model, params, false)
    }

    fn build(model: &StageModel, params: &ObserverParams, checked: bool) -> Result<ObserverDesign> {
        params.validate()?;
        let (b, b_in) = augmented(model)?;
        // Continuous injection K (Eq. 38 with k_ei = g_i e_i on the positions, and
        // κ_d S⁻¹ on the disturbance, S = −C B⁻¹ E the static gain from d to q): B0 = B − K C.
        let b_inv = model
            .b
            .try_inverse()
            .ok_or_else(|| ControlError::Singular { what: "B".into() })?;
        let s_gain = nalgebra::Matrix2::new(
            -b_inv[(0, 4)],
            -b_inv[(0, 5)],
            -b_inv[(1, 4)],
            -b_inv[(1, 5)],
        );
        let g_dc_inv = s_gain.try_inverse().ok_or_else(|| ControlError::Singular {
            what: "static gain from Δ_η to q".into(),
        })?;
        let mut b0 = b;
        b0[(0, 0)] -= params.gain[0];
        b0[(1, 1)] -= params.gain[1];
        for i in 0..2 {
            for j in 0..2 {
                b0[(8 + i, j)] -= params.disturbance_gain * g_dc_inv[(i, j)];
            }
        }
        let b0d = to_dyn(&b0);
        let abscissa = spectral_abscissa(&b0d)?;
        let p = if abscissa < 0.0 {
            let p = lyap(&b0d.transpose(), &DMatrix::identity(NX, NX))?;
            if checked && !is_positive_definite(&p) {
                return Err(ControlError::Unstable {
                    what: "observer matrix B0 (Eq. 39)".into(),
                    detail: "the Lyapunov solution P is not positive definite".into(),
                });
            }
            p
        } else if checked {
            return Err(ControlError::Unstable {
                what: "observer matrix B0 (Eq. 38)".into(),
                detail: format!("max Re λ = {abscissa:e} ≥ 0"),
            });
        } else {
            DMatrix::zeros(NX, NX)
        };
        let t = params.sample_time;
        let (phi, gamma) = c2d(&to_dyn(&b), &to_dyn(&b_in), t)?;
        let phi0 = expm(&(&b0d * t))?;
        let l = (&phi - &phi0).columns(0, 2).into_owned();
        let mut f = phi.clone();
        f.columns_mut(0, 2).copy_from(&phi0.columns(0, 2));
        let rho = spectral_radius(&f)?;
        if checked && rho >= 1.0 {
            return Err(ControlError::Unstable {
                what: "discrete observer error matrix F".into(),
                detail: format!("spectral radius {rho} ≥ 1"),
            });
        }
        Ok(ObserverDesign {
            b0,
            p: from_dyn(&p),
            phi: from_dyn(&phi),
            gamma: from_dyn(&gamma),
            phi0: from_dyn(&phi0),
            l: from_dyn(&l),
            f: from_dyn(&f),
        })
    }

    /// The residual ‖P B0 + B0ᵀ P + I‖_max of Eq. (39).
    pub fn lyapunov_residual(&self) -> f64 {
        (self.p * self.b0 + self.b0.transpose() * self.p + Matrix10::identity()).amax()
    }

    /// True when P = Pᵀ > 0 (Eq. 39).
    pub fn lyapunov(&self) -> bool {
        let sym = (self.p - self.p.transpose()).amax() <= 1e-9 * self.p.amax();
        sym && is_positive_definite(&to_dyn(&self.p))
    }
}

/// Number of numbers in [`KFilter::state`].
pub const FILTER_LEN: usize = 3 * NX;

/// The discrete K-filter: ζ and the two input filters Ω₁, Ω₂ (Eq. 40–41). No allocation.
#[derive(Debug, Clone)]
pub struct KFilter {
    f: Matrix10,
    l: Matrix10x2,
    gamma: Matrix10x2,
    zeta: Vector10,
    omega: [Vector10; 2],
}

impl KFilter {
    /// A filter at ẑ = 0, d̂ = 0.
    pub fn new(design: &ObserverDesign) -> KFilter {
        KFilter {
            f: design.f,
            l: design.l,
            gamma: design.gamma,
            zeta: Vector10::zeros(),
            omega: [Vector10::zeros(); 2],
        }
    }

    /// A filter at zero with any predictor gain `l` (e.g. the steady-state Kalman gain of
    /// [`crate::estimator::KalmanDesign`]): F = Φ − L C.
    pub fn with_gain(phi: &Matrix10, gamma: &Matrix10x2, l: &Matrix10x2) -> KFilter {
        let mut f = *phi;
        for i in 0..2 {
            let col = f.column(i) - l.column(i);
            f.set_column(i, &col);
        }
        KFilter {
            f,
            l: *l,
            gamma: *gamma,
            zeta: Vector10::zeros(),
            omega: [Vector10::zeros(); 2],
        }
    }

    /// A filter at zero with the error matrix `f` = Φ − L C, the injection gain `l` and the
    /// input matrix `gamma` as they are ([`KFilter::matrices`] of another filter).
    pub fn from_matrices(f: &Matrix10, l: &Matrix10x2, gamma: &Matrix10x2) -> KFilter {
        KFilter {
            f: *f,
            l: *l,
            gamma: *gamma,
            zeta: Vector10::zeros(),
            omega: [Vector10::zeros(); 2],
        }
    }

    /// The filter's matrices (F, L, Γ).
    pub fn matrices(&self) -> (Matrix10, Matrix10x2, Matrix10x2) {
        (self.f, self.l, self.gamma)
    }

    /// The estimate [ẑ_k, d̂_k] = ζ + Ω₁ + Ω₂ (Eq. 40).
    #[inline]
    pub fn estimate(&self) -> Vector10 {
        self.zeta + self.omega[0] + self.omega[1]
    }

    /// Advances to the next sample with the measurement y_k and the input u_k held over the
    /// sample (ZOH), Eq. (41) discretized.
    #[inline]
    pub fn step(&mut self, y: [f64; 2], u: [f64; 2]) {
        self.zeta = self.f * self.zeta + self.l.column(0) * y[0] + self.l.column(1) * y[1];
        for i in 0..2 {
            self.omega[i] = self.f * self.omega[i] + self.gamma.column(i) * u[i];
        }
    }

    /// Sets the estimate to `x` = [z, d] (ζ = x, Ω = 0).
    pub fn reset(&mut self, x: Vector10) {
        self.zeta = x;
        self.omega = [Vector10::zeros(); 2];
    }

    /// The filter states [ζ, Ω₁, Ω₂].
    pub fn state(&self) -> [f64; FILTER_LEN] {
        let mut s = [0.0; FILTER_LEN];
        s[..NX].copy_from_slice(self.zeta.as_slice());
        s[NX..2 * NX].copy_from_slice(self.omega[0].as_slice());
        s[2 * NX..].copy_from_slice(self.omega[1].as_slice());
        s
    }

    /// Sets the filter states from [`KFilter::state`]'s layout.
    pub fn set_state(&mut self, s: &[f64; FILTER_LEN]) {
        self.zeta = Vector10::from_column_slice(&s[..NX]);
        self.omega[0] = Vector10::from_column_slice(&s[NX..2 * NX]);
        self.omega[1] = Vector10::from_column_slice(&s[2 * NX..]);
    }
}
