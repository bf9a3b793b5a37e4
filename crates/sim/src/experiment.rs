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
}

impl Metrics {
    /// Whether the run diverged: a non-finite sample, or a non-finite RMS or maximum.
    pub fn diverged(&self) -> bool {
        self.non_finite > 0
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
}

/// Runs `controller` on `plant` for `duration` seconds and records everything. Allocates only
/// the record (once, up front).
pub fn run(
    controller: &mut dyn StageControl,
    plant: &mut dyn StagePlant,
    duration: f64,
    sample_time: f64,
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
        plant.apply(&cmd);
        if k % 1000 == 999 {
            progress(1000);
        }
    }
    rec
}
