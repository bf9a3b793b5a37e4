//! Reference trajectories of the output q (Section 4.2, Figures 9–11): Lissajous curves of any
//! frequency ratio, a circle, steps and ramps, each with a smooth start.
//!
//! Every reference provides q_d and its first three time derivatives, which the backstepping
//! law needs (ṡ contains q̈_d; ȧ contains q⃛_d). The smooth start multiplies the curve by a
//! C³ window w(t) (the septic "smootherstep" 35τ⁴ − 84τ⁵ + 70τ⁶ − 20τ⁷, τ = t/t_s) so that
//! q_d and its first three derivatives are zero at t = 0: no jump at the start.

use flexstage_scenario::Trajectory;

use crate::error::{Result, check, non_negative, positive};

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
