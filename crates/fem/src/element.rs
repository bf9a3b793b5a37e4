//! Q4 element kernels (2×2 Gauss), allocation-free, on fixed-size arrays.
//!
//! For element `e` with physical density `ρ_e` and displacement `u_e ∈ ℝ⁸` (DOF order
//! `[x0, y0, x1, y1, x2, y2, x3, y3]`, counter-clockwise nodes):
//!
//! * internal force, paper Eq. (A5): `r_e = Σ_gp w·t·detJ · B(u_e)ᵀ (S + S̃)`;
//! * consistent tangent `k_e = ∂r_e/∂u_e = Σ w (Bᵀ D_tot B + G(S + S̃))`, with the geometric
//!   stiffness `G_ab = (∇N_a · (S+S̃) ∇N_b) I₂` (absent for [`Kinematics::Linear`]);
//! * `∂r_e/∂ρ_e = Σ w Bᵀ ∂(S+S̃)/∂ρ`, where `∂S/∂ρ = E'(ρ) D̂ E` and
//!   `∂S̃/∂ρ = −pρ^{p−1} S̃_unit` — the additive term's `(1 − ρ^p)` factor (DECISIONS.md);
//! * strain energy `W_e = Σ w (Ψ_SVK + Ψ̃)`, with `∂W_e/∂u_e = r_e` (hyperelastic) and
//!   `∂W_e/∂ρ_e`.
//!
//! `S = E(ρ) D̂ E` is the SIMP St Venant–Kirchhoff stress (paper `S_e = ρ_e D E` in Eq. (A5),
//! here with the modified SIMP modulus), `D̂` the unit-modulus plane-stress matrix.

// Index loops over small fixed-size tensors mirror the formulas; iterator rewrites obscure them.
#![allow(clippy::needless_range_loop)]

use crate::material::{Kinematics, Material, PointResponse, yeoh_linear_d, yeoh_response};

const GP: f64 = 0.577_350_269_189_625_8; // 1/√3
const XI: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
const GAUSS: [[f64; 2]; 4] = [[-GP, -GP], [GP, -GP], [GP, GP], [-GP, GP]];

/// Geometry data shared by all (identical, axis-aligned rectangular) elements of a structured
/// mesh: shape-function gradients and integration weights at the 4 Gauss points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ElementGeometry {
    /// `∂N_a/∂X_J` at Gauss point `g`: `dndx[g][a][J]`.
    pub dndx: [[[f64; 2]; 4]; 4],
    /// Gauss weight × det J × thickness (reference volume per Gauss point).
    pub wdet: [f64; 4],
    /// Element volume `a·b·t`.
    pub volume: f64,
}

impl ElementGeometry {
    /// Rectangle of size `dx × dy × thickness` (`dx ≠ dy` is supported).
    pub fn rectangle(dx: f64, dy: f64, thickness: f64) -> Self {
        let mut dndx = [[[0.0; 2]; 4]; 4];
        for (g, gp) in GAUSS.iter().enumerate() {
            for (a, xa) in XI.iter().enumerate() {
                let dxi = 0.25 * xa[0] * (1.0 + xa[1] * gp[1]);
                let deta = 0.25 * xa[1] * (1.0 + xa[0] * gp[0]);
                dndx[g][a] = [dxi * 2.0 / dx, deta * 2.0 / dy];
            }
        }
        let w = 0.25 * dx * dy * thickness;
        Self {
            dndx,
            wdet: [w; 4],
            volume: dx * dy * thickness,
        }
    }
}

/// Density-dependent coefficients of one element (computed from `ρ_e` once per evaluation).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ElementCoefficients {
    /// `E(ρ) = E_min + ρ^p (E0 − E_min)`.
    pub modulus: f64,
    /// `dE/dρ`.
    pub dmodulus: f64,
    /// Additive factor `1 − ρ^p` (0 when the additive material is off).
    pub additive: f64,
    /// `d(1 − ρ^p)/dρ = −p ρ^{p−1}` (0 when off).
    pub dadditive: f64,
    /// Yeoh `c1e` (0 when off).
    pub c1: f64,
    /// Yeoh `c2e` (0 when off).
    pub c2: f64,
}

impl ElementCoefficients {
    /// Coefficients for density `rho` and optional Yeoh coefficients `(c1e, c2e)`.
    #[inline]
    pub fn new(material: &Material, rho: f64, yeoh: Option<(f64, f64)>) -> Self {
        // One power per element (integer penalties by multiplication): these coefficients are
        // recomputed at every assembly, and `powf` was ~6 % of a design iteration.
        let p = material.penalty;
        let rp1 = if p.fract() == 0.0 && (1.0..=10.0).contains(&p) {
            rho.powi(p as i32 - 1)
        } else {
            rho.powf(p - 1.0)
        };
        let rp = rp1 * rho;
        let (additive, dadditive, c1, c2) = match yeoh {
            Some((c1, c2)) => (1.0 - rp, -p * rp1, c1, c2),
            None => (0.0, 0.0, 0.0, 0.0),
        };
        let de = material.e0 - material.e_min;
        Self {
            modulus: material.e_min + rp * de,
            dmodulus: p * rp1 * de,
            additive,
            dadditive,
            c1,
            c2,
        }
    }
    #[inline]
    fn has_yeoh(&self) -> bool {
        self.additive != 0.0 || self.dadditive != 0.0
    }
}

/// Element kernel: geometry + kinematics + unit constitutive matrix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ElementKernel {
    /// Shared geometry.
    pub geometry: ElementGeometry,
    /// Kinematics.
    pub kinematics: Kinematics,
    /// Unit-modulus plane-stress matrix `D̂`.
    pub dhat: [[f64; 3]; 3],
}

/// Kinematic quantities at a Gauss point.
#[derive(Clone, Copy)]
pub(crate) struct GpKin {
    /// Deformation gradient F (identity for small strain).
    pub(crate) f: [[f64; 2]; 2],
    /// Green–Lagrange (or small) strain, Voigt `[E11, E22, 2E12]`.
    pub(crate) e: [f64; 3],
}

#[inline(always)]
fn matvec3(d: &[[f64; 3]; 3], e: &[f64; 3]) -> [f64; 3] {
    [
        d[0][0] * e[0] + d[0][1] * e[1] + d[0][2] * e[2],
        d[1][0] * e[0] + d[1][1] * e[1] + d[1][2] * e[2],
        d[2][0] * e[0] + d[2][1] * e[1] + d[2][2] * e[2],
    ]
}

#[inline(always)]
fn dot3(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl ElementKernel {
    /// Kernel for a mesh element of size `dx × dy × thickness`.
    pub fn new(material: &Material, kinematics: Kinematics, dx: f64, dy: f64, t: f64) -> Self {
        Self {
            geometry: ElementGeometry::rectangle(dx, dy, t),
            kinematics,
            dhat: material.unit_plane_stress(),
        }
    }

    #[inline(always)]
    pub(crate) fn kin(&self, g: usize, u: &[f64; 8]) -> GpKin {
        let dn = &self.geometry.dndx[g];
        let mut h = [[0.0; 2]; 2];
        for a in 0..4 {
            for i in 0..2 {
                h[i][0] += u[2 * a + i] * dn[a][0];
                h[i][1] += u[2 * a + i] * dn[a][1];
            }
        }
        match self.kinematics {
            Kinematics::Linear => GpKin {
                f: [[1.0, 0.0], [0.0, 1.0]],
                e: [h[0][0], h[1][1], h[0][1] + h[1][0]],
            },
            Kinematics::TotalLagrangian => GpKin {
                f: [[1.0 + h[0][0], h[0][1]], [h[1][0], 1.0 + h[1][1]]],
                e: [
                    h[0][0] + 0.5 * (h[0][0] * h[0][0] + h[1][0] * h[1][0]),
                    h[1][1] + 0.5 * (h[0][1] * h[0][1] + h[1][1] * h[1][1]),
                    h[0][1] + h[1][0] + h[0][0] * h[0][1] + h[1][0] * h[1][1],
                ],
            },
        }
    }

    /// Strain-displacement matrix `B(u)` (3×8) at Gauss point `g` for deformation gradient `f`.
    #[inline(always)]
    pub(crate) fn bmat(&self, g: usize, f: &[[f64; 2]; 2]) -> [[f64; 8]; 3] {
        let dn = &self.geometry.dndx[g];
        let mut b = [[0.0; 8]; 3];
        for a in 0..4 {
            let (nx, ny) = (dn[a][0], dn[a][1]);
            b[0][2 * a] = f[0][0] * nx;
            b[0][2 * a + 1] = f[1][0] * nx;
            b[1][2 * a] = f[0][1] * ny;
            b[1][2 * a + 1] = f[1][1] * ny;
            b[2][2 * a] = f[0][0] * ny + f[0][1] * nx;
            b[2][2 * a + 1] = f[1][0] * ny + f[1][1] * nx;
        }
        b
    }

    /// Total material response (SVK + additive Yeoh) at strain `e`.
    #[inline(always)]
    fn response(&self, c: &ElementCoefficients, e: &[f64; 3], need_d: bool) -> PointResponse {
        let ds = self.dhat;
        let mut d = [[0.0; 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                d[a][b] = c.modulus * ds[a][b];
            }
        }
        let mut out = PointResponse::default();
        if c.has_yeoh() && c.additive != 0.0 {
            match self.kinematics {
                Kinematics::TotalLagrangian => {
                    let y = yeoh_response(c.c1, c.c2, *e);
                    for a in 0..3 {
                        out.s[a] = c.additive * y.s[a];
                    }
                    out.psi = c.additive * y.psi;
                    if need_d {
                        for a in 0..3 {
                            for b in 0..3 {
                                d[a][b] += c.additive * y.d[a][b];
                            }
                        }
                    }
                }
                Kinematics::Linear => {
                    let d0 = yeoh_linear_d(c.c1, c.c2);
                    for a in 0..3 {
                        for b in 0..3 {
                            d[a][b] += c.additive * d0[a][b];
                        }
                    }
                }
            }
        }
        // SVK part (and, for Linear kinematics, the linearized additive part folded into d).
        let s_lin = match self.kinematics {
            Kinematics::TotalLagrangian => {
                let s = matvec3(&ds, e);
                [c.modulus * s[0], c.modulus * s[1], c.modulus * s[2]]
            }
            Kinematics::Linear => matvec3(&d, e),
        };
        out.psi += 0.5 * dot3(&s_lin, e);
        for a in 0..3 {
            out.s[a] += s_lin[a];
        }
        out.d = d;
        out
    }

    /// `∂S/∂ρ` and `∂Ψ/∂ρ` at strain `e`.
    #[inline(always)]
    fn response_drho(&self, c: &ElementCoefficients, e: &[f64; 3]) -> ([f64; 3], f64) {
        let se = matvec3(&self.dhat, e);
        let mut ds = [c.dmodulus * se[0], c.dmodulus * se[1], c.dmodulus * se[2]];
        let mut dpsi = 0.5 * c.dmodulus * dot3(&se, e);
        if c.has_yeoh() {
            match self.kinematics {
                Kinematics::TotalLagrangian => {
                    let y = yeoh_response(c.c1, c.c2, *e);
                    for a in 0..3 {
                        ds[a] += c.dadditive * y.s[a];
                    }
                    dpsi += c.dadditive * y.psi;
                }
                Kinematics::Linear => {
                    let d0 = yeoh_linear_d(c.c1, c.c2);
                    let s0 = matvec3(&d0, e);
                    for a in 0..3 {
                        ds[a] += c.dadditive * s0[a];
                    }
                    dpsi += 0.5 * c.dadditive * dot3(&s0, e);
                }
            }
        }
        (ds, dpsi)
    }

    /// Internal force `r_e` and (optionally) the consistent tangent `k_e` (row-major 8×8).
    #[inline(always)]
    pub fn residual_tangent(
        &self,
        c: &ElementCoefficients,
        u: &[f64; 8],
        r: &mut [f64; 8],
        k: Option<&mut [[f64; 8]; 8]>,
    ) {
        *r = [0.0; 8];
        let need_k = k.is_some();
        let mut kk = [[0.0; 8]; 8];
        for g in 0..4 {
            let w = self.geometry.wdet[g];
            let kin = self.kin(g, u);
            let resp = self.response(c, &kin.e, need_k);
            let b = self.bmat(g, &kin.f);
            for p in 0..8 {
                r[p] += w * (b[0][p] * resp.s[0] + b[1][p] * resp.s[1] + b[2][p] * resp.s[2]);
            }
            if need_k {
                // DB = D·B (3×8), scaled by w.
                let mut db = [[0.0; 8]; 3];
                for i in 0..3 {
                    for q in 0..8 {
                        db[i][q] = w
                            * (resp.d[i][0] * b[0][q]
                                + resp.d[i][1] * b[1][q]
                                + resp.d[i][2] * b[2][q]);
                    }
                }
                // Full rows of eight (they vectorize; a triangular `q ≥ p` loop stays scalar).
                // Only the upper triangle is kept (symmetrized below), and each of its entries
                // is summed in the same order as before, so the result is bitwise the same.
                let geometric = self.kinematics == Kinematics::TotalLagrangian;
                let dn = &self.geometry.dndx[g];
                let s = resp.s;
                // Geometric stiffness G_ab = w ∇N_a·S∇N_b on the x–x and y–y DOF pairs:
                // `gx[q]` is ∇N_b(q)/2 in the x/y components of DOF q, masked by parity.
                let nxq: [f64; 8] = std::array::from_fn(|q| dn[q / 2][0]);
                let nyq: [f64; 8] = std::array::from_fn(|q| dn[q / 2][1]);
                for p in 0..8 {
                    let (b0, b1, b2) = (b[0][p], b[1][p], b[2][p]);
                    let row = &mut kk[p];
                    for q in 0..8 {
                        row[q] += b0 * db[0][q] + b1 * db[1][q] + b2 * db[2][q];
                    }
                    if geometric {
                        let a = p / 2;
                        let sa = [
                            w * (s[0] * dn[a][0] + s[2] * dn[a][1]),
                            w * (s[2] * dn[a][0] + s[1] * dn[a][1]),
                        ];
                        for q in 0..8 {
                            if q % 2 == p % 2 {
                                row[q] += sa[0] * nxq[q] + sa[1] * nyq[q];
                            }
                        }
                    }
                }
            }
        }
        if let Some(k) = k {
            for p in 0..8 {
                for q in 0..p {
                    kk[p][q] = kk[q][p];
                }
            }
            *k = kk;
        }
    }

    /// Strain energy `W_e(u_e, ρ_e) = ∫ (Ψ_SVK + Ψ̃) dV`.
    pub fn energy(&self, c: &ElementCoefficients, u: &[f64; 8]) -> f64 {
        (0..4)
            .map(|g| {
                let kin = self.kin(g, u);
                self.geometry.wdet[g] * self.response(c, &kin.e, false).psi
            })
            .sum()
    }

    /// `∂r_e/∂ρ_e` (8) and `∂W_e/∂ρ_e`, at fixed `u_e`.
    pub fn drho(&self, c: &ElementCoefficients, u: &[f64; 8], dr: &mut [f64; 8]) -> f64 {
        *dr = [0.0; 8];
        let mut dw = 0.0;
        for g in 0..4 {
            let w = self.geometry.wdet[g];
            let kin = self.kin(g, u);
            let (ds, dpsi) = self.response_drho(c, &kin.e);
            let b = self.bmat(g, &kin.f);
            for p in 0..8 {
                dr[p] += w * (b[0][p] * ds[0] + b[1][p] * ds[1] + b[2][p] * ds[2]);
            }
            dw += w * dpsi;
        }
        dw
    }

    /// Volume-averaged von Mises (Cauchy, plane stress) stress of the element, Pa.
    /// For TL, `σ = F S Fᵀ / det F`; for Linear, `σ = S`.
    pub fn von_mises_stress(&self, c: &ElementCoefficients, u: &[f64; 8]) -> f64 {
        let mut acc = 0.0;
        for g in 0..4 {
            let kin = self.kin(g, u);
            let s = self.response(c, &kin.e, false).s;
            let sig = match self.kinematics {
                Kinematics::Linear => s,
                Kinematics::TotalLagrangian => {
                    let f = kin.f;
                    let sm = [[s[0], s[2]], [s[2], s[1]]];
                    let j = f[0][0] * f[1][1] - f[0][1] * f[1][0];
                    let mut fs = [[0.0; 2]; 2];
                    for i in 0..2 {
                        for k in 0..2 {
                            fs[i][k] = f[i][0] * sm[0][k] + f[i][1] * sm[1][k];
                        }
                    }
                    let mut sg = [[0.0; 2]; 2];
                    for i in 0..2 {
                        for k in 0..2 {
                            sg[i][k] = (fs[i][0] * f[k][0] + fs[i][1] * f[k][1]) / j;
                        }
                    }
                    [sg[0][0], sg[1][1], sg[0][1]]
                }
            };
            acc += (sig[0] * sig[0] - sig[0] * sig[1] + sig[1] * sig[1] + 3.0 * sig[2] * sig[2])
                .max(0.0)
                .sqrt();
        }
        0.25 * acc
    }

    /// Volume-averaged equivalent (von Mises) strain `√(⅔ dev E : dev E)` with `E33 = 0`
    /// (plane-strain reading, consistent with the additive material); used as `ε_e` in the
    /// `c2` update of paper Eq. (A3). Equals `|ε|` for an isochoric uniaxial strain.
    pub fn von_mises_strain(&self, u: &[f64; 8]) -> f64 {
        let mut acc = 0.0;
        for g in 0..4 {
            let e = self.kin(g, u).e;
            let m = (e[0] + e[1]) / 3.0;
            let e12 = 0.5 * e[2];
            let dd = (e[0] - m).powi(2) + (e[1] - m).powi(2) + m * m + 2.0 * e12 * e12;
            acc += (2.0 / 3.0 * dd).sqrt();
        }
        0.25 * acc
    }
}
