//! Stress recovery at the Gauss points, for stress-constrained design.
//!
//! The *solid* stress of an element is the stress it would carry if it were fully solid at its
//! current strain, `S⁰ = E0 D̂ E(u)` (second Piola–Kirchhoff, Voigt `[S11, S22, S12]`, with the
//! Green–Lagrange strain for total Lagrangian kinematics and the small strain otherwise). The
//! relaxed stress measures of stress-constrained topology optimization scale it by a power of
//! the density (the "qp" relaxation, Bruggi 2008; Le, Norato, Bruns, Ha & Tortorelli, "Stress-
//! based topology optimization for continua", SMO 41 (2010) 605–620, Eq. 7: `σ = ρ^{1/2} σ⁰`).
//!
//! Its plane-stress von Mises value is `σ_vm² = S11² − S11 S22 + S22² + 3 S12²`. PK2 and Cauchy
//! stresses differ by terms of the order of the displacement gradient (≈ 1e-3 at the paper's
//! strokes), far below the modelling error of the design mesh, and the PK2 form keeps the
//! derivative simple: `∂σ_vm²/∂u_e = (∂σ_vm²/∂S) E0 D̂ B(u_e)` with `B(u)` the strain–displacement
//! matrix of the kinematics (the one of the internal force).
//!
//! The values are returned *squared*: aggregation functions raise them to a power `P ≥ 2`,
//! and `σ_vm^P = (σ_vm²)^{P/2}` has a derivative that stays finite where `σ_vm = 0`.

use rayon::prelude::*;

use crate::element::ElementKernel;
use crate::model::Model;

/// Gauss points per element.
pub const STRESS_POINTS: usize = 4;

impl ElementKernel {
    /// Squared von Mises value of the solid stress `S⁰ = E0 D̂ E(u)` at each Gauss point
    /// (module docs) and, if `grad` is given, its gradient with respect to the element
    /// displacements (`grad[g][p] = ∂σ_vm,g²/∂u_p`).
    pub fn solid_von_mises_squared(
        &self,
        e0: f64,
        u: &[f64; 8],
        grad: Option<&mut [[f64; 8]; STRESS_POINTS]>,
    ) -> [f64; STRESS_POINTS] {
        let mut out = [0.0; STRESS_POINTS];
        let mut g_out = [[0.0; 8]; STRESS_POINTS];
        let need = grad.is_some();
        let d = &self.dhat;
        for (g, (o, go)) in out.iter_mut().zip(g_out.iter_mut()).enumerate() {
            let kin = self.kin(g, u);
            let e = kin.e;
            let s: [f64; 3] =
                std::array::from_fn(|i| e0 * (d[i][0] * e[0] + d[i][1] * e[1] + d[i][2] * e[2]));
            *o = s[0] * s[0] - s[0] * s[1] + s[1] * s[1] + 3.0 * s[2] * s[2];
            if need {
                // ∂σ²/∂S, then through S = E0 D̂ E and ∂E/∂u = B(u).
                let ds = [2.0 * s[0] - s[1], 2.0 * s[1] - s[0], 6.0 * s[2]];
                let w: [f64; 3] = std::array::from_fn(|j| {
                    e0 * (ds[0] * d[0][j] + ds[1] * d[1][j] + ds[2] * d[2][j])
                });
                let b = self.bmat(g, &kin.f);
                for (p, gp) in go.iter_mut().enumerate() {
                    *gp = w[0] * b[0][p] + w[1] * b[1][p] + w[2] * b[2][p];
                }
            }
        }
        if let Some(gr) = grad {
            *gr = g_out;
        }
        out
    }
}

impl Model {
    /// Squared von Mises values of the solid stress (module docs) at the Gauss points of every
    /// element, `out[e][g]`, for the full displacement vector `u`.
    pub fn solid_von_mises_squared(&self, u: &[f64], out: &mut [[f64; STRESS_POINTS]]) {
        assert_eq!(u.len(), self.n_dofs(), "displacement length");
        assert_eq!(out.len(), self.mesh().n_elements(), "out length");
        let e0 = self.material().e0;
        out.par_iter_mut()
            .enumerate()
            .with_min_len(128)
            .for_each(|(e, o)| {
                *o = self.kernel().solid_von_mises_squared(
                    e0,
                    &self.element_displacement(e, u),
                    None,
                );
            });
    }
}
