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

/// The predictor's vectors for one design (module docs), and the buffers that build them
/// (kept between designs, so a build allocates nothing after the first).
#[derive(Debug, Clone, Default)]
pub(crate) struct Predictor {
    /// Reference stroke `a_i` of each input (the largest |x_nom,i| of the cases).
    scale: Vec<f64>,
    /// `u_i` (full vectors), one per input.
    linear: Vec<Vec<f64>>,
    /// `w_ij` for `i ≤ j` (full vectors), row-major over the upper triangle.
    quadratic: Vec<Vec<f64>>,
    /// Column-major solve block (reduced vectors).
    block: Vec<f64>,
    /// `Q(u_i)` (full vectors).
    q_ii: Vec<Vec<f64>>,
    /// Full-vector scratch: residual, ±state, cross term.
    r: Vec<f64>,
    tmp: Vec<f64>,
    q: Vec<f64>,
    cross: Vec<f64>,
}

/// Resizes a list of full vectors to `count` vectors of length `len` (reusing storage).
fn shape(v: &mut Vec<Vec<f64>>, count: usize, len: usize) {
    v.resize_with(count, Vec::new);
    for x in v.iter_mut() {
        x.clear();
        x.resize(len, 0.0);
    }
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
        let npairs = ni * (ni + 1) / 2;
        self.block.clear();
        self.block.resize(nf * ni.max(npairs), 0.0);
        for v in [&mut self.r, &mut self.tmp, &mut self.q, &mut self.cross] {
            v.clear();
            v.resize(nd, 0.0);
        }
        // Linear part: K [u_1 … u_ni] = [P_1 … P_ni], one multi-column solve.
        for (i, port) in problem.inputs.iter().enumerate() {
            self.r.fill(0.0);
            port.add_force(
                flexstage_fem::pea_force(port.stiffness, self.scale[i]),
                &mut self.r,
            );
            dofs.gather(&self.r, &mut self.block[i * nf..(i + 1) * nf]);
        }
        k.solve_columns_in_place(&mut self.block[..nf * ni], ni, sws)?;
        shape(&mut self.linear, ni, nd);
        for (i, u) in self.linear.iter_mut().enumerate() {
            dofs.scatter(&self.block[i * nf..(i + 1) * nf], u);
        }
        // Quadratic part: Q(a) = ½(R(a) + R(−a)).
        let Self { r, tmp, .. } = self;
        let mut even = |a: &[f64], out: &mut [f64]| {
            model.residual(design, a, r, assembly);
            out.copy_from_slice(r);
            tmp.iter_mut().zip(a).for_each(|(t, v)| *t = -v);
            model.residual(design, tmp, r, assembly);
            out.iter_mut()
                .zip(r.iter())
                .for_each(|(o, v)| *o = 0.5 * (*o + v));
        };
        shape(&mut self.q_ii, ni, nd);
        for (q, u) in self.q_ii.iter_mut().zip(&self.linear) {
            even(u, q);
        }
        let mut c = 0;
        for i in 0..ni {
            for j in i..ni {
                if i == j {
                    self.q.copy_from_slice(&self.q_ii[i]);
                } else {
                    // Q(u_i + u_j) − Q(u_i) − Q(u_j), with the sum in `q` meanwhile.
                    for ((s, a), b) in self.q.iter_mut().zip(&self.linear[i]).zip(&self.linear[j]) {
                        *s = a + b;
                    }
                    even(&self.q, &mut self.cross);
                    for (((v, x), a), b) in self
                        .q
                        .iter_mut()
                        .zip(&self.cross)
                        .zip(&self.q_ii[i])
                        .zip(&self.q_ii[j])
                    {
                        *v = x - a - b;
                    }
                }
                let col = &mut self.block[c * nf..(c + 1) * nf];
                dofs.gather(&self.q, col);
                col.iter_mut().for_each(|v| *v = -*v);
                c += 1;
            }
        }
        k.solve_columns_in_place(&mut self.block[..nf * npairs], npairs, sws)?;
        shape(&mut self.quadratic, npairs, nd);
        for (c, w) in self.quadratic.iter_mut().enumerate() {
            dofs.scatter(&self.block[c * nf..(c + 1) * nf], w);
        }
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
