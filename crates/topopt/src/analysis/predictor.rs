//! A quadratic load-path predictor: the start of every load case's equilibrium iteration.
//!
//! Every load case is a combination of the input loads, `P(t) = Σ_i t_i P_i` with `t_i =
//! x_nom,i / a_i ∈ [−1, 1]` and `P_i = K_pea,i a_i e_in,i` (Eq. 2–3). Expand the residual at
//! `u = 0` as `R(u) = K u + Q(u) + C(u)` with `Q` quadratic and `C` the rest (for St Venant–
//! Kirchhoff material in total Lagrangian kinematics, exactly cubic). The equilibrium
//! `R(u(t)) = P(t)` then has the solution
//!
//! ```text
//! u(t) = Σ_i t_i u_i + Σ_i t_i² w_ii + Σ_{i<j} t_i t_j w_ij + O(t³),
//! K u_i = P_i,   K w_ii = −Q(u_i),   K w_ij = −[Q(u_i + u_j) − Q(u_i) − Q(u_j)],
//! ```
//!
//! and the quadratic part is exact from residual evaluations, since the odd terms cancel:
//! `Q(a) = ½ (R(a) + R(−a))` (up to the quartic and higher even terms of other materials). For
//! two inputs this costs 5 solves with the shared factor of `K` and 6 residual assemblies per
//! design, instead of per-case work: the start error drops from the design change (warm
//! starts) to the cubic term, ≈ (strain)² of the solution, so most cases converge in the first
//! sweep. For small-strain kinematics the predictor is exact.

use flexstage_fem::{AssemblyWorkspace, Design, Factor, SolveWorkspace};

use crate::error::Result;
use crate::problem::Problem;

/// The predictor's vectors for one design (module docs).
#[derive(Debug, Clone, Default)]
pub(crate) struct Predictor {
    /// Reference stroke `a_i` of each input (the largest |x_nom,i| of the cases).
    scale: Vec<f64>,
    /// `u_i` (full vectors), one per input.
    linear: Vec<Vec<f64>>,
    /// `w_ij` for `i ≤ j` (full vectors), row-major over the upper triangle.
    quadratic: Vec<Vec<f64>>,
}

impl Predictor {
    /// Builds the predictor of `design` with the factor `k` of `K(ρ)` at `u = 0`.
    pub(crate) fn build(
        &mut self,
        problem: &Problem,
        design: &Design,
        k: &Factor,
        assembly: &mut AssemblyWorkspace,
        sws: &mut SolveWorkspace,
    ) -> Result<()> {
        let model = &problem.model;
        let dofs = model.dofs();
        let (nf, nd) = (dofs.n_free(), model.n_dofs());
        let ni = problem.inputs.len();
        self.scale = (0..ni)
            .map(|i| problem.cases.iter().fold(0.0f64, |m, c| m.max(c[i].abs())))
            .collect();
        // Linear part: K [u_1 … u_ni] = [P_1 … P_ni], one multi-column solve.
        let mut block = vec![0.0; nf * ni];
        for (i, port) in problem.inputs.iter().enumerate() {
            let mut p = model.zero_vector();
            p[port.dof] = flexstage_fem::pea_force(port.stiffness, self.scale[i]);
            dofs.gather(&p, &mut block[i * nf..(i + 1) * nf]);
        }
        k.solve_columns_in_place(&mut block, ni, sws)?;
        self.linear = (0..ni)
            .map(|i| {
                let mut u = vec![0.0; nd];
                dofs.scatter(&block[i * nf..(i + 1) * nf], &mut u);
                u
            })
            .collect();
        // Quadratic part: Q(a) = ½(R(a) + R(−a)).
        let (mut r, mut tmp) = (vec![0.0; nd], vec![0.0; nd]);
        let mut even = |a: &[f64], out: &mut Vec<f64>| {
            out.clear();
            out.resize(nd, 0.0);
            model.residual(design, a, &mut r, assembly);
            out.copy_from_slice(&r);
            tmp.iter_mut().zip(a).for_each(|(t, v)| *t = -v);
            model.residual(design, &tmp, &mut r, assembly);
            out.iter_mut()
                .zip(&r)
                .for_each(|(o, v)| *o = 0.5 * (*o + v));
        };
        let mut q_ii = vec![Vec::new(); ni];
        for (i, q) in q_ii.iter_mut().enumerate() {
            even(&self.linear[i], q);
        }
        let pairs: Vec<(usize, usize)> =
            (0..ni).flat_map(|i| (i..ni).map(move |j| (i, j))).collect();
        let mut block = vec![0.0; nf * pairs.len()];
        let mut q = Vec::new();
        for (c, &(i, j)) in pairs.iter().enumerate() {
            if i == j {
                q.clone_from(&q_ii[i]);
            } else {
                let sum: Vec<f64> = self.linear[i]
                    .iter()
                    .zip(&self.linear[j])
                    .map(|(a, b)| a + b)
                    .collect();
                even(&sum, &mut q);
                for ((v, a), b) in q.iter_mut().zip(&q_ii[i]).zip(&q_ii[j]) {
                    *v -= a + b;
                }
            }
            let col = &mut block[c * nf..(c + 1) * nf];
            dofs.gather(&q, col);
            col.iter_mut().for_each(|v| *v = -*v);
        }
        k.solve_columns_in_place(&mut block, pairs.len(), sws)?;
        self.quadratic = (0..pairs.len())
            .map(|c| {
                let mut w = vec![0.0; nd];
                dofs.scatter(&block[c * nf..(c + 1) * nf], &mut w);
                w
            })
            .collect();
        Ok(())
    }

    /// The predicted displacements of the case with nominal strokes `x` into `u`.
    pub(crate) fn predict(&self, x: &[f64], u: &mut [f64]) {
        let t: Vec<f64> = x
            .iter()
            .zip(&self.scale)
            .map(|(x, a)| if *a > 0.0 { x / a } else { 0.0 })
            .collect();
        u.fill(0.0);
        for (ti, ui) in t.iter().zip(&self.linear) {
            u.iter_mut().zip(ui).for_each(|(v, w)| *v += ti * w);
        }
        let mut c = 0;
        for i in 0..t.len() {
            for j in i..t.len() {
                let f = t[i] * t[j];
                u.iter_mut()
                    .zip(&self.quadratic[c])
                    .for_each(|(v, w)| *v += f * w);
                c += 1;
            }
        }
    }
}
