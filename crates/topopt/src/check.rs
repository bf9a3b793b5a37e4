//! Central finite-difference check of the adjoint gradients (`flexstage design
//! --check-gradients`).

use flexstage_fem::AdditiveYeoh;

use crate::analysis::{AnalysisParams, Evaluator};
use crate::error::Result;
use crate::filter::Projection;
use crate::problem::Problem;

/// Names of the checked responses, in [`crate::Evaluation::gradients`] order.
pub const RESPONSES: [&str; 5] = [
    "objective",
    "strain energy",
    "input stroke",
    "tilt",
    "volume",
];

/// Result of the check for one response.
#[derive(Debug, Clone, PartialEq)]
pub struct GradientCheck {
    /// Response name.
    pub name: &'static str,
    /// `max_j |g_adj,j − g_fd,j| / max_j |g_adj,j|` over the checked variables.
    pub relative_error: f64,
    /// `max_j |g_adj,j|` over the checked variables.
    pub scale: f64,
    /// Variables checked.
    pub checked: usize,
}

/// Compares the adjoint gradients with central differences (step `h`) of `variables` design
/// variables (evenly spread) at the design `x`, with tight Newton tolerances and direct solves.
pub fn check_gradients(
    problem: &Problem,
    filter_radius: f64,
    proj: Projection,
    yeoh: Option<&AdditiveYeoh>,
    x: &[f64],
    variables: usize,
    h: f64,
) -> Result<Vec<GradientCheck>> {
    let mut ev = Evaluator::new(problem, filter_radius, AnalysisParams::tight())?;
    let (_, base) = ev.evaluate(x, proj, yeoh)?;
    let n = x.len();
    let step = (n / variables.max(1)).max(1);
    let picks: Vec<usize> = (0..n).step_by(step).take(variables).collect();
    let mut fd = vec![vec![0.0; picks.len()]; 5];
    let values = |e: &crate::Evaluation| [e.objective, e.energy, e.stroke, e.tilt, e.volume];
    for (c, &j) in picks.iter().enumerate() {
        let mut xp = x.to_vec();
        xp[j] += h;
        // Fresh warm starts would differ only at solver tolerance; keep the same start.
        let mut evp = Evaluator::new(problem, filter_radius, AnalysisParams::tight())?;
        let (_, ep) = evp.evaluate(&xp, proj, yeoh)?;
        let mut xm = x.to_vec();
        xm[j] -= h;
        let mut evm = Evaluator::new(problem, filter_radius, AnalysisParams::tight())?;
        let (_, em) = evm.evaluate(&xm, proj, yeoh)?;
        let (vp, vm) = (values(&ep), values(&em));
        for q in 0..5 {
            fd[q][c] = (vp[q] - vm[q]) / (2.0 * h);
        }
    }
    Ok((0..5)
        .filter(|&q| q != 3 || problem.tilt.is_some())
        .filter(|&q| q != 2 || problem.max_stroke.is_some())
        .map(|q| {
            let g = &base.gradients[q];
            let scale = picks.iter().map(|&j| g[j].abs()).fold(0.0, f64::max);
            let err = picks
                .iter()
                .enumerate()
                .map(|(c, &j)| (g[j] - fd[q][c]).abs())
                .fold(0.0, f64::max);
            GradientCheck {
                name: RESPONSES[q],
                relative_error: if scale > 0.0 { err / scale } else { err },
                scale,
                checked: picks.len(),
            }
        })
        .collect())
}
