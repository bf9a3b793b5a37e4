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
//! Per load case, the converged tangent is factorized once and every response needs one solve
//! with it. `∂Q/∂u_k` combines the output selector `L_o` (Eq. 7), the input selectors and, for
//! the strain energy `W(u) = Σ_e W_e(u, ρ)`, the internal force `∂W/∂u = R(u) − K_s u`.
//!
//! Densities flow `x → x̃ (filter) → x̄ (projection) → ρ (passive overrides)`; gradients flow
//! back through the adjoints of each map ([`crate::filter`]).
//!
//! Load cases are solved in parallel (rayon), each with its own [`NewtonWorkspace`] sharing one
//! [`SymbolicFactor`], warm-started from the previous design iteration, with PCG
//! preconditioned by one factorization of the stiffness `K(ρ)` at `u = 0` for the current
//! design (refreshed once per design iteration; at the paper's strains the problem is nearly
//! linear, so PCG converges in a few iterations). A case that fails is retried from `u = 0`
//! with direct solves and more load increments (cutback), and the retry is reported.

use std::sync::Arc;

use flexstage_fem::{
    AdditiveYeoh, Design, Factor, LinearStrategy, Model, NewtonParams, NewtonWorkspace, Passive,
    PcgParams, SymbolicFactor, newton,
};
use rayon::prelude::*;

use crate::error::{Result, TopoptError};
use crate::filter::{DensityFilter, Projection};
use crate::problem::{Objective, Problem, shoelace, shoelace_gradient};

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
}

impl Default for AnalysisParams {
    fn default() -> Self {
        Self {
            newton: NewtonParams {
                residual_tol: 1e-9,
                displacement_tol: 1e-5,
                linear: LinearStrategy::Pcg(PcgParams {
                    rel_tol: 1e-6,
                    max_iter: 60,
                }),
                ..NewtonParams::default()
            },
            retry_increments: 4,
            retries: 2,
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
    /// Tilt measure `(D·n)² − tan²τ (D·d)²` [m²] (0 without tilt).
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
}

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
        let symbolic = SymbolicFactor::new(model.pattern().clone())?;
        let cases = (0..problem.cases.len())
            .map(|_| CaseState {
                u: model.zero_vector(),
                ws: NewtonWorkspace::new(model, symbolic.clone()),
            })
            .collect();
        Ok(Self {
            problem,
            filter: DensityFilter::new(model.mesh(), filter_radius),
            design: problem.design_elements(),
            cases,
            params,
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
        let zero = model.zero_vector();
        model.assemble(
            &design,
            &zero,
            None,
            Some(&mut self.precond_ws.tangent),
            &mut self.precond_ws.assembly,
        );
        self.precond.factorize(&self.precond_ws.tangent)?;
        let precond = &self.precond;
        let params = self.params;
        let results: Vec<Result<(usize, usize)>> = self
            .cases
            .par_iter_mut()
            .enumerate()
            .map(|(k, cs)| solve_case(problem, &design, k, cs, precond, &params))
            .collect();
        let mut r = Response::default();
        for (k, res) in results.into_iter().enumerate() {
            let (its, retries) = res?;
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
            let tau2 = t.tolerance.tan().powi(2);
            let g = [
                2.0 * dn * n[0] - 2.0 * tau2 * dd * d[0],
                2.0 * dn * n[1] - 2.0 * tau2 * dd * d[1],
            ];
            for c in 0..2 {
                coef[3][kc * width + c] += g[c];
                coef[3][kt * width + c] -= g[c];
            }
            dn * dn - tau2 * dd * dd
        } else {
            0.0
        };

        // --- adjoints per case, contracted with ∂R/∂ρ and ∂W/∂ρ ---------------------------
        let design = match yeoh {
            Some(y) => Design::with_yeoh(&dens.physical, y),
            None => Design::new(&dens.physical),
        };
        let ne = model.mesh().n_elements();
        let per_case: Vec<Result<Vec<Vec<f64>>>> = self
            .cases
            .par_iter_mut()
            .enumerate()
            .map(|(k, cs)| {
                let cf: Vec<&[f64]> = (0..4)
                    .map(|q| &coef[q][k * width..(k + 1) * width])
                    .collect();
                case_gradients(problem, &design, cs, &cf)
            })
            .collect();
        let mut g_rho = vec![vec![0.0; ne]; 4];
        for res in per_case {
            let g = res?;
            for q in 0..4 {
                if !g[q].is_empty() {
                    for (a, b) in g_rho[q].iter_mut().zip(&g[q]) {
                        *a += b;
                    }
                }
            }
        }
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
) -> Result<(usize, usize)> {
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
            return Ok((rep.iterations, 0));
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
                return Ok((its, attempt));
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

/// Adjoint solves and contractions of one case for the responses with non-zero coefficients.
/// Returns, per response, `dQ/dρ` contributions (empty if the response does not depend on
/// this case).
fn case_gradients(
    problem: &Problem,
    design: &Design,
    cs: &mut CaseState,
    coef: &[&[f64]],
) -> Result<Vec<Vec<f64>>> {
    let model = &problem.model;
    let ni = problem.inputs.len();
    let active: Vec<usize> = (0..coef.len())
        .filter(|&q| coef[q].iter().any(|c| *c != 0.0))
        .collect();
    let mut out = vec![Vec::new(); coef.len()];
    if active.is_empty() {
        return Ok(out);
    }
    // The tangent in the workspace is the converged one (newton::solve guarantees it).
    cs.ws.factorize_tangent()?;
    let u = &cs.u;
    let needs_fint = active.iter().any(|&q| coef[q][2 + ni] != 0.0);
    let mut fint = Vec::new();
    if needs_fint {
        fint = model.zero_vector();
        let mut aws = model.new_workspace();
        model.residual(design, u, &mut fint, &mut aws);
        for s in &model.bcs().springs {
            fint[s.dof] -= s.stiffness * u[s.dof];
        }
    }
    let nf = model.dofs().n_free();
    let mut tmp = vec![0.0; nf];
    let mut lambdas: Vec<Vec<f64>> = Vec::with_capacity(active.len());
    let mut wcoef = Vec::with_capacity(active.len());
    for &q in &active {
        let c = coef[q];
        let mut b = model.zero_vector();
        add_unit(&mut b, 2 * problem.output, c[0]);
        add_unit(&mut b, 2 * problem.output + 1, c[1]);
        for (i, p) in problem.inputs.iter().enumerate() {
            add_unit(&mut b, p.dof, c[2 + i]);
        }
        let aw = c[2 + ni];
        if aw != 0.0 {
            for (bi, f) in b.iter_mut().zip(&fint) {
                *bi += aw * f;
            }
        }
        let mut lam = model.zero_vector();
        cs.ws
            .factor
            .solve_full(model.dofs(), &b, &mut lam, &mut tmp, &mut cs.ws.solve_ws)?;
        lambdas.push(lam);
        wcoef.push(aw);
    }
    // One pass over the elements: ∂r_e/∂ρ_e and ∂W_e/∂ρ_e once, contracted with every λ.
    let mesh = model.mesh();
    let kernel = model.kernel();
    let dofs = model.dofs();
    let ne = mesh.n_elements();
    let mut g = vec![vec![0.0; ne]; active.len()];
    let mut dr = [0.0; 8];
    #[allow(clippy::needless_range_loop)]
    for e in 0..ne {
        let c = model.coefficients(design, e);
        let ue = model.element_displacement(e, u);
        let dw = kernel.drho(&c, &ue, &mut dr);
        let d = mesh.element_dofs(e);
        for (a, lam) in lambdas.iter().enumerate() {
            let mut s = 0.0;
            for k in 0..8 {
                if !dofs.is_fixed(d[k]) {
                    s += lam[d[k]] * dr[k];
                }
            }
            g[a][e] = wcoef[a] * dw - s;
        }
    }
    for (a, &q) in active.iter().enumerate() {
        out[q] = std::mem::take(&mut g[a]);
    }
    Ok(out)
}
