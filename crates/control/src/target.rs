//! A linear controller as a real-time target runs it: the PID + notch law
//! (`flexstage_control_core::PidLaw`) with its feed-forward (the static inverse G_dc⁻¹ q_d, or
//! the 2 × 2 FIR inverse of the measured loop with preview of [`crate::feedforward`]), the
//! positive position feedback of [`crate::damping`] when the controller damps its modes, a
//! learned correction table of one period when it learned one ([`crate::learning`], frozen),
//! followed by the actuator stage of [`crate::actuator`] (stroke clip, inverse hysteresis
//! compensation of Eq. 19–21 of Actuators 2022, 11(7), 179, amplifier range), with the
//! reference supplied from outside at every sample ([`TargetInput`]).
//!
//! [`TargetLaw`] holds every coefficient of it (per-axis gains, the notches and the PPF
//! filters as second-order section coefficients, the inverse static gain G_dc⁻¹, the FIR's
//! taps, preview and lag, the learned table, the sample time, the actuator stage with its
//! Bouc–Wen parameters); [`TargetController`] runs it, and the simulated PI + notch, PID and
//! PPF controllers ([`crate::pi_notch::PiNotchController`]) step exactly this, so what is
//! exported is what was simulated. [`TargetLaw::c_source`] writes it as a self-contained C99
//! source and header (coefficients compiled in as constants, the same arithmetic in the same
//! order, `<math.h>` only); `docs/controller-export.md` says how to call it.
//!
//! The backstepping controllers (K-filter observer, Kalman estimate, robust law) have no
//! [`TargetLaw`] ([`TargetLaw::of_design`] gives `None` for them): their law is
//! [`crate::target_backstepping::BacksteppingLaw`].

use flexstage_control_core::{Biquad, PidGains, PidLaw};
use flexstage_piezo::CompensatorParams;
use flexstage_sim::pea::{mean_slope, preload};
use nalgebra::Matrix2;

use crate::actuator::{Actuated, Actuator, ActuatorParams, Compensation};
use crate::error::{ControlError, Result, positive};
use crate::feedforward::{FirBuffer, FirFeedForward};
use crate::pi_notch::{PiNotchParams, notch_section};
use crate::registry::Design;

pub use crate::target_c::{c_prefix, is_c_identifier};

/// Every coefficient of a linear controller on a target (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct TargetLaw {
    /// Per-axis PID gains on e = q_d − y.
    pub gains: [PidGains; 2],
    /// Per axis, the two second-order sections in series on the feedback (the identity
    /// where the axis has no notch).
    pub sections: [[Biquad; 2]; 2],
    /// The inverse static gain G_dc⁻¹ (row-major): x_nom = G_dc⁻¹ (q_d + N(c)) with the
    /// static feed-forward, G_dc⁻¹ N(c) + x_ff with the FIR.
    pub inverse_gain: [[f64; 2]; 2],
    /// Sample time T \[s\].
    pub sample_time: f64,
    /// The actuator stage: stroke, amplifier range, bias, compensation mode and the
    /// compensator's Bouc–Wen parameters.
    pub actuator: ActuatorParams,
    /// The PPF damping filters D_i on each axis's reading ([`crate::damping`]; a zero
    /// section on an axis without one), added as G_dc⁻¹ D(y); `None`: no damping loop.
    pub damping: Option<[Biquad; 2]>,
    /// The FIR feed-forward with preview in place of the static inverse; `None`: the static
    /// inverse G_dc⁻¹ q_d.
    pub feedforward: Option<FirFeedForward>,
    /// The learned correction c\[k\] \[m\] of each sample k of the period (its length N),
    /// subtracted from the reading before the law sees it; `None`: no learning.
    pub learned: Option<Vec<[f64; 2]>>,
}

/// What a [`TargetController`] takes at sample k.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TargetInput {
    /// The reference q_d((k + p) T) \[m\], p the FIR's preview: the newest sample the FIR
    /// feed-forward reads (unused by the static feed-forward).
    pub ahead: [f64; 2],
    /// The feedback's reference \[m\]: q_d((k − τ) T), τ the FIR's lag (the sensor chain's
    /// datasheet lag); q_d(kT) with the static feed-forward, which also feeds it forward.
    pub reference: [f64; 2],
    /// The reading y \[m\] (non-finite: a dropout).
    pub reading: [f64; 2],
    /// The sample's index k from the reference's start (entry k mod N of the learned table
    /// is used; unused without a table).
    pub index: usize,
}

impl TargetLaw {
    /// The law of the PI(D) + notch + static feed-forward structure `p` with the actuator
    /// stage `actuator`: the notches as their prewarped Tustin sections
    /// ([`crate::pi_notch::notch_section`]), the static gain inverted.
    pub fn of_linear(p: &PiNotchParams, actuator: ActuatorParams) -> Result<TargetLaw> {
        p.validate()?;
        let g = p.static_gain;
        let inv = Matrix2::new(g[0][0], g[0][1], g[1][0], g[1][1])
            .try_inverse()
            .ok_or_else(|| ControlError::Singular {
                what: "pi_notch.static_gain".into(),
            })?;
        let t = p.sample_time;
        Ok(TargetLaw {
            gains: p.axes.map(|a| PidGains {
                kp: a.kp,
                ki: a.ki,
                kd: a.kd,
            }),
            sections: p.axes.map(|a| {
                a.notches
                    .map(|n| n.map_or(Biquad::IDENTITY, |n| notch_section(&n, t)))
            }),
            inverse_gain: [[inv[(0, 0)], inv[(0, 1)]], [inv[(1, 0)], inv[(1, 1)]]],
            sample_time: t,
            actuator,
            damping: None,
            feedforward: None,
            learned: None,
        })
    }

    /// This law with the FIR feed-forward `ff` in place of the static inverse.
    pub fn with_feedforward(mut self, ff: FirFeedForward) -> TargetLaw {
        self.feedforward = Some(ff);
        self
    }

    /// This law with the PPF damping filters `filters` on the readings.
    pub fn with_damping(mut self, filters: [Biquad; 2]) -> TargetLaw {
        self.damping = Some(filters);
        self
    }

    /// This law with the learned correction table `table` (one entry per sample of the
    /// period, ≥ 1 entries, finite; checked by [`TargetLaw::controller`]).
    pub fn with_learned(mut self, table: Vec<[f64; 2]>) -> TargetLaw {
        self.learned = Some(table);
        self
    }

    /// The law of a registry design with the actuator stage `actuator`
    /// ([`Design::target`]); `None` for a nonlinear design (the backstepping), which has no
    /// such law.
    pub fn of_design(design: &dyn Design, actuator: ActuatorParams) -> Result<Option<TargetLaw>> {
        design.target(actuator)
    }

    /// The controller at rest (PEA models preloaded to the bias, no history, the FIR's
    /// buffer zero: prime it with [`TargetController::prime`]). Checks every coefficient:
    /// gains ≥ 0, finite sections, inverse gain and learned table, T > 0, a valid actuator
    /// stage.
    pub fn controller(&self) -> Result<TargetController> {
        let finite =
            |field: &str, v: f64| crate::error::check(field, v, true, "finite coefficients");
        for (i, axis) in self.sections.iter().enumerate() {
            for s in axis {
                for v in s.numerator().into_iter().chain(s.denominator()) {
                    finite(&format!("target.sections[{i}]"), v)?;
                }
            }
        }
        for (i, s) in self.damping.iter().flatten().enumerate() {
            for v in s.numerator().into_iter().chain(s.denominator()) {
                finite(&format!("target.damping[{i}]"), v)?;
            }
        }
        if let Some(table) = &self.learned {
            crate::error::check(
                "target.learned",
                table.len() as f64,
                !table.is_empty(),
                "at least one sample",
            )?;
            for (k, c) in table.iter().enumerate() {
                finite(&format!("target.learned[{k}]"), c[0])?;
                finite(&format!("target.learned[{k}]"), c[1])?;
            }
        }
        if let Some(ff) = &self.feedforward {
            let checked = FirFeedForward::from_taps(ff.preview(), ff.taps().to_vec(), ff.lag())?;
            if let Some(c) = ff.reading() {
                checked.with_reading(c.to_vec())?;
            }
        }
        positive("target.sample_time", self.sample_time)?;
        let law = PidLaw::new(
            self.gains,
            self.inverse_gain,
            self.sample_time,
            self.actuator.stroke,
        )?
        .with_sections(self.sections);
        Ok(TargetController {
            law,
            actuator: Actuator::new(self.actuator)?,
            sample_time: self.sample_time,
            last_x_nom: [0.0; 2],
            damping: self.damping.map(|f| (f, self.inverse_gain)),
            last_y: [0.0; 2],
            fir: self.feedforward.as_ref().map(FirBuffer::new),
            learned: self.learned.clone(),
            expected: None,
        })
    }

    /// The constants the actuator stage derives from its parameters at start-up, per PEA:
    /// the preloaded state (U_b \[V\], h_b \[µm\]), the rest displacement x_bias \[µm\] and the
    /// mean virgin slope κ \[µm/V\] ([`crate::actuator`]).
    pub fn preload(&self) -> [Preload; 2] {
        preload_of(&self.actuator)
    }

    /// The compensator's settings (the actuator stage's: its amplifier range, the default
    /// tolerance and iteration budget).
    pub fn compensator(&self) -> CompensatorParams {
        self.actuator.compensator()
    }

    /// This law as a self-contained C99 header and source whose functions and types are
    /// prefixed `prefix` (a C identifier: letters, digits, `_`, not starting with a digit);
    /// the source includes the header by the file name `header_file` (e.g. `pi-notch-ff.h`).
    pub fn c_source(&self, prefix: &str, header_file: &str) -> Result<CSource> {
        crate::target_c::c_source(self, prefix, header_file)
    }
}

/// The constants the actuator stage `a` derives from its parameters at start-up, per PEA
/// ([`TargetLaw::preload`]).
pub fn preload_of(a: &ActuatorParams) -> [Preload; 2] {
    a.hysteresis.map(|p| {
        let (u, h, x_bias) = preload(&p, a.bias_voltage);
        Preload {
            voltage: u,
            h,
            x_bias,
            slope: mean_slope(&p, a.voltage_range),
        }
    })
}

/// The actuator stage's start-up constants of one PEA ([`TargetLaw::preload`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Preload {
    /// Bias voltage U_b \[V\].
    pub voltage: f64,
    /// Hysteretic state h at the bias \[µm\].
    pub h: f64,
    /// Rest displacement x_bias = d_p U_b − h_b \[µm\].
    pub x_bias: f64,
    /// Mean slope κ of the virgin curve over the amplifier range \[µm/V\].
    pub slope: f64,
}

/// A C header and source ([`TargetLaw::c_source`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CSource {
    /// `<prefix>.h`.
    pub header: String,
    /// `<prefix>.c`.
    pub source: String,
}

/// A [`TargetLaw`] running: `step(input) -> command` ([`TargetInput`]). No allocation per
/// step.
#[derive(Debug, Clone)]
pub struct TargetController {
    law: PidLaw,
    actuator: Actuator,
    sample_time: f64,
    last_x_nom: [f64; 2],
    /// The PPF filters and G_dc⁻¹.
    damping: Option<([Biquad; 2], [[f64; 2]; 2])>,
    /// The last finite reading the damping filters saw.
    last_y: [f64; 2],
    fir: Option<FirBuffer>,
    learned: Option<Vec<[f64; 2]>>,
    /// The feedback's reference of the last step when the FIR has a reading correction.
    expected: Option<[f64; 2]>,
}

impl TargetController {
    /// The reading the last step's feedback expected, when the FIR feed-forward carries a
    /// reading correction ([`FirFeedForward::fit_reading`]); `None` otherwise.
    pub fn expected_reading(&self) -> Option<[f64; 2]> {
        self.expected
    }

    /// Stores `ahead` \[m\] in the FIR's buffer without a sample: before the first step,
    /// the reference at the times [`FirFeedForward::prime_times`] gives, oldest first (no
    /// effect with the static feed-forward).
    pub fn prime(&mut self, ahead: [f64; 2]) {
        if let Some(f) = &mut self.fir {
            f.push(ahead);
        }
    }

    /// One sample (module docs): the voltages, the x_nom \[m\] the actuator model expects
    /// from them and whether anything clipped out. A non-finite reading holds the last
    /// finite one; a non-finite command (only from non-finite references) holds the last
    /// command's x_nom.
    #[inline]
    pub fn step(&mut self, input: &TargetInput) -> Actuated {
        let mut y = input.reading;
        if let Some(table) = &self.learned {
            let c = table[input.index % table.len()];
            y = [y[0] - c[0], y[1] - c[1]];
        }
        let mut u = match &mut self.fir {
            Some(f) => {
                f.push(input.ahead);
                let x_ff = f.output();
                let r = f.reference(input.reference);
                if f.has_reading() {
                    self.expected = Some(r);
                }
                self.law.command_with_feedforward(y, r, x_ff)
            }
            None => self.law.command(y, input.reference),
        };
        if let Some((filters, g)) = &mut self.damping {
            if y[0].is_finite() && y[1].is_finite() {
                self.last_y = y;
            }
            let y = self.last_y;
            let d = [filters[0].step(y[0]), filters[1].step(y[1])];
            for (i, ui) in u.iter_mut().enumerate() {
                *ui += g[i][0] * d[0] + g[i][1] * d[1];
            }
        }
        if !(u[0].is_finite() && u[1].is_finite()) {
            u = self.last_x_nom;
        }
        let act = self.actuator.command(u, self.sample_time);
        self.law.end_sample(act.saturated);
        self.last_x_nom = act.x_nom;
        act
    }
}

/// The compensation mode's name in files and C (`inverse`, `off`, `ideal`).
pub fn compensation_name(c: Compensation) -> &'static str {
    match c {
        Compensation::Inverse => "inverse",
        Compensation::Off => "off",
        Compensation::Ideal => "ideal",
    }
}

/// The compensation mode of a name ([`compensation_name`]).
pub fn compensation_of(name: &str) -> Result<Compensation> {
    [
        Compensation::Inverse,
        Compensation::Off,
        Compensation::Ideal,
    ]
    .into_iter()
    .find(|&c| compensation_name(c) == name)
    .ok_or_else(|| {
        flexstage_numerics::RangeError::new(
            "actuator.compensation",
            name.to_string(),
            "inverse, off or ideal",
        )
        .into()
    })
}

/// One sample of a recorded sequence ([`recorded_sequence`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Recorded {
    /// What the controller took (the reading NaN during the dropout).
    pub input: TargetInput,
    /// What the controller commanded.
    pub command: Actuated,
}

/// A recorded sequence of a [`TargetController`] ([`recorded_sequence`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedSequence {
    /// The reference samples pushed before the first step ([`TargetController::prime`]),
    /// oldest first (none with the static feed-forward).
    pub primed: Vec<[f64; 2]>,
    /// The samples.
    pub samples: Vec<Recorded>,
}

impl RecordedSequence {
    /// The commands of the samples.
    pub fn commands(&self) -> Vec<Actuated> {
        self.samples.iter().map(|r| r.command).collect()
    }

    /// The commands of a fresh controller of `law` given the same inputs.
    pub fn replay(&self, law: &TargetLaw) -> Result<Vec<Actuated>> {
        let mut c = law.controller()?;
        for &q in &self.primed {
            c.prime(q);
        }
        Ok(self.samples.iter().map(|r| c.step(&r.input)).collect())
    }
}

/// The pole of the stage of [`recorded_sequence`]: its static gain G_dc through a first-order
/// lag of about 355 Hz at 10 kHz, so that the PPF filters, which damp modes the stage does not
/// have, keep its loop stable.
const RECORDED_POLE: f64 = 0.8;

/// Samples of [`recorded_sequence`]: 0.3 s at 10 kHz.
pub const RECORDED_SAMPLES: usize = 3000;

/// The reference of [`recorded_sequence`] at sample position `s` (fractional for the FIR's
/// lag) and sample time `t`: the 3:1 Lissajous, the step from sample 2000 to 2400.
fn recorded_reference(s: f64, t: f64) -> [f64; 2] {
    if (2000.0..2400.0).contains(&s) {
        [40e-6, -40e-6]
    } else {
        let w = std::f64::consts::TAU * 20.0 * s * t;
        [8e-6 * (3.0 * w).sin(), 16e-6 * w.sin()]
    }
}

/// A fixed seeded sequence of `law`'s controller in a closed loop that reaches every branch
/// of its step: a 3:1 Lissajous (±8 µm, ±16 µm at 20 Hz) on a stage that is its own static
/// gain G_dc through a first-order lag (pole 0.8: about 355 Hz) with one sample of delay and 2 nm
/// RMS of reading noise (seed `seed`), a sensor
/// dropout of five samples (NaN readings), and a 40 ms step to ±40 µm that the stroke and
/// the amplifier clip. With the FIR feed-forward, the reference p samples ahead and τ
/// samples behind (the lag, between samples) of the same curve, primed as a simulated
/// controller primes it; with a learned table, the index k mod N. The reference for
/// checking an exported controller against this one.
pub fn recorded_sequence(law: &TargetLaw, seed: u64) -> Result<RecordedSequence> {
    let mut c = law.controller()?;
    let t = law.sample_time;
    let (preview, lag) = law
        .feedforward
        .as_ref()
        .map_or((0.0, 0.0), |f| (f.preview() as f64, f.lag()));
    let primed: Vec<[f64; 2]> = law.feedforward.as_ref().map_or(Vec::new(), |f| {
        f.prime_times(1.0)
            .map(|s| recorded_reference(s, t))
            .collect()
    });
    for &q in &primed {
        c.prime(q);
    }
    let period = law.learned.as_ref().map_or(1, Vec::len);
    let gi = law.inverse_gain;
    let det = gi[0][0] * gi[1][1] - gi[0][1] * gi[1][0];
    let g = [
        [gi[1][1] / det, -gi[0][1] / det],
        [-gi[1][0] / det, gi[0][0] / det],
    ];
    let mut noise = flexstage_numerics::noise::GaussianNoise::new(2e-9, seed);
    let mut y = [0.0; 2];
    let mut samples = Vec::with_capacity(RECORDED_SAMPLES);
    for k in 0..RECORDED_SAMPLES {
        let reading = if (1500..1505).contains(&k) {
            [f64::NAN; 2]
        } else {
            [y[0] + noise.sample(), y[1] + noise.sample()]
        };
        let input = TargetInput {
            ahead: recorded_reference(k as f64 + preview, t),
            reference: recorded_reference(k as f64 - lag, t),
            reading,
            index: k % period,
        };
        let command = c.step(&input);
        let x = command.x_nom;
        let a = RECORDED_POLE;
        y = [
            a * y[0] + (1.0 - a) * (g[0][0] * x[0] + g[0][1] * x[1]),
            a * y[1] + (1.0 - a) * (g[1][0] * x[0] + g[1][1] * x[1]),
        ];
        samples.push(Recorded { input, command });
    }
    Ok(RecordedSequence { primed, samples })
}

/// The largest relative difference |a − b| / |b| of the commands (voltages and x_nom) of two
/// sequences of equal length (0 where they are equal, infinite where b = 0 ≠ a or a
/// saturation flag differs).
pub fn largest_relative_difference(a: &[Actuated], b: &[Actuated]) -> f64 {
    let rel = |x: f64, r: f64| {
        let d = (x - r).abs();
        if d == 0.0 {
            0.0
        } else if r == 0.0 {
            f64::INFINITY
        } else {
            d / r.abs()
        }
    };
    a.iter()
        .zip(b)
        .map(|(a, b)| {
            if a.saturated != b.saturated {
                return f64::INFINITY;
            }
            (0..2)
                .map(|i| rel(a.voltage[i], b.voltage[i]).max(rel(a.x_nom[i], b.x_nom[i])))
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::actuator::Compensation;
    use crate::pi_notch::{AxisGains, Notch};
    use flexstage_control_core::Biquad;

    fn law(compensation: Compensation) -> TargetLaw {
        let axis = |f: f64| AxisGains {
            kp: 0.2,
            ki: 600.0,
            kd: 2e-6,
            notches: [
                Some(Notch {
                    frequency: f,
                    zero_damping: 0.05,
                    pole_damping: 0.5,
                }),
                None,
            ],
        };
        let p = PiNotchParams {
            axes: [axis(1500.0), axis(2700.0)],
            static_gain: [[1.1, 0.05], [-0.08, 0.9]],
            sample_time: 1e-4,
        };
        let setup = crate::experiment::Setup::from_scenario(&flexstage_scenario::Scenario::paper());
        // A rate limit the Lissajous of the recorded sequence passes and its step meets.
        let actuator = ActuatorParams {
            max_voltage_step: 8.0,
            ..setup.actuator(compensation)
        };
        TargetLaw::of_linear(&p, actuator).unwrap()
    }

    /// The law of `law(Compensation::Inverse)` with a FIR feed-forward of 3 preview and 5
    /// causal taps (a lead of about one sample, coupled), a lag of 0.3 samples, a reading
    /// correction of the feedback's reference (a few per cent, coupled), PPF filters
    /// on both axes and a learned table of 500 samples.
    fn full_law() -> TargetLaw {
        let taps = (0..8)
            .map(|n| {
                let v = if n == 2 { 0.9 } else { 0.02 * n as f64 - 0.05 };
                [[v, 0.01], [-0.02, 1.1 * v]]
            })
            .collect();
        let reading = (0..8)
            .map(|n| {
                let v = [0.0, 0.0, 0.0, 0.04, -0.03, -0.01, 0.0, 0.0][n];
                [[v, 0.002], [-0.001, 0.5 * v]]
            })
            .collect();
        let ff = FirFeedForward::from_taps(3, taps, 0.3)
            .unwrap()
            .with_reading(reading)
            .unwrap();
        let ppf = |f: f64| {
            crate::damping::DampingFilter::new(
                (f, 0.01),
                nalgebra::Complex::new(-0.02, 0.01),
                0.3,
                500.0,
                1e-4,
            )
            .section()
        };
        let table = (0..500)
            .map(|k| {
                let w = std::f64::consts::TAU * k as f64 / 500.0;
                [2e-9 + 3e-9 * w.sin(), -1e-9 + 2e-9 * (2.0 * w).cos()]
            })
            .collect();
        law(Compensation::Inverse)
            .with_feedforward(ff)
            .with_damping([ppf(1010.0), ppf(3200.0)])
            .with_learned(table)
    }

    /// The recorded sequence reaches the branches of the step (dropout, clipping by the
    /// stroke, the amplifier range and the rate limit, the unclipped loop), and replaying it gives it back bitwise,
    /// with the static feed-forward in every compensation mode and with the FIR, the PPF
    /// filters and the learned table.
    #[test]
    fn recorded_sequence_reaches_every_branch_and_replays_bitwise() {
        let laws = [
            law(Compensation::Inverse),
            law(Compensation::Off),
            law(Compensation::Ideal),
            full_law(),
        ];
        for l in laws {
            let seq = recorded_sequence(&l, 7).unwrap();
            assert_eq!(seq.samples.len(), RECORDED_SAMPLES);
            assert_eq!(
                seq.primed.len(),
                l.feedforward.as_ref().map_or(0, |f| f.taps().len() - 1)
            );
            assert!(seq.samples.iter().any(|r| r.input.reading[0].is_nan()));
            let clipped = seq.samples.iter().filter(|r| r.command.saturated).count();
            let limited = seq
                .samples
                .iter()
                .filter(|r| r.command.rate_limited)
                .count();
            let mode = l.actuator.compensation;
            assert!(clipped > 100 && clipped < 1000, "{mode:?}: {clipped}");
            println!("{mode:?}: {clipped} samples clipped, {limited} by the rate limit");
            assert!(limited > 10 && limited < clipped, "{mode:?}: {limited}");
            assert_eq!(
                largest_relative_difference(&seq.replay(&l).unwrap(), &seq.commands()),
                0.0
            );
        }
    }

    /// Goal: the simulated controller steps the target law: a [`PiNotchController`] of the
    /// full law on a reference gives, sample by sample, the commands of a
    /// [`TargetController`] given the reference p samples ahead, τ samples behind, and
    /// k mod N, primed with the reference before the start (the C's interface), bitwise.
    #[test]
    fn the_simulated_controller_is_the_target_law_bitwise() {
        use crate::pi_notch::PiNotchController;
        use flexstage_sim::experiment::StageControl;
        use flexstage_sim::trajectory::{Reference, Shape};
        let l = full_law();
        let r = Reference::new(Shape::Lissajous {
            ratio: 3.0,
            amplitude: [5e-6, 9e-6],
            frequency: 20.0,
        });
        let mut sim = PiNotchController::of_law(&l, r).unwrap();
        let mut target = l.controller().unwrap();
        let ff = l.feedforward.as_ref().unwrap();
        let t = l.sample_time;
        for time in ff.prime_times(t) {
            target.prime(r.sample(time).q);
        }
        let mut y = [0.0; 2];
        for k in 0..2000u64 {
            let (a, f) = crate::feedforward::sample_times(k, ff.preview(), ff.lag(), t);
            let want = target.step(&TargetInput {
                ahead: r.sample(a).q,
                reference: r.sample(f).q,
                reading: y,
                index: (k % 500) as usize,
            });
            let got = sim.step(y);
            assert_eq!(got.x_nom.map(f64::to_bits), want.x_nom.map(f64::to_bits));
            assert_eq!(
                got.voltage.map(f64::to_bits),
                want.voltage.map(f64::to_bits)
            );
            y = [0.9 * got.x_nom[0], 1.1 * got.x_nom[1]];
        }
    }

    /// The check can fail: a coefficient changed by one part in 10⁹ (a gain, a notch
    /// coefficient, the inverse static gain, a Bouc–Wen parameter of the compensator, a FIR
    /// tap, a reading correction tap, a PPF filter coefficient, the rate limit, the learned table) moves some command of the recorded
    /// sequence by more than the 1e-12 the C check accepts.
    #[test]
    fn a_mutated_coefficient_fails_the_check() {
        let l = full_law();
        let seq = recorded_sequence(&l, 7).unwrap();
        let commands = seq.commands();
        let scale = 1.0 + 1e-9;
        let mut mutants = Vec::new();
        let mut m = l.clone();
        m.gains[0].kp *= scale;
        mutants.push(("kp", m));
        let mut m = l.clone();
        m.gains[1].ki *= scale;
        mutants.push(("ki", m));
        let mut m = l.clone();
        let (b, a) = (m.sections[1][0].numerator(), m.sections[1][0].denominator());
        m.sections[1][0] = Biquad::new([b[0], b[1] * scale, b[2]], a);
        mutants.push(("notch b1", m));
        let mut m = l.clone();
        m.inverse_gain[0][1] *= scale;
        mutants.push(("G_dc^-1", m));
        let mut m = l.clone();
        m.actuator.hysteresis[1].a_bw *= scale;
        mutants.push(("A_bw", m));
        let ff = l.feedforward.clone().unwrap();
        let mut taps = ff.taps().to_vec();
        taps[4][1][0] *= scale;
        let m = l.clone().with_feedforward(
            FirFeedForward::from_taps(ff.preview(), taps, ff.lag())
                .and_then(|f| f.with_reading(ff.reading().unwrap().to_vec()))
                .unwrap(),
        );
        mutants.push(("FIR tap", m));
        let mut c = ff.reading().unwrap().to_vec();
        c[4][0][0] *= scale;
        let m = l
            .clone()
            .with_feedforward(ff.clone().with_reading(c).unwrap());
        mutants.push(("reading tap", m));
        let mut m = l.clone();
        let mut d = m.damping.unwrap();
        let (b, a) = (d[0].numerator(), d[0].denominator());
        d[0] = Biquad::new(b, [a[0] * scale, a[1]]);
        m.damping = Some(d);
        mutants.push(("PPF a1", m));
        let mut m = l.clone();
        m.actuator.max_voltage_step *= scale;
        mutants.push(("rate limit", m));
        let mut m = l.clone();
        for c in m.learned.as_mut().unwrap() {
            c[1] *= scale;
        }
        mutants.push(("learned table", m));
        for (what, m) in mutants {
            let d = largest_relative_difference(&seq.replay(&m).unwrap(), &commands);
            assert!(d > 1e-12, "{what}: {d}");
        }
    }

    /// Reference: C99 §6.4.4.2 (a decimal floating constant is the nearest representable
    /// value) and Rust's shortest round-trip formatting: every literal written into the C
    /// source reads back to the same bits, including subnormals and −0.
    #[test]
    fn c_literals_read_back_exactly() {
        for v in [
            1.0 / 3.0,
            0.1 + 0.2,
            -2.5e-300,
            5e-324,
            -0.0,
            1e-4,
            6.2e-2,
            f64::MAX,
        ] {
            let text = crate::target_c::lit(v);
            assert_eq!(
                text.parse::<f64>().unwrap().to_bits(),
                v.to_bits(),
                "{text}"
            );
        }
    }

    /// Only the linear designs have a law; the C source names its functions by the prefix
    /// and refuses a prefix that is no C identifier.
    #[test]
    fn c_source_is_prefixed_and_checks_the_prefix() {
        let src = law(Compensation::Inverse)
            .c_source("pi_notch_ff", "pi-notch-ff.h")
            .unwrap();
        assert!(src.header.contains("pi_notch_ff_command pi_notch_ff_step("));
        assert!(
            src.source
                .contains("static const double GAINS[2][3] = {{2e-1, 6e2, 2e-6}")
        );
        assert!(src.source.contains("#include \"pi-notch-ff.h\""));
        for token in [
            "PREFIX",
            "COEFFICIENTS",
            "HEADER_FILE",
            "SAMPLE_TIME_LITERAL",
        ] {
            assert!(
                !src.source.contains(token) && !src.header.contains(token),
                "{token}"
            );
        }
        let e = law(Compensation::Inverse)
            .c_source("pi-notch", "pi-notch.h")
            .unwrap_err();
        assert!(e.to_string().contains("controller.c_prefix"), "{e}");
        assert_eq!(c_prefix("pi-notch-ff"), "pi_notch_ff");
        assert!(!is_c_identifier("9a") && is_c_identifier("_a9"));
    }

    /// The linear registry designs have a law, the backstepping has none.
    #[test]
    fn linear_designs_have_a_law_and_the_backstepping_none() {
        use crate::registry::{Designs, Stage};
        let setup = crate::experiment::Setup::from_scenario(&flexstage_scenario::Scenario::paper());
        let designs = Designs::for_stage(&Stage::scenario(&setup)).unwrap();
        let actuator = setup.actuator(Compensation::Inverse);
        let of = |c| TargetLaw::of_design(&**designs.get(c).unwrap(), actuator).unwrap();
        assert!(of(&crate::pid::PID_FF_SCENARIO).is_some());
        assert!(of(&crate::controller::ROBUST).is_none());
        assert!(of(&crate::controller::NONROBUST).is_none());
    }
}
