//! Recursive least squares with a forgetting factor, generic over the number of parameters,
//! and the batch least squares it must agree with (L. Ljung, T. Söderström, *Theory and
//! Practice of Recursive Identification*, MIT Press 1983, ch. 2; written with the equation
//! numbers of Actuators 2022, 11(7), 179, Appendix B, Eq. (A9)–(A11)).
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
//! the scalar W₀⁻¹ + φᵀΓφ.) With one output, W₀ is a positive scalar. An optional trace limit
//! guards against covariance wind-up when λ_f < 1 and the data stop exciting some direction
//! (e.g. a voltage held constant).
//!
//! # Square-root form (departure from the literal recursion)
//! (A11) is implemented in Potter's square-root form: the estimator keeps a factor S with
//! Cov = S Sᵀ, and one step is, with f = Sᵀφ/√λ_f, a = W₀⁻¹ + fᵀf, γ = 1/(a + √(a W₀⁻¹)),
//!
//! ```text
//! S ← (S/√λ_f)(I − γ f fᵀ),    θ̂ ← θ̂ + (S_old f/√λ_f) ε⁰ / a
//! ```
//!
//! which is algebraically identical to (A11) (S Sᵀ after the step equals Cov(t), and the gain
//! equals Cov(t)φW₀), but keeps Cov positive semi-definite by construction and needs half
//! the precision: the conventional update Γ − ggᵀ/(W₀⁻¹ + φᵀg) cancels catastrophically
//! once the covariance spans more than ~10⁸ (the summed PEA regression of `flexstage-piezo`,
//! whose regressors grow with time, reaches 10¹⁵ and more, and the conventional form then
//! loses positive definiteness and diverges). Each update is O(P²) on stack arrays (one
//! square root): no allocation.
//!
//! The stage identification of `flexstage-identify` uses [`Rls`] directly (build φ and y per
//! sample and call [`Rls::update`]); the parallel RLS of the Bouc–Wen model in
//! `flexstage-piezo` uses the information form [`WeightedMoments`] with [`SpdFactor`].
//!
//! [`SpdFactor`]: crate::dense::SpdFactor

// Small dense matrix code reads best with explicit indices.
#![allow(clippy::needless_range_loop)]

use nalgebra::{Cholesky, Const, SMatrix, SVector};

use crate::Error;
use crate::validate::{DataError, Interval, RangeError, check};

/// Accepted forgetting factors λ_f.
const FORGETTING: Interval = Interval::open_closed(0.0, 1.0);

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
    pub fn validate(&self) -> Result<(), RangeError> {
        FORGETTING.check("rls.forgetting", self.forgetting)?;
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
            return Err(RangeError::number(
                "rls.max_trace",
                self.max_trace,
                "a number > 0 (inf for no limit)",
            ));
        }
        Ok(())
    }
}

/// A recursive least-squares estimator of `P` parameters, Eq. (A11), in square-root form.
#[derive(Debug, Clone)]
pub struct Rls<const P: usize> {
    theta: [f64; P],
    /// Square-root factor S of the covariance, Cov = S Sᵀ (module docs).
    sqrt_cov: [[f64; P]; P],
    params: RlsParams,
    updates: u64,
}

impl<const P: usize> Rls<P> {
    /// An estimator starting at `theta0` with Cov(0) = `initial_covariance`·I.
    pub fn new(params: RlsParams, theta0: [f64; P]) -> Result<Self, RangeError> {
        params.validate()?;
        let mut rls = Rls {
            theta: theta0,
            sqrt_cov: [[0.0; P]; P],
            params,
            updates: 0,
        };
        rls.reset_covariance();
        Ok(rls)
    }

    /// An estimator initialized *exactly* from a first block of data: θ̂ is the weighted batch
    /// least-squares solution and Cov the inverse weighted normal matrix (A9), with the
    /// weights W(N, i) of (A10) at constant λ_f. Continuing with [`Rls::update`] then equals
    /// batch least squares over all data seen, with no prior term.
    pub fn from_batch(params: RlsParams, phis: &[[f64; P]], ys: &[f64]) -> Result<Self, Error> {
        params.validate()?;
        let (normal, rhs) = normal_equations(phis, ys, params.forgetting, params.weight)?;
        let chol = cholesky(&normal)?;
        let theta = chol.solve(&SVector::from(rhs));
        // normal = L Lᵀ, so Cov = L⁻ᵀ L⁻¹ = S Sᵀ with S = L⁻ᵀ: Lᵀ S = I.
        let s = chol
            .l_dirty()
            .tr_solve_lower_triangular(&SMatrix::<f64, P, P>::identity())
            .expect("a Cholesky factor has a non-zero diagonal");
        Ok(Rls {
            theta: theta.into(),
            sqrt_cov: std::array::from_fn(|i| std::array::from_fn(|j| s[(i, j)])),
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
        let s = self.params.initial_covariance.sqrt();
        self.sqrt_cov = [[0.0; P]; P];
        for (i, row) in self.sqrt_cov.iter_mut().enumerate() {
            row[i] = s;
        }
    }

    /// Makes parameter `i` a fresh unknown: θ̂_i = `value`, and row and column i of Cov are
    /// replaced by the prior (Cov_ii = `initial_covariance`, cross terms 0). The other
    /// parameters keep their estimates and their covariance block: for the Gaussian posterior
    /// that RLS propagates, this is exact marginalization of the old θ_i followed by an
    /// independent prior on the new one (used when a nuisance offset changes, e.g. a new
    /// record). O(P³) (the square-root factor is recomputed). Panics if `i ≥ P`.
    pub fn reset_parameter(&mut self, i: usize, value: f64) {
        assert!(i < P, "parameter index {i} out of range 0..{P}");
        self.theta[i] = value;
        let mut cov = self.covariance();
        for j in 0..P {
            cov[i][j] = 0.0;
            cov[j][i] = 0.0;
        }
        cov[i][i] = self.params.initial_covariance;
        // Lower Cholesky factor with pivots clipped at 0 (a semi-definite Cov is legitimate
        // after long forgetting-free runs); L Lᵀ = Cov, so S = L.
        let mut l = [[0.0; P]; P];
        for c in 0..P {
            let mut d = cov[c][c];
            for k in 0..c {
                d -= l[c][k] * l[c][k];
            }
            let d = d.max(0.0).sqrt();
            l[c][c] = d;
            for r in c + 1..P {
                let mut v = cov[r][c];
                for k in 0..c {
                    v -= l[r][k] * l[c][k];
                }
                l[r][c] = if d > 0.0 { v / d } else { 0.0 };
            }
        }
        self.sqrt_cov = l;
    }

    /// Current covariance Cov(t) = S Sᵀ (computed, O(P³)).
    pub fn covariance(&self) -> [[f64; P]; P] {
        let s = &self.sqrt_cov;
        let mut cov = [[0.0; P]; P];
        for i in 0..P {
            for j in i..P {
                let mut v = 0.0;
                for k in 0..P {
                    v += s[i][k] * s[j][k];
                }
                cov[i][j] = v;
                cov[j][i] = v;
            }
        }
        cov
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
    /// Returns the a priori error ε⁰. Square-root form (module docs).
    #[inline]
    pub fn update_with_forgetting(&mut self, phi: &[f64; P], y: f64, lambda: f64) -> f64 {
        let r = 1.0 / self.params.weight;
        if lambda != 1.0 {
            // Γ(t) = Cov(t−1)/λ_f: S ← S/√λ_f.
            let scale = lambda.sqrt().recip();
            for row in self.sqrt_cov.iter_mut() {
                for v in row.iter_mut() {
                    *v *= scale;
                }
            }
        }
        let s = &mut self.sqrt_cov;
        // f = Sᵀφ, a = W₀⁻¹ + fᵀf = W₀⁻¹ + φᵀΓφ.
        let mut f = [0.0; P];
        for i in 0..P {
            let p = phi[i];
            for j in 0..P {
                f[j] += s[i][j] * p;
            }
        }
        let mut a = r;
        for v in f {
            a += v * v;
        }
        // g = S f = Γφ; the gain of (A11) is Cov(t)φW₀ = g/a.
        let mut g = [0.0; P];
        for i in 0..P {
            let mut acc = 0.0;
            for j in 0..P {
                acc += s[i][j] * f[j];
            }
            g[i] = acc;
        }
        // S ← S (I − γ f fᵀ) = S − γ g fᵀ.
        let gamma = 1.0 / (a + (a * r).sqrt());
        let mut trace = 0.0;
        for i in 0..P {
            let gi = gamma * g[i];
            for j in 0..P {
                let v = s[i][j] - gi * f[j];
                s[i][j] = v;
                trace += v * v;
            }
        }
        if trace > self.params.max_trace {
            let scale = (self.params.max_trace / trace).sqrt();
            for row in s.iter_mut() {
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
        let k = eps / a;
        for i in 0..P {
            self.theta[i] += g[i] * k;
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
) -> Result<([[f64; P]; P], [f64; P]), DataError> {
    if phis.len() != ys.len() {
        return Err(DataError::new(
            "least squares",
            format!("{} regressors but {} measurements", phis.len(), ys.len()),
        ));
    }
    if phis.len() < P {
        return Err(DataError::new(
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
) -> Result<[f64; P], Error> {
    FORGETTING.check("forgetting", forgetting)?;
    let (a, b) = normal_equations(phis, ys, forgetting, 1.0)?;
    Ok(cholesky(&a)?.solve(&SVector::from(b)).into())
}

/// Smallest accepted Cholesky pivot of the normal equations, relative to its diagonal entry.
const NORMAL_MIN_PIVOT: f64 = 1e-14;

/// Cholesky factor of the normal matrix, or a [`DataError`] when a pivot is below
/// [`NORMAL_MIN_PIVOT`] of its diagonal entry (the regressors are linearly dependent).
fn cholesky<const P: usize>(a: &[[f64; P]; P]) -> Result<Cholesky<f64, Const<P>>, DataError> {
    let m = SMatrix::<f64, P, P>::from_fn(|i, j| a[i][j]);
    let chol = Cholesky::new(m).filter(|c| {
        let l = c.l_dirty();
        (0..P).all(|j| {
            let pivot = l[(j, j)] * l[(j, j)];
            pivot.is_finite() && pivot > NORMAL_MIN_PIVOT * a[j][j].abs()
        })
    });
    chol.ok_or_else(|| {
        DataError::new(
            "least squares",
            "the regressors are linearly dependent (normal matrix not positive definite): \
             the data do not excite every parameter",
        )
    })
}

/// Exponentially weighted second moments M(t) = Σ_{i ≤ t} W(t, i) v(i) v(i)ᵀ of a data vector
/// v (regressor entries and measurement together), with W(t, i) of (A10) at constant λ_f.
///
/// This is the information form of (A9): for any regressor φ = A v and measurement y = bᵀv
/// that are *linear maps of v*, the weighted normal equations are A M Aᵀ θ = A M b, and the
/// weighted residual sum of squares is (b − Aᵀθ)ᵀ M (b − Aᵀθ). Unlike the covariance
/// recursion (A11), the maps A and b may change from one sample to the next and still apply
/// to every past sample: the recursive least-squares estimate is re-evaluated exactly for the
/// *current* map. `flexstage-piezo`'s parallel RLS uses this for the Bouc–Wen regressor, which depends on
/// the current d_p estimate. One update is O(N²) on stack arrays, no allocation.
#[derive(Debug, Clone)]
pub struct WeightedMoments<const N: usize> {
    m: [[f64; N]; N],
    forgetting: f64,
    weight: f64,
    /// Π λ_f over the updates so far (the decay of a prior term).
    decay: f64,
}

impl<const N: usize> WeightedMoments<N> {
    /// Empty moments with forgetting factor λ_f ∈ (0, 1] and weight W₀ > 0.
    pub fn new(forgetting: f64, weight: f64) -> Result<Self, RangeError> {
        FORGETTING.check("forgetting", forgetting)?;
        check("weight", weight, weight > 0.0, "a finite number > 0")?;
        Ok(WeightedMoments {
            m: [[0.0; N]; N],
            forgetting,
            weight,
            decay: 1.0,
        })
    }

    /// M ← λ_f M + W₀ v vᵀ.
    #[inline]
    pub fn add(&mut self, v: &[f64; N]) {
        let (l, w) = (self.forgetting, self.weight);
        for i in 0..N {
            let wi = w * v[i];
            for j in i..N {
                let x = l * self.m[i][j] + wi * v[j];
                self.m[i][j] = x;
                self.m[j][i] = x;
            }
        }
        self.decay *= l;
    }

    /// The moment matrix M.
    #[inline]
    pub fn matrix(&self) -> &[[f64; N]; N] {
        &self.m
    }

    /// Π λ_f over the updates so far: the weight a prior term has left (as in (A11), where
    /// Cov(0) is divided by λ_f at every step).
    #[inline]
    pub fn decay(&self) -> f64 {
        self.decay
    }

    /// M times a vector.
    #[inline]
    pub fn times(&self, a: &[f64; N]) -> [f64; N] {
        let mut out = [0.0; N];
        for i in 0..N {
            let mut acc = 0.0;
            for j in 0..N {
                acc += self.m[i][j] * a[j];
            }
            out[i] = acc;
        }
        out
    }

    /// Profiles out the coefficient of entry `i` when v_i is a regressor entry: M ← M −
    /// M e_i e_iᵀ M / M_ii, so that row and column i become 0. Every quadratic form of M is
    /// then minimized over that coefficient; a later block of data can bring a fresh,
    /// unrelated coefficient for the same entry (e.g. the offset of a new record). No effect
    /// when M_ii = 0.
    pub fn eliminate(&mut self, i: usize) {
        let p = self.m[i][i];
        if p <= 0.0 {
            return;
        }
        let col = self.m[i];
        for r in 0..N {
            for c in 0..N {
                self.m[r][c] -= col[r] * col[c] / p;
            }
        }
        for k in 0..N {
            self.m[i][k] = 0.0;
            self.m[k][i] = 0.0;
        }
    }
}
