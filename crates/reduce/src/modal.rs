//! Modal analysis: the lowest natural frequencies and mode shapes of a design,
//! `K φ = ω² M φ`, to check Assumption 2 (design resonance ≫ input frequency).
//!
//! `K` is the model's stiffness at the undeformed state (material stiffness, supports and
//! grounded springs — the PEAs hold the stage, Eq. 2–3) and `M` the mass matrix of
//! [`crate::mass`]. The solver is **shift-invert Lanczos** (σ = 0) on `K⁻¹M`, self-adjoint in
//! the `M` inner product: every step is one solve with the sparse Cholesky factor of `K`
//! (faer low-level API through [`flexstage_fem::Factor`], factored once) and one `M` mat-vec;
//! the Lanczos basis is fully reorthogonalized (twice, classical Gram–Schmidt in the `M` inner
//! product), which is cheap for the few modes needed. The eigenvalues `θ = 1/ω²` of the
//! tridiagonal matrix come from cyclic Jacobi rotations. A Ritz pair is accepted when the
//! Lanczos residual bound `|β_j s_ji| ≤ tol·θ_i`; the reported residual
//! `‖Kφ − ω²Mφ‖/‖Kφ‖` is recomputed from the mode shape. `M` may be singular (massless void
//! nodes): the start vector is taken in the range of `K⁻¹M`, so infinite eigenvalues stay out.

use flexstage_fem::{Design, Factor, Model, SolveWorkspace, SymbolicFactor};

use crate::error::{ReduceError, Result, check};
use crate::mass::{MassInterpolation, MassLumping, MassMatrix, PointMass};

/// Parameters of the modal analysis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModalParams {
    /// Number of modes, in [1, 50]. Default 6.
    pub modes: usize,
    /// Consistent or lumped mass. Default consistent.
    pub lumping: MassLumping,
    /// Density → mass interpolation. Default `ρ_c = 0.1`, `q = 6`.
    pub interpolation: MassInterpolation,
    /// Convergence tolerance of the Lanczos residual bound (relative), in [1e-14, 1e-3].
    /// Default 1e-10.
    pub tolerance: f64,
    /// Maximum Lanczos steps, in [10, 5000]. Default 400.
    pub max_steps: usize,
    /// Seed of the start vector.
    pub seed: u64,
}

impl Default for ModalParams {
    fn default() -> Self {
        Self {
            modes: 6,
            lumping: MassLumping::Consistent,
            interpolation: MassInterpolation::default(),
            tolerance: 1e-10,
            max_steps: 400,
            seed: 7,
        }
    }
}

impl ModalParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        check(
            "ModalParams::modes",
            self.modes as f64,
            (1..=50).contains(&self.modes),
            "[1, 50]",
        )?;
        check(
            "ModalParams::tolerance",
            self.tolerance,
            (1e-14..=1e-3).contains(&self.tolerance),
            "[1e-14, 1e-3]",
        )?;
        check(
            "ModalParams::max_steps",
            self.max_steps as f64,
            (10..=5000).contains(&self.max_steps),
            "[10, 5000]",
        )?;
        self.interpolation.validate()
    }
}

/// Natural frequencies and mode shapes, lowest first.
#[derive(Debug, Clone, PartialEq)]
pub struct Modes {
    /// `ω²` [rad²/s²].
    pub omega2: Vec<f64>,
    /// `f = ω/2π` [Hz].
    pub frequencies: Vec<f64>,
    /// Mode shapes as full displacement vectors, `φᵀMφ = 1`.
    pub shapes: Vec<Vec<f64>>,
    /// `‖Kφ − ω²Mφ‖ / ‖Kφ‖` of each mode.
    pub residuals: Vec<f64>,
    /// Lanczos steps taken.
    pub steps: usize,
    /// Total mass in the mass matrix [kg].
    pub total_mass: f64,
}

/// Splitmix64: a small deterministic generator for the start vector.
fn splitmix(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64 - 0.5
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Eigen-decomposition of a small symmetric matrix (row-major `n×n`) by cyclic Jacobi:
/// returns eigenvalues and eigenvectors (column `k` of the row-major `v`), unsorted.
pub fn jacobi_eigen(a: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut a = a.to_vec();
    let mut v = vec![0.0; n * n];
    for i in 0..n {
        v[i * n + i] = 1.0;
    }
    for _sweep in 0..100 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i * n + j] * a[i * n + j])
            .sum();
        let diag: f64 = (0..n).map(|i| a[i * n + i] * a[i * n + i]).sum();
        if off <= 1e-30 * diag || off == 0.0 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[p * n + q];
                if apq.abs() <= 1e-300 {
                    continue;
                }
                let (app, aqq) = (a[p * n + p], a[q * n + q]);
                let tau = (aqq - app) / (2.0 * apq);
                let t = tau.signum() / (tau.abs() + (1.0 + tau * tau).sqrt());
                let t = if tau == 0.0 { 1.0 } else { t };
                let c = 1.0 / (1.0 + t * t).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (akp, akq) = (a[k * n + p], a[k * n + q]);
                    a[k * n + p] = c * akp - s * akq;
                    a[k * n + q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[p * n + k], a[q * n + k]);
                    a[p * n + k] = c * apk - s * aqk;
                    a[q * n + k] = s * apk + c * aqk;
                }
                for k in 0..n {
                    let (vkp, vkq) = (v[k * n + p], v[k * n + q]);
                    v[k * n + p] = c * vkp - s * vkq;
                    v[k * n + q] = s * vkp + c * vkq;
                }
            }
        }
    }
    ((0..n).map(|i| a[i * n + i]).collect(), v)
}

/// The lowest `params.modes` natural frequencies and mode shapes of `model` with densities
/// `rho`, material density `density` [kg/m³] and point masses (module docs).
pub fn modal_analysis(
    model: &Model,
    rho: &[f64],
    density: f64,
    point_masses: &[PointMass],
    params: &ModalParams,
) -> Result<Modes> {
    params.validate()?;
    let design = Design::new(rho);
    design.validate(model.mesh().n_elements())?;
    let mass = MassMatrix::assemble(
        model,
        rho,
        density,
        params.interpolation,
        params.lumping,
        point_masses,
    )?;
    let mut k = model.new_matrix();
    let zero = model.zero_vector();
    let mut aws = model.new_workspace();
    model.assemble(&design, &zero, None, Some(&mut k), &mut aws);
    let symbolic = SymbolicFactor::for_model(model)?;
    let mut factor = Factor::new(symbolic.clone());
    factor.allow_indefinite = false;
    factor.factorize(&k)?;
    let mut sws = SolveWorkspace::new(&symbolic);
    let n = mass.n();
    let nev = params.modes.min(n);
    let max_steps = params.max_steps.min(n);

    // Start vector in range(K⁻¹M).
    let mut seed = params.seed ^ 0x5DEE_CE66;
    let r0: Vec<f64> = (0..n).map(|_| splitmix(&mut seed)).collect();
    let mut w = vec![0.0; n];
    mass.matvec(&r0, &mut w);
    factor.solve_in_place(&mut w, &mut sws)?;
    let mut mw = vec![0.0; n];
    mass.matvec(&w, &mut mw);
    let b0 = dot(&w, &mw).sqrt();
    if b0.is_nan() || b0 <= 0.0 {
        return Err(ReduceError::Input(
            "the mass matrix is zero on the free DOFs".into(),
        ));
    }
    let mut q: Vec<Vec<f64>> = vec![w.iter().map(|x| x / b0).collect()];
    let mut mq: Vec<Vec<f64>> = vec![mw.iter().map(|x| x / b0).collect()];
    let mut alphas: Vec<f64> = Vec::new();
    let mut betas: Vec<f64> = Vec::new();
    let mut converged: Option<(Vec<f64>, Vec<f64>, usize)> = None;
    let mut n_conv = 0;
    for j in 0..max_steps {
        // w = K⁻¹ M q_j
        w.copy_from_slice(&mq[j]);
        factor.solve_in_place(&mut w, &mut sws)?;
        let a = dot(&mq[j], &w);
        alphas.push(a);
        for (wi, qi) in w.iter_mut().zip(&q[j]) {
            *wi -= a * qi;
        }
        if j > 0 {
            let b = betas[j - 1];
            for (wi, qi) in w.iter_mut().zip(&q[j - 1]) {
                *wi -= b * qi;
            }
        }
        for _ in 0..2 {
            for (qi, mqi) in q.iter().zip(&mq) {
                let c = dot(mqi, &w);
                for (wk, qk) in w.iter_mut().zip(qi) {
                    *wk -= c * qk;
                }
            }
        }
        mass.matvec(&w, &mut mw);
        let b = dot(&w, &mw).max(0.0).sqrt();
        let m = j + 1;
        let check_now = m >= nev && (m % 5 == 0 || m == max_steps || b <= 1e-14 * a.abs());
        if check_now {
            let mut t = vec![0.0; m * m];
            for i in 0..m {
                t[i * m + i] = alphas[i];
                if i + 1 < m {
                    t[i * m + i + 1] = betas[i];
                    t[(i + 1) * m + i] = betas[i];
                }
            }
            let (theta, s) = jacobi_eigen(&t, m);
            let mut order: Vec<usize> = (0..m).collect();
            order.sort_by(|&x, &y| theta[y].total_cmp(&theta[x]));
            let ok = order[..nev]
                .iter()
                .filter(|&&i| (b * s[(m - 1) * m + i]).abs() <= params.tolerance * theta[i].abs())
                .count();
            n_conv = ok;
            if ok == nev || b <= 1e-14 * a.abs() || m == max_steps {
                converged = Some((theta, s, m));
                break;
            }
        }
        if b <= 0.0 {
            break;
        }
        betas.push(b);
        q.push(w.iter().map(|x| x / b).collect());
        mq.push(mw.iter().map(|x| x / b).collect());
    }
    let Some((theta, s, m)) = converged else {
        return Err(ReduceError::Eigen {
            wanted: nev,
            converged: n_conv,
            steps: alphas.len(),
        });
    };
    if n_conv < nev {
        return Err(ReduceError::Eigen {
            wanted: nev,
            converged: n_conv,
            steps: m,
        });
    }
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&x, &y| theta[y].total_cmp(&theta[x]));
    let dofs = model.dofs();
    let mut out = Modes {
        omega2: Vec::new(),
        frequencies: Vec::new(),
        shapes: Vec::new(),
        residuals: Vec::new(),
        steps: m,
        total_mass: mass.total_mass(),
    };
    let mut kphi = vec![0.0; n];
    for &i in &order[..nev] {
        let mut phi = vec![0.0; n];
        for (jj, qj) in q.iter().take(m).enumerate() {
            let c = s[jj * m + i];
            for (p, qv) in phi.iter_mut().zip(qj) {
                *p += c * qv;
            }
        }
        mass.matvec(&phi, &mut mw);
        let nrm = dot(&phi, &mw).sqrt();
        phi.iter_mut().for_each(|x| *x /= nrm);
        mw.iter_mut().for_each(|x| *x /= nrm);
        let om2 = 1.0 / theta[i];
        k.matvec(&phi, &mut kphi);
        let res = kphi
            .iter()
            .zip(&mw)
            .map(|(a, b)| (a - om2 * b).powi(2))
            .sum::<f64>()
            .sqrt()
            / dot(&kphi, &kphi).sqrt();
        let mut full = model.zero_vector();
        dofs.scatter(&phi, &mut full);
        out.omega2.push(om2);
        out.frequencies
            .push(om2.sqrt() / (2.0 * std::f64::consts::PI));
        out.shapes.push(full);
        out.residuals.push(res);
    }
    Ok(out)
}
