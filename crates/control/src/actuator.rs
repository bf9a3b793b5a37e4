//! The piezo actuators as the controller sees them: preload bias, inverse hysteresis
//! compensation (Eq. 19–21, Figure 5, inside the loop as in Figure 7) and the amplifier range.
//!
//! The controller computes a desired nominal displacement x_nom,i \[m\] (the input u of
//! Eq. 36, measured from the preload bias). The actuator stage turns it into a voltage:
//!
//! * [`Compensation::Inverse`]: x_pea = x_bias + x_nom is inverted through the Bouc–Wen model
//!   of the PEA (flexstage-piezo's [`InverseCompensator`]), then clamped to the amplifier;
//! * [`Compensation::Off`]: a straight line U = U_b + x_nom/κ through the bias with the mean
//!   slope κ of the virgin curve over the amplifier range (no hysteresis model);
//! * [`Compensation::Ideal`]: the linear model's input directly (x_nom is the actuator's
//!   output; voltage reported through the same straight line). For tests on Eq. (36).
//!
//! **Rate limit** (the amplifier's current and slew, anti-windup): with
//! [`ActuatorParams::max_voltage_step`] = δ > 0 every voltage stays within δ of the last
//! sample's (inside the amplifier range: the compensator solves Eq. 21 inside that window,
//! the straight line is clamped to it), and the command counts as saturated on a sample the
//! window clipped, so the law's integrator holds as it does for a clip. δ comes from the
//! amplifier's datasheet and the PEA ([`max_voltage_step`]): a first-order amplifier of
//! bandwidth f_a driven by a held command that steps by δ every sample T settles into a ramp
//! whose output rate peaks right after each step at κ δ/T, with the overshoot factor
//! `κ = x/(1 − e^{−x})`, `x = 2π f_a T` (the sum of the steps' decaying exponentials
//! `δ/τ Σ_j e^{−jT/τ}`, τ = 1/(2π f_a): no sequence of steps of at most δ rises faster), so
//! `δ = r_max T/κ` keeps the amplifier's rate under r_max = min(slew rate, I_max/C_pea) and
//! its current under I_max. 3 kHz at 10 kHz: x = 1.885, κ = 2.22; 0.1 A into 1.5 µF: δ = 3.0 V.
//!
//! **Preload** (Section 4.1): both the plant and the compensator bring the virgin PEA to the
//! bias voltage U_b along a slow ramp ([`flexstage_sim::pea::preload`]); x_bias = d_p U_b − h_b is the rest
//! displacement, so x_nom = 0 at rest and the nominal range is about ±30 µm.

use flexstage_piezo::{BoucWenParams, CompensatorParams, InverseCompensator, MICROMETRE};
use flexstage_sim::pea::{mean_slope, preload};

use flexstage_numerics::RangeError;

use crate::error::{Result, check, positive};

/// How x_nom becomes a voltage.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compensation {
    /// Inverse multiplicative compensation through the Bouc–Wen model (Eq. 21).
    Inverse,
    /// No hysteresis model: a straight line through the bias.
    Off,
    /// The linear model's input x_nom directly (no voltage stage).
    Ideal,
}

/// Settings of the actuator stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActuatorParams {
    /// Bouc–Wen parameters of PEA1 and PEA2 (µm, V, s; Table A1).
    pub hysteresis: [BoucWenParams; 2],
    /// Amplifier range \[V\] (DECISIONS.md: 0–1000).
    pub voltage_range: [f64; 2],
    /// Preload bias voltage U_b \[V\] (default: the middle of the range).
    pub bias_voltage: f64,
    /// Largest |x_nom| the controller may ask for \[m\] (Section 4.1: the ±30 µm nominal stroke).
    pub stroke: f64,
    /// The compensation mode.
    pub compensation: Compensation,
    /// Largest change of a voltage per sample \[V\] (module docs: the amplifier's current and
    /// slew, [`max_voltage_step`]); 0: no rate limit.
    pub max_voltage_step: f64,
}

/// The overshoot factor κ = x/(1 − e^{−x}), x = 2π f_a T, of a first-order amplifier of
/// bandwidth `bandwidth` \[Hz\] driven by a command held for `sample_time` \[s\]: its output's
/// largest rate over the held command's mean rate δ/T for steps of at most δ (module docs).
/// 1 for x → 0 (a slow amplifier follows the mean rate).
pub fn amplifier_overshoot(bandwidth: f64, sample_time: f64) -> f64 {
    let x = std::f64::consts::TAU * bandwidth * sample_time;
    if x < 1e-12 { 1.0 } else { x / -(-x).exp_m1() }
}

/// The largest voltage change per sample δ = r_max T/κ \[V\] that keeps a first-order
/// amplifier of bandwidth `bandwidth` \[Hz\] within its largest rate `max_rate` \[V/s\]
/// (min(slew rate, I_max/C_pea): the datasheet's slew and current limit and the PEA's
/// capacitance) at sample time `sample_time` \[s\] (module docs). 0 (no limiter) when the
/// amplifier is ideal (bandwidth 0: it jumps, no finite step keeps it in) or has no finite
/// rate limit.
pub fn max_voltage_step(bandwidth: f64, max_rate: f64, sample_time: f64) -> f64 {
    if bandwidth > 0.0 && max_rate.is_finite() && max_rate > 0.0 {
        max_rate * sample_time / amplifier_overshoot(bandwidth, sample_time)
    } else {
        0.0
    }
}

impl ActuatorParams {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        for p in &self.hysteresis {
            p.validate().map_err(|e| {
                RangeError::new("hysteresis", e.to_string(), "valid Bouc–Wen parameters")
            })?;
        }
        let [lo, hi] = self.voltage_range;
        check("hysteresis.voltage_min", lo, lo.is_finite(), "finite [V]")?;
        check("hysteresis.voltage_max", hi, hi > lo, "> voltage_min [V]")?;
        check(
            "bias_voltage",
            self.bias_voltage,
            self.bias_voltage > lo && self.bias_voltage < hi,
            "inside the amplifier range [V]",
        )?;
        positive("stroke", self.stroke)?;
        check(
            "max_voltage_step",
            self.max_voltage_step,
            self.max_voltage_step.is_finite() && self.max_voltage_step >= 0.0,
            "≥ 0 [V] (0: no rate limit)",
        )
    }

    /// The settings of the inverse compensator: the amplifier range, with the default
    /// tolerance and iteration budget.
    pub fn compensator(&self) -> CompensatorParams {
        CompensatorParams {
            u_min: self.voltage_range[0],
            u_max: self.voltage_range[1],
            ..CompensatorParams::default()
        }
    }
}

/// The result of one actuator command.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Actuated {
    /// Voltages sent to the amplifiers \[V\], inside the range.
    pub voltage: [f64; 2],
    /// The x_nom \[m\] the actuator model expects from them (the observer's input).
    pub x_nom: [f64; 2],
    /// True when a voltage or the stroke limit clipped the request (the rate limit
    /// included).
    pub saturated: bool,
    /// True when the rate limit clipped a voltage ([`ActuatorParams::max_voltage_step`]).
    pub rate_limited: bool,
}

/// The actuator stage of the controller. No allocation per step.
#[derive(Debug, Clone)]
pub struct Actuator {
    params: ActuatorParams,
    comp: [InverseCompensator; 2],
    x_bias: [f64; 2],
    slope: [f64; 2],
    /// The last voltages sent \[V\] (the bias at start).
    last_voltage: [f64; 2],
}

impl Actuator {
    /// Builds the stage and preloads its models to the bias.
    pub fn new(params: ActuatorParams) -> Result<Actuator> {
        params.validate()?;
        let settings = params.compensator();
        let make = |p: BoucWenParams| {
            let mut c = InverseCompensator::new(p, settings).map_err(|e| {
                RangeError::new("hysteresis", e.to_string(), "valid compensator settings")
            })?;
            let (u, h, _) = preload(&p, params.bias_voltage);
            c.set_state(u, h);
            Ok::<_, crate::error::ControlError>(c)
        };
        let comp = [make(params.hysteresis[0])?, make(params.hysteresis[1])?];
        let x_bias = [0, 1].map(|i| preload(&params.hysteresis[i], params.bias_voltage).2);
        let slope = [0, 1].map(|i| mean_slope(&params.hysteresis[i], params.voltage_range));
        Ok(Actuator {
            params,
            comp,
            x_bias,
            slope,
            last_voltage: [params.bias_voltage; 2],
        })
    }

    /// The settings.
    pub fn params(&self) -> &ActuatorParams {
        &self.params
    }

    /// Rest displacements x_bias \[µm\] of the preloaded PEAs.
    pub fn x_bias(&self) -> [f64; 2] {
        self.x_bias
    }

    /// Turns the desired x_nom \[m\] into voltages, held for `dt` \[s\]: the stroke clip, then
    /// the compensation mode inside the amplifier range and the rate limit's window around
    /// the last voltage (module docs).
    #[inline]
    pub fn command(&mut self, x_nom: [f64; 2], dt: f64) -> Actuated {
        let [lo, hi] = self.params.voltage_range;
        let ub = self.params.bias_voltage;
        let step = self.params.max_voltage_step;
        let mut out = Actuated::default();
        for i in 0..2 {
            let want = x_nom[i];
            let x = want.clamp(-self.params.stroke, self.params.stroke);
            out.saturated |= x != want;
            let (wlo, whi) = if step > 0.0 {
                let last = self.last_voltage[i];
                (lo.max(last - step), hi.min(last + step))
            } else {
                (lo, hi)
            };
            match self.params.compensation {
                Compensation::Inverse => {
                    let c = self.comp[i].step_within(self.x_bias[i] + x / MICROMETRE, dt, wlo, whi);
                    out.voltage[i] = c.u;
                    out.saturated |= c.saturated;
                    let p = self.comp[i].model().params();
                    out.x_nom[i] = (p.d_p * c.u - c.h - self.x_bias[i]) * MICROMETRE;
                }
                Compensation::Off => {
                    let u = ub + x / MICROMETRE / self.slope[i];
                    let uc = u.clamp(wlo, whi);
                    out.saturated |= uc != u;
                    out.voltage[i] = uc;
                    out.x_nom[i] = (uc - ub) * self.slope[i] * MICROMETRE;
                }
                Compensation::Ideal => {
                    let u = ub + x / MICROMETRE / self.slope[i];
                    let uc = u.clamp(wlo, whi);
                    out.voltage[i] = uc;
                    out.x_nom[i] = x;
                    if uc != u.clamp(lo, hi) {
                        // The window clipped: the ideal actuator moves as far as the voltage.
                        out.x_nom[i] = (uc - ub) * self.slope[i] * MICROMETRE;
                        out.saturated = true;
                    }
                }
            }
            let u = out.voltage[i];
            out.rate_limited |= (u <= wlo && wlo > lo) || (u >= whi && whi < hi);
            self.last_voltage[i] = u;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference: a first-order amplifier (time constant τ = 1/(2π f_a)) driven by a held
    /// command that steps by δ at every sample T: its output rate right after the n-th step
    /// is δ/τ Σ_{j<n} e^{−jT/τ}, whose limit is κ δ/T with κ = x/(1 − e^{−x}), x = T/τ.
    /// Simulated with 10 000 substeps per sample over 50 samples (the largest finite-difference
    /// rate), it equals κ δ/T within the substep's first-order error; a slow amplifier
    /// (x → 0) follows the mean rate (κ → 1); the step δ = r T/κ, 0 for an ideal amplifier.
    #[test]
    fn overshoot_factor_is_the_peak_rate_of_a_first_order_amplifier_under_held_steps() {
        for (fa, t) in [(3000.0, 1e-4), (500.0, 1e-4), (20_000.0, 5e-5)] {
            let tau = 1.0 / (std::f64::consts::TAU * fa);
            let (n, delta) = (10_000, 1.0);
            let h = t / n as f64;
            let (mut u, mut goal, mut peak) = (0.0f64, 0.0, 0.0f64);
            for _ in 0..50 {
                goal += delta;
                for _ in 0..n {
                    let next = goal + (u - goal) * (-h / tau).exp();
                    peak = peak.max((next - u) / h);
                    u = next;
                }
            }
            let kappa = amplifier_overshoot(fa, t);
            let simulated = peak * t / delta;
            assert!(
                (simulated - kappa).abs() < 1e-3 * kappa,
                "{fa} Hz: {simulated} vs {kappa}"
            );
        }
        assert!((amplifier_overshoot(1e-3, 1e-4) - 1.0).abs() < 1e-6);
        assert!((amplifier_overshoot(3000.0, 1e-4) - 2.2226).abs() < 1e-3);
        assert_eq!(max_voltage_step(0.0, 1e5, 1e-4), 0.0);
        assert_eq!(max_voltage_step(3000.0, f64::INFINITY, 1e-4), 0.0);
        let d = max_voltage_step(3000.0, 0.1 / 1.5e-6, 1e-4);
        assert!((d - 2.99938).abs() < 1e-3, "{d}");
    }

    /// The window: a rate-limited stage moves each voltage by at most δ per sample, flags
    /// the clipped samples as saturated and rate-limited, and without a limit (δ = 0) gives
    /// the unlimited stage's commands bitwise, in every compensation mode.
    #[test]
    fn the_rate_limit_moves_each_voltage_by_at_most_its_step() {
        let base = crate::experiment::Setup::from_scenario(&flexstage_scenario::Scenario::paper())
            .actuator(Compensation::Inverse);
        for mode in [
            Compensation::Inverse,
            Compensation::Off,
            Compensation::Ideal,
        ] {
            let mut p = ActuatorParams {
                compensation: mode,
                ..base
            };
            p.max_voltage_step = 2.5;
            let mut limited = Actuator::new(p).unwrap();
            p.max_voltage_step = 0.0;
            let mut free = Actuator::new(p).unwrap();
            let mut plain = Actuator::new(p).unwrap();
            let mut last = [p.bias_voltage; 2];
            let mut clipped = 0;
            for k in 0..400 {
                let x = if k < 200 { [15e-6, -10e-6] } else { [0.0, 0.0] };
                let a = limited.command(x, 1e-4);
                for i in 0..2 {
                    assert!(
                        (a.voltage[i] - last[i]).abs() <= 2.5 + 1e-12,
                        "{mode:?} {k}"
                    );
                }
                assert!(!a.rate_limited || a.saturated);
                clipped += usize::from(a.rate_limited);
                last = a.voltage;
                let (f, g) = (free.command(x, 1e-4), plain.command(x, 1e-4));
                assert!(!f.rate_limited);
                assert_eq!(f, g);
            }
            assert!(clipped > 20 && clipped < 300, "{mode:?}: {clipped}");
        }
    }
}
