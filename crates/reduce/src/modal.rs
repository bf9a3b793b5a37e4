//! Modal analysis: the lowest natural frequencies and mode shapes of a design,
//! `K φ = ω² M φ`, to check Assumption 2 (design resonance ≫ input frequency).
//!
//! `K` is the model's stiffness at the undeformed state (material stiffness, supports and
//! grounded springs — the PEAs hold the stage, Eq. 2–3) and `M` the mass matrix of
//! [`crate::mass`]. The solver is the project's one modal solver,
//! [`flexstage_fem::eigen`] (shift-invert Lanczos with the sparse Cholesky factor of `K`,
//! factored once); this module only assembles the design's operators and returns full-length
//! mode shapes. `M` may be singular (massless void nodes): the solver keeps the infinite
//! eigenvalues out.

use flexstage_fem::{
    Design, EigenError, EigenOperators, Factor, Lanczos, LanczosParams, Model, SolveWorkspace,
    SolverError, SparseMatrix, SymbolicFactor,
};

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
        Ok(self.interpolation.validate()?)
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
    let mut op = Operators::factor(model, &design, &mass)?;
    let pairs = Lanczos::new()
        .solve(
            &mut op,
            &LanczosParams {
                modes: params.modes,
                tolerance: params.tolerance,
                max_steps: params.max_steps,
                seed: params.seed,
                ..LanczosParams::default()
            },
        )
        .map_err(|e| match e {
            EigenError::NotConverged {
                wanted,
                converged,
                steps,
            } => ReduceError::Eigen {
                wanted,
                converged,
                steps,
            },
            EigenError::Solver(e) => e.into(),
            EigenError::Params(e) => e.into(),
            EigenError::ZeroMass => {
                ReduceError::Input("the mass matrix is zero on the free DOFs".into())
            }
        })?;
    let frequencies = pairs.frequencies();
    let shapes = pairs
        .vectors
        .iter()
        .map(|phi| {
            let mut full = model.zero_vector();
            model.dofs().scatter(phi, &mut full);
            full
        })
        .collect();
    Ok(Modes {
        omega2: pairs.values,
        frequencies,
        shapes,
        residuals: pairs.residuals,
        steps: pairs.steps,
        total_mass: mass.total_mass(),
    })
}

/// The design's operators: `K` at the undeformed state with its sparse Cholesky factor (`K⁻¹`
/// is applied by solves) and the mass matrix.
struct Operators<'a> {
    k: SparseMatrix,
    factor: Factor,
    workspace: SolveWorkspace,
    mass: &'a MassMatrix,
}

impl<'a> Operators<'a> {
    fn factor(model: &Model, design: &Design, mass: &'a MassMatrix) -> Result<Self> {
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
            mass,
        })
    }
}

impl EigenOperators for Operators<'_> {
    fn n(&self) -> usize {
        self.mass.n()
    }
    fn solve(&mut self, x: &mut [f64]) -> std::result::Result<(), SolverError> {
        self.factor.solve_in_place(x, &mut self.workspace)
    }
    fn mass(&self, x: &[f64], y: &mut [f64]) {
        self.mass.matvec(x, y);
    }
    fn stiffness(&self, x: &[f64], y: &mut [f64]) {
        self.k.matvec(x, y);
    }
}
