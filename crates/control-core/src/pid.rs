//! The PID + static feed-forward law on the two output axes, with up to two second-order
//! sections (notches) on each axis's feedback: the one implementation of the law, used by the
//! simulated controllers of `flexstage-control` (PI + notch + FF, PID + FF) and on a target.
//!
//! Per axis i, on the error e_i = q_d,i − y_i sampled at T:
//!
//! ```text
//! c_i,k   = k_p e_i,k + k_i (I_i,k + T e_i,k / 2) + k_d (e_i,k − e_i,k−1) / T
//! w_i,k   = q_d,i,k + N_i,2(N_i,1(c_i,k))          (N: second-order sections, identity if none)
//! x_nom,k = G_dc⁻¹ w_k
//! I_i,k+1 = I_i,k + T e_i,k   unless the command was clipped (conditional integration)
//! ```
//!
//! The integral is the trapezoidal (Tustin) one and the derivative the backward difference
//! (0 at the first sample). G_dc is the static gain x_nom → q of the stage (Eq. 36 of
//! Actuators 2022, 11(7), 179, at s = 0, or a measured one): G_dc⁻¹ q_d is the static
//! inverse, and G_dc⁻¹ applied to the per-axis feedback decouples the axes at low frequency.
//! A non-finite measurement is replaced by the last finite one (sensor dropout).
//!
//! A sample is [`PidLaw::command`] (the unclipped x_nom) then [`PidLaw::end_sample`] with
//! whether the actuator stage clipped it; [`PidLaw::step`] does both with the stroke as the
//! only clip, for a target whose inverse-hysteresis stage is outside.

use crate::{CoreError, check};

/// Gains of the PID on one axis, on e = q_d − y.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidGains {
    /// Proportional gain k_p, ≥ 0 (dimensionless).
    pub kp: f64,
    /// Integral gain k_i [1/s], ≥ 0.
    pub ki: f64,
    /// Derivative gain k_d \[s\], ≥ 0.
    pub kd: f64,
}

impl PidGains {
    /// Checks the fields against their ranges.
    pub fn validate(&self) -> Result<(), CoreError> {
        check("pid.kp", self.kp, self.kp >= 0.0, "kp ≥ 0")?;
        check("pid.ki", self.ki, self.ki >= 0.0, "ki ≥ 0 [1/s]")?;
        check("pid.kd", self.kd, self.kd >= 0.0, "kd ≥ 0 [s]")
    }
}

/// A second-order section `y = (b₀ + b₁ z⁻¹ + b₂ z⁻²)/(1 + a₁ z⁻¹ + a₂ z⁻²) u` in direct
/// form II transposed (its coefficients are designed outside, e.g. a Tustin notch).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Biquad {
    b: [f64; 3],
    a: [f64; 2],
    s: [f64; 2],
}

impl Biquad {
    /// The identity (b = [1, 0, 0], a = [0, 0]).
    pub const IDENTITY: Biquad = Biquad {
        b: [1.0, 0.0, 0.0],
        a: [0.0, 0.0],
        s: [0.0; 2],
    };

    /// The section with numerator `b` = [b₀, b₁, b₂] and denominator `a` = [a₁, a₂] (a₀ = 1),
    /// at rest.
    pub const fn new(b: [f64; 3], a: [f64; 2]) -> Biquad {
        Biquad { b, a, s: [0.0; 2] }
    }

    /// The numerator [b₀, b₁, b₂].
    pub fn numerator(&self) -> [f64; 3] {
        self.b
    }

    /// The denominator [a₁, a₂] (a₀ = 1).
    pub fn denominator(&self) -> [f64; 2] {
        self.a
    }

    /// One sample.
    #[inline]
    pub fn step(&mut self, u: f64) -> f64 {
        let y = self.b[0] * u + self.s[0];
        self.s[0] = self.b[1] * u - self.a[0] * y + self.s[1];
        self.s[1] = self.b[2] * u - self.a[1] * y;
        y
    }
}

/// The PID + feed-forward law (module docs). 2 × 2, no allocation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidLaw {
    gains: [PidGains; 2],
    sections: [[Biquad; 2]; 2],
    g_inv: [[f64; 2]; 2],
    t: f64,
    stroke: f64,
    integral: [f64; 2],
    /// The error of the current sample (set by `command`).
    e: [f64; 2],
    e_prev: [f64; 2],
    y_prev: [f64; 2],
    have_prev: bool,
    saturated: bool,
}

impl PidLaw {
    /// A law with per-axis `gains`, the inverse static gain `g_inv` = G_dc⁻¹ (finite), sample
    /// time `t` \[s\] (> 0) and the actuator stroke \[m\] (> 0) that [`PidLaw::step`] clips
    /// x_nom to; no sections.
    pub fn new(
        gains: [PidGains; 2],
        g_inv: [[f64; 2]; 2],
        t: f64,
        stroke: f64,
    ) -> Result<Self, CoreError> {
        for g in &gains {
            g.validate()?;
        }
        check("sample_time", t, t > 0.0, "a finite number > 0 [s]")?;
        check("stroke", stroke, stroke > 0.0, "a finite number > 0 [m]")?;
        for row in g_inv {
            for v in row {
                check("g_inv", v, true, "finite entries")?;
            }
        }
        Ok(PidLaw {
            gains,
            sections: [[Biquad::IDENTITY; 2]; 2],
            g_inv,
            t,
            stroke,
            integral: [0.0; 2],
            e: [0.0; 2],
            e_prev: [0.0; 2],
            y_prev: [0.0; 2],
            have_prev: false,
            saturated: false,
        })
    }

    /// The law with the second-order sections `sections[axis]` in series on each axis's
    /// feedback (module docs).
    pub fn with_sections(mut self, sections: [[Biquad; 2]; 2]) -> Self {
        self.sections = sections;
        self
    }

    /// True when the last sample's command was clipped.
    pub fn saturated(&self) -> bool {
        self.saturated
    }

    /// The command of this sample before any clipping, x_nom = G_dc⁻¹ (q_d + N(c)) \[m\], from
    /// the measurement y \[m\] and the reference q_d \[m\] (module docs); advances the
    /// sections. Call [`PidLaw::end_sample`] before the next one.
    #[inline]
    pub fn command(&mut self, y_in: [f64; 2], r: [f64; 2]) -> [f64; 2] {
        let c = self.feedback(y_in, r);
        let w = [r[0] + c[0], r[1] + c[1]];
        let g = &self.g_inv;
        [
            g[0][0] * w[0] + g[0][1] * w[1],
            g[1][0] * w[0] + g[1][1] * w[1],
        ]
    }

    /// The command of this sample with an outside feed-forward `x_ff` \[m\] in place of the
    /// static inverse: x_nom = G_dc⁻¹ N(c) + x_ff, the feedback on the error r − y (r: the
    /// reference the reading should show). Call [`PidLaw::end_sample`] before the next one.
    #[inline]
    pub fn command_with_feedforward(
        &mut self,
        y_in: [f64; 2],
        r: [f64; 2],
        x_ff: [f64; 2],
    ) -> [f64; 2] {
        let c = self.feedback(y_in, r);
        let g = &self.g_inv;
        [
            g[0][0] * c[0] + g[0][1] * c[1] + x_ff[0],
            g[1][0] * c[0] + g[1][1] * c[1] + x_ff[1],
        ]
    }

    /// The feedback N(c) per axis on the error r − y; advances the sections.
    #[inline]
    fn feedback(&mut self, y_in: [f64; 2], r: [f64; 2]) -> [f64; 2] {
        let finite = y_in[0].is_finite() && y_in[1].is_finite();
        let y = if finite { y_in } else { self.y_prev };
        let mut out = [0.0; 2];
        for i in 0..2 {
            let g = &self.gains[i];
            let e = r[i] - y[i];
            let de = if self.have_prev {
                (e - self.e_prev[i]) / self.t
            } else {
                0.0
            };
            let c = g.kp * e + g.ki * (self.integral[i] + 0.5 * self.t * e) + g.kd * de;
            let c = self.sections[i][0].step(c);
            out[i] = self.sections[i][1].step(c);
            self.e[i] = e;
        }
        self.y_prev = y;
        out
    }

    /// Ends the sample whose command was `saturated` (clipped by the stroke or the amplifier):
    /// the integral advances only when it was not.
    #[inline]
    pub fn end_sample(&mut self, saturated: bool) {
        if !saturated {
            for i in 0..2 {
                self.integral[i] += self.t * self.e[i];
            }
        }
        self.saturated = saturated;
        self.e_prev = self.e;
        self.have_prev = true;
    }

    /// One sample on a target: [`PidLaw::command`] clipped to ±stroke, then
    /// [`PidLaw::end_sample`] with that clip.
    #[inline]
    pub fn step(&mut self, y_in: [f64; 2], r: [f64; 2]) -> [f64; 2] {
        let want = self.command(y_in, r);
        let mut u = [0.0; 2];
        let mut saturated = false;
        for i in 0..2 {
            u[i] = want[i].clamp(-self.stroke, self.stroke);
            saturated |= u[i] != want[i];
        }
        self.end_sample(saturated);
        u
    }
}
