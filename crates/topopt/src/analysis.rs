//! Finite-element analysis of all load cases and exact adjoint sensitivities (Algorithm 1,
//! "Finite element analysis" and "Objective and constraints evaluation").
//!
//! For every response `Q(u_1 … u_pm, ρ)` (objective, aggregated strain energy, aggregated
//! input stroke, tilt), the gradient with respect to the physical densities is
//!
//! ```text
//! dQ/dρ_e = ∂Q/∂ρ_e − Σ_k λ_kᵀ ∂R_k/∂ρ_e,        K_T(u_k) λ_k = ∂Q/∂u_k,
//! ```
//!
//! the exact adjoint of the discretized nonlinear equilibrium `R(u_k, ρ) = P_k` (Eq. 6), with
//! the consistent tangent `K_T` and the exact `∂R/∂ρ` of the fem crate (including the additive
//! material's `(1 − ρ^p)` factor). This replaces the tangent-space approximations of Eq. (13)–(16).
//! `∂Q/∂u_k` combines the output selector `L_o` (Eq. 7), the input selectors and, for the strain
//! energy `W(u) = Σ_e W_e(u, ρ)`, the internal force `∂W/∂u = R(u) − K_s u`.
//!
//! # Solver (DECISIONS.md "Loading": warm starts, reuse factorizations)
//! One factorization per design iteration, of the stiffness `K(ρ)` at `u = 0` (the centroid of
//! the tangents of the ± symmetric stroke square), shared read-only by all cases. The cases are
//! split into [`GROUPS`] fixed groups (one rayon task each) solved in lock-step:
//! * equilibrium: from each case's warm start (its last equilibrium), Anderson-accelerated
//!   sweeps `u ← u + K⁻¹(P − R(u))` with residual-only assemblies and **one multi-column solve
//!   per sweep for the whole group** (the factor is streamed once for ~20 right-hand sides,
//!   ~3× cheaper per case than single solves), until `‖P − R(u)‖ ≤ residual_tol·‖P‖`; a case
//!   that stalls falls back to Newton (PCG, then direct solves with cutbacks from `u = 0`);
//! * adjoints: block PCG over all (case, response) columns of the group, each column with its
//!   case's exact tangent `K_T(u_k)` (assembled once at the converged state, together with the
//!   residual reused for `∂W/∂u`) and the shared factor as preconditioner, so each adjoint is
//!   exact to the PCG tolerance (1e-9; a failing column falls back to a factorization of its
//!   tangent).
//!
//! Densities flow `x → x̃ (filter) → x̄ (projection) → ρ (passive overrides)`; gradients flow
//! back through the adjoints of each map ([`crate::filter`]).

use std::sync::Arc;
use std::time::Instant;

use flexstage_fem::{
    AdditiveYeoh, BlockPcgWorkspace, ColumnOutcome, Design, Factor, Kinematics, LinearStrategy,
    Model, NewtonParams, NewtonWorkspace, Passive, PcgParams, SolveWorkspace, SymbolicFactor,
    newton, pcg_block,
};
use rayon::prelude::*;

use crate::error::{Result, TopoptError};
use crate::filter::{DensityFilter, Projection};
use crate::problem::{Objective, Problem, shoelace, shoelace_gradient};

/// The tilt constraint bounds the angle error by `TILT_MARGIN · τ`: MMA leaves an active
/// constraint slightly violated while β continuation perturbs the design, and the margin keeps
/// the delivered design within the documented tolerance τ.
pub const TILT_MARGIN: f64 = 0.75;

/// Exponent of the p-norm that aggregates per-case strain energies (Σ ≈ max_k W_k) and input
/// strokes; the p-norm over-estimates the maximum by at most `N^{1/p}` (conservative).
pub const AGGREGATION_P: f64 = 8.0;

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
    /// to Newton (0: Newton for every case, see [`solve_group`]).
    pub lockstep_iterations: usize,
    /// Adjoint solves: PCG on the converged tangent preconditioned by the shared factor, to
    /// this tolerance (`None`: a factorization of the tangent per case). A PCG failure falls
    /// back to the factorization.
    pub adjoint: Option<PcgParams>,
}

impl Default for AnalysisParams {
    fn default() -> Self {
        Self {
            // Equilibrium to 1e-8·‖P‖ and adjoints to 1e-7·‖b‖: responses and gradients to
            // ~7 digits, far below what moves an MMA step, and one lock-step sweep and about
            // one adjoint iteration per case cheaper than 1e-9 (≈ 20 % of an iteration).
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
            // Gradient error ~ PCG tolerance × a modest κ(K⁻¹K_T). A column still running
            // after 8 iterations (strongly nonlinear designs, where the preconditioner is far
            // from the converged tangent) is cheaper to finish by a factorization of its
            // case's tangent (~8 ms ≈ 15 block iterations).
            adjoint: Some(PcgParams {
                rel_tol: 1e-7,
                max_iter: 8,
            }),
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
        )
    }
}

/// The density chain `x → x̃ → x̄ → ρ`.
#[derive(Debug, Clone)]
pub struct Densities {
    /// Design variables scattered to all elements (passive solid 1, void ρ_min).
    pub x_full: Vec<f64>,
    /// Filtered `x̃`.
    pub filtered: Vec<f64>,
    /// Projected `x̄`.
    pub projected: Vec<f64>,
    /// Physical densities ρ (passive overrides applied), the FE input.
    pub physical: Vec<f64>,
}

/// Per-case results of one analysis.
#[derive(Debug, Clone, Default)]
pub struct Response {
    /// Output-node displacement `u_o = L_oᵀ u` per case [m] (Eq. 7).
    pub outputs: Vec<[f64; 2]>,
    /// Input-port displacements per case [m].
    pub inputs: Vec<Vec<f64>>,
    /// Structural strain energy per case [J].
    pub energies: Vec<f64>,
    /// Newton iterations per case.
    pub newton_iterations: Vec<usize>,
    /// Retries (cutbacks from `u = 0`) per case; non-zero entries are logged.
    pub retries: Vec<usize>,
    /// Inner linear iterations (PCG iterations, or 1 per direct solve) per case.
    pub linear_iterations: Vec<usize>,
}

/// Wall-clock split of the last [`Evaluator::evaluate`] (seconds).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Timing {
    /// Shared preconditioner (assembly + factorization).
    pub precondition: f64,
    /// Newton solves of all cases (incl. strain energies).
    pub solve: f64,
    /// Adjoint solves and contractions of all cases.
    pub adjoint: f64,
    /// Adjoint PCG iterations (1 per direct solve) summed over cases and responses.
    pub adjoint_iterations: usize,
}

/// Raw responses and their gradients with respect to the design variables.
#[derive(Debug, Clone)]
pub struct Evaluation {
    /// Case results.
    pub response: Response,
    /// Objective to maximize: signed area `sign·J` [m²] or `d·u_out` [m].
    pub objective: f64,
    /// Shoelace area `J` of the output polygon (Eq. 4), unsigned convention (CCW positive).
    pub area: f64,
    /// p-norm aggregate of the per-case strain energies [J] (≈ Σ of Eq. 15).
    pub energy: f64,
    /// p-norm aggregate of |u_in|/max_stroke (1 = at the stroke limit).
    pub stroke: f64,
    /// Tilt measure `((D·n)² − t (D·d)²) / (t |D|²)`, `t = tan²(TILT_MARGIN·τ)` (≤ 0 iff the
    /// differential output `D` is within `TILT_MARGIN·τ` of the target axis; 0 without tilt). Dimensionless and
    /// independent of |D|, so it stays O(1) while the workspace grows.
    pub tilt: f64,
    /// Volume fraction of the design elements.
    pub volume: f64,
    /// Gradients w.r.t. the design variables, same order: objective, energy, stroke, tilt,
    /// volume (each of length n).
    pub gradients: [Vec<f64>; 5],
}

/// Per-load-case state: the last equilibrium (warm start) and the Newton buffers.
pub struct CaseState {
    /// Displacements of the last converged solve (full vector).
    pub u: Vec<f64>,
    ws: NewtonWorkspace,
    /// Start of the current solve (for the Newton fallback).
    u0: Vec<f64>,
    /// `R(u)` at the converged state (full; reused as `∂W/∂u + K_s u` by the adjoint).
    r: Vec<f64>,
    /// Right-hand sides, then adjoints, per response (full vectors).
    pub(crate) lambdas: Vec<Vec<f64>>,
    /// Whether `lambdas[q]` holds the adjoint of the last evaluation (the warm start of the
    /// next one).
    pub(crate) warm: [bool; 4],
    /// `dQ_q/dρ` contributions of this case, per response and element.
    grads: Vec<Vec<f64>>,
    /// Whether response q depends on this case.
    active: [bool; 4],
    adjoint_iterations: usize,
    aa: Anderson,
}

/// Depth of the Anderson acceleration of the lock-step sweeps.
const ANDERSON_DEPTH: usize = 5;

/// Anderson acceleration (type II, Walker & Ni 2011) of the fixed-point map
/// `g(x) = x + K⁻¹(P − R(x))` on the free DOFs: for a linear problem it is equivalent to GMRES,
/// so the few eigenvalues of `K⁻¹K_T` far from 1 (soft members under compression, additive
/// material) do not stall the sweeps as plain Richardson would.
struct Anderson {
    df: Vec<f64>,
    dg: Vec<f64>,
    f: Vec<f64>,
    g: Vec<f64>,
    x: Vec<f64>,
    len: usize,
    head: usize,
    started: bool,
}

impl Anderson {
    fn new(nf: usize) -> Self {
        Self {
            df: vec![0.0; ANDERSON_DEPTH * nf],
            dg: vec![0.0; ANDERSON_DEPTH * nf],
            f: vec![0.0; nf],
            g: vec![0.0; nf],
            x: vec![0.0; nf],
            len: 0,
            head: 0,
            started: false,
        }
    }

    fn reset(&mut self) {
        self.len = 0;
        self.head = 0;
        self.started = false;
    }

    /// Given the current iterate `x` (free DOFs, in `self.x`) and the preconditioned residual
    /// `f = K⁻¹(P − R(x))`, overwrite `self.x` with the next iterate.
    #[allow(clippy::needless_range_loop)]
    fn step(&mut self, f: &[f64]) {
        let nf = f.len();
        let m = ANDERSON_DEPTH;
        if self.started {
            let h = self.head;
            for i in 0..nf {
                let g = self.x[i] + f[i];
                self.df[h * nf + i] = f[i] - self.f[i];
                self.dg[h * nf + i] = g - self.g[i];
            }
            self.head = (h + 1) % m;
            self.len = (self.len + 1).min(m);
        }
        self.started = true;
        for i in 0..nf {
            self.f[i] = f[i];
            self.g[i] = self.x[i] + f[i];
        }
        let k = self.len;
        self.x.copy_from_slice(&self.g);
        if k == 0 {
            return;
        }
        // Least squares min ‖f − ΔF γ‖ by the (regularized) normal equations.
        let mut a = [[0.0f64; ANDERSON_DEPTH]; ANDERSON_DEPTH];
        let mut b = [0.0f64; ANDERSON_DEPTH];
        for p in 0..k {
            let dp = &self.df[p * nf..(p + 1) * nf];
            b[p] = dp.iter().zip(f).map(|(x, y)| x * y).sum();
            for q in p..k {
                let dq = &self.df[q * nf..(q + 1) * nf];
                let v: f64 = dp.iter().zip(dq).map(|(x, y)| x * y).sum();
                a[p][q] = v;
                a[q][p] = v;
            }
        }
        let tr: f64 = (0..k).map(|p| a[p][p]).sum();
        if !(tr > 0.0 && tr.is_finite()) {
            return;
        }
        for p in 0..k {
            a[p][p] += 1e-12 * tr;
        }
        // Gaussian elimination with partial pivoting.
        let mut gamma = b;
        for c in 0..k {
            let piv = (c..k)
                .max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))
                .unwrap_or(c);
            a.swap(c, piv);
            gamma.swap(c, piv);
            if a[c][c] == 0.0 {
                return;
            }
            for r in c + 1..k {
                let l = a[r][c] / a[c][c];
                for cc in c..k {
                    a[r][cc] -= l * a[c][cc];
                }
                gamma[r] -= l * gamma[c];
            }
        }
        for c in (0..k).rev() {
            let mut v = gamma[c];
            for cc in c + 1..k {
                v -= a[c][cc] * gamma[cc];
            }
            gamma[c] = v / a[c][c];
        }
        if gamma[..k].iter().any(|g| !g.is_finite()) {
            return;
        }
        for p in 0..k {
            let dg = &self.dg[p * nf..(p + 1) * nf];
            for (x, d) in self.x.iter_mut().zip(dg) {
                *x -= gamma[p] * d;
            }
        }
    }
}

impl CaseState {
    /// Adjoint PCG iterations of the last evaluation (1 per direct solve), summed over responses.
    pub fn adjoint_iterations(&self) -> usize {
        self.adjoint_iterations
    }

    fn new(model: &Model, symbolic: &Arc<SymbolicFactor>) -> Self {
        let ne = model.mesh().n_elements();
        Self {
            u: model.zero_vector(),
            ws: NewtonWorkspace::new(model, symbolic.clone()),
            u0: model.zero_vector(),
            r: model.zero_vector(),
            lambdas: vec![model.zero_vector(); 4],
            warm: [false; 4],
            grads: vec![vec![0.0; ne]; 4],
            active: [false; 4],
            adjoint_iterations: 0,
            aa: Anderson::new(model.dofs().n_free()),
        }
    }
}

/// Buffers of one group of load cases solved in lock-step (one rayon task).
struct GroupWorkspace {
    /// Column-major block: one column per case (Newton) or per case and response (adjoint).
    rhs: Vec<f64>,
    sol: Vec<f64>,
    sws: SolveWorkspace,
    pcg: BlockPcgWorkspace,
    outcome: Vec<ColumnOutcome>,
}

impl GroupWorkspace {
    fn new(nf: usize, cases: usize, symbolic: &SymbolicFactor) -> Self {
        let cols = 4 * cases;
        Self {
            rhs: vec![0.0; nf * cols],
            sol: vec![0.0; nf * cols],
            sws: SolveWorkspace::with_columns(symbolic, cols),
            pcg: BlockPcgWorkspace::new(nf, cols),
            outcome: vec![ColumnOutcome::Running; cols],
        }
    }
}

/// Number of lock-step groups (fixed, so that results do not depend on the thread count).
pub const GROUPS: usize = 2;

/// Evaluates the responses of a [`Problem`] and their exact gradients.
pub struct Evaluator<'p> {
    /// The problem.
    pub problem: &'p Problem,
    /// Density filter.
    pub filter: DensityFilter,
    /// Design elements (variable j ↔ element design[j]).
    pub design: Vec<usize>,
    /// Per-case states (warm starts).
    pub cases: Vec<CaseState>,
    /// Parameters.
    pub params: AnalysisParams,
    /// Timing of the last evaluation.
    pub timing: Timing,
    loads: Vec<Vec<f64>>,
    groups: Vec<GroupWorkspace>,
    symbolic: Arc<SymbolicFactor>,
    precond: Factor,
    precond_ws: NewtonWorkspace,
}

/// Adds `coef · e_dof` to a right-hand side.
fn add_unit(b: &mut [f64], dof: usize, coef: f64) {
    b[dof] += coef;
}

fn pnorm(v: &[f64], p: f64) -> (f64, Vec<f64>) {
    let vmax = v.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    if vmax == 0.0 {
        return (0.0, vec![0.0; v.len()]);
    }
    let s: f64 = v.iter().map(|x| (x.abs() / vmax).powf(p)).sum();
    let n = vmax * s.powf(1.0 / p);
    let d = v
        .iter()
        .map(|x| (x.abs() / n).powf(p - 1.0) * x.signum())
        .collect();
    (n, d)
}

impl<'p> Evaluator<'p> {
    /// Prepares the filter (radius in element sizes), the shared symbolic factorization and
    /// one workspace per load case.
    pub fn new(problem: &'p Problem, filter_radius: f64, params: AnalysisParams) -> Result<Self> {
        params.validate()?;
        problem.validate()?;
        let model = &problem.model;
        let symbolic = SymbolicFactor::for_model(model)?;
        let nc = problem.cases.len();
        let cases = (0..nc).map(|_| CaseState::new(model, &symbolic)).collect();
        let per_group = nc.div_ceil(GROUPS);
        let nf = model.dofs().n_free();
        let groups = if params.lockstep_iterations > 0 {
            (0..nc.div_ceil(per_group))
                .map(|_| GroupWorkspace::new(nf, per_group, &symbolic))
                .collect()
        } else {
            Vec::new()
        };
        Ok(Self {
            problem,
            filter: DensityFilter::new(model.mesh(), filter_radius),
            design: problem.design_elements(),
            cases,
            params,
            timing: Timing::default(),
            loads: (0..nc).map(|k| problem.load(k)).collect(),
            groups,
            precond: Factor::new(symbolic.clone()),
            precond_ws: NewtonWorkspace::new(model, symbolic.clone()),
            symbolic,
        })
    }

    /// Number of design variables.
    pub fn n(&self) -> usize {
        self.design.len()
    }

    /// The shared symbolic factorization.
    pub fn symbolic(&self) -> &Arc<SymbolicFactor> {
        &self.symbolic
    }

    /// `x → x̃ → x̄ → ρ`.
    pub fn densities(&self, x: &[f64], proj: Projection) -> Densities {
        let mesh = self.problem.mesh();
        let ne = mesh.n_elements();
        let rho_min = self.problem.rho_min;
        let mut x_full = vec![0.0; ne];
        for (e, p) in mesh.passive.iter().enumerate() {
            x_full[e] = match p {
                Passive::Solid => 1.0,
                Passive::Void | Passive::Design => rho_min,
            };
        }
        for (&e, &v) in self.design.iter().zip(x) {
            x_full[e] = v;
        }
        let mut filtered = vec![0.0; ne];
        self.filter.apply(&x_full, &mut filtered);
        let projected: Vec<f64> = filtered.iter().map(|&v| proj.value(v)).collect();
        let mut physical: Vec<f64> = projected.iter().map(|v| v.clamp(0.0, 1.0)).collect();
        mesh.apply_passive(&mut physical, rho_min);
        Densities {
            x_full,
            filtered,
            projected,
            physical,
        }
    }

    /// Chain rule `dQ/dρ → dQ/dx` through the passive overrides, projection and filter.
    pub fn chain(&self, d: &Densities, proj: Projection, g_rho: &[f64]) -> Vec<f64> {
        let mesh = self.problem.mesh();
        let g_tilde: Vec<f64> = (0..g_rho.len())
            .map(|e| {
                if mesh.passive[e] == Passive::Design {
                    g_rho[e] * proj.derivative(d.filtered[e])
                } else {
                    0.0
                }
            })
            .collect();
        let mut g_full = vec![0.0; g_rho.len()];
        self.filter.apply_adjoint(&g_tilde, &mut g_full);
        self.design.iter().map(|&e| g_full[e]).collect()
    }

    /// Solves every load case at the physical densities `rho` (Algorithm 1, FE analysis),
    /// warm-started from the previous solution of each case.
    pub fn solve_cases(&mut self, rho: &[f64], yeoh: Option<&AdditiveYeoh>) -> Result<Response> {
        let problem = self.problem;
        let model = &problem.model;
        let design = match yeoh {
            Some(y) => Design::with_yeoh(rho, y),
            None => Design::new(rho),
        };
        design.validate(model.mesh().n_elements())?;
        // Shared preconditioner: K(ρ) at u = 0, refreshed once per design iteration.
        let t0 = Instant::now();
        let zero = model.zero_vector();
        model.assemble(
            &design,
            &zero,
            None,
            Some(&mut self.precond_ws.tangent),
            &mut self.precond_ws.assembly,
        );
        self.precond.factorize(&self.precond_ws.tangent)?;
        self.timing.precondition = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let precond = &self.precond;
        // Small-strain kinematics: K_T ≡ K(ρ) (also with the linearized additive material), so
        // the shared matrix is every case's tangent and need not be assembled again.
        let linear_tangent =
            (model.kinematics() == Kinematics::Linear).then_some(&self.precond_ws.tangent);
        let params = self.params;
        let loads = &self.loads;
        let results: Vec<Result<(usize, usize, usize)>> = if self.groups.is_empty() {
            self.cases
                .par_iter_mut()
                .enumerate()
                .map(|(k, cs)| {
                    cs.u0.copy_from_slice(&cs.u);
                    let res = solve_case(problem, &design, k, cs, precond, &params);
                    cs.r.copy_from_slice(cs.ws.residual());
                    res
                })
                .collect()
        } else {
            let per_group = self.cases.len().div_ceil(self.groups.len());
            self.cases
                .par_chunks_mut(per_group)
                .zip(self.groups.par_iter_mut())
                .enumerate()
                .flat_map_iter(|(g, (cases, gws))| {
                    solve_group(
                        problem,
                        &design,
                        &loads[g * per_group..],
                        g * per_group,
                        cases,
                        gws,
                        precond,
                        linear_tangent,
                        &params,
                    )
                })
                .collect()
        };
        let mut r = Response::default();
        for (k, res) in results.into_iter().enumerate() {
            let (its, retries, lin) = res?;
            r.linear_iterations.push(lin);
            let u = &self.cases[k].u;
            r.outputs
                .push([u[2 * problem.output], u[2 * problem.output + 1]]);
            r.inputs
                .push(problem.inputs.iter().map(|p| u[p.dof]).collect());
            r.newton_iterations.push(its);
            r.retries.push(retries);
        }
        r.energies = self
            .cases
            .par_iter()
            .map(|cs| model.strain_energy(&design, &cs.u))
            .collect();
        if r.energies.iter().any(|e| !e.is_finite())
            || r.outputs
                .iter()
                .any(|o| !o[0].is_finite() || !o[1].is_finite())
        {
            return Err(TopoptError::NonFinite {
                what: "FE response",
                iteration: 0,
            });
        }
        self.timing.solve = t0.elapsed().as_secs_f64();
        Ok(r)
    }

    /// Full evaluation: densities, FE analysis of all cases, responses and their exact
    /// gradients with respect to the design variables `x`.
    pub fn evaluate(
        &mut self,
        x: &[f64],
        proj: Projection,
        yeoh: Option<&AdditiveYeoh>,
    ) -> Result<(Densities, Evaluation)> {
        let dens = self.densities(x, proj);
        let response = self.solve_cases(&dens.physical, yeoh)?;
        let problem = self.problem;
        let model = &problem.model;
        let nc = problem.cases.len();
        let ni = problem.inputs.len();

        // --- responses and their partial derivatives w.r.t. case quantities -------------
        // coefficient layout per response q and case k: [a_out_x, a_out_y, a_in..., a_W]
        let width = 3 + ni;
        let mut coef = vec![vec![0.0; nc * width]; 4];
        let (objective, area) = match problem.objective {
            Objective::Workspace { sign } => {
                let a = shoelace(&response.outputs);
                for (k, g) in shoelace_gradient(&response.outputs).iter().enumerate() {
                    coef[0][k * width] = sign * g[0];
                    coef[0][k * width + 1] = sign * g[1];
                }
                (sign * a, a)
            }
            Objective::Displacement { direction } => {
                coef[0][0] = direction[0];
                coef[0][1] = direction[1];
                let o = response.outputs[0];
                (direction[0] * o[0] + direction[1] * o[1], 0.0)
            }
        };
        let (energy, de) = pnorm(&response.energies, AGGREGATION_P);
        for k in 0..nc {
            coef[1][k * width + 2 + ni] = de[k];
        }
        let stroke = if let Some(ms) = problem.max_stroke {
            let s: Vec<f64> = response.inputs.iter().flatten().map(|u| u / ms).collect();
            let (v, ds) = pnorm(&s, 2.0 * AGGREGATION_P);
            for k in 0..nc {
                for i in 0..ni {
                    coef[2][k * width + 2 + i] = ds[k * ni + i] / ms;
                }
            }
            v
        } else {
            0.0
        };
        let tilt = if let Some(t) = problem.tilt {
            let (kc, kt) = problem.differential_corners();
            let (oc, ot) = (response.outputs[kc], response.outputs[kt]);
            let dvec = [oc[0] - ot[0], oc[1] - ot[1]];
            let d = [t.theta.sin(), t.theta.cos()];
            let n = [t.theta.cos(), -t.theta.sin()];
            let (dn, dd) = (
                dvec[0] * n[0] + dvec[1] * n[1],
                dvec[0] * d[0] + dvec[1] * d[1],
            );
            // g = ((D·n)² − t (D·d)²) / (t |D|²), t = tan²τ: scale-invariant and O(1)
            // (= (tan²φ − t) cos²φ / t for an angle error φ), ≤ 0 iff |φ| ≤ τ with D·d > 0
            // allowed either sign; the objective's orientation fixes the sign of D·d.
            let t2 = (TILT_MARGIN * t.tolerance).tan().powi(2);
            let (a, b) = (dn * dn, dd * dd);
            let s2 = (a + b).max(f64::MIN_POSITIVE);
            let ga = b * (1.0 + t2) / (t2 * s2 * s2);
            let gb = -a * (1.0 + t2) / (t2 * s2 * s2);
            let g = [
                ga * 2.0 * dn * n[0] + gb * 2.0 * dd * d[0],
                ga * 2.0 * dn * n[1] + gb * 2.0 * dd * d[1],
            ];
            for c in 0..2 {
                coef[3][kc * width + c] += g[c];
                coef[3][kt * width + c] -= g[c];
            }
            (a - t2 * b) / (t2 * s2)
        } else {
            0.0
        };

        // --- adjoints per case, contracted with ∂R/∂ρ and ∂W/∂ρ ---------------------------
        let design = match yeoh {
            Some(y) => Design::with_yeoh(&dens.physical, y),
            None => Design::new(&dens.physical),
        };
        let ne = model.mesh().n_elements();
        let t0 = Instant::now();
        let precond = &self.precond;
        let adjoint = self.params.adjoint;
        let coef = &coef;
        let case_coef = |k: usize| -> [&[f64]; 4] {
            std::array::from_fn(|q| &coef[q][k * width..(k + 1) * width])
        };
        let results: Vec<Result<()>> = if self.groups.is_empty() {
            self.cases
                .par_iter_mut()
                .enumerate()
                .map(|(k, cs)| {
                    let cf = case_coef(k);
                    let mut one = GroupWorkspace::new(model.dofs().n_free(), 1, &self.symbolic);
                    group_gradients(
                        problem,
                        &design,
                        std::slice::from_mut(cs),
                        &[cf],
                        &mut one,
                        precond,
                        adjoint,
                    )
                })
                .collect()
        } else {
            let per_group = self.cases.len().div_ceil(self.groups.len());
            self.cases
                .par_chunks_mut(per_group)
                .zip(self.groups.par_iter_mut())
                .enumerate()
                .map(|(g, (cases, gws))| {
                    let cf: Vec<[&[f64]; 4]> = (0..cases.len())
                        .map(|j| case_coef(g * per_group + j))
                        .collect();
                    group_gradients(problem, &design, cases, &cf, gws, precond, adjoint)
                })
                .collect()
        };
        for res in results {
            res?;
        }
        let mut g_rho = vec![vec![0.0; ne]; 4];
        for cs in &self.cases {
            for (q, gq) in g_rho.iter_mut().enumerate() {
                if cs.active[q] {
                    for (a, b) in gq.iter_mut().zip(&cs.grads[q]) {
                        *a += b;
                    }
                }
            }
        }
        self.timing.adjoint = t0.elapsed().as_secs_f64();
        self.timing.adjoint_iterations = self.cases.iter().map(|c| c.adjoint_iterations).sum();
        let mut gradients: [Vec<f64>; 5] = Default::default();
        for q in 0..4 {
            gradients[q] = self.chain(&dens, proj, &g_rho[q]);
        }
        let nd = self.design.len() as f64;
        let volume = self.design.iter().map(|&e| dens.physical[e]).sum::<f64>() / nd;
        let mut gv = vec![0.0; ne];
        for &e in &self.design {
            gv[e] = 1.0 / nd;
        }
        gradients[4] = self.chain(&dens, proj, &gv);
        for g in &gradients {
            if g.iter().any(|v| !v.is_finite()) {
                return Err(TopoptError::NonFinite {
                    what: "gradient",
                    iteration: 0,
                });
            }
        }
        Ok((
            dens,
            Evaluation {
                response,
                objective,
                area,
                energy,
                stroke,
                tilt,
                volume,
                gradients,
            },
        ))
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

/// Newton solve of one case with warm start, then retries from zero with direct solves and
/// more increments. Returns (iterations, retries).
fn solve_case(
    problem: &Problem,
    design: &Design,
    k: usize,
    cs: &mut CaseState,
    precond: &Factor,
    params: &AnalysisParams,
) -> Result<(usize, usize, usize)> {
    let model: &Model = &problem.model;
    let load = problem.load(k);
    let mut u = cs.u.clone();
    let first = newton::solve(
        model,
        design,
        &load,
        &mut u,
        &params.newton,
        &mut cs.ws,
        Some(precond),
    );
    let mut last = match first {
        Ok(rep) => {
            cs.u = u;
            return Ok((rep.iterations, 0, rep.linear_iterations));
        }
        Err(e) => e,
    };
    let mut its = 0;
    let mut incr = params.retry_increments;
    for attempt in 1..=params.retries {
        let p = NewtonParams {
            increments: incr,
            max_cutbacks: 20,
            linear: LinearStrategy::Direct,
            ..params.newton
        };
        let mut u = model.zero_vector();
        match newton::solve(model, design, &load, &mut u, &p, &mut cs.ws, None) {
            Ok(rep) => {
                cs.u = u;
                its += rep.iterations;
                return Ok((its, attempt, rep.linear_iterations));
            }
            Err(e) => last = e,
        }
        incr = (incr * 4).min(10_000);
    }
    let c = &problem.cases[k];
    Err(TopoptError::LoadCase {
        case: k,
        x1: c[0],
        x2: c.get(1).copied().unwrap_or(0.0),
        attempts: params.retries + 1,
        source: last,
    })
}

/// Lock-step solve of a group of load cases: preconditioned Richardson iterations
/// `u_j ← u_j + K(ρ)⁻¹ (P_j − R(u_j))` from the warm starts, with one multi-column solve of
/// the shared factor per iteration for all unconverged cases (the factor is streamed once per
/// sweep, ~3× cheaper per case than single solves), and residual-only assemblies. At the
/// paper's strains `‖I − K⁻¹K_T‖ ≈ 10⁻²`, so a few sweeps reach the residual tolerance. A case
/// converges when `‖P − R(u)‖ ≤ residual_tol·‖P‖` (free DOFs); one that stalls (reduction per
/// sweep worse than ½) or does not converge in `lockstep_iterations` sweeps falls back to
/// Newton from its warm start ([`solve_case`]). The tangent (for the adjoint) and the residual
/// are assembled at every converged state.
#[allow(clippy::too_many_arguments)]
fn solve_group(
    problem: &Problem,
    design: &Design,
    loads: &[Vec<f64>],
    first: usize,
    cases: &mut [CaseState],
    gws: &mut GroupWorkspace,
    precond: &Factor,
    linear_tangent: Option<&flexstage_fem::SparseMatrix>,
    params: &AnalysisParams,
) -> Vec<Result<(usize, usize, usize)>> {
    #[derive(Clone, Copy, PartialEq)]
    enum St {
        Run,
        Done,
        Fallback,
    }
    let model = &problem.model;
    let dofs = model.dofs();
    let free = dofs.free_dofs();
    let nf = free.len();
    let m = cases.len();
    let tol = params.newton.residual_tol;
    let mut st = vec![St::Run; m];
    let mut its = vec![0usize; m];
    let pnorm: Vec<f64> = (0..m)
        .map(|j| {
            let n = free
                .iter()
                .map(|&d| loads[j][d].powi(2))
                .sum::<f64>()
                .sqrt();
            if n > 0.0 { n } else { 1.0 }
        })
        .collect();
    let mut best = vec![f64::INFINITY; m];
    for cs in cases.iter_mut() {
        cs.u0.copy_from_slice(&cs.u);
        cs.aa.reset();
        dofs.gather(&cs.u, &mut cs.aa.x);
    }
    let rhs = &mut gws.rhs[..nf * m];
    for sweep in 0..=params.lockstep_iterations {
        let mut running = 0;
        for (j, cs) in cases.iter_mut().enumerate() {
            let col = &mut rhs[j * nf..(j + 1) * nf];
            if st[j] != St::Run {
                col.fill(0.0);
                continue;
            }
            model.assemble(design, &cs.u, Some(&mut cs.r), None, &mut cs.ws.assembly);
            let p = &loads[j];
            for (x, &d) in col.iter_mut().zip(free) {
                *x = p[d] - cs.r[d];
            }
            let rel = col.iter().map(|x| x * x).sum::<f64>().sqrt() / pnorm[j];
            if rel <= tol {
                st[j] = St::Done;
            } else if !rel.is_finite()
                || rel > 10.0 * best[j]
                || sweep == params.lockstep_iterations
            {
                st[j] = St::Fallback;
            } else {
                best[j] = best[j].min(rel);
                its[j] += 1;
                running += 1;
                continue;
            }
            col.fill(0.0);
        }
        if running == 0 {
            break;
        }
        // Pack the running columns to the front (k ≤ j, so forward copies are safe) and solve
        // only those: late sweeps have few cases left.
        let mut k = 0;
        for (j, &s) in st.iter().enumerate() {
            if s == St::Run {
                if k != j {
                    rhs.copy_within(j * nf..(j + 1) * nf, k * nf);
                }
                k += 1;
            }
        }
        if let Err(e) =
            precond.solve_columns_in_place(&mut rhs[..running * nf], running, &mut gws.sws)
        {
            return vec![Err(e.into())];
        }
        let mut k = 0;
        for (j, cs) in cases.iter_mut().enumerate() {
            if st[j] == St::Run {
                cs.aa.step(&rhs[k * nf..(k + 1) * nf]);
                k += 1;
                for (x, &d) in cs.aa.x.iter().zip(free) {
                    cs.u[d] = *x;
                }
            }
        }
    }
    cases
        .iter_mut()
        .enumerate()
        .map(|(j, cs)| match st[j] {
            St::Done => {
                // `cs.r` already holds R(u) at the converged state (last sweep).
                match linear_tangent {
                    Some(k) => cs.ws.tangent.values_mut().copy_from_slice(k.values()),
                    None => model.assemble(
                        design,
                        &cs.u,
                        None,
                        Some(&mut cs.ws.tangent),
                        &mut cs.ws.assembly,
                    ),
                }
                Ok((its[j], 0, its[j]))
            }
            _ => {
                cs.u.copy_from_slice(&cs.u0);
                // Stalled sweeps mean the shared factor is far from this case's tangent: Newton
                // with fresh factorizations (quadratic convergence) rather than PCG with it.
                let direct = AnalysisParams {
                    newton: NewtonParams {
                        linear: LinearStrategy::Direct,
                        ..params.newton
                    },
                    ..*params
                };
                let (n, retries, lin) =
                    solve_case(problem, design, first + j, cs, precond, &direct)?;
                cs.r.copy_from_slice(cs.ws.residual());
                Ok((its[j] + n, retries, its[j] + lin))
            }
        })
        .collect()
}

/// Adjoint solves and contractions of a group of cases for the responses with non-zero
/// coefficients, into `cs.grads[q]` (`dQ_q/dρ` contributions; `cs.active[q]` says whether
/// response `q` depends on the case).
///
/// `K_T(u_k) λ = ∂Q/∂u_k` uses the tangent assembled at the converged state, with block PCG
/// over all (case, response) columns of the group preconditioned by the shared factor
/// (`adjoint = Some`), so every adjoint is exact to the PCG tolerance; a column that fails
/// (e.g. an indefinite tangent) falls back to a factorization of its case's tangent.
/// `∂W/∂u = R(u) − K_s u` reuses the residual assembled at the converged state.
#[allow(clippy::needless_range_loop)]
fn group_gradients(
    problem: &Problem,
    design: &Design,
    cases: &mut [CaseState],
    coef: &[[&[f64]; 4]],
    gws: &mut GroupWorkspace,
    precond: &Factor,
    adjoint: Option<PcgParams>,
) -> Result<()> {
    let model = &problem.model;
    let dofs = model.dofs();
    let nf = dofs.n_free();
    let ni = problem.inputs.len();
    // Right-hand sides, one column per (case, active response).
    let mut cols: Vec<(usize, usize)> = Vec::with_capacity(4 * cases.len());
    for (j, cs) in cases.iter_mut().enumerate() {
        cs.adjoint_iterations = 0;
        let CaseState {
            u,
            r,
            lambdas,
            warm,
            active,
            ..
        } = cs;
        for q in 0..4 {
            let c = coef[j][q];
            active[q] = c.iter().any(|v| *v != 0.0);
            if !active[q] {
                continue;
            }
            let lam = &mut lambdas[q];
            // Warm start: the last evaluation's adjoint (pcg_block rescales it optimally).
            let c0 = cols.len();
            let x0 = &mut gws.sol[c0 * nf..(c0 + 1) * nf];
            if warm[q] {
                dofs.gather(lam, x0);
            } else {
                x0.fill(0.0);
            }
            lam.fill(0.0);
            add_unit(lam, 2 * problem.output, c[0]);
            add_unit(lam, 2 * problem.output + 1, c[1]);
            for (i, p) in problem.inputs.iter().enumerate() {
                add_unit(lam, p.dof, c[2 + i]);
            }
            let aw = c[2 + ni];
            if aw != 0.0 {
                // ∂W/∂u = R(u) − K_s u (springs are not strain energy).
                for (bi, f) in lam.iter_mut().zip(r.iter()) {
                    *bi += aw * f;
                }
                for s in &model.bcs().springs {
                    lam[s.dof] -= aw * s.stiffness * u[s.dof];
                }
            }
            dofs.gather(lam, &mut gws.rhs[c0 * nf..(c0 + 1) * nf]);
            cols.push((j, q));
        }
    }
    let k = cols.len();
    if k > 0 {
        let (b, x) = (&gws.rhs[..k * nf], &mut gws.sol[..k * nf]);
        let outcome = &mut gws.outcome[..k];
        match adjoint {
            Some(pp) => {
                let mats: Vec<&flexstage_fem::SparseMatrix> =
                    cols.iter().map(|&(j, _)| &cases[j].ws.tangent).collect();
                pcg_block(
                    &mats,
                    precond,
                    b,
                    x,
                    pp,
                    &mut gws.pcg,
                    &mut gws.sws,
                    outcome,
                )?;
            }
            None => outcome.fill(ColumnOutcome::NotConverged),
        }
        let mut factored = vec![false; cases.len()];
        for (c, &(j, q)) in cols.iter().enumerate() {
            let cs = &mut cases[j];
            let xc = &mut x[c * nf..(c + 1) * nf];
            match outcome[c] {
                ColumnOutcome::Converged(n) => cs.adjoint_iterations += n,
                _ => {
                    if !factored[j] {
                        cs.ws.factorize_tangent()?;
                        factored[j] = true;
                    }
                    xc.copy_from_slice(&b[c * nf..(c + 1) * nf]);
                    cs.ws.factor.solve_in_place(xc, &mut cs.ws.solve_ws)?;
                    cs.adjoint_iterations += 1;
                }
            }
            dofs.scatter(xc, &mut cs.lambdas[q]);
            cs.warm[q] = true;
        }
    }
    // One pass over the elements per case: ∂r_e/∂ρ_e and ∂W_e/∂ρ_e once, contracted with
    // every λ of the case.
    let mesh = model.mesh();
    let kernel = model.kernel();
    let ne = mesh.n_elements();
    let mut dr = [0.0; 8];
    for (j, cs) in cases.iter_mut().enumerate() {
        if !cs.active.iter().any(|a| *a) {
            continue;
        }
        let wcoef: [f64; 4] = std::array::from_fn(|q| coef[j][q][2 + ni]);
        let CaseState {
            u,
            lambdas,
            grads,
            active,
            ..
        } = cs;
        for e in 0..ne {
            let c = model.coefficients(design, e);
            let ue = model.element_displacement(e, u);
            let dw = kernel.drho(&c, &ue, &mut dr);
            let d = mesh.element_dofs(e);
            for q in 0..4 {
                if !active[q] {
                    continue;
                }
                let lam = &lambdas[q];
                // λ is zero at fixed DOFs (scattered from the reduced solution).
                let s: f64 = (0..8).map(|k| lam[d[k]] * dr[k]).sum();
                grads[q][e] = wcoef[q] * dw - s;
            }
        }
    }
    Ok(())
}
