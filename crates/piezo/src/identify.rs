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
//! with Ū, h̄ the interval means (exact for the U and δ terms, midpoint rule for h). The same
//! θ, no derivative of data, and the δ regressor carries Δt, so δ_bw comes out in µm/(V·s)
//! as in Table A1.
//!
//! # Where h comes from, and the d_p estimator
//! h is not measured. Given d_p it follows from the measurement, h = d_p U − x ("measured x
//! gives h once d_p is known"), and the increment regression becomes *bilinear* in d_p and θ:
//! B_bw |ΔU| h̄ = B_bw |ΔU| (d_p Ū − x̄), and the same for Γ_bw. Algorithm A1 runs two RLS
//! estimators in parallel, alternating between the two factors:
//!
//! * θ estimator, (A11) with regressor (A8): h̄ = d̂_p Ū − x̄ with the current d̂_p;
//! * d_p estimator, (A11) with a scalar regressor: the paper's (A12), x = d_p U − h, is
//!   differentiated and h̄ expanded as above, so that d_p is the coefficient of
//!   ψ = (B̂|ΔU| + Γ̂ ΔU sgn h̄)·Ū in the residual Δx − α̂ΔU + (B̂|ΔU| + Γ̂ ΔU sgn h̄)·x̄ +
//!   δ̂ Δt Ū s. "Update state variable h" is h = d̂_p U − x.
//!
//! Why not (A12) literally, x + h = d_p U with h integrated by forward Euler from the current
//! estimates: that h depends on d̂_p through A_bw = d̂_p − α̂, and in tests the loop fed back
//! positively (d̂_p drifted to zero and below from Table A1's zero initial guess). The form
//! used here makes both estimators minimize the same squared error, so the alternation
//! descends. Both estimates are also projected onto the admissible set after each update
//! (B_bw ≥ 0, B_bw + Γ_bw > 0, d_p between the slope s of the line x(U) and 3s).
//!
//! Measured behaviour (tests, Table A1 parameters, 10 kHz, decaying 1 Hz sine): on noise-free
//! data the parallel RLS with λ_f = 0.999 recovers all five parameters to better than 0.01 %
//! in one pass. With 10 nm sensor noise the coupled online scheme is not reliable (the
//! bilinear alternation with short memory can wander far off); use [`fit_batch`] for noisy
//! offline records: on the same drive it recovers every parameter within 2 % (δ_bw, whose
//! effect is only ~0.1 µm per loop at 1 Hz, is the hardest; a slower drive helps, since the
//! δ effect grows with the time spent per loop: within 0.4 % at 0.25 Hz).
//!
//! # Batch fit
//! [`fit_batch`] fits the same integrated regression offline, summed from the first sample
//! (so the noise is white), by *variable projection*: for a given d_p, h̄ = d_p Ū − x̄ makes
//! the problem linear in θ (and x_0), solved by least squares; the
//! residual sum of squares is then minimized over the scalar d_p by a grid search and golden
//! section. It needs no initial guess and is the cross-check of the recursive estimates.

use serde::{Deserialize, Serialize};

use crate::data::PeaData;
use crate::error::{Result, check, data_error};
use crate::hysteresis::line_fit;
use crate::model::{BoucWenParams, sgn};
use crate::rls::{Rls, RlsParams, batch_least_squares};

/// Settings of the parallel RLS identification (Algorithm A1).
///
/// λ_f sets the memory, about 1/(1 − λ_f) samples. B_bw and Γ_bw are separable only across
/// segments where sgn(U̇)·sgn(h) differs, so on slow drives a longer memory (λ_f closer to 1)
/// is needed; 0.999 suits the 1 Hz drive at 10 kHz.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdentifyParams {
    /// RLS settings of the θ = [α, B, Γ, δ] estimator. Default λ_f = 0.999, W₀ = 1,
    /// Cov(0) = 1e4·I, trace(Cov) ≤ 1e8.
    pub theta_rls: RlsParams,
    /// RLS settings of the d_p estimator (A12). Default as `theta_rls`.
    pub dp_rls: RlsParams,
    /// Initial guess. Table A1 starts from zeros; d_p = 0 is then replaced by the slope of
    /// the least-squares line x(U) of the record (a zero d_p makes h = −x, far from the truth).
    pub initial: BoucWenParams,
    /// Admissible range of d_p [µm/V] (parameter projection), 0 ≤ lower < upper. [`identify`]
    /// narrows a default (0, ∞) to [s, 3s] with s the slope of the least-squares line x(U):
    /// for A_bw > 0 the hysteresis lowers the apparent slope, so d_p > s.
    pub dp_bounds: (f64, f64),
    /// Runs over the record, ≥ 1, carrying estimates and covariances over (the model state
    /// restarts virgin). Default 1 (online use).
    pub passes: u32,
    /// Record the estimates every this many samples for the convergence history, ≥ 1.
    pub record_every: usize,
}

impl Default for IdentifyParams {
    fn default() -> Self {
        let rls = RlsParams {
            forgetting: 0.999,
            weight: 1.0,
            initial_covariance: 1e4,
            max_trace: 1e8,
        };
        IdentifyParams {
            theta_rls: rls,
            dp_rls: rls,
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

impl IdentifyParams {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        self.theta_rls.validate()?;
        self.dp_rls.validate()?;
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
            return Err(crate::PiezoError::OutOfRange {
                field: "dp_bounds".into(),
                value: format!("{:?}", self.dp_bounds),
                expected: "0 ≤ lower < upper [µm/V]".into(),
            });
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
    /// Time into the identification [s] (continuing across passes).
    pub t: f64,
    /// The estimates at that time.
    pub estimate: BoucWenParams,
    /// A priori error of the θ estimator ε⁰ (on Δx) [µm].
    pub error: f64,
}

/// Result of an identification.
#[derive(Debug, Clone, PartialEq)]
pub struct Identification {
    /// Final estimates.
    pub estimate: BoucWenParams,
    /// Convergence history.
    pub history: Vec<HistoryPoint>,
    /// RMS of x − x_model when the identified model is simulated along the record [µm].
    pub rms_error: f64,
}

/// The parallel recursive least-squares identifier of Algorithm A1, one sample at a time.
///
/// Usable online: feed each new sample with [`ParallelRls::update`]; no allocation per step.
#[derive(Debug, Clone)]
pub struct ParallelRls {
    theta: Rls<4>,
    dp: Rls<1>,
    /// Previous sample (t, U, x) and the model's h there.
    prev: Option<(f64, f64, f64)>,
    h: f64,
    dp_bounds: (f64, f64),
}

impl ParallelRls {
    /// A new identifier from the settings' initial guess (`initial.d_p` must be > 0 here:
    /// [`identify`] replaces a zero by the record's slope).
    pub fn new(params: &IdentifyParams) -> Result<Self> {
        params.validate()?;
        let p = params.initial;
        check(
            "initial.d_p",
            p.d_p,
            p.d_p > 0.0,
            "a finite number > 0 [µm/V]",
        )?;
        Ok(ParallelRls {
            theta: Rls::new(
                params.theta_rls,
                [p.d_p - p.a_bw, p.b_bw, p.gamma_bw, p.delta_bw],
            )?,
            dp: Rls::new(params.dp_rls, [p.d_p])?,
            prev: None,
            h: 0.0,
            dp_bounds: params.dp_bounds,
        })
    }

    /// Parameter projection onto the admissible set: d_p within `dp_bounds`, B_bw ≥ 0 and
    /// B_bw + Γ_bw ≥ 1e-6/V (bounded hysteresis, as `BoucWenParams::validate` requires).
    fn project(&mut self) {
        let [alpha, mut b, mut g, delta] = *self.theta.theta();
        if b < 0.0 || b + g < 1e-6 {
            b = b.max(0.0);
            g = g.max(1e-6 - b);
            self.theta.set_theta([alpha, b, g, delta]);
        }
        let d = self.dp.theta()[0];
        let clamped = d.clamp(self.dp_bounds.0, self.dp_bounds.1);
        if clamped != d {
            self.dp.set_theta([clamped]);
        }
    }

    /// The current estimates.
    pub fn estimate(&self) -> BoucWenParams {
        let [alpha, b, g, d] = *self.theta.theta();
        let d_p = self.dp.theta()[0];
        BoucWenParams {
            d_p,
            a_bw: d_p - alpha,
            b_bw: b,
            gamma_bw: g,
            delta_bw: d,
        }
    }

    /// The hysteretic state h = d̂_p U − x [µm] at the last sample.
    pub fn h(&self) -> f64 {
        self.h
    }

    /// Forgets the previous sample, so the next update starts a new record.
    pub fn restart(&mut self) {
        self.prev = None;
    }

    /// One sample (t [s], U [V], x [µm]) of Algorithm A1. Returns the a priori error of the θ
    /// estimator [µm] (0 for the first sample of a record).
    #[inline]
    pub fn update(&mut self, t: f64, u: f64, x: f64) -> f64 {
        let Some((t0, u0, x0)) = self.prev.replace((t, u, x)) else {
            return 0.0;
        };
        let (du, dx, dt) = (u - u0, x - x0, t - t0);
        let (u_mean, x_mean) = (0.5 * (u + u0), 0.5 * (x + x0));
        let d_p = self.dp.theta()[0];
        // (A11) for regressor (A8), integrated over the sample, with h from the measurement.
        let h_mean = d_p * u_mean - x_mean;
        let phi = [
            du,
            du.abs() * h_mean,
            du * h_mean.abs(),
            -dt * u_mean * sgn(du),
        ];
        let err = if du != 0.0 {
            self.theta.update(&phi, dx)
        } else {
            // No excitation (sgn(0) = 0 makes φ = 0): an update would only inflate the
            // covariance by 1/λ_f.
            0.0
        };
        // Update the state h (from the measurement, with the current d̂_p) and run (A11) for
        // the d_p regression: the part of the increment of (A12) that d_p multiplies.
        self.project();
        let [alpha, b, g, delta] = *self.theta.theta();
        let sigma = sgn(d_p * u_mean - x_mean);
        self.h = d_p * u - x;
        let psi = (b * du.abs() + g * sigma * du) * u_mean;
        let r = dx - alpha * du
            + (b * du.abs() + g * sigma * du) * x_mean
            + delta * dt * u_mean * sgn(du);
        if psi != 0.0 {
            self.dp.update(&[psi], r);
        }
        self.project();
        err
    }
}

/// Runs the parallel RLS of Algorithm A1 over a record (starting from a virgin state h = 0)
/// and returns the final estimates and the convergence history.
pub fn identify(data: &PeaData, params: &IdentifyParams) -> Result<Identification> {
    params.validate()?;
    let mut params = *params;
    let (_, slope) = line_fit(data.u(), data.x());
    if params.dp_bounds == (0.0, f64::INFINITY) && slope > 0.0 {
        params.dp_bounds = (slope, 3.0 * slope);
    }
    if params.initial.d_p == 0.0 {
        if slope.is_nan() || slope <= 0.0 {
            return Err(data_error(
                "identification",
                format!(
                    "x does not increase with U (slope {slope:e} µm/V): check the columns and \
                     units (x in µm, U in V)"
                ),
            ));
        }
        params.initial.d_p = slope;
        params.initial.a_bw = 0.0;
    }
    let mut id = ParallelRls::new(&params)?;
    let (t, u, x) = (data.t(), data.u(), data.x());
    let span = t[t.len() - 1] - t[0];
    let mut history =
        Vec::with_capacity(params.passes as usize * (data.len() / params.record_every + 2));
    for pass in 0..params.passes {
        id.restart();
        let offset = pass as f64 * span;
        for k in 0..data.len() {
            let err = id.update(t[k], u[k], x[k]);
            if k % params.record_every == 0 || k + 1 == data.len() {
                history.push(HistoryPoint {
                    t: offset + t[k] - t[0],
                    estimate: id.estimate(),
                    error: err,
                });
            }
        }
    }
    let estimate = id.estimate();
    Ok(Identification {
        estimate,
        history,
        rms_error: rms_model_error(data, &estimate),
    })
}

/// RMS of x − x_model [µm] when `params` is simulated along the record's voltage from a
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
    /// RMS residual of the summed regression (on x) [µm].
    pub rms_residual: f64,
    /// RMS of x − x_model when the fitted model is simulated along the record [µm].
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
    let mut c = [1.0, 0.0, 0.0, 0.0, 0.0];
    phis.push(c);
    ys.push(x[0]);
    for k in 1..data.len() {
        let du = u[k] - u[k - 1];
        let u_mean = 0.5 * (u[k] + u[k - 1]);
        let h_mean = d_p * u_mean - 0.5 * (x[k] + x[k - 1]);
        c[1] += du;
        c[2] += du.abs() * h_mean;
        c[3] += du * h_mean.abs();
        c[4] -= (t[k] - t[k - 1]) * u_mean * sgn(du);
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

/// Batch least-squares fit of Eq. (18) to a record by variable projection (module docs).
/// d_p is searched in [0.8, 3]× the slope of the least-squares line x(U).
pub fn fit_batch(data: &PeaData) -> Result<BatchFit> {
    let (_, slope) = line_fit(data.u(), data.x());
    if slope.is_nan() || slope <= 0.0 {
        return Err(data_error(
            "batch fit",
            format!(
                "x does not increase with U (slope {slope:e} µm/V): check the columns and units \
                 (x in µm, U in V)"
            ),
        ));
    }
    let mut phis = Vec::with_capacity(data.len());
    let mut ys = Vec::with_capacity(data.len());
    let mut rss = |d: f64| projected(data, d, &mut phis, &mut ys).map(|(_, r)| r);
    // Coarse grid, then golden section around the best grid point.
    const GRID: usize = 56;
    let (lo, hi) = (0.8 * slope, 3.0 * slope);
    let step = (hi - lo) / GRID as f64;
    let mut best = (f64::INFINITY, lo);
    for i in 0..=GRID {
        let d = lo + step * i as f64;
        let r = rss(d)?;
        if r < best.0 {
            best = (r, d);
        }
    }
    let (mut a, mut b) = ((best.1 - step).max(1e-12), best.1 + step);
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
    let d_p = 0.5 * (a + b);
    let (theta, r) = projected(data, d_p, &mut phis, &mut ys)?;
    let estimate = BoucWenParams {
        d_p,
        a_bw: d_p - theta[1],
        b_bw: theta[2],
        gamma_bw: theta[3],
        delta_bw: theta[4],
    };
    Ok(BatchFit {
        estimate,
        rms_residual: (r / ys.len().max(1) as f64).sqrt(),
        rms_error: rms_model_error(data, &estimate),
    })
}
