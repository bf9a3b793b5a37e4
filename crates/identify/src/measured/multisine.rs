//! The response from two periodic multisine logs ([`MeasuredResponse::from_multisine`]).

use flexstage_numerics::DataError;

use crate::error::{IdentifyError, Result};
use crate::frequency::C64;
use crate::measured::{
    LabLog, MeasuredLine, MeasuredResponse, MultisinePlan, dft_with, inverse, mul, twiddles,
};

impl MeasuredResponse {
    /// The response from the two experiments of `plan` (`logs[j]`: input j driven,
    /// [`MultisinePlan::commands`]), each logged from its first command on.
    ///
    /// Per measured period p (after `plan.settle`), at every line, the spectra of both
    /// experiments form U_p = \[U_0,p U_1,p\] (the commands, 2 × 2) and Y_p (the readings);
    /// `H_p = Y_p U_p⁻¹` (any two independent experiments work, not only one input at a
    /// time). The estimate is the mean over the P periods, its standard deviation the
    /// spread of the H_p over √P (`std² = Σ|H_p − Ĥ|²/(P(P − 1))`; Pintelon & Schoukens,
    /// System Identification: A Frequency Domain Approach, 2nd ed., Section 2.4), and the
    /// coherence `|Ĥ|² / mean|H_p|²`, the share of the per-period power that repeats from
    /// period to period (1 when the spread is 0).
    pub fn from_multisine(logs: [&LabLog; 2], plan: &MultisinePlan) -> Result<MeasuredResponse> {
        plan.validate()?;
        let n = plan.period;
        let need = (plan.settle + plan.periods) * n;
        for (j, log) in logs.iter().enumerate() {
            let rel = (log.sample_time() / plan.sample_time - 1.0).abs();
            if rel > 1e-9 || log.len() < need {
                return Err(IdentifyError::Data(DataError::new(
                    format!("multisine log {}", j + 1),
                    format!(
                        "{} samples at {} s; the plan plays {need} samples at {} s",
                        log.len(),
                        log.sample_time(),
                        plan.sample_time
                    ),
                )));
            }
        }
        let tw = twiddles(n);
        let p_count = plan.periods;
        // spectra[e][p][line] = (U (2), Y (2)) of experiment e, period p.
        let spectra: Vec<Vec<Vec<[C64; 4]>>> = logs
            .iter()
            .map(|log| {
                (0..p_count)
                    .map(|p| {
                        let at = (plan.settle + p) * n;
                        let ch = [
                            &log.command()[0][at..at + n],
                            &log.command()[1][at..at + n],
                            &log.reading()[0][at..at + n],
                            &log.reading()[1][at..at + n],
                        ];
                        plan.lines
                            .iter()
                            .map(|&k| ch.map(|x| dft_with(x, k, &tw)))
                            .collect()
                    })
                    .collect()
            })
            .collect();
        let mut lines = Vec::with_capacity(plan.lines.len());
        for (l, &k) in plan.lines.iter().enumerate() {
            let mut hs = Vec::with_capacity(p_count);
            for p in 0..p_count {
                let (a, b) = (spectra[0][p][l], spectra[1][p][l]);
                let u = [[a[0], b[0]], [a[1], b[1]]];
                let y = [[a[2], b[2]], [a[3], b[3]]];
                let Some(ui) = inverse(u) else {
                    return Err(IdentifyError::Data(DataError::new(
                        "multisine logs",
                        format!(
                            "the commands of the two experiments are not independent at {} Hz \
                             (period {p}): each line needs both inputs excited",
                            plan.frequency(k)
                        ),
                    )));
                };
                hs.push(mul(y, ui));
            }
            lines.push(period_statistics(plan.frequency(k), &hs));
        }
        MeasuredResponse::new(plan.sample_time, lines)
    }
}

/// Mean, standard deviation of the mean and coherence of per-period estimates.
pub(crate) fn period_statistics(f: f64, hs: &[[[C64; 2]; 2]]) -> MeasuredLine {
    let p = hs.len() as f64;
    let mut line = MeasuredLine {
        f,
        h: [[C64::new(0.0, 0.0); 2]; 2],
        coherence: [[1.0; 2]; 2],
        std: [[0.0; 2]; 2],
    };
    for i in 0..2 {
        for j in 0..2 {
            let mean = hs.iter().map(|h| h[i][j]).sum::<C64>() / p;
            let spread: f64 = hs.iter().map(|h| (h[i][j] - mean).norm_sqr()).sum();
            let power: f64 = hs.iter().map(|h| h[i][j].norm_sqr()).sum::<f64>() / p;
            line.h[i][j] = mean;
            line.std[i][j] = (spread / (p * (p - 1.0))).sqrt();
            if spread > 0.0 && power > 0.0 {
                line.coherence[i][j] = (mean.norm_sqr() / power).clamp(0.0, 1.0);
            }
        }
    }
    line
}
