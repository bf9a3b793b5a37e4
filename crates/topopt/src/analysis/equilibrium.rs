//! Equilibrium of a group of load cases, `R(u_k, ρ) = P_k` (Eq. 6), in lock-step.
//!
//! Preconditioned Richardson sweeps `u_j ← u_j + K(ρ)⁻¹ (P_j − R(u_j))` from the quadratic
//! load-path prediction ([`super::predictor`]; or from the warm starts without it),
//! accelerated by Anderson mixing, with one multi-column solve of the shared factor per sweep
//! for all unconverged cases (the factor is streamed once per sweep, ~3× cheaper per case than
//! single solves) and residual-only assemblies. At the paper's strains `‖I − K⁻¹K_T‖ ≈ 10⁻²`,
//! so a few sweeps reach the residual tolerance. A case converges when
//! `‖P − R(u)‖ ≤ residual_tol·‖P‖` (free DOFs); one that stalls (residual ten times its best)
//! or does not converge in `lockstep_iterations` sweeps falls back to Newton with direct
//! solves from its start, then to retries from `u = 0` with more increments. The tangent (for
//! the adjoint) and the residual are assembled at every converged state; the first sweep
//! assembles both, so a case that converges there (most do from the prediction) needs one
//! assembly in all. A group runs on one thread (the groups and the realizations are the
//! parallel tasks), so its assemblies are serial with the tangent scattered element by element
//! ([`flexstage_fem::Model::assemble_serial`]).

use flexstage_fem::{Design, Factor, LinearStrategy, NewtonParams, SparseMatrix, newton};

use crate::analysis::AnalysisParams;
use crate::analysis::predictor::Predictor;
use crate::analysis::workspace::{CaseState, GroupWorkspace, Slot};
use crate::error::{Result, TopoptError};
use crate::problem::Problem;

/// Work done for one case.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct CaseSolve {
    /// Sweeps plus Newton iterations.
    pub iterations: usize,
    /// Retries from `u = 0`.
    pub retries: usize,
    /// Inner linear iterations.
    pub linear: usize,
}

/// Newton solve of case `k` from `u` (its warm start) with the fallback workspace, then
/// retries from zero with direct solves and more increments. On success `u` holds the
/// solution and the workspace's tangent and residual are at it.
fn solve_case(
    problem: &Problem,
    design: &Design,
    k: usize,
    load: &[f64],
    u: &mut Vec<f64>,
    gws: &mut GroupWorkspace,
    params: &AnalysisParams,
) -> Result<CaseSolve> {
    let model = &problem.model;
    // Stalled sweeps mean the shared factor is far from this case's tangent: Newton with
    // fresh factorizations (quadratic convergence) rather than PCG with it.
    let direct = NewtonParams {
        linear: LinearStrategy::Direct,
        ..params.newton
    };
    let mut trial = u.clone();
    let mut last = match newton::solve(
        model,
        design,
        load,
        &mut trial,
        &direct,
        &mut gws.newton,
        None,
    ) {
        Ok(rep) => {
            *u = trial;
            return Ok(CaseSolve {
                iterations: rep.iterations,
                retries: 0,
                linear: rep.linear_iterations,
            });
        }
        Err(e) => e,
    };
    let mut its = 0;
    let mut incr = params.retry_increments;
    for attempt in 1..=params.retries {
        let p = NewtonParams {
            increments: incr,
            max_cutbacks: 20,
            ..direct
        };
        let mut trial = model.zero_vector();
        match newton::solve(model, design, load, &mut trial, &p, &mut gws.newton, None) {
            Ok(rep) => {
                *u = trial;
                its += rep.iterations;
                return Ok(CaseSolve {
                    iterations: its,
                    retries: attempt,
                    linear: rep.linear_iterations,
                });
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

#[derive(Clone, Copy, PartialEq)]
enum Status {
    Run,
    Done,
    Fallback,
}

/// What a group solve shares with the other groups.
pub(crate) struct Shared<'a> {
    pub design: &'a Design<'a>,
    pub precond: &'a Factor,
    /// The shared matrix when it is every case's tangent (small-strain kinematics).
    pub linear_tangent: Option<&'a SparseMatrix>,
    /// Start of every case (None: the warm starts).
    pub predictor: Option<&'a Predictor>,
    pub params: &'a AnalysisParams,
}

/// Lock-step solve of the cases `first..first + cases.len()` (module docs).
pub(crate) fn solve_group(
    problem: &Problem,
    sh: &Shared,
    loads: &[Vec<f64>],
    first: usize,
    cases: &mut [CaseState],
    gws: &mut GroupWorkspace,
) -> Result<Vec<CaseSolve>> {
    let (design, params) = (sh.design, sh.params);
    let model = &problem.model;
    let dofs = model.dofs();
    let free = dofs.free_dofs();
    let nf = free.len();
    let m = cases.len();
    let tol = params.newton.residual_tol;
    let mut st = vec![Status::Run; m];
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
    // Whether the slot's tangent (of the first sweep) may serve the adjoint: at the final
    // state, or at the prediction when `exact_tangent` is off.
    let mut fresh = vec![false; m];
    for (j, (cs, slot)) in cases.iter_mut().zip(gws.slots.iter_mut()).enumerate() {
        if let Some(p) = sh.predictor {
            p.predict(&problem.cases[first + j], &mut cs.u);
        }
        slot.u0.copy_from_slice(&cs.u);
        slot.re_valid = false;
        slot.aa.reset();
        dofs.gather(&cs.u, &mut slot.aa.x);
    }
    for sweep in 0..=params.lockstep_iterations {
        let rhs = &mut gws.rhs[..nf * m];
        let mut running = 0;
        for (j, (cs, slot)) in cases.iter_mut().zip(gws.slots.iter_mut()).enumerate() {
            let col = &mut rhs[j * nf..(j + 1) * nf];
            col.fill(0.0);
            if st[j] != Status::Run {
                continue;
            }
            // The first sweep also assembles the tangent: most cases converge there.
            let tangent = (sweep == 0 && sh.linear_tangent.is_none()).then_some(&mut slot.tangent);
            model.assemble_serial(design, &cs.u, Some(&mut slot.r), tangent, &mut gws.assembly);
            for (x, &d) in col.iter_mut().zip(free) {
                *x = loads[j][d] - slot.r[d];
            }
            let rel = col.iter().map(|x| x * x).sum::<f64>().sqrt() / pnorm[j];
            if rel <= tol {
                st[j] = Status::Done;
                slot.re.copy_from_slice(gws.assembly.element_residuals());
                slot.re_valid = true;
                fresh[j] = sh.linear_tangent.is_none() && (sweep == 0 || !params.exact_tangent);
                col.fill(0.0);
            } else if !rel.is_finite()
                || rel > 10.0 * best[j]
                || sweep == params.lockstep_iterations
            {
                st[j] = Status::Fallback;
                col.fill(0.0);
            } else {
                best[j] = best[j].min(rel);
                its[j] += 1;
                running += 1;
            }
        }
        if running == 0 {
            break;
        }
        sweep_running(&st, cases, gws, sh.precond, free, running)?;
    }
    let mut out = Vec::with_capacity(m);
    for j in 0..m {
        let slot = &mut gws.slots[j];
        if st[j] == Status::Done {
            // `slot.r` already holds R(u) at the converged state (last sweep).
            match sh.linear_tangent {
                Some(k) => slot.tangent.values_mut().copy_from_slice(k.values()),
                None if fresh[j] => {}
                None => model.assemble_serial(
                    design,
                    &cases[j].u,
                    None,
                    Some(&mut slot.tangent),
                    &mut gws.assembly,
                ),
            }
            out.push(CaseSolve {
                iterations: its[j],
                retries: 0,
                linear: its[j],
            });
            continue;
        }
        let cs = &mut cases[j];
        cs.u.copy_from_slice(&gws.slots[j].u0);
        let s = solve_case(
            problem,
            design,
            first + j,
            &loads[j],
            &mut cs.u,
            gws,
            params,
        )?;
        let Slot { tangent, r, .. } = &mut gws.slots[j];
        tangent
            .values_mut()
            .copy_from_slice(gws.newton.tangent.values());
        r.copy_from_slice(gws.newton.residual());
        out.push(CaseSolve {
            iterations: its[j] + s.iterations,
            retries: s.retries,
            linear: its[j] + s.linear,
        });
    }
    Ok(out)
}

/// One sweep for the running cases: pack their residual columns to the front (forward copies
/// are safe since the packed index never exceeds the original), one multi-column solve with
/// the shared factor, then the Anderson step of each.
fn sweep_running(
    st: &[Status],
    cases: &mut [CaseState],
    gws: &mut GroupWorkspace,
    precond: &Factor,
    free: &[usize],
    running: usize,
) -> Result<()> {
    let nf = free.len();
    let rhs = &mut gws.rhs;
    let mut k = 0;
    for (j, &s) in st.iter().enumerate() {
        if s == Status::Run {
            if k != j {
                rhs.copy_within(j * nf..(j + 1) * nf, k * nf);
            }
            k += 1;
        }
    }
    precond.solve_columns_in_place(&mut rhs[..running * nf], running, &mut gws.sws)?;
    let mut k = 0;
    for (j, (cs, slot)) in cases.iter_mut().zip(gws.slots.iter_mut()).enumerate() {
        if st[j] == Status::Run {
            slot.aa.step(&rhs[k * nf..(k + 1) * nf]);
            k += 1;
            for (x, &d) in slot.aa.x.iter().zip(free) {
                cs.u[d] = *x;
            }
        }
    }
    Ok(())
}
