//! Finite-element analysis of all load cases of one density field and the exact adjoint
//! sensitivities of the named responses (Algorithm 1, "Finite element analysis" and "Objective
//! and constraints evaluation").
//!
//! * `equilibrium`: the load cases in lock-step groups, `R(u_k, ρ) = P_k` (Eq. 6), started from
//!   a quadratic load-path prediction (`predictor`), with the shared factor of `K(ρ)` at
//!   `u = 0` (the centroid of the tangents of the ± symmetric stroke square) as preconditioner.
//! * `adjoint`: `K_T(u_k) λ_k = ∂Q/∂u_k` for every response and case, and
//!   `dQ/dρ = ∂Q/∂ρ − Σ_k λ_kᵀ ∂R_k/∂ρ` with the exact `∂R/∂ρ` of the fem crate (including the
//!   additive material's `(1 − ρ^p)` factor).
//! * `workspace`: warm starts per case, heavy buffers per group (shared by
//!   designs analysed one after the other).
//!
//! One factorization per design and evaluation, of `K(ρ)` at `u = 0`, shared read-only by all
//! cases (DECISIONS.md "Loading": warm starts, reuse factorizations). The density chain and the
//! robust realizations live in [`crate::realization`].

mod adjoint;
mod anderson;
mod equilibrium;
mod predictor;
mod workspace;

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use flexstage_fem::{
    AdditiveYeoh, AssemblyWorkspace, Design, Factor, Kinematics, LinearStrategy, NewtonParams,
    PcgParams, SparseMatrix,
};
use rayon::prelude::*;

pub use workspace::{CaseState, GROUPS, Workspace};

use crate::error::{Result, TopoptError};
use crate::problem::Problem;
use crate::responses::{PerResponse, ResponseCoefficients, ResponseKind};

/// Parameters of the FE analysis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AnalysisParams {
    /// Newton parameters of the first attempt (warm start, PCG with the shared factor).
    pub newton: NewtonParams,
    /// Load increments of the retries from `u = 0` (each retry multiplies by 4), in [1, 1000].
    pub retry_increments: usize,
    /// Number of retries after a failed first attempt, in [0, 4].
    pub retries: usize,
    /// Lock-step preconditioned Richardson sweeps per design iteration before a case falls back
    /// to Newton (0: Newton for every case, see `solve_group`).
    pub lockstep_iterations: usize,
    /// Adjoint solves: PCG on the converged tangent preconditioned by the shared factor, to
    /// this tolerance (`None`: a factorization of the tangent per case). A PCG failure falls
    /// back to the factorization.
    pub adjoint: Option<PcgParams>,
    /// Start every case from the quadratic load-path prediction (`predictor`) instead of its
    /// warm start.
    pub predictor: bool,
    /// Adjoints with the tangent at the converged state (true), or, for a case that converged
    /// in the lock-step sweeps, with the tangent assembled in the first sweep at the predicted
    /// state (false). The two differ by the prediction error (≈ the strain squared, relative),
    /// so the gradients by far less than the adjoint tolerance, and a case that needs a sweep
    /// saves a tangent assembly. Gradient checks use true.
    pub exact_tangent: bool,
    /// The stage's eigen-analysis ([`crate::modal`]), when the problem has a resonance
    /// requirement.
    pub modal: crate::modal::ModalParams,
}

impl Default for AnalysisParams {
    fn default() -> Self {
        Self {
            // Equilibrium to 1e-8·‖P‖: responses to ~8 digits, far below what moves an MMA step,
            // and one lock-step sweep per case cheaper than 1e-9.
            // Gradient checks use [`AnalysisParams::tight`].
            newton: NewtonParams {
                residual_tol: 1e-8,
                displacement_tol: 1e-5,
                linear: LinearStrategy::Pcg(PcgParams {
                    rel_tol: 1e-6,
                    max_iter: 60,
                }),
                ..NewtonParams::default()
            },
            retry_increments: 4,
            retries: 2,
            lockstep_iterations: 25,
            // Gradient error ~ PCG tolerance × a modest κ(K⁻¹K_T): 1e-6 is far below what moves
            // an MMA step and saves about one block iteration in three against 1e-7. A column
            // still running after 8 iterations (strongly nonlinear designs, where the
            // preconditioner is far from the converged tangent) is cheaper to finish by a
            // factorization of its case's tangent (~8 ms ≈ 15 block iterations).
            adjoint: Some(PcgParams {
                rel_tol: 1e-6,
                max_iter: 8,
            }),
            predictor: true,
            exact_tangent: false,
            modal: crate::modal::ModalParams::default(),
        }
    }
}

impl AnalysisParams {
    /// Tight tolerances for finite-difference checks.
    pub fn tight() -> Self {
        Self {
            newton: NewtonParams {
                residual_tol: 1e-13,
                displacement_tol: 1e-12,
                linear: LinearStrategy::Direct,
                ..NewtonParams::default()
            },
            adjoint: Some(PcgParams {
                rel_tol: 1e-12,
                max_iter: 200,
            }),
            exact_tangent: true,
            ..Self::default()
        }
    }

    /// Check every field (the error names it and its accepted range).
    pub fn validate(&self) -> Result<()> {
        self.newton.validate()?;
        crate::error::check_range(
            "AnalysisParams::retry_increments",
            self.retry_increments as f64,
            (1..=1000).contains(&self.retry_increments),
            "[1, 1000]",
        )?;
        crate::error::check_range(
            "AnalysisParams::retries",
            self.retries as f64,
            self.retries <= 4,
            "[0, 4]",
        )?;
        self.modal.validate()
    }
}

/// Per-case results of one analysis.
#[derive(Debug, Clone, Default)]
pub struct CaseResults {
    /// Output-node displacement `u_o = L_oᵀ u` per case \[m\] (Eq. 7).
    pub outputs: Vec<[f64; 2]>,
    /// Input-port displacements per case \[m\].
    pub inputs: Vec<Vec<f64>>,
    /// Structural strain energy per case \[J\] (empty when the evaluator skips it).
    pub energies: Vec<f64>,
    /// Newton iterations (lock-step sweeps plus fallback Newton iterations) per case.
    pub newton_iterations: Vec<usize>,
    /// Retries (cutbacks from `u = 0`) per case; non-zero entries are logged.
    pub retries: Vec<usize>,
    /// Inner linear iterations (PCG iterations, or 1 per direct solve) per case.
    pub linear_iterations: Vec<usize>,
}

/// Wall-clock split of the last evaluation (seconds).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Timing {
    /// Shared preconditioner (assembly + factorization).
    pub precondition: f64,
    /// Equilibrium of all cases (incl. strain energies).
    pub solve: f64,
    /// Adjoint solves and contractions of all cases.
    pub adjoint: f64,
    /// Adjoint PCG iterations (1 per direct solve) summed over cases and responses.
    pub adjoint_iterations: usize,
}

static NEXT_ID: AtomicU64 = AtomicU64::new(1);

/// The FE analysis of one density field: warm starts of every load case and the shared
/// preconditioner. The heavy buffers come from a [`Workspace`]: its own (created on first use by
/// [`Evaluator::solve_cases`]) or one shared by several evaluators (the `_in` methods).
pub struct Evaluator<'p> {
    /// The problem.
    pub problem: &'p Problem,
    /// Per-case warm starts.
    pub cases: Vec<CaseState>,
    /// Parameters.
    pub params: AnalysisParams,
    /// Timing of the last evaluation.
    pub timing: Timing,
    /// Whether [`CaseResults::energies`] is computed (skipped when no response needs it).
    pub compute_energies: bool,
    precond: Factor,
    k0: SparseMatrix,
    assembly: AssemblyWorkspace,
    predictor: predictor::Predictor,
    basis: adjoint::AdjointBasis,
    /// The zero displacement (the preconditioner's state).
    zero: Vec<f64>,
    id: u64,
    own: Option<Workspace>,
}

impl<'p> Evaluator<'p> {
    /// Prepares the per-case warm starts and the preconditioner's buffers.
    pub fn new(problem: &'p Problem, params: AnalysisParams) -> Result<Self> {
        problem.validate()?;
        let symbolic = flexstage_fem::SymbolicFactor::for_model(&problem.model)?;
        Self::with_symbolic(problem, params, symbolic)
    }

    /// [`Evaluator::new`] for use with a shared workspace: its symbolic factorization is
    /// reused.
    pub fn with_workspace_of(
        problem: &'p Problem,
        params: AnalysisParams,
        ws: &Workspace,
    ) -> Result<Self> {
        problem.validate()?;
        Self::with_symbolic(problem, params, ws.symbolic.clone())
    }

    fn with_symbolic(
        problem: &'p Problem,
        params: AnalysisParams,
        symbolic: std::sync::Arc<flexstage_fem::SymbolicFactor>,
    ) -> Result<Self> {
        params.validate()?;
        let model = &problem.model;
        Ok(Self {
            problem,
            cases: (0..problem.cases.len())
                .map(|_| CaseState::new(model))
                .collect(),
            params,
            timing: Timing::default(),
            compute_energies: true,
            precond: Factor::new(symbolic),
            k0: model.new_matrix(),
            assembly: model.new_workspace(),
            predictor: predictor::Predictor::default(),
            basis: adjoint::AdjointBasis::default(),
            zero: Vec::new(),
            id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
            own: None,
        })
    }

    /// Solves every load case at the physical densities `rho` (Algorithm 1, FE analysis),
    /// warm-started from the previous solution of each case, with this evaluator's own
    /// workspace.
    pub fn solve_cases(&mut self, rho: &[f64], yeoh: Option<&AdditiveYeoh>) -> Result<CaseResults> {
        // The own workspace is created once; it is taken out for the call so that `self` can
        // be borrowed mutably beside it.
        let mut ws = match self.own.take() {
            Some(ws) => ws,
            None => Workspace::new(self.problem)?,
        };
        let r = self.solve_cases_in(&mut ws, rho, yeoh);
        self.own = Some(ws);
        r
    }

    /// [`Evaluator::solve_cases`] with a shared workspace. The workspace then holds this
    /// evaluator's converged states, which [`Evaluator::gradients_in`] needs.
    pub fn solve_cases_in(
        &mut self,
        ws: &mut Workspace,
        rho: &[f64],
        yeoh: Option<&AdditiveYeoh>,
    ) -> Result<CaseResults> {
        let problem = self.problem;
        let model = &problem.model;
        let design = make_design(rho, yeoh);
        design.validate(model.mesh().n_elements())?;
        // Shared preconditioner: K(ρ) at u = 0, refreshed once per design iteration.
        let t0 = Instant::now();
        self.zero.resize(model.n_dofs(), 0.0);
        model.assemble(
            &design,
            &self.zero,
            None,
            Some(&mut self.k0),
            &mut self.assembly,
        );
        self.precond.factorize(&self.k0)?;
        if self.params.predictor {
            self.predictor.build(
                problem,
                &design,
                &self.precond,
                &mut self.assembly,
                &mut ws.groups[0].sws,
            )?;
        }
        self.timing.precondition = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        ws.loaded = None;
        // Small-strain kinematics: K_T ≡ K(ρ) (also with the linearized additive material), so
        // the shared matrix is every case's tangent and need not be assembled again.
        let shared = equilibrium::Shared {
            design: &design,
            precond: &self.precond,
            linear_tangent: (model.kinematics() == Kinematics::Linear).then_some(&self.k0),
            predictor: self.params.predictor.then_some(&self.predictor),
            params: &self.params,
        };
        let per_group = ws.per_group;
        let Workspace { groups, loads, .. } = ws;
        let solves: Vec<Result<Vec<equilibrium::CaseSolve>>> = self
            .cases
            .par_chunks_mut(per_group)
            .zip(groups.par_iter_mut())
            .enumerate()
            .map(|(g, (cases, gws))| {
                let first = g * per_group;
                equilibrium::solve_group(problem, &shared, &loads[first..], first, cases, gws)
            })
            .collect();
        let mut r = CaseResults::default();
        for s in solves {
            for c in s? {
                r.newton_iterations.push(c.iterations);
                r.retries.push(c.retries);
                r.linear_iterations.push(c.linear);
            }
        }
        for cs in &self.cases {
            let u = &cs.u;
            r.outputs
                .push([u[2 * problem.output], u[2 * problem.output + 1]]);
            r.inputs
                .push(problem.inputs.iter().map(|p| p.displacement(u)).collect());
        }
        if self.compute_energies {
            r.energies = self
                .cases
                .par_iter()
                .map(|cs| strain_energy(model, &design, &cs.u))
                .collect();
        }
        if r.energies.iter().any(|e| !e.is_finite())
            || r.outputs.iter().flatten().any(|o| !o.is_finite())
        {
            return Err(TopoptError::NonFinite {
                what: "FE response",
                iteration: 0,
            });
        }
        ws.loaded = Some(self.id);
        self.timing.solve = t0.elapsed().as_secs_f64();
        Ok(r)
    }

    /// `dQ/dρ` (per element) of every response with coefficients, by the adjoints of the
    /// states of the last [`Evaluator::solve_cases_in`] on this workspace, plus the explicit
    /// part.
    pub fn gradients_in(
        &mut self,
        ws: &mut Workspace,
        rho: &[f64],
        yeoh: Option<&AdditiveYeoh>,
        coefficients: &PerResponse<Option<ResponseCoefficients>>,
    ) -> Result<PerResponse<Option<Vec<f64>>>> {
        if ws.loaded != Some(self.id) {
            return Err(TopoptError::Problem(
                "internal: adjoints requested for states the workspace does not hold".into(),
            ));
        }
        let t0 = Instant::now();
        let problem = self.problem;
        let design = make_design(rho, yeoh);
        self.basis
            .build(problem, &self.precond, &mut ws.groups[0].sws)?;
        let (precond, adjoint, per_group) = (&self.precond, self.params.adjoint, ws.per_group);
        let basis = &self.basis;
        let results: Vec<Result<()>> = self
            .cases
            .par_chunks_mut(per_group)
            .zip(ws.groups.par_iter_mut())
            .enumerate()
            .map(|(g, (cases, gws))| {
                let range = g * per_group..g * per_group + cases.len();
                let coef = PerResponse::from_fn(|q| {
                    coefficients[q].as_ref().map(|c| &c.cases[range.clone()])
                });
                adjoint::group_gradients(
                    problem, &design, cases, &coef, gws, precond, basis, adjoint,
                )
            })
            .collect();
        for res in results {
            res?;
        }
        let ne = problem.mesh().n_elements();
        let mut out = PerResponse::from_fn(|q| {
            coefficients[q]
                .as_ref()
                .map(|c| c.explicit.clone().unwrap_or_else(|| vec![0.0; ne]))
        });
        for q in ResponseKind::FE {
            if let Some(g) = out[q].as_mut() {
                for gws in &ws.groups {
                    for (a, b) in g.iter_mut().zip(&gws.grads[q]) {
                        *a += b;
                    }
                }
                if g.iter().any(|v| !v.is_finite()) {
                    return Err(TopoptError::NonFinite {
                        what: "gradient",
                        iteration: 0,
                    });
                }
            }
        }
        self.timing.adjoint = t0.elapsed().as_secs_f64();
        self.timing.adjoint_iterations = self.cases.iter().map(|c| c.adjoint_iterations).sum();
        Ok(out)
    }

    /// `K(ρ)` at `u = 0` of the last [`Evaluator::solve_cases_in`] and its factor (the
    /// preconditioner of the load cases), for the stage's eigen-analysis.
    pub(crate) fn stiffness_at_rest(&self) -> (&SparseMatrix, &Factor) {
        (&self.k0, &self.precond)
    }

    /// Element-wise maximum over the load cases of the average von Mises strain (for the `c2`
    /// update of Eq. A3).
    pub fn max_element_strains(&self) -> Vec<f64> {
        let model = &self.problem.model;
        let ne = model.mesh().n_elements();
        let mut out = vec![0.0f64; ne];
        let mut tmp = vec![0.0; ne];
        for cs in &self.cases {
            model.element_von_mises_strains(&cs.u, &mut tmp);
            for (o, t) in out.iter_mut().zip(&tmp) {
                *o = o.max(*t);
            }
        }
        out
    }
}

fn make_design<'a>(rho: &'a [f64], yeoh: Option<&'a AdditiveYeoh>) -> Design<'a> {
    match yeoh {
        Some(y) => Design::with_yeoh(rho, y),
        None => Design::new(rho),
    }
}

/// Total strain energy `Σ_e W_e` without allocating (springs excluded).
fn strain_energy(model: &flexstage_fem::Model, design: &Design, u: &[f64]) -> f64 {
    let kernel = model.kernel();
    (0..model.mesh().n_elements())
        .map(|e| {
            kernel.energy(
                &model.coefficients(design, e),
                &model.element_displacement(e, u),
            )
        })
        .sum()
}
