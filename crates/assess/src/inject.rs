//! Margins of any controller by sine injection, as on a rig: a small sine d is added to
//! the measurement of axis i before the controller (the loop broken at the sensor), the
//! other loop stays closed, and after the transient the return ratio is
//! `L_i(jω) = −A/B`, A the plant's output of axis i, B = A + d the controller's input (both
//! one DFT bin at the injected frequency over whole periods). This needs no linear model of
//! the controller, so it works for the backstepping controllers with their observer and
//! input transformation; for a linear controller it equals the analytic loop-at-a-time
//! ratio (tests).

use flexstage_control::margins::{MarginParams, Margins, margin};
use flexstage_control::registry::Design;
use flexstage_sim::experiment::StageControl;
use flexstage_sim::rig::StagePlant;
use nalgebra::Complex;

use crate::error::Result;

/// A loop margins are measured on by injection: a controller of a design and the plant it
/// runs on, both at rest. [`crate::bench::LinearLoop`] is the twin's linear loop (where
/// margins are scored), [`crate::bench::MeasuredLoop`] the loop model a lab measured (where
/// designs sized by their margins are sized).
pub trait InjectionLoop {
    /// `design` built for a zero reference, its command the x_nom the plant takes.
    fn controller(&self, design: &dyn Design) -> Result<Box<dyn StageControl>>;
    /// The plant with `delay` samples of rig delay.
    fn plant(&self, delay: usize) -> Result<Box<dyn StagePlant>>;
    /// The sample time \[s\].
    fn sample_time(&self) -> f64;
}

/// Settings of the injection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InjectionParams {
    /// Injected amplitude \[m\] (small: the nonlinear parts stay linear).
    pub amplitude: f64,
    /// Settling time before measuring \[s\] (plus three periods).
    pub settle: f64,
    /// Shortest measuring window \[s\] (at least four periods, whole periods).
    pub window: f64,
}

impl Default for InjectionParams {
    fn default() -> Self {
        InjectionParams {
            amplitude: 1e-9,
            settle: 0.05,
            window: 0.02,
        }
    }
}

/// One closed loop of `design` on the loop `probe` with `delay` samples, at rest with a zero
/// reference.
fn closed_loop(
    probe: &dyn InjectionLoop,
    design: &dyn Design,
    delay: usize,
) -> Result<(Box<dyn StageControl>, Box<dyn StagePlant>)> {
    Ok((probe.controller(design)?, probe.plant(delay)?))
}

/// The measured return ratio of loop `axis` at `f` \[Hz\]; NaN when the loop diverges.
pub fn return_ratio(
    probe: &dyn InjectionLoop,
    design: &dyn Design,
    delay: usize,
    axis: usize,
    f: f64,
    p: &InjectionParams,
) -> Result<Complex<f64>> {
    let (mut ctrl, mut plant) = closed_loop(probe, design, delay)?;
    let t = probe.sample_time();
    let settle = ((p.settle + 3.0 / f) / t).ceil() as usize;
    let cycles = (4.0f64).max((p.window * f).ceil());
    let n = (cycles / (f * t)).round() as usize;
    let w = std::f64::consts::TAU * f * t;
    let (mut a, mut b) = (Complex::new(0.0, 0.0), Complex::new(0.0, 0.0));
    for k in 0..settle + n {
        let y = plant.measure();
        let d = p.amplitude * (w * k as f64).sin();
        let mut yc = y;
        yc[axis] += d;
        let cmd = ctrl.step(yc);
        plant.apply(&cmd);
        if !(y[axis].is_finite() && y[axis].abs() < 1e-3) {
            return Ok(Complex::new(f64::NAN, f64::NAN));
        }
        if k >= settle {
            let e = Complex::from_polar(1.0, -w * k as f64);
            a += y[axis] * e;
            b += yc[axis] * e;
        }
    }
    Ok(-a / b)
}

/// Whether the closed loop of `design` on the linear rig is asymptotically stable: after
/// a 10 nm kick of both measurements, the output over the last fifth of `duration` \[s\] stays
/// below a tenth of its peak and below the kick, and does not grow over the last tenth (a
/// loop held flat by the stroke or voltage clamp is not stable). (A slowly growing mode
/// can still pass for a short `duration`; [`injected_margins`] also reports a loop that
/// diverges under injection as unstable.)
pub fn is_stable(
    probe: &dyn InjectionLoop,
    design: &dyn Design,
    delay: usize,
    duration: f64,
) -> Result<bool> {
    let (mut ctrl, mut plant) = closed_loop(probe, design, delay)?;
    let t = probe.sample_time();
    let n = (duration / t).round() as usize;
    let (mut peak, mut tail, mut last) = (0.0f64, 0.0f64, 0.0f64);
    for k in 0..n {
        let mut y = plant.measure();
        if k == 0 {
            y = [y[0] + KICK, y[1] + KICK];
        }
        let cmd = ctrl.step(y);
        plant.apply(&cmd);
        let q = plant.output();
        let m = q[0].abs().max(q[1].abs());
        if !m.is_finite() || m > 1e-3 {
            return Ok(false);
        }
        peak = peak.max(m);
        if k >= n * 4 / 5 {
            tail = tail.max(m);
        }
        if k >= n * 9 / 10 {
            last = last.max(m);
        }
    }
    // The output must also end below the kick: a loop that runs into the stroke or voltage
    // clamp and stays there is flat at the end but not stable.
    Ok(tail < 0.1 * peak && last <= tail && last < KICK)
}

/// The kick of [`is_stable`] \[m\].
const KICK: f64 = 1e-8;

/// Margins of `design` from measured return ratios; `None` when the closed loop is
/// unstable (no margin to speak of).
pub fn injected_margins(
    probe: &dyn InjectionLoop,
    design: &dyn Design,
    delay: usize,
    m: &MarginParams,
    p: &InjectionParams,
) -> Result<Option<[Margins; 2]>> {
    if !is_stable(probe, design, delay, 1.0)? {
        return Ok(None);
    }
    let mut out = [None, None];
    for axis in 0..2 {
        let mut err = None;
        let mut diverged = false;
        let r = margin(
            |f| match return_ratio(probe, design, delay, axis, f, p) {
                Ok(z) => {
                    diverged |= !(z.re.is_finite() && z.im.is_finite());
                    z
                }
                Err(e) => {
                    err = Some(e);
                    Complex::new(f64::NAN, f64::NAN)
                }
            },
            m,
        )?;
        if let Some(e) = err {
            return Err(e);
        }
        if diverged {
            // The loop diverged under injection: not stable, no margins.
            return Ok(None);
        }
        out[axis] = Some(r);
    }
    Ok(Some([out[0].unwrap(), out[1].unwrap()]))
}
