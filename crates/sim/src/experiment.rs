//! The simulated experiment (Section 4, Figures 9–11): a controller and a plant run sample
//! by sample, with the time series and the metrics.
//!
//! [`run`] drives any [`StageControl`] on any [`StagePlant`]: the lumped plant in its
//! minimal loop ([`crate::plant::Plant`]), the lumped plant in the scenario's rig or the
//! finite-element twin of the designed stage (`flexstage-twin`). The controllers themselves
//! are `flexstage-control`'s; this crate defines only what the loop exchanges with them: the
//! measurement in, a [`Command`] out.

use crate::rig::StagePlant;

/// One sample of controller output.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Command {
    /// Amplifier voltages \[V\], always finite and inside the range.
    pub voltage: [f64; 2],
    /// The x_nom \[m\] the actuator model expects from the voltages (Eq. 36 input).
    pub x_nom: [f64; 2],
    /// The reference q_d at this sample \[m\].
    pub reference: [f64; 2],
    /// True when the stroke or the amplifier range clipped the command.
    pub saturated: bool,
    /// True when the measurement was not finite and the last valid one was used.
    pub dropout: bool,
}

/// A sampled position controller: one call per sample.
pub trait StageControl {
    /// Takes the measured output y_k = [q_o1, q_o2] \[m\] and returns the command held until
    /// the next sample.
    fn step(&mut self, y: [f64; 2]) -> Command;
    /// The state estimate [ẑ, d̂] \[SI\] (zeros for controllers without an observer).
    fn estimate(&self) -> [f64; 10];
    /// The reading \[m\] the last step's feedback compared the measurement with, where it is
    /// not the reference delayed by the sensor's lag (a controller whose feedback expects
    /// the reading a measured model predicts); `None` otherwise.
    fn expected_reading(&self) -> Option<[f64; 2]> {
        None
    }
}

/// A boxed controller is a controller (so a wrapper such as `flexstage-control`'s learning
/// layer takes a `Box<dyn StageControl>`).
impl<T: StageControl + ?Sized> StageControl for Box<T> {
    #[inline]
    fn step(&mut self, y: [f64; 2]) -> Command {
        (**self).step(y)
    }
    fn estimate(&self) -> [f64; 10] {
        (**self).estimate()
    }
    fn expected_reading(&self) -> Option<[f64; 2]> {
        (**self).expected_reading()
    }
}

/// The time series of one run (one entry per sample).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Record {
    /// Time \[s\].
    pub t: Vec<f64>,
    /// Reference q_d \[m\].
    pub reference: [Vec<f64>; 2],
    /// Measured y \[m\].
    pub measured: [Vec<f64>; 2],
    /// True output q_o \[m\].
    pub truth: [Vec<f64>; 2],
    /// Tracking error q_o − q_d \[m\].
    pub error: [Vec<f64>; 2],
    /// Applied voltages \[V\].
    pub voltage: [Vec<f64>; 2],
    /// Commanded x_nom \[m\].
    pub x_nom: [Vec<f64>; 2],
    /// Estimated state ẑ and input disturbance d̂ \[SI\] (zeros for the PID baseline).
    pub estimate: [Vec<f64>; 10],
    /// Samples at which the command saturated.
    pub saturated: usize,
    /// Samples with a sensor dropout.
    pub dropouts: usize,
    /// Why the run stopped before its end ([`run_watched`]), if it did.
    pub stopped: Option<Stopped>,
}

/// Bounds that stop a run while it runs ([`run_watched`]): a diverged or open loop is
/// stopped at once instead of being simulated to its end (and its NaN or 1e300 series drawn).
/// A non-finite state always stops a run, whatever the bounds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WatchParams {
    /// Largest |q_o − q_d| on either axis \[m\]; beyond it the loop has diverged.
    pub max_error: f64,
    /// Longest time the command may stay saturated without a break \[s\]; beyond it the
    /// loop is open (the controller's output no longer acts).
    pub max_saturated: f64,
}

impl Default for WatchParams {
    /// Only the non-finite check: both bounds infinite.
    fn default() -> Self {
        WatchParams {
            max_error: f64::INFINITY,
            max_saturated: f64::INFINITY,
        }
    }
}

/// Why [`run_watched`] stopped a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StopCause {
    /// The measurement, the true output or the command was NaN or ∞.
    NonFinite,
    /// The error left [`WatchParams::max_error`].
    Error {
        /// |error| at the stop \[m\].
        error: f64,
        /// The bound \[m\].
        bound: f64,
    },
    /// The command stayed saturated longer than [`WatchParams::max_saturated`].
    Saturated {
        /// The bound \[s\].
        bound: f64,
    },
}

/// A run stopped before its end: when, and why.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stopped {
    /// Time of the last recorded sample \[s\].
    pub t: f64,
    /// The cause.
    pub cause: StopCause,
}

impl std::fmt::Display for Stopped {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let t = self.t;
        match self.cause {
            StopCause::NonFinite => write!(f, "stopped at t = {t:.4} s: a non-finite state"),
            StopCause::Error { error, bound } => write!(
                f,
                "stopped at t = {t:.4} s: |error| {error:.3e} m beyond the bound {bound:.3e} m"
            ),
            StopCause::Saturated { bound } => write!(
                f,
                "stopped at t = {t:.4} s: the command saturated for more than {bound} s on end"
            ),
        }
    }
}

impl Record {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The CSV column names of [`Record::columns`].
    pub fn header() -> Vec<&'static str> {
        vec![
            "t_s", "ref1_m", "ref2_m", "meas1_m", "meas2_m", "true1_m", "true2_m", "err1_m",
            "err2_m", "volt1_V", "volt2_V", "xnom1_m", "xnom2_m", "zhat1", "zhat2", "zhat3",
            "zhat4", "zhat5", "zhat6", "zhat7", "zhat8", "dhat1_m", "dhat2_m",
        ]
    }

    /// The columns in [`Record::header`] order.
    pub fn columns(&self) -> Vec<&[f64]> {
        let mut c: Vec<&[f64]> = vec![&self.t];
        for group in [
            &self.reference,
            &self.measured,
            &self.truth,
            &self.error,
            &self.voltage,
            &self.x_nom,
        ] {
            c.extend(group.iter().map(|v| v.as_slice()));
        }
        c.extend(self.estimate.iter().map(|v| v.as_slice()));
        c
    }

    /// Metrics of the run; `half_range` per axis \[m\] (for % of range), as from
    /// [`crate::trajectory::Reference::half_range`].
    ///
    /// A non-finite sample (NaN or ∞: a diverged simulation) is never hidden: it is counted in
    /// [`Metrics::non_finite`], and the RMS, maximum and settling of its axis become NaN or ∞
    /// (the maximum propagates NaN, unlike `f64::max`, which would drop it and report 0).
    pub fn metrics(&self, half_range: [f64; 2]) -> Metrics {
        let n = self.len();
        let mut m = Metrics::default();
        if n == 0 {
            return m;
        }
        let mut settle = 0usize;
        for i in 0..2 {
            let e = &self.error[i];
            m.rms[i] = (e.iter().map(|x| x * x).sum::<f64>() / n as f64).sqrt();
            m.max[i] = max_abs(e);
            let range = 2.0 * half_range[i];
            let pct = |x: f64| if range > 0.0 { 100.0 * x / range } else { 0.0 };
            m.rms_pct[i] = pct(m.rms[i]);
            m.max_pct[i] = pct(m.max[i]);
            // Settling of the initial transient: the last sample whose error exceeds five
            // times the RMS error of the second half of the run.
            let tail = &e[n / 2..];
            let band = 5.0 * (tail.iter().map(|x| x * x).sum::<f64>() / tail.len() as f64).sqrt();
            m.steady_rms[i] = band / 5.0;
            if let Some(k) = e.iter().rposition(|x| x.abs() > band) {
                settle = settle.max(k + 1);
            }
        }
        m.non_finite = [&self.error, &self.truth, &self.voltage]
            .iter()
            .flat_map(|g| g.iter().flatten())
            .filter(|x| !x.is_finite())
            .count();
        m.settling = if m.non_finite > 0 {
            f64::NAN
        } else if settle < n {
            self.t[settle.min(n - 1)]
        } else {
            self.t[n - 1]
        };
        m.peak_voltage = fold_nan(self.voltage.iter().flatten().copied(), 0.0, f64::max);
        m.min_voltage = fold_nan(
            self.voltage.iter().flatten().copied(),
            f64::INFINITY,
            f64::min,
        );
        m.saturated = self.saturated;
        m.dropouts = self.dropouts;
        m.samples = n;
        let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / n as f64).sqrt();
        m.at_rest_rms = [rms(&self.reference[0]), rms(&self.reference[1])];
        m.stopped = self.stopped;
        m
    }
}

/// `max |x|` over `x`, NaN if any element is NaN (where `f64::max` would skip it).
fn max_abs(x: &[f64]) -> f64 {
    fold_nan(x.iter().map(|v| v.abs()), 0.0, f64::max)
}

/// Folds with `f`, but any NaN element makes the result NaN.
fn fold_nan(x: impl Iterator<Item = f64>, init: f64, f: fn(f64, f64) -> f64) -> f64 {
    x.fold(init, |a, v| {
        if a.is_nan() || v.is_nan() {
            f64::NAN
        } else {
            f(a, v)
        }
    })
}

/// Tracking metrics of one run (errors against the true output).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Metrics {
    /// RMS error per axis \[m\].
    pub rms: [f64; 2],
    /// Max |error| per axis \[m\].
    pub max: [f64; 2],
    /// RMS error in % of the reference range (peak to peak).
    pub rms_pct: [f64; 2],
    /// Max error in % of the reference range.
    pub max_pct: [f64; 2],
    /// RMS error over the second half of the run (after the transient) \[m\].
    pub steady_rms: [f64; 2],
    /// Settling time of the initial transient \[s\].
    pub settling: f64,
    /// Highest applied voltage \[V\].
    pub peak_voltage: f64,
    /// Lowest applied voltage \[V\].
    pub min_voltage: f64,
    /// Saturated samples.
    pub saturated: usize,
    /// Sensor dropouts.
    pub dropouts: usize,
    /// Non-finite samples (NaN or ∞) in the error, true output and voltage series: a
    /// diverged run. Its metrics are NaN or ∞, never a finite-looking number.
    pub non_finite: usize,
    /// Samples recorded.
    pub samples: usize,
    /// RMS of the reference per axis \[m\]: the RMS error of a stage that stays at rest.
    pub at_rest_rms: [f64; 2],
    /// Why the run stopped before its end, if it did ([`run_watched`]).
    pub stopped: Option<Stopped>,
}

/// What a run's result is worth ([`Metrics::status`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// Finished, finite, within the bounds.
    Ok,
    /// Finished, but the command saturated in more than [`SATURATED_SHARE`] of the samples:
    /// the errors include the amplifier's or the stroke's limits, not only the controller.
    Saturated,
    /// Finished, but the RMS error over both axes exceeds that of a stage at rest
    /// ([`Metrics::at_rest_rms`]): the loop made the tracking worse than doing nothing.
    ErrorAboveBound,
    /// Non-finite, or stopped by [`run_watched`]: the loop diverged or opened.
    Diverged,
}

/// The share of saturated samples above which a finished run is flagged
/// [`Status::Saturated`].
pub const SATURATED_SHARE: f64 = 0.01;

impl Status {
    /// The name in `metrics.csv`, the terminal and the report.
    pub fn name(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Saturated => "saturated",
            Status::ErrorAboveBound => "error-above-bound",
            Status::Diverged => "diverged",
        }
    }

    /// Whether the result is refused (the command fails after writing it): a diverged run,
    /// or one worse than a stage at rest.
    pub fn refused(self) -> bool {
        matches!(self, Status::ErrorAboveBound | Status::Diverged)
    }
}

impl Metrics {
    /// Whether the run diverged: stopped while it ran ([`run_watched`]), a non-finite
    /// sample, or a non-finite RMS or maximum.
    pub fn diverged(&self) -> bool {
        self.stopped.is_some()
            || self.non_finite > 0
            || self
                .rms
                .iter()
                .chain(&self.max)
                .chain(&self.steady_rms)
                .any(|x| !x.is_finite())
    }

    /// The combined RMS error over both axes \[m\].
    pub fn rms_total(&self) -> f64 {
        ((self.rms[0].powi(2) + self.rms[1].powi(2)) / 2.0).sqrt()
    }

    /// The run's [`Status`]: diverged (non-finite, or stopped while it ran), else error above
    /// the bound (RMS error over both axes above that of a stage at rest), else saturated
    /// (more than [`SATURATED_SHARE`] of the samples), else ok.
    pub fn status(&self) -> Status {
        let at_rest = ((self.at_rest_rms[0].powi(2) + self.at_rest_rms[1].powi(2)) / 2.0).sqrt();
        if self.diverged() {
            Status::Diverged
        } else if self.rms_total() > at_rest {
            Status::ErrorAboveBound
        } else if self.saturated as f64 > SATURATED_SHARE * self.samples as f64 {
            Status::Saturated
        } else {
            Status::Ok
        }
    }

    /// The status with its reason, for people: `ok`, or e.g. `diverged: stopped at
    /// t = 0.0541 s: a non-finite state`.
    pub fn status_detail(&self) -> String {
        let status = self.status();
        let why = match status {
            Status::Ok => return status.name().into(),
            Status::Diverged => match self.stopped {
                Some(s) => s.to_string(),
                None => format!("{} non-finite samples", self.non_finite),
            },
            Status::ErrorAboveBound => format!(
                "RMS error {:.3e} m above {:.3e} m, that of a stage at rest",
                self.rms_total(),
                ((self.at_rest_rms[0].powi(2) + self.at_rest_rms[1].powi(2)) / 2.0).sqrt()
            ),
            Status::Saturated => {
                format!("{} of {} samples saturated", self.saturated, self.samples)
            }
        };
        format!("{}: {why}", status.name())
    }
}

/// Runs `controller` on `plant` for `duration` seconds and records everything
/// ([`run_watched`] with the default [`WatchParams`]: a non-finite state stops the run).
pub fn run(
    controller: &mut dyn StageControl,
    plant: &mut dyn StagePlant,
    duration: f64,
    sample_time: f64,
    progress: impl FnMut(usize),
) -> Record {
    run_watched(
        controller,
        plant,
        duration,
        sample_time,
        &WatchParams::default(),
        progress,
    )
}

/// Runs `controller` on `plant` for `duration` seconds and records everything, stopping at the
/// first sample whose measurement, true output or command is not finite, whose error leaves
/// `watch.max_error`, or that ends a saturation longer than `watch.max_saturated`: that sample
/// is the last one recorded, [`Record::stopped`] says why, and `progress` is told the samples
/// skipped (so a progress bar ends). Allocates only the record (once, up front).
pub fn run_watched(
    controller: &mut dyn StageControl,
    plant: &mut dyn StagePlant,
    duration: f64,
    sample_time: f64,
    watch: &WatchParams,
    mut progress: impl FnMut(usize),
) -> Record {
    let n = (duration / sample_time).round() as usize;
    let mut rec = Record {
        t: Vec::with_capacity(n),
        ..Record::default()
    };
    for v in rec
        .reference
        .iter_mut()
        .chain(rec.measured.iter_mut())
        .chain(rec.truth.iter_mut())
        .chain(rec.error.iter_mut())
        .chain(rec.voltage.iter_mut())
        .chain(rec.x_nom.iter_mut())
        .chain(rec.estimate.iter_mut())
    {
        v.reserve_exact(n);
    }
    let mut saturated_run = 0usize;
    for k in 0..n {
        let y = plant.measure();
        let q = plant.output();
        let zh = controller.estimate();
        let cmd = controller.step(y);
        rec.t.push(k as f64 * sample_time);
        for i in 0..2 {
            rec.reference[i].push(cmd.reference[i]);
            rec.measured[i].push(y[i]);
            rec.truth[i].push(q[i]);
            rec.error[i].push(q[i] - cmd.reference[i]);
            rec.voltage[i].push(cmd.voltage[i]);
            rec.x_nom[i].push(cmd.x_nom[i]);
        }
        for (j, e) in rec.estimate.iter_mut().enumerate() {
            e.push(zh[j]);
        }
        rec.saturated += cmd.saturated as usize;
        rec.dropouts += cmd.dropout as usize;
        saturated_run = if cmd.saturated { saturated_run + 1 } else { 0 };
        if let Some(cause) = watch_sample(y, q, &cmd, saturated_run, sample_time, watch) {
            rec.stopped = Some(Stopped {
                t: k as f64 * sample_time,
                cause,
            });
            progress(n - k / 1000 * 1000);
            return rec;
        }
        plant.apply(&cmd);
        if k % 1000 == 999 {
            progress(1000);
        }
    }
    rec
}

/// Why a run must stop at this sample, if it must ([`run_watched`]).
fn watch_sample(
    y: [f64; 2],
    q: [f64; 2],
    cmd: &Command,
    saturated_run: usize,
    sample_time: f64,
    watch: &WatchParams,
) -> Option<StopCause> {
    let finite = y
        .iter()
        .chain(&q)
        .chain(&cmd.voltage)
        .chain(&cmd.x_nom)
        .chain(&cmd.reference)
        .all(|x| x.is_finite());
    if !finite {
        return Some(StopCause::NonFinite);
    }
    let error = (q[0] - cmd.reference[0])
        .abs()
        .max((q[1] - cmd.reference[1]).abs());
    if error > watch.max_error {
        return Some(StopCause::Error {
            error,
            bound: watch.max_error,
        });
    }
    if saturated_run as f64 * sample_time > watch.max_saturated {
        return Some(StopCause::Saturated {
            bound: watch.max_saturated,
        });
    }
    None
}
