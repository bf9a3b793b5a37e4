//! Recursive least squares with a forgetting factor, Eq. (A9)–(A11), generic over the number
//! of parameters, and the batch least squares it must agree with.
//!
//! For a scalar measurement y(t) = φ(t)ᵀθ + e(t) the estimator minimizes
//!
//! ```text
//! Σ_{i ≤ t} W(t, i) (y(i) − φ(i)ᵀθ)²,   W(t, i) = Π_{m=i+1..t} λ_f(m) · W₀        (A10)
//! ```
//!
//! so Cov(t) = [Σ φ(i) W(t,i) φ(i)ᵀ]⁻¹ (A9), with the recursion (A11):
//!
//! ```text
//! Γ(t)     = Cov(t−1)/λ_f(t)
//! Cov(t)   = Γ(t) − Γ(t)φ(t) [W₀⁻¹ + φ(t)ᵀΓ(t)φ(t)]⁻¹ φ(t)ᵀΓ(t)
//! ε⁰(t)    = y(t) − φ(t)ᵀθ̂(t−1)                       (a priori prediction error)
//! θ̂(t)     = θ̂(t−1) + Cov(t) φ(t) W₀ ε⁰(t)
//! ```
//!
//! (The paper writes "φ(t)[…]⁻¹φ(t)ᵀ" with φ a row; with φ a column, as here, the bracket is
//! the scalar W₀⁻¹ + φᵀΓφ.) With one output, W₀ is a positive scalar. Each update is
//! O(P²) on stack arrays: no allocation. The covariance is re-symmetrized after each update,
//! and an optional trace limit guards against covariance wind-up when λ_f < 1 and the data
//! stop exciting some direction (e.g. a voltage held constant).
//!
//! The stage identification uses the same type: build φ and y per sample and call
//! [`Rls::update`].

// Small dense matrix code reads best with explicit indices.
#![allow(clippy::needless_range_loop)]

use crate::error::{Result, check, data_error};

/// Settings of [`Rls`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RlsParams {
    /// Forgetting factor λ_f in (0, 1]. 1 is plain least squares. Typical: 0.995–0.99999.
    pub forgetting: f64,
    /// Measurement weight W₀ > 0. Default 1.
    pub weight: f64,
    /// Initial covariance Cov(0) = c·I, c > 0: large means "no prior confidence". Default 1e6.
    pub initial_covariance: f64,
    /// Upper limit of trace(Cov), > 0 (infinite: no limit). When exceeded, Cov is scaled
    /// down to it (anti-windup). Default infinite.
    pub max_trace: f64,
}

impl Default for RlsParams {
    fn default() -> Self {
        RlsParams {
            forgetting: 1.0,
            weight: 1.0,
            initial_covariance: 1e6,
            max_trace: f64::INFINITY,
        }
    }
}

impl RlsParams {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        check(
            "rls.forgetting",
            self.forgetting,
            self.forgetting > 0.0 && self.forgetting <= 1.0,
            "a number in (0, 1]",
        )?;
        check(
            "rls.weight",
            self.weight,
            self.weight > 0.0,
            "a finite number > 0",
        )?;
        check(
            "rls.initial_covariance",
            self.initial_covariance,
            self.initial_covariance > 0.0,
            "a finite number > 0",
        )?;
        if self.max_trace.is_nan() || self.max_trace <= 0.0 {
            return Err(crate::PiezoError::OutOfRange {
                field: "rls.max_trace".into(),
                value: format!("{:e}", self.max_trace),
                expected: "a number > 0 (inf for no limit)".into(),
            });
        }
        Ok(())
    }
}

/// A recursive least-squares estimator of `P` parameters, Eq. (A11).
#[derive(Debug, Clone)]
pub struct Rls<const P: usize> {
    theta: [f64; P],
    cov: [[f64; P]; P],
    params: RlsParams,
    updates: u64,
}

impl<const P: usize> Rls<P> {
    /// An estimator starting at `theta0` with Cov(0) = `initial_covariance`·I.
    pub fn new(params: RlsParams, theta0: [f64; P]) -> Result<Self> {
        params.validate()?;
        let mut cov = [[0.0; P]; P];
        for (i, row) in cov.iter_mut().enumerate() {
            row[i] = params.initial_covariance;
        }
        Ok(Rls {
            theta: theta0,
            cov,
            params,
            updates: 0,
        })
    }

    /// An estimator initialized *exactly* from a first block of data: θ̂ is the weighted batch
    /// least-squares solution and Cov the inverse weighted normal matrix (A9), with the
    /// weights W(N, i) of (A10) at constant λ_f. Continuing with [`Rls::update`] then equals
    /// batch least squares over all data seen, with no prior term.
    pub fn from_batch(params: RlsParams, phis: &[[f64; P]], ys: &[f64]) -> Result<Self> {
        params.validate()?;
        let (normal, rhs) = normal_equations(phis, ys, params.forgetting, params.weight)?;
        let chol = cholesky(&normal)?;
        let theta = chol_solve(&chol, &rhs);
        let mut cov = [[0.0; P]; P];
        for j in 0..P {
            let mut e = [0.0; P];
            e[j] = 1.0;
            let col = chol_solve(&chol, &e);
            for i in 0..P {
                cov[i][j] = col[i];
            }
        }
        Ok(Rls {
            theta,
            cov,
            params,
            updates: phis.len() as u64,
        })
    }

    /// Current estimate θ̂.
    pub fn theta(&self) -> &[f64; P] {
        &self.theta
    }

    /// Overwrites the estimate (keeps the covariance).
    pub fn set_theta(&mut self, theta: [f64; P]) {
        self.theta = theta;
    }

    /// Resets the covariance to Cov(0) = `initial_covariance`·I (keeps θ̂).
    pub fn reset_covariance(&mut self) {
        self.cov = [[0.0; P]; P];
        for (i, row) in self.cov.iter_mut().enumerate() {
            row[i] = self.params.initial_covariance;
        }
    }

    /// Current covariance Cov(t).
    pub fn covariance(&self) -> &[[f64; P]; P] {
        &self.cov
    }

    /// The settings.
    pub fn params(&self) -> &RlsParams {
        &self.params
    }

    /// Number of updates so far.
    pub fn updates(&self) -> u64 {
        self.updates
    }

    /// One step of (A11) with the configured λ_f. Returns the a priori error ε⁰.
    #[inline]
    pub fn update(&mut self, phi: &[f64; P], y: f64) -> f64 {
        self.update_with_forgetting(phi, y, self.params.forgetting)
    }

    /// One step of (A11) with a time-varying forgetting factor `lambda` = λ_f(t) ∈ (0, 1].
    /// Returns the a priori error ε⁰.
    #[inline]
    pub fn update_with_forgetting(&mut self, phi: &[f64; P], y: f64, lambda: f64) -> f64 {
        let inv_lambda = 1.0 / lambda;
        // g = Γφ = Cov φ / λ
        let mut g = [0.0; P];
        for i in 0..P {
            let mut acc = 0.0;
            for j in 0..P {
                acc += self.cov[i][j] * phi[j];
            }
            g[i] = acc * inv_lambda;
        }
        let mut phi_g = 0.0;
        for i in 0..P {
            phi_g += phi[i] * g[i];
        }
        let denom = 1.0 / self.params.weight + phi_g;
        let inv_denom = 1.0 / denom;
        // Cov = Γ − g gᵀ / denom, symmetrized.
        let mut trace = 0.0;
        for i in 0..P {
            for j in i..P {
                let v =
                    0.5 * (self.cov[i][j] + self.cov[j][i]) * inv_lambda - g[i] * g[j] * inv_denom;
                self.cov[i][j] = v;
                self.cov[j][i] = v;
            }
            trace += self.cov[i][i];
        }
        if trace > self.params.max_trace {
            let scale = self.params.max_trace / trace;
            for row in self.cov.iter_mut() {
                for v in row.iter_mut() {
                    *v *= scale;
                }
            }
        }
        let mut pred = 0.0;
        for i in 0..P {
            pred += phi[i] * self.theta[i];
        }
        let eps = y - pred;
        // Cov(t) φ W₀ = g (1 − φᵀg/denom) W₀ = g/denom: the gain of (A11) in closed form
        // (identical to multiplying by the updated Cov, before any trace limiting).
        for i in 0..P {
            self.theta[i] += g[i] * inv_denom * eps;
        }
        self.updates += 1;
        eps
    }
}

/// Weighted normal equations Σ w_i φ_i φ_iᵀ, Σ w_i φ_i y_i with w_i = W₀ λ^{N−1−i} (A10).
fn normal_equations<const P: usize>(
    phis: &[[f64; P]],
    ys: &[f64],
    forgetting: f64,
    weight: f64,
) -> Result<([[f64; P]; P], [f64; P])> {
    if phis.len() != ys.len() {
        return Err(data_error(
            "least squares",
            format!("{} regressors but {} measurements", phis.len(), ys.len()),
        ));
    }
    if phis.len() < P {
        return Err(data_error(
            "least squares",
            format!("need at least {P} samples, got {}", phis.len()),
        ));
    }
    let mut a = [[0.0; P]; P];
    let mut b = [0.0; P];
    // Accumulate backwards so the weight is a running product.
    let mut w = weight;
    for (phi, &y) in phis.iter().zip(ys).rev() {
        for i in 0..P {
            for j in i..P {
                a[i][j] += w * phi[i] * phi[j];
            }
            b[i] += w * phi[i] * y;
        }
        w *= forgetting;
    }
    for i in 0..P {
        for j in 0..i {
            a[i][j] = a[j][i];
        }
    }
    Ok((a, b))
}

/// Weighted batch least squares: θ minimizing Σ W₀ λ^{N−1−i} (y_i − φ_iᵀθ)², solved by
/// Cholesky on the normal equations (A9). `forgetting` = 1 gives ordinary least squares.
pub fn batch_least_squares<const P: usize>(
    phis: &[[f64; P]],
    ys: &[f64],
    forgetting: f64,
) -> Result<[f64; P]> {
    check(
        "forgetting",
        forgetting,
        forgetting > 0.0 && forgetting <= 1.0,
        "a number in (0, 1]",
    )?;
    let (a, b) = normal_equations(phis, ys, forgetting, 1.0)?;
    let l = cholesky(&a)?;
    Ok(chol_solve(&l, &b))
}

/// Lower Cholesky factor of a symmetric positive definite matrix.
fn cholesky<const P: usize>(a: &[[f64; P]; P]) -> Result<[[f64; P]; P]> {
    let mut l = [[0.0; P]; P];
    for j in 0..P {
        let mut d = a[j][j];
        for k in 0..j {
            d -= l[j][k] * l[j][k];
        }
        if d.is_nan() || d <= 1e-14 * a[j][j].abs() || !d.is_finite() {
            return Err(data_error(
                "least squares",
                "the regressors are linearly dependent (normal matrix not positive definite): \
                 the data do not excite every parameter",
            ));
        }
        let d = d.sqrt();
        l[j][j] = d;
        for i in j + 1..P {
            let mut v = a[i][j];
            for k in 0..j {
                v -= l[i][k] * l[j][k];
            }
            l[i][j] = v / d;
        }
    }
    Ok(l)
}

fn chol_solve<const P: usize>(l: &[[f64; P]; P], b: &[f64; P]) -> [f64; P] {
    let mut y = [0.0; P];
    for i in 0..P {
        let mut v = b[i];
        for k in 0..i {
            v -= l[i][k] * y[k];
        }
        y[i] = v / l[i][i];
    }
    let mut x = [0.0; P];
    for i in (0..P).rev() {
        let mut v = y[i];
        for k in i + 1..P {
            v -= l[k][i] * x[k];
        }
        x[i] = v / l[i][i];
    }
    x
}
