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
//! tridiagonal matrix come from nalgebra's symmetric QR algorithm
//! ([`flexstage_numerics::dense::symmetric_eigen`]). A Ritz pair is accepted when the
//! Lanczos residual bound `|β_j s_ji| ≤ tol·θ_i`; the reported residual
//! `‖Kφ − ω²Mφ‖/‖Kφ‖` is recomputed from the mode shape. `M` may be singular (massless void
//! nodes): the start vector is taken in the range of `K⁻¹M`, so infinite eigenvalues stay out.

use flexstage_fem::{Design, Factor, Model, SolveWorkspace, SparseMatrix, SymbolicFactor};
use flexstage_numerics::dense::{dot, symmetric_eigen};
use flexstage_numerics::noise::SplitMix64;

use crate::error::{ReduceError, Result, count, within};
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
        count("ModalParams::modes", self.modes, 1, 50)?;
        within("ModalParams::tolerance", self.tolerance, 1e-14, 1e-3)?;
        count("ModalParams::max_steps", self.max_steps, 10, 5000)?;
        self.interpolation.validate()
    }
}

/// Natural frequencies and mode shapes, lowest first.
#[derive(Debug, Clone, PartialEq)]
pub struct Modes {
    /// `ω²` [rad²/s²].
    pub omega2: Vec<f64>,
    /// `f = ω/2π` \[Hz\].
    pub frequencies: Vec<f64>,
    /// Mode shapes as full displacement vectors, `φᵀMφ = 1`.
    pub shapes: Vec<Vec<f64>>,
    /// `‖Kφ − ω²Mφ‖ / ‖Kφ‖` of each mode.
    pub residuals: Vec<f64>,
    /// Lanczos steps taken.
    pub steps: usize,
    /// Total mass in the mass matrix \[kg\].
    pub total_mass: f64,
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
    let mut stiffness = Stiffness::factor(model, &design)?;
    let nev = params.modes.min(mass.n());
    let mut lanczos = Lanczos::start(&mass, &mut stiffness, params.seed)?;
    let ritz = lanczos.run(&mass, &mut stiffness, nev, params)?;
    Ok(lanczos.modes(model, &mass, &stiffness.k, &ritz, nev))
}

/// K at the undeformed state and its sparse Cholesky factor: `K⁻¹` is applied by solves.
struct Stiffness {
    k: SparseMatrix,
    factor: Factor,
    workspace: SolveWorkspace,
}

impl Stiffness {
    fn factor(model: &Model, design: &Design) -> Result<Self> {
        let mut k = model.new_matrix();
        let zero = model.zero_vector();
        let mut aws = model.new_workspace();
        model.assemble(design, &zero, None, Some(&mut k), &mut aws);
        let symbolic = SymbolicFactor::for_model(model)?;
        let mut factor = Factor::new(symbolic.clone());
        factor.allow_indefinite = false;
        factor.factorize(&k)?;
        let workspace = SolveWorkspace::new(&symbolic);
        Ok(Self {
            k,
            factor,
            workspace,
        })
    }

    /// `w ← K⁻¹ w`.
    fn solve(&mut self, w: &mut [f64]) -> Result<()> {
        self.factor.solve_in_place(w, &mut self.workspace)?;
        Ok(())
    }
}

/// The converged Ritz values `θ = 1/ω²` and vectors `s` (row-major `m × m`, column `i` for
/// `θ_i`) of the `m`-step Lanczos tridiagonal matrix.
struct Ritz {
    theta: Vec<f64>,
    s: Vec<f64>,
    m: usize,
}

impl Ritz {
    /// Indices of the Ritz values, largest θ (lowest ω) first.
    fn order(&self) -> Vec<usize> {
        let mut order: Vec<usize> = (0..self.m).collect();
        order.sort_by(|&x, &y| self.theta[y].total_cmp(&self.theta[x]));
        order
    }
}

/// The M-orthonormal Lanczos basis `q` (and `M q`) of `K⁻¹M` with the tridiagonal
/// coefficients α (diagonal) and β (off-diagonal).
struct Lanczos {
    q: Vec<Vec<f64>>,
    mq: Vec<Vec<f64>>,
    alphas: Vec<f64>,
    betas: Vec<f64>,
    /// Scratch: the next vector and `M` times it.
    w: Vec<f64>,
    mw: Vec<f64>,
}

impl Lanczos {
    /// The first basis vector `q₀ ∝ K⁻¹M r₀` (in the range of `K⁻¹M`, so that the infinite
    /// eigenvalues of a singular `M` stay out), `r₀` pseudo-random from `seed`.
    fn start(mass: &MassMatrix, stiffness: &mut Stiffness, seed: u64) -> Result<Self> {
        let n = mass.n();
        let mut rng = SplitMix64::new(seed ^ 0x5DEE_CE66);
        let r0: Vec<f64> = (0..n).map(|_| rng.next_f64() - 0.5).collect();
        let mut w = vec![0.0; n];
        mass.matvec(&r0, &mut w);
        stiffness.solve(&mut w)?;
        let mut mw = vec![0.0; n];
        mass.matvec(&w, &mut mw);
        let b0 = dot(&w, &mw).sqrt();
        if b0.is_nan() || b0 <= 0.0 {
            return Err(ReduceError::Input(
                "the mass matrix is zero on the free DOFs".into(),
            ));
        }
        Ok(Self {
            q: vec![w.iter().map(|x| x / b0).collect()],
            mq: vec![mw.iter().map(|x| x / b0).collect()],
            alphas: Vec::new(),
            betas: Vec::new(),
            w,
            mw,
        })
    }

    /// Lanczos steps until the `nev` largest Ritz values pass the residual bound
    /// `|β_j s_ji| ≤ tol·θ_i` (checked every 5 steps), the Krylov space is exhausted or
    /// `max_steps` is reached.
    fn run(
        &mut self,
        mass: &MassMatrix,
        stiffness: &mut Stiffness,
        nev: usize,
        params: &ModalParams,
    ) -> Result<Ritz> {
        let max_steps = params.max_steps.min(mass.n());
        let mut n_conv = 0;
        for j in 0..max_steps {
            let (a, b) = self.step(j, mass, stiffness)?;
            let m = j + 1;
            let exhausted = b <= 1e-14 * a.abs();
            if m >= nev && (m % 5 == 0 || m == max_steps || exhausted) {
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
        Err(ReduceError::Eigen {
            wanted: nev,
            converged: n_conv,
            steps: self.alphas.len(),
        })
    }

    /// Step `j`: `w = K⁻¹M q_j − α_j q_j − β_{j−1} q_{j−1}`, fully reorthogonalized (twice,
    /// classical Gram–Schmidt in the M inner product); returns α_j and β_j = ‖w‖_M.
    fn step(
        &mut self,
        j: usize,
        mass: &MassMatrix,
        stiffness: &mut Stiffness,
    ) -> Result<(f64, f64)> {
        let w = &mut self.w;
        w.copy_from_slice(&self.mq[j]);
        stiffness.solve(w)?;
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
            for (qi, mqi) in self.q.iter().zip(&self.mq) {
                let c = dot(mqi, w);
                for (wk, qk) in w.iter_mut().zip(qi) {
                    *wk -= c * qk;
                }
            }
        }
        mass.matvec(w, &mut self.mw);
        Ok((a, dot(w, &self.mw).max(0.0).sqrt()))
    }

    /// Appends `q_{j+1} = w/β_j` (and `M q_{j+1}`).
    fn extend(&mut self, b: f64) {
        self.betas.push(b);
        self.q.push(self.w.iter().map(|x| x / b).collect());
        self.mq.push(self.mw.iter().map(|x| x / b).collect());
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

    /// The `nev` lowest modes from the Ritz pairs: `φ = Q s` normalized to `φᵀMφ = 1`,
    /// `ω² = 1/θ`, and the residual `‖Kφ − ω²Mφ‖/‖Kφ‖` recomputed from the shape.
    fn modes(
        &mut self,
        model: &Model,
        mass: &MassMatrix,
        k: &SparseMatrix,
        ritz: &Ritz,
        nev: usize,
    ) -> Modes {
        let (n, m) = (mass.n(), ritz.m);
        let mut out = Modes {
            omega2: Vec::new(),
            frequencies: Vec::new(),
            shapes: Vec::new(),
            residuals: Vec::new(),
            steps: m,
            total_mass: mass.total_mass(),
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
            mass.matvec(&phi, mw);
            let nrm = dot(&phi, mw).sqrt();
            phi.iter_mut().for_each(|x| *x /= nrm);
            mw.iter_mut().for_each(|x| *x /= nrm);
            let om2 = 1.0 / ritz.theta[i];
            k.matvec(&phi, &mut kphi);
            let res = kphi
                .iter()
                .zip(mw.iter())
                .map(|(a, b)| (a - om2 * b).powi(2))
                .sum::<f64>()
                .sqrt()
                / dot(&kphi, &kphi).sqrt();
            let mut full = model.zero_vector();
            model.dofs().scatter(&phi, &mut full);
            out.omega2.push(om2);
            out.frequencies
                .push(om2.sqrt() / (2.0 * std::f64::consts::PI));
            out.shapes.push(full);
            out.residuals.push(res);
        }
        out
    }
}
