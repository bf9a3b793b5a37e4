//! Identification of the Bouc–Wen parameters from (t, U, x) records, Appendix B.
//!
//! # The regression (A8), integrated over one sample
//! Differentiating x_nom = d_p U − h and inserting Eq. (18) gives
//!
//! ```text
//! ẋ_nom = α U̇ + B_bw |U̇| h + Γ_bw U̇ |h| − δ_bw U sgn(U̇),    α = d_p − A_bw          (A8)
//! ```
//!
//! which is linear in θ = [α, B_bw, Γ_bw, δ_bw] once h is known. The paper writes it with
//! time derivatives; differentiating measured x amplifies sensor noise by 1/Δt. Here (A8) is
//! integrated over each sample interval [t_{k−1}, t_k], along which U is a ramp (sgn(U̇) = s
//! constant):
//!
//! ```text
//! Δx_k = α ΔU_k + B_bw |ΔU_k| h̄_k + Γ_bw ΔU_k |h̄_k| − δ_bw Δt_k Ū_k s_k
//! ```
//!
//! with Ū, h̄ the interval means (exact for the U and δ terms, midpoint rule for h), and h
//! from the measurement, h̄ = d_p Ū − x̄ ("measured x gives h once d_p is known"). The δ
//! regressor carries Δt, so δ_bw comes out in µm/(V·s) as in Table A1.
//!
//! # Summed from the start (departure 1 from the paper)
//! Regressing the increments Δx_k makes the noise differenced (n_k − n_{k−1}: strongly
//! correlated, and 10 nm of noise is large against the per-sample increments), and least
//! squares on it is inefficient: with 10 nm noise the increment form wandered 10–900 % off.
//! Both the online and the batch estimators therefore regress the *level*, summed from the
//! first sample k = 0 of the record, where the noise is white again:
//!
//! ```text
//! x_k = x_0 + α s_u + B_bw (d_p s_bu − s_bx) + Γ_bw (d_p s_gu − s_gx) + δ_bw s_d
//! s_u  = Σ ΔU_j = U_k − U_0,     s_bu = Σ |ΔU_j| Ū_j,    s_bx = Σ |ΔU_j| x̄_j,
//! s_gu = Σ σ_j ΔU_j Ū_j,         s_gx = Σ σ_j ΔU_j x̄_j,  s_d  = −Σ Δt_j Ū_j s_j     (j ≤ k)
//! ```
//!
//! (σ_j = sgn h̄_j, evaluated once with the d̂_p of that sample.) The offset x_0 is a fifth
//! unknown of the θ estimator. The regressor is *affine in d_p*, and the sums do not depend on
//! d_p (except through σ, which only matters where h̄ ≈ 0).
//!
//! # The two estimators (Algorithm A1), in the information form (A9) (departure 2)
//! Per sample, as in Algorithm A1: the θ estimator, then "update h" (h = d̂_p U − x), then the
//! d_p estimator. Both minimize the same criterion, the exponentially weighted sum (A10) of
//! squared level residuals e_k = x_k − c_k(d_p)ᵀ[x_0, θ]:
//!
//! * **θ estimator**, (A9) for the summed (A8) at the current d̂_p: the weighted normal
//!   equations Σ W c_k(d̂_p) c_k(d̂_p)ᵀ θ = Σ W c_k(d̂_p) x_k, plus the prior Cov(0)⁻¹ = I/c
//!   (decaying with λ_f as in (A11)).
//! * **d_p estimator**, the scalar regression of the residual on d_p (the paper's (A12),
//!   x = d_p U − h, with h expressed through the regressors above). Its regressor is ψ_k =
//!   ∂(c_kᵀθ̂)/∂d_p = B̂ s_bu + Γ̂ s_gu, made orthogonal to the θ regressors (ψ⊥ = ψ −
//!   C N⁻¹Cᵀψ, N = CᵀWC), so that the d_p step accounts for θ re-adjusting:
//!   Δd̂_p = ψᵀW e / ψ⊥ᵀW ψ⊥ (a Gauss–Newton step of the separable least-squares problem),
//!   limited to 0.1 % of d̂_p per sample (trust region; the first samples excite little) and
//!   projected onto `dp_bounds`.
//!
//! Why not the covariance recursion (A11) for each estimator: the regressor of each depends on
//! the other's current estimate. (A11) freezes every past regressor row with the estimates of
//! its time, and in the summed form the rows grow with time, so stale rows dominate: with
//! (A11) on the summed regressors (and the d_p estimator of the paper, ψ at fixed θ̂) the
//! estimates stalled 2–5000 % off even without noise (also with λ_f = 0.9999–0.99995). The
//! plain alternation (d_p regressed at fixed θ̂, without the orthogonalization) converged far
//! too slowly for the same reason: d_p and θ are strongly coupled (a d_p error of 0.005 %
//! moved B_bw, Γ_bw, δ_bw by up to 200 %).
//! Here every quantity is a linear map of the data vector v_k = [1, s_u, s_bu, s_bx, s_gu,
//! s_gx, s_d, x_k], so the single 8×8 moment matrix M = Σ W v vᵀ ([`WeightedMoments`], the
//! information form of (A9)–(A10), updated recursively with λ_f) gives the normal equations of
//! both estimators for the *current* estimates over all past samples, exactly. Per sample this
//! is O(1): a rank-one update of M and two 5×5 Cholesky solves, no allocation. With λ_f = 1
//! the estimates converge to the batch least-squares solution ([`fit_batch`]) of the record.
//!
//! # Constraints
//! The estimators stay unconstrained (exact least squares); [`ParallelRls::estimate`] and the
//! h/σ evaluation use the estimates projected onto the admissible set (B_bw ≥ 0,
//! B_bw + Γ_bw > 0, d_p within `dp_bounds`, by default between the slope s of the line x(U)
//! and 5s). Projecting inside a recursive estimator fed back into it and diverged.
//!
//! # Measured behaviour
//! Tests (`tests/identify.rs`), Table A1 parameters, 10 kHz, the decaying 1 Hz drive of
//! 10 s, from Table A1's zero initial guess, λ_f = 1: noise-free, every parameter within
//! 0.001 %; with 10 nm sensor noise, seeds 1–10, worst parameter error 1.1 % (PEA1)
//! and 2.7 % (PEA2), δ_bw being the hardest (its effect is only ~0.1 µm per loop at 1 Hz;
//! a slower drive helps, since the δ effect grows with the time spent per loop). With
//! forgetting the memory shortens and the noise shows: λ_f = 0.99998 (5 s memory) 1.2 % and
//! 2.9 %, λ_f = 0.9999 (1 s) 2.1 % and 6.1 %.
//!
//! # Batch fit
//! [`fit_batch`] fits the same summed regression offline by *variable projection*: for a given
//! d_p the problem is linear in [x_0, θ], solved by least squares; the residual sum of squares
//! ([`profile_rss`]) is then minimized globally over the scalar d_p (next section). It needs
//! no initial guess and is the cross-check of the recursive estimates.
//!
//! # Global d_p
//! On a single-amplitude periodic drive (triangle or sine, 10 periods) the profile of d_p is
//! flat (RSS ≈ 10⁵ µm² at 10 nm noise) except for one valley about ±0.1 % of d_p wide at the
//! truth (RSS ≈ N σ²); the valley narrows with the number of periods, since a wrong d_p leaves
//! a residual that the summed form accumulates period after period. A 56-point grid plus a
//! local golden section missed it (d_p 6–54 % off), and the recursive d_p estimator, a local
//! Gauss–Newton step per sample, left d̂_p a few 1e-5 off in the valley's flank while the
//! σ_j = sgn h̄_j frozen into the sums early (with d̂_p still near the slope) biased the
//! criterion itself: Γ_bw up to 103 % off. So:
//!
//! * the search is global: the record's 8×8 moments Σ v vᵀ make the profile O(1) per point,
//!   so d_p is scanned on 18 000 points over [0.8 s, 5 s] (σ evaluated at 45 centres), then
//!   the exact profile is evaluated on ±16 scan steps around the best point (the moment
//!   profile loses digits to cancellation) and golden section finishes;
//! * [`identify`] seeds the recursive estimator with that global d_p
//!   ([`ParallelRls::seeded`]): σ_j use it, and a prior on d̂_p (weight of about one period
//!   of data) holds it through the first period; at the end of the record a few Gauss–Newton
//!   iterations ([`ParallelRls::settle`]) converge d̂_p to the minimum of the accumulated
//!   criterion. The per-sample recursion is unchanged, usable online without the seed.
//!
//! Measured (tests/identify_periodic.rs, 10 nm noise, seeds 1–10, PEA1 and PEA2, triangle
//! and sine): every parameter within 3.5 % (δ_bw of PEA2 on the triangle the worst), RLS and
//! batch fit equal to 1e-6.

use flexstage_numerics::dense::SpdFactor;
use flexstage_numerics::rls::{WeightedMoments, batch_least_squares};
use flexstage_numerics::{DataError, RangeError};
use serde::{Deserialize, Serialize};

use crate::data::PeaData;
use crate::error::{Result, check};
use crate::hysteresis::line_fit;
use crate::model::{BoucWenParams, sgn};

/// Settings of the parallel RLS identification (Algorithm A1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdentifyParams {
    /// Forgetting factor λ_f of (A10) in (0, 1], shared by both estimators (they minimize one
    /// weighted criterion, module docs). Default 1: the estimates then converge to the batch
    /// least-squares solution of the whole record. Below 1 the memory is about 1/(1 − λ_f)
    /// samples; keep it at several drive periods (B_bw and Γ_bw are separable only across
    /// segments where sgn(U̇)·sgn(h) differs, and δ_bw only over whole loops): at 10 kHz and
    /// 1 Hz, λ_f = 0.99998 (5 s) still meets 5 % with 10 nm noise, 0.9999 (1 s) does not.
    pub forgetting: f64,
    /// Cov(0) = c·I of (A11): the prior on θ and d_p around `initial` has weight 1/c (decaying
    /// with λ_f like Cov(0) in (A11)). Default 1e4 (no practical influence).
    pub initial_covariance: f64,
    /// Initial guess. Table A1 starts from zeros; d_p = 0 is then replaced by the slope of
    /// the least-squares line x(U) of the record (a zero d_p makes h = −x, far from the truth).
    pub initial: BoucWenParams,
    /// Admissible range of d_p [µm/V] (parameter projection), 0 ≤ lower < upper. [`identify`]
    /// narrows a default (0, ∞) to [s, 5s] with s the slope of the least-squares line x(U):
    /// for A_bw > 0 the hysteresis lowers the apparent slope, so d_p > s.
    pub dp_bounds: (f64, f64),
    /// Runs over the record, ≥ 1, carrying the estimates and the accumulated information over
    /// (each pass is a new record: the sums restart, and its offset x_0 is a new unknown).
    /// Default 1 (online use).
    pub passes: u32,
    /// Record the estimates every this many samples for the convergence history, ≥ 1.
    pub record_every: usize,
}

impl Default for IdentifyParams {
    fn default() -> Self {
        IdentifyParams {
            forgetting: 1.0,
            initial_covariance: 1e4,
            initial: BoucWenParams {
                d_p: 0.0,
                a_bw: 0.0,
                b_bw: 0.0,
                gamma_bw: 0.0,
                delta_bw: 0.0,
            },
            dp_bounds: (0.0, f64::INFINITY),
            passes: 1,
            record_every: 100,
        }
    }
}

/// Smallest forgetting factor: below it the estimator remembers fewer than 10 samples, too
/// few for the parameters it estimates (a factor of 1e-20 once overflowed the covariance).
pub const MIN_FORGETTING: f64 = 0.9;

impl IdentifyParams {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        check(
            "forgetting",
            self.forgetting,
            self.forgetting >= MIN_FORGETTING && self.forgetting <= 1.0,
            "a number in [0.9, 1] (the memory 1/(1 − λ_f) of at least 10 samples)",
        )?;
        check(
            "initial_covariance",
            self.initial_covariance,
            self.initial_covariance > 0.0,
            "a finite number > 0",
        )?;
        for (name, v) in [
            ("initial.d_p", self.initial.d_p),
            ("initial.a_bw", self.initial.a_bw),
            ("initial.b_bw", self.initial.b_bw),
            ("initial.gamma_bw", self.initial.gamma_bw),
            ("initial.delta_bw", self.initial.delta_bw),
        ] {
            check(name, v, true, "a finite number")?;
        }
        if !(self.dp_bounds.0 >= 0.0 && self.dp_bounds.1 > self.dp_bounds.0) {
            return Err(RangeError::new(
                "dp_bounds",
                format!("{:?}", self.dp_bounds),
                "0 ≤ lower < upper [µm/V]",
            )
            .into());
        }
        check(
            "passes",
            self.passes as f64,
            self.passes >= 1,
            "an integer ≥ 1",
        )?;
        check(
            "record_every",
            self.record_every as f64,
            self.record_every >= 1,
            "an integer ≥ 1",
        )
    }
}

/// One point of the convergence history (Figure A2).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HistoryPoint {
    /// Time into the identification \[s\] (continuing across passes).
    pub t: f64,
    /// The estimates at that time.
    pub estimate: BoucWenParams,
    /// A priori error of the θ estimator ε⁰ on the level x (before this sample's update) \[µm\].
    pub error: f64,
}

/// Result of an identification.
#[derive(Debug, Clone, PartialEq)]
pub struct Identification {
    /// Final estimates.
    pub estimate: BoucWenParams,
    /// Convergence history.
    pub history: Vec<HistoryPoint>,
    /// RMS of x − x_model when the identified model is simulated along the record \[µm\].
    pub rms_error: f64,
}

/// Index of the entries of the data vector v = [1, s_u, s_bu, s_bx, s_gu, s_gx, s_d, x] (module
/// docs).
const V_ONE: usize = 0;
const V_SU: usize = 1;
const V_SBU: usize = 2;
const V_SBX: usize = 3;
const V_SGU: usize = 4;
const V_SGX: usize = 5;
const V_SD: usize = 6;
const V_X: usize = 7;

/// Index of the unknowns θ = [x_0, α, B_bw, Γ_bw, δ_bw] of the summed regression (module
/// docs), in the θ estimator and in the batch fit.
const TH_X0: usize = 0;
const TH_ALPHA: usize = 1;
const TH_B: usize = 2;
const TH_GAMMA: usize = 3;
const TH_DELTA: usize = 4;

/// Largest change of d̂_p per sample, relative (a trust region on the Gauss–Newton step of the
/// d_p estimator: while the record is still short the step can be wild, module docs).
const MAX_DP_STEP: f64 = 1e-3;

/// Upper end of the d_p search, relative to the slope s of the line x(U): PEA2 of Table A1
/// has d_p ≈ 3.0 s on a full-range triangle (an upper end of 3 s clipped it).
const DP_RANGE: f64 = 5.0;

/// Prior weight of the located d_p in [`identify`], per (d_p/s)² [µm²]: about the curvature
/// of the criterion after one 1 Hz period at 10 kHz, so it holds d̂_p through the first
/// period and weighs about a tenth of the data after ten.
const SEED_WEIGHT: f64 = 1e8;

/// Gauss–Newton iterations [`identify`] runs at the end of the record
/// ([`ParallelRls::settle`]).
const SETTLE_ITERATIONS: usize = 50;

/// The parallel recursive least-squares identifier of Algorithm A1, one sample at a time, on
/// the summed (integrated-from-start) form of (A8), in the information form (A9) (module
/// docs).
///
/// Usable online: feed each new sample with [`ParallelRls::update`]; no allocation per step.
#[derive(Debug, Clone)]
pub struct ParallelRls {
    /// Weighted moments of v (shared by both estimators).
    moments: WeightedMoments<8>,
    /// The running sums of the current record, v without the measurement.
    sums: [f64; 8],
    /// θ estimator, [x_0, α, B_bw, Γ_bw, δ_bw] (x_0: the record's offset), unconstrained.
    theta: [f64; 5],
    /// d_p estimator, unconstrained.
    d_p: f64,
    /// The initial guess (prior mean) and the prior weight 1/Cov(0).
    theta_prior: [f64; 5],
    dp_prior: f64,
    prior_weight: f64,
    /// Previous sample (t, U, x).
    prev: Option<(f64, f64, f64)>,
    h: f64,
    dp_bounds: (f64, f64),
    /// d_p used for σ_j = sgn h̄_j in the sums, when fixed ([`ParallelRls::with_sign_reference`]);
    /// otherwise the current d̂_p.
    sign_dp: Option<f64>,
    /// Prior weight on d̂_p around `dp_prior` (1/Cov(0) unless seeded).
    dp_prior_weight: f64,
}

impl ParallelRls {
    /// A new identifier from the settings' initial guess (`initial.d_p` must be > 0 here:
    /// [`identify`] replaces a zero by the record's slope). The offset x_0 starts at 0.
    pub fn new(params: &IdentifyParams) -> Result<Self> {
        params.validate()?;
        let p = params.initial;
        check(
            "initial.d_p",
            p.d_p,
            p.d_p > 0.0,
            "a finite number > 0 [µm/V]",
        )?;
        let theta = [0.0, p.d_p - p.a_bw, p.b_bw, p.gamma_bw, p.delta_bw];
        Ok(ParallelRls {
            moments: WeightedMoments::new(params.forgetting, 1.0)?,
            sums: [0.0; 8],
            theta,
            d_p: p.d_p,
            theta_prior: theta,
            dp_prior: p.d_p,
            prior_weight: 1.0 / params.initial_covariance,
            prev: None,
            h: 0.0,
            dp_bounds: params.dp_bounds,
            sign_dp: None,
            dp_prior_weight: 1.0 / params.initial_covariance,
        })
    }

    /// Evaluates σ_j = sgn h̄_j of the sums with the fixed `d_p` [µm/V] instead of the current
    /// estimate (which wanders in the first samples and freezes wrong signs into the sums:
    /// module docs, "Two sweeps").
    pub fn with_sign_reference(mut self, d_p: f64) -> Self {
        self.sign_dp = Some(d_p);
        self
    }

    /// Seeds the d_p estimator with a located global minimum `d_p` [µm/V] (e.g. the batch
    /// fit's): σ_j use it ([`ParallelRls::with_sign_reference`]) and d̂_p gets the prior
    /// weight `weight` [µm²/(µm/V)²] around it, so the Gauss–Newton steps of the first,
    /// little-exciting samples cannot walk d̂_p out of the narrow valley of the criterion
    /// (module docs, "Global d_p"); the data outweigh it once they carry more information.
    pub fn seeded(mut self, d_p: f64, weight: f64) -> Self {
        self.d_p = d_p;
        self.dp_prior = d_p;
        self.dp_prior_weight = weight;
        self.with_sign_reference(d_p)
    }

    /// The estimates projected onto the admissible set, [x_0, α, B_bw, Γ_bw, δ_bw] and d_p:
    /// d_p within `dp_bounds`, B_bw ≥ 0 and B_bw + Γ_bw ≥ 1e-6/V (bounded hysteresis, as
    /// `BoucWenParams::validate` requires). The estimators themselves stay unconstrained
    /// (exact least squares).
    #[inline]
    fn projected(&self) -> ([f64; 5], f64) {
        let [x0, alpha, mut b, mut g, delta] = self.theta;
        if b < 0.0 || b + g < 1e-6 {
            b = b.max(0.0);
            g = g.max(1e-6 - b);
        }
        let d = self.d_p.clamp(self.dp_bounds.0, self.dp_bounds.1);
        ([x0, alpha, b, g, delta], d)
    }

    /// The current estimates (projected onto the admissible set).
    pub fn estimate(&self) -> BoucWenParams {
        let ([_, alpha, b, g, d], d_p) = self.projected();
        BoucWenParams {
            d_p,
            a_bw: d_p - alpha,
            b_bw: b,
            gamma_bw: g,
            delta_bw: d,
        }
    }

    /// The estimated offset x_0 of the current record \[µm\] (x at its first sample, without
    /// the sensor noise).
    pub fn offset(&self) -> f64 {
        self.theta[TH_X0]
    }

    /// The hysteretic state h = d̂_p U − x \[µm\] at the last sample.
    pub fn h(&self) -> f64 {
        self.h
    }

    /// Starts a new record with the next sample: the sums restart from zero and the offset
    /// x_0 of the records seen so far is profiled out of the moments
    /// ([`WeightedMoments::eliminate`]), so the new record brings its own offset. The
    /// information on θ and d_p carries over.
    pub fn restart(&mut self) {
        if self.prev.take().is_some() {
            self.sums = [0.0; 8];
            self.moments.eliminate(V_ONE);
        }
    }

    /// The rows r_i of the θ regressor c = R v at d_p: c = [1, s_u, d_p s_bu − s_bx,
    /// d_p s_gu − s_gx, s_d], as (index, coefficient) pairs.
    #[inline]
    fn theta_rows(d_p: f64) -> [[(usize, f64); 2]; 5] {
        [
            [(V_ONE, 1.0), (V_ONE, 0.0)],
            [(V_SU, 1.0), (V_SU, 0.0)],
            [(V_SBU, d_p), (V_SBX, -1.0)],
            [(V_SGU, d_p), (V_SGX, -1.0)],
            [(V_SD, 1.0), (V_SD, 0.0)],
        ]
    }

    /// One sample (t \[s\], U \[V\], x \[µm\]) of Algorithm A1. Returns the a priori error ε⁰ of
    /// the θ estimator on the level x \[µm\].
    #[inline]
    pub fn update(&mut self, t: f64, u: f64, x: f64) -> f64 {
        let (_, d_p) = self.projected();
        if let Some((t0, u0, x0)) = self.prev.replace((t, u, x)) {
            // The integrated (A8) of this sample interval, h̄ from the measurement.
            let (du, dt) = (u - u0, t - t0);
            let (u_mean, x_mean) = (0.5 * (u + u0), 0.5 * (x + x0));
            let sigma_du = sgn(self.sign_dp.unwrap_or(d_p) * u_mean - x_mean) * du;
            let s = &mut self.sums;
            s[V_SU] += du;
            s[V_SBU] += du.abs() * u_mean;
            s[V_SBX] += du.abs() * x_mean;
            s[V_SGU] += sigma_du * u_mean;
            s[V_SGX] += sigma_du * x_mean;
            s[V_SD] -= dt * u_mean * sgn(du);
        }
        let mut v = self.sums;
        v[V_ONE] = 1.0;
        v[V_X] = x;
        let rows = Self::theta_rows(d_p);
        let err = x - rows
            .iter()
            .zip(&self.theta)
            .map(|(r, th)| th * (r[0].1 * v[r[0].0] + r[1].1 * v[r[1].0]))
            .sum::<f64>();
        self.moments.add(&v);
        self.h = d_p * u - x;
        self.solve(d_p, MAX_DP_STEP);
        err
    }

    /// Gauss–Newton iterations of both estimators on the information gathered so far, with
    /// no new sample: the d_p step of [`ParallelRls::update`] is one Gauss–Newton step per
    /// sample, and on a long periodic record the profile of d_p is so narrow (its width
    /// shrinks with the number of periods) that the last steps leave d̂_p a few 1e-5 off,
    /// which moves Γ_bw and δ_bw by tens of percent. Iterating at the end converges d̂_p to
    /// the minimum of the accumulated criterion. Stops when the step is below 1e-12·d̂_p or
    /// after `iterations`.
    pub fn settle(&mut self, iterations: usize) {
        for _ in 0..iterations {
            let (_, d_p) = self.projected();
            self.solve(d_p, f64::INFINITY);
            if (self.d_p - d_p).abs() <= 1e-12 * d_p {
                break;
            }
        }
    }

    /// The θ solve and the d_p step at the current moments (the body of Algorithm A1 after
    /// the moment update), the d_p step limited to `max_step`·d̂_p.
    #[inline]
    fn solve(&mut self, d_p: f64, max_step: f64) {
        let prior = self.prior_weight * self.moments.decay();
        let rows = Self::theta_rows(d_p);

        // θ estimator, (A9) for the summed regressor (A8) at the current d̂_p: the weighted
        // normal equations R M Rᵀ θ = R M e_x (+ the prior of Cov(0)).
        let m = self.moments.matrix();
        let mut mr = [[0.0; 8]; 5]; // M r_j
        for (j, r) in rows.iter().enumerate() {
            for i in 0..8 {
                mr[j][i] = m[i][r[0].0] * r[0].1 + m[i][r[1].0] * r[1].1;
            }
        }
        let mut normal = [[0.0; 5]; 5];
        let mut rhs = [0.0; 5];
        for i in 0..5 {
            let ri = &rows[i];
            for j in i..5 {
                let n = ri[0].1 * mr[j][ri[0].0] + ri[1].1 * mr[j][ri[1].0];
                normal[i][j] = n;
                normal[j][i] = n;
            }
            normal[i][i] += prior;
            rhs[i] = mr[i][V_X] + prior * self.theta_prior[i];
        }
        let factor = SpdFactor::new(&normal);
        if let Some(f) = &factor {
            self.theta = f.solve(&rhs);
        }

        // Then the d_p estimator (after "update h", done by the caller): the regression of
        // the residual e on d_p with the regressor ψ = ∂(cᵀθ̂)/∂d_p = B̂ s_bu + Γ̂ s_gu made
        // orthogonal to the θ regressors (the θ-profiled regressor ψ⊥ = ψ − C N⁻¹Cᵀψ), (A9)
        // at the current θ̂: Δd_p = ψᵀe / ψ⊥ᵀψ⊥ (Cᵀe = 0 at the θ̂ just solved).
        let [_, _, b, g, _] = self.theta;
        let mut m_psi = [0.0; 8];
        for (mp, row) in m_psi.iter_mut().zip(m) {
            *mp = b * row[V_SBU] + g * row[V_SGU];
        }
        let mut a_e = [0.0; 8];
        a_e[V_X] = 1.0;
        for (r, th) in rows.iter().zip(&self.theta) {
            a_e[r[0].0] -= th * r[0].1;
            a_e[r[1].0] -= th * r[1].1;
        }
        let psi_e: f64 = m_psi.iter().zip(&a_e).map(|(p, e)| p * e).sum();
        let psi_psi: f64 = b * m_psi[V_SBU] + g * m_psi[V_SGU];
        let mut c_psi = [0.0; 5];
        for (c, r) in c_psi.iter_mut().zip(&rows) {
            *c = r[0].1 * m_psi[r[0].0] + r[1].1 * m_psi[r[1].0];
        }
        let profiled = match &factor {
            Some(f) => {
                let z = f.solve(&c_psi);
                psi_psi - z.iter().zip(&c_psi).map(|(a, b)| a * b).sum::<f64>()
            }
            None => psi_psi,
        };
        let prior_dp = self.dp_prior_weight * self.moments.decay();
        let denom = profiled.max(0.0) + prior_dp;
        let step = ((psi_e + prior_dp * (self.dp_prior - d_p)) / denom)
            .clamp(-max_step * d_p, max_step * d_p);
        self.d_p = (d_p + step).clamp(self.dp_bounds.0, self.dp_bounds.1);
    }
}

/// Runs the parallel RLS of Algorithm A1 over a record (starting from a virgin state h = 0)
/// and returns the final estimates and the convergence history.
pub fn identify(data: &PeaData, params: &IdentifyParams) -> Result<Identification> {
    params.validate()?;
    let mut params = *params;
    let (_, slope) = line_fit(data.u(), data.x());
    if params.dp_bounds == (0.0, f64::INFINITY) && slope > 0.0 {
        params.dp_bounds = (slope, DP_RANGE * slope);
    }
    let auto_dp = params.initial.d_p == 0.0;
    if slope.is_nan() || slope <= 0.0 {
        return Err(DataError::new(
            "identification",
            format!(
                "x does not increase with U (slope {slope:e} µm/V): check the columns and \
                     units (x in µm, U in V)"
            ),
        )
        .into());
    }
    if auto_dp {
        params.initial.a_bw = 0.0;
    }
    // The σ_j = sgn h̄_j frozen into the sums use the d̂_p of their sample, and the early
    // samples (d̂_p still near the slope s) get many wrong on a periodic drive (module docs,
    // "Global d_p"): the signs use the batch fit's global d_p instead, which also seeds d̂_p.
    let located = global_dp(data, slope)?;
    if auto_dp {
        params.initial.d_p = located;
    }
    let mut id = ParallelRls::new(&params)?.seeded(located, SEED_WEIGHT / (slope * slope));
    let mut history =
        Vec::with_capacity(params.passes as usize * (data.len() / params.record_every + 2));
    // Figure A2 starts at the initial guess (before the first sample is seen).
    history.push(HistoryPoint {
        t: 0.0,
        estimate: params.initial,
        error: 0.0,
    });
    sweep(
        &mut id,
        data,
        params.passes,
        &mut history,
        params.record_every,
    );
    id.settle(SETTLE_ITERATIONS);
    let estimate = id.estimate();
    // The last point carries the settled estimate (the result).
    if let Some(last) = history.last_mut() {
        last.estimate = estimate;
    }
    Ok(Identification {
        estimate,
        history,
        rms_error: rms_model_error(data, &estimate),
    })
}

/// Feeds the record `passes` times to `id`, recording the estimates every `record_every`
/// samples into `history`.
fn sweep(
    id: &mut ParallelRls,
    data: &PeaData,
    passes: u32,
    history: &mut Vec<HistoryPoint>,
    record_every: usize,
) {
    let (t, u, x) = (data.t(), data.u(), data.x());
    let span = t[t.len() - 1] - t[0];
    for pass in 0..passes {
        id.restart();
        let offset = pass as f64 * span;
        for k in 0..data.len() {
            let err = id.update(t[k], u[k], x[k]);
            if (k > 0 && k % record_every == 0) || k + 1 == data.len() {
                history.push(HistoryPoint {
                    t: offset + t[k] - t[0],
                    estimate: id.estimate(),
                    error: err,
                });
            }
        }
    }
}

/// RMS of x − x_model \[µm\] when `params` is simulated along the record's voltage from a
/// virgin state (h = 0 at the first sample).
pub fn rms_model_error(data: &PeaData, params: &BoucWenParams) -> f64 {
    let xm = crate::model::simulate(params, data.t(), data.u(), 0.0);
    let s: f64 = xm
        .iter()
        .zip(data.x())
        .map(|(a, b)| (a - b) * (a - b))
        .sum();
    (s / data.len() as f64).sqrt()
}

/// Result of [`fit_batch`].
#[derive(Debug, Clone, PartialEq)]
pub struct BatchFit {
    /// The least-squares estimates.
    pub estimate: BoucWenParams,
    /// RMS residual of the summed regression (on x) \[µm\].
    pub rms_residual: f64,
    /// RMS of x − x_model when the fitted model is simulated along the record \[µm\].
    pub rms_error: f64,
}

/// Regressors and targets of the batch fit for a given d_p: the integrated (A8) summed from
/// the first sample, x_k = x_0 + Σ_{j≤k} φ_jᵀθ, with x_0 as a fifth unknown. Summing makes the
/// sensor noise white again (the increments Δx carry differenced, strongly correlated noise,
/// for which least squares on increments is inefficient): the slow, small δ_bw effect is then
/// estimated several times more precisely.
fn regression(data: &PeaData, d_p: f64, phis: &mut Vec<[f64; 5]>, ys: &mut Vec<f64>) {
    phis.clear();
    ys.clear();
    let (t, u, x) = (data.t(), data.u(), data.x());
    let mut c = [0.0; 5];
    c[TH_X0] = 1.0;
    phis.push(c);
    ys.push(x[0]);
    for k in 1..data.len() {
        let du = u[k] - u[k - 1];
        let u_mean = 0.5 * (u[k] + u[k - 1]);
        let h_mean = d_p * u_mean - 0.5 * (x[k] + x[k - 1]);
        c[TH_ALPHA] += du;
        c[TH_B] += du.abs() * h_mean;
        c[TH_GAMMA] += du * h_mean.abs();
        c[TH_DELTA] -= (t[k] - t[k - 1]) * u_mean * sgn(du);
        phis.push(c);
        ys.push(x[k]);
    }
}

/// [x_0, α, B, Γ, δ] and the residual sum of squares of the summed (A8) at a given d_p.
fn projected(
    data: &PeaData,
    d_p: f64,
    phis: &mut Vec<[f64; 5]>,
    ys: &mut Vec<f64>,
) -> Result<([f64; 5], f64)> {
    regression(data, d_p, phis, ys);
    let theta = batch_least_squares(phis, ys, 1.0)?;
    let rss = phis
        .iter()
        .zip(ys.iter())
        .map(|(p, y)| {
            let r = y - p.iter().zip(&theta).map(|(a, b)| a * b).sum::<f64>();
            r * r
        })
        .sum();
    Ok((theta, rss))
}

/// The variable-projection profile of the batch fit: the residual sum of squares \[µm²\] of the
/// summed (A8) with [x_0, θ] solved by least squares at the given d_p [µm/V] (module docs).
/// [`fit_batch`] minimizes it over d_p; exposed for diagnostics and tests.
pub fn profile_rss(data: &PeaData, d_p: f64) -> Result<f64> {
    let mut phis = Vec::with_capacity(data.len());
    let mut ys = Vec::with_capacity(data.len());
    projected(data, d_p, &mut phis, &mut ys).map(|(_, r)| r)
}

/// The 8×8 moments Σ v vᵀ of the data vector v = [1, s_u, s_bu, s_bx, s_gu, s_gx, s_d, x]
/// (module docs) of the whole record, with σ_j = sgn h̄_j evaluated at `d_sigma`. The
/// profile of any d_p then costs O(1) ([`moment_profile`]); it is exact at d_p = d_sigma
/// and close to it (σ only changes where h̄ ≈ 0).
fn record_moments(data: &PeaData, d_sigma: f64) -> [[f64; 8]; 8] {
    let (t, u, x) = (data.t(), data.u(), data.x());
    let mut m = [[0.0; 8]; 8];
    let mut v = [0.0; 8];
    v[V_ONE] = 1.0;
    for k in 0..data.len() {
        if k > 0 {
            let (du, dt) = (u[k] - u[k - 1], t[k] - t[k - 1]);
            let (u_mean, x_mean) = (0.5 * (u[k] + u[k - 1]), 0.5 * (x[k] + x[k - 1]));
            let sigma_du = sgn(d_sigma * u_mean - x_mean) * du;
            v[V_SU] += du;
            v[V_SBU] += du.abs() * u_mean;
            v[V_SBX] += du.abs() * x_mean;
            v[V_SGU] += sigma_du * u_mean;
            v[V_SGX] += sigma_du * x_mean;
            v[V_SD] -= dt * u_mean * sgn(du);
        }
        v[V_X] = x[k];
        for i in 0..8 {
            for j in i..8 {
                m[i][j] += v[i] * v[j];
            }
        }
    }
    core::array::from_fn(|i| core::array::from_fn(|j| m[i.min(j)][i.max(j)]))
}

/// The residual sum of squares of the summed (A8) at d_p from the record's moments:
/// RSS = M_xx − bᵀN⁻¹b with N = R M Rᵀ, b = R M e_x (R the θ regressor rows at d_p), the
/// normal equations scaled to unit diagonal. +∞ when N is singular.
fn moment_profile(m: &[[f64; 8]; 8], d_p: f64) -> f64 {
    let rows = ParallelRls::theta_rows(d_p);
    let apply = |r: &[(usize, f64); 2], col: &dyn Fn(usize) -> f64| {
        r[0].1 * col(r[0].0) + r[1].1 * col(r[1].0)
    };
    let mut normal = [[0.0; 5]; 5];
    let mut rhs = [0.0; 5];
    for i in 0..5 {
        for j in 0..5 {
            normal[i][j] = apply(&rows[i], &|a| apply(&rows[j], &|b| m[a][b]));
        }
        rhs[i] = apply(&rows[i], &|a| m[a][V_X]);
    }
    let scale: [f64; 5] =
        core::array::from_fn(|i| 1.0 / normal[i][i].max(f64::MIN_POSITIVE).sqrt());
    for i in 0..5 {
        rhs[i] *= scale[i];
        for j in 0..5 {
            normal[i][j] *= scale[i] * scale[j];
        }
    }
    match SpdFactor::new(&normal) {
        Some(f) => {
            let z = f.solve(&rhs);
            m[V_X][V_X] - z.iter().zip(&rhs).map(|(a, b)| a * b).sum::<f64>()
        }
        None => f64::INFINITY,
    }
}

/// Centres of the σ evaluation of the global d_p scan, over the search range.
const SCAN_CENTRES: usize = 45;
/// Exact profile evaluations either side of the scan's best point, in scan steps.
const EXACT_STEPS: i32 = 16;
/// Profile evaluations per centre (from the moments, O(1) each).
const SCAN_POINTS: usize = 400;

/// Global search of the d_p profile over [lo, hi], returning the best scan point and the
/// scan step.
///
/// On a single-amplitude periodic drive the profile is flat far from the truth and has one
/// valley whose width shrinks with the number of periods (about ±0.1 % of d_p over ten
/// 1 Hz periods, far narrower than any affordable grid of exact profile evaluations), with
/// other shallow local minima: a coarse grid plus a local search landed 5–55 % off. The scan
/// here is dense (a step of 1e-4 of the range) because each evaluation costs O(1): the
/// record's moments are formed once per centre of σ ([`record_moments`]) and the profile
/// is evaluated from them ([`moment_profile`]) on the points nearest that centre.
fn locate_dp(data: &PeaData, lo: f64, hi: f64) -> (f64, f64) {
    let n = SCAN_CENTRES * SCAN_POINTS;
    let step = (hi - lo) / n as f64;
    let mut best = (f64::INFINITY, lo);
    for c in 0..SCAN_CENTRES {
        let first = c * SCAN_POINTS;
        let centre = lo + step * (first as f64 + 0.5 * SCAN_POINTS as f64);
        let m = record_moments(data, centre);
        for i in first..=first + SCAN_POINTS {
            let d = lo + step * i as f64;
            let r = moment_profile(&m, d);
            if r < best.0 {
                best = (r, d);
            }
        }
    }
    (best.1, step)
}

/// The global minimum of the d_p profile ([`profile_rss`]) over [0.8 s, 5 s] (s the slope
/// of the line x(U), > 0): the dense scan of [`locate_dp`], then golden section on the exact
/// profile around the best of the exact profile on ±16 scan steps of its best point.
fn global_dp(data: &PeaData, slope: f64) -> Result<f64> {
    let (lo, hi) = (0.8 * slope, DP_RANGE * slope);
    let (centre, step) = locate_dp(data, lo, hi);
    let mut phis = Vec::with_capacity(data.len());
    let mut ys = Vec::with_capacity(data.len());
    let mut rss = |d: f64| projected(data, d, &mut phis, &mut ys).map(|(_, r)| r);
    // The moment profile is not accurate enough to pick the scan step of the minimum
    // (cancellation in M_xx − bᵀN⁻¹b): the exact profile on ±EXACT_STEPS scan steps.
    let mut best = (f64::INFINITY, centre);
    for i in -EXACT_STEPS..=EXACT_STEPS {
        let d = centre + step * i as f64;
        if d > 0.0 {
            let r = rss(d)?;
            if r < best.0 {
                best = (r, d);
            }
        }
    }
    let (mut a, mut b) = (best.1 - step, best.1 + step);
    a = a.max(1e-12);
    let phi = 0.5 * (5f64.sqrt() - 1.0);
    let mut c = b - phi * (b - a);
    let mut d = a + phi * (b - a);
    let (mut fc, mut fd) = (rss(c)?, rss(d)?);
    for _ in 0..80 {
        if (b - a) <= 1e-13 * b {
            break;
        }
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - phi * (b - a);
            fc = rss(c)?;
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + phi * (b - a);
            fd = rss(d)?;
        }
    }
    Ok(0.5 * (a + b))
}

/// Batch least-squares fit of Eq. (18) to a record by variable projection (module docs).
/// d_p is searched globally in [0.8, 5]× the slope of the least-squares line x(U)
/// (`locate_dp`), then refined by golden section on the exact profile.
pub fn fit_batch(data: &PeaData) -> Result<BatchFit> {
    let (_, slope) = line_fit(data.u(), data.x());
    if slope.is_nan() || slope <= 0.0 {
        return Err(DataError::new(
            "batch fit",
            format!(
                "x does not increase with U (slope {slope:e} µm/V): check the columns and units \
                 (x in µm, U in V)"
            ),
        )
        .into());
    }
    let d_p = global_dp(data, slope)?;
    let mut phis = Vec::with_capacity(data.len());
    let mut ys = Vec::with_capacity(data.len());
    let (theta, r) = projected(data, d_p, &mut phis, &mut ys)?;
    let estimate = BoucWenParams {
        d_p,
        a_bw: d_p - theta[TH_ALPHA],
        b_bw: theta[TH_B],
        gamma_bw: theta[TH_GAMMA],
        delta_bw: theta[TH_DELTA],
    };
    Ok(BatchFit {
        estimate,
        rms_residual: (r / ys.len().max(1) as f64).sqrt(),
        rms_error: rms_model_error(data, &estimate),
    })
}
