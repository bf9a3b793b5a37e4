//! KKT residual of the original problem (`kktcheck` of Svanberg's MMA distribution).

use crate::error::MmaError;
use crate::input::{check_finite, check_len};
use crate::params::MmaParams;

/// Multipliers of an MMA subproblem, borrowed from [`crate::Mma::multipliers`].
///
/// In the notation of Svanberg's note: λ for the constraints, (y, z) the artificial
/// variables, μ and ζ the multipliers of `y ≥ 0`, `z ≥ 0`, s the slacks of the constraints,
/// ξ and η the multipliers of the lower and upper bounds on x.
#[derive(Debug, Clone, Copy)]
pub struct Multipliers<'a> {
    /// λ (length m).
    pub lam: &'a [f64],
    /// y (length m).
    pub y: &'a [f64],
    /// z.
    pub z: f64,
    /// μ (length m).
    pub mu: &'a [f64],
    /// ζ.
    pub zet: f64,
    /// s (length m).
    pub s: &'a [f64],
    /// ξ (length n).
    pub xsi: &'a [f64],
    /// η (length n).
    pub eta: &'a [f64],
}

/// The original problem at a point: iterate, bounds, gradients and constraint values.
#[derive(Debug, Clone, Copy)]
pub struct KktProblem<'a> {
    /// x (length n).
    pub x: &'a [f64],
    /// Lower bounds (length n).
    pub xmin: &'a [f64],
    /// Upper bounds (length n).
    pub xmax: &'a [f64],
    /// ∇f₀ (length n).
    pub df0dx: &'a [f64],
    /// fᵢ(x) (length m).
    pub f: &'a [f64],
    /// ∂fᵢ/∂xⱼ, m × n row-major.
    pub dfdx: &'a [f64],
}

/// Euclidean and max norms of the KKT residual vector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KktResidual {
    /// ‖r‖₂.
    pub norm: f64,
    /// ‖r‖∞.
    pub max: f64,
}

/// KKT residual of the problem with artificial variables (Svanberg's `kktcheck`):
///
/// ```text
/// r_x   = ∇f₀ + Σᵢ λᵢ ∇fᵢ − ξ + η          r_ξ = ξ ∘ (x − xmin)
/// r_y   = c + d ∘ y − μ − λ                  r_η = η ∘ (xmax − x)
/// r_z   = a₀ − ζ − aᵀλ                       r_μ = μ ∘ y
/// r_λ   = f − a z − y + s                    r_ζ = ζ z,   r_s = λ ∘ s
/// ```
///
/// All multipliers are non-negative by construction, so `r = 0` is exactly the KKT
/// conditions. The vector has 3n + 4m + 2 entries.
///
/// # Errors
/// [`MmaError::DimensionMismatch`] naming the slice whose length disagrees with
/// `n = problem.x.len()` and `m = problem.f.len()`; [`MmaError::NonFinite`] for
/// non-finite gradients or constraint values.
pub fn kkt_residual(
    problem: &KktProblem<'_>,
    mult: &Multipliers<'_>,
    params: &MmaParams,
) -> Result<KktResidual, MmaError> {
    let n = problem.x.len();
    let m = problem.f.len();
    let lens: [(&'static str, &[f64], usize); 10] = [
        ("xmin", problem.xmin, n),
        ("xmax", problem.xmax, n),
        ("df0dx", problem.df0dx, n),
        ("dfdx", problem.dfdx, m * n),
        ("lam", mult.lam, m),
        ("y", mult.y, m),
        ("mu", mult.mu, m),
        ("s", mult.s, m),
        ("xsi", mult.xsi, n),
        ("eta", mult.eta, n),
    ];
    for (name, slice, expected) in lens {
        check_len(name, slice, expected)?;
    }
    check_finite("df0dx", problem.df0dx, false)?;
    check_finite("f", problem.f, false)?;
    check_finite("dfdx", problem.dfdx, false)?;

    let mut sum = 0.0f64;
    let mut mx = 0.0f64;
    let mut add = |r: f64| {
        sum += r * r;
        mx = mx.max(r.abs());
    };
    for j in 0..n {
        let mut rex = problem.df0dx[j] - mult.xsi[j] + mult.eta[j];
        for i in 0..m {
            rex += problem.dfdx[i * n + j] * mult.lam[i];
        }
        add(rex);
        add(mult.xsi[j] * (problem.x[j] - problem.xmin[j]));
        add(mult.eta[j] * (problem.xmax[j] - problem.x[j]));
    }
    let mut alam = 0.0;
    for i in 0..m {
        alam += params.a * mult.lam[i];
        add(params.c + params.d * mult.y[i] - mult.mu[i] - mult.lam[i]);
        add(problem.f[i] - params.a * mult.z - mult.y[i] + mult.s[i]);
        add(mult.mu[i] * mult.y[i]);
        add(mult.lam[i] * mult.s[i]);
    }
    add(params.a0 - mult.zet - alam);
    add(mult.zet * mult.z);
    Ok(KktResidual {
        norm: sum.sqrt(),
        max: mx,
    })
}
