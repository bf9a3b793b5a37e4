//! The mass matrix of the FE model, stored in the model's own sparsity pattern so that it can
//! be combined entry by entry with the tangent (the effective matrix `c₀M + K_T` of an
//! implicit time step, [`crate::transient`]).
//!
//! # Element mass (rectangular Q4, bilinear shape functions)
//! The consistent mass of an element of mass `m_e` is
//!
//! ```text
//! M_e = m_e/36 · [[4,2,1,2],[2,4,2,1],[1,2,4,2],[2,1,2,4]] ⊗ I₂      (counter-clockwise nodes)
//! ```
//!
//! (e.g. Cook, Malkus, Plesha & Witt, *Concepts and Applications of Finite Element Analysis*,
//! 4th ed., 2002, §11.3). Each row sums to `m_e/4`, so a rigid translation `r` gives
//! `M r` = the nodal masses ([`rigid_body_load`]). The element masses are the caller's
//! (density × volume × a density → mass interpolation), so the assembly knows nothing about
//! SIMP.
//!
//! # Mass interpolation (Du & Olhoff 2007)
//! With SIMP stiffness `E ∝ ρ^p` (p = 3) and mass `∝ ρ`, the ratio `E/m ∝ ρ^{p−1}` vanishes in
//! low-density regions, which then carry spurious, localized low-frequency modes (Pedersen,
//! Struct. Multidisc. Optim. 20 (2000) 2–11). [`MassInterpolation`] is the remedy of Du &
//! Olhoff (Struct. Multidisc. Optim. 34 (2007) 91–110): the true mass `m = ρ` above a
//! threshold `ρ_c` and a polynomial of degree `q + 1` below it,
//!
//! ```text
//! m(ρ) = ρ                                        ρ ≥ ρ_c
//! m(ρ) = ρ_c t^q (q − (q − 1) t),   t = ρ/ρ_c      ρ < ρ_c
//! ```
//!
//! continuous with a continuous slope at `ρ_c` (value `ρ_c`, slope 1), so eigenvalue
//! sensitivities are continuous too. With the defaults `ρ_c = 0.1`, `q = 6` this is Du &
//! Olhoff's `m = c₁ρ⁶ + c₂ρ⁷`, `c₁ = 6·10⁵`, `c₂ = −5·10⁶`. As `ρ → 0`, `E/m ∝ ρ^{p−q} → ∞`:
//! void and faint grey regions become massless and cannot resonate.
//!
//! Point masses add to the diagonal of one DOF. Fixed DOFs are eliminated as in the tangent.

use crate::error::{ParamError, check_len, check_range};
use crate::model::{Model, SparseMatrix};

/// Consistent Q4 element mass pattern, `m_e/36 ·` this matrix (per direction).
const CONSISTENT: [[f64; 4]; 4] = [
    [4.0, 2.0, 1.0, 2.0],
    [2.0, 4.0, 2.0, 1.0],
    [1.0, 2.0, 4.0, 2.0],
    [2.0, 1.0, 2.0, 4.0],
];

/// The density → mass interpolation of the module docs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassInterpolation {
    /// Threshold `ρ_c`, in [0, 1] (0: plain `m = ρ`). Default 0.1.
    pub cutoff: f64,
    /// Exponent `q` below the threshold, in [1, 20]. Default 6.
    pub exponent: f64,
}

impl Default for MassInterpolation {
    fn default() -> Self {
        Self {
            cutoff: 0.1,
            exponent: 6.0,
        }
    }
}

impl MassInterpolation {
    /// Plain proportional mass `m = ρ`.
    pub fn linear() -> Self {
        Self {
            cutoff: 0.0,
            exponent: 1.0,
        }
    }

    /// Checks the fields.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_range("MassInterpolation::cutoff", self.cutoff, 0.0, 1.0, "[0, 1]")?;
        check_range(
            "MassInterpolation::exponent",
            self.exponent,
            1.0,
            20.0,
            "[1, 20]",
        )
    }

    /// Relative mass `m(ρ)`.
    #[inline]
    pub fn relative_mass(&self, rho: f64) -> f64 {
        if rho >= self.cutoff || self.cutoff == 0.0 {
            rho
        } else {
            let (q, t) = (self.exponent, rho / self.cutoff);
            self.cutoff * t.powf(q) * (q - (q - 1.0) * t)
        }
    }

    /// `dm/dρ`.
    #[inline]
    pub fn derivative(&self, rho: f64) -> f64 {
        if rho >= self.cutoff || self.cutoff == 0.0 {
            1.0
        } else {
            let (q, t) = (self.exponent, rho / self.cutoff);
            q * t.powf(q - 1.0) * (q - (q - 1.0) * t) - (q - 1.0) * t.powf(q)
        }
    }

    /// Element masses `m(ρ_e) · density · volume` \[kg\] into `out`.
    pub fn element_masses(&self, rho: &[f64], density: f64, volume: f64, out: &mut [f64]) {
        for (o, &r) in out.iter_mut().zip(rho) {
            *o = self.relative_mass(r) * density * volume;
        }
    }
}

/// A point mass on one DOF (full numbering).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DofMass {
    /// Full DOF index.
    pub dof: usize,
    /// Mass \[kg\], ≥ 0.
    pub mass: f64,
}

/// CSC slot of the lower-triangle entry `(i, j)` of the reduced matrix.
fn slot(pattern: &crate::model::SparsityPattern, i: usize, j: usize) -> usize {
    let (c, r) = if i <= j { (i, j) } else { (j, i) };
    let rows = &pattern.row_idx()[pattern.col_ptr()[c]..pattern.col_ptr()[c + 1]];
    pattern.col_ptr()[c]
        + rows
            .binary_search(&r)
            .expect("consistent mass couples only DOFs of one element")
}

/// The consistent mass matrix of `model` with element masses `element_mass` \[kg\] (fem element
/// order) and point masses, in the model's pattern (reduced DOFs, lower triangle).
pub fn consistent_mass(
    model: &Model,
    element_mass: &[f64],
    point_masses: &[DofMass],
) -> Result<SparseMatrix, ParamError> {
    let mut m = SparseMatrix::zeros(model.pattern().clone());
    consistent_mass_into(model, element_mass, point_masses, &mut m)?;
    Ok(m)
}

/// [`consistent_mass`] into a matrix of the model's pattern (refilled in place, no
/// allocation).
pub fn consistent_mass_into(
    model: &Model,
    element_mass: &[f64],
    point_masses: &[DofMass],
    m: &mut SparseMatrix,
) -> Result<(), ParamError> {
    let mesh = model.mesh();
    check_len("element_mass", element_mass.len(), mesh.n_elements())?;
    for &m in element_mass {
        check_range("element_mass", m, 0.0, f64::MAX, "[0, ∞) kg")?;
    }
    for p in point_masses {
        if p.dof >= model.n_dofs() {
            return Err(ParamError::Index {
                what: "point-mass dof",
                index: p.dof,
                bound: model.n_dofs(),
            });
        }
        check_range("DofMass::mass", p.mass, 0.0, f64::MAX, "[0, ∞) kg")?;
    }
    if !std::sync::Arc::ptr_eq(m.pattern(), model.pattern()) {
        check_len(
            "mass matrix pattern",
            m.pattern().nnz(),
            model.pattern().nnz(),
        )?;
    }
    let dofs = model.dofs();
    let pattern = model.pattern().clone();
    let vals = m.values_mut();
    vals.fill(0.0);
    for (e, &me) in element_mass.iter().enumerate() {
        if me == 0.0 {
            continue;
        }
        let nodes = mesh.element_nodes(e);
        for d in 0..2 {
            for a in 0..4 {
                let Some(ra) = dofs.reduced(2 * nodes[a] + d) else {
                    continue;
                };
                for b in 0..=a {
                    let Some(rb) = dofs.reduced(2 * nodes[b] + d) else {
                        continue;
                    };
                    vals[slot(&pattern, ra, rb)] += me * CONSISTENT[a][b] / 36.0;
                }
            }
        }
    }
    for p in point_masses {
        if let Some(r) = dofs.reduced(p.dof) {
            vals[pattern.diag_slots()[r]] += p.mass;
        }
    }
    Ok(())
}

/// `out[e] = a_eᵀ M̂_e a_e` with `M̂_e` the consistent mass of element `e` per unit element mass
/// (`∂M/∂m_e`), for a full-length vector `a` whose entries at fixed DOFs are zero: with the
/// element masses `m_e(ρ_e)`, `aᵀ(∂M/∂ρ_e)a = m_e'(ρ_e) · out[e]`.
pub fn consistent_mass_forms(model: &Model, a: &[f64], out: &mut [f64]) {
    let mesh = model.mesh();
    assert_eq!(a.len(), model.n_dofs(), "vector length");
    assert_eq!(out.len(), mesh.n_elements(), "out length");
    for (e, o) in out.iter_mut().enumerate() {
        let nodes = mesh.element_nodes(e);
        let mut acc = 0.0;
        for d in 0..2 {
            for (i, &ni) in nodes.iter().enumerate() {
                let ai = a[2 * ni + d];
                let row: f64 = nodes
                    .iter()
                    .zip(&CONSISTENT[i])
                    .map(|(&nj, c)| c * a[2 * nj + d])
                    .sum();
                acc += ai * row;
            }
        }
        *o = acc / 36.0;
    }
}

/// `M r` for the rigid translation `r` along `direction` (0 = x, 1 = y) as a full vector: the
/// nodal masses (row sums of the consistent element masses, `m_e/4` per node) plus the point
/// masses on DOFs of that direction. Fixed DOFs are included, as they move with the base.
/// Used for base (floor) excitation: the inertial load is `−M r a_g`.
pub fn rigid_body_load(
    model: &Model,
    element_mass: &[f64],
    point_masses: &[DofMass],
    direction: usize,
) -> Result<Vec<f64>, ParamError> {
    let mesh = model.mesh();
    check_len("element_mass", element_mass.len(), mesh.n_elements())?;
    check_range("direction", direction as f64, 0.0, 1.0, "0 (x) or 1 (y)")?;
    let mut out = model.zero_vector();
    for (e, &me) in element_mass.iter().enumerate() {
        for n in mesh.element_nodes(e) {
            out[2 * n + direction] += 0.25 * me;
        }
    }
    for p in point_masses {
        if p.dof < out.len() && p.dof % 2 == direction {
            out[p.dof] += p.mass;
        }
    }
    Ok(out)
}
