//! PID + static feed-forward on the two output axes, as `flexstage-control`'s
//! `PidController` with `Compensation::Ideal` (the command is x_nom):
//!
//! ```text
//! e_k  = q_d,k − y_k
//! w_k  = q_d,k + k_p e_k + k_i (I_k + T e_k / 2) + k_d (e_k − e_{k−1}) / T
//! x_nom,k = clamp(G_dc⁻¹ w_k, ±stroke)
//! I_{k+1} = I_k + T e_k  unless the stroke clipped the command (conditional integration)
//! ```
//!
//! G_dc is the static gain x_nom → q of the stage model (Eq. 36 of Actuators 2022, 11(7),
//! 179, at s = 0); the feed-forward G_dc⁻¹ q_d is the static inverse. A non-finite measurement
//! is replaced by the last finite one (sensor dropout).

use crate::{CoreError, check};

/// Gains of the PID, per axis, on e = q_d − y.
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

/// The PID + feed-forward law (module docs). 2 × 2, no allocation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidLaw {
    gains: PidGains,
    g_inv: [[f64; 2]; 2],
    t: f64,
    stroke: f64,
    integral: [f64; 2],
    e_prev: [f64; 2],
    y_prev: [f64; 2],
    have_prev: bool,
    saturated: bool,
}

impl PidLaw {
    /// A law with `gains`, the inverse static gain `g_inv` = G_dc⁻¹ (finite), sample time
    /// `t` \[s\] (> 0) and the actuator stroke \[m\] (> 0) that clips x_nom.
    pub fn new(
        gains: PidGains,
        g_inv: [[f64; 2]; 2],
        t: f64,
        stroke: f64,
    ) -> Result<Self, CoreError> {
        gains.validate()?;
        check("sample_time", t, t > 0.0, "a finite number > 0 [s]")?;
        check("stroke", stroke, stroke > 0.0, "a finite number > 0 [m]")?;
        for row in g_inv {
            for v in row {
                check("g_inv", v, true, "finite entries")?;
            }
        }
        Ok(PidLaw {
            gains,
            g_inv,
            t,
            stroke,
            integral: [0.0; 2],
            e_prev: [0.0; 2],
            y_prev: [0.0; 2],
            have_prev: false,
            saturated: false,
        })
    }

    /// True when the stroke clipped the last command.
    pub fn saturated(&self) -> bool {
        self.saturated
    }

    /// One sample: measurement y \[m\], reference q_d \[m\] → x_nom \[m\] (module docs).
    #[inline]
    pub fn step(&mut self, y_in: [f64; 2], r: [f64; 2]) -> [f64; 2] {
        let finite = y_in[0].is_finite() && y_in[1].is_finite();
        let y = if finite { y_in } else { self.y_prev };
        let g = self.gains;
        let mut e = [0.0; 2];
        let mut w = [0.0; 2];
        for i in 0..2 {
            e[i] = r[i] - y[i];
            let de = if self.have_prev {
                (e[i] - self.e_prev[i]) / self.t
            } else {
                0.0
            };
            w[i] = r[i] + g.kp * e[i] + g.ki * (self.integral[i] + 0.5 * self.t * e[i]) + g.kd * de;
        }
        let mut u = [0.0; 2];
        let mut saturated = false;
        for i in 0..2 {
            let want = self.g_inv[i][0] * w[0] + self.g_inv[i][1] * w[1];
            u[i] = want.clamp(-self.stroke, self.stroke);
            saturated |= u[i] != want;
        }
        if !saturated {
            for i in 0..2 {
                self.integral[i] += self.t * e[i];
            }
        }
        self.saturated = saturated;
        self.e_prev = e;
        self.y_prev = y;
        self.have_prev = true;
        u
    }
}
