//! The stage's natural frequencies in the design loop: the generalized eigenproblem
//! `K_s φ = λ M φ` (`λ = ω²`) of the stage as it is built, linearized at the undeformed state,
//! its lowest eigenvalues by the project's one modal solver ([`flexstage_fem::eigen`]), their
//! exact sensitivities, and a smooth aggregate of the lowest few that a constraint or an
//! objective can use where eigenvalues cross or coincide.
//!
//! # The stage (paper Eq. 1–3, DECISIONS.md "Design for bandwidth")
//! * `K_s`: the design model's stiffness at `u = 0` (SIMP, the PEA springs K_pea, the rollers
//!   at the inputs) with the input plates' springs K_in added and the optimizer's output load
//!   (`optimization.output_spring`, a design device that is no part of the stage) taken off;
//! * `M`: consistent Q4 element masses `m(ρ_e) ρ0 V_e` with Du & Olhoff's interpolation
//!   ([`MassInterpolation`]: void and faint grey carry no mass, so they make no spurious local
//!   modes), the input plates `m_in` on the input nodes and the payload on the output node.
//!
//! The plates are the scenario's model guess (`stage.guess`), what the designer knows; the
//! simulated stage's truth never enters a design decision. The design loop evaluates it on
//! the blueprint and the eroded design of the robust formulation (each on its own
//! factorization, concurrently).
//!
//! # Reusing the design's factorization
//! Every design iteration factors `K(ρ)` at `u = 0` of the design model as the preconditioner
//! of its load cases. `K_s` differs from it by four springs, so `K_s⁻¹` is applied through that
//! factor with the Woodbury identity ([`SpringUpdate`]): four extra solves per design instead
//! of an assembly and a factorization.
//!
//! # Sensitivities
//! For a simple eigenvalue with `φᵀMφ = 1` (e.g. Haftka & Gürdal, *Elements of Structural
//! Optimization*, 1992, §7.3):
//!
//! ```text
//! ∂λ/∂ρ_e = φᵀ (∂K_s/∂ρ_e − λ ∂M/∂ρ_e) φ = φ_eᵀ(∂K_e/∂ρ_e)φ_e − λ m'(ρ_e) ρ0 V_e φ_eᵀM̂_eφ_e
//! ```
//!
//! The springs and point masses do not depend on ρ.
//!
//! # Where eigenvalues coincide: the aggregate
//! A single eigenvalue is not differentiable where it coincides with another (the lowest two
//! modes of a symmetric stage cross as the design changes: a symmetric and an antisymmetric
//! mode). Its order then switches, the gradient of "the lowest" jumps, and an optimizer that
//! bounds it oscillates. The design therefore bounds a smooth lower bound of the lowest `n`
//! eigenvalues instead (Kreisselmeier–Steinhauser-type aggregation, here the `P`-mean of the
//! reciprocals, which is scale-free):
//!
//! ```text
//! Λ = (Σ_{j≤n} λ_j^{−P})^{−1/P},    ∂Λ/∂λ_j = (Λ/λ_j)^{P+1},    n^{−1/P} λ_1 ≤ Λ ≤ λ_1.
//! ```
//!
//! `Λ` is a symmetric function of the eigenvalues of the group, so it is differentiable where
//! they coincide (the weights of equal eigenvalues are equal, and the sum of `φᵀAφ` over an
//! eigenspace does not depend on the basis Lanczos returns; Lewis, *SIAM J. Matrix Anal. Appl.*
//! 17 (1996) 927–949). With `P = 16` it is within 0.2 % of the lowest frequency once the next
//! is 10 % above it, and 2.2 % below it where two coincide (a conservative bound).

use flexstage_fem::{
    Design, DofMass, EigenError, EigenOperators, Factor, Lanczos, LanczosParams, LinkSpring,
    MassInterpolation, Model, SolveWorkspace, SolverError, SparseMatrix, SpringUpdate,
    SymbolicFactor, consistent_mass_forms, consistent_mass_into,
};

use crate::error::{Result, TopoptError};
use crate::problem::Problem;

/// The stage's dynamic parts beyond the design model (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct StageDynamics {
    /// Material density ρ0 [kg/m³].
    pub density: f64,
    /// Density → mass interpolation.
    pub interpolation: MassInterpolation,
    /// Point masses (input plates on the input DOFs, the payload on both output DOFs).
    pub point_masses: Vec<DofMass>,
    /// Springs added to the design model (positive stiffness: the plates' K_in) or taken off
    /// it (negative: the optimizer's output load).
    pub springs: Vec<LinkSpring>,
}

/// Parameters of the stage's eigen-analysis in the design loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModalParams {
    /// Eigenvalues in the aggregate `n`, in [1, 10]. Default 4.
    pub modes: usize,
    /// Aggregation exponent `P`, in [2, 64]. Default 16.
    pub exponent: f64,
    /// Lanczos tolerance (relative residual bound), in [1e-14, 1e-3]. Default 1e-10.
    pub tolerance: f64,
}

impl Default for ModalParams {
    fn default() -> Self {
        Self {
            modes: 4,
            exponent: 16.0,
            tolerance: 1e-10,
        }
    }
}

impl ModalParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        crate::error::check_range(
            "ModalParams::modes",
            self.modes as f64,
            (1..=10).contains(&self.modes),
            "[1, 10]",
        )?;
        crate::error::check_range(
            "ModalParams::exponent",
            self.exponent,
            (2.0..=64.0).contains(&self.exponent),
            "[2, 64]",
        )?;
        crate::error::check_range(
            "ModalParams::tolerance",
            self.tolerance,
            (1e-14..=1e-3).contains(&self.tolerance),
            "[1e-14, 1e-3]",
        )
    }

    /// The solver's parameters: converged pairs are tested after every step (the design loop
    /// pays for every solve; the small tridiagonal eigen-solve is negligible beside one).
    fn lanczos(&self) -> LanczosParams {
        LanczosParams {
            modes: self.modes,
            tolerance: self.tolerance,
            check_every: 1,
            ..LanczosParams::default()
        }
    }
}

/// The stage's lowest natural frequencies at one design.
#[derive(Debug, Clone, PartialEq)]
pub struct StageModes {
    /// Eigenvalues `λ_j = ω_j²` [rad²/s²], lowest first.
    pub eigenvalues: Vec<f64>,
    /// Natural frequencies `f_j = ω_j/2π` \[Hz\].
    pub frequencies: Vec<f64>,
    /// The aggregate `Λ` [rad²/s²] (module docs).
    pub aggregate: f64,
    /// `∂Λ/∂ρ_e` per element (when asked for).
    pub gradient: Option<Vec<f64>>,
    /// Mode shapes, full vectors, `φᵀMφ = 1`.
    pub shapes: Vec<Vec<f64>>,
    /// Relative residuals `‖K_sφ − λMφ‖/‖K_sφ‖`.
    pub residuals: Vec<f64>,
    /// Lanczos steps.
    pub steps: usize,
}

impl StageModes {
    /// The aggregate as a frequency `√Λ/2π` \[Hz\].
    pub fn aggregate_frequency(&self) -> f64 {
        self.aggregate.sqrt() / (2.0 * std::f64::consts::PI)
    }
}

/// `Λ = (Σ λ_j^{−P})^{−1/P}` and `∂Λ/∂λ_j = (Λ/λ_j)^{P+1}` (module docs), computed relative to
/// the lowest eigenvalue so that no power overflows.
pub fn aggregate(values: &[f64], exponent: f64) -> (f64, Vec<f64>) {
    let l1 = values.iter().copied().fold(f64::INFINITY, f64::min);
    let s: f64 = values.iter().map(|&l| (l1 / l).powf(exponent)).sum();
    let agg = l1 * s.powf(-1.0 / exponent);
    let d = values
        .iter()
        .map(|&l| (agg / l).powf(exponent + 1.0))
        .collect();
    (agg, d)
}

/// The stage operators of one design: the design model's factor and stiffness with the spring
/// update, and the mass matrix.
struct Operators<'a> {
    factor: &'a Factor,
    k: &'a SparseMatrix,
    mass: &'a SparseMatrix,
    update: &'a mut SpringUpdate,
    sws: &'a mut SolveWorkspace,
}

impl EigenOperators for Operators<'_> {
    fn n(&self) -> usize {
        self.k.n()
    }
    fn solve(&mut self, x: &mut [f64]) -> std::result::Result<(), SolverError> {
        self.update.solve(self.factor, x, self.sws)
    }
    fn mass(&self, x: &[f64], y: &mut [f64]) {
        self.mass.matvec(x, y);
    }
    fn stiffness(&self, x: &[f64], y: &mut [f64]) {
        self.k.matvec(x, y);
        self.update.add_product(x, y);
    }
}

/// The design model's stiffness at `u = 0` and its factorization.
#[derive(Clone, Copy)]
pub struct Factored<'a> {
    /// `K(ρ)` at `u = 0` (springs included).
    pub k: &'a SparseMatrix,
    /// Its factorization.
    pub factor: &'a Factor,
}

/// What the stage's eigen-analysis keeps between design iterations: the Lanczos basis, the
/// spring update, the mass matrix and the element buffers.
#[derive(Debug, Clone)]
pub struct ModalWorkspace {
    lanczos: Lanczos,
    update: SpringUpdate,
    mass: SparseMatrix,
    element_mass: Vec<f64>,
    forms: Vec<f64>,
}

impl ModalWorkspace {
    /// Buffers for the stage of `problem` (which must have [`Problem::dynamics`]).
    pub fn new(problem: &Problem) -> Result<Self> {
        let dynamics = stage_dynamics(problem)?;
        let model = &problem.model;
        Ok(Self {
            lanczos: Lanczos::new(),
            update: SpringUpdate::new(model.dofs(), &dynamics.springs),
            mass: model.new_matrix(),
            element_mass: vec![0.0; model.mesh().n_elements()],
            forms: vec![0.0; model.mesh().n_elements()],
        })
    }

    /// The stage modes of the design with physical densities in `design`, given the design
    /// model's stiffness at `u = 0` and its factor (module docs, "Reusing the design's
    /// factorization"); with `gradient`, `∂Λ/∂ρ_e`.
    pub fn solve(
        &mut self,
        problem: &Problem,
        design: &Design,
        at_rest: Factored,
        sws: &mut SolveWorkspace,
        params: &ModalParams,
        gradient: bool,
    ) -> Result<StageModes> {
        let Factored { k, factor } = at_rest;
        params.validate()?;
        let dynamics = stage_dynamics(problem)?;
        let model = &problem.model;
        let mesh = model.mesh();
        let volume = mesh.dx() * mesh.dy() * mesh.thickness;
        dynamics.interpolation.element_masses(
            design.rho,
            dynamics.density,
            volume,
            &mut self.element_mass,
        );
        consistent_mass_into(
            model,
            &self.element_mass,
            &dynamics.point_masses,
            &mut self.mass,
        )?;
        self.update.refactor(factor, sws)?;
        let mut op = Operators {
            factor,
            k,
            mass: &self.mass,
            update: &mut self.update,
            sws,
        };
        let pairs = self
            .lanczos
            .solve(&mut op, &params.lanczos())
            .map_err(eigen_error)?;
        let (agg, weights) = aggregate(&pairs.values, params.exponent);
        let shapes: Vec<Vec<f64>> = pairs
            .vectors
            .iter()
            .map(|phi| {
                let mut full = model.zero_vector();
                model.dofs().scatter(phi, &mut full);
                full
            })
            .collect();
        let gradient = gradient.then(|| {
            let mut g = vec![0.0; mesh.n_elements()];
            for ((phi, &lambda), w) in shapes.iter().zip(&pairs.values).zip(&weights) {
                model.stiffness_drho_forms(design, phi, &mut self.forms);
                for (ge, f) in g.iter_mut().zip(&self.forms) {
                    *ge += w * f;
                }
                consistent_mass_forms(model, phi, &mut self.forms);
                for (e, (ge, f)) in g.iter_mut().zip(&self.forms).enumerate() {
                    let dm = dynamics.interpolation.derivative(design.rho[e]) * dynamics.density;
                    *ge -= w * lambda * dm * volume * f;
                }
            }
            g
        });
        Ok(StageModes {
            frequencies: pairs.frequencies(),
            eigenvalues: pairs.values,
            aggregate: agg,
            gradient,
            shapes,
            residuals: pairs.residuals,
            steps: pairs.steps,
        })
    }
}

fn stage_dynamics(problem: &Problem) -> Result<&StageDynamics> {
    problem.dynamics.as_ref().ok_or_else(|| {
        TopoptError::Problem(
            "the stage's eigen-analysis needs the two-PEA stage (a [[ports]] mechanism has no \
             PEA sets)"
                .into(),
        )
    })
}

fn eigen_error(e: EigenError) -> TopoptError {
    TopoptError::Problem(format!("stage modal analysis: {e}"))
}

/// The stage modes of the physical densities `rho` on their own: assembles and factors the
/// design model's stiffness at `u = 0` and solves as the design loop does (same operators, same
/// numbers). For the final analysis, reports and tests.
pub fn stage_modes(
    problem: &Problem,
    rho: &[f64],
    params: &ModalParams,
    gradient: bool,
) -> Result<StageModes> {
    let model: &Model = &problem.model;
    let design = Design::new(rho);
    design.validate(model.mesh().n_elements())?;
    let mut k = model.new_matrix();
    let zero = model.zero_vector();
    let mut aws = model.new_workspace();
    model.assemble(&design, &zero, None, Some(&mut k), &mut aws);
    let symbolic = SymbolicFactor::for_model(model)?;
    let mut factor = Factor::new(symbolic.clone());
    factor.allow_indefinite = false;
    factor.factorize(&k)?;
    let mut sws = SolveWorkspace::new(&symbolic);
    let at_rest = Factored {
        k: &k,
        factor: &factor,
    };
    ModalWorkspace::new(problem)?.solve(problem, &design, at_rest, &mut sws, params, gradient)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aggregate_is_a_smooth_lower_bound() {
        let v = [4.0, 5.0, 9.0];
        let (a, d) = aggregate(&v, 16.0);
        assert!(a <= 4.0 && a >= 4.0 * 3f64.powf(-1.0 / 16.0));
        let h = 1e-6;
        for j in 0..3 {
            let (mut p, mut m) = (v, v);
            p[j] += h;
            m[j] -= h;
            let fd = (aggregate(&p, 16.0).0 - aggregate(&m, 16.0).0) / (2.0 * h);
            assert!((fd - d[j]).abs() < 1e-8, "{fd} vs {}", d[j]);
        }
        let (two, _) = aggregate(&[3.0, 3.0], 16.0);
        assert!((two - 3.0 * 2f64.powf(-1.0 / 16.0)).abs() < 1e-14);
    }
}
