//! Margins of any controller by sine injection, as on a rig: a small sine d is added to
//! the measurement of axis i before the controller (the loop broken at the sensor), the
//! other loop stays closed, and after the transient the return ratio is
//! `L_i(jω) = −A/B`, A the plant's output of axis i, B = A + d the controller's input (both
//! one DFT bin at the injected frequency over whole periods). This needs no linear model of
//! the controller, so it works for the backstepping controllers with their observer and
//! input transformation; for a linear controller it equals the analytic loop-at-a-time
//! ratio (tests).

use flexstage_control::actuator::Compensation;
use flexstage_control::margins::{MarginParams, Margins, margin};
use flexstage_sim::rig::StagePlant;
use flexstage_sim::trajectory::{Reference, Shape};
use nalgebra::Complex;

use crate::bench::{Bench, Candidate};
use crate::error::Result;

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

/// One closed loop of a candidate on the bench's linear rig, at rest with a zero reference.
fn closed_loop(
    bench: &Bench,
    c: Candidate,
    delay: usize,
) -> Result<(
    Box<dyn flexstage_sim::experiment::StageControl>,
    Box<dyn StagePlant>,
)> {
    let r = Reference::new(Shape::Step { target: [0.0; 2] });
    let ctrl = bench.controller(c, Compensation::Ideal, r)?;
    let plant = bench.linear_plant(delay)?;
    Ok((ctrl, Box::new(plant)))
}

/// The measured return ratio of loop `axis` at `f` \[Hz\]; NaN when the loop diverges.
pub fn return_ratio(
    bench: &Bench,
    c: Candidate,
    delay: usize,
    axis: usize,
    f: f64,
    p: &InjectionParams,
) -> Result<Complex<f64>> {
    let (mut ctrl, mut plant) = closed_loop(bench, c, delay)?;
    let t = bench.setup.rig.sample_time;
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

/// Whether the closed loop of a candidate on the linear rig is asymptotically stable: after
/// a 10 nm kick of both measurements, the output over the last fifth of `duration` \[s\] stays
/// below a tenth of its peak and below the kick, and does not grow over the last tenth (a
/// loop held flat by the stroke or voltage clamp is not stable). (A slowly growing mode
/// can still pass for a short `duration`; [`injected_margins`] also reports a loop that
/// diverges under injection as unstable.)
pub fn is_stable(bench: &Bench, c: Candidate, delay: usize, duration: f64) -> Result<bool> {
    let (mut ctrl, mut plant) = closed_loop(bench, c, delay)?;
    let t = bench.setup.rig.sample_time;
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

/// Margins of a candidate from measured return ratios; `None` when the closed loop is
/// unstable (no margin to speak of).
pub fn injected_margins(
    bench: &Bench,
    c: Candidate,
    delay: usize,
    m: &MarginParams,
    p: &InjectionParams,
) -> Result<Option<[Margins; 2]>> {
    if !is_stable(bench, c, delay, 1.0)? {
        return Ok(None);
    }
    let mut out = [None, None];
    for axis in 0..2 {
        let mut err = None;
        let mut diverged = false;
        let r = margin(
            |f| match return_ratio(bench, c, delay, axis, f, p) {
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

/// Sets the backstepping up from the twin's sampled response
/// ([`flexstage_control::controller::ControllerParams::for_response`] on the bench's
/// identified fit, else on the fit of the twin's exact modes: fitted model, the tuned PI +
/// notch's notches on the measurement) with the largest gain scale of
/// [`flexstage_control::controller::GAIN_SCALES`] whose robust and non-robust loops keep
/// the margin targets of the bench's tuning (6 dB / 40°) with the rig's delay, by sine
/// injection; the smallest scale when none does (the margins table then flags it). Returns
/// the scale.
pub fn size_backstepping(bench: &mut Bench) -> Result<f64> {
    use flexstage_control::controller::GAIN_SCALES;
    let base = bench.setup.controller.clone();
    let modes = bench.twin.modal.plant_modes();
    let notches = bench.pi_notch.params.axes.map(|a| a.notches);
    let delay = bench.setup.rig.delay;
    let (gm, pm) = (bench.tuning.gain_margin_db, bench.tuning.phase_margin_deg);
    let mut mp = bench.tuning.margins;
    mp.f_min = 10.0;
    mp.points = 40;
    mp.refine = 8;
    for &scale in &GAIN_SCALES {
        bench.setup.controller = match &bench.identified {
            Some(fit) => base.for_response(fit, notches, scale),
            None => base.for_sampled_plant(&modes, notches, scale),
        };
        let mut ok = true;
        for c in [Candidate::Robust, Candidate::NonRobust] {
            ok &= match injected_margins(bench, c, delay, &mp, &InjectionParams::default())? {
                Some(m) => m.iter().all(|m| m.meets(gm, pm)),
                None => false,
            };
            if !ok {
                break;
            }
        }
        if ok {
            return Ok(scale);
        }
    }
    Ok(GAIN_SCALES[GAIN_SCALES.len() - 1])
}
