//! The response from any log by the H1 estimator ([`MeasuredResponse::from_log`]).

use flexstage_numerics::DataError;

use crate::error::{IdentifyError, Result, check};
use crate::frequency::C64;
use crate::measured::{LabLog, MeasuredLine, MeasuredResponse, dft_with, inverse, mul, twiddles};

/// Settings of the H1 estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WelchParams {
    /// Samples per segment (the line spacing is 1/(segment·T)), ≥ 16. Default 2000.
    pub segment: usize,
    /// Samples skipped at the start of the log (the transient). Default 0.
    pub skip: usize,
}

impl Default for WelchParams {
    fn default() -> Self {
        WelchParams {
            segment: 2000,
            skip: 0,
        }
    }
}

impl MeasuredResponse {
    /// The H1 estimate from any log in which both commands are excited independently over
    /// the band: Hann-windowed segments of `p.segment` samples with 50 % overlap, at every
    /// bin k = 1..segment/2 of the segment (f = k/(segment·T)), the sums over segments
    /// S_uu = Σ U Uᴴ, S_yu = Σ Y Uᴴ, S_yy,i = Σ |Y_i|², and `Ĥ = S_yu S_uu⁻¹` (the
    /// multiple-input H1; Bendat & Piersol, Random Data, 4th ed., Section 7.3).
    ///
    /// The coherence of entry (i, j) is output i's multiple coherence
    /// `γ²_i = (Ĥ S_uy)_ii / S_yy,i`. The standard deviation is that of the per-bin linear
    /// regression `Y_i = H_i· U + E` over the n_d segments:
    /// `std²_ij = (1 − γ²_i) S_yy,i / (n_d − 2) · [S_uu⁻¹]_jj`, the residual variance times
    /// the inverse input power (the 50 % overlap of Hann segments makes neighbouring segments
    /// slightly correlated, so this is a little optimistic). Leakage of a non-periodic input
    /// biases lines at sharp resonances; the periodic multisine
    /// ([`MeasuredResponse::from_multisine`]) has none.
    pub fn from_log(log: &LabLog, p: &WelchParams) -> Result<MeasuredResponse> {
        check(
            "welch.segment",
            p.segment as f64,
            p.segment >= 16,
            "≥ 16 samples",
        )?;
        let l = p.segment;
        let hop = l / 2;
        let usable = log.len().saturating_sub(p.skip);
        let segments = if usable >= l {
            (usable - l) / hop + 1
        } else {
            0
        };
        if segments < 4 {
            return Err(IdentifyError::Data(DataError::new(
                "log",
                format!(
                    "{} samples after skipping {} hold {segments} segments of {l}; H1 needs at \
                     least 4",
                    log.len(),
                    p.skip
                ),
            )));
        }
        let tw = twiddles(l);
        let window: Vec<f64> = (0..l)
            .map(|m| 0.5 - 0.5 * (std::f64::consts::TAU * m as f64 / l as f64).cos())
            .collect();
        let bins = l.div_ceil(2) - 1;
        let zero = C64::new(0.0, 0.0);
        let mut suu = vec![[[zero; 2]; 2]; bins];
        let mut syu = vec![[[zero; 2]; 2]; bins];
        let mut syy = vec![[0.0; 2]; bins];
        let mut buf = vec![vec![0.0; l]; 4];
        for s in 0..segments {
            let at = p.skip + s * hop;
            let ch = [
                &log.command()[0],
                &log.command()[1],
                &log.reading()[0],
                &log.reading()[1],
            ];
            for (b, x) in buf.iter_mut().zip(ch) {
                let mean = x[at..at + l].iter().sum::<f64>() / l as f64;
                for m in 0..l {
                    b[m] = (x[at + m] - mean) * window[m];
                }
            }
            for k in 0..bins {
                let [u0, u1, y0, y1] = [0, 1, 2, 3].map(|c| dft_with(&buf[c], k + 1, &tw));
                let (u, y) = ([u0, u1], [y0, y1]);
                for i in 0..2 {
                    for j in 0..2 {
                        suu[k][i][j] += u[i] * u[j].conj();
                        syu[k][i][j] += y[i] * u[j].conj();
                    }
                    syy[k][i] += y[i].norm_sqr();
                }
            }
        }
        let nd = segments as f64;
        let ts = log.sample_time();
        let mut lines = Vec::with_capacity(bins);
        for k in 0..bins {
            let f = (k + 1) as f64 / (l as f64 * ts);
            let Some(si) = inverse(suu[k]) else {
                return Err(IdentifyError::Data(DataError::new(
                    "log",
                    format!(
                        "the two commands are not independently excited at {f} Hz: H1 needs \
                         both inputs driven by uncorrelated signals"
                    ),
                )));
            };
            let h = mul(syu[k], si);
            let mut line = MeasuredLine {
                f,
                h,
                coherence: [[1.0; 2]; 2],
                std: [[0.0; 2]; 2],
            };
            for i in 0..2 {
                // (Ĥ S_uy)_ii with S_uy = S_yuᴴ.
                let explained = (h[i][0] * syu[k][i][0].conj() + h[i][1] * syu[k][i][1].conj()).re;
                let gamma = if syy[k][i] > 0.0 {
                    (explained / syy[k][i]).clamp(0.0, 1.0)
                } else {
                    1.0
                };
                let residual = ((1.0 - gamma) * syy[k][i]).max(0.0);
                for j in 0..2 {
                    line.coherence[i][j] = gamma;
                    line.std[i][j] = (residual / (nd - 2.0) * si[j][j].re.max(0.0)).sqrt();
                }
            }
            lines.push(line);
        }
        MeasuredResponse::new(ts, lines)
    }
}
