//! The industry-standard baseline: per-axis PI(D) with an optional notch on the first
//! resonance, static feed-forward through a measured static gain and the inverse-hysteresis
//! compensation of [`crate::actuator`].
//!
//! Per axis i, on the output error e_i = q_d,i − y_i (sampled, T):
//!
//! ```text
//! c_i = N_i(z) · [ kp_i + ki_i T (z + 1) / (2 (z − 1)) + kd_i (1 − z⁻¹)/T ] e_i
//! x_nom = G⁻¹ (q_d + c)                                                        (*)
//! N(s) = (s² + 2 ζ_z ω_n s + ω_n²) / (s² + 2 ζ_p ω_n s + ω_n²)
//! ```
//!
//! The integral is the trapezoidal (Tustin) one; the notch is the Tustin transform of N(s)
//! prewarped at ω_n (Franklin, Powell & Workman, Digital Control of Dynamic Systems, 3rd ed.,
//! Section 6.3.2), so its zero sits exactly at ω_n in the sampled loop. G is the static gain
//! x_nom → q of the stage (from its frequency response: the twin's, or an identified one);
//! mapping the per-axis commands through G⁻¹ decouples the axes at low frequency, as the
//! feed-forward q_d ↦ G⁻¹ q_d does.
//!
//! With `notch: None` and the integral/proportional/derivative gains this is the PID + FF
//! baseline with a measured static gain; [`crate::tuning`] tunes both by the same procedure.
//! The law is `flexstage_control_core::PidLaw` (the one implementation, also the embeddable
//! one), with the notches as its sections; this controller adds the reference, the
//! inverse-hysteresis compensation and the amplifier range.

use std::sync::Arc;

use flexstage_control_core::Biquad;
use nalgebra::Complex;

use crate::actuator::ActuatorParams;
use crate::error::{Result, check};
use crate::feedforward::{FirFeedForward, sample_times};
use crate::registry::{Controller, Design, Stage};
use crate::target::{TargetController, TargetInput, TargetLaw};
use crate::tuning::{Structure, tuned};
use flexstage_sim::experiment::{Command, StageControl};
use flexstage_sim::trajectory::Reference;

/// The default controller: PI + notches + inverse-hysteresis feed-forward, tuned on the
/// stage's sampled response ([`crate::tuning`], structure [`Structure::PiNotch`]); not
/// designed where the stage offers no response (the lumped plant).
pub static PI_NOTCH_FF: Controller = Controller {
    name: "pi-notch-ff",
    label: "PI + notches + inverse-hysteresis feed-forward, tuned on the sampled response",
    default: true,
    design: design_tuned,
};

fn design_tuned(stage: &Stage<'_>) -> Result<Option<Arc<dyn Design>>> {
    tuned(stage, Structure::PiNotch)?
        .map(|t| crate::feedforward::design_with(stage, t.params))
        .transpose()
}

/// The PI(D) + notch + FF structure is a design: [`PiNotchController`] with these gains.
impl Design for PiNotchParams {
    fn build(
        &self,
        actuator: ActuatorParams,
        _delay: usize,
        reference: Reference,
    ) -> Result<Box<dyn StageControl>> {
        Ok(Box::new(PiNotchController::new(
            *self, actuator, reference,
        )?))
    }

    fn linear(&self) -> Option<&PiNotchParams> {
        Some(self)
    }

    fn target(&self, actuator: ActuatorParams) -> Result<Option<TargetLaw>> {
        TargetLaw::of_linear(self, actuator).map(Some)
    }
}

/// A notch filter N(s) = (s² + 2ζ_z ω s + ω²)/(s² + 2ζ_p ω s + ω²) at f = ω/2π.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Notch {
    /// Centre frequency \[Hz\], 0 < f < f_s/2.
    pub frequency: f64,
    /// Damping of the zeros ζ_z, 0 ≤ ζ_z < ζ_p (depth at f: ζ_z/ζ_p).
    pub zero_damping: f64,
    /// Damping of the poles ζ_p, 0 < ζ_p ≤ 2 (width).
    pub pole_damping: f64,
}

/// Gains of one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisGains {
    /// Proportional gain (dimensionless), ≥ 0.
    pub kp: f64,
    /// Integral gain [1/s], ≥ 0.
    pub ki: f64,
    /// Derivative gain \[s\], ≥ 0.
    pub kd: f64,
    /// Up to two notches in series (None: none).
    pub notches: [Option<Notch>; 2],
}

/// Settings of [`PiNotchController`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PiNotchParams {
    /// Gains per axis (q1, q2).
    pub axes: [AxisGains; 2],
    /// Static gain G x_nom → q (row-major), invertible.
    pub static_gain: [[f64; 2]; 2],
    /// Sample time T \[s\], > 0.
    pub sample_time: f64,
}

impl PiNotchParams {
    /// Checks the fields (names as in the scenario's `[controller]`).
    pub fn validate(&self) -> Result<()> {
        check(
            "controller.sample_time",
            self.sample_time,
            self.sample_time > 0.0,
            "> 0 s",
        )?;
        let nyquist = 0.5 / self.sample_time;
        for (i, a) in self.axes.iter().enumerate() {
            check(&format!("pi_notch.axes[{i}].kp"), a.kp, a.kp >= 0.0, "≥ 0")?;
            check(
                &format!("pi_notch.axes[{i}].ki"),
                a.ki,
                a.ki >= 0.0,
                "≥ 0 [1/s]",
            )?;
            check(
                &format!("pi_notch.axes[{i}].kd"),
                a.kd,
                a.kd >= 0.0,
                "≥ 0 [s]",
            )?;
            for n in a.notches.iter().flatten() {
                check(
                    &format!("pi_notch.axes[{i}].notch.frequency"),
                    n.frequency,
                    n.frequency > 0.0 && n.frequency < nyquist,
                    &format!("0 < f < {nyquist} Hz (Nyquist)"),
                )?;
                check(
                    &format!("pi_notch.axes[{i}].notch.pole_damping"),
                    n.pole_damping,
                    n.pole_damping > 0.0 && n.pole_damping <= 2.0,
                    "0 < ζ_p ≤ 2",
                )?;
                check(
                    &format!("pi_notch.axes[{i}].notch.zero_damping"),
                    n.zero_damping,
                    n.zero_damping >= 0.0 && n.zero_damping < n.pole_damping,
                    "0 ≤ ζ_z < ζ_p",
                )?;
            }
        }
        let g = self.static_gain;
        let det = g[0][0] * g[1][1] - g[0][1] * g[1][0];
        check(
            "pi_notch.static_gain",
            det,
            det.is_finite() && det.abs() > 1e-12 * (g[0][0].abs() + g[1][1].abs()).powi(2),
            "an invertible 2 × 2 matrix",
        )
    }

    /// The controller's frequency response per axis, c_i(e^{jωT}) at `f` \[Hz\] (error →
    /// axis command before G⁻¹), for margin computations.
    pub fn axis_response(&self, f: f64) -> [Complex<f64>; 2] {
        let t = self.sample_time;
        let z = Complex::from_polar(1.0, std::f64::consts::TAU * f * t);
        let one = Complex::new(1.0, 0.0);
        self.axes.map(|a| {
            let mut c =
                a.kp + a.ki * t * (z + one) / (2.0 * (z - one)) + a.kd * (one - one / z) / t;
            for n in a.notches.iter().flatten() {
                let q = notch_section(n, t);
                let (b, a) = (q.numerator(), q.denominator());
                c *= (b[0] + b[1] / z + b[2] / (z * z)) / (one + a[0] / z + a[1] / (z * z));
            }
            c
        })
    }
}

/// The Tustin transform of the notch `n` at sample time `t`, prewarped at its centre (module
/// docs), as a second-order section of the law.
pub fn notch_section(n: &Notch, t: f64) -> Biquad {
    let w = std::f64::consts::TAU * n.frequency;
    let c = w / (0.5 * w * t).tan();
    let c2 = c * c;
    let w2 = w * w;
    let num = |zeta: f64| {
        [
            c2 + 2.0 * zeta * w * c + w2,
            2.0 * (w2 - c2),
            c2 - 2.0 * zeta * w * c + w2,
        ]
    };
    let (bn, an) = (num(n.zero_damping), num(n.pole_damping));
    Biquad::new(
        [bn[0] / an[0], bn[1] / an[0], bn[2] / an[0]],
        [an[1] / an[0], an[2] / an[0]],
    )
}

/// The PI(D) + notch + feed-forward controller (module docs), and every controller with a
/// [`TargetLaw`] (its FIR feed-forward, PPF damping, learned table): the
/// [`TargetController`] of the law with the reference sampled at each step (at kT, and with
/// the FIR p samples ahead and τ behind, [`crate::feedforward::sample_times`]). No
/// allocation per step.
#[derive(Debug, Clone)]
pub struct PiNotchController {
    target: TargetController,
    reference: Reference,
    sample_time: f64,
    k: u64,
    /// The FIR's preview p and lag τ \[samples\].
    fir: Option<(usize, f64)>,
    /// The learned table's period N (1 without one).
    period: u64,
}

impl PiNotchController {
    /// Builds the controller of the PI(D) + notch + static feed-forward `params` for a
    /// reference.
    pub fn new(
        params: PiNotchParams,
        actuator: ActuatorParams,
        reference: Reference,
    ) -> Result<Self> {
        PiNotchController::of_law(&TargetLaw::of_linear(&params, actuator)?, reference)
    }

    /// Builds the controller of `law` for a reference: the FIR's buffer primed with the
    /// reference before the start ([`FirFeedForward::prime_times`]).
    pub fn of_law(law: &TargetLaw, reference: Reference) -> Result<Self> {
        reference.validate()?;
        let t = law.sample_time;
        let mut target = law.controller()?;
        if let Some(ff) = &law.feedforward {
            for time in ff.prime_times(t) {
                target.prime(reference.sample(time).q);
            }
        }
        Ok(PiNotchController {
            target,
            reference,
            sample_time: t,
            k: 0,
            fir: law.feedforward.as_ref().map(|f| (f.preview(), f.lag())),
            period: law.learned.as_ref().map_or(1, |l| l.len() as u64),
        })
    }
}

/// A linear design with a feed-forward of its own ([`crate::feedforward`]): the PI(D) +
/// notch gains and the filter in place of the static inverse. Its margins are those of
/// `params`: the feed-forward acts outside the loop.
#[derive(Debug, Clone, PartialEq)]
pub struct WithFeedForward {
    /// The feedback and its static gain.
    pub params: PiNotchParams,
    /// The feed-forward.
    pub feedforward: FirFeedForward,
}

impl Design for WithFeedForward {
    fn build(
        &self,
        actuator: ActuatorParams,
        _delay: usize,
        reference: Reference,
    ) -> Result<Box<dyn StageControl>> {
        let law = TargetLaw::of_linear(&self.params, actuator)?
            .with_feedforward(self.feedforward.clone());
        Ok(Box::new(PiNotchController::of_law(&law, reference)?))
    }

    fn linear(&self) -> Option<&PiNotchParams> {
        Some(&self.params)
    }

    fn feedforward(&self) -> Option<&FirFeedForward> {
        Some(&self.feedforward)
    }

    fn target(&self, actuator: ActuatorParams) -> Result<Option<TargetLaw>> {
        Ok(Some(
            TargetLaw::of_linear(&self.params, actuator)?
                .with_feedforward(self.feedforward.clone()),
        ))
    }
}

impl StageControl for PiNotchController {
    #[inline]
    fn step(&mut self, y_in: [f64; 2]) -> Command {
        let dropout = !(y_in[0].is_finite() && y_in[1].is_finite());
        let t = self.sample_time;
        let r = self.reference.sample(self.k as f64 * t);
        let (ahead, reference) = match self.fir {
            Some((preview, lag)) => {
                let (a, f) = sample_times(self.k, preview, lag, t);
                (self.reference.sample(a).q, self.reference.sample(f).q)
            }
            None => (r.q, r.q),
        };
        let act = self.target.step(&TargetInput {
            ahead,
            reference,
            reading: y_in,
            index: (self.k % self.period) as usize,
        });
        self.k += 1;
        Command {
            voltage: act.voltage,
            x_nom: act.x_nom,
            reference: r.q,
            saturated: act.saturated,
            dropout,
        }
    }

    fn estimate(&self) -> [f64; 10] {
        [0.0; 10]
    }

    fn expected_reading(&self) -> Option<[f64; 2]> {
        self.target.expected_reading()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(notch: Option<Notch>) -> PiNotchParams {
        let a = AxisGains {
            kp: 0.3,
            ki: 800.0,
            kd: 1e-5,
            notches: [notch, None],
        };
        PiNotchParams {
            axes: [a, a],
            static_gain: [[1.0, 0.0], [0.0, 1.0]],
            sample_time: 1e-4,
        }
    }

    /// Reference: the notch's definition. At its centre frequency the prewarped Tustin notch
    /// has gain exactly ζ_z/ζ_p (the continuous N(jω_n)), at DC 1, and at Nyquist 1.
    #[test]
    fn tustin_notch_depth_at_centre_prewarped() {
        let n = Notch {
            frequency: 2700.0,
            zero_damping: 0.02,
            pole_damping: 0.5,
        };
        let q = notch_section(&n, 1e-4);
        let (b, a) = (q.numerator(), q.denominator());
        let h = |f: f64| {
            let z = Complex::from_polar(1.0, std::f64::consts::TAU * f * 1e-4);
            (b[0] + b[1] / z + b[2] / (z * z)) / (1.0 + a[0] / z + a[1] / (z * z))
        };
        assert!((h(2700.0).norm() - 0.04).abs() < 1e-9);
        assert!((h(1e-6).norm() - 1.0).abs() < 1e-9);
        assert!((h(5000.0 - 1e-6).norm() - 1.0).abs() < 1e-6);
    }

    /// Reference: the transfer function of the module docs. The controller's response to a
    /// sampled sine of the error (identity static gain, feed-forward of a zero reference,
    /// ideal actuator) after the transient equals `axis_response` at that frequency.
    #[test]
    fn simulated_sine_matches_axis_response() {
        use crate::actuator::Compensation;
        use flexstage_sim::trajectory::{Reference, Shape};
        let p = params(Some(Notch {
            frequency: 1500.0,
            zero_damping: 0.05,
            pole_damping: 0.4,
        }));
        let act = crate::samples::ideal_actuator();
        assert_eq!(act.compensation, Compensation::Ideal);
        let r = Reference::new(Shape::Step { target: [0.0; 2] });
        let mut c = PiNotchController::new(p, act, r).unwrap();
        let f = 250.0;
        let n = 4000;
        let (mut re, mut im) = (0.0, 0.0);
        for k in 0..n + 400 {
            let ph = std::f64::consts::TAU * f * k as f64 * 1e-4;
            let e = 1e-9 * ph.sin();
            let cmd = c.step([-e, 0.0]);
            if k >= 400 {
                re += cmd.x_nom[0] * ph.sin();
                im += cmd.x_nom[0] * ph.cos();
            }
        }
        // The integral makes the DC part grow: remove it through the sine correlation only.
        let measured = Complex::new(re, im) * (2.0 / n as f64) / 1e-9;
        let expect = p.axis_response(f)[0];
        assert!(
            (measured - expect).norm() < 2e-3 * expect.norm(),
            "{measured} vs {expect}"
        );
    }

    #[test]
    fn bad_notch_names_the_field() {
        let p = params(Some(Notch {
            frequency: 6000.0,
            zero_damping: 0.05,
            pole_damping: 0.4,
        }));
        let e = p.validate().unwrap_err().to_string();
        assert!(e.contains("pi_notch.axes[0].notch.frequency"), "{e}");
    }
}
