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
//! (density × volume × a density → mass interpolation, see `flexstage-reduce`'s
//! `MassInterpolation`), so this module knows nothing about SIMP.
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
    let dofs = model.dofs();
    let pattern = model.pattern().clone();
    let mut m = SparseMatrix::zeros(pattern.clone());
    let vals = m.values_mut();
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
    Ok(m)
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
