//! Constitutive models: SIMP-interpolated St Venant–Kirchhoff (plane stress) and the
//! additive Yeoh hyperelastic material of paper Eq. (A2)–(A4).
//!
//! Voigt convention throughout: strain `[E11, E22, 2·E12]`, stress `[S11, S22, S12]`, so that
//! the energy increment is `Sᵀ·δE`.

// Index loops over small fixed-size tensors mirror the formulas; iterator rewrites obscure them.
#![allow(clippy::needless_range_loop)]

use crate::error::{ParamError, check_len, check_open, check_range};

/// Kinematic description (same element interface for both).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Kinematics {
    /// Small strain: `ε = sym ∇u`, `σ = D ε`. With the additive Yeoh material enabled, its
    /// small-strain linearization (see [`AdditiveYeoh`]) is used.
    Linear,
    /// Total Lagrangian: Green–Lagrange strain `E = ½(H + Hᵀ + HᵀH)` (paper Eq. (A1)),
    /// second Piola–Kirchhoff stress, consistent tangent with geometric stiffness.
    #[default]
    TotalLagrangian,
}

/// SIMP-interpolated isotropic material in plane stress.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Young's modulus of the solid `E0`, Pa (paper Table 3: 73 GPa).
    pub e0: f64,
    /// Young's modulus of void `E_min`, Pa (Table 3: 1 kPa). Must satisfy `0 ≤ E_min < E0`.
    pub e_min: f64,
    /// Poisson's ratio ν ∈ (−1, 0.5) (Table 3: 0.33).
    pub nu: f64,
    /// SIMP penalty `p ≥ 1` (Table 3: 3).
    pub penalty: f64,
}

impl Material {
    /// Paper Table 3 values: E0 = 73 GPa, E_min = 1 kPa, ν = 0.33, p = 3.
    pub fn paper() -> Self {
        Self {
            e0: 73e9,
            e_min: 1e3,
            nu: 0.33,
            penalty: 3.0,
        }
    }

    /// Check every field against its accepted range.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_open("Material::e0", self.e0, 0.0, f64::INFINITY, "(0, ∞) Pa")?;
        check_range("Material::e_min", self.e_min, 0.0, self.e0, "[0, e0) Pa")?;
        if self.e_min >= self.e0 {
            return Err(ParamError::OutOfRange {
                field: "Material::e_min",
                value: self.e_min,
                range: "[0, e0) Pa",
            });
        }
        check_open("Material::nu", self.nu, -1.0, 0.5, "(-1, 0.5)")?;
        check_range("Material::penalty", self.penalty, 1.0, 10.0, "[1, 10]")?;
        Ok(())
    }

    /// Modified SIMP modulus `E(ρ) = E_min + ρ^p (E0 − E_min)`.
    #[inline]
    pub fn modulus(&self, rho: f64) -> f64 {
        self.e_min + rho.powf(self.penalty) * (self.e0 - self.e_min)
    }

    /// `dE/dρ = p ρ^{p−1} (E0 − E_min)`.
    #[inline]
    pub fn dmodulus(&self, rho: f64) -> f64 {
        self.penalty * rho.powf(self.penalty - 1.0) * (self.e0 - self.e_min)
    }

    /// Plane-stress constitutive matrix for unit Young's modulus,
    /// `D̂ = 1/(1−ν²) [[1, ν, 0], [ν, 1, 0], [0, 0, (1−ν)/2]]`.
    #[inline]
    pub fn unit_plane_stress(&self) -> [[f64; 3]; 3] {
        let nu = self.nu;
        let c = 1.0 / (1.0 - nu * nu);
        [
            [c, c * nu, 0.0],
            [c * nu, c, 0.0],
            [0.0, 0.0, c * 0.5 * (1.0 - nu)],
        ]
    }
}

/// Per-element coefficients of the additive Yeoh material, paper Eq. (A2)–(A3):
///
/// `Ψ̃_e = (1 − ρ_e^p) · [ c1e·(I1 − 3 − 2(J − 1)) + c2e·(I1 − 3)² ]`.
///
/// # How `I1` is formed in 2D (and the `−2(J−1)` term)
///
/// The element is treated in **plane strain** for the additive material: `C33 = 1`, so
/// `I1 = tr C = C11 + C22 + 1` and `J = det F = √(C11·C22 − C12²)`. This keeps `I1 − 3 = 0` in
/// the reference state and makes `I1 − 3 = 2(E11 + E22)` exactly, the natural 2D reading of
/// the 3D invariant. (A plane-stress reading would need `C33` from an incompressibility or
/// zero-stress condition, which the paper does not give.)
///
/// The paper's literal energy `c1(I1 − 3)` is the *incompressible* Yeoh/neo-Hookean term: without
/// a pressure it has a non-zero stress `S̃ = 2c1·I` in the undeformed state, so `u = 0` would not
/// be an equilibrium and rigid rotations would produce forces. We therefore add the standard
/// compressible correction `−2c1(J − 1)`, polynomial (no `ln J` singularity, so a Newton trial
/// state with `J ≤ 0` still evaluates). In-plane stretches `λ1, λ2` give
/// `I1 − 3 − 2(J − 1) = (λ1 − λ2)² ≥ 0`: a pure distortion energy with small-strain shear
/// modulus `μ = 2c1`. The `c2` term is unchanged; its small-strain stiffness is a bulk-like
/// `λ_Lamé = 8c2`.
///
/// Second Piola–Kirchhoff stress (paper Eq. (A4), `S̃ = 2 ∂Ψ̃/∂C`):
/// `S̃ = 2(1 − ρ^p)[c1(I − J C⁻¹) + 2c2(I1 − 3) I]`.
#[derive(Debug, Clone, PartialEq)]
pub struct AdditiveYeoh {
    /// `c1e` per element, Pa.
    pub c1: Vec<f64>,
    /// `c2e` per element, Pa.
    pub c2: Vec<f64>,
}

/// Parameters of the `c2` update rule, paper Eq. (A3).
///
/// The paper's `ω_e` is not defined in the text. We take `ω_e = clamp(η_e, ω_min, ω_max)` with
/// `η_e = ε_e/ε*`: below the threshold (`η ≤ 1`) `c2 ← c2·√ω` relaxes `c2` gently, above it
/// (`η > 1`) `c2 ← c2·ω` stiffens the element in proportion to the overshoot. The clamps keep
/// `c2` from collapsing to 0 in unstrained elements or exploding in one update, and the result
/// is clamped to `[c2_min, c2_max]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct YeohUpdate {
    /// Strain threshold ε* > 0 (paper Table 3: 0.5).
    pub eps_star: f64,
    /// Lower clamp of ω, in (0, 1].
    pub omega_min: f64,
    /// Upper clamp of ω, ≥ 1.
    pub omega_max: f64,
    /// Lower bound of c2, Pa (≥ 0).
    pub c2_min: f64,
    /// Upper bound of c2, Pa (≥ c2_min).
    pub c2_max: f64,
}

impl YeohUpdate {
    /// Defaults: ε* = 0.5 (Table 3), ω ∈ [0.5, 2], c2 ∈ [1e-9·E0, 1e-3·E0].
    pub fn paper(e0: f64) -> Self {
        Self {
            eps_star: 0.5,
            omega_min: 0.5,
            omega_max: 2.0,
            c2_min: 1e-9 * e0,
            c2_max: 1e-3 * e0,
        }
    }

    /// Check every field against its accepted range.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_open(
            "YeohUpdate::eps_star",
            self.eps_star,
            0.0,
            f64::INFINITY,
            "(0, ∞)",
        )?;
        check_range(
            "YeohUpdate::omega_min",
            self.omega_min,
            1e-12,
            1.0,
            "(0, 1]",
        )?;
        check_range(
            "YeohUpdate::omega_max",
            self.omega_max,
            1.0,
            1e12,
            "[1, 1e12]",
        )?;
        check_range(
            "YeohUpdate::c2_min",
            self.c2_min,
            0.0,
            f64::MAX,
            "[0, ∞) Pa",
        )?;
        check_range(
            "YeohUpdate::c2_max",
            self.c2_max,
            self.c2_min,
            f64::MAX,
            "[c2_min, ∞) Pa",
        )?;
        Ok(())
    }
}

impl AdditiveYeoh {
    /// Uniform coefficients for `n_elements` elements.
    pub fn uniform(n_elements: usize, c1: f64, c2: f64) -> Self {
        Self {
            c1: vec![c1; n_elements],
            c2: vec![c2; n_elements],
        }
    }

    /// Paper defaults: `c1e = ρ_min^p E0 / 6` (Eq. (A3)) and initial `c2e = 1e-5·E0`
    /// (Table 3's "initial hyper-elastic coefficient 1e-5 E"; since Eq. (A3) fixes `c1`, we read
    /// the table entry as the starting value of the updated coefficient `c2`).
    pub fn paper(n_elements: usize, e0: f64, rho_min: f64, penalty: f64) -> Self {
        Self::uniform(n_elements, rho_min.powf(penalty) * e0 / 6.0, 1e-5 * e0)
    }

    /// Validate sizes and signs.
    pub fn validate(&self, n_elements: usize) -> Result<(), ParamError> {
        check_len("AdditiveYeoh::c1", self.c1.len(), n_elements)?;
        check_len("AdditiveYeoh::c2", self.c2.len(), n_elements)?;
        for (&a, &b) in self.c1.iter().zip(&self.c2) {
            check_range("AdditiveYeoh::c1", a, 0.0, f64::MAX, "[0, ∞) Pa")?;
            check_range("AdditiveYeoh::c2", b, 0.0, f64::MAX, "[0, ∞) Pa")?;
        }
        Ok(())
    }

    /// The `c2` update of paper Eq. (A3), given per-element average von Mises strains `ε_e`
    /// (e.g. from [`crate::Model::element_von_mises_strains`]): `η_e = ε_e/ε*`,
    /// `ω_e = clamp(η_e, ω_min, ω_max)`, `c2 ← c2·√ω_e` if `η_e ≤ 1`, else `c2·ω_e`, then
    /// clamped to `[c2_min, c2_max]`.
    pub fn update_c2(&mut self, strains: &[f64], rule: &YeohUpdate) -> Result<(), ParamError> {
        rule.validate()?;
        check_len("strains", strains.len(), self.c2.len())?;
        for (c2, &eps) in self.c2.iter_mut().zip(strains) {
            let eta = eps / rule.eps_star;
            let omega = if eta.is_finite() {
                eta.clamp(rule.omega_min, rule.omega_max)
            } else {
                rule.omega_max
            };
            let f = if eta <= 1.0 { omega.sqrt() } else { omega };
            *c2 = (*c2 * f).clamp(rule.c2_min, rule.c2_max);
        }
        Ok(())
    }
}

/// Stress, material tangent and energy density at one point.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct PointResponse {
    pub s: [f64; 3],
    pub d: [[f64; 3]; 3],
    pub psi: f64,
}

/// Additive Yeoh energy (without the `(1−ρ^p)` factor), stress and tangent from the Green–
/// Lagrange strain (Voigt). Derivation: with `C11 = 1+2E11`, `C22 = 1+2E22`, `C12 = γ = 2E12`,
/// `d = det C`, `J = √d`, `s = I1 − 3 = 2(E11+E22)`, `q = ∂J/∂(E11,E22,γ) = (C22, C11, −C12)/J`:
/// `Ψ = c1(s − 2J + 2) + c2 s²`, `S = 2c1(n − q) + 4c2 s n` with `n = (1,1,0)`,
/// `D = −2c1 ∂q/∂E + 8c2 n nᵀ`, `∂q/∂E = (1/(2J)) ∂²d − q qᵀ/J`.
#[inline]
pub(crate) fn yeoh_response(c1: f64, c2: f64, e: [f64; 3]) -> PointResponse {
    let c11 = 1.0 + 2.0 * e[0];
    let c22 = 1.0 + 2.0 * e[1];
    let c12 = e[2];
    let det = c11 * c22 - c12 * c12;
    let j = det.sqrt();
    let s = 2.0 * (e[0] + e[1]);
    let inv_j = 1.0 / j;
    let q = [c22 * inv_j, c11 * inv_j, -c12 * inv_j];
    let psi = c1 * (s - 2.0 * j + 2.0) + c2 * s * s;
    let stress = [
        2.0 * c1 * (1.0 - q[0]) + 4.0 * c2 * s,
        2.0 * c1 * (1.0 - q[1]) + 4.0 * c2 * s,
        -2.0 * c1 * q[2],
    ];
    // Hessian of d w.r.t. (E11, E22, γ): [[0,4,0],[4,0,0],[0,0,-2]].
    let h = 0.5 * inv_j;
    let dd = [
        [0.0, 4.0 * h, 0.0],
        [4.0 * h, 0.0, 0.0],
        [0.0, 0.0, -2.0 * h],
    ];
    let mut d = [[0.0; 3]; 3];
    for a in 0..3 {
        for b in 0..3 {
            let dq = dd[a][b] - q[a] * q[b] * inv_j;
            let nn = if a < 2 && b < 2 { 1.0 } else { 0.0 };
            d[a][b] = -2.0 * c1 * dq + 8.0 * c2 * nn;
        }
    }
    PointResponse { s: stress, d, psi }
}

/// Small-strain linearization of [`yeoh_response`] at `E = 0`:
/// `D0 = 2c1 [[1,−1,0],[−1,1,0],[0,0,1]] + 8c2 n nᵀ`.
#[inline]
pub(crate) fn yeoh_linear_d(c1: f64, c2: f64) -> [[f64; 3]; 3] {
    [
        [2.0 * c1 + 8.0 * c2, -2.0 * c1 + 8.0 * c2, 0.0],
        [-2.0 * c1 + 8.0 * c2, 2.0 * c1 + 8.0 * c2, 0.0],
        [0.0, 0.0, 2.0 * c1],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yeoh_stress_is_energy_gradient_and_tangent_is_stress_gradient() {
        let (c1, c2) = (1.3, 0.7);
        let e = [0.11, -0.07, 0.23];
        let r = yeoh_response(c1, c2, e);
        let h = 1e-6;
        for a in 0..3 {
            let mut ep = e;
            let mut em = e;
            ep[a] += h;
            em[a] -= h;
            let rp = yeoh_response(c1, c2, ep);
            let rm = yeoh_response(c1, c2, em);
            let ds = (rp.psi - rm.psi) / (2.0 * h);
            assert!((ds - r.s[a]).abs() < 1e-7, "S[{a}]");
            for b in 0..3 {
                let dd = (rp.s[b] - rm.s[b]) / (2.0 * h);
                assert!((dd - r.d[b][a]).abs() < 1e-7, "D[{b}][{a}]");
            }
        }
        let r0 = yeoh_response(c1, c2, [0.0; 3]);
        assert!(r0.s.iter().all(|s| s.abs() < 1e-14));
        let d0 = yeoh_linear_d(c1, c2);
        for a in 0..3 {
            for b in 0..3 {
                assert!((d0[a][b] - r0.d[a][b]).abs() < 1e-12);
            }
        }
    }
}
