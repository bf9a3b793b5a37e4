//! The design variables and the elements they set.
//!
//! Without symmetry each design (non-passive) element has its own variable. With mirror
//! symmetry about the vertical centre line `x = l/2`, element `(i, j)` and its mirror image
//! `(n_l − 1 − i, j)` share one variable, so the density field is mirror-symmetric by
//! construction (DECISIONS.md, "Symmetry"): the filter and the FE model of a symmetric problem
//! commute with the mirror, and the chain rule sums the two elements' sensitivities into their
//! variable.

use flexstage_fem::{Mesh, Passive};

use crate::error::{Result, TopoptError};

const NONE: u32 = u32::MAX;

/// Variables ↔ elements (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct DesignSpace {
    /// Elements of each variable: the element and, with symmetry, its mirror (`NONE` if the
    /// element is its own mirror).
    members: Vec<[u32; 2]>,
    /// Variable of each element (`NONE` for passive elements).
    variable: Vec<u32>,
    mirrored: bool,
    n_design_elements: usize,
}

/// The mirror image of element `e` about `x = l/2`.
pub fn mirror_element(mesh: &Mesh, e: usize) -> usize {
    let (i, j) = (e / mesh.nw, e % mesh.nw);
    mesh.element(mesh.nl - 1 - i, j)
}

impl DesignSpace {
    /// The variables of `mesh` (its passive flags), optionally mirror-symmetric. With symmetry
    /// the passive flags must be mirror-symmetric too.
    pub fn new(mesh: &Mesh, mirrored: bool) -> Result<Self> {
        let ne = mesh.n_elements();
        let mut variable = vec![NONE; ne];
        let mut members = Vec::new();
        for e in 0..ne {
            if mesh.passive[e] != Passive::Design || variable[e] != NONE {
                continue;
            }
            let m = if mirrored { mirror_element(mesh, e) } else { e };
            if mesh.passive[m] != mesh.passive[e] {
                let (i, j) = (e / mesh.nw, e % mesh.nw);
                return Err(TopoptError::Problem(format!(
                    "mirror symmetry: element (i = {i}, j = {j}) is designed but its mirror image \
                     (i = {}, j = {j}) is passive; make the passive regions symmetric about \
                     x = l/2 or set optimization.mirror_symmetry = false",
                    mesh.nl - 1 - i
                )));
            }
            let v = members.len() as u32;
            variable[e] = v;
            variable[m] = v;
            members.push([e as u32, if m == e { NONE } else { m as u32 }]);
        }
        let n_design_elements = variable.iter().filter(|v| **v != NONE).count();
        Ok(Self {
            members,
            variable,
            mirrored,
            n_design_elements,
        })
    }

    /// Number of design variables.
    pub fn n(&self) -> usize {
        self.members.len()
    }

    /// Number of design elements (both halves with symmetry).
    pub fn n_design_elements(&self) -> usize {
        self.n_design_elements
    }

    /// Whether the variables are mirror-symmetric.
    pub fn is_mirrored(&self) -> bool {
        self.mirrored
    }

    /// The variable of element `e`, `None` for a passive element.
    pub fn variable_of(&self, e: usize) -> Option<usize> {
        let v = self.variable[e];
        (v != NONE).then_some(v as usize)
    }

    /// The design elements (ascending).
    pub fn design_elements(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.variable.len()).filter(|&e| self.variable[e] != NONE)
    }

    /// Sets the design elements of `full` from the variables `x`.
    pub fn scatter(&self, x: &[f64], full: &mut [f64]) {
        for (m, &v) in self.members.iter().zip(x) {
            for &e in m.iter().filter(|e| **e != NONE) {
                full[e as usize] = v;
            }
        }
    }

    /// Chain rule `∂/∂x_v = Σ_{e of v} ∂/∂x_e`: the variables' sensitivities from the elements'.
    pub fn gather(&self, g_full: &[f64], out: &mut [f64]) {
        for (o, m) in out.iter_mut().zip(&self.members) {
            *o = m
                .iter()
                .filter(|e| **e != NONE)
                .map(|&e| g_full[e as usize])
                .sum();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mirror_pairs_share_a_variable_and_gather_is_the_adjoint_of_scatter() {
        let mut mesh = Mesh::new(5.0, 2.0, 1.0, 5, 2).unwrap();
        mesh.set_passive(&[mesh.element(0, 0), mesh.element(4, 0)], Passive::Solid);
        let s = DesignSpace::new(&mesh, true).unwrap();
        // 10 elements, 2 passive, the middle column (i = 2) maps to itself: 3 + 2 variables.
        assert_eq!((s.n(), s.n_design_elements()), (5, 8));
        assert_eq!(
            s.variable_of(mesh.element(1, 1)),
            s.variable_of(mesh.element(3, 1))
        );
        let x: Vec<f64> = (0..s.n()).map(|v| 0.1 * (v + 1) as f64).collect();
        let mut full = vec![0.0; 10];
        s.scatter(&x, &mut full);
        for e in 0..10 {
            assert_eq!(full[e], full[mirror_element(&mesh, e)]);
        }
        let g: Vec<f64> = (0..10).map(|e| (e as f64).sin()).collect();
        let mut gx = vec![0.0; s.n()];
        s.gather(&g, &mut gx);
        let a: f64 = full.iter().zip(&g).map(|(p, q)| p * q).sum();
        let b: f64 = x.iter().zip(&gx).map(|(p, q)| p * q).sum();
        assert!((a - b).abs() < 1e-12);
        // An asymmetric passive map is rejected with both elements named.
        mesh.set_passive(&[mesh.element(4, 0)], Passive::Design);
        let e = DesignSpace::new(&mesh, true).unwrap_err().to_string();
        assert!(e.contains("mirror symmetry") && e.contains("i = 4"), "{e}");
    }
}
