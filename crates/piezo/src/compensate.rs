//! Inverse multiplicative hysteresis compensation, Eq. (19)–(21) and Figure 5.
//!
//! Eq. (21), U = (x_nom_d + H(U))/d_p, is implicit: the hysteretic state H(U) at the current
//! sample depends on the voltage being chosen. Figure 5 draws it as a feedback loop through
//! the model. Using the *previous* sample's h (an explicit, one-sample-delayed version) leaves
//! an error of order (dh/dU)·ΔU per sample. Here, as DECISIONS.md asks, the equation is solved
//! at each sample: with the state (U_{k−1}, h_{k−1}) of the previous sample, find U_k with
//!
//! ```text
//! g(U_k) = d_p U_k − h(U_k) − x_nom_d,k = 0,    h(U_k) = advance(U_{k−1}, h_{k−1} → U_k, Δt)
//! ```
//!
//! where `advance` is the model's exact step ([`crate::advance`]). g is increasing (d_p
//! exceeds the slope of h for physical parameters), so a safeguarded secant iteration started
//! from the explicit guess (x_nom_d + h_{k−1})/d_p converges in two or three evaluations. The
//! result is clamped to the amplifier range [U_min, U_max]; the model state always follows
//! the voltage actually applied.

use serde::{Deserialize, Serialize};

use crate::error::{Result, check};
use crate::hysteresis::{LoopMetrics, Waveform, loop_metrics};
use crate::model::{BoucWen, BoucWenParams, advance};

/// Settings of the compensator.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CompensatorParams {
    /// Lowest amplifier voltage \[V\]. Default 0 (DECISIONS.md).
    pub u_min: f64,
    /// Highest amplifier voltage \[V\], > u_min. Default 1000 (DECISIONS.md).
    pub u_max: f64,
    /// Accepted |d_p U − h − x_nom_d| \[µm\], > 0. Default 1e-9 (1 fm).
    pub tolerance: f64,
    /// Most evaluations of the model step per sample, ≥ 2. Default 20.
    pub max_iterations: u32,
}

impl Default for CompensatorParams {
    fn default() -> Self {
        CompensatorParams {
            u_min: 0.0,
            u_max: 1000.0,
            tolerance: 1e-9,
            max_iterations: 20,
        }
    }
}

impl CompensatorParams {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        check("compensator.u_min", self.u_min, true, "a finite number [V]")?;
        check(
            "compensator.u_max",
            self.u_max,
            self.u_max > self.u_min,
            "a finite number > u_min [V]",
        )?;
        check(
            "compensator.tolerance",
            self.tolerance,
            self.tolerance > 0.0,
            "a finite number > 0 [µm]",
        )?;
        check(
            "compensator.max_iterations",
            self.max_iterations as f64,
            self.max_iterations >= 2,
            "an integer ≥ 2",
        )
    }
}

/// Output of one compensation step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Compensated {
    /// Voltage to apply \[V\], within [u_min, u_max].
    pub u: f64,
    /// The model's hysteretic state after applying it \[µm\].
    pub h: f64,
    /// True when the desired displacement needed a voltage outside the amplifier range.
    pub saturated: bool,
}

/// The inverse multiplicative compensator of Eq. (21), with its internal Bouc–Wen model.
#[derive(Debug, Clone)]
pub struct InverseCompensator {
    model: BoucWen,
    settings: CompensatorParams,
}

impl InverseCompensator {
    /// A compensator whose model starts virgin at U = clamp(0, u_min, u_max), h = 0.
    pub fn new(params: BoucWenParams, settings: CompensatorParams) -> Result<Self> {
        params.validate()?;
        settings.validate()?;
        let u0 = 0.0f64.clamp(settings.u_min, settings.u_max);
        Ok(InverseCompensator {
            model: BoucWen::with_state(params, u0, 0.0),
            settings,
        })
    }

    /// The internal model (its state is that of the last applied voltage).
    pub fn model(&self) -> &BoucWen {
        &self.model
    }

    /// Resets the model state (U \[V\], h \[µm\]), e.g. to match the actuator at start-up.
    pub fn set_state(&mut self, u: f64, h: f64) {
        self.model.set_state(u, h);
    }

    /// One sample of Eq. (21): the voltage that makes the model's x_nom equal `x_desired`
    /// \[µm\] when the drive ramps to it over `dt` \[s\]. No allocation.
    #[inline]
    pub fn step(&mut self, x_desired: f64, dt: f64) -> Compensated {
        let (lo, hi) = (self.settings.u_min, self.settings.u_max);
        self.step_within(x_desired, dt, lo, hi)
    }

    /// [`InverseCompensator::step`] with the voltage confined to `[u_min, u_max]` this sample
    /// (a window inside the amplifier range, e.g. a rate limit around the last voltage;
    /// `u_min ≤ u_max`): the voltage in the window whose model output is closest to
    /// `x_desired` (the model's output rises with the voltage), `saturated` when the window
    /// clipped it. With the amplifier range as the window it is [`InverseCompensator::step`].
    #[inline]
    pub fn step_within(&mut self, x_desired: f64, dt: f64, u_min: f64, u_max: f64) -> Compensated {
        let p = *self.model.params();
        let (u0, h0) = (self.model.u(), self.model.h());
        let CompensatorParams {
            tolerance,
            max_iterations,
            ..
        } = self.settings;
        let g = |u: f64| {
            let h = advance(&p, u0, h0, u, dt);
            (p.d_p * u - h - x_desired, h)
        };
        // Explicit guess: Eq. (21) with the previous sample's state.
        let mut u = ((x_desired + h0) / p.d_p).clamp(u_min, u_max);
        let (mut gu, mut hu) = g(u);
        // Slope of g from Eq. (18) at the previous state, for the first Newton step.
        let s = if gu < 0.0 { 1.0 } else { -1.0 };
        let slope = (p.d_p - (p.a_bw - s * p.b_bw * h0 - p.gamma_bw * h0.abs())).max(0.05 * p.d_p);
        // Bracket: lo has g < 0, hi has g > 0 (NAN until found).
        let (mut lo, mut glo, mut hlo) = (f64::NAN, f64::NAN, f64::NAN);
        let (mut hi, mut ghi, mut hhi) = (f64::NAN, f64::NAN, f64::NAN);
        let mut prev: Option<(f64, f64)> = None;
        let mut saturated = false;
        let mut evaluations = 1;
        while gu.abs() > tolerance && evaluations < max_iterations {
            if gu < 0.0 {
                (lo, glo, hlo) = (u, gu, hu);
                if u >= u_max {
                    saturated = true;
                    break;
                }
            } else {
                (hi, ghi, hhi) = (u, gu, hu);
                if u <= u_min {
                    saturated = true;
                    break;
                }
            }
            let mut next = match prev {
                Some((up, gp)) if gp != gu => u - gu * (u - up) / (gu - gp),
                _ => u - gu / slope,
            };
            next = next.clamp(u_min, u_max);
            if lo.is_finite() && hi.is_finite() {
                if hi - lo <= 1e-13 * (1.0 + hi.abs()) {
                    // The root sits in the tiny jump of g at U = U_{k−1} caused by the δ
                    // term (sgn(0) = 0): keep the closer end.
                    (u, _, hu) = if -glo <= ghi {
                        (lo, glo, hlo)
                    } else {
                        (hi, ghi, hhi)
                    };
                    break;
                }
                if !(next > lo && next < hi) {
                    next = 0.5 * (lo + hi);
                }
            }
            prev = Some((u, gu));
            u = next;
            (gu, hu) = g(u);
            evaluations += 1;
        }
        self.model.set_state(u, hu);
        Compensated {
            u,
            h: hu,
            saturated,
        }
    }

    /// Compensates a whole desired trajectory `x_desired` \[µm\] sampled every `dt` \[s\];
    /// returns the voltages \[V\].
    pub fn run(&mut self, x_desired: &[f64], dt: f64) -> Vec<f64> {
        x_desired.iter().map(|&x| self.step(x, dt).u).collect()
    }
}

/// A compensated actuator driven around a periodic desired displacement.
#[derive(Debug, Clone, PartialEq)]
pub struct CompensatedLoop {
    /// Desired displacement over the last period \[µm\].
    pub x_desired: Vec<f64>,
    /// Voltage applied \[V\].
    pub u: Vec<f64>,
    /// Displacement of the actuator \[µm\].
    pub x: Vec<f64>,
    /// Loop metrics of x against x_desired (the residual nonlinearity).
    pub metrics: LoopMetrics,
    /// Largest |x − x_desired| \[µm\].
    pub max_error: f64,
    /// Samples at which the amplifier saturated.
    pub saturated: usize,
}

/// Residual nonlinearity of the compensated actuator: the compensator built on `model` drives
/// an actuator `plant` (the same parameters for "compensation on the model itself", different
/// ones to study model error) along `waveform` \[µm\] for `periods` periods at sample time `dt`
/// \[s\]. The metrics are of the last period, plant output against desired displacement.
pub fn compensated_loop(
    plant: &BoucWenParams,
    model: &BoucWenParams,
    settings: CompensatorParams,
    waveform: &Waveform,
    periods: u32,
    dt: f64,
) -> Result<CompensatedLoop> {
    plant.validate()?;
    waveform.validate()?;
    check("dt", dt, dt > 0.0, "a finite number > 0 [s]")?;
    check("periods", periods as f64, periods >= 1, "an integer ≥ 1")?;
    let mut comp = InverseCompensator::new(*model, settings)?;
    let u0 = comp.model().u();
    let mut actuator = BoucWen::with_state(*plant, u0, 0.0);
    let n = ((1.0 / waveform.frequency / dt).round() as usize).max(3);
    let dt = 1.0 / waveform.frequency / n as f64;
    let mut out = CompensatedLoop {
        x_desired: Vec::with_capacity(n + 1),
        u: Vec::with_capacity(n + 1),
        x: Vec::with_capacity(n + 1),
        metrics: LoopMetrics {
            range: 0.0,
            width: 0.0,
            width_pct: 0.0,
            max_deviation: 0.0,
            max_deviation_pct: 0.0,
        },
        max_error: 0.0,
        saturated: 0,
    };
    for p in 0..periods {
        let last = p + 1 == periods;
        for k in 0..=n {
            if k == 0 && p > 0 {
                continue;
            }
            let t = (p as usize * n + k) as f64 * dt;
            let xd = waveform.value(t);
            let c = comp.step(xd, dt);
            let x = actuator.step(c.u, dt);
            if last {
                if k == 0 || out.x.is_empty() {
                    out.x_desired.clear();
                    out.u.clear();
                    out.x.clear();
                }
                out.x_desired.push(xd);
                out.u.push(c.u);
                out.x.push(x);
                out.saturated += c.saturated as usize;
                out.max_error = out.max_error.max((x - xd).abs());
            }
        }
    }
    out.metrics = loop_metrics(&out.x_desired, &out.x)?;
    Ok(out)
}
