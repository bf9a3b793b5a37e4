//! Voltage waveforms, steady-state hysteresis loops and loop metrics.

use flexstage_numerics::DataError;
use serde::{Deserialize, Serialize};

use crate::error::{Result, check};
use crate::model::{BoucWen, BoucWenParams};

/// Shape of a periodic drive between `low` and `high`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WaveShape {
    /// low + (high − low)·(1 − cos 2πft)/2: starts at `low` with zero slope.
    Sine,
    /// Symmetric triangle starting at `low`.
    Triangle,
    /// The sine with an amplitude decaying linearly from 1 to 0.3 over `cycles` periods: a
    /// sequence of nested minor loops, the richer excitation for identification.
    Decaying,
}

impl WaveShape {
    /// Parses "sine", "triangle" or "decaying".
    pub fn from_name(name: &str) -> Option<WaveShape> {
        match name {
            "sine" => Some(WaveShape::Sine),
            "triangle" => Some(WaveShape::Triangle),
            "decaying" => Some(WaveShape::Decaying),
            _ => None,
        }
    }
}

/// A periodic waveform (voltage \[V\] or desired displacement \[µm\]) of frequency \[Hz\].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Waveform {
    /// Shape.
    pub shape: WaveShape,
    /// Lowest value.
    pub low: f64,
    /// Highest value, > low.
    pub high: f64,
    /// Frequency \[Hz\], > 0.
    pub frequency: f64,
    /// Number of periods, ≥ 1 (only [`WaveShape::Decaying`] uses it for its envelope).
    pub cycles: u32,
}

impl Waveform {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        check("waveform.low", self.low, true, "a finite number")?;
        check(
            "waveform.high",
            self.high,
            self.high > self.low,
            "a finite number > low",
        )?;
        check(
            "waveform.frequency",
            self.frequency,
            self.frequency > 0.0,
            "a finite number > 0 [Hz]",
        )?;
        check(
            "waveform.cycles",
            self.cycles as f64,
            self.cycles >= 1,
            "an integer ≥ 1",
        )
    }

    /// Duration of `cycles` periods \[s\].
    pub fn duration(&self) -> f64 {
        self.cycles as f64 / self.frequency
    }

    /// Value at time `t` \[s\].
    pub fn value(&self, t: f64) -> f64 {
        let phase = (t * self.frequency).rem_euclid(1.0);
        let unit = match self.shape {
            WaveShape::Sine => 0.5 * (1.0 - (std::f64::consts::TAU * phase).cos()),
            WaveShape::Triangle => 1.0 - (2.0 * phase - 1.0).abs(),
            WaveShape::Decaying => {
                let progress = (t / self.duration()).clamp(0.0, 1.0);
                let amplitude = 1.0 - 0.7 * progress;
                amplitude * 0.5 * (1.0 - (std::f64::consts::TAU * phase).cos())
            }
        };
        self.low + (self.high - self.low) * unit
    }

    /// Samples `t = 0, dt, 2dt, …` over `cycles` periods (inclusive of the end point).
    pub fn sample(&self, dt: f64) -> (Vec<f64>, Vec<f64>) {
        let n = (self.duration() / dt).round() as usize;
        let t: Vec<f64> = (0..=n).map(|k| k as f64 * dt).collect();
        let v = t.iter().map(|&t| self.value(t)).collect();
        (t, v)
    }
}

/// One period of a hysteresis loop: input (voltage or desired displacement) and output.
#[derive(Debug, Clone, PartialEq)]
pub struct HysteresisLoop {
    /// Input samples over one period.
    pub input: Vec<f64>,
    /// Output samples \[µm\].
    pub output: Vec<f64>,
    /// Periods simulated until the loop repeated.
    pub periods: u32,
}

/// Shape measures of a loop. Percentages are of the output range (max − min of the output).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LoopMetrics {
    /// Output range (stroke) \[µm\].
    pub range: f64,
    /// Largest vertical gap between the branches at equal input \[µm\].
    pub width: f64,
    /// `width` as % of `range`.
    pub width_pct: f64,
    /// Largest distance of the output from its least-squares straight line in the input \[µm\].
    pub max_deviation: f64,
    /// `max_deviation` as % of `range`.
    pub max_deviation_pct: f64,
}

/// Loop metrics of an (input, output) trajectory, usually one period of a steady loop.
///
/// The width is evaluated on a grid of 512 input levels: at each level, every segment of the
/// trajectory that crosses it gives an interpolated output, and the width there is the spread
/// of those outputs. The maximum deviation from linear is taken from the least-squares line
/// output ≈ a + b·input over all samples.
pub fn loop_metrics(input: &[f64], output: &[f64]) -> Result<LoopMetrics> {
    if input.len() != output.len() || input.len() < 3 {
        return Err(DataError::new(
            "loop",
            format!(
                "need equal-length input and output with ≥ 3 samples, got {} and {}",
                input.len(),
                output.len()
            ),
        )
        .into());
    }
    if input.iter().chain(output).any(|v| !v.is_finite()) {
        return Err(DataError::new("loop", "non-finite sample").into());
    }
    let (imin, imax) = min_max(input);
    let (omin, omax) = min_max(output);
    let range = omax - omin;
    if imax <= imin || range <= 0.0 {
        return Err(DataError::new("loop", "input or output is constant").into());
    }
    const GRID: usize = 512;
    let mut lo = vec![f64::INFINITY; GRID + 1];
    let mut hi = vec![f64::NEG_INFINITY; GRID + 1];
    let level = |g: usize| imin + (imax - imin) * g as f64 / GRID as f64;
    for k in 1..input.len() {
        let (a, b) = (input[k - 1], input[k]);
        let (ya, yb) = (output[k - 1], output[k]);
        let (s0, s1) = if a <= b { (a, b) } else { (b, a) };
        let g0 = (((s0 - imin) / (imax - imin)) * GRID as f64)
            .ceil()
            .max(0.0) as usize;
        let g1 = ((((s1 - imin) / (imax - imin)) * GRID as f64).floor() as usize).min(GRID);
        for g in g0..=g1 {
            let v = level(g);
            if v < s0 || v > s1 {
                continue;
            }
            let y = if b == a {
                0.5 * (ya + yb)
            } else {
                ya + (yb - ya) * (v - a) / (b - a)
            };
            lo[g] = lo[g].min(y);
            hi[g] = hi[g].max(y);
        }
    }
    let width = lo
        .iter()
        .zip(&hi)
        .filter(|(l, h)| l.is_finite() && h.is_finite())
        .map(|(l, h)| h - l)
        .fold(0.0, f64::max);
    let (a, b) = line_fit(input, output);
    let max_deviation = input
        .iter()
        .zip(output)
        .map(|(i, o)| (o - (a + b * i)).abs())
        .fold(0.0, f64::max);
    Ok(LoopMetrics {
        range,
        width,
        width_pct: 100.0 * width / range,
        max_deviation,
        max_deviation_pct: 100.0 * max_deviation / range,
    })
}

/// Least-squares line y ≈ a + b·x.
pub(crate) fn line_fit(x: &[f64], y: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mx = x.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    let b = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    (my - b * mx, b)
}

pub(crate) fn min_max(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        })
}

/// Settings of [`steady_state_loop`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopParams {
    /// Sample time \[s\], > 0. Default 1e-4 (the 10 kHz controller rate).
    pub dt: f64,
    /// Stop when one period's output differs from the previous one by less than this
    /// fraction of the output range, > 0. Default 1e-9.
    pub tolerance: f64,
    /// Give up after this many periods, ≥ 2. Default 50.
    pub max_periods: u32,
}

impl Default for LoopParams {
    fn default() -> Self {
        LoopParams {
            dt: 1e-4,
            tolerance: 1e-9,
            max_periods: 50,
        }
    }
}

impl LoopParams {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        check("loop.dt", self.dt, self.dt > 0.0, "a finite number > 0 [s]")?;
        check(
            "loop.tolerance",
            self.tolerance,
            self.tolerance > 0.0,
            "a finite number > 0",
        )?;
        check(
            "loop.max_periods",
            self.max_periods as f64,
            self.max_periods >= 2,
            "an integer ≥ 2",
        )
    }
}

/// The steady-state hysteresis loop of a virgin actuator driven by a periodic voltage
/// `waveform(t)` \[V\] of period `period` \[s\]: periods are simulated until one repeats the
/// previous one (to `tolerance` of the range); the last one is returned.
pub fn steady_state_loop(
    params: &BoucWenParams,
    waveform: impl Fn(f64) -> f64,
    period: f64,
    settings: LoopParams,
) -> Result<HysteresisLoop> {
    params.validate()?;
    settings.validate()?;
    check(
        "loop.period",
        period,
        period > 0.0,
        "a finite number > 0 [s]",
    )?;
    let n = ((period / settings.dt).round() as usize).max(3);
    let dt = period / n as f64;
    let mut pea = BoucWen::new(*params);
    pea.set_state(waveform(0.0), 0.0);
    let mut prev: Vec<f64> = Vec::new();
    let mut input = vec![0.0; n + 1];
    let mut output = vec![0.0; n + 1];
    for p in 1..=settings.max_periods {
        input[0] = pea.u();
        output[0] = pea.x();
        for k in 1..=n {
            let u = waveform(k as f64 * dt);
            input[k] = u;
            output[k] = pea.step(u, dt);
        }
        if !prev.is_empty() {
            let (lo, hi) = min_max(&output);
            let change = prev
                .iter()
                .zip(&output)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            if change <= settings.tolerance * (hi - lo).max(f64::MIN_POSITIVE) {
                return Ok(HysteresisLoop {
                    input,
                    output,
                    periods: p,
                });
            }
        }
        prev.clone_from(&output);
    }
    Err(DataError::new(
        "steady_state_loop",
        format!(
            "the loop did not repeat within {} periods (tolerance {:e})",
            settings.max_periods, settings.tolerance
        ),
    )
    .into())
}
