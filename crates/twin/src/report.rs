//! The twin's data for the report: its modes, its frequency response from x_nom to q beside
//! the lumped model's (Bode magnitude and phase, both axes), as data, CSV and SVG figures
//! (`flexstage_figures::plot`).
//!
//! The two axes of the stage are the combinations the mechanism separates: the **common**
//! input `x_nom1 = x_nom2 = x` moves the output along q1 (the moving frame of Eq. 22), the
//! **differential** input `x_nom1 = −x_nom2 = x` along q2 (amplified by α, Eq. 27). The Bode
//! figures show `q1/x` for the common input and `q2/x` for the differential one, for the twin
//! and for the lumped 8-state model (Eq. 36) the controller is designed on; the CSV has the
//! four entries of both 2 × 2 matrices.

use flexstage_figures::plot::{Figure, Legend, Series};
use flexstage_sim::model::StageModel;
use nalgebra::{Complex, DMatrix};
use serde::Serialize;

use crate::error::{Result, TwinError};
use crate::twin::Twin;

/// One row of the modes table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ModeRow {
    /// Mode number (1-based).
    pub index: usize,
    /// Frequency \[Hz\].
    pub frequency: f64,
    /// Damping ratio.
    pub damping: f64,
    /// Static output per unit common input |q1/x| of this mode's term (participation).
    pub common: f64,
    /// Static output per unit differential input |q2/x| of this mode's term.
    pub differential: f64,
    /// Whether the twin claims the mode (below its reach, `Twin::covered_frequency`).
    pub claimed: bool,
}

/// The twin's modes with their static participation in the two axes.
pub fn modes_table(twin: &Twin) -> Vec<ModeRow> {
    let limit = twin.covered_frequency();
    twin.modal
        .modes
        .iter()
        .enumerate()
        .map(|(k, m)| {
            let w2 = (std::f64::consts::TAU * m.frequency).powi(2);
            ModeRow {
                index: k + 1,
                frequency: m.frequency,
                damping: m.damping,
                common: (m.output[0] * (m.input[0] + m.input[1]) / w2).abs(),
                differential: (m.output[1] * (m.input[0] - m.input[1]) / w2).abs(),
                claimed: m.frequency <= limit * (1.0 + 1e-9),
            }
        })
        .collect()
}

/// Frequency response of the lumped model x_nom → q at `f` \[Hz\]: `C (jωI − B)⁻¹ b`.
pub fn lumped_response(model: &StageModel, f: f64) -> Result<[[(f64, f64); 2]; 2]> {
    let w = std::f64::consts::TAU * f;
    let b = model.b_dyn();
    let mut a = DMatrix::<Complex<f64>>::zeros(8, 8);
    for i in 0..8 {
        for j in 0..8 {
            a[(i, j)] = Complex::new(-b[(i, j)], 0.0);
        }
        a[(i, i)] += Complex::new(0.0, w);
    }
    let bu = model.input_dyn().map(|x| Complex::new(x, 0.0));
    let x = a
        .lu()
        .solve(&bu)
        .ok_or_else(|| TwinError::Reduced(format!("the lumped model is singular at {f} Hz")))?;
    Ok([0, 1].map(|i| [0, 1].map(|j| (x[(i, j)].re, x[(i, j)].im))))
}

/// The Bode data of the twin beside the lumped model with parameters `lumped` (e.g. the
/// design's `reduce/params.toml`, no cross terms), 10 Hz to 50 kHz, 400 points.
pub fn bode_for(twin: &Twin, lumped: &flexstage_scenario::StageParams) -> Result<Bode> {
    let model = StageModel::new(lumped)?;
    Bode::new(twin, &model, 10.0, 50_000.0, 400)
}

/// Bode data of the twin and the lumped model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Bode {
    /// Frequencies \[Hz\], log-spaced.
    pub frequency: Vec<f64>,
    /// Twin x_nom → q, per frequency, row-major 2 × 2 of (re, im).
    pub twin: Vec<[[(f64, f64); 2]; 2]>,
    /// Lumped model x_nom → q.
    pub lumped: Vec<[[(f64, f64); 2]; 2]>,
}

/// The axis responses of a 2 × 2 response: (common → q1, differential → q2).
fn axes(g: &[[(f64, f64); 2]; 2]) -> [(f64, f64); 2] {
    [
        (g[0][0].0 + g[0][1].0, g[0][0].1 + g[0][1].1),
        (g[1][0].0 - g[1][1].0, g[1][0].1 - g[1][1].1),
    ]
}

/// Magnitude [dB] and phase [deg] of a complex number.
fn mag_phase(z: (f64, f64)) -> (f64, f64) {
    (20.0 * z.0.hypot(z.1).log10(), z.1.atan2(z.0).to_degrees())
}

impl Bode {
    /// `points` log-spaced frequencies from `f_min` to `f_max` \[Hz\].
    pub fn new(
        twin: &Twin,
        lumped: &StageModel,
        f_min: f64,
        f_max: f64,
        points: usize,
    ) -> Result<Bode> {
        crate::error::check(
            "Bode range",
            f_max,
            f_min > 0.0 && f_max > f_min && points >= 2,
            "0 < f_min < f_max, at least 2 points",
        )?;
        let frequency: Vec<f64> = (0..points)
            .map(|k| f_min * (f_max / f_min).powf(k as f64 / (points - 1) as f64))
            .collect();
        let twin_g = frequency
            .iter()
            .map(|&f| twin.modal.frequency_response(f))
            .collect();
        let lumped_g = frequency
            .iter()
            .map(|&f| lumped_response(lumped, f))
            .collect::<Result<Vec<_>>>()?;
        Ok(Bode {
            frequency,
            twin: twin_g,
            lumped: lumped_g,
        })
    }

    /// The data as named columns: `f_Hz`, then magnitude \[dB\] and phase \[deg\] of the eight
    /// entries (`twin_q1_x1_dB`, `twin_q1_x1_deg`, …, `lumped_q2_x2_deg`).
    pub fn columns(&self) -> (Vec<String>, Vec<Vec<f64>>) {
        let mut header = vec!["f_Hz".to_string()];
        let mut columns = vec![self.frequency.clone()];
        for (who, g) in [("twin", &self.twin), ("lumped", &self.lumped)] {
            for (i, j) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                let (m, p): (Vec<f64>, Vec<f64>) = g.iter().map(|g| mag_phase(g[i][j])).unzip();
                header.push(format!("{who}_q{}_x{}_dB", i + 1, j + 1));
                header.push(format!("{who}_q{}_x{}_deg", i + 1, j + 1));
                columns.push(m);
                columns.push(p);
            }
        }
        (header, columns)
    }

    /// The magnitude and phase figures (SVG) of the two axes, twin beside lumped.
    pub fn svg(&self) -> Result<[String; 2]> {
        let lf: Vec<f64> = self.frequency.iter().map(|f| f.log10()).collect();
        // Phases unwrapped along the frequency axis (no ±360° jumps in the figure).
        let series = |g: &[[[(f64, f64); 2]; 2]], axis: usize, phase: bool| -> Vec<(f64, f64)> {
            let mut last: Option<f64> = None;
            g.iter()
                .zip(&lf)
                .map(|(g, &x)| {
                    let (m, mut p) = mag_phase(axes(g)[axis]);
                    if let Some(l) = last {
                        p += 360.0 * ((l - p) / 360.0).round();
                    }
                    last = Some(p);
                    (x, if phase { p } else { m })
                })
                .collect()
        };
        let mut out = [String::new(), String::new()];
        for (k, phase) in [false, true].into_iter().enumerate() {
            let (title, unit) = if phase {
                (
                    "Phase from x_nom to q: twin and lumped model",
                    "phase [deg]",
                )
            } else {
                (
                    "Magnitude from x_nom to q: twin and lumped model",
                    "|q/x_nom| [dB]",
                )
            };
            // The legend sits lower left, where neither the flat static gain nor the falling
            // high-frequency magnitude and phase run.
            let fig = Figure::new(title, "frequency [Hz]", unit)
                .log10_x()
                .with_legend(Legend::LowerLeft)
                .with(Series::line(
                    "twin q1 (common x_nom)",
                    series(&self.twin, 0, phase),
                ))
                .with(Series::line(
                    "lumped q1 (common x_nom)",
                    series(&self.lumped, 0, phase),
                ))
                .with(Series::line(
                    "twin q2 (differential x_nom)",
                    series(&self.twin, 1, phase),
                ))
                .with(Series::line(
                    "lumped q2 (differential x_nom)",
                    series(&self.lumped, 1, phase),
                ));
            out[k] = fig.to_svg()?;
        }
        Ok(out)
    }
}

/// A summary of the twin's validity for the report: per case the largest error in % of
/// range per axis, the worst modal error, and the reference's cost.
pub fn validity_lines(v: &crate::reference::Validity) -> Vec<String> {
    let mut lines = Vec::new();
    let worst = v.modes.iter().map(|m| m.relative.abs()).fold(0.0, f64::max);
    lines.push(format!(
        "modes: {} claimed, largest difference to the FE modal analysis {:.3} %",
        v.modes.len(),
        100.0 * worst
    ));
    for c in &v.cases {
        let r = c.twin.relative();
        let l = c.linear_twin.relative();
        lines.push(format!(
            "{}: twin vs full nonlinear transient {:.3} % / {:.3} % of range (q1 / q2); linear \
             twin {:.3} % / {:.3} %; full model {} DOF, {} steps, {} Newton iterations, {:.1} s",
            c.name,
            100.0 * r[0],
            100.0 * r[1],
            100.0 * l[0],
            100.0 * l[1],
            c.cost.dofs,
            c.cost.steps,
            c.cost.iterations,
            c.cost.seconds
        ));
    }
    lines
}
