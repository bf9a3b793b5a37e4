//! The loop as a lab measures it: the 2 × 2 discrete-time response from the DAC command
//! (x_nom) to the ADC reading at the controller's own sample time, estimated from what a rig
//! records and from nothing else.
//!
//! * [`LabLog`] (`log`): the recorded signals (sample time, two commands, two readings) and
//!   their CSV file.
//! * [`MultisinePlan`], [`run_log`] (`experiment`): the periodic multisine of the response
//!   experiment and a command sequence played through a simulated rig at the controller's
//!   rate (zero-order hold, delay, amplifier, hysteretic PEAs, sensor chain, noise), logged.
//! * [`MeasuredResponse`] (this file): the response on a list of lines up to Nyquist, with
//!   per-line coherence and standard deviation; estimated from two periodic multisine logs
//!   (`multisine`: period averaging, the spread over periods) or from any log by H1
//!   (`welch`: Welch averaging, coherence, the regression variance); its CSV file.
//! * [`ZFit`] (`fit`): a z-domain rational model of a measured response with its delay,
//!   the [`flexstage_sim::modal::LoopPlant`] a design evaluates anywhere; the folded modes
//!   are simply poles in z.
//!
//! Sampled at the controller's rate, a mode above Nyquist folds into the band (a 8.99 kHz
//! mode appears at 1.01 kHz at 10 kHz): this is what the loop sees and what a design must
//! see, so nothing here samples faster than the controller.
//!
//! A [`MeasuredResponse`] can be built only by the estimators from a [`LabLog`] or read from
//! its file: no constructor takes a modal model, so a design that takes one cannot be fed
//! the simulation's truth. File formats: `docs/formats.md`.
//!
//! The loop model is fitted from a measured response:
//! ```
//! use flexstage_identify::measured::{FitParams, LabLog, MeasuredResponse, WelchParams, ZFit};
//! // A log of white commands through y_k = 0.5 u_{k−1}.
//! let mut noise = flexstage_numerics::noise::GaussianNoise::new(1e-6, 1);
//! let u: Vec<[f64; 2]> = (0..8000).map(|_| [noise.sample(), noise.sample()]).collect();
//! let y = |i: usize| (0..u.len()).map(|k| if k > 0 { 0.5 * u[k - 1][i] } else { 0.0 }).collect();
//! let log = LabLog::new(1e-4, [u.iter().map(|v| v[0]).collect(), u.iter().map(|v| v[1]).collect()], [y(0), y(1)])?;
//! let response = MeasuredResponse::from_log(&log, &WelchParams { segment: 200, skip: 0 })?;
//! let model = ZFit::fit(&response, &FitParams::default())?;
//! assert_eq!(model.delay(), 0); // z⁻¹ is the hold's own sample: strictly proper, no extra delay
//! # Ok::<(), flexstage_identify::IdentifyError>(())
//! ```
//! and only from one: the simulation's exact loop (a `ModalPlant`) is not a measured
//! response, so this does not compile.
//! ```compile_fail
//! use flexstage_identify::measured::{FitParams, ZFit};
//! use flexstage_sim::modal::ModalPlant;
//! let truth = ModalPlant::new(flexstage_sim::samples::decoupled_modes(), 1e-4, 1).unwrap();
//! let model = ZFit::fit(&truth, &FitParams::default());
//! ```

mod experiment;
mod fast_period;
mod fit;
mod lifted;
mod lifted_file;
mod log;
mod multisine;
mod welch;

use std::fmt::Write as _;
use std::io::Read;

use flexstage_numerics::DataError;
use flexstage_numerics::records::{NumericCsv, RecordError};

pub use experiment::{Drive, MultisinePlan, run_log};
pub use fast_period::{FastChannel, FastPeriod, FastRecorded, SampledOutput};
pub use fit::{FitParams, ZFilter, ZFit};
pub use lifted::{
    FastAdc, FastLog, LiftedLine, LiftedResponse, from_harmonics, harmonic_frequency, image_bound,
    intersample_bound, run_fast_log, to_harmonics,
};
pub use lifted_file::lifted_columns;
pub use log::{LOG_COLUMNS, LabLog};
pub use welch::WelchParams;

use crate::error::Result;
use crate::frequency::C64;

/// The response at one line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeasuredLine {
    /// Frequency \[Hz\], in (0, Nyquist).
    pub f: f64,
    /// H\[i\]\[j\]: reading i per command j (dimensionless).
    pub h: [[C64; 2]; 2],
    /// Coherence γ² of each entry, in \[0, 1\] (1: noise-free and linear).
    pub coherence: [[f64; 2]; 2],
    /// Standard deviation of each estimate (of the complex value: E|Ĥ − H|² = std²).
    pub std: [[f64; 2]; 2],
}

/// The measured 2 × 2 response command → reading at the controller's sample time (module
/// docs). Built only from a [`LabLog`] or its file.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredResponse {
    sample_time: f64,
    lines: Vec<MeasuredLine>,
}

/// The columns of a response file, in file order.
pub const RESPONSE_COLUMNS: [&str; 14] = [
    "f",
    "re11",
    "im11",
    "re12",
    "im12",
    "re21",
    "im21",
    "re22",
    "im22",
    "coh11",
    "coh12",
    "coh21",
    "coh22",
    "sample_time",
];

/// The standard-deviation columns of a response file.
pub const STD_COLUMNS: [&str; 4] = ["std11", "std12", "std21", "std22"];

impl MeasuredResponse {
    /// Checks and wraps estimated lines.
    fn new(sample_time: f64, lines: Vec<MeasuredLine>) -> Result<MeasuredResponse> {
        crate::error::check(
            "response.sample_time",
            sample_time,
            sample_time > 0.0 && sample_time.is_finite(),
            "a time > 0 [s]",
        )?;
        let nyquist = 0.5 / sample_time;
        for (n, l) in lines.iter().enumerate() {
            crate::error::check(
                &format!("response line {n} frequency"),
                l.f,
                l.f > 0.0 && l.f < nyquist && (n == 0 || l.f > lines[n - 1].f),
                &format!("ascending frequencies in (0, {nyquist}) [Hz]"),
            )?;
            for i in 0..2 {
                for j in 0..2 {
                    let (h, c, s) = (l.h[i][j], l.coherence[i][j], l.std[i][j]);
                    crate::error::check(
                        &format!("response line {n} ({} Hz) H{}{}", l.f, i + 1, j + 1),
                        h.norm(),
                        h.re.is_finite() && h.im.is_finite(),
                        "a finite value",
                    )?;
                    crate::error::check(
                        &format!("response line {n} ({} Hz) coh{}{}", l.f, i + 1, j + 1),
                        c,
                        (0.0..=1.0).contains(&c),
                        "a coherence in [0, 1]",
                    )?;
                    crate::error::check(
                        &format!("response line {n} ({} Hz) std{}{}", l.f, i + 1, j + 1),
                        s,
                        s >= 0.0 && s.is_finite(),
                        "a standard deviation ≥ 0",
                    )?;
                }
            }
        }
        if lines.is_empty() {
            return Err(DataError::new("response", "no line".to_string()).into());
        }
        Ok(MeasuredResponse { sample_time, lines })
    }

    /// The controller's sample time \[s\] the response was measured at.
    pub fn sample_time(&self) -> f64 {
        self.sample_time
    }

    /// The lines, by frequency.
    pub fn lines(&self) -> &[MeasuredLine] {
        &self.lines
    }

    /// The response as CSV text (`docs/formats.md`): header
    /// `f,re11,im11,…,im22,coh11,…,coh22,sample_time,std11,…,std22`, one line per frequency,
    /// numbers in Rust's shortest round-trip form ([`MeasuredResponse::from_csv`] reads it
    /// back bit for bit).
    pub fn to_csv(&self) -> String {
        let mut s = String::new();
        s.push_str(&RESPONSE_COLUMNS.join(","));
        s.push(',');
        s.push_str(&STD_COLUMNS.join(","));
        s.push('\n');
        for l in &self.lines {
            let _ = write!(s, "{:e}", l.f);
            write_cells(&mut s, l, self.sample_time);
            s.push('\n');
        }
        s
    }

    /// Reads a response file (`docs/formats.md`); `origin` names it in errors. The
    /// `sample_time` column holds the same value on every line.
    pub fn from_csv(reader: impl Read, origin: &str) -> Result<MeasuredResponse> {
        let table = NumericCsv::open(reader, origin)?;
        let names: Vec<&str> = RESPONSE_COLUMNS
            .iter()
            .chain(&STD_COLUMNS)
            .copied()
            .collect();
        let cols = table.require(&names, &names.join(", "))?;
        let d = table.read(&cols, &names)?;
        let Some(&ts) = d[13].first() else {
            return Err(RecordError::whole(origin, DataError::new("response", "no line")).into());
        };
        if let Some(k) = d[13].iter().position(|v| v.to_bits() != ts.to_bits()) {
            return Err(RecordError::whole(
                origin,
                DataError::new(
                    "sample_time",
                    format!(
                        "line {k} of the data has {} s, the first {ts} s: one response has \
                         one sample time",
                        d[13][k]
                    ),
                ),
            )
            .into());
        }
        let lines = (0..d[0].len())
            .map(|k| line_from_cells(d[0][k], |col| d[col + 1][k]))
            .collect();
        MeasuredResponse::new(ts, lines)
    }
}

/// Writes the cells of a response file's row after `f` (in a lifted response file, after
/// `phase`) for the line `l`: `,re11,im11,…,im22,coh11,…,coh22,sample_time,std11,…,std22`
/// (`ts` the sample time), numbers in Rust's shortest round-trip form.
pub(crate) fn write_cells(s: &mut String, l: &MeasuredLine, ts: f64) {
    for v in l.h.iter().flatten() {
        let _ = write!(s, ",{:e},{:e}", v.re, v.im);
    }
    for v in l.coherence.iter().flatten() {
        let _ = write!(s, ",{v:e}");
    }
    let _ = write!(s, ",{ts:e}");
    for v in l.std.iter().flatten() {
        let _ = write!(s, ",{v:e}");
    }
}

/// The line at `f` of a response file's row whose cells after `f` (in a lifted response
/// file, after `phase`) are `c(0)` (re11) … `c(16)` (std22), in [`write_cells`]'s order
/// (`c(12)`, the sample time, is checked by the caller).
pub(crate) fn line_from_cells(f: f64, c: impl Fn(usize) -> f64) -> MeasuredLine {
    MeasuredLine {
        f,
        h: [
            [C64::new(c(0), c(1)), C64::new(c(2), c(3))],
            [C64::new(c(4), c(5)), C64::new(c(6), c(7))],
        ],
        coherence: [[c(8), c(9)], [c(10), c(11)]],
        std: [[c(13), c(14)], [c(15), c(16)]],
    }
}

/// The twiddles e^{−j2πm/n}, m = 0..n, of a DFT of length n (each angle exact).
pub(crate) fn twiddles(n: usize) -> Vec<C64> {
    (0..n)
        .map(|m| C64::from_polar(1.0, -std::f64::consts::TAU * m as f64 / n as f64))
        .collect()
}

/// The DFT Σ x_m e^{−j2πkm/n} of `x` (length n = `tw.len()`) at harmonic k, from the
/// [`twiddles`] `tw` (index k·m mod n: no trigonometry per sample, no growing angle error).
pub(crate) fn dft_with(x: &[f64], k: usize, tw: &[C64]) -> C64 {
    let n = tw.len();
    let mut s = C64::new(0.0, 0.0);
    let mut idx = 0usize;
    for &v in x {
        s += tw[idx] * v;
        idx += k;
        if idx >= n {
            idx %= n;
        }
    }
    s
}

/// [`dft_with`] with its own twiddles.
#[cfg(test)]
pub(crate) fn dft(x: &[f64], k: usize) -> C64 {
    dft_with(x, k, &twiddles(x.len()))
}

/// The inverse of a 2 × 2 complex matrix, or `None` when it is singular.
pub(crate) fn inverse(m: [[C64; 2]; 2]) -> Option<[[C64; 2]; 2]> {
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    let scale = m.iter().flatten().map(|v| v.norm()).fold(0.0, f64::max);
    if !(det.norm() > 1e-14 * scale * scale) {
        return None;
    }
    Some([
        [m[1][1] / det, -m[0][1] / det],
        [-m[1][0] / det, m[0][0] / det],
    ])
}

/// The product of two 2 × 2 complex matrices.
pub(crate) fn mul(a: [[C64; 2]; 2], b: [[C64; 2]; 2]) -> [[C64; 2]; 2] {
    let mut c = [[C64::new(0.0, 0.0); 2]; 2];
    for i in 0..2 {
        for j in 0..2 {
            c[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j];
        }
    }
    c
}
