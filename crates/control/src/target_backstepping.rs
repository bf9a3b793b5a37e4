//! The backstepping controller ([`crate::controller`], `robust` and `nonrobust`) as a
//! real-time target runs it, with the reference and its first three time derivatives
//! supplied from outside at every sample ([`BacksteppingInput`]).
//!
//! [`BacksteppingLaw`] holds every coefficient of one sample of it: the K-filter of
//! Eq. (37)–(42) as its matrices (F = Φ − L C and L: the pole-placed injection of Table 4 or
//! the steady-state Kalman gain of [`crate::estimator`]; Γ), the nominal sampled model (Φ, Γ)
//! the estimate is predicted with over the rig's delay with the commands still pending, the
//! robust backstepping law of Appendix D of Actuators 2022, 11(7), 179
//! ([`crate::backstepping::Law`]: the rows of B it reads, G⁻¹ and the gains), the input
//! transformation (Eq. 44, corrected: D⁻¹ and the rows of B, [`crate::controller`]), the
//! notches on the reading as second-order sections, a learned correction table when it has
//! one (frozen, subtracted from the reading as the learning layer does), and the actuator
//! stage of [`crate::actuator`] (stroke clip, inverse hysteresis compensation of Eq. 19–21,
//! amplifier range). [`BacksteppingTarget`] runs it, and the simulated controller
//! ([`crate::controller::BacksteppingController`]) steps exactly this, sampling the reference
//! itself, so what is exported is what was simulated.
//! [`BacksteppingLaw::c_source`] writes it as a self-contained C99 source and header;
//! `docs/controller-export.md` says how to call it.
//!
//! # The reference the law takes
//! At sample k the law aims at the reference of sample k + d (d the delay it predicts over),
//! half a sample earlier when d ≥ 1, and each axis earlier again by its notches'
//! low-frequency delay τ_i ([`crate::controller::notch_delay`]): axis i takes q_d and its
//! first three derivatives at t_i = ((k + d) − λ) T − τ_i, λ = [`BacksteppingLaw::lead`]
//! ([`BacksteppingLaw::reference_time`]).

use flexstage_control_core::Biquad;
use flexstage_sim::model::Matrix8;
use flexstage_sim::model::state::{Q_O, Q_O_DOT, X_IN, X_IN_DOT};
use flexstage_sim::trajectory::{RefSample, Reference};
use nalgebra::{Matrix2, SMatrix, Vector2};

use crate::actuator::{Actuated, Actuator, ActuatorParams};
use crate::backstepping::{Law, LawOutput, LawParams};
use crate::controller::{Inner, MAX_DELAY, Velocity};
use crate::error::{Result, check, positive};
use crate::observer::{DISTURBANCE, KFilter, Matrix10, Matrix10x2, Vector10};

/// Every coefficient of the backstepping controller on a target (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct BacksteppingLaw {
    /// Sample time T \[s\].
    pub sample_time: f64,
    /// Samples d of rig delay the estimate is predicted over, 0–2 (0: the reading is used
    /// directly, as in Section 3.2.2).
    pub delay: usize,
    /// Φ = e^{B T} of the observer's augmented model \[z, d\] (10 × 10): the prediction.
    pub phi: Matrix10,
    /// Γ = ∫₀ᵀ e^{Bs} ds b (10 × 2): the input filters and the prediction.
    pub gamma: Matrix10x2,
    /// The filter's error matrix F = Φ − L C (10 × 10).
    pub f: Matrix10,
    /// The filter's injection gain L (10 × 2).
    pub l: Matrix10x2,
    /// B of the controller's model (Eq. 36; rows 5–8 are read).
    pub b: Matrix8,
    /// G⁻¹ of the law (A24).
    pub g_inv: Matrix2<f64>,
    /// D⁻¹ of the input transformation (Eq. 44).
    pub d_inv: Matrix2<f64>,
    /// The law's gains and robust terms.
    pub law: LawParams,
    /// Where q̇ comes from with d = 0 (with d ≥ 1 always the estimate).
    pub velocity: Velocity,
    /// The inner state the law takes.
    pub inner: Inner,
    /// Whether the law cancels the estimated model error Δ̂_η.
    pub disturbance_feedback: bool,
    /// Per axis, the two notch sections on the reading (the identity where there is none).
    pub notches: [[Biquad; 2]; 2],
    /// Per axis, the notches' low-frequency delay τ_i \[s\] (the reference's shift).
    pub notch_delay: [f64; 2],
    /// The actuator stage.
    pub actuator: ActuatorParams,
    /// The learned correction c\[k\] \[m\] per sample of the period, subtracted from the
    /// reading; `None`: no learning.
    pub learned: Option<Vec<[f64; 2]>>,
}

/// The matrix of `rows` (row-major, as the coefficients file stores it).
pub fn matrix<const R: usize, const C: usize>(rows: &[[f64; C]; R]) -> SMatrix<f64, R, C> {
    SMatrix::from_fn(|i, j| rows[i][j])
}

/// The rows of `m` ([`matrix`] back).
pub fn rows<const R: usize, const C: usize>(m: &SMatrix<f64, R, C>) -> [[f64; C]; R] {
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
}

/// What a [`BacksteppingTarget`] takes at sample k.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BacksteppingInput {
    /// The reading y \[m\] (non-finite: a dropout).
    pub reading: [f64; 2],
    /// Per axis i, q_d and its first three derivatives at
    /// [`BacksteppingLaw::reference_time`] (m, m/s, m/s², m/s³).
    pub reference: RefSample,
    /// The sample's index k from the reference's start (entry k mod N of the learned table
    /// is used; unused without a table).
    pub index: usize,
}

/// What a [`BacksteppingTarget`] gives at one sample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BacksteppingOutput {
    /// Voltages, x_nom and whether anything clipped.
    pub command: Actuated,
    /// True when the reading was not finite and the last finite one was used.
    pub dropout: bool,
}

impl BacksteppingLaw {
    /// The samples λ the law's reference is taken earlier: 0.5 with a delay, else 0
    /// ([`crate::controller`], "Reference timing").
    pub fn lead(&self) -> f64 {
        if self.delay > 0 { 0.5 } else { 0.0 }
    }

    /// The time \[s\] at which axis `axis` of the reference of sample `k` is taken:
    /// ((k + d) − λ) T − τ_axis (module docs).
    pub fn reference_time(&self, k: u64, axis: usize) -> f64 {
        ((k + self.delay as u64) as f64 - self.lead()) * self.sample_time - self.notch_delay[axis]
    }

    /// The reference the law takes at sample `k` of `reference` (sample 0 at t = 0): each
    /// axis at [`BacksteppingLaw::reference_time`].
    pub fn reference_at(&self, reference: &Reference, k: u64) -> RefSample {
        let t0 = self.reference_time(k, 0);
        let t1 = self.reference_time(k, 1);
        let mut r = reference.sample(t0);
        if t1 != t0 {
            let b = reference.sample(t1);
            r.q[1] = b.q[1];
            r.dq[1] = b.dq[1];
            r.ddq[1] = b.ddq[1];
            r.dddq[1] = b.dddq[1];
        }
        r
    }

    /// This law with the learned correction table `table` (one entry per sample of the
    /// period, ≥ 1 entries, finite; checked by [`BacksteppingLaw::controller`]).
    pub fn with_learned(mut self, table: Vec<[f64; 2]>) -> BacksteppingLaw {
        self.learned = Some(table);
        self
    }

    /// The controller at rest (estimate zero, no history, PEA models preloaded to the bias).
    /// Checks every coefficient: T > 0, d ≤ 2, finite matrices, sections and table, the
    /// law's gains in their ranges, a valid actuator stage.
    pub fn controller(&self) -> Result<BacksteppingTarget> {
        positive("backstepping.sample_time", self.sample_time)?;
        check(
            "backstepping.delay",
            self.delay as f64,
            self.delay <= MAX_DELAY,
            "0–2 samples",
        )?;
        let finite = |field: &str, v: &mut dyn Iterator<Item = f64>| -> Result<()> {
            for x in v {
                check(field, x, x.is_finite(), "finite coefficients")?;
            }
            Ok(())
        };
        finite("backstepping.phi", &mut self.phi.iter().copied())?;
        finite("backstepping.gamma", &mut self.gamma.iter().copied())?;
        finite("backstepping.f", &mut self.f.iter().copied())?;
        finite("backstepping.l", &mut self.l.iter().copied())?;
        finite("backstepping.model_b", &mut self.b.iter().copied())?;
        finite("backstepping.g_inv", &mut self.g_inv.iter().copied())?;
        finite("backstepping.d_inv", &mut self.d_inv.iter().copied())?;
        finite(
            "backstepping.notch_delay",
            &mut self.notch_delay.into_iter(),
        )?;
        for s in self.notches.iter().flatten() {
            let mut v = s.numerator().into_iter().chain(s.denominator());
            finite("backstepping.notches", &mut v)?;
        }
        if let Some(table) = &self.learned {
            check(
                "backstepping.learned",
                table.len() as f64,
                !table.is_empty(),
                "at least one sample",
            )?;
            finite("backstepping.learned", &mut table.iter().flatten().copied())?;
        }
        Ok(BacksteppingTarget {
            law: Law::with_inverse(self.b, self.g_inv, self.law)?,
            filter: KFilter::from_matrices(&self.f, &self.l, &self.gamma),
            phi: self.phi,
            gamma: self.gamma,
            b: self.b,
            d_inv: self.d_inv,
            actuator: Actuator::new(self.actuator)?,
            velocity: self.velocity,
            inner: self.inner,
            disturbance_feedback: if self.disturbance_feedback { 1.0 } else { 0.0 },
            notch: self.notches,
            t: self.sample_time,
            delay: self.delay,
            pending: [[0.0; 2]; MAX_DELAY],
            xi_d: [0.0; 2],
            y_prev: [0.0; 2],
            v_prev: [0.0; 2],
            have_prev: false,
            last: Actuated::default(),
            last_law: LawOutput::default(),
            learned: self.learned.clone(),
        })
    }

    /// This law as a self-contained C99 header and source whose functions and types are
    /// prefixed `prefix` (a C identifier); the source includes the header by the file name
    /// `header_file`.
    pub fn c_source(&self, prefix: &str, header_file: &str) -> Result<crate::target::CSource> {
        crate::target_backstepping_c::c_source(self, prefix, header_file)
    }
}

/// A [`BacksteppingLaw`] running: `step(input) -> output` ([`BacksteppingInput`]). No
/// allocation per step.
#[derive(Debug, Clone)]
pub struct BacksteppingTarget {
    law: Law,
    pub(crate) filter: KFilter,
    phi: Matrix10,
    gamma: Matrix10x2,
    b: Matrix8,
    d_inv: Matrix2<f64>,
    pub(crate) actuator: Actuator,
    velocity: Velocity,
    inner: Inner,
    disturbance_feedback: f64,
    notch: [[Biquad; 2]; 2],
    t: f64,
    delay: usize,
    /// Commands x_nom issued but not yet acting, oldest first (`pending[0]` acts during the
    /// current sample when `delay` ≥ 1).
    pending: [[f64; 2]; MAX_DELAY],
    pub(crate) xi_d: [f64; 2],
    pub(crate) y_prev: [f64; 2],
    pub(crate) v_prev: [f64; 2],
    pub(crate) have_prev: bool,
    last: Actuated,
    pub(crate) last_law: LawOutput,
    learned: Option<Vec<[f64; 2]>>,
}

impl BacksteppingTarget {
    /// The estimate [ẑ, d̂] predicted to the sample at which the next command acts: the
    /// filter's ẑ_{k+1|k} advanced by the nominal model (Φ, Γ, without injection) with the
    /// commands still pending, `delay − 1` samples.
    #[inline]
    fn predicted(&self) -> Vector10 {
        let mut z = self.filter.estimate();
        for u in &self.pending[1..self.delay] {
            z = self.phi * z + self.gamma * Vector2::new(u[0], u[1]);
        }
        z
    }

    /// The estimate [ẑ, d̂] and the output position and velocity the law takes, after the
    /// notched reading `y` (and the raw one `y_raw` for the finite difference).
    #[inline]
    fn estimate(&mut self, y: [f64; 2], y_raw: [f64; 2]) -> (Vector10, [f64; 2], [f64; 2]) {
        let t = self.t;
        // With a delay, the estimate is first advanced with the command acting now, then
        // predicted to the sample at which the new command acts.
        let zh = if self.delay > 0 {
            self.filter.step(y, self.pending[0]);
            self.predicted()
        } else {
            self.filter.estimate()
        };
        let (q, q_dot) = if self.delay > 0 {
            (Q_O.map(|i| zh[i]), Q_O_DOT.map(|i| zh[i]))
        } else {
            let v = match self.velocity {
                Velocity::FiniteDifference if self.have_prev => [
                    (y_raw[0] - self.y_prev[0]) / t,
                    (y_raw[1] - self.y_prev[1]) / t,
                ],
                _ => Q_O_DOT.map(|i| zh[i]),
            };
            (y, v)
        };
        (zh, q, q_dot)
    }

    /// The input transformation (44*) with ξ_d at mid-sample: x_nom = D⁻¹ rhs.
    #[inline]
    fn transformation(&self, v: [f64; 2], q: [f64; 2], q_dot: [f64; 2]) -> [f64; 2] {
        let t = self.t;
        let v_dot = if self.have_prev {
            [(v[0] - self.v_prev[0]) / t, (v[1] - self.v_prev[1]) / t]
        } else {
            [0.0; 2]
        };
        let b = &self.b;
        let ([q1, q2], [x1, x2], [v1, v2], [w1, w2]) = (Q_O, X_IN, Q_O_DOT, X_IN_DOT);
        let mut rhs = Vector2::zeros();
        for i in 0..2 {
            let row = X_IN_DOT[i];
            let xi_mid = [self.xi_d[0] + 0.5 * t * v[0], self.xi_d[1] + 0.5 * t * v[1]];
            rhs[i] = v_dot[i]
                - (b[(row, q1)] * q[0]
                    + b[(row, q2)] * q[1]
                    + b[(row, v1)] * q_dot[0]
                    + b[(row, v2)] * q_dot[1]
                    + b[(row, x1)] * xi_mid[0]
                    + b[(row, x2)] * xi_mid[1]
                    + b[(row, w1)] * v[0]
                    + b[(row, w2)] * v[1]);
        }
        let u = self.d_inv * rhs;
        [u[0], u[1]]
    }

    /// One sample (the law of [`crate::controller`]): the learned correction off the
    /// reading, a non-finite reading held at the last finite one, the notches, the estimate
    /// (predicted over the delay), the law, the input transformation, the actuator stage. A
    /// non-finite command repeats the last one and restarts ξ_d from the estimate.
    #[inline]
    pub fn step(&mut self, input: &BacksteppingInput) -> BacksteppingOutput {
        let t = self.t;
        let mut y_in = input.reading;
        if let Some(table) = &self.learned {
            let c = table[input.index % table.len()];
            y_in = [y_in[0] - c[0], y_in[1] - c[1]];
        }
        let dropout = !(y_in[0].is_finite() && y_in[1].is_finite());
        let y_raw = if dropout { self.y_prev } else { y_in };
        let mut y = y_raw;
        for (i, n) in self.notch.iter_mut().enumerate() {
            let a = n[0].step(y[i]);
            y[i] = n[1].step(a);
        }
        let (zh, q, q_dot) = self.estimate(y, y_raw);
        // η̂ = [z1, z2, ẑ3, ẑ4, q̇1, q̇2] and ξ̂̇ = [ẑ7, ẑ8] (Section 3.2.2, after Eq. 44).
        let (xi, xi_dot) = match self.inner {
            Inner::Estimate => (X_IN.map(|i| zh[i]), X_IN_DOT.map(|i| zh[i])),
            Inner::Command => (self.xi_d, self.v_prev),
        };
        let mut eta = [0.0; 6];
        for i in 0..2 {
            eta[Q_O[i]] = q[i];
            eta[X_IN[i]] = xi[i];
            eta[Q_O_DOT[i]] = q_dot[i];
        }
        let delta = DISTURBANCE.map(|i| self.disturbance_feedback * zh[i]);
        let law = self.law.evaluate(&eta, &xi_dot, &delta, &input.reference);
        let v = law.v;
        let mut u = self.transformation(v, q, q_dot);
        let finite = u[0].is_finite() && u[1].is_finite();
        if !finite {
            u = self.last.x_nom;
        }
        let mut act = self.actuator.command(u, t);
        if !(act.voltage[0].is_finite() && act.voltage[1].is_finite()) {
            act.voltage = self.last.voltage;
            act.x_nom = self.last.x_nom;
        }
        if self.delay == 0 {
            self.filter.step(y, act.x_nom);
        } else {
            self.pending.copy_within(1..self.delay, 0);
            self.pending[self.delay - 1] = act.x_nom;
        }
        if !finite {
            let z = self.filter.estimate();
            self.xi_d = X_IN.map(|i| z[i]);
            self.v_prev = [0.0; 2];
        } else {
            if !act.saturated {
                self.xi_d[0] += t * v[0];
                self.xi_d[1] += t * v[1];
            }
            self.v_prev = v;
        }
        self.y_prev = y_raw;
        self.have_prev = true;
        self.last = act;
        self.last_law = law;
        BacksteppingOutput {
            command: act,
            dropout,
        }
    }
}

/// One sample of a recorded sequence ([`recorded_sequence`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Recorded {
    /// What the controller took (the reading NaN during the dropout).
    pub input: BacksteppingInput,
    /// What it commanded.
    pub output: BacksteppingOutput,
}

/// A recorded sequence of a [`BacksteppingTarget`] ([`recorded_sequence`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedSequence {
    /// The samples.
    pub samples: Vec<Recorded>,
}

impl RecordedSequence {
    /// The commands of the samples.
    pub fn commands(&self) -> Vec<Actuated> {
        self.samples.iter().map(|r| r.output.command).collect()
    }

    /// The sequence as the C check reads it (`c/check_backstepping.c`): a header line, then
    /// per sample k, the reading, the index, the reference times of `law` (the law recorded)
    /// per axis, the reference (q_d, its three derivatives, each q1, q2), the voltages, x_nom,
    /// the saturation and dropout flags; every number in its shortest round-trip form.
    pub fn to_csv(&self, law: &BacksteppingLaw) -> String {
        use std::fmt::Write as _;
        let mut csv = String::from(
            "k,y1,y2,index,t1,t2,q1,q2,dq1,dq2,ddq1,ddq2,dddq1,dddq2,voltage1,voltage2,\
             x_nom1,x_nom2,saturated,dropout\n",
        );
        for (k, s) in self.samples.iter().enumerate() {
            let (i, c) = (s.input, s.output.command);
            let r = i.reference;
            let t = [0, 1].map(|a| law.reference_time(k as u64, a));
            let numbers = [
                i.reading[0],
                i.reading[1],
                i.index as f64,
                t[0],
                t[1],
                r.q[0],
                r.q[1],
                r.dq[0],
                r.dq[1],
                r.ddq[0],
                r.ddq[1],
                r.dddq[0],
                r.dddq[1],
                c.voltage[0],
                c.voltage[1],
                c.x_nom[0],
                c.x_nom[1],
            ];
            let _ = write!(csv, "{k}");
            for v in numbers {
                let _ = write!(csv, ",{v:e}");
            }
            let _ = writeln!(
                csv,
                ",{},{}",
                u8::from(c.saturated),
                u8::from(s.output.dropout)
            );
        }
        csv
    }

    /// The commands of a fresh controller of `law` given the same inputs.
    pub fn replay(&self, law: &BacksteppingLaw) -> Result<Vec<Actuated>> {
        let mut c = law.controller()?;
        Ok(self
            .samples
            .iter()
            .map(|r| c.step(&r.input).command)
            .collect())
    }
}

/// A fixed seeded sequence of `law`'s controller in a closed loop that reaches every branch
/// of its step, as [`crate::target::recorded_sequence`] for the linear law: the law's own
/// nominal sampled model (Φ, Γ from the commanded x_nom to the output, the model error d at
/// zero) with the law's delay and 2 nm RMS of reading noise (seed `seed`), following a 3:1
/// Lissajous (±8 µm, ±16 µm at 20 Hz, from rest) given at the law's reference times
/// ([`BacksteppingLaw::reference_at`]), with a sensor dropout of five samples (NaN readings)
/// and, from sample 2000 to 2400, the reference 40 µm further on q1 and 40 µm back on q2;
/// the stroke clips that jump and the Lissajous's peaks (the amplifier range, behind the
/// stroke, is not reached: the linear law's sequence reaches it in the same actuator stage);
/// with a learned table, the index k mod N.
pub fn recorded_sequence(law: &BacksteppingLaw, seed: u64) -> Result<RecordedSequence> {
    use flexstage_sim::trajectory::Shape;
    let mut c = law.controller()?;
    let reference = Reference::new(Shape::Lissajous {
        ratio: 3.0,
        amplitude: [8e-6, 16e-6],
        frequency: 20.0,
    });
    let period = law.learned.as_ref().map_or(1, Vec::len);
    let mut noise = flexstage_numerics::noise::GaussianNoise::new(2e-9, seed);
    let mut x = Vector10::zeros();
    let mut queue = [[0.0; 2]; MAX_DELAY + 1];
    let mut samples = Vec::with_capacity(crate::target::RECORDED_SAMPLES);
    for k in 0..crate::target::RECORDED_SAMPLES {
        let reading = if (1500..1505).contains(&k) {
            [f64::NAN; 2]
        } else {
            [x[0] + noise.sample(), x[1] + noise.sample()]
        };
        let mut r = law.reference_at(&reference, k as u64);
        if (2000..2400).contains(&k) {
            r.q = [r.q[0] + 40e-6, r.q[1] - 40e-6];
        }
        let input = BacksteppingInput {
            reading,
            reference: r,
            index: k % period,
        };
        let output = c.step(&input);
        // The command acts `delay` samples later.
        queue[law.delay] = output.command.x_nom;
        let u = queue[0];
        queue.copy_within(1..=MAX_DELAY, 0);
        x = law.phi * x + law.gamma * Vector2::new(u[0], u[1]);
        samples.push(Recorded { input, output });
    }
    Ok(RecordedSequence { samples })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::actuator::Compensation;
    use crate::target::largest_relative_difference;

    /// The `robust` (or `nonrobust`) design of the registry on the paper scenario over two
    /// decoupled 1 %-damped modes with one sample of delay (the model fitted to the
    /// response, the PI + notch's notches on the reading), with inverse compensation.
    fn design(robust: bool) -> (std::sync::Arc<dyn crate::registry::Design>, ActuatorParams) {
        let setup = crate::experiment::Setup::from_scenario(&flexstage_scenario::Scenario::paper());
        let designs = crate::samples::decoupled_designs(&setup).unwrap();
        let c = if robust {
            &crate::controller::ROBUST
        } else {
            &crate::controller::NONROBUST
        };
        (
            designs.get(c).unwrap().clone(),
            setup.actuator(Compensation::Inverse),
        )
    }

    /// The law of [`design`] predicting over `delay` samples.
    fn law(robust: bool, delay: usize) -> BacksteppingLaw {
        let (d, actuator) = design(robust);
        d.backstepping(actuator, delay).unwrap().unwrap()
    }

    fn table() -> Vec<[f64; 2]> {
        (0..500)
            .map(|k| {
                let w = std::f64::consts::TAU * k as f64 / 500.0;
                [2e-9 + 3e-9 * w.sin(), -1e-9 + 2e-9 * (2.0 * w).cos()]
            })
            .collect()
    }

    /// The recorded sequence reaches the branches of the step (dropout, clipping by the
    /// stroke, the unclipped loop), stays finite, and replaying it gives
    /// it back bitwise: robust with 0, 1 and 2 samples of delay, non-robust, with a learned
    /// table.
    #[test]
    fn recorded_sequence_reaches_every_branch_and_replays_bitwise() {
        let laws = [
            law(true, 1),
            law(true, 0),
            law(true, 2),
            law(false, 1),
            law(true, 1).with_learned(table()),
        ];
        for l in laws {
            assert!(l.notches.iter().flatten().any(|s| *s != Biquad::IDENTITY));
            let seq = recorded_sequence(&l, 7).unwrap();
            assert!(seq.samples.iter().any(|r| r.output.dropout));
            let clipped = seq
                .samples
                .iter()
                .filter(|r| r.output.command.saturated)
                .count();
            assert!(
                clipped > 10 && clipped < 1500,
                "delay {}: {clipped}",
                l.delay
            );
            assert!(
                seq.samples
                    .iter()
                    .all(|r| r.output.command.voltage.iter().all(|v| v.is_finite()))
            );
            assert_eq!(
                largest_relative_difference(&seq.replay(&l).unwrap(), &seq.commands()),
                0.0
            );
        }
    }

    /// Goal: the simulated controller steps the target law: a registry design's
    /// `BacksteppingController` (sampling its reference itself) gives, sample by sample, the
    /// commands of the [`BacksteppingTarget`] of its [`BacksteppingLaw`] given the reference
    /// at [`BacksteppingLaw::reference_at`] (the C's interface), bitwise, with 0 and 1
    /// samples of delay: the law the design exports is the one it simulates.
    #[test]
    fn the_simulated_controller_is_the_target_law_bitwise() {
        use flexstage_sim::experiment::StageControl;
        use flexstage_sim::trajectory::Shape;
        let r = Reference::new(Shape::Lissajous {
            ratio: 3.0,
            amplitude: [5e-6, 9e-6],
            frequency: 20.0,
        });
        let (d, actuator) = design(true);
        for delay in [0, 1] {
            let l = d.backstepping(actuator, delay).unwrap().unwrap();
            let mut sim = d.build(actuator, delay, r).unwrap();
            let mut target = l.controller().unwrap();
            let mut y = [0.0; 2];
            for k in 0..2000u64 {
                let want = target.step(&BacksteppingInput {
                    reading: y,
                    reference: l.reference_at(&r, k),
                    index: k as usize,
                });
                let got = sim.step(y);
                assert_eq!(
                    got.x_nom.map(f64::to_bits),
                    want.command.x_nom.map(f64::to_bits)
                );
                assert_eq!(
                    got.voltage.map(f64::to_bits),
                    want.command.voltage.map(f64::to_bits)
                );
                y = [0.9 * got.x_nom[0], 1.1 * got.x_nom[1]];
            }
        }
    }

    /// The check can fail: a coefficient changed by one part in 10⁹ (an entry of F, L, Γ,
    /// Φ, B, G⁻¹, D⁻¹, a gain of the law, a notch coefficient, a Bouc–Wen parameter of the
    /// compensator, the learned table) moves some command of the recorded sequence by more
    /// than the 1e-12 the C check accepts.
    #[test]
    fn a_mutated_coefficient_fails_the_check() {
        let l = law(true, 2).with_learned(table());
        let seq = recorded_sequence(&l, 7).unwrap();
        let commands = seq.commands();
        let s = 1.0 + 1e-9;
        let mut mutants: Vec<(&str, BacksteppingLaw)> = Vec::new();
        let mut m = l.clone();
        m.f[(4, 0)] *= s;
        mutants.push(("F", m));
        let mut m = l.clone();
        m.l[(5, 1)] *= s;
        mutants.push(("L", m));
        let mut m = l.clone();
        m.gamma[(6, 0)] *= s;
        mutants.push(("Gamma", m));
        let mut m = l.clone();
        m.phi[(4, 0)] *= s;
        mutants.push(("Phi", m));
        let mut m = l.clone();
        m.b[(6, 2)] *= s;
        mutants.push(("B", m));
        let mut m = l.clone();
        m.g_inv[(0, 1)] *= s;
        mutants.push(("G^-1", m));
        let mut m = l.clone();
        m.d_inv[(1, 1)] *= s;
        mutants.push(("D^-1", m));
        let mut m = l.clone();
        m.law.error_gain[0] *= s;
        mutants.push(("k_eps", m));
        let mut m = l.clone();
        m.law.feedback_gain[1] *= s;
        mutants.push(("k", m));
        let mut m = l.clone();
        let n = m.notches[0][0];
        let (b, a) = (n.numerator(), n.denominator());
        m.notches[0][0] = Biquad::new([b[0], b[1] * s, b[2]], a);
        mutants.push(("notch b1", m));
        let mut m = l.clone();
        m.actuator.hysteresis[0].a_bw *= s;
        mutants.push(("A_bw", m));
        let mut m = l.clone();
        for c in m.learned.as_mut().unwrap() {
            c[0] *= s;
        }
        mutants.push(("learned table", m));
        for (what, m) in mutants {
            let d = largest_relative_difference(&seq.replay(&m).unwrap(), &commands);
            assert!(d > 1e-12, "{what}: {d}");
        }
    }

    /// Goal: `track` can export every controller it runs: each registry controller designed
    /// on a sampled stage has a linear target law or a backstepping law.
    #[test]
    fn every_registry_controller_has_a_target_law() {
        let (_, actuator) = design(true);
        let setup = crate::experiment::Setup::from_scenario(&flexstage_scenario::Scenario::paper());
        let designs = crate::samples::decoupled_designs(&setup).unwrap();
        for c in crate::registry::CONTROLLERS {
            let d = designs.get(c).unwrap();
            let linear = crate::target::TargetLaw::of_design(&**d, actuator).unwrap();
            let bs = d.backstepping(actuator, 1).unwrap();
            assert!(linear.is_some() != bs.is_some(), "{c}");
        }
    }

    /// A non-finite coefficient and a delay beyond two samples are refused naming the field.
    #[test]
    fn a_bad_law_is_refused_naming_the_field() {
        let mut m = law(true, 1);
        m.f[(3, 3)] = f64::NAN;
        let e = m.controller().unwrap_err().to_string();
        assert!(e.contains("backstepping.f"), "{e}");
        let mut m = law(true, 1);
        m.delay = 3;
        let e = m.controller().unwrap_err().to_string();
        assert!(e.contains("backstepping.delay"), "{e}");
    }
}
