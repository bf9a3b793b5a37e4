//! Exact adjoint sensitivities of a group of load cases (Algorithm 1, "Objective and
//! constraints evaluation"; replaces the tangent-space approximations of Eq. 13–16).
//!
//! For a response `Q(u_1 … u_pm, ρ)` and case k, `K_T(u_k) λ_k = ∂Q/∂u_k` with the tangent
//! assembled at the converged state, and `dQ/dρ_e = ∂Q/∂ρ_e − Σ_k λ_kᵀ ∂R_k/∂ρ_e`. The right-hand
//! side combines the output and input selectors (Eq. 7), `∂W/∂u = R(u) − K_s u` for the strain
//! energy (springs store no strain energy; the residual of the converged state is reused) and
//! any extra vector of the response (the stress). All (case, response) columns of the group go
//! through one block PCG preconditioned by the shared factor (exact to the PCG tolerance); a
//! column that fails (e.g. an indefinite tangent) falls back to a factorization of its case's
//! tangent. One pass over the elements per case then computes `∂r_e/∂ρ_e` and `∂W_e/∂ρ_e` once
//! and contracts them with every adjoint of the case.
//!
//! **Initial guesses.** The right-hand sides are combinations of a few unit vectors (output,
//! inputs, spring DOFs) plus `a_W·(R(u) − K_s u) ≈ a_W (K − K_s) u`, so with `μ_d = K⁻¹ e_d`
//! (one multi-column solve with the shared factor per design, [`AdjointBasis`]) each adjoint
//! has the guess `Σ_d b_d μ_d + a_W (u − Σ_d (K_s u)_d μ_d)`, exact for small-strain kinematics
//! and off by the relative nonlinearity (≈ the strain) otherwise; PCG then needs about one
//! iteration. Columns with an extra right-hand side (the stress) start from the last
//! evaluation's adjoint instead.

use flexstage_fem::{ColumnOutcome, Design, DofMap, Factor, PcgParams, SparseMatrix, pcg_block};

use crate::analysis::workspace::{CaseState, GroupWorkspace};
use crate::error::Result;
use crate::problem::Problem;
use crate::responses::{CaseCoefficients, PerResponse, ResponseKind};

/// The coefficients of the requested responses for the cases of one group.
pub(crate) type GroupCoefficients<'a> = PerResponse<Option<&'a [CaseCoefficients]>>;

/// `μ_d = K⁻¹ e_d` for the DOFs of the output, inputs and springs (module docs).
#[derive(Debug, Clone, Default)]
pub(crate) struct AdjointBasis {
    /// `(d, μ_d)` with full vectors (storage reused between designs).
    columns: Vec<(usize, Vec<f64>)>,
    block: Vec<f64>,
}

impl AdjointBasis {
    /// Solves for the basis of `problem` with the shared factor `k`.
    pub(crate) fn build(
        &mut self,
        problem: &Problem,
        k: &Factor,
        sws: &mut flexstage_fem::SolveWorkspace,
    ) -> Result<()> {
        let model = &problem.model;
        let dofs = model.dofs();
        let bcs = model.bcs();
        let mut ds: Vec<usize> = vec![2 * problem.output, 2 * problem.output + 1];
        ds.extend(
            problem
                .inputs
                .iter()
                .flat_map(|p| p.face.iter().map(|t| t.0)),
        );
        ds.extend(bcs.springs.iter().map(|s| s.dof));
        ds.extend(bcs.links.iter().flat_map(|l| l.terms.iter().map(|t| t.0)));
        ds.sort_unstable();
        ds.dedup();
        ds.retain(|&d| !dofs.is_fixed(d));
        let nf = dofs.n_free();
        let block = &mut self.block;
        block.clear();
        block.resize(nf * ds.len(), 0.0);
        for (c, &d) in ds.iter().enumerate() {
            block[c * nf + dofs.reduced(d).expect("free")] = 1.0;
        }
        k.solve_columns_in_place(block, ds.len(), sws)?;
        self.columns.resize_with(ds.len(), || (0, Vec::new()));
        for (c, (&d, (dd, mu))) in ds.iter().zip(self.columns.iter_mut()).enumerate() {
            *dd = d;
            mu.resize(model.n_dofs(), 0.0);
            dofs.scatter(&block[c * nf..(c + 1) * nf], mu);
        }
        Ok(())
    }

    fn mu(&self, d: usize) -> Option<&[f64]> {
        self.columns
            .iter()
            .find(|(e, _)| *e == d)
            .map(|(_, m)| m.as_slice())
    }

    /// The linear guess of the module docs for the coefficients `c` at the state `u` (full
    /// vector into `out`); `ks_u` is scratch.
    fn guess(
        &self,
        problem: &Problem,
        c: &CaseCoefficients,
        u: &[f64],
        ks_u: &mut [f64],
        out: &mut [f64],
    ) {
        out.fill(0.0);
        let add = |d: usize, a: f64, out: &mut [f64]| {
            if let (Some(mu), true) = (self.mu(d), a != 0.0) {
                out.iter_mut().zip(mu).for_each(|(o, m)| *o += a * m);
            }
        };
        add(2 * problem.output, c.output[0], out);
        add(2 * problem.output + 1, c.output[1], out);
        for (p, a) in problem.inputs.iter().zip(c.inputs) {
            for &(d, w) in &p.face {
                add(d, w * a, out);
            }
        }
        if c.energy != 0.0 {
            out.iter_mut().zip(u).for_each(|(o, v)| *o += c.energy * v);
            ks_u.fill(0.0);
            problem.model.add_spring_forces(u, -c.energy, ks_u);
            for (d, _) in &self.columns {
                add(*d, ks_u[*d], out);
            }
        }
    }
}

/// `∂Q/∂u_k` of one response and case (module docs) into the full vector `b`.
fn right_hand_side(problem: &Problem, c: &CaseCoefficients, u: &[f64], r: &[f64], b: &mut [f64]) {
    let model = &problem.model;
    b.fill(0.0);
    b[2 * problem.output] += c.output[0];
    b[2 * problem.output + 1] += c.output[1];
    for (p, a) in problem.inputs.iter().zip(c.inputs) {
        p.add_force(a, b);
    }
    if c.energy != 0.0 {
        for (bi, f) in b.iter_mut().zip(r) {
            *bi += c.energy * f;
        }
        // Springs (grounded and link) are not strain energy: subtract a_W·K_s u.
        model.add_spring_forces(u, -c.energy, b);
    }
    if let Some(x) = &c.extra {
        for (bi, xi) in b.iter_mut().zip(x) {
            *bi += xi;
        }
    }
}

/// Adjoint solves and contractions of a group (module docs); `dQ/dρ` contributions without the
/// explicit part accumulate into `gws.grads[q]` for every requested response q.
#[allow(clippy::too_many_arguments)]
pub(crate) fn group_gradients(
    problem: &Problem,
    design: &Design,
    cases: &mut [CaseState],
    coef: &GroupCoefficients,
    gws: &mut GroupWorkspace,
    precond: &Factor,
    basis: &AdjointBasis,
    adjoint: Option<PcgParams>,
) -> Result<()> {
    let model = &problem.model;
    let dofs = model.dofs();
    let nf = dofs.n_free();
    let ne = model.mesh().n_elements();
    // Right-hand sides, one column per (case, active response), case-major.
    let mut cols: Vec<(usize, ResponseKind)> =
        Vec::with_capacity(ResponseKind::FE.len() * cases.len());
    let [b, guess, scratch] = &mut gws.full;
    for (j, cs) in cases.iter_mut().enumerate() {
        cs.adjoint_iterations = 0;
        for q in ResponseKind::FE {
            let Some(c) = coef[q].map(|c| &c[j]) else {
                continue;
            };
            if !c.is_active() {
                continue;
            }
            let col = cols.len();
            // Initial guess (module docs); pcg_block rescales it optimally.
            let x0 = &mut gws.sol[col * nf..(col + 1) * nf];
            if c.extra.is_none() {
                basis.guess(problem, c, &cs.u, scratch, guess);
                dofs.gather(guess, x0);
            } else if cs.lambdas[q].is_empty() {
                x0.fill(0.0);
            } else {
                dofs.gather(&cs.lambdas[q], x0);
            }
            right_hand_side(problem, c, &cs.u, &gws.slots[j].r, b);
            dofs.gather(b, &mut gws.rhs[col * nf..(col + 1) * nf]);
            cols.push((j, q));
        }
    }
    solve_columns(dofs, &cols, cases, gws, precond, adjoint)?;
    for q in ResponseKind::FE {
        if coef[q].is_some() {
            let g = &mut gws.grads[q];
            g.clear();
            g.resize(ne, 0.0);
        }
    }
    contract(problem, design, cases, coef, gws);
    Ok(())
}

/// Solves the adjoint columns `cols` (block PCG, then factorizations for failed columns) and
/// stores each solution as its case's adjoint of the response.
fn solve_columns(
    dofs: &DofMap,
    cols: &[(usize, ResponseKind)],
    cases: &mut [CaseState],
    gws: &mut GroupWorkspace,
    precond: &Factor,
    adjoint: Option<PcgParams>,
) -> Result<()> {
    let k = cols.len();
    if k == 0 {
        return Ok(());
    }
    let nf = dofs.n_free();
    let GroupWorkspace {
        slots,
        rhs,
        sol,
        sws,
        pcg,
        outcome,
        newton,
        ..
    } = gws;
    let (b, x, outcome) = (&rhs[..k * nf], &mut sol[..k * nf], &mut outcome[..k]);
    match adjoint {
        Some(pp) => {
            let mats: Vec<&SparseMatrix> = cols.iter().map(|&(j, _)| &slots[j].tangent).collect();
            pcg_block(&mats, precond, b, x, pp, pcg, sws, outcome)?;
        }
        None => outcome.fill(ColumnOutcome::NotConverged),
    }
    let mut factored: Option<usize> = None;
    for (c, &(j, q)) in cols.iter().enumerate() {
        let cs = &mut cases[j];
        let xc = &mut x[c * nf..(c + 1) * nf];
        match outcome[c] {
            ColumnOutcome::Converged(n) => cs.adjoint_iterations += n,
            _ => {
                if factored != Some(j) {
                    newton.factor.factorize(&slots[j].tangent)?;
                    factored = Some(j);
                }
                xc.copy_from_slice(&b[c * nf..(c + 1) * nf]);
                newton.factor.solve_in_place(xc, &mut newton.solve_ws)?;
                cs.adjoint_iterations += 1;
            }
        }
        let lambda = &mut cs.lambdas[q];
        lambda.resize(dofs.n_full(), 0.0);
        dofs.scatter(xc, lambda);
    }
    Ok(())
}

/// One pass over the elements per case: `∂r_e/∂ρ_e` and `∂W_e/∂ρ_e` once, contracted with every
/// adjoint of the case (λ is zero at fixed DOFs). Without the additive material and the energy
/// response, `r_e` is linear in the element modulus, so `∂r_e/∂ρ_e = (E'/E) r_e` with the
/// element forces stored at convergence: a dot product per element instead of a kernel
/// evaluation.
fn contract(
    problem: &Problem,
    design: &Design,
    cases: &[CaseState],
    coef: &GroupCoefficients,
    gws: &mut GroupWorkspace,
) {
    let model = &problem.model;
    let mesh = model.mesh();
    let kernel = model.kernel();
    let mut dr = [0.0; 8];
    for (j, cs) in cases.iter().enumerate() {
        let active: Vec<(ResponseKind, f64)> = ResponseKind::FE
            .into_iter()
            .filter_map(|q| {
                coef[q]
                    .map(|c| &c[j])
                    .filter(|c| c.is_active())
                    .map(|c| (q, c.energy))
            })
            .collect();
        if active.is_empty() {
            continue;
        }
        let slot = &gws.slots[j];
        let linear_in_modulus =
            design.yeoh.is_none() && slot.re_valid && active.iter().all(|(_, a_w)| *a_w == 0.0);
        for e in 0..mesh.n_elements() {
            let c = model.coefficients(design, e);
            let d = mesh.element_dofs(e);
            let dw = if linear_in_modulus {
                let ratio = c.dmodulus / c.modulus;
                dr.iter_mut()
                    .zip(&slot.re[e])
                    .for_each(|(x, r)| *x = ratio * r);
                0.0
            } else {
                let ue = model.element_displacement(e, &cs.u);
                kernel.drho(&c, &ue, &mut dr)
            };
            for &(q, a_w) in &active {
                let lam = &cs.lambdas[q];
                let s: f64 = (0..8).map(|k| lam[d[k]] * dr[k]).sum();
                gws.grads[q][e] += a_w * dw - s;
            }
        }
    }
}
