//! Whether the rig can follow a reference with a controller's feed-forward (the static
//! inverse of the stage, or any feed-forward command sequence such as the dynamic inverse of
//! [`crate::feedforward`], through the controller's inverse-hysteresis compensator): below the
//! Nyquist frequency, inside the controller's stroke and the amplifier's range, current and
//! slew rate. The rate is the one the amplifier's output takes: the held voltage through its
//! first-order small-signal response (datasheet bandwidth f_a), whose slope at the start of a
//! sample is 2π f_a |U_k − u(t_k)| (up to 2π f_a T ≈ 1.9 times the mean rate |ΔU|/T at
//! 3 kHz and 10 kHz). The references are `flexstage_sim::trajectory`'s; this check lives with
//! the controllers because the voltages it checks are the ones their feed-forward asks for.
//! [`Feasibility::binding`] says which limit binds and by how much to scale the amplitude.

use flexstage_piezo::{CompensatorParams, InverseCompensator, MICROMETRE};
use flexstage_sim::pea::{deliverable_stroke, preload};
use flexstage_sim::rig::AmplifierParams;
use flexstage_sim::trajectory::Reference;

use crate::actuator::ActuatorParams;
use crate::error::{ControlError, Result, positive};

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
    /// Largest |dU/dt| [V/s] of the amplifier's output.
    pub peak_rate: f64,
    /// Where the compensator first needed a voltage outside the amplifier range, if it did.
    pub range_exceeded: Option<RangeExcess>,
    /// The amplifier's slew-rate limit [V/s] (0: none).
    pub slew_rate: f64,
    /// The amplifier's current limit over the PEA capacitance, I_max/C [V/s] (∞: none).
    pub current_rate: f64,
}

/// A limit of the rig that a reference can exceed ([`Feasibility::binding`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Limit {
    /// The controller's stroke |x_nom| ≤ `controller.stroke`.
    ControllerStroke,
    /// The amplifier's voltage range.
    AmplifierRange,
    /// The amplifier's output current, C |dU/dt| ≤ I_max.
    AmplifierCurrent,
    /// The amplifier's slew rate.
    AmplifierSlew,
}

impl Limit {
    /// Its name in files and tables.
    pub fn name(self) -> &'static str {
        match self {
            Limit::ControllerStroke => "controller-stroke",
            Limit::AmplifierRange => "amplifier-range",
            Limit::AmplifierCurrent => "amplifier-current",
            Limit::AmplifierSlew => "amplifier-slew",
        }
    }
}

impl Feasibility {
    /// The limits exceeded, each with the factor (< 1) that scaling the reference's
    /// amplitude by meets it (the stroke and the rate scale with the amplitude; the range
    /// only roughly, through the hysteresis: its factor is at most 0.95).
    pub fn exceeded(&self) -> Vec<(Limit, f64)> {
        let mut out = Vec::new();
        if self.controller_stroke_usage > 1.0 {
            out.push((Limit::ControllerStroke, 1.0 / self.controller_stroke_usage));
        }
        if self.range_exceeded.is_some() {
            out.push((Limit::AmplifierRange, (1.0 / self.stroke_usage).min(0.95)));
        }
        let max_rate = self.max_rate();
        if self.peak_rate > max_rate {
            let limit = if self.current_rate <= self.slew_rate || self.slew_rate <= 0.0 {
                Limit::AmplifierCurrent
            } else {
                Limit::AmplifierSlew
            };
            out.push((limit, max_rate / self.peak_rate));
        }
        out
    }

    /// The limit that asks for the smallest amplitude and its factor; `None` when the
    /// reference fits.
    pub fn binding(&self) -> Option<(Limit, f64)> {
        self.exceeded()
            .into_iter()
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The amplifier's largest |dU/dt|: min(slew rate, I_max/C) [V/s].
    pub fn max_rate(&self) -> f64 {
        if self.slew_rate > 0.0 {
            self.slew_rate.min(self.current_rate)
        } else {
            self.current_rate
        }
    }
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
    let inv = static_inverse(gain)?;
    let f = feasibility_of(reference, duration, dt, actuator, amplifier, |k| {
        let q = reference.sample(k as f64 * dt).q;
        [0, 1].map(|i| inv[i][0] * q[0] + inv[i][1] * q[1])
    })?;
    refuse(&f, actuator, amplifier)?;
    Ok(f)
}

/// The inverse of the static gain `gain` (x_nom → q).
pub fn static_inverse(gain: [[f64; 2]; 2]) -> Result<[[f64; 2]; 2]> {
    let det = gain[0][0] * gain[1][1] - gain[0][1] * gain[1][0];
    if !(det.abs() > 0.0 && det.is_finite()) {
        return Err(ControlError::Singular {
            what: "static gain x_nom → q".into(),
        });
    }
    Ok([
        [gain[1][1] / det, -gain[0][1] / det],
        [-gain[1][0] / det, gain[0][0] / det],
    ])
}

/// What following `reference` over `duration` seconds at sample time `dt` takes from the
/// rig when the controller sends the nominal strokes `command(k)` \[m\] at sample k (its
/// feed-forward: the static inverse, or a dynamic one with preview): the stroke, the voltages
/// of the inverse-hysteresis compensator and the amplifier output's rate (module docs). Only
/// the Nyquist frequency refuses here; [`Feasibility::binding`] says what else is exceeded.
pub fn feasibility_of(
    reference: &Reference,
    duration: f64,
    dt: f64,
    actuator: &ActuatorParams,
    amplifier: &AmplifierParams,
    mut command: impl FnMut(usize) -> [f64; 2],
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
        range_exceeded: None,
        slew_rate: amplifier.slew_rate,
        current_rate: if amplifier.current_limit > 0.0 && amplifier.capacitance > 0.0 {
            amplifier.current_limit / amplifier.capacitance
        } else {
            f64::INFINITY
        },
    };
    // The amplifier's output: first order of bandwidth f_a towards the held voltage (a jump
    // when f_a = 0, whose rate is the mean |ΔU|/T).
    let wa = std::f64::consts::TAU * amplifier.bandwidth;
    let decay = (-wa * dt).exp();
    let mut u_out = [actuator.bias_voltage; 2];
    let n = (duration / dt).ceil() as usize;
    for k in 0..=n {
        let t = k as f64 * dt;
        let x_nom = command(k);
        for i in 0..2 {
            let x = x_nom[i];
            let usage = if x >= 0.0 {
                x / reach[i][0]
            } else {
                -x / reach[i][1]
            };
            f.stroke_usage = f.stroke_usage.max(usage);
            f.controller_stroke_usage = f.controller_stroke_usage.max(x.abs() / actuator.stroke);
            let c = comp[i].step(x_bias[i] + x / MICROMETRE, dt);
            if c.saturated && f.range_exceeded.is_none() {
                f.range_exceeded = Some(RangeExcess {
                    pea: i,
                    t,
                    x_nom: x,
                    reach: reach[i],
                });
            }
            f.voltage[i] = [f.voltage[i][0].min(c.u), f.voltage[i][1].max(c.u)];
            let rate = if wa > 0.0 {
                wa * (c.u - u_out[i]).abs()
            } else {
                (c.u - u_out[i]).abs() / dt
            };
            f.peak_rate = f.peak_rate.max(rate);
            u_out[i] = if wa > 0.0 {
                c.u + (u_out[i] - c.u) * decay
            } else {
                c.u
            };
        }
    }
    f.peak_current = amplifier.capacitance * f.peak_rate;
    Ok(f)
}

/// Where the compensator first needed a voltage outside the amplifier range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RangeExcess {
    /// The PEA (0: PEA1, 1: PEA2).
    pub pea: usize,
    /// The time \[s\].
    pub t: f64,
    /// The nominal stroke asked for \[m\].
    pub x_nom: f64,
    /// The stroke the range delivers around the bias (+, −) \[m\].
    pub reach: [f64; 2],
}

/// The error of the first limit `f` exceeds, in the order stroke, range, rate: which limit,
/// when, and by how much to scale the reference.
fn refuse(f: &Feasibility, actuator: &ActuatorParams, amplifier: &AmplifierParams) -> Result<()> {
    if f.controller_stroke_usage > 1.0 {
        return Err(ControlError::Infeasible {
            what: "trajectory amplitude".into(),
            detail: format!(
                "its feed-forward asks |x_nom| up to {:.1} µm, beyond controller.stroke = \
                 {:.1} µm; scale the amplitude by at most {:.2}",
                f.controller_stroke_usage * actuator.stroke * 1e6,
                actuator.stroke * 1e6,
                1.0 / f.controller_stroke_usage
            ),
        });
    }
    if let Some(r) = f.range_exceeded {
        let [lo, hi] = actuator.voltage_range;
        return Err(ControlError::Infeasible {
            what: "trajectory amplitude".into(),
            detail: format!(
                "PEA{} would need a voltage outside the amplifier range [{}, {}] V at \
                 t = {:.4} s (x_nom = {:.1} µm); the range delivers +{:.1}/−{:.1} µm around \
                 the bias and the reference needs {:.0} % of it: scale the amplitude by at \
                 most {:.2}",
                r.pea + 1,
                flexstage_numerics::compact(lo),
                flexstage_numerics::compact(hi),
                r.t,
                r.x_nom * 1e6,
                r.reach[0] * 1e6,
                r.reach[1] * 1e6,
                100.0 * f.stroke_usage,
                (1.0 / f.stroke_usage).min(0.95)
            ),
        });
    }
    let max_rate = f.max_rate();
    if f.peak_rate > max_rate {
        return Err(ControlError::Infeasible {
            what: "trajectory speed".into(),
            detail: format!(
                "it needs |dU/dt| up to {:.3e} V/s at the amplifier's output (a PEA current \
                 of {:.3} A with C = {:.2e} F); the amplifier delivers {:.3e} V/s (slew \
                 {:.2e} V/s, current {:.3e} A): lower the frequency or the amplitude by a \
                 factor {:.3e}",
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
    Ok(())
}

/// [`feasibility_of`] with the refusal of [`feasibility`]: `Err` naming the first limit
/// exceeded by the commands `command(k)`.
pub fn check_commands(
    reference: &Reference,
    duration: f64,
    dt: f64,
    actuator: &ActuatorParams,
    amplifier: &AmplifierParams,
    command: impl FnMut(usize) -> [f64; 2],
) -> Result<Feasibility> {
    let f = feasibility_of(reference, duration, dt, actuator, amplifier, command)?;
    refuse(&f, actuator, amplifier)?;
    Ok(f)
}
