//! Reference trajectories of the output q (Section 4.2, Figures 9–11): Lissajous curves of any
//! frequency ratio, a circle, steps and ramps, each with a smooth start.
//!
//! Every reference provides q_d and its first three time derivatives, which the backstepping
//! law needs (ṡ contains q̈_d; ȧ contains q⃛_d). The smooth start multiplies the curve by a
//! C³ window w(t) (the septic "smootherstep" 35τ⁴ − 84τ⁵ + 70τ⁶ − 20τ⁷, τ = t/t_s) so that
//! q_d and its first three derivatives are zero at t = 0: no jump at the start.

use flexstage_piezo::{CompensatorParams, InverseCompensator, MICROMETRE};
use flexstage_scenario::Trajectory;

use crate::actuator::{ActuatorParams, deliverable_stroke, preload};
use crate::error::{ControlError, Result, check, non_negative, positive};
use crate::rig::AmplifierParams;

/// q_d and its first three derivatives at one instant (SI).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RefSample {
    /// q_d \[m\].
    pub q: [f64; 2],
    /// q̇_d [m/s].
    pub dq: [f64; 2],
    /// q̈_d [m/s²].
    pub ddq: [f64; 2],
    /// q⃛_d [m/s³].
    pub dddq: [f64; 2],
}

/// The shape of a reference, before the smooth start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// q1 = A1 sin(r·2πf t), q2 = A2 sin(2πf t): Lissajous curve with frequency ratio r.
    Lissajous {
        /// Frequency ratio r of q1 to q2 (3 and 2 in the paper).
        ratio: f64,
        /// Amplitudes (A1, A2) \[m\].
        amplitude: [f64; 2],
        /// Base frequency f \[Hz\].
        frequency: f64,
    },
    /// q = R (sin 2πf t, cos 2πf t): a circle of radius R about the rest position.
    Circle {
        /// Radius R \[m\].
        radius: f64,
        /// Frequency f \[Hz\].
        frequency: f64,
    },
    /// A constant target (a step once the window is applied; the window's length is the
    /// rise time).
    Step {
        /// Target q \[m\].
        target: [f64; 2],
    },
    /// q = rate·t (a ramp).
    Ramp {
        /// Rate [m/s].
        rate: [f64; 2],
    },
}

/// A reference: a [`Shape`] with a smooth start of `smooth_start` seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reference {
    /// The curve.
    pub shape: Shape,
    /// Length t_s of the smooth start \[s\], ≥ 0 (0: none).
    pub smooth_start: f64,
}

impl Reference {
    /// A reference with the default smooth start: a quarter of the period (of the slowest
    /// component) for periodic curves, 1 ms for steps and ramps.
    pub fn new(shape: Shape) -> Reference {
        let smooth_start = match shape {
            Shape::Lissajous { frequency, .. } | Shape::Circle { frequency, .. } => {
                0.25 / frequency
            }
            Shape::Step { .. } | Shape::Ramp { .. } => 1e-3,
        };
        Reference {
            shape,
            smooth_start,
        }
    }

    /// The reference of a scenario trajectory (with the default smooth start) and its
    /// duration \[s\].
    pub fn from_scenario(t: &Trajectory) -> (Reference, f64) {
        match *t {
            Trajectory::Lissajous {
                ratio,
                amplitude,
                frequency,
                duration,
                ..
            } => (
                Reference::new(Shape::Lissajous {
                    ratio,
                    amplitude,
                    frequency,
                }),
                duration,
            ),
            Trajectory::Circle {
                radius,
                frequency,
                duration,
                ..
            } => (
                Reference::new(Shape::Circle { radius, frequency }),
                duration,
            ),
        }
    }

    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        non_negative("trajectory.smooth_start", self.smooth_start)?;
        match self.shape {
            Shape::Lissajous {
                ratio,
                amplitude,
                frequency,
            } => {
                positive("trajectory.ratio", ratio)?;
                check("trajectory.amplitude[0]", amplitude[0], true, "finite")?;
                check("trajectory.amplitude[1]", amplitude[1], true, "finite")?;
                positive("trajectory.frequency", frequency)
            }
            Shape::Circle { radius, frequency } => {
                positive("trajectory.radius", radius)?;
                positive("trajectory.frequency", frequency)
            }
            Shape::Step { target } => {
                check("trajectory.target[0]", target[0], true, "finite")?;
                check("trajectory.target[1]", target[1], true, "finite")
            }
            Shape::Ramp { rate } => {
                check("trajectory.rate[0]", rate[0], true, "finite")?;
                check("trajectory.rate[1]", rate[1], true, "finite")
            }
        }
    }

    /// q_d and derivatives at time `t` \[s\] (t < 0 gives the rest position). No allocation.
    #[inline]
    pub fn sample(&self, t: f64) -> RefSample {
        if t <= 0.0 {
            return RefSample::default();
        }
        let f = self.shape.sample(t);
        let w = window(t, self.smooth_start);
        let mut r = RefSample::default();
        for i in 0..2 {
            // Leibniz rule up to the third derivative.
            r.q[i] = w[0] * f[0][i];
            r.dq[i] = w[1] * f[0][i] + w[0] * f[1][i];
            r.ddq[i] = w[2] * f[0][i] + 2.0 * w[1] * f[1][i] + w[0] * f[2][i];
            r.dddq[i] =
                w[3] * f[0][i] + 3.0 * w[2] * f[1][i] + 3.0 * w[1] * f[2][i] + w[0] * f[3][i];
        }
        r
    }

    /// The largest |q_d,i| over [0, duration] (sampled every `dt`), per axis: the half range
    /// used to express errors in % of range.
    pub fn half_range(&self, duration: f64, dt: f64) -> [f64; 2] {
        let n = (duration / dt).ceil() as usize;
        let mut m = [0.0f64; 2];
        for k in 0..=n {
            let q = self.sample(k as f64 * dt).q;
            m[0] = m[0].max(q[0].abs());
            m[1] = m[1].max(q[1].abs());
        }
        m
    }
}

impl Shape {
    /// The highest frequency in the curve \[Hz\] (0 for steps and ramps).
    pub fn highest_frequency(&self) -> f64 {
        match *self {
            Shape::Lissajous {
                ratio, frequency, ..
            } => ratio.max(1.0) * frequency,
            Shape::Circle { frequency, .. } => frequency,
            Shape::Step { .. } | Shape::Ramp { .. } => 0.0,
        }
    }

    /// [q, q̇, q̈, q⃛] of the raw curve at t.
    #[inline]
    fn sample(&self, t: f64) -> [[f64; 2]; 4] {
        use std::f64::consts::TAU;
        let sine = |a: f64, w: f64| {
            let (s, c) = (w * t).sin_cos();
            [a * s, a * w * c, -a * w * w * s, -a * w * w * w * c]
        };
        match *self {
            Shape::Lissajous {
                ratio,
                amplitude,
                frequency,
            } => {
                let w = TAU * frequency;
                let a = sine(amplitude[0], ratio * w);
                let b = sine(amplitude[1], w);
                [[a[0], b[0]], [a[1], b[1]], [a[2], b[2]], [a[3], b[3]]]
            }
            Shape::Circle { radius, frequency } => {
                let w = TAU * frequency;
                let a = sine(radius, w);
                // cos(ωt) and its derivatives.
                let (s, c) = (w * t).sin_cos();
                let b = [
                    radius * c,
                    -radius * w * s,
                    -radius * w * w * c,
                    radius * w * w * w * s,
                ];
                [[a[0], b[0]], [a[1], b[1]], [a[2], b[2]], [a[3], b[3]]]
            }
            Shape::Step { target } => [target, [0.0; 2], [0.0; 2], [0.0; 2]],
            Shape::Ramp { rate } => [[rate[0] * t, rate[1] * t], rate, [0.0; 2], [0.0; 2]],
        }
    }
}

/// The smooth-start window w(t) and its first three derivatives.
#[inline]
fn window(t: f64, ts: f64) -> [f64; 4] {
    if ts <= 0.0 || t >= ts {
        return [1.0, 0.0, 0.0, 0.0];
    }
    let x = t / ts;
    let x2 = x * x;
    let x3 = x2 * x;
    let x4 = x2 * x2;
    let w = x4 * (35.0 - 84.0 * x + 70.0 * x2 - 20.0 * x3);
    let d1 = x3 * (140.0 - 420.0 * x + 420.0 * x2 - 140.0 * x3);
    let d2 = x2 * (420.0 - 1680.0 * x + 2100.0 * x2 - 840.0 * x3);
    let d3 = x * (840.0 - 5040.0 * x + 8400.0 * x2 - 4200.0 * x3);
    [w, d1 / ts, d2 / (ts * ts), d3 / (ts * ts * ts)]
}

/// The designed workspace in the output plane: the image of the nominal strokes
/// |x_nom,i| ≤ x_max under the static gain q = G_dc x_nom (a parallelogram).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Workspace {
    /// G_dc⁻¹ (maps q to the x_nom that holds it statically).
    pub inverse_gain: [[f64; 2]; 2],
    /// Nominal stroke half-range x_max \[m\] (Section 4.1: 30 µm).
    pub stroke: f64,
}

impl Workspace {
    /// How much of the stroke the point q uses: max_i |(G_dc⁻¹ q)_i| / x_max (≤ 1 inside).
    #[inline]
    pub fn usage(&self, q: [f64; 2]) -> f64 {
        let g = &self.inverse_gain;
        let x1 = g[0][0] * q[0] + g[0][1] * q[1];
        let x2 = g[1][0] * q[0] + g[1][1] * q[1];
        x1.abs().max(x2.abs()) / self.stroke
    }

    /// The largest usage along a reference over [0, duration], sampled every `dt`.
    pub fn max_usage(&self, r: &Reference, duration: f64, dt: f64) -> f64 {
        let n = (duration / dt).ceil() as usize;
        (0..=n)
            .map(|k| self.usage(r.sample(k as f64 * dt).q))
            .fold(0.0, f64::max)
    }
}

/// What following a reference takes from the rig ([`feasibility`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Feasibility {
    /// Highest frequency of the reference \[Hz\].
    pub highest_frequency: f64,
    /// Nyquist frequency of the controller \[Hz\].
    pub nyquist: f64,
    /// Largest fraction of the stroke the amplifier range delivers
    /// ([`deliverable_stroke`]) that the static inverse of the reference needs (≤ 1 to fit).
    pub stroke_usage: f64,
    /// Largest |x_nom| over the controller's stroke limit.
    pub controller_stroke_usage: f64,
    /// Lowest and highest voltage of each PEA along the compensated reference \[V\].
    pub voltage: [[f64; 2]; 2],
    /// Largest PEA current C·|dU/dt| \[A\] along the compensated reference.
    pub peak_current: f64,
    /// Largest |dU/dt| [V/s].
    pub peak_rate: f64,
}

/// Checks that the rig can follow `reference` over `duration` seconds at sample time `dt`:
/// its highest frequency must be below the Nyquist frequency 1/(2 dt); the nominal strokes of
/// its static inverse `x_nom = G⁻¹ q_d` (`gain` = G, x_nom → q) must stay inside the
/// controller's stroke limit; the inverse-hysteresis compensator (the controller's own
/// Bouc–Wen model, preloaded at the bias) must find voltages inside the amplifier range; and
/// the PEA current `C dU/dt` and the slew rate must stay inside the amplifier's limits. The
/// error says which limit is exceeded, when, and by how much to scale the reference.
pub fn feasibility(
    reference: &Reference,
    duration: f64,
    dt: f64,
    gain: [[f64; 2]; 2],
    actuator: &ActuatorParams,
    amplifier: &AmplifierParams,
) -> Result<Feasibility> {
    reference.validate()?;
    positive("duration", duration)?;
    positive("sample time", dt)?;
    let f_max = reference.shape.highest_frequency();
    let nyquist = 0.5 / dt;
    if f_max >= nyquist {
        return Err(ControlError::Infeasible {
            what: "trajectory frequency".into(),
            detail: format!(
                "its fastest component is {f_max} Hz, at or above the Nyquist frequency \
                 {nyquist} Hz of the {:.0} Hz controller; lower the frequency",
                1.0 / dt
            ),
        });
    }
    let det = gain[0][0] * gain[1][1] - gain[0][1] * gain[1][0];
    if !(det.abs() > 0.0 && det.is_finite()) {
        return Err(ControlError::Singular {
            what: "static gain x_nom → q".into(),
        });
    }
    let inv = [
        [gain[1][1] / det, -gain[0][1] / det],
        [-gain[1][0] / det, gain[0][0] / det],
    ];
    let [lo, hi] = actuator.voltage_range;
    let settings = CompensatorParams {
        u_min: lo,
        u_max: hi,
        ..CompensatorParams::default()
    };
    let mut comp = Vec::with_capacity(2);
    let mut x_bias = [0.0; 2];
    let mut reach = [[0.0; 2]; 2];
    for i in 0..2 {
        let p = actuator.hysteresis[i];
        let mut c = InverseCompensator::new(p, settings).map_err(|e| {
            ControlError::from(flexstage_numerics::RangeError::new(
                "hysteresis",
                e.to_string(),
                "valid Bouc–Wen parameters",
            ))
        })?;
        let (u, h, x) = preload(&p, actuator.bias_voltage);
        c.set_state(u, h);
        comp.push(c);
        x_bias[i] = x;
        reach[i] = deliverable_stroke(&p, actuator.voltage_range, actuator.bias_voltage, 0.25);
    }
    let mut f = Feasibility {
        highest_frequency: f_max,
        nyquist,
        stroke_usage: 0.0,
        controller_stroke_usage: 0.0,
        voltage: [[actuator.bias_voltage; 2]; 2],
        peak_current: 0.0,
        peak_rate: 0.0,
    };
    let mut u_prev = [actuator.bias_voltage; 2];
    let mut first_saturation: Option<(usize, f64, f64)> = None;
    let n = (duration / dt).ceil() as usize;
    for k in 0..=n {
        let t = k as f64 * dt;
        let q = reference.sample(t).q;
        for i in 0..2 {
            let x = inv[i][0] * q[0] + inv[i][1] * q[1];
            let usage = if x >= 0.0 {
                x / reach[i][0]
            } else {
                -x / reach[i][1]
            };
            f.stroke_usage = f.stroke_usage.max(usage);
            f.controller_stroke_usage = f.controller_stroke_usage.max(x.abs() / actuator.stroke);
            let c = comp[i].step(x_bias[i] + x / MICROMETRE, dt);
            if c.saturated && first_saturation.is_none() {
                first_saturation = Some((i, t, x));
            }
            f.voltage[i] = [f.voltage[i][0].min(c.u), f.voltage[i][1].max(c.u)];
            if k > 0 {
                f.peak_rate = f.peak_rate.max((c.u - u_prev[i]).abs() / dt);
            }
            u_prev[i] = c.u;
        }
    }
    f.peak_current = amplifier.capacitance * f.peak_rate;
    if f.controller_stroke_usage > 1.0 {
        return Err(ControlError::Infeasible {
            what: "trajectory amplitude".into(),
            detail: format!(
                "its static inverse asks |x_nom| up to {:.1} µm, beyond controller.stroke = \
                 {:.1} µm; scale the amplitude by at most {:.2}",
                f.controller_stroke_usage * actuator.stroke * 1e6,
                actuator.stroke * 1e6,
                1.0 / f.controller_stroke_usage
            ),
        });
    }
    if let Some((i, t, x)) = first_saturation {
        return Err(ControlError::Infeasible {
            what: "trajectory amplitude".into(),
            detail: format!(
                "PEA{} would need a voltage outside the amplifier range [{lo}, {hi}] V at \
                 t = {t:.4} s (x_nom = {:.1} µm); the range delivers +{:.1}/−{:.1} µm around \
                 the bias and the reference needs {:.0} % of it: scale the amplitude by at \
                 most {:.2}",
                i + 1,
                x * 1e6,
                reach[i][0] * 1e6,
                reach[i][1] * 1e6,
                100.0 * f.stroke_usage,
                (1.0 / f.stroke_usage).min(0.95)
            ),
        });
    }
    let max_rate = amplifier.max_rate();
    if f.peak_rate > max_rate {
        return Err(ControlError::Infeasible {
            what: "trajectory speed".into(),
            detail: format!(
                "it needs |dU/dt| up to {:.3e} V/s (a PEA current of {:.3} A with C = {:.2e} F); \
                 the amplifier delivers {:.3e} V/s (slew {:.2e} V/s, current {:.3} A): lower the \
                 frequency or the amplitude by a factor {:.2}",
                f.peak_rate,
                f.peak_current,
                amplifier.capacitance,
                max_rate,
                amplifier.slew_rate,
                amplifier.current_limit,
                f.peak_rate / max_rate
            ),
        });
    }
    Ok(f)
}
