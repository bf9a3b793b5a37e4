//! A linear controller as a real-time target runs it: the PID + notch + feed-forward law
//! (`flexstage_control_core::PidLaw`) followed by the actuator stage of [`crate::actuator`]
//! (stroke clip, inverse hysteresis compensation of Eq. 19–21 of Actuators 2022, 11(7), 179,
//! amplifier range), with the reference supplied from outside at every sample:
//! `step(reference, reading) -> command`.
//!
//! [`TargetLaw`] holds every coefficient of it (per-axis gains, the notches as second-order
//! section coefficients, the inverse static gain G_dc⁻¹, the sample time, the actuator stage
//! with its Bouc–Wen parameters); [`TargetController`] runs it, and the simulated PI + notch
//! and PID controllers ([`crate::pi_notch::PiNotchController`]) step exactly this, so what is
//! exported is what was simulated. [`TargetLaw::c_source`] writes it as a self-contained C99
//! source and header (coefficients compiled in as constants, the same arithmetic in the same
//! order, `<math.h>` only); `docs/controller-export.md` says how to call it.
//!
//! The backstepping controllers (K-filter observer, Kalman estimate, robust law) have no
//! [`TargetLaw`]: [`TargetLaw::of_design`] gives `None` for them.

use flexstage_control_core::{Biquad, PidGains, PidLaw};
use flexstage_piezo::CompensatorParams;
use flexstage_sim::pea::{mean_slope, preload};
use nalgebra::Matrix2;

use crate::actuator::{Actuated, Actuator, ActuatorParams, Compensation};
use crate::error::{ControlError, Result, positive};
use crate::pi_notch::{PiNotchParams, notch_section};
use crate::registry::Design;

pub use crate::target_c::{c_prefix, is_c_identifier};

/// Every coefficient of a linear controller on a target (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TargetLaw {
    /// Per-axis PID gains on e = q_d − y.
    pub gains: [PidGains; 2],
    /// Per axis, the two second-order sections in series on the feedback (the identity
    /// where the axis has no notch).
    pub sections: [[Biquad; 2]; 2],
    /// The inverse static gain G_dc⁻¹ (row-major): x_nom = G_dc⁻¹ (q_d + N(c)).
    pub inverse_gain: [[f64; 2]; 2],
    /// Sample time T \[s\].
    pub sample_time: f64,
    /// The actuator stage: stroke, amplifier range, bias, compensation mode and the
    /// compensator's Bouc–Wen parameters.
    pub actuator: ActuatorParams,
}

impl TargetLaw {
    /// The law of the PI(D) + notch + feed-forward structure `p` with the actuator stage
    /// `actuator`: the notches as their prewarped Tustin sections
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
        })
    }

    /// The law of a registry design with the actuator stage `actuator`; `None` for a
    /// nonlinear design (the backstepping), which has no such law.
    pub fn of_design(design: &dyn Design, actuator: ActuatorParams) -> Result<Option<TargetLaw>> {
        design
            .linear()
            .map(|p| TargetLaw::of_linear(p, actuator))
            .transpose()
    }

    /// The controller at rest (PEA models preloaded to the bias, no history). Checks every
    /// coefficient: gains ≥ 0, finite sections and inverse gain, T > 0, a valid actuator stage.
    pub fn controller(&self) -> Result<TargetController> {
        for (i, axis) in self.sections.iter().enumerate() {
            for s in axis {
                for v in s.numerator().into_iter().chain(s.denominator()) {
                    crate::error::check(
                        &format!("target.sections[{i}]"),
                        v,
                        true,
                        "finite coefficients",
                    )?;
                }
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
        })
    }

    /// The constants the actuator stage derives from its parameters at start-up, per PEA:
    /// the preloaded state (U_b \[V\], h_b \[µm\]), the rest displacement x_bias \[µm\] and the
    /// mean virgin slope κ \[µm/V\] ([`crate::actuator`]).
    pub fn preload(&self) -> [Preload; 2] {
        let a = &self.actuator;
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

/// A [`TargetLaw`] running: `step(reference, reading) -> command`. No allocation per step.
#[derive(Debug, Clone)]
pub struct TargetController {
    law: PidLaw,
    actuator: Actuator,
    sample_time: f64,
    last_x_nom: [f64; 2],
}

impl TargetController {
    /// One sample: the reference q_d \[m\] and the reading y \[m\] in; the voltages, the
    /// x_nom \[m\] the actuator model expects from them and whether anything clipped out.
    /// A non-finite reading holds the last finite one; a non-finite command (only from
    /// non-finite references) holds the last command's x_nom.
    #[inline]
    pub fn step(&mut self, reference: [f64; 2], reading: [f64; 2]) -> Actuated {
        let u = self.law.command(reading, reference);
        self.actuate(u)
    }

    /// One sample with an outside feed-forward `x_ff` \[m\] in place of the static inverse
    /// (`flexstage_control_core::PidLaw::command_with_feedforward`): the feedback on
    /// `reference` − `reading`, then the actuator stage as in [`TargetController::step`].
    #[inline]
    pub fn step_with_feedforward(
        &mut self,
        reference: [f64; 2],
        reading: [f64; 2],
        x_ff: [f64; 2],
    ) -> Actuated {
        let u = self.law.command_with_feedforward(reading, reference, x_ff);
        self.actuate(u)
    }

    #[inline]
    fn actuate(&mut self, mut u: [f64; 2]) -> Actuated {
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
    /// Reference q_d \[m\].
    pub reference: [f64; 2],
    /// Reading y \[m\] (NaN during the dropout).
    pub reading: [f64; 2],
    /// What the controller commanded.
    pub command: Actuated,
}

/// Samples of [`recorded_sequence`]: 0.3 s at 10 kHz.
pub const RECORDED_SAMPLES: usize = 3000;

/// A fixed seeded sequence of `law`'s controller in a closed loop that reaches every branch
/// of its step: a 3:1 Lissajous (±8 µm, ±16 µm at 20 Hz) on a stage that is its own static
/// gain G_dc with one sample of delay and 2 nm RMS of reading noise (seed `seed`), a sensor
/// dropout of five samples (NaN readings), and a 40 ms step to ±40 µm that the stroke and
/// the amplifier clip. The reference for checking an exported controller against this one.
pub fn recorded_sequence(law: &TargetLaw, seed: u64) -> Result<Vec<Recorded>> {
    let mut c = law.controller()?;
    let gi = law.inverse_gain;
    let det = gi[0][0] * gi[1][1] - gi[0][1] * gi[1][0];
    let g = [
        [gi[1][1] / det, -gi[0][1] / det],
        [-gi[1][0] / det, gi[0][0] / det],
    ];
    let mut noise = flexstage_numerics::noise::GaussianNoise::new(2e-9, seed);
    let mut y = [0.0; 2];
    let mut out = Vec::with_capacity(RECORDED_SAMPLES);
    for k in 0..RECORDED_SAMPLES {
        let w = std::f64::consts::TAU * 20.0 * k as f64 * law.sample_time;
        let reference = if (2000..2400).contains(&k) {
            [40e-6, -40e-6]
        } else {
            [8e-6 * (3.0 * w).sin(), 16e-6 * w.sin()]
        };
        let reading = if (1500..1505).contains(&k) {
            [f64::NAN; 2]
        } else {
            [y[0] + noise.sample(), y[1] + noise.sample()]
        };
        let command = c.step(reference, reading);
        let x = command.x_nom;
        y = [
            g[0][0] * x[0] + g[0][1] * x[1],
            g[1][0] * x[0] + g[1][1] * x[1],
        ];
        out.push(Recorded {
            reference,
            reading,
            command,
        });
    }
    Ok(out)
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
        TargetLaw::of_linear(&p, setup.actuator(compensation)).unwrap()
    }

    fn replay(law: &TargetLaw, seq: &[Recorded]) -> Vec<Actuated> {
        let mut c = law.controller().unwrap();
        seq.iter().map(|r| c.step(r.reference, r.reading)).collect()
    }

    /// The recorded sequence reaches the branches of the step (dropout, clipping by the
    /// stroke and the amplifier, the unclipped loop), and replaying it gives it back bitwise.
    #[test]
    fn recorded_sequence_reaches_every_branch_and_replays_bitwise() {
        for mode in [
            Compensation::Inverse,
            Compensation::Off,
            Compensation::Ideal,
        ] {
            let l = law(mode);
            let seq = recorded_sequence(&l, 7).unwrap();
            assert_eq!(seq.len(), RECORDED_SAMPLES);
            assert!(seq.iter().any(|r| r.reading[0].is_nan()));
            let clipped = seq.iter().filter(|r| r.command.saturated).count();
            assert!(clipped > 100 && clipped < 1000, "{mode:?}: {clipped}");
            let commands: Vec<Actuated> = seq.iter().map(|r| r.command).collect();
            assert_eq!(
                largest_relative_difference(&replay(&l, &seq), &commands),
                0.0
            );
        }
    }

    /// The check can fail: a coefficient changed by one part in 10⁹ (a gain, a notch
    /// coefficient, the inverse static gain, a Bouc–Wen parameter of the compensator) moves
    /// some command of the recorded sequence by more than the 1e-12 the C check accepts.
    #[test]
    fn a_mutated_coefficient_fails_the_check() {
        let l = law(Compensation::Inverse);
        let seq = recorded_sequence(&l, 7).unwrap();
        let commands: Vec<Actuated> = seq.iter().map(|r| r.command).collect();
        let scale = 1.0 + 1e-9;
        let mut mutants = Vec::new();
        let mut m = l;
        m.gains[0].kp *= scale;
        mutants.push(("kp", m));
        let mut m = l;
        m.gains[1].ki *= scale;
        mutants.push(("ki", m));
        let mut m = l;
        let (b, a) = (m.sections[1][0].numerator(), m.sections[1][0].denominator());
        m.sections[1][0] = Biquad::new([b[0], b[1] * scale, b[2]], a);
        mutants.push(("notch b1", m));
        let mut m = l;
        m.inverse_gain[0][1] *= scale;
        mutants.push(("G_dc^-1", m));
        let mut m = l;
        m.actuator.hysteresis[1].a_bw *= scale;
        mutants.push(("A_bw", m));
        for (what, m) in mutants {
            let d = largest_relative_difference(&replay(&m, &seq), &commands);
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
