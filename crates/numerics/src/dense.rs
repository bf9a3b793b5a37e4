//! Small dense linear algebra: the workspace's one library for it is
//! [nalgebra](https://nalgebra.org) (fixed-size matrices on the stack for 2–8 states, `no_std`
//! capable with `libm`), re-exported here as [`nalgebra`]; sparse finite-element work stays
//! on faer.
//!
//! This module adds what the stage crates need on top of nalgebra's decompositions:
//!
//! * [`SpdFactor`]: the Cholesky factor of a symmetric positive definite matrix after
//!   symmetric diagonal equilibration, with a rank test relative to the diagonal, for
//!   normal equations whose columns differ in scale by many orders of magnitude (the summed
//!   Bouc–Wen regression of `flexstage-piezo`); [`solve_spd`] for one right-hand side. It is
//!   written out on arrays, not on nalgebra: it sits in a 10 kHz loop where that measured
//!   faster (its docs).
//! * [`symmetric_eigen`]: eigenvalues and eigenvectors of a small symmetric matrix (the
//!   Lanczos tridiagonal matrix of `flexstage-reduce`'s modal analysis);
//! * [`dot`]: the dot product of two slices (available without the `dense` feature).
//!
//! All work on `[f64; P]` arrays or row-major slices at the boundary, so that callers keep
//! their plain-array data layout; nothing but [`symmetric_eigen`] allocates.

// Small dense matrix code reads best with explicit indices.
#![allow(clippy::needless_range_loop)]

#[cfg(feature = "dense")]
pub use nalgebra;

#[cfg(feature = "dense")]
use nalgebra::DMatrix;

/// `Σ aᵢ bᵢ` over the common length, summed in order.
#[inline]
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The equilibrated Cholesky factor of a symmetric positive definite matrix A:
/// D A D = L Lᵀ with D = diag(A)^{-1/2}, so A⁻¹ b = D (L Lᵀ)⁻¹ D b. Columns of very
/// different scale then do not matter. No allocation.
///
/// Written out on `[f64; P]` arrays rather than on nalgebra's `Cholesky`: it runs twice per
/// sample in the parallel RLS of `flexstage-piezo` (a 5 × 5 factor and two solves), where the
/// unrolled loops measured 140 ns against 190 ns for nalgebra's (fastest of 3 divan runs;
/// see `docs/DECISIONS.md`, Numerics).
#[derive(Debug, Clone, Copy)]
pub struct SpdFactor<const P: usize> {
    /// Lower Cholesky factor of D A D.
    l: [[f64; P]; P],
    /// D = diag(A)^{-1/2}.
    s: [f64; P],
}

/// Smallest accepted pivot of the equilibrated factorization (unit diagonal): a smaller one
/// means that a column is, to this relative precision, a combination of the others.
pub const SPD_MIN_PIVOT: f64 = 1e-13;

impl<const P: usize> SpdFactor<P> {
    /// Factors A (only its lower triangle is read); `None` when A is not numerically positive
    /// definite: a non-positive or non-finite diagonal, or an equilibrated pivot below
    /// [`SPD_MIN_PIVOT`].
    #[inline]
    pub fn new(a: &[[f64; P]; P]) -> Option<Self> {
        let mut s = [0.0; P];
        for i in 0..P {
            if a[i][i].is_nan() || a[i][i] <= 0.0 || !a[i][i].is_finite() {
                return None;
            }
            s[i] = a[i][i].sqrt().recip();
        }
        let mut l = [[0.0; P]; P];
        for j in 0..P {
            let mut d: f64 = 1.0;
            for k in 0..j {
                d -= l[j][k] * l[j][k];
            }
            if d.is_nan() || d <= SPD_MIN_PIVOT {
                return None;
            }
            let d = d.sqrt();
            l[j][j] = d;
            let inv = d.recip();
            for i in j + 1..P {
                let mut v = a[i][j] * s[i] * s[j];
                for k in 0..j {
                    v -= l[i][k] * l[j][k];
                }
                l[i][j] = v * inv;
            }
        }
        Some(SpdFactor { l, s })
    }

    /// Solves A x = b.
    #[inline]
    pub fn solve(&self, b: &[f64; P]) -> [f64; P] {
        let sb: [f64; P] = std::array::from_fn(|i| b[i] * self.s[i]);
        let z = cholesky_solve(&self.l, &sb);
        std::array::from_fn(|i| z[i] * self.s[i])
    }
}

/// Solves L Lᵀ x = b with L lower triangular (forward, then back substitution).
#[inline]
fn cholesky_solve<const P: usize>(l: &[[f64; P]; P], b: &[f64; P]) -> [f64; P] {
    let mut y = [0.0; P];
    for i in 0..P {
        let mut v = b[i];
        for k in 0..i {
            v -= l[i][k] * y[k];
        }
        y[i] = v / l[i][i];
    }
    let mut x = [0.0; P];
    for i in (0..P).rev() {
        let mut v = y[i];
        for k in i + 1..P {
            v -= l[k][i] * x[k];
        }
        x[i] = v / l[i][i];
    }
    x
}

/// Solves the symmetric positive definite system A x = b through [`SpdFactor`]; `None` when
/// A is not numerically positive definite.
pub fn solve_spd<const P: usize>(a: &[[f64; P]; P], b: &[f64; P]) -> Option<[f64; P]> {
    SpdFactor::new(a).map(|f| f.solve(b))
}

#[cfg(feature = "dense")]
/// Eigenvalues and eigenvectors of the symmetric `n × n` matrix `a` (row-major; only its lower
/// triangle is read), by nalgebra's symmetric QR algorithm. Returns the eigenvalues, unsorted,
/// and the eigenvectors as the columns of a row-major `n × n` matrix (`v[i * n + k]` is entry
/// `i` of eigenvector `k`).
///
/// # Panics
/// When `a.len() != n * n`.
pub fn symmetric_eigen(a: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    assert_eq!(
        a.len(),
        n * n,
        "symmetric_eigen: {} entries for n = {n}",
        a.len()
    );
    // Row-major lower triangle = column-major upper triangle: read as the transpose.
    let m = DMatrix::from_fn(
        n,
        n,
        |i, j| if i >= j { a[i * n + j] } else { a[j * n + i] },
    );
    let eig = m.symmetric_eigen();
    let mut v = vec![0.0; n * n];
    for i in 0..n {
        for k in 0..n {
            v[i * n + k] = eig.eigenvectors[(i, k)];
        }
    }
    (eig.eigenvalues.iter().copied().collect(), v)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference: the Hilbert-like matrix A = D H D with H the 4×4 Hilbert matrix and
    /// D = diag(1, 1e4, 1e-4, 1e8), whose columns span sixteen orders of magnitude; x = D⁻¹ y
    /// with y the solution of H y = D⁻¹ b. Goal: equilibration makes the solve as accurate
    /// as for H itself (relative residual ≤ 1e-12), and singular or indefinite matrices are
    /// refused.
    #[test]
    fn spd_factor_solves_badly_scaled_normal_equations() {
        let d = [1.0, 1e4, 1e-4, 1e8];
        let mut a = [[0.0; 4]; 4];
        for i in 0..4 {
            for j in 0..4 {
                a[i][j] = d[i] * d[j] / (i + j + 1) as f64;
            }
        }
        let x_true = [1.0, -2e-4, 3e4, -4e-8];
        let b: [f64; 4] = std::array::from_fn(|i| (0..4).map(|j| a[i][j] * x_true[j]).sum());
        let x = solve_spd(&a, &b).expect("SPD");
        for i in 0..4 {
            let rel = (x[i] / x_true[i] - 1.0).abs();
            assert!(rel < 1e-10, "x[{i}] = {:e}, want {:e}", x[i], x_true[i]);
        }
        assert!(solve_spd(&[[1.0, 1.0], [1.0, 1.0]], &[1.0, 1.0]).is_none());
        assert!(solve_spd(&[[1.0, 2.0], [2.0, 1.0]], &[1.0, 1.0]).is_none());
        assert!(solve_spd(&[[0.0, 0.0], [0.0, 1.0]], &[1.0, 1.0]).is_none());
        assert!(solve_spd(&[[f64::NAN, 0.0], [0.0, 1.0]], &[1.0, 1.0]).is_none());
    }

    /// Reference: the path-graph Laplacian tridiag(−1, 2, −1) of order n, whose eigenvalues are
    /// 2 − 2 cos(kπ/(n+1)), k = 1..n, with eigenvectors sin(jkπ/(n+1)). Goal: eigenvalues to
    /// 1e-13 and A v = λ v for every returned pair.
    #[cfg(feature = "dense")]
    #[test]
    fn symmetric_eigen_matches_the_path_laplacian() {
        let n = 12;
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            a[i * n + i] = 2.0;
            if i + 1 < n {
                a[i * n + i + 1] = -1.0;
                a[(i + 1) * n + i] = -1.0;
            }
        }
        let (lam, v) = symmetric_eigen(&a, n);
        let mut got = lam.clone();
        got.sort_by(f64::total_cmp);
        for (k, g) in got.iter().enumerate() {
            let want = 2.0 - 2.0 * ((k + 1) as f64 * std::f64::consts::PI / (n + 1) as f64).cos();
            assert!((g - want).abs() < 1e-13, "λ{k} = {g}, want {want}");
        }
        for (k, l) in lam.iter().enumerate() {
            for i in 0..n {
                let av: f64 = (0..n).map(|j| a[i * n + j] * v[j * n + k]).sum();
                assert!((av - l * v[i * n + k]).abs() < 1e-13);
            }
        }
    }
}
