//! Textbook linear-systems helpers in the style of python-control: [`expm`], [`c2d`] (zero-order
//! hold), [`lyap`], [`dlyap`], [`poles`], [`spectral_radius`].
//!
//! They work on `nalgebra` dynamic matrices; the sizes here are small (≤ 64 × 64 for the
//! vectorized Lyapunov solve), so clarity wins over speed. None of them is used inside the
//! real-time step: the controller precomputes its fixed-size matrices at construction.

use nalgebra::{Complex, DMatrix};

use flexstage_numerics::RangeError;

use crate::error::{Result, SimError};

/// The matrix exponential e^A (scaling and squaring with a Padé approximant, nalgebra's
/// implementation). Tested against closed forms in `tests/linalg.rs`.
pub fn expm(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    square(a, "expm")?;
    Ok(a.clone().exp())
}

/// Zero-order-hold discretization of ẋ = A x + B u with sample time `t`:
/// x_{k+1} = Φ x_k + Γ u_k with Φ = e^{A t}, Γ = ∫₀ᵗ e^{A s} ds B.
///
/// Computed exactly with one exponential of the augmented matrix
/// `[[A, B], [0, 0]]·t` = `[[Φ, Γ], [0, I]]` (Van Loan), as python-control's
/// `c2d(sys, t, "zoh")`. Returns (Φ, Γ).
pub fn c2d(a: &DMatrix<f64>, b: &DMatrix<f64>, t: f64) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
    let n = square(a, "c2d")?;
    if b.nrows() != n {
        return Err(SimError::Dimension {
            what: "c2d".into(),
            detail: format!("A is {n}×{n}, B has {} rows", b.nrows()),
        });
    }
    if !(t > 0.0 && t.is_finite()) {
        return Err(RangeError::number("sample time", t, "a finite number > 0").into());
    }
    let m = b.ncols();
    let mut aug = DMatrix::zeros(n + m, n + m);
    aug.view_mut((0, 0), (n, n)).copy_from(&(a * t));
    aug.view_mut((0, n), (n, m)).copy_from(&(b * t));
    let e = aug.exp();
    Ok((
        e.view((0, 0), (n, n)).into_owned(),
        e.view((0, n), (n, m)).into_owned(),
    ))
}

/// Solves the continuous Lyapunov equation A X + X Aᵀ + Q = 0 (python-control's
/// `lyap(A, Q)`) by the vectorized (Kronecker) linear system (I ⊗ A + A ⊗ I) vec X = −vec Q.
///
/// Eq. (39), P B0 + B0ᵀ P = −I, is `lyap(B0ᵀ, I)`. Unique when no two eigenvalues of A sum to
/// zero (in particular when A is Hurwitz).
pub fn lyap(a: &DMatrix<f64>, q: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = square(a, "lyap")?;
    same_size(q, n, "lyap")?;
    let eye = DMatrix::<f64>::identity(n, n);
    let k = eye.kronecker(a) + a.kronecker(&eye);
    solve_vec(k, q, n, "lyap: I ⊗ A + A ⊗ I")
}

/// Solves the discrete Lyapunov equation A X Aᵀ − X + Q = 0 (python-control's `dlyap(A, Q)`)
/// by (A ⊗ A − I) vec X = −vec Q. Unique when no product of two eigenvalues of A equals 1.
pub fn dlyap(a: &DMatrix<f64>, q: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = square(a, "dlyap")?;
    same_size(q, n, "dlyap")?;
    let k = a.kronecker(a) - DMatrix::<f64>::identity(n * n, n * n);
    solve_vec(k, q, n, "dlyap: A ⊗ A − I")
}

/// Eigenvalues of a square matrix (real Schur decomposition): the poles of ẋ = A x or of
/// x_{k+1} = A x_k.
pub fn poles(a: &DMatrix<f64>) -> Result<Vec<Complex<f64>>> {
    square(a, "poles")?;
    if a.iter().any(|v| !v.is_finite()) {
        return Err(SimError::Dimension {
            what: "poles".into(),
            detail: "the matrix has non-finite entries".into(),
        });
    }
    Ok(a.clone().complex_eigenvalues().iter().copied().collect())
}

/// max |λ| over the eigenvalues of A (< 1 ⇔ x_{k+1} = A x_k is asymptotically stable).
pub fn spectral_radius(a: &DMatrix<f64>) -> Result<f64> {
    Ok(poles(a)?.iter().map(|z| z.norm()).fold(0.0, f64::max))
}

/// max Re λ over the eigenvalues of A (< 0 ⇔ A is Hurwitz).
pub fn spectral_abscissa(a: &DMatrix<f64>) -> Result<f64> {
    Ok(poles(a)?
        .iter()
        .map(|z| z.re)
        .fold(f64::NEG_INFINITY, f64::max))
}

/// True when the symmetric part of P is positive definite (Cholesky succeeds).
pub fn is_positive_definite(p: &DMatrix<f64>) -> bool {
    if p.nrows() != p.ncols() {
        return false;
    }
    let sym = (p + p.transpose()) * 0.5;
    sym.cholesky().is_some()
}

fn square(a: &DMatrix<f64>, what: &str) -> Result<usize> {
    if a.nrows() == a.ncols() && a.nrows() > 0 {
        Ok(a.nrows())
    } else {
        Err(SimError::Dimension {
            what: what.into(),
            detail: format!(
                "expected a non-empty square matrix, got {}×{}",
                a.nrows(),
                a.ncols()
            ),
        })
    }
}

fn same_size(q: &DMatrix<f64>, n: usize, what: &str) -> Result<()> {
    if q.nrows() == n && q.ncols() == n {
        Ok(())
    } else {
        Err(SimError::Dimension {
            what: what.into(),
            detail: format!("A is {n}×{n}, Q is {}×{}", q.nrows(), q.ncols()),
        })
    }
}

fn solve_vec(k: DMatrix<f64>, q: &DMatrix<f64>, n: usize, what: &str) -> Result<DMatrix<f64>> {
    // Column-major vec: nalgebra stores matrices column by column.
    let rhs = DMatrix::from_column_slice(n * n, 1, (-q).as_slice());
    let x = k
        .lu()
        .solve(&rhs)
        .ok_or_else(|| SimError::Singular { what: what.into() })?;
    if x.iter().any(|v| !v.is_finite()) {
        return Err(SimError::Singular { what: what.into() });
    }
    Ok(DMatrix::from_column_slice(n, n, x.as_slice()))
}
