//! Lowest natural frequencies of the body-fitted model, `K φ = ω² M φ`, by the project's one
//! modal solver, [`flexstage_fem::eigen`] (shift-invert Lanczos), on the T6 model's own
//! matrices and Cholesky factor.

use flexstage_fem::{EigenError, EigenOperators, Lanczos, LanczosParams, SolverError};

use crate::error::{Result, VerifyError};
use crate::fe::{Cholesky, SymCsc};

/// Natural frequencies \[Hz\] (lowest first) and the relative residual `‖Kφ − ω²Mφ‖/‖Kφ‖` of
/// each mode.
#[derive(Debug, Clone, PartialEq)]
pub struct Frequencies {
    /// `f = ω / 2π` \[Hz\].
    pub hz: Vec<f64>,
    /// Residuals.
    pub residuals: Vec<f64>,
}

/// The body-fitted model's `K` (with its factor) and `M`.
struct Operators<'a> {
    k: &'a SymCsc,
    factor: &'a Cholesky,
    m: &'a SymCsc,
}

impl EigenOperators for Operators<'_> {
    fn n(&self) -> usize {
        self.k.n()
    }
    fn solve(&mut self, x: &mut [f64]) -> std::result::Result<(), SolverError> {
        self.factor.solve_in_place(x, 1);
        Ok(())
    }
    fn mass(&self, x: &[f64], y: &mut [f64]) {
        self.m.matvec(x, y);
    }
    fn stiffness(&self, x: &[f64], y: &mut [f64]) {
        self.k.matvec(x, y);
    }
}

/// The `modes` lowest frequencies of `(K, M)` with `K = factor` (positive definite).
pub fn lowest_frequencies(
    k: &SymCsc,
    factor: &Cholesky,
    m: &SymCsc,
    modes: usize,
) -> Result<Frequencies> {
    let nev = modes.clamp(1, 50);
    let params = LanczosParams {
        modes: nev,
        max_steps: (20 * nev + 40).min(5000),
        ..LanczosParams::default()
    };
    let pairs = Lanczos::new()
        .solve(&mut Operators { k, factor, m }, &params)
        .map_err(|e| match e {
            EigenError::NotConverged {
                wanted,
                converged,
                steps,
            } => VerifyError::Eigen {
                wanted,
                converged,
                steps,
            },
            EigenError::ZeroMass => VerifyError::Solver("the mass matrix is zero".into()),
            other => VerifyError::Solver(other.to_string()),
        })?;
    Ok(Frequencies {
        hz: pairs.frequencies(),
        residuals: pairs.residuals,
    })
}
