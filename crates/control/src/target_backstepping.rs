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
use nalgebra::{Matrix2, Vector2};

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
        finite("backstepping.notch_delay", &mut self.notch_delay.into_iter())?;
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
