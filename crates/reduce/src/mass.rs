//! Mass of a design: the lumped mass `M` of the reduced model (Eq. 30–32) and the FE mass
//! matrix of the modal analysis.
//!
//! # Lumped mass `M`
//! `M = Σ_e ρ_e · ρ0 · V_e` (physical density × material density, Table 3: 2710 kg/m³, ×
//! element volume), [`design_mass`]: the mass of material the design contains, grey elements
//! counted in proportion.
//!
//! # Mass interpolation for the modal analysis
//! [`MassInterpolation`] (re-exported from `flexstage-fem`, where the design loop uses it too):
//! Du & Olhoff's (2007) interpolation, `m = ρ` above `ρ_c = 0.1` and a C¹ polynomial
//! `c₁ρ⁶ + c₂ρ⁷` below, so void and faint grey regions carry no mass and make no spurious
//! local modes (Pedersen 2000).
//!
//! # Element mass matrices (rectangular Q4, thickness t)
//! * consistent: `m_e/36 · [[4,2,1,2],[2,4,2,1],[1,2,4,2],[2,1,2,4]] ⊗ I₂` (counter-clockwise
//!   nodes), assembled by `flexstage_fem::consistent_mass` (the one implementation);
//! * lumped (row sum): `m_e/4` on each node and direction.
//!
//! Point masses (e.g. the input plates `m_in`) add to both directions of a node.

pub use flexstage_fem::MassInterpolation;
use flexstage_fem::{DofMass, Mesh, Model, consistent_mass};

use crate::error::{Result, check};

/// `Σ_e ρ_e ρ0 V_e` \[kg\].
pub fn design_mass(mesh: &Mesh, rho: &[f64], density: f64) -> f64 {
    let v = mesh.dx() * mesh.dy() * mesh.thickness;
    rho.iter().sum::<f64>() * density * v
}

/// Consistent or lumped element mass matrices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MassLumping {
    /// Consistent (bilinear shape functions).
    Consistent,
    /// Row-sum lumped (diagonal).
    Lumped,
}

/// A point mass on a node, in the directions `axes` (`[x, y]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointMass {
    /// Node id.
    pub node: usize,
    /// Mass \[kg\], ≥ 0.
    pub mass: f64,
    /// The displacement components that carry it (`[true, true]`: a rigid body on the node;
    /// `[true, false]`: an input plate's share of its face, which moves in x).
    pub axes: [bool; 2],
}

/// Symmetric mass matrix on the model's free DOFs, CSR (full storage).
#[derive(Debug, Clone, PartialEq)]
pub struct MassMatrix {
    row_ptr: Vec<usize>,
    col_idx: Vec<usize>,
    values: Vec<f64>,
    total: f64,
}

impl MassMatrix {
    /// Assembles the mass matrix of `model` for densities `rho`, material density `density`
    /// [kg/m³] and point masses.
    pub fn assemble(
        model: &Model,
        rho: &[f64],
        density: f64,
        interpolation: MassInterpolation,
        lumping: MassLumping,
        point_masses: &[PointMass],
    ) -> Result<Self> {
        interpolation.validate()?;
        check(
            "material density",
            density,
            density > 0.0,
            "a finite number > 0 [kg/m³]",
        )?;
        let mesh = model.mesh();
        if rho.len() != mesh.n_elements() {
            return Err(crate::ReduceError::Input(format!(
                "{} densities for {} elements",
                rho.len(),
                mesh.n_elements()
            )));
        }
        for p in point_masses {
            check(
                "PointMass::mass",
                p.mass,
                p.mass >= 0.0,
                "a finite number ≥ 0 [kg]",
            )?;
            if p.node >= mesh.n_nodes() {
                return Err(crate::ReduceError::Input(format!(
                    "point mass on node {} of {}",
                    p.node,
                    mesh.n_nodes()
                )));
            }
        }
        let dofs = model.dofs();
        let v = mesh.dx() * mesh.dy() * mesh.thickness;
        let element_mass: Vec<f64> = rho
            .iter()
            .map(|&r| interpolation.relative_mass(r) * density * v)
            .collect();
        let total = point_masses
            .iter()
            .fold(element_mass.iter().sum::<f64>(), |t, p| t + p.mass);
        let mut trip: Vec<(usize, usize, f64)> = Vec::with_capacity(mesh.n_elements() * 32);
        match lumping {
            MassLumping::Lumped => {
                for (e, &m) in element_mass.iter().enumerate() {
                    for &node in mesh.element_nodes(e).iter().filter(|_| m != 0.0) {
                        for d in 0..2 {
                            if let Some(r) = dofs.reduced(2 * node + d) {
                                trip.push((r, r, 0.25 * m));
                            }
                        }
                    }
                }
                for p in point_masses {
                    for d in (0..2).filter(|&d| p.axes[d]) {
                        if let Some(r) = dofs.reduced(2 * p.node + d) {
                            trip.push((r, r, p.mass));
                        }
                    }
                }
            }
            // The consistent element mass is `flexstage_fem::consistent_mass` (the one
            // implementation of the Q4 element mass), stored as its lower triangle in the
            // model's pattern; mirrored here into full storage.
            MassLumping::Consistent => {
                let dof_masses: Vec<DofMass> = point_masses
                    .iter()
                    .flat_map(|p| {
                        (0..2).filter(move |&d| p.axes[d]).map(move |d| DofMass {
                            dof: 2 * p.node + d,
                            mass: p.mass,
                        })
                    })
                    .collect();
                let lower = consistent_mass(model, &element_mass, &dof_masses)?;
                let pattern = lower.pattern();
                let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
                for c in 0..dofs.n_free() {
                    let (from, to) = (col_ptr[c], col_ptr[c + 1]);
                    for (&r, &value) in row_idx[from..to].iter().zip(&lower.values()[from..to]) {
                        trip.push((r, c, value));
                        if r != c {
                            trip.push((c, r, value));
                        }
                    }
                }
            }
        }
        trip.sort_unstable_by_key(|t| (t.0, t.1));
        let n = dofs.n_free();
        let mut row_ptr = vec![0usize; n + 1];
        let mut col_idx = Vec::with_capacity(trip.len());
        let mut values: Vec<f64> = Vec::with_capacity(trip.len());
        let mut last: Option<(usize, usize)> = None;
        for (r, c, v) in trip {
            if last == Some((r, c)) {
                *values.last_mut().expect("entry") += v;
            } else {
                row_ptr[r + 1] += 1;
                col_idx.push(c);
                values.push(v);
                last = Some((r, c));
            }
        }
        for r in 0..n {
            row_ptr[r + 1] += row_ptr[r];
        }
        Ok(Self {
            row_ptr,
            col_idx,
            values,
            total,
        })
    }

    /// Order (number of free DOFs).
    pub fn n(&self) -> usize {
        self.row_ptr.len() - 1
    }

    /// Total mass represented (elements + point masses, including fixed DOFs' share) \[kg\].
    pub fn total_mass(&self) -> f64 {
        self.total
    }

    /// `y = M x` (reduced vectors).
    pub fn matvec(&self, x: &[f64], y: &mut [f64]) {
        for (r, yr) in y.iter_mut().enumerate() {
            let mut acc = 0.0;
            for k in self.row_ptr[r]..self.row_ptr[r + 1] {
                acc += self.values[k] * x[self.col_idx[k]];
            }
            *yr = acc;
        }
    }
}
