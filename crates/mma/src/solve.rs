//! A simple driver loop around [`Mma`].

use crate::error::MmaError;
use crate::kkt::KktResidual;
use crate::mma::Mma;
use crate::params::MmaParams;

/// A problem `min f₀(x)` s.t. `fᵢ(x) ≤ 0` that can evaluate values and gradients.
pub trait Problem {
    /// Number of variables.
    fn n(&self) -> usize;
    /// Number of constraints.
    fn m(&self) -> usize;
    /// Writes `∇f₀` (length n), `f` (length m) and `∂fᵢ/∂xⱼ` into `dfdx[i * n + j]`
    /// (m × n row-major); returns `f₀(x)`.
    fn evaluate(&self, x: &[f64], df0dx: &mut [f64], f: &mut [f64], dfdx: &mut [f64]) -> f64;
}

/// When [`minimize`] stops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StopCriteria {
    /// Largest number of MMA updates.
    pub max_iterations: usize,
    /// Stop when the KKT residual norm ([`crate::kkt_residual`]) falls below this.
    pub kkt_tolerance: f64,
}

impl Default for StopCriteria {
    fn default() -> Self {
        Self {
            max_iterations: 500,
            kkt_tolerance: 1e-6,
        }
    }
}

/// Result of [`minimize`].
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// Final iterate.
    pub x: Vec<f64>,
    /// `f₀(x)`.
    pub f0: f64,
    /// `fᵢ(x)`.
    pub f: Vec<f64>,
    /// Multipliers λ of the last subproblem.
    pub lambda: Vec<f64>,
    /// MMA updates done.
    pub iterations: usize,
    /// KKT residual at `x` (infinite if no update was done).
    pub kkt: KktResidual,
    /// Whether `kkt.norm <= kkt_tolerance`.
    pub converged: bool,
}

/// Runs MMA from `x0` until the KKT residual norm is below `stop.kkt_tolerance` or
/// `stop.max_iterations` updates are done.
///
/// # Errors
/// Any [`MmaError`] from [`Mma::new`] or [`Mma::update`] (e.g. `x0` outside the bounds or a
/// non-finite gradient).
pub fn minimize<P: Problem + ?Sized>(
    problem: &P,
    x0: &[f64],
    xmin: Vec<f64>,
    xmax: Vec<f64>,
    params: MmaParams,
    stop: StopCriteria,
) -> Result<Solution, MmaError> {
    let (n, m) = (problem.n(), problem.m());
    let mut mma = Mma::new(n, m, xmin, xmax, params)?;
    if x0.len() != n {
        return Err(MmaError::DimensionMismatch {
            name: "x0",
            expected: n,
            got: x0.len(),
        });
    }
    let mut x = x0.to_vec();
    let mut df0dx = vec![0.0; n];
    let mut f = vec![0.0; m];
    let mut dfdx = vec![0.0; m * n];
    let mut f0 = problem.evaluate(&x, &mut df0dx, &mut f, &mut dfdx);
    let mut kkt = KktResidual {
        norm: f64::INFINITY,
        max: f64::INFINITY,
    };
    let mut iterations = 0;
    while iterations < stop.max_iterations {
        mma.update(&mut x, f0, &df0dx, &f, &dfdx)?;
        iterations += 1;
        f0 = problem.evaluate(&x, &mut df0dx, &mut f, &mut dfdx);
        kkt = mma.kkt_residual(&x, &df0dx, &f, &dfdx)?;
        if kkt.norm <= stop.kkt_tolerance {
            break;
        }
    }
    Ok(Solution {
        x,
        f0,
        f,
        lambda: mma.lambda().to_vec(),
        iterations,
        converged: kkt.norm <= stop.kkt_tolerance,
        kkt,
    })
}
