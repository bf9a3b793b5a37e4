//! The lowest eigenpairs of a symmetric generalized eigenproblem `K φ = λ M φ` (`K` positive
//! definite, `M` positive semi-definite): the one modal solver of flexstage, used by the design
//! loop (`flexstage-topopt`), the reduced model (`flexstage-reduce`), the body-fitted
//! verification (`flexstage-verify`) and the digital twin.
//!
//! # Algorithm
//! **Shift-invert Lanczos** with shift σ = 0 (Ericsson & Ruhe, *Math. Comp.* 35 (1980)
//! 1251–1268; Grimes, Lewis & Simon, *SIAM J. Matrix Anal. Appl.* 15 (1994) 228–272): the
//! Lanczos recurrence on `K⁻¹M`, which is self-adjoint in the `M` inner product, so its
//! largest eigenvalues `θ = 1/λ` (the lowest `λ`) converge first. Every step is one solve with
//! a factorization of `K` (the caller's, through [`EigenOperators::solve`]) and one `M`
//! mat-vec:
//!
//! ```text
//! w = K⁻¹M q_j − α_j q_j − β_{j−1} q_{j−1},   α_j = q_jᵀ M K⁻¹M q_j,   β_j = ‖w‖_M,
//! q_{j+1} = w / β_j
//! ```
//!
//! The basis is fully reorthogonalized (twice, classical Gram–Schmidt in the `M` inner
//! product), which is cheap for the few modes wanted and keeps spurious copies of converged
//! Ritz values out. The eigenvalues `θ` of the tridiagonal matrix `T_m = tridiag(β, α, β)` come
//! from nalgebra's symmetric QR algorithm (`flexstage_numerics::dense::symmetric_eigen`). A
//! Ritz pair `(θ_i, Q s_i)` is accepted when the Lanczos residual bound
//! `|β_m s_mi| ≤ tol·θ_i` holds (the residual of `K⁻¹M φ = θ φ` in the `M` norm); the reported
//! residual `‖Kφ − λMφ‖/‖Kφ‖` is recomputed from the mode shape.
//!
//! `M` may be singular (massless void nodes, Du & Olhoff's interpolation): the start vector
//! `q₀ ∝ K⁻¹M r₀` lies in the range of `K⁻¹M`, so the infinite eigenvalues (`θ = 0`) stay out.
//! The pseudo-random `r₀` comes from SplitMix64 (`flexstage_numerics::noise`), so a result is
//! reproducible for its seed on every platform.
//!
//! The buffers of the basis are kept in a [`Lanczos`] workspace between calls, so a design
//! loop that solves one eigenproblem per iteration allocates nothing once the basis has grown
//! to its size.

use flexstage_numerics::dense::{dot, symmetric_eigen};
use flexstage_numerics::noise::SplitMix64;
use thiserror::Error;

use crate::error::{ParamError, SolverError, check_range};

/// The operators of `K φ = λ M φ` that shift-invert Lanczos needs, on vectors of length
/// [`EigenOperators::n`] (e.g. the free DOFs of a model).
pub trait EigenOperators {
    /// Order `n`.
    fn n(&self) -> usize;
    /// `x ← K⁻¹ x`.
    fn solve(&mut self, x: &mut [f64]) -> Result<(), SolverError>;
    /// `y = M x`.
    fn mass(&self, x: &[f64], y: &mut [f64]);
    /// `y = K x` (for the residuals of the modes).
    fn stiffness(&self, x: &[f64], y: &mut [f64]);
}

/// Parameters of [`Lanczos::solve`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LanczosParams {
    /// Number of eigenpairs wanted, in [1, 50] (fewer when `n` is smaller). Default 6.
    pub modes: usize,
    /// Convergence tolerance of the Lanczos residual bound (relative), in [1e-14, 1e-3].
    /// Default 1e-10.
    pub tolerance: f64,
    /// Maximum Lanczos steps, in [10, 5000] (at most `n`). Default 400.
    pub max_steps: usize,
    /// Seed of the start vector.
    pub seed: u64,
    /// Test for convergence every this many steps, in [1, 100] (each test is an eigen-solve of
    /// the small tridiagonal matrix). Default 5; 1 stops at the first step that converges.
    pub check_every: usize,
}

impl Default for LanczosParams {
    fn default() -> Self {
        Self {
            modes: 6,
            tolerance: 1e-10,
            max_steps: 400,
            seed: 7,
            check_every: 5,
        }
    }
}

impl LanczosParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_range(
            "LanczosParams::modes",
            self.modes as f64,
            1.0,
            50.0,
            "[1, 50]",
        )?;
        check_range(
            "LanczosParams::tolerance",
            self.tolerance,
            1e-14,
            1e-3,
            "[1e-14, 1e-3]",
        )?;
        check_range(
            "LanczosParams::max_steps",
            self.max_steps as f64,
            10.0,
            5000.0,
            "[10, 5000]",
        )?;
        check_range(
            "LanczosParams::check_every",
            self.check_every as f64,
            1.0,
            100.0,
            "[1, 100]",
        )
    }
}

/// Why the eigenproblem was not solved.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum EigenError {
    /// A parameter is out of range.
    #[error(transparent)]
    Params(#[from] ParamError),
    /// A solve with `K` failed.
    #[error(transparent)]
    Solver(#[from] SolverError),
    /// `M r₀ = 0`: the mass matrix is zero on every free DOF.
    #[error("the mass matrix is zero on the free DOFs")]
    ZeroMass,
    /// Not every wanted eigenpair met the tolerance within the allowed steps.
    #[error(
        "{converged} of {wanted} eigenpairs converged in {steps} Lanczos steps (raise \
         `max_steps`, accepted range [10, 5000])"
    )]
    NotConverged {
        /// Eigenpairs wanted.
        wanted: usize,
        /// Eigenpairs converged.
        converged: usize,
        /// Steps taken.
        steps: usize,
    },
}

/// The lowest eigenpairs, lowest first.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Eigenpairs {
    /// Eigenvalues `λ` (`ω²` [rad²/s²] for a structure).
    pub values: Vec<f64>,
    /// Eigenvectors, `φᵀMφ = 1`, of length `n`.
    pub vectors: Vec<Vec<f64>>,
    /// `‖Kφ − λMφ‖ / ‖Kφ‖` of each pair.
    pub residuals: Vec<f64>,
    /// Lanczos steps taken.
    pub steps: usize,
}

impl Eigenpairs {
    /// The natural frequencies `√λ / 2π` \[Hz\].
    pub fn frequencies(&self) -> Vec<f64> {
        self.values
            .iter()
            .map(|l| l.sqrt() / (2.0 * std::f64::consts::PI))
            .collect()
    }
}

/// The converged Ritz values `θ = 1/λ` and vectors `s` (row-major `m × m`, column `i` for
/// `θ_i`) of the `m`-step Lanczos tridiagonal matrix.
struct Ritz {
    theta: Vec<f64>,
    s: Vec<f64>,
    m: usize,
}

impl Ritz {
    /// Indices of the Ritz values, largest θ (lowest λ) first.
    fn order(&self) -> Vec<usize> {
        let mut order: Vec<usize> = (0..self.m).collect();
        order.sort_by(|&x, &y| self.theta[y].total_cmp(&self.theta[x]));
        order
    }
}

/// The shift-invert Lanczos solver and its buffers (module docs): the `M`-orthonormal basis
/// `q` (and `M q`) with the tridiagonal coefficients α and β. Keep one between calls to reuse
/// its storage.
#[derive(Debug, Clone, Default)]
pub struct Lanczos {
    /// Basis vectors; the first `len` are in use (the rest are storage kept for reuse).
    q: Vec<Vec<f64>>,
    mq: Vec<Vec<f64>>,
    len: usize,
    alphas: Vec<f64>,
    betas: Vec<f64>,
    /// Scratch: the next vector and `M` times it.
    w: Vec<f64>,
    mw: Vec<f64>,
}

impl Lanczos {
    /// An empty solver (buffers grow on first use).
    pub fn new() -> Self {
        Self::default()
    }

    /// The `params.modes` lowest eigenpairs of the operators (module docs).
    pub fn solve(
        &mut self,
        op: &mut impl EigenOperators,
        params: &LanczosParams,
    ) -> Result<Eigenpairs, EigenError> {
        params.validate()?;
        let nev = params.modes.min(op.n());
        self.start(op, params.seed)?;
        let ritz = self.run(op, nev, params)?;
        Ok(self.pairs(op, &ritz, nev))
    }

    /// Takes basis slot `j` (allocated on first use) with length `n`.
    fn slot(v: &mut Vec<Vec<f64>>, j: usize, n: usize) -> &mut Vec<f64> {
        if v.len() <= j {
            v.resize_with(j + 1, Vec::new);
        }
        let s = &mut v[j];
        s.resize(n, 0.0);
        s
    }

    /// The first basis vector `q₀ ∝ K⁻¹M r₀` (in the range of `K⁻¹M`, so that the infinite
    /// eigenvalues of a singular `M` stay out), `r₀` pseudo-random from `seed`.
    fn start(&mut self, op: &mut impl EigenOperators, seed: u64) -> Result<(), EigenError> {
        let n = op.n();
        let mut rng = SplitMix64::new(seed ^ 0x5DEE_CE66);
        let r0 = Self::slot(&mut self.q, 0, n);
        r0.iter_mut().for_each(|x| *x = rng.next_f64() - 0.5);
        self.w.resize(n, 0.0);
        self.mw.resize(n, 0.0);
        op.mass(&self.q[0], &mut self.w);
        op.solve(&mut self.w)?;
        op.mass(&self.w, &mut self.mw);
        let b0 = dot(&self.w, &self.mw).sqrt();
        if b0.is_nan() || b0 <= 0.0 {
            return Err(EigenError::ZeroMass);
        }
        let (w, mw) = (&self.w, &self.mw);
        Self::slot(&mut self.q, 0, n)
            .iter_mut()
            .zip(w)
            .for_each(|(q, x)| *q = x / b0);
        Self::slot(&mut self.mq, 0, n)
            .iter_mut()
            .zip(mw)
            .for_each(|(q, x)| *q = x / b0);
        self.len = 1;
        self.alphas.clear();
        self.betas.clear();
        Ok(())
    }

    /// Lanczos steps until the `nev` largest Ritz values pass the residual bound
    /// `|β_j s_ji| ≤ tol·θ_i` (checked every `check_every` steps), the Krylov space is
    /// exhausted or `max_steps` is reached.
    fn run(
        &mut self,
        op: &mut impl EigenOperators,
        nev: usize,
        params: &LanczosParams,
    ) -> Result<Ritz, EigenError> {
        let max_steps = params.max_steps.min(op.n());
        let mut n_conv = 0;
        for j in 0..max_steps {
            let (a, b) = self.step(j, op)?;
            let m = j + 1;
            let exhausted = b <= 1e-14 * a.abs();
            if m >= nev && (m % params.check_every == 0 || m == max_steps || exhausted) {
                let ritz = self.ritz(m);
                n_conv = ritz.order()[..nev]
                    .iter()
                    .filter(|&&i| {
                        (b * ritz.s[(m - 1) * m + i]).abs()
                            <= params.tolerance * ritz.theta[i].abs()
                    })
                    .count();
                if n_conv == nev || exhausted || m == max_steps {
                    if n_conv < nev {
                        break;
                    }
                    return Ok(ritz);
                }
            }
            if b <= 0.0 {
                break;
            }
            self.extend(b);
        }
        Err(EigenError::NotConverged {
            wanted: nev,
            converged: n_conv,
            steps: self.alphas.len(),
        })
    }

    /// Step `j`: `w = K⁻¹M q_j − α_j q_j − β_{j−1} q_{j−1}`, fully reorthogonalized (twice,
    /// classical Gram–Schmidt in the M inner product); returns α_j and β_j = ‖w‖_M.
    fn step(&mut self, j: usize, op: &mut impl EigenOperators) -> Result<(f64, f64), EigenError> {
        let w = &mut self.w;
        w.copy_from_slice(&self.mq[j]);
        op.solve(w)?;
        let a = dot(&self.mq[j], w);
        self.alphas.push(a);
        for (wi, qi) in w.iter_mut().zip(&self.q[j]) {
            *wi -= a * qi;
        }
        if j > 0 {
            let b = self.betas[j - 1];
            for (wi, qi) in w.iter_mut().zip(&self.q[j - 1]) {
                *wi -= b * qi;
            }
        }
        for _ in 0..2 {
            for (qi, mqi) in self.q[..self.len].iter().zip(&self.mq[..self.len]) {
                let c = dot(mqi, w);
                for (wk, qk) in w.iter_mut().zip(qi) {
                    *wk -= c * qk;
                }
            }
        }
        op.mass(w, &mut self.mw);
        Ok((a, dot(w, &self.mw).max(0.0).sqrt()))
    }

    /// Appends `q_{j+1} = w/β_j` (and `M q_{j+1}`).
    fn extend(&mut self, b: f64) {
        self.betas.push(b);
        let (j, n) = (self.len, self.w.len());
        let (w, mw) = (&self.w, &self.mw);
        Self::slot(&mut self.q, j, n)
            .iter_mut()
            .zip(w)
            .for_each(|(q, x)| *q = x / b);
        Self::slot(&mut self.mq, j, n)
            .iter_mut()
            .zip(mw)
            .for_each(|(q, x)| *q = x / b);
        self.len += 1;
    }

    /// Eigen-decomposition of the leading `m × m` tridiagonal matrix.
    fn ritz(&self, m: usize) -> Ritz {
        let mut t = vec![0.0; m * m];
        for i in 0..m {
            t[i * m + i] = self.alphas[i];
            if i + 1 < m {
                t[i * m + i + 1] = self.betas[i];
                t[(i + 1) * m + i] = self.betas[i];
            }
        }
        let (theta, s) = symmetric_eigen(&t, m);
        Ritz { theta, s, m }
    }

    /// The `nev` lowest pairs from the Ritz pairs: `φ = Q s` normalized to `φᵀMφ = 1`,
    /// `λ = 1/θ`, and the residual `‖Kφ − λMφ‖/‖Kφ‖` recomputed from the shape.
    fn pairs(&mut self, op: &mut impl EigenOperators, ritz: &Ritz, nev: usize) -> Eigenpairs {
        let (n, m) = (op.n(), ritz.m);
        let mut out = Eigenpairs {
            steps: m,
            ..Eigenpairs::default()
        };
        let mw = &mut self.mw;
        let mut kphi = vec![0.0; n];
        for &i in &ritz.order()[..nev] {
            let mut phi = vec![0.0; n];
            for (jj, qj) in self.q.iter().take(m).enumerate() {
                let c = ritz.s[jj * m + i];
                for (p, qv) in phi.iter_mut().zip(qj) {
                    *p += c * qv;
                }
            }
            op.mass(&phi, mw);
            let nrm = dot(&phi, mw).sqrt();
            phi.iter_mut().for_each(|x| *x /= nrm);
            mw.iter_mut().for_each(|x| *x /= nrm);
            let lambda = 1.0 / ritz.theta[i];
            op.stiffness(&phi, &mut kphi);
            let res = kphi
                .iter()
                .zip(mw.iter())
                .map(|(a, b)| (a - lambda * b).powi(2))
                .sum::<f64>()
                .sqrt()
                / dot(&kphi, &kphi).sqrt();
            out.values.push(lambda);
            out.vectors.push(phi);
            out.residuals.push(res);
        }
        out
    }
}

/// Springs added to or taken off a factored stiffness: `K_s = K + V C Vᵀ`, one column `v_j`
/// per spring (its DOF combination, a single DOF for a grounded spring) and `C = diag(k_j)`
/// (negative to take a spring off). `K_s⁻¹` is applied through the factor of `K` by the
/// Woodbury identity (e.g. Golub & Van Loan, *Matrix Computations*, 4th ed., 2013, §2.1.4),
///
/// ```text
/// K_s⁻¹ x = K⁻¹x − Z (C⁻¹ + VᵀZ)⁻¹ Vᵀ K⁻¹x,   Z = K⁻¹V,
/// ```
///
/// so an eigenproblem of a stage that differs from a factored design model by a few springs
/// reuses that model's factorization: [`SpringUpdate::refactor`] costs one solve per spring,
/// and each solve after it one solve with `K` and `O(n·r)` more.
#[derive(Debug, Clone, Default)]
pub struct SpringUpdate {
    /// Per spring: its terms (reduced index, coefficient) and its signed stiffness.
    springs: Vec<(Vec<(usize, f64)>, f64)>,
    /// `Z = K⁻¹V`, column-major `n × r`.
    z: Vec<f64>,
    /// `(C⁻¹ + VᵀZ)⁻¹`, row-major `r × r`.
    s_inv: Vec<f64>,
    /// Scratch of length `r`.
    t: Vec<f64>,
}

impl SpringUpdate {
    /// The update by `springs` (`LinkSpring` with signed stiffness: negative takes a spring
    /// off) on the free DOFs of `dofs`; terms on fixed DOFs and springs without a free term or
    /// with zero stiffness drop out.
    pub fn new(dofs: &crate::DofMap, springs: &[crate::LinkSpring]) -> Self {
        let springs = springs
            .iter()
            .filter(|s| s.stiffness != 0.0)
            .map(|s| {
                let terms: Vec<(usize, f64)> = s
                    .terms
                    .iter()
                    .filter_map(|&(d, c)| dofs.reduced(d).map(|r| (r, c)))
                    .collect();
                (terms, s.stiffness)
            })
            .filter(|(t, _)| !t.is_empty())
            .collect::<Vec<_>>();
        let r = springs.len();
        Self {
            springs,
            t: vec![0.0; r],
            ..Self::default()
        }
    }

    /// Number of springs `r`.
    pub fn rank(&self) -> usize {
        self.springs.len()
    }

    /// `Vᵀx` into `self.t`.
    fn project(&mut self, x: &[f64]) {
        for (t, (terms, _)) in self.t.iter_mut().zip(&self.springs) {
            *t = terms.iter().map(|&(i, c)| c * x[i]).sum();
        }
    }

    /// Prepares `Z` and the capacitance inverse for the current factor of `K` (once per
    /// factorization).
    pub fn refactor(
        &mut self,
        factor: &crate::Factor,
        ws: &mut crate::SolveWorkspace,
    ) -> Result<(), SolverError> {
        let (n, r) = (factor.symbolic().n(), self.springs.len());
        self.z.clear();
        self.z.resize(n * r, 0.0);
        for (j, (terms, _)) in self.springs.iter().enumerate() {
            let col = &mut self.z[j * n..(j + 1) * n];
            for &(i, c) in terms {
                col[i] += c;
            }
            factor.solve_in_place(col, ws)?;
        }
        let s = nalgebra::DMatrix::from_fn(r, r, |a, b| {
            let vz: f64 = self.springs[a]
                .0
                .iter()
                .map(|&(i, c)| c * self.z[b * n + i])
                .sum();
            vz + if a == b { 1.0 / self.springs[a].1 } else { 0.0 }
        });
        let inv = s.try_inverse().ok_or(SolverError::SingularUpdate)?;
        if inv.iter().any(|v| !v.is_finite()) {
            return Err(SolverError::SingularUpdate);
        }
        self.s_inv = (0..r * r).map(|k| inv[(k / r, k % r)]).collect();
        Ok(())
    }

    /// `x ← K_s⁻¹ x` with the factor of `K` that [`SpringUpdate::refactor`] saw.
    pub fn solve(
        &mut self,
        factor: &crate::Factor,
        x: &mut [f64],
        ws: &mut crate::SolveWorkspace,
    ) -> Result<(), SolverError> {
        factor.solve_in_place(x, ws)?;
        let (n, r) = (x.len(), self.springs.len());
        if r == 0 {
            return Ok(());
        }
        self.project(x);
        for a in 0..r {
            let y: f64 = (0..r).map(|b| self.s_inv[a * r + b] * self.t[b]).sum();
            for (xi, zi) in x.iter_mut().zip(&self.z[a * n..(a + 1) * n]) {
                *xi -= y * zi;
            }
        }
        Ok(())
    }

    /// `y += V C Vᵀ x` (the springs' part of `K_s x`).
    pub fn add_product(&self, x: &[f64], y: &mut [f64]) {
        for (terms, k) in &self.springs {
            let t: f64 = terms.iter().map(|&(i, c)| c * x[i]).sum();
            for &(i, c) in terms {
                y[i] += k * t * c;
            }
        }
    }
}
