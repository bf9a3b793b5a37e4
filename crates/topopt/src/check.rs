//! Central finite-difference check of the adjoint gradients (`flexstage design
//! --check-gradients` and the gradient tests): every response of every realization.

use flexstage_fem::AdditiveYeoh;

use crate::analysis::AnalysisParams;
use crate::error::Result;
use crate::problem::Problem;
use crate::realization::{DesignEvaluator, Evaluation, RobustThresholds};
use crate::responses::ResponseKind;

/// The density chain under test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CheckSetup {
    /// Filter radius in element sizes.
    pub filter_radius: f64,
    /// Robust thresholds (None: the blueprint alone).
    pub robust: Option<RobustThresholds>,
    /// Blueprint threshold η.
    pub eta: f64,
    /// Projection sharpness β (0: none).
    pub beta: f64,
}

/// Result of the check for one response of one realization.
#[derive(Debug, Clone, PartialEq)]
pub struct GradientCheck {
    /// `realization: response`.
    pub name: String,
    /// `max_j |g_adj,j − g_fd,j| / max_j |g_adj,j|` over the checked variables.
    pub relative_error: f64,
    /// `max_j |g_adj,j|` over the checked variables.
    pub scale: f64,
    /// Variables checked.
    pub checked: usize,
}

/// Every evaluated (realization, response) value of an evaluation, in a fixed order.
fn values(e: &Evaluation) -> Vec<(String, f64, Option<&[f64]>)> {
    e.realizations
        .iter()
        .flat_map(|r| {
            ResponseKind::ALL.into_iter().filter_map(move |q| {
                r.gradients[q].as_ref().map(|g| {
                    (
                        format!("{}: {}", r.kind.name(), q.name()),
                        r.values[q],
                        Some(g.as_slice()),
                    )
                })
            })
        })
        .collect()
}

/// Compares the adjoint gradients with central differences (step `h`) of `variables` design
/// variables (evenly spread) at the design `x`, with tight Newton tolerances and direct solves.
pub fn check_gradients(
    problem: &Problem,
    setup: &CheckSetup,
    yeoh: Option<&AdditiveYeoh>,
    x: &[f64],
    variables: usize,
    h: f64,
) -> Result<Vec<GradientCheck>> {
    let evaluator = || {
        DesignEvaluator::new(
            problem,
            setup.filter_radius,
            setup.robust,
            setup.eta,
            AnalysisParams::tight(),
        )
    };
    let (_, base) = evaluator()?.evaluate(x, setup.beta, yeoh)?;
    let base = values(&base);
    let n = x.len();
    let step = (n / variables.max(1)).max(1);
    let picks: Vec<usize> = (0..n).step_by(step).take(variables).collect();
    let mut fd = vec![vec![0.0; picks.len()]; base.len()];
    for (c, &j) in picks.iter().enumerate() {
        let at = |dx: f64| -> Result<Vec<f64>> {
            let mut xp = x.to_vec();
            xp[j] += dx;
            let (_, e) = evaluator()?.evaluate(&xp, setup.beta, yeoh)?;
            Ok(values(&e).into_iter().map(|(_, v, _)| v).collect())
        };
        let (vp, vm) = (at(h)?, at(-h)?);
        for (q, f) in fd.iter_mut().enumerate() {
            f[c] = (vp[q] - vm[q]) / (2.0 * h);
        }
    }
    Ok(base
        .iter()
        .zip(&fd)
        .map(|((name, _, g), fdq)| {
            let g = g.expect("gradient");
            let scale = picks.iter().map(|&j| g[j].abs()).fold(0.0, f64::max);
            let err = picks
                .iter()
                .zip(fdq)
                .map(|(&j, f)| (g[j] - f).abs())
                .fold(0.0, f64::max);
            GradientCheck {
                name: name.clone(),
                relative_error: if scale > 0.0 { err / scale } else { err },
                scale,
                checked: picks.len(),
            }
        })
        .collect())
}
