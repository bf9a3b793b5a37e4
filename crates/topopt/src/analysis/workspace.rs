//! What the FE analysis keeps between calls: per load case only the warm starts
//! ([`CaseState`]); the heavy buffers live once per group of cases in a [`Workspace`] (one
//! rayon task per group).
//!
//! Memory per case is two or three full vectors (displacements and the adjoints of the
//! responses it feeds); matrices, Anderson histories, block-solve buffers and the fallback
//! factor exist once per group. Several evaluators may share one workspace (one after the
//! other); the robust formulation gives each realization its own, sharing one symbolic
//! factorization ([`Workspace::sharing`]), so that the eroded, blueprint and dilated designs are
//! analysed concurrently (about 0.25 GB per workspace at 120 × 60, 40 cases).

use std::sync::Arc;

use flexstage_fem::{
    AssemblyWorkspace, BlockPcgWorkspace, ColumnOutcome, Model, NewtonWorkspace, SolveWorkspace,
    SparseMatrix, SymbolicFactor,
};

use crate::analysis::anderson::Anderson;
use crate::error::Result;
use crate::problem::Problem;
use crate::responses::{PerResponse, ResponseKind};

/// Number of lock-step groups (fixed, so that results do not depend on the thread count).
pub const GROUPS: usize = 2;

/// The warm starts of one load case: its last equilibrium and the last adjoint of each
/// response (empty until the response is first computed).
#[derive(Debug, Clone)]
pub struct CaseState {
    /// Displacements of the last converged solve (full vector).
    pub u: Vec<f64>,
    /// Adjoints of the last evaluation, per response (full vectors; empty = none yet).
    pub(crate) lambdas: PerResponse<Vec<f64>>,
    pub(crate) adjoint_iterations: usize,
}

impl CaseState {
    pub(crate) fn new(model: &Model) -> Self {
        Self {
            u: model.zero_vector(),
            lambdas: PerResponse::default(),
            adjoint_iterations: 0,
        }
    }

    /// Adjoint PCG iterations of the last evaluation (1 per direct solve), summed over
    /// responses.
    pub fn adjoint_iterations(&self) -> usize {
        self.adjoint_iterations
    }

    /// The adjoint warm start of a response (empty if none).
    pub fn adjoint(&self, q: ResponseKind) -> &[f64] {
        &self.lambdas[q]
    }

    /// Sets the adjoint warm start of a response (checkpoint restore).
    pub(crate) fn set_adjoint(&mut self, q: ResponseKind, lambda: Vec<f64>) {
        self.lambdas[q] = lambda;
    }
}

/// Buffers of the case a slot of a group holds during one evaluation.
pub(crate) struct Slot {
    /// Tangent `K_T` at the converged state (the adjoint's matrix).
    pub tangent: SparseMatrix,
    /// `R(u)` at the converged state (reused for `∂W/∂u`).
    pub r: Vec<f64>,
    /// Start of the current solve (for the Newton fallback).
    pub u0: Vec<f64>,
    /// Anderson history of the lock-step sweeps.
    pub aa: Anderson,
    /// Element internal forces `r_e` at the converged state (valid when `re_valid`), for the
    /// adjoint contraction `λ_eᵀ ∂r_e/∂ρ_e = (E'/E) λ_eᵀ r_e` without the additive material.
    pub re: Vec<[f64; 8]>,
    pub re_valid: bool,
}

/// Buffers of one group of load cases solved in lock-step (one rayon task).
pub(crate) struct GroupWorkspace {
    pub slots: Vec<Slot>,
    /// Column-major blocks: one column per case (equilibrium) or per case and response
    /// (adjoints).
    pub rhs: Vec<f64>,
    pub sol: Vec<f64>,
    pub sws: SolveWorkspace,
    pub pcg: BlockPcgWorkspace,
    pub outcome: Vec<ColumnOutcome>,
    /// Element buffers of residual assemblies.
    pub assembly: AssemblyWorkspace,
    /// Newton fallback and direct adjoint solves.
    pub newton: NewtonWorkspace,
    /// `dQ/dρ` contributions of the group's cases, per response.
    pub grads: PerResponse<Vec<f64>>,
    /// Full-vector scratch of the adjoints (right-hand side, guess, spring forces).
    pub full: [Vec<f64>; 3],
}

impl GroupWorkspace {
    fn new(model: &Model, cases: usize, symbolic: &Arc<SymbolicFactor>) -> Self {
        let nf = model.dofs().n_free();
        let cols = ResponseKind::FE.len() * cases;
        Self {
            slots: (0..cases)
                .map(|_| Slot {
                    tangent: model.new_matrix(),
                    r: model.zero_vector(),
                    u0: model.zero_vector(),
                    aa: Anderson::new(nf),
                    re: vec![[0.0; 8]; model.mesh().n_elements()],
                    re_valid: false,
                })
                .collect(),
            rhs: vec![0.0; nf * cols],
            sol: vec![0.0; nf * cols],
            sws: SolveWorkspace::with_columns(symbolic, cols),
            pcg: BlockPcgWorkspace::new(nf, cols),
            outcome: vec![ColumnOutcome::Running; cols],
            assembly: model.new_workspace(),
            newton: NewtonWorkspace::new(model, symbolic.clone()),
            grads: PerResponse::default(),
            full: std::array::from_fn(|_| model.zero_vector()),
        }
    }
}

/// The shared heavy buffers of the FE analysis of one problem (module docs).
pub struct Workspace {
    pub(crate) groups: Vec<GroupWorkspace>,
    /// Cases per group (the last group may hold fewer).
    pub(crate) per_group: usize,
    pub(crate) symbolic: Arc<SymbolicFactor>,
    /// External load vector of each case.
    pub(crate) loads: Vec<Vec<f64>>,
    /// Which evaluator's converged states the slots hold (adjoints need them).
    pub(crate) loaded: Option<u64>,
}

impl Workspace {
    /// Buffers for the load cases of `problem`, with its symbolic factorization.
    pub fn new(problem: &Problem) -> Result<Self> {
        let symbolic = SymbolicFactor::for_model(&problem.model)?;
        Self::sharing(problem, symbolic)
    }

    /// [`Workspace::new`] with a symbolic factorization of the model's pattern computed before
    /// (e.g. another workspace's, [`Workspace::symbolic`]).
    pub fn sharing(problem: &Problem, symbolic: Arc<SymbolicFactor>) -> Result<Self> {
        let model = &problem.model;
        let nc = problem.cases.len();
        let per_group = nc.div_ceil(GROUPS);
        let groups = (0..nc.div_ceil(per_group))
            .map(|g| GroupWorkspace::new(model, per_group.min(nc - g * per_group), &symbolic))
            .collect();
        Ok(Self {
            groups,
            per_group,
            symbolic,
            loads: (0..nc).map(|k| problem.load(k)).collect(),
            loaded: None,
        })
    }

    /// The shared symbolic factorization.
    pub fn symbolic(&self) -> &Arc<SymbolicFactor> {
        &self.symbolic
    }
}
