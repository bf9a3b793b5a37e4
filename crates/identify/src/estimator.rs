//! The online estimator: four RLS rows (flexstage-piezo's [`Rls`], forgetting factor) over
//! the regression of [`crate::regression`], with an optional prefilter and decimation.
//!
//! # Prefilter
//! The regression is a linear, time-invariant relation between delayed samples of the six
//! signals, so filtering *every* signal with the same linear filter keeps it exact (the
//! filter commutes with the delays and differences). A second-order Butterworth low-pass
//! ([`IdentifyParams::prefilter`]) removes the sensor noise and quantization above the
//! excitation band, where the second differences amplify it most (|1 − e^{−jωT}|² = 16 at
//! Nyquist).
//!
//! # Decimation
//! `decimation` = d > 1 runs the regression at d·T_s on every d-th (filtered) sample. The
//! second-difference signal grows as d² while the noise does not; the central-difference
//! error grows as (ωdT_s)²/12. The prefilter is then the anti-aliasing filter.

use flexstage_numerics::DataError;
use flexstage_numerics::rls::{Rls, RlsParams};
use flexstage_scenario::StageParams;
use nalgebra::{DMatrix, SymmetricEigen};

use crate::data::StageRecord;
use crate::error::{IdentifyError, Result, check};
use crate::regression::{
    OUT_GAIN, OUT_KC, OUTPUT_REGRESSORS, PLATE_REGRESSORS, Physical, Rows, Scheme, Theta, Window,
    physical, rows,
};

/// Positions are scaled to µm inside the estimator so that the regressors are O(1) and the
/// prior Cov(0) = c·I is weak against the data.
const SCALE: f64 = 1e6;

/// Settings of the identification.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifyParams {
    /// Forgetting factor λ_f of the four RLS rows, in (0, 1]. 1 (default): least squares
    /// over the whole record.
    pub forgetting: f64,
    /// Initial covariance c of Cov(0) = c·I (positions in µm), > 0. Default 1e6.
    pub initial_covariance: f64,
    /// Prefilter cut-off \[Hz\] (second-order Butterworth, applied to every signal), ≥ 0 and
    /// below the Nyquist frequency of the record; 0 switches it off. Default 150 Hz (the top
    /// of the default low band; measured against 300 Hz in the crate docs). With
    /// [`IdentifyParams::output_prefilter`] set, it filters the plate rows only.
    pub prefilter: f64,
    /// Prefilter cut-off of the output (q_o1, q_o2) rows \[Hz\], same rules as `prefilter`;
    /// `None` (default): the output rows use `prefilter`. Set it above the resonance band
    /// of the excitation ([`crate::Band`]) so that the output rows see the modes (their
    /// dampings) while the plate rows keep the low band (K_in, see the crate docs).
    pub output_prefilter: Option<f64>,
    /// Decimation d ≥ 1: the regression runs at d·T_s. Default 1.
    pub decimation: usize,
    /// Sampling of the stiffness regressors. Default [`Scheme::Numerov`].
    pub scheme: Scheme,
    /// Estimate the cross-term coupling k_c (third column of the output rows). Default true.
    pub coupling: bool,
    /// The excitation has a band around the output modes ([`crate::Band`]): correct the
    /// output rows' stiffness and damping for the discretization at their natural frequencies
    /// ([`crate::regression::physical`]). Default false (the low band alone: no correction).
    pub resonant: bool,
    /// Estimate the static gains of the output rows (a fourth column each: β of q_o1 on
    /// (x_in1 + x_in2)/2, α' of q_o2 on x_in1 − x_in2; [`crate::regression::Theta`]) instead of
    /// taking them from Eq. (32) with the known α. The identified α' replaces α in the
    /// parameter set. For a structure whose kinematics differ from the reduced model's by more
    /// than the dynamic deflection the rows see (the twin: α 1.5 % off). Default false.
    pub static_gains: bool,
    /// Condition number (of the information matrix with unit-scaled columns) above which a
    /// warning says the excitation is not persistent in some direction, > 1. Default 1e5 (the
    /// default excitation gives 1–4e3 on the output rows and ≈ 6 on the plate rows).
    pub condition_warning: f64,
    /// Relative tolerance of the sample-time check of records, in (0, 0.5). Default 1e-3.
    pub sampling_tolerance: f64,
    /// Points of the convergence history, ≥ 2. Default 400.
    pub history_points: usize,
}

impl Default for IdentifyParams {
    fn default() -> Self {
        IdentifyParams {
            forgetting: 1.0,
            initial_covariance: 1e6,
            prefilter: 150.0,
            output_prefilter: None,
            decimation: 1,
            scheme: Scheme::Numerov,
            coupling: true,
            resonant: false,
            static_gains: false,
            condition_warning: 1e5,
            sampling_tolerance: 1e-3,
            history_points: 400,
        }
    }
}

/// Lowest non-zero prefilter cut-off \[Hz\]: below it the filter removes the excitation.
pub const MIN_PREFILTER: f64 = 1.0;

impl IdentifyParams {
    /// Checks the fields that depend on the record's `sample_time` \[s\] (the prefilter
    /// below the Nyquist frequency), before a record is simulated or read.
    pub fn validate_sampling(&self, sample_time: f64) -> Result<()> {
        check(
            "sample_time",
            sample_time,
            sample_time > 0.0,
            "a finite time step > 0 [s]",
        )?;
        check(
            "identify.prefilter",
            self.prefilter,
            self.prefilter < 0.5 / sample_time,
            &format!(
                "a frequency below the Nyquist frequency {} Hz",
                0.5 / sample_time
            ),
        )?;
        match self.output_prefilter {
            Some(f) => check(
                "identify.output_prefilter",
                f,
                f < 0.5 / sample_time,
                &format!(
                    "a frequency below the Nyquist frequency {} Hz",
                    0.5 / sample_time
                ),
            ),
            None => Ok(()),
        }
    }

    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        check(
            "identify.forgetting",
            self.forgetting,
            self.forgetting >= flexstage_piezo::identify::MIN_FORGETTING && self.forgetting <= 1.0,
            "a number in [0.9, 1] (the memory 1/(1 − λ_f) of at least 10 samples)",
        )?;
        check(
            "identify.initial_covariance",
            self.initial_covariance,
            self.initial_covariance > 0.0,
            "a finite number > 0",
        )?;
        check(
            "identify.prefilter",
            self.prefilter,
            self.prefilter == 0.0 || self.prefilter >= MIN_PREFILTER,
            "0 (off) or a frequency ≥ 1 Hz below the Nyquist frequency [Hz] (a lower cut-off \
             removes the excitation itself)",
        )?;
        if let Some(f) = self.output_prefilter {
            check(
                "identify.output_prefilter",
                f,
                f == 0.0 || f >= MIN_PREFILTER,
                "0 (off) or a frequency ≥ 1 Hz below the Nyquist frequency [Hz]",
            )?;
        }
        check(
            "identify.decimation",
            self.decimation as f64,
            (1..=1000).contains(&self.decimation),
            "an integer in 1..=1000",
        )?;
        check(
            "identify.condition_warning",
            self.condition_warning,
            self.condition_warning > 1.0,
            "a number > 1",
        )?;
        check(
            "identify.sampling_tolerance",
            self.sampling_tolerance,
            self.sampling_tolerance > 0.0 && self.sampling_tolerance < 0.5,
            "a number in (0, 0.5)",
        )?;
        check(
            "identify.history_points",
            self.history_points as f64,
            self.history_points >= 2,
            "an integer ≥ 2",
        )
    }
}

/// Second-order Butterworth low-pass (bilinear, prewarped), direct form II transposed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Biquad {
    b: [f64; 3],
    a: [f64; 2],
    z: [f64; 2],
}

impl Biquad {
    /// Cut-off `fc` \[Hz\] at sample time `ts` \[s\]; `fc` = 0 gives the identity.
    pub fn lowpass(fc: f64, ts: f64) -> Biquad {
        if fc <= 0.0 {
            return Biquad {
                b: [1.0, 0.0, 0.0],
                a: [0.0, 0.0],
                z: [0.0; 2],
            };
        }
        let k = (std::f64::consts::PI * fc * ts).tan();
        let r2 = std::f64::consts::SQRT_2;
        let norm = 1.0 / (1.0 + r2 * k + k * k);
        let b0 = k * k * norm;
        Biquad {
            b: [b0, 2.0 * b0, b0],
            a: [2.0 * (k * k - 1.0) * norm, (1.0 - r2 * k + k * k) * norm],
            z: [0.0; 2],
        }
    }

    /// Sets the state to the steady state of a constant input `x`.
    pub fn settle(&mut self, x: f64) {
        self.z[1] = (self.b[2] - self.a[1]) * x;
        self.z[0] = (self.b[1] - self.a[0]) * x + self.z[1];
    }

    /// Filters one sample.
    #[inline]
    pub fn step(&mut self, x: f64) -> f64 {
        let y = self.b[0] * x + self.z[0];
        self.z[0] = self.b[1] * x - self.a[0] * y + self.z[1];
        self.z[1] = self.b[2] * x - self.a[1] * y;
        y
    }
}

/// The online stage identifier: feed samples with [`StageIdentifier::update`].
/// No allocation per sample.
#[derive(Debug, Clone)]
pub struct StageIdentifier {
    known: StageParams,
    ts: f64,
    decimation: usize,
    coupling: bool,
    static_gains: bool,
    resonant: bool,
    scheme: Scheme,
    filters: [Biquad; 6],
    window: Window,
    /// The output rows' prefilter and window (same as the plates' without
    /// [`IdentifyParams::output_prefilter`]).
    filters_out: [Biquad; 6],
    window_out: Window,
    seen: u64,
    filled: u8,
    output: [Rls<4>; 2],
    plate: [Rls<5>; 2],
    info_output: [[[f64; 4]; 4]; 2],
    info_plate: [[[f64; 5]; 5]; 2],
    updates: u64,
}

impl StageIdentifier {
    /// An identifier for records sampled at `sample_time` \[s\], starting from `guess` (its
    /// masses and α are the weighed / Eq. 27 values kept fixed; its stiffnesses and dampings
    /// the initial θ) with an initial coupling `k_c0` [N/m].
    pub fn new(
        guess: &StageParams,
        k_c0: f64,
        sample_time: f64,
        params: &IdentifyParams,
    ) -> Result<StageIdentifier> {
        params.validate()?;
        guess
            .validate("guess")
            .map_err(|e| DataError::new("initial guess", e.to_string()))?;
        params.validate_sampling(sample_time)?;
        let ts = sample_time * params.decimation as f64;
        let k_c0 = if params.coupling { k_c0 } else { 0.0 };
        let theta = Theta::from_params(guess, k_c0, ts);
        let rls = RlsParams {
            forgetting: params.forgetting,
            weight: 1.0,
            initial_covariance: params.initial_covariance,
            max_trace: f64::INFINITY,
        };
        let filter = Biquad::lowpass(params.prefilter, sample_time);
        let filter_out = Biquad::lowpass(
            params.output_prefilter.unwrap_or(params.prefilter),
            sample_time,
        );
        Ok(StageIdentifier {
            known: guess.clone(),
            ts,
            decimation: params.decimation,
            coupling: params.coupling,
            static_gains: params.static_gains,
            resonant: params.resonant,
            scheme: params.scheme,
            filters: [filter; 6],
            window: Window::default(),
            filters_out: [filter_out; 6],
            window_out: Window::default(),
            seen: 0,
            filled: 0,
            output: [Rls::new(rls, theta.output1)?, Rls::new(rls, theta.output2)?],
            plate: [
                Rls::new(rls, theta.plate[0])?,
                Rls::new(rls, theta.plate[1])?,
            ],
            info_output: [[[0.0; 4]; 4]; 2],
            info_plate: [[[0.0; 5]; 5]; 2],
            updates: 0,
        })
    }

    /// The regression's sample time d·T_s \[s\].
    pub fn regression_time(&self) -> f64 {
        self.ts
    }

    /// Regression updates so far.
    pub fn updates(&self) -> u64 {
        self.updates
    }

    /// Feeds one sample (SI). Returns true when the estimators were updated (after the first
    /// three regression samples, on every `decimation`-th sample).
    #[inline]
    pub fn update(&mut self, x_nom: [f64; 2], x_in: [f64; 2], q: [f64; 2]) -> bool {
        let raw = [x_nom[0], x_nom[1], x_in[0], x_in[1], q[0], q[1]];
        let mut f = [0.0; 6];
        let mut g = [0.0; 6];
        for i in 0..6 {
            let v = raw[i] * SCALE;
            if self.seen == 0 {
                self.filters[i].settle(v);
                self.filters_out[i].settle(v);
            }
            f[i] = self.filters[i].step(v);
            g[i] = self.filters_out[i].step(v);
        }
        self.seen += 1;
        if (self.seen - 1) % self.decimation as u64 != 0 {
            return false;
        }
        self.window.push([f[0], f[1]], [f[2], f[3]], [f[4], f[5]]);
        self.window_out
            .push([g[0], g[1]], [g[2], g[3]], [g[4], g[5]]);
        if self.filled < 3 {
            self.filled += 1;
            if self.filled < 3 {
                return false;
            }
        }
        let mut r = rows(&self.window, self.known.alpha, self.scheme);
        r.output = rows(&self.window_out, self.known.alpha, self.scheme).output;
        self.apply(&r);
        true
    }

    #[inline]
    fn apply(&mut self, r: &Rows) {
        for i in 0..2 {
            let (mut phi, y) = r.output[i];
            if !self.coupling {
                phi[OUT_KC] = 0.0;
            }
            if !self.static_gains {
                phi[OUT_GAIN] = 0.0;
            }
            self.output[i].update(&phi, y);
            accumulate(&mut self.info_output[i], &phi);
            let (phi, y) = r.plate[i];
            self.plate[i].update(&phi, y);
            accumulate(&mut self.info_plate[i], &phi);
        }
        self.updates += 1;
    }

    /// The current θ.
    pub fn theta(&self) -> Theta {
        Theta {
            output1: *self.output[0].theta(),
            output2: *self.output[1].theta(),
            plate: [*self.plate[0].theta(), *self.plate[1].theta()],
        }
    }

    /// The current physical estimates ([`physical`]).
    pub fn estimate(&self) -> Physical {
        let cov = [self.plate[0].covariance(), self.plate[1].covariance()];
        physical(
            &self.theta(),
            &cov,
            &self.known,
            self.ts,
            self.scheme,
            self.resonant,
        )
    }

    /// Condition numbers of the information matrices Σφφᵀ of the four rows after scaling
    /// every column to unit norm (1 = orthogonal regressors). For the plates, the column
    /// q_o1 − x_in is left out: its direction carries the common scale that is taken from
    /// K_qo1 ([`physical`]); the rest must be excited. Infinite when a regressor is zero.
    pub fn conditioning(&self) -> [f64; 4] {
        let out = |m: &[[f64; 4]; 4]| {
            let idx: Vec<usize> = (0..4)
                .filter(|&j| (j != OUT_KC || self.coupling) && (j != OUT_GAIN || self.static_gains))
                .collect();
            let mut s = [[0.0; 4]; 4];
            for (a, &i) in idx.iter().enumerate() {
                for (b, &j) in idx.iter().enumerate() {
                    s[a][b] = m[i][j];
                }
            }
            // Unused slots: unit diagonal, no coupling (they do not change the ratio).
            for a in idx.len()..4 {
                s[a][a] = 1.0;
            }
            condition_of(&s, idx.len())
        };
        let plate = |m: &[[f64; 5]; 5]| {
            let idx = [0, 1, 3, 4];
            let mut s = [[0.0; 4]; 4];
            for (a, &i) in idx.iter().enumerate() {
                for (b, &j) in idx.iter().enumerate() {
                    s[a][b] = m[i][j];
                }
            }
            condition(&s)
        };
        [
            out(&self.info_output[0]),
            out(&self.info_output[1]),
            plate(&self.info_plate[0]),
            plate(&self.info_plate[1]),
        ]
    }

    /// Checks that every regressor was excited; Err names the first that was not.
    pub fn check_excitation(&self) -> Result<()> {
        let rows_out = ["q_o1", "q_o2"];
        let rows_plate = ["x_in1", "x_in2"];
        let hint_out = "excite both PEAs with different signals so that x_in1 + x_in2 and \
                        x_in1 − x_in2 both move, and include frequencies of a few hundred Hz";
        let hint_plate = "the PEA must move its plate, and the two PEAs must be driven \
                          differently";
        let limit = 1e-12 * self.updates.max(1) as f64;
        for i in 0..2 {
            for j in 0..4 {
                let used = (j != OUT_KC || self.coupling) && (j != OUT_GAIN || self.static_gains);
                if used && !(self.info_output[i][j][j] > limit) {
                    return Err(IdentifyError::NotExcited {
                        row: rows_out[i],
                        regressor: OUTPUT_REGRESSORS[j],
                        hint: hint_out,
                    });
                }
            }
            for j in 0..5 {
                if !(self.info_plate[i][j][j] > limit) {
                    return Err(IdentifyError::NotExcited {
                        row: rows_plate[i],
                        regressor: PLATE_REGRESSORS[j],
                        hint: hint_plate,
                    });
                }
            }
        }
        Ok(())
    }
}

#[inline]
fn accumulate<const P: usize>(m: &mut [[f64; P]; P], phi: &[f64; P]) {
    for a in 0..P {
        for b in 0..P {
            m[a][b] += phi[a] * phi[b];
        }
    }
}

/// Condition number of a symmetric PSD matrix after unit-diagonal scaling.
fn condition<const P: usize>(m: &[[f64; P]; P]) -> f64 {
    condition_of(m, P)
}

/// [`condition`] of the leading `n` × `n` block.
fn condition_of<const P: usize>(m: &[[f64; P]; P], n: usize) -> f64 {
    let mut s = DMatrix::<f64>::zeros(n, n);
    for a in 0..n {
        for b in 0..n {
            let d = (m[a][a] * m[b][b]).sqrt();
            if !(d > 0.0) {
                return f64::INFINITY;
            }
            s[(a, b)] = m[a][b] / d;
        }
    }
    let e = SymmetricEigen::new(s).eigenvalues;
    let max = e.iter().cloned().fold(f64::MIN, f64::max);
    let min = e.iter().cloned().fold(f64::MAX, f64::min);
    if min <= 0.0 { f64::INFINITY } else { max / min }
}

/// One point of the convergence history.
#[derive(Debug, Clone, PartialEq)]
pub struct HistoryPoint {
    /// Time of the record \[s\].
    pub t: f64,
    /// The estimates then.
    pub estimate: Physical,
}

/// The result of [`identify`].
#[derive(Debug, Clone, PartialEq)]
pub struct Identification {
    /// The record's sample time T_s \[s\].
    pub sample_time: f64,
    /// The regression's sample time d·T_s \[s\].
    pub regression_time: f64,
    /// Regression updates.
    pub updates: u64,
    /// The final θ.
    pub theta: Theta,
    /// The final physical estimates (raw: dampings may be negative).
    pub raw: Physical,
    /// The parameter set to use (e.g. in `flexstage track`): the estimates, with any
    /// negative damping estimate replaced by the guess (listed in `warnings`).
    pub params: StageParams,
    /// The cross-axis coupling stiffness k_c of Eq. (30) [N/m] for the controller's model
    /// (`flexstage_sim::model::StageModel::with_coupling(&params, coupling)`): the mean of
    /// the q_o1 and q_o2 rows' estimates ([`Physical::coupling`]), 0 when
    /// [`IdentifyParams::coupling`] is off. Keeping it in the model cuts the tracking error
    /// 3–5× at ten times the default scan speed.
    pub coupling: f64,
    /// Condition numbers of the four rows ([`StageIdentifier::conditioning`]).
    pub conditioning: [f64; 4],
    /// Convergence history.
    pub history: Vec<HistoryPoint>,
    /// Warnings (ill-conditioning, replaced dampings).
    pub warnings: Vec<String>,
}

/// The regression rows, in the order of [`Theta`]'s rows: the output rows and the plates'.
const ROWS: [&str; 4] = [
    "q_o1 (k_qo1, c_qo1)",
    "q_o2 (k_qo2, c_qo2)",
    "x_in1 (k_in1, k_pea1, c_in1)",
    "x_in2 (k_in2, k_pea2, c_in2)",
];

/// Largest factor by which an identified stiffness may differ from its guess (either way).
/// The guess comes from the reduced model of the design (Section 3.2.1), which predicts the
/// stiffnesses within tens of percent; an estimate a thousand times off means the record does
/// not identify the model (wrong units, a sensor on the wrong axis), not a different stage.
pub const PLAUSIBLE_FACTOR: f64 = 1e3;

/// The exit guard of [`identify`]: every estimate finite; every stiffness positive and within
/// [`PLAUSIBLE_FACTOR`] of its guess; and no row of θ stuck at its initial value (equal to
/// the guess's within round-off, 1e-12 relative), which means the record carried no
/// information the estimator could use for that row.
fn check_estimate(
    raw: &Physical,
    guess: &StageParams,
    theta: &Theta,
    theta0: &Theta,
) -> Result<()> {
    let p = &raw.params;
    let rows = |t: &Theta| -> [Vec<f64>; 4] {
        [
            t.output1.to_vec(),
            t.output2.to_vec(),
            t.plate[0].to_vec(),
            t.plate[1].to_vec(),
        ]
    };
    let (now, start) = (rows(theta), rows(theta0));
    let finite = now.iter().flatten().all(|v| v.is_finite());
    if !finite || raw.coupling.iter().any(|v| !v.is_finite()) {
        return Err(IdentifyError::Estimate {
            what: "stage identification".into(),
            reason: "the estimator diverged (a non-finite θ or coupling): the record does not \
                     identify the model (check the columns' units [m], the sample time and the \
                     excitation)"
                .into(),
        });
    }
    // Stuck: a row's θ within round-off of its start, ‖θ − θ₀‖ ≤ 1e-12 ‖θ₀‖. One stuck row
    // is enough to refuse: its parameters would be reported as estimates while they are the
    // guess (a column 1e300 times too large left the x_in1 row at its start).
    let norm = |v: &mut dyn Iterator<Item = f64>| v.map(|x| x * x).sum::<f64>().sqrt();
    let stuck: Vec<&str> = now
        .iter()
        .zip(&start)
        .zip(ROWS)
        .filter(|((a, b), _)| {
            norm(&mut a.iter().zip(*b).map(|(x, y)| x - y)) <= 1e-12 * norm(&mut b.iter().copied())
        })
        .map(|(_, name)| name)
        .collect();
    if !stuck.is_empty() {
        return Err(IdentifyError::Estimate {
            what: "stage identification".into(),
            reason: format!(
                "the estimates of the {} regression(s) equal their initial guess to round-off \
                 (1e-12 relative): the record carried no information the estimator used for \
                 them (a constant or too short record, inputs that do not move the stage, \
                 columns in the wrong units, or an initial covariance too small to let the \
                 estimates move)",
                stuck.join(", ")
            ),
        });
    }
    for (name, v, g) in [
        ("k_qo1", p.k_qo1, guess.k_qo1),
        ("k_qo2", p.k_qo2, guess.k_qo2),
        ("k_pea1", p.k_pea1, guess.k_pea1),
        ("k_pea2", p.k_pea2, guess.k_pea2),
        ("k_in1", p.k_in1, guess.k_in1),
        ("k_in2", p.k_in2, guess.k_in2),
    ] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(IdentifyError::Estimate {
                what: name.into(),
                reason: format!(
                    "the estimate {v:e} N/m is not a positive stiffness: the record does not \
                     identify the model (check the columns' units [m] and the excitation)"
                ),
            });
        }
        if !(v <= g * PLAUSIBLE_FACTOR && v >= g / PLAUSIBLE_FACTOR) {
            return Err(IdentifyError::Estimate {
                what: name.into(),
                reason: format!(
                    "the estimate {v:e} N/m is outside [{:e}, {:e}], {PLAUSIBLE_FACTOR:e} times \
                     either side of the guess {g:e} N/m: the record does not identify the \
                     model (check the columns' units [m] and the excitation)",
                    g / PLAUSIBLE_FACTOR,
                    g * PLAUSIBLE_FACTOR
                ),
            });
        }
    }
    for (name, v) in [
        ("c_qo1", p.c_qo1),
        ("c_qo2", p.c_qo2),
        ("c_in1", p.c_in1),
        ("c_in2", p.c_in2),
    ] {
        if !v.is_finite() {
            return Err(IdentifyError::Estimate {
                what: name.into(),
                reason: format!("the damping estimate {v:e} N·s/m is not finite"),
            });
        }
    }
    Ok(())
}

/// Identifies the stage parameters from a record, starting from `guess` (masses and α
/// fixed, see [`StageIdentifier::new`]). Errors when a regressor is not excited, an estimate
/// is not finite, a stiffness is not positive or more than [`PLAUSIBLE_FACTOR`] from its
/// guess, or a row of the estimate is stuck at the guess; warns when the information matrix is ill-conditioned.
pub fn identify(
    record: &StageRecord,
    guess: &StageParams,
    params: &IdentifyParams,
) -> Result<Identification> {
    let ts = record.sample_time();
    let mut id = StageIdentifier::new(guess, 0.0, ts, params)?;
    let n = record.len();
    let every = (n / params.history_points).max(1);
    let mut history = Vec::with_capacity(params.history_points + 1);
    for k in 0..n {
        id.update(
            [record.x_nom[0][k], record.x_nom[1][k]],
            [record.x_in[0][k], record.x_in[1][k]],
            [record.q[0][k], record.q[1][k]],
        );
        if (k + 1) % every == 0 || k + 1 == n {
            history.push(HistoryPoint {
                t: record.t[k],
                estimate: id.estimate(),
            });
        }
    }
    id.check_excitation()?;
    let conditioning = id.conditioning();
    let mut warnings = Vec::new();
    let names = ["q_o1", "q_o2", "x_in1", "x_in2"];
    for (i, &c) in conditioning.iter().enumerate() {
        if !(c <= params.condition_warning) {
            warnings.push(format!(
                "the {} regression is ill-conditioned (condition number {c:.3e} > {:.1e}): the \
                 excitation is not persistent in some direction; its estimates are unreliable \
                 (use a richer or longer excitation: both PEAs, independent signals, \
                 frequencies up to a few hundred Hz)",
                names[i], params.condition_warning
            ));
        }
    }
    let raw = id.estimate();
    check_estimate(
        &raw,
        guess,
        &id.theta(),
        &Theta::from_params(guess, 0.0, id.ts),
    )?;
    let p = &raw.params;
    let mut out = p.clone();
    for (name, v, g, slot) in [
        ("c_qo1", p.c_qo1, guess.c_qo1, &mut out.c_qo1),
        ("c_qo2", p.c_qo2, guess.c_qo2, &mut out.c_qo2),
        ("c_in1", p.c_in1, guess.c_in1, &mut out.c_in1),
        ("c_in2", p.c_in2, guess.c_in2, &mut out.c_in2),
    ] {
        if !(v >= 0.0 && v.is_finite()) {
            warnings.push(format!(
                "{name}: the damping estimate {v:e} N·s/m is not physical; the guess {g:e} is \
                 written instead (damping is weakly identifiable, see the docs)"
            ));
            *slot = g;
        }
    }
    let coupling = if params.coupling {
        0.5 * (raw.coupling[0] + raw.coupling[1])
    } else {
        0.0
    };
    Ok(Identification {
        sample_time: ts,
        regression_time: id.regression_time(),
        updates: id.updates(),
        theta: id.theta(),
        raw,
        params: out,
        coupling,
        conditioning,
        history,
        warnings,
    })
}
