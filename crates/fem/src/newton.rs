//! Incremental Newton–Raphson solver for `R(u, ρ) = λP` (paper Eq. (6), (A7), Fig. A1b).
//!
//! * Load path `P_λ = R(u₀) + λ (P − R(u₀))`, `λ = 1/n, 2/n, …, 1`, where `u₀` is the initial
//!   guess: for `u₀ = 0` this is the usual proportional loading `λP`; for a warm start from an
//!   equilibrium state of another load it is a continuation from that load. A failed increment is retried from the last
//!   converged state with half the step (adaptive cutback), up to `max_cutbacks` times; after
//!   a success the step grows back (×2, capped at `1/n`).
//! * Each iteration solves `K_T Δu = λP − R(u)` either with a fresh numeric factorization of
//!   `K_T` ([`LinearStrategy::Direct`]) or with PCG preconditioned by a factorization of another
//!   state ([`LinearStrategy::Pcg`], for many load cases sharing one factor).
//! * Backtracking line search (halving) accepts a step if the residual norm decreases or the
//!   energy criterion `|Δuᵀ r(u + αΔu)| ≤ 0.8 |Δuᵀ r(u)|` holds.
//! * Convergence of an increment needs, after at least one correction, **both**
//!   `‖P_λ − R(u)‖ ≤ residual_tol · ‖P_λ‖` (free DOFs) **and**
//!   `‖αΔu‖ ≤ displacement_tol · ‖u‖`. A full step (α = 1) whose increment is at machine
//!   precision, `‖Δu‖ ≤ 64 ε ‖u‖` ([`MACHINE_INCREMENT`]), also ends the increment: no
//!   further correction can change `u`, and the residual left is the round-off of the
//!   internal forces (on slender or stiff meshes it can exceed `residual_tol · ‖P_λ‖`).
//! * NaN/∞ anywhere or exhausted cutbacks return a [`NewtonError`] carrying the full history.
//!
//! Warm start: `u` on entry is the initial guess (e.g. the solution of the previous design
//! iteration, or of a neighbouring load case). On success the workspace's `tangent` is
//! assembled at the converged state (ready for adjoint solves; [`NewtonWorkspace::factorize_tangent`]).

use std::sync::Arc;

use crate::error::{
    IterationRecord, NewtonError, ParamError, SolverError, check_open, check_range,
};
use crate::model::{AssemblyWorkspace, Design, Model, SparseMatrix};
use crate::solver::{
    Factor, FactorKind, PcgParams, PcgWorkspace, SolveWorkspace, SymbolicFactor, pcg,
};

/// How Newton corrections are computed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LinearStrategy {
    /// Fresh numeric factorization of `K_T` at every iteration (reusing the symbolic analysis).
    Direct,
    /// PCG on `K_T` preconditioned by a factorization of another state: the `precond` argument
    /// of [`solve`] if given, else the workspace's own factor (computed at the first iteration
    /// if it holds none, then kept across calls until [`NewtonWorkspace::invalidate_factor`]).
    /// If PCG fails, the workspace factor is refreshed at the current state and PCG is retried.
    Pcg(PcgParams),
}

/// Newton–Raphson parameters. Call [`NewtonParams::validate`] (done by [`solve`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonParams {
    /// Number of equal load increments, in `[1, 10000]`.
    pub increments: usize,
    /// Maximum corrections per increment, in `[1, 1000]`.
    pub max_iterations: usize,
    /// Maximum number of step halvings over the whole solve, in `[0, 60]`.
    pub max_cutbacks: usize,
    /// Relative residual tolerance (w.r.t. `‖P_λ‖` on free DOFs), in `(0, 1)`.
    pub residual_tol: f64,
    /// Relative displacement-increment tolerance (w.r.t. `‖u‖`), in `(0, 1)`.
    pub displacement_tol: f64,
    /// Maximum line-search halvings per iteration, in `[0, 30]` (0 = full Newton steps).
    pub max_line_search: usize,
    /// Linear solver strategy.
    pub linear: LinearStrategy,
}

impl Default for NewtonParams {
    fn default() -> Self {
        Self {
            increments: 1,
            max_iterations: 30,
            max_cutbacks: 10,
            residual_tol: 1e-9,
            displacement_tol: 1e-7,
            max_line_search: 8,
            linear: LinearStrategy::Direct,
        }
    }
}

impl NewtonParams {
    /// Check every field; the error names the field and the accepted range.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_range(
            "NewtonParams::increments",
            self.increments as f64,
            1.0,
            1e4,
            "[1, 10000]",
        )?;
        check_range(
            "NewtonParams::max_iterations",
            self.max_iterations as f64,
            1.0,
            1e3,
            "[1, 1000]",
        )?;
        check_range(
            "NewtonParams::max_cutbacks",
            self.max_cutbacks as f64,
            0.0,
            60.0,
            "[0, 60]",
        )?;
        check_open(
            "NewtonParams::residual_tol",
            self.residual_tol,
            0.0,
            1.0,
            "(0, 1)",
        )?;
        check_open(
            "NewtonParams::displacement_tol",
            self.displacement_tol,
            0.0,
            1.0,
            "(0, 1)",
        )?;
        check_range(
            "NewtonParams::max_line_search",
            self.max_line_search as f64,
            0.0,
            30.0,
            "[0, 30]",
        )?;
        if let LinearStrategy::Pcg(p) = self.linear {
            check_open(
                "NewtonParams::linear.rel_tol",
                p.rel_tol,
                0.0,
                1.0,
                "(0, 1)",
            )?;
            check_range(
                "NewtonParams::linear.max_iter",
                p.max_iter as f64,
                1.0,
                1e5,
                "[1, 100000]",
            )?;
        }
        Ok(())
    }
}

/// Summary of a converged solve.
#[derive(Debug, Clone, PartialEq)]
pub struct NewtonReport {
    /// Total corrections (all increments, including failed attempts).
    pub iterations: usize,
    /// Converged increments.
    pub increments: usize,
    /// Cutbacks used.
    pub cutbacks: usize,
    /// Numeric factorizations performed.
    pub factorizations: usize,
    /// Total inner linear iterations (PCG iterations, or 1 per direct solve).
    pub linear_iterations: usize,
    /// Whether any factorization needed the indefinite (LBLᵀ) fallback.
    pub indefinite: bool,
    /// Final relative residual.
    pub relative_residual: f64,
    /// Every iteration.
    pub history: Vec<IterationRecord>,
}

/// Buffers for one concurrent Newton solve (one per thread / load case).
#[derive(Debug)]
pub struct NewtonWorkspace {
    /// Tangent; after a successful [`solve`] it is assembled at the converged state.
    pub tangent: SparseMatrix,
    /// This workspace's numeric factor.
    pub factor: Factor,
    /// Scratch for solves with any factor of the same symbolic structure.
    pub solve_ws: SolveWorkspace,
    /// Element buffers.
    pub assembly: AssemblyWorkspace,
    pcg: PcgWorkspace,
    r_full: Vec<f64>,
    p0: Vec<f64>,
    u_trial: Vec<f64>,
    u_conv: Vec<f64>,
    du_full: Vec<f64>,
    rhs: Vec<f64>,
    du: Vec<f64>,
    factor_current: bool,
}

impl NewtonWorkspace {
    /// Allocate all buffers for `model`, sharing the symbolic factorization.
    pub fn new(model: &Model, symbolic: Arc<SymbolicFactor>) -> Self {
        let n = model.dofs().n_free();
        let nf = model.n_dofs();
        Self {
            tangent: model.new_matrix(),
            solve_ws: SolveWorkspace::new(&symbolic),
            factor: Factor::new(symbolic),
            assembly: model.new_workspace(),
            pcg: PcgWorkspace::new(n),
            r_full: vec![0.0; nf],
            p0: vec![0.0; nf],
            u_trial: vec![0.0; nf],
            u_conv: vec![0.0; nf],
            du_full: vec![0.0; nf],
            rhs: vec![0.0; n],
            du: vec![0.0; n],
            factor_current: false,
        }
    }

    /// The full residual `R(u)` (internal + spring forces; reactions at fixed DOFs) assembled
    /// together with [`NewtonWorkspace::tangent`]: after a successful [`solve`], at the
    /// converged state. Lets adjoint code reuse it instead of assembling again.
    pub fn residual(&self) -> &[f64] {
        &self.r_full
    }

    /// Forget the workspace's factor (so that `Pcg` mode refactorizes at the next iteration).
    pub fn invalidate_factor(&mut self) {
        self.factor_current = false;
    }

    /// Factorize `self.tangent` (after [`solve`]: the tangent at the converged state) into
    /// `self.factor`, e.g. for exact adjoint solves `K_T λ = b`.
    pub fn factorize_tangent(&mut self) -> Result<FactorKind, SolverError> {
        let k = self.factor.factorize(&self.tangent)?;
        self.factor_current = true;
        Ok(k)
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// Reason an increment failed (internal).
enum IncrementFailure {
    NotConverged(f64),
    /// The solver error, and whether it came from the tangent at the converged state (the
    /// first iteration of the increment), which a cutback would only factorize again.
    Linear(SolverError, bool),
}

/// A factorization found the matrix singular (a zero pivot), not merely indefinite.
fn is_singular(e: &SolverError) -> bool {
    matches!(
        e,
        SolverError::SingularStiffness { .. } | SolverError::Singular { .. }
    )
}

enum Fail {
    Linear(SolverError),
    NotConverged {
        reached: f64,
        attempted: f64,
        cutbacks: usize,
        last_residual: f64,
    },
}

struct Counters {
    iterations: usize,
    factorizations: usize,
    linear_iterations: usize,
    indefinite: bool,
}

/// A full Newton step smaller than this, relative to `‖u‖`, is at machine precision: the
/// increment is converged whatever the residual (64 ε ≈ 1.4e-14).
pub const MACHINE_INCREMENT: f64 = 64.0 * f64::EPSILON;

/// Solve `R(u, ρ) = P` by incremental Newton–Raphson. `load` is the full external load vector
/// (entries at fixed DOFs ignored); `u` holds the initial guess (warm start) and receives the
/// solution. `precond` is only used with [`LinearStrategy::Pcg`].
pub fn solve(
    model: &Model,
    design: &Design,
    load: &[f64],
    u: &mut [f64],
    params: &NewtonParams,
    ws: &mut NewtonWorkspace,
    precond: Option<&Factor>,
) -> Result<NewtonReport, NewtonError> {
    check_inputs(model, design, load, u, params)?;
    // Fixed DOFs are prescribed zero.
    for &d in &model.bcs().fixed {
        u[d] = 0.0;
    }
    let mut history = Vec::new();
    let mut cnt = Counters {
        iterations: 0,
        factorizations: 0,
        linear_iterations: 0,
        indefinite: false,
    };
    let p_ref = reference_force(model, design, load, u, ws);
    // Start of the load path: the force in equilibrium with the initial guess.
    let mut p0 = std::mem::take(&mut ws.p0);
    p0.copy_from_slice(&ws.r_full);
    if p_ref == 0.0 {
        // Zero load and zero internal force: u is the solution.
        ws.p0 = p0;
        return Ok(NewtonReport {
            iterations: 0,
            increments: 0,
            cutbacks: 0,
            factorizations: 0,
            linear_iterations: 0,
            indefinite: false,
            relative_residual: 0.0,
            history,
        });
    }
    let dlam0 = 1.0 / params.increments as f64;
    let mut dlam = dlam0;
    let mut lam = 0.0;
    let mut cutbacks = 0;
    let mut increments = 0;
    let mut last_rel = f64::NAN;
    ws.u_conv.copy_from_slice(u);
    let mut assembled_at_u = true;
    let outcome = 'outer: {
        while lam < 1.0 {
            let target = if 1.0 - (lam + dlam) < 1e-12 {
                1.0
            } else {
                lam + dlam
            };
            let res = increment(
                model,
                design,
                load,
                &p0,
                u,
                target,
                p_ref,
                params,
                ws,
                precond,
                &mut history,
                &mut cnt,
                &mut assembled_at_u,
            );
            match res {
                Ok(rel) => {
                    lam = target;
                    last_rel = rel;
                    increments += 1;
                    ws.u_conv.copy_from_slice(u);
                    dlam = (2.0 * dlam).min(dlam0);
                }
                Err(fail) => {
                    // A pattern mismatch, or a singular tangent at the converged state (a
                    // floating structure), is the same after any cutback.
                    if let IncrementFailure::Linear(e, at_start) = &fail {
                        if matches!(e, SolverError::PatternMismatch { .. })
                            || (*at_start && is_singular(e))
                        {
                            break 'outer Err(Fail::Linear(e.clone()));
                        }
                    }
                    let rel = match &fail {
                        IncrementFailure::NotConverged(r) => *r,
                        IncrementFailure::Linear(..) => f64::NAN,
                    };
                    if cutbacks >= params.max_cutbacks {
                        if let IncrementFailure::Linear(source, _) = fail {
                            if params.max_cutbacks == 0 || is_singular(&source) {
                                break 'outer Err(Fail::Linear(source));
                            }
                        }
                        break 'outer Err(Fail::NotConverged {
                            reached: lam,
                            attempted: target,
                            cutbacks,
                            last_residual: rel,
                        });
                    }
                    cutbacks += 1;
                    dlam *= 0.5;
                    u.copy_from_slice(&ws.u_conv);
                    assembled_at_u = false;
                }
            }
        }
        Ok(())
    };
    ws.p0 = p0;
    match outcome {
        Ok(()) => {}
        Err(Fail::Linear(source)) => return Err(NewtonError::Linear { source, history }),
        Err(Fail::NotConverged {
            reached,
            attempted,
            cutbacks,
            last_residual,
        }) => {
            return Err(NewtonError::NotConverged {
                reached,
                attempted,
                cutbacks,
                last_residual,
                history,
            });
        }
    }
    Ok(NewtonReport {
        iterations: cnt.iterations,
        increments,
        cutbacks,
        factorizations: cnt.factorizations,
        linear_iterations: cnt.linear_iterations,
        indefinite: cnt.indefinite,
        relative_residual: last_rel,
        history,
    })
}

/// The checks of [`solve`]'s inputs: parameters, design, lengths, finite values.
fn check_inputs(
    model: &Model,
    design: &Design,
    load: &[f64],
    u: &[f64],
    params: &NewtonParams,
) -> Result<(), NewtonError> {
    params.validate()?;
    design.validate(model.mesh().n_elements())?;
    crate::error::check_len("load", load.len(), model.n_dofs())?;
    crate::error::check_len("u", u.len(), model.n_dofs())?;
    for (what, v) in [("u", u), ("load", load)] {
        if let Some(index) = v.iter().position(|x| !x.is_finite()) {
            return Err(ParamError::NonFinite { what, index }.into());
        }
    }
    Ok(())
}

/// Assembles residual and tangent at the initial state `u` (into `ws.r_full`, `ws.tangent`)
/// and returns the reference force of the convergence test: `‖P‖` on the free DOFs, or, under
/// zero load, the initial out-of-balance force `‖R(u₀)‖`.
fn reference_force(
    model: &Model,
    design: &Design,
    load: &[f64],
    u: &[f64],
    ws: &mut NewtonWorkspace,
) -> f64 {
    let free = model.dofs().free_dofs();
    let p_norm = free.iter().map(|&d| load[d] * load[d]).sum::<f64>().sqrt();
    model.assemble(
        design,
        u,
        Some(&mut ws.r_full),
        Some(&mut ws.tangent),
        &mut ws.assembly,
    );
    let r0 = free
        .iter()
        .map(|&d| ws.r_full[d].powi(2))
        .sum::<f64>()
        .sqrt();
    if p_norm > 0.0 { p_norm } else { r0 }
}

#[allow(clippy::too_many_arguments)]
fn increment(
    model: &Model,
    design: &Design,
    load: &[f64],
    p0: &[f64],
    u: &mut [f64],
    lam: f64,
    p_ref_total: f64,
    params: &NewtonParams,
    ws: &mut NewtonWorkspace,
    precond: Option<&Factor>,
    history: &mut Vec<IterationRecord>,
    cnt: &mut Counters,
    assembled_at_u: &mut bool,
) -> Result<f64, IncrementFailure> {
    let dofs = model.dofs();
    let free = dofs.free_dofs();
    let p_lam = |d: usize| ws_p0_interp(p0, load, lam, d);
    let p_ref = {
        let n = free.iter().map(|&d| p_lam(d).powi(2)).sum::<f64>().sqrt();
        if n > 0.0 { n } else { p_ref_total }
    };
    if !*assembled_at_u {
        model.assemble(
            design,
            u,
            Some(&mut ws.r_full),
            Some(&mut ws.tangent),
            &mut ws.assembly,
        );
        *assembled_at_u = true;
    }
    // Out-of-balance force on free DOFs: rhs = P_λ − R(u).
    let fill_rhs = |rhs: &mut [f64], r_full: &[f64]| {
        for (x, &d) in rhs.iter_mut().zip(free) {
            *x = ws_p0_interp(p0, load, lam, d) - r_full[d];
        }
    };
    fill_rhs(&mut ws.rhs, &ws.r_full);
    let mut rn = norm(&ws.rhs);
    let mut last_du_rel = f64::INFINITY;
    let mut last_alpha = 0.0;
    for it in 0..=params.max_iterations {
        let rel = rn / p_ref;
        if !rel.is_finite() {
            return Err(IncrementFailure::NotConverged(rel));
        }
        let at_tolerance = rel <= params.residual_tol && last_du_rel <= params.displacement_tol;
        let at_machine_precision = last_alpha == 1.0 && last_du_rel <= MACHINE_INCREMENT;
        if it > 0 && (at_tolerance || at_machine_precision) {
            return Ok(rel);
        }
        if it == params.max_iterations {
            return Err(IncrementFailure::NotConverged(rel));
        }
        // Linear solve K_T du = rhs.
        let lin_its = linear_solve(params, ws, precond, cnt)
            .map_err(|e| IncrementFailure::Linear(e, it == 0))?;
        cnt.iterations += 1;
        cnt.linear_iterations += lin_its;
        // Line search.
        dofs.scatter(&ws.du, &mut ws.du_full);
        let s0: f64 = ws.du.iter().zip(&ws.rhs).map(|(a, b)| a * b).sum();
        let mut alpha = 1.0;
        let mut accepted = false;
        for ls in 0..=params.max_line_search {
            for ((t, &ui), &di) in ws.u_trial.iter_mut().zip(u.iter()).zip(&ws.du_full) {
                *t = ui + alpha * di;
            }
            model.assemble(
                design,
                &ws.u_trial,
                Some(&mut ws.r_full),
                Some(&mut ws.tangent),
                &mut ws.assembly,
            );
            fill_rhs(&mut ws.rhs, &ws.r_full);
            let rn_new = norm(&ws.rhs);
            if rn_new.is_finite() {
                let s: f64 = ws.du.iter().zip(&ws.rhs).map(|(a, b)| a * b).sum();
                if params.max_line_search == 0
                    || rn_new < rn
                    || rn_new / p_ref <= params.residual_tol
                    || s.abs() <= 0.8 * s0.abs()
                {
                    rn = rn_new;
                    accepted = true;
                    break;
                }
            }
            if ls < params.max_line_search {
                alpha *= 0.5;
            }
        }
        let du_norm = alpha * norm(&ws.du);
        last_alpha = if accepted { alpha } else { 0.0 };
        u.copy_from_slice(&ws.u_trial);
        let u_norm = norm(u);
        last_du_rel = if u_norm > 0.0 {
            du_norm / u_norm
        } else {
            du_norm
        };
        history.push(IterationRecord {
            load_factor: lam,
            iteration: it,
            residual_norm: rn,
            relative_residual: rn / p_ref,
            relative_increment: last_du_rel,
            step_length: alpha,
            linear_iterations: lin_its,
        });
        if !accepted {
            return Err(IncrementFailure::NotConverged(rn / p_ref));
        }
    }
    unreachable!("loop returns at it == max_iterations")
}

#[inline(always)]
fn ws_p0_interp(p0: &[f64], load: &[f64], lam: f64, d: usize) -> f64 {
    p0[d] + lam * (load[d] - p0[d])
}

/// Solve `K_T du = rhs` into `ws.du` according to the strategy; returns inner iterations.
fn linear_solve(
    params: &NewtonParams,
    ws: &mut NewtonWorkspace,
    precond: Option<&Factor>,
    cnt: &mut Counters,
) -> Result<usize, SolverError> {
    match params.linear {
        LinearStrategy::Direct => {
            let kind = ws.factor.factorize(&ws.tangent)?;
            cnt.factorizations += 1;
            cnt.indefinite |= kind != FactorKind::Llt;
            ws.factor_current = true;
            ws.du.copy_from_slice(&ws.rhs);
            ws.factor.solve_in_place(&mut ws.du, &mut ws.solve_ws)?;
            Ok(1)
        }
        LinearStrategy::Pcg(pp) => {
            ws.du.fill(0.0);
            let first = match precond {
                Some(m) => pcg(
                    &ws.tangent,
                    m,
                    &ws.rhs,
                    &mut ws.du,
                    pp,
                    &mut ws.pcg,
                    &mut ws.solve_ws,
                ),
                None => {
                    if !ws.factor_current {
                        let kind = ws.factor.factorize(&ws.tangent)?;
                        cnt.factorizations += 1;
                        cnt.indefinite |= kind != FactorKind::Llt;
                        ws.factor_current = true;
                    }
                    pcg(
                        &ws.tangent,
                        &ws.factor,
                        &ws.rhs,
                        &mut ws.du,
                        pp,
                        &mut ws.pcg,
                        &mut ws.solve_ws,
                    )
                }
            };
            match first {
                Ok(rep) => Ok(rep.iterations.max(1)),
                Err(SolverError::PcgNotConverged { iterations, .. })
                | Err(SolverError::PcgIndefinite {
                    iteration: iterations,
                    ..
                }) => {
                    // Refresh the own factor at the current state and retry.
                    let kind = ws.factor.factorize(&ws.tangent)?;
                    cnt.factorizations += 1;
                    cnt.indefinite |= kind != FactorKind::Llt;
                    ws.factor_current = true;
                    if kind != FactorKind::Llt {
                        // PCG needs an SPD preconditioner: solve directly with LBLᵀ.
                        ws.du.copy_from_slice(&ws.rhs);
                        ws.factor.solve_in_place(&mut ws.du, &mut ws.solve_ws)?;
                        return Ok(iterations + 1);
                    }
                    ws.du.fill(0.0);
                    let rep = pcg(
                        &ws.tangent,
                        &ws.factor,
                        &ws.rhs,
                        &mut ws.du,
                        pp,
                        &mut ws.pcg,
                        &mut ws.solve_ws,
                    )?;
                    Ok(iterations + rep.iterations.max(1))
                }
                Err(e) => Err(e),
            }
        }
    }
}
