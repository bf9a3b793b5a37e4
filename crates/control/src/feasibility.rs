//! Whether the rig can follow a reference with a controller's feed-forward (the static
//! inverse of the stage through the controller's inverse-hysteresis compensator): below the
//! Nyquist frequency, inside the controller's stroke and the amplifier's range, current and
//! slew rate. The references are `flexstage_sim::trajectory`'s; this check lives with the
//! controllers because the voltages it checks are the ones their feed-forward asks for.

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
                "PEA{} would need a voltage outside the amplifier range [{}, {}] V at \
                 t = {t:.4} s (x_nom = {:.1} µm); the range delivers +{:.1}/−{:.1} µm around \
                 the bias and the reference needs {:.0} % of it: scale the amplitude by at \
                 most {:.2}",
                i + 1,
                flexstage_numerics::compact(lo),
                flexstage_numerics::compact(hi),
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
                 the amplifier delivers {:.3e} V/s (slew {:.2e} V/s, current {:.3e} A): lower \
                 the frequency or the amplitude by a factor {:.3e}",
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
