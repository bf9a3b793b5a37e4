//! Linear statics on the body-fitted T6 mesh with *distributing* port couplings.
//!
//! # Ports
//! The design model attaches a PEA, a roller or the output to **one node** of the Q4 mesh. On
//! a body-fitted mesh a point load is a stress singularity (the peak von Mises grows without
//! bound as the mesh is refined), so each port acts on the outline boundary within a radius of
//! its point through a distributing coupling (the "RBE3" element of commercial codes): the port
//! displacement is the weighted mean `ū = Σ w_i u_i` of the boundary nodes, with the weights of
//! a uniform traction on the quadratic edges (`L/6, 2L/3, L/6` per edge of length `L`,
//! normalized to `Σ w = 1`). A force `F` on the port is the uniform traction `f_i = w_i F`; a
//! grounded spring `k` on the port adds `½ k ū²`; a roller `ū_c = 0` is eliminated exactly:
//! `u_{p,c} = −Σ_{i≠p} (w_i/w_p) u_{i,c}` for the node `p` of largest weight. The coupling
//! adds no stiffness and leaves the port free to rotate, like the single node of the design
//! model, and it removes the singularity (a uniform traction on a straight edge gives bounded
//! stresses).
//!
//! # Algebra
//! Every full DOF maps to a combination of reduced unknowns (itself, nothing if fixed, or the
//! combination above); element matrices are assembled through that map into the lower
//! triangle of a CSC matrix, factored by faer's sparse Cholesky (AMD ordering, sequential).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::{Conj, Par, Side};
use rayon::prelude::*;

use crate::error::{Result, VerifyError};
use crate::mesh::TriMesh;
use crate::t6::{self, PlaneStress};

/// A port: boundary nodes near a point, coupled to their weighted mean displacement.
#[derive(Debug, Clone, PartialEq)]
pub struct Attachment {
    /// What it is ("PEA1", "output", …), for messages.
    pub name: String,
    /// The port's point \[m\].
    pub point: [f64; 2],
    /// Boundary nodes.
    pub nodes: Vec<usize>,
    /// Their weights (uniform traction, `Σ w = 1`).
    pub weights: Vec<f64>,
    /// Components of the mean displacement held at zero (rollers): `[x, y]`.
    pub fixed: [bool; 2],
}

impl Attachment {
    /// The boundary edges whose mid-node lies within `radius` of `point` (`None` if none).
    pub fn on_boundary(
        mesh: &TriMesh,
        name: &str,
        point: [f64; 2],
        radius: f64,
        fixed: [bool; 2],
    ) -> Option<Self> {
        Self::on_boundary_where(mesh, name, point, fixed, |m| {
            (m[0] - point[0]).hypot(m[1] - point[1]) <= radius
        })
    }

    /// The boundary edges whose mid-node satisfies `select` (`None` if none).
    pub fn on_boundary_where(
        mesh: &TriMesh,
        name: &str,
        point: [f64; 2],
        fixed: [bool; 2],
        select: impl Fn([f64; 2]) -> bool,
    ) -> Option<Self> {
        let mut w = std::collections::BTreeMap::<usize, f64>::new();
        for e in &mesh.boundary {
            if !select(mesh.nodes[e[1]]) {
                continue;
            }
            let (a, b) = (mesh.nodes[e[0]], mesh.nodes[e[2]]);
            let len = (b[0] - a[0]).hypot(b[1] - a[1]);
            *w.entry(e[0]).or_default() += len / 6.0;
            *w.entry(e[1]).or_default() += 2.0 * len / 3.0;
            *w.entry(e[2]).or_default() += len / 6.0;
        }
        let total: f64 = w.values().sum();
        if w.is_empty() || total <= 0.0 {
            return None;
        }
        Some(Self {
            name: name.to_string(),
            point,
            nodes: w.keys().copied().collect(),
            weights: w.values().map(|v| v / total).collect(),
            fixed,
        })
    }

    /// Mean displacement component `c` of the full displacement vector `u`.
    pub fn mean(&self, u: &[f64], c: usize) -> f64 {
        self.nodes
            .iter()
            .zip(&self.weights)
            .map(|(&n, w)| w * u[2 * n + c])
            .sum()
    }
}

/// Lower triangle of a symmetric sparse matrix in CSC.
#[derive(Debug, Clone, PartialEq)]
pub struct SymCsc {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
}

impl SymCsc {
    /// From `(row, col, value)` entries with `row ≥ col`; duplicates add up.
    pub fn from_entries(n: usize, mut e: Vec<(usize, usize, f64)>) -> Self {
        e.par_sort_unstable_by_key(|t| (t.1, t.0));
        let mut col_ptr = vec![0usize; n + 1];
        let mut row_idx = Vec::with_capacity(e.len() / 2);
        let mut values: Vec<f64> = Vec::with_capacity(e.len() / 2);
        let mut last = (usize::MAX, usize::MAX);
        for (r, c, v) in e {
            if (r, c) == last {
                *values.last_mut().expect("an entry") += v;
            } else {
                row_idx.push(r);
                values.push(v);
                col_ptr[c + 1] += 1;
                last = (r, c);
            }
        }
        for c in 0..n {
            col_ptr[c + 1] += col_ptr[c];
        }
        Self {
            n,
            col_ptr,
            row_idx,
            values,
        }
    }

    /// Order.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Stored entries.
    pub fn nnz(&self) -> usize {
        self.values.len()
    }

    /// `y = A x` (both triangles).
    pub fn matvec(&self, x: &[f64], y: &mut [f64]) {
        y.iter_mut().for_each(|v| *v = 0.0);
        for c in 0..self.n {
            for k in self.col_ptr[c]..self.col_ptr[c + 1] {
                let (r, v) = (self.row_idx[k], self.values[k]);
                y[r] += v * x[c];
                if r != c {
                    y[c] += v * x[r];
                }
            }
        }
    }

    fn as_faer(&self) -> faer::sparse::SparseColMatRef<'_, usize, f64> {
        let sym = faer::sparse::SymbolicSparseColMatRef::new_checked(
            self.n,
            self.n,
            &self.col_ptr,
            None,
            &self.row_idx,
        );
        faer::sparse::SparseColMatRef::new(sym, &self.values)
    }
}

/// Sparse Cholesky factor `A = L Lᵀ` (faer low-level API, AMD, sequential).
#[derive(Debug)]
pub struct Cholesky {
    symbolic: SymbolicCholesky<usize>,
    values: Vec<f64>,
}

impl Cholesky {
    /// Factors `a`; a non-positive pivot (a mechanism) is an error.
    pub fn new(a: &SymCsc) -> Result<Self> {
        let symbolic = factorize_symbolic_cholesky(
            a.as_faer().symbolic(),
            Side::Lower,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .map_err(|e| VerifyError::Solver(format!("symbolic analysis: {e:?}")))?;
        let mut values = vec![0.0; symbolic.len_val()];
        let mut mem = MemBuffer::new(
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
        );
        symbolic
            .factorize_numeric_llt::<f64>(
                &mut values,
                a.as_faer(),
                Side::Lower,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(|e| {
                VerifyError::Solver(format!(
                    "the stiffness matrix is not positive definite ({e:?}): a part is not held"
                ))
            })?;
        Ok(Self { symbolic, values })
    }

    /// Solves `A X = B` in place for `ncols` column-major right-hand sides.
    pub fn solve_in_place(&self, rhs: &mut [f64], ncols: usize) {
        let n = self.symbolic.nrows();
        let mut mem = MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(ncols, Par::Seq));
        let mat = faer::MatMut::from_column_major_slice_mut(rhs, n, ncols);
        LltRef::new(&self.symbolic, &self.values).solve_in_place_with_conj(
            Conj::No,
            mat,
            Par::Seq,
            MemStack::new(&mut mem),
        );
    }
}

/// A spring on a linear combination of port mean displacements,
/// `½ k (Σᵢ cᵢ ū_{aᵢ,cᵢ})²` (the design model's `flexstage_fem::LinkSpring`, e.g. the output
/// load relative to the moving frame of Eq. 22).
#[derive(Debug, Clone, PartialEq)]
pub struct PortLink {
    /// `(port index a, component c, coefficient)`.
    pub terms: Vec<(usize, usize, f64)>,
    /// Stiffness k [N/m].
    pub stiffness: f64,
}

/// The body-fitted FE model: mesh, material, ports and direct supports, with the map from
/// full DOFs to reduced unknowns.
#[derive(Debug, Clone)]
pub struct FeModel {
    /// The mesh.
    pub mesh: TriMesh,
    /// Material and thickness.
    pub material: PlaneStress,
    /// Ports.
    pub attachments: Vec<Attachment>,
    /// Directly fixed `(node, component)`.
    pub fixed: Vec<(usize, usize)>,
    /// Full DOF `d` is `Σ coef · reduced[r]` over `terms[offsets[d]..offsets[d + 1]]`.
    offsets: Vec<usize>,
    terms: Vec<(usize, f64)>,
    n: usize,
}

impl FeModel {
    /// Builds the DOF map. Attachments must not share nodes; directly fixed nodes are removed
    /// from them first.
    pub fn new(
        mesh: TriMesh,
        material: PlaneStress,
        mut attachments: Vec<Attachment>,
        fixed: Vec<(usize, usize)>,
    ) -> Result<Self> {
        let nd = 2 * mesh.nodes.len();
        let mut is_fixed = vec![false; nd];
        for &(node, c) in &fixed {
            is_fixed[2 * node + c] = true;
        }
        let names: Vec<String> = attachments.iter().map(|a| a.name.clone()).collect();
        let held: Vec<bool> = attachments
            .iter()
            .map(|a| a.fixed.iter().any(|&f| f))
            .collect();
        let mut owner = vec![usize::MAX; mesh.nodes.len()];
        for (a, att) in attachments.iter_mut().enumerate() {
            let keep: Vec<usize> = (0..att.nodes.len())
                .filter(|&i| !is_fixed[2 * att.nodes[i]] && !is_fixed[2 * att.nodes[i] + 1])
                .collect();
            let total: f64 = keep.iter().map(|&i| att.weights[i]).sum();
            if keep.is_empty() || total <= 0.0 {
                return Err(VerifyError::Outline(format!(
                    "port {} lies on supported boundary only",
                    att.name
                )));
            }
            att.nodes = keep.iter().map(|&i| att.nodes[i]).collect();
            att.weights = keep.iter().map(|&i| att.weights[i] / total).collect();
            // Ports may share boundary nodes unless one of them holds a component (its
            // roller is eliminated through those nodes).
            for &node in &att.nodes {
                if owner[node] != usize::MAX && (att.fixed.iter().any(|&f| f) || held[owner[node]])
                {
                    return Err(VerifyError::Outline(format!(
                        "ports {} and {} overlap (lower VerifyParams::port_radius)",
                        names[owner[node]], att.name
                    )));
                }
                owner[node] = a;
            }
        }
        // Pivot DOFs of the rollers.
        let mut pivot: Vec<Option<(usize, usize)>> = vec![None; nd];
        for (a, att) in attachments.iter().enumerate() {
            let p = (0..att.nodes.len())
                .max_by(|&i, &j| att.weights[i].total_cmp(&att.weights[j]))
                .expect("non-empty");
            for c in 0..2 {
                if att.fixed[c] {
                    pivot[2 * att.nodes[p] + c] = Some((a, p));
                }
            }
        }
        let mut reduced = vec![usize::MAX; nd];
        let mut n = 0;
        for d in 0..nd {
            if !is_fixed[d] && pivot[d].is_none() {
                reduced[d] = n;
                n += 1;
            }
        }
        let mut offsets = Vec::with_capacity(nd + 1);
        let mut terms = Vec::with_capacity(nd);
        offsets.push(0);
        for d in 0..nd {
            if let Some((a, p)) = pivot[d] {
                let att = &attachments[a];
                let c = d % 2;
                for (i, &node) in att.nodes.iter().enumerate() {
                    let r = reduced[2 * node + c];
                    if i != p && r != usize::MAX {
                        terms.push((r, -att.weights[i] / att.weights[p]));
                    }
                }
            } else if reduced[d] != usize::MAX {
                terms.push((reduced[d], 1.0));
            }
            offsets.push(terms.len());
        }
        Ok(Self {
            mesh,
            material,
            attachments,
            fixed,
            offsets,
            terms,
            n,
        })
    }

    /// Number of reduced unknowns.
    pub fn n(&self) -> usize {
        self.n
    }

    fn terms(&self, d: usize) -> &[(usize, f64)] {
        &self.terms[self.offsets[d]..self.offsets[d + 1]]
    }

    /// Pushes the lower-triangle entries of `Tᵀ k T` for the full DOFs `dofs`.
    fn scatter<const N: usize>(
        &self,
        dofs: &[usize; N],
        k: &[[f64; N]; N],
        out: &mut Vec<(usize, usize, f64)>,
    ) {
        for i in 0..N {
            for j in 0..N {
                if k[i][j] == 0.0 {
                    continue;
                }
                for &(ri, ci) in self.terms(dofs[i]) {
                    for &(rj, cj) in self.terms(dofs[j]) {
                        if ri >= rj {
                            out.push((ri, rj, ci * cj * k[i][j]));
                        }
                    }
                }
            }
        }
    }

    fn corners(&self, e: usize) -> t6::Corners {
        let el = &self.mesh.elements[e];
        [
            self.mesh.nodes[el[0]],
            self.mesh.nodes[el[1]],
            self.mesh.nodes[el[2]],
        ]
    }

    fn element_dofs(&self, e: usize) -> [usize; 12] {
        let el = &self.mesh.elements[e];
        std::array::from_fn(|k| 2 * el[k / 2] + k % 2)
    }

    /// `½ k ū_c²` of each port `a` with `springs[a] = [k_x, k_y]` as `(dofs, weights)` pairs.
    fn port_entries(&self, per_port: &[[f64; 2]], out: &mut Vec<(usize, usize, f64)>) {
        for (att, k) in self.attachments.iter().zip(per_port) {
            for (c, &kc) in k.iter().enumerate() {
                if kc == 0.0 {
                    continue;
                }
                for (i, &ni) in att.nodes.iter().enumerate() {
                    for (j, &nj) in att.nodes.iter().enumerate() {
                        let v = kc * att.weights[i] * att.weights[j];
                        self.scatter(&[2 * ni + c, 2 * nj + c], &[[v, 0.0], [0.0, 0.0]], out);
                    }
                }
            }
        }
    }

    /// `½ k (Σᵢ cᵢ ū_{aᵢ,cᵢ})²` of each link spring between port means
    /// (`flexstage_fem::LinkSpring` carried over to the ports): the outer product of its
    /// weights over the nodes of the ports involved.
    fn link_entries(&self, links: &[PortLink], out: &mut Vec<(usize, usize, f64)>) {
        for l in links {
            for &(a, ca, wa) in &l.terms {
                for &(b, cb, wb) in &l.terms {
                    let (att_a, att_b) = (&self.attachments[a], &self.attachments[b]);
                    for (i, &ni) in att_a.nodes.iter().enumerate() {
                        for (j, &nj) in att_b.nodes.iter().enumerate() {
                            let v = l.stiffness * wa * wb * att_a.weights[i] * att_b.weights[j];
                            self.scatter(&[2 * ni + ca, 2 * nj + cb], &[[0.0, v], [0.0, 0.0]], out);
                        }
                    }
                }
            }
        }
    }

    /// Stiffness with grounded springs `springs[a] = [k_x, k_y]` on the ports' mean
    /// displacements and link springs between them.
    pub fn stiffness(&self, springs: &[[f64; 2]], links: &[PortLink]) -> SymCsc {
        let ne = self.mesh.elements.len();
        let mut entries: Vec<(usize, usize, f64)> = (0..ne)
            .into_par_iter()
            .fold(Vec::new, |mut out, e| {
                let k = t6::stiffness(&self.corners(e), &self.material);
                self.scatter(&self.element_dofs(e), &k, &mut out);
                out
            })
            .reduce(Vec::new, |mut a, mut b| {
                a.append(&mut b);
                a
            });
        self.port_entries(springs, &mut entries);
        self.link_entries(links, &mut entries);
        SymCsc::from_entries(self.n, entries)
    }

    /// Consistent mass matrix with density `rho0` [kg/m³] and point masses `masses[a]` \[kg\]
    /// moving with the ports' mean displacements.
    pub fn mass(&self, rho0: f64, masses: &[f64]) -> SymCsc {
        let ne = self.mesh.elements.len();
        let t = self.material.thickness;
        let mut entries: Vec<(usize, usize, f64)> = (0..ne)
            .into_par_iter()
            .fold(Vec::new, |mut out, e| {
                let m = t6::mass(&self.corners(e), rho0, t);
                let el = &self.mesh.elements[e];
                for c in 0..2 {
                    let dofs: [usize; 6] = std::array::from_fn(|a| 2 * el[a] + c);
                    self.scatter(&dofs, &m, &mut out);
                }
                out
            })
            .reduce(Vec::new, |mut a, mut b| {
                a.append(&mut b);
                a
            });
        let per: Vec<[f64; 2]> = masses.iter().map(|&m| [m, m]).collect();
        self.port_entries(&per, &mut entries);
        SymCsc::from_entries(self.n, entries)
    }

    /// Mass of the meshed solid \[kg\].
    pub fn solid_mass(&self, rho0: f64) -> f64 {
        rho0 * self.material.thickness * self.mesh.area()
    }

    /// Reduced load of a force `f` on component `c` of port `a` (a uniform traction).
    pub fn port_load(&self, a: usize, c: usize, f: f64, rhs: &mut [f64]) {
        let att = &self.attachments[a];
        for (&node, w) in att.nodes.iter().zip(&att.weights) {
            for &(r, coef) in self.terms(2 * node + c) {
                rhs[r] += coef * w * f;
            }
        }
    }

    /// Full displacement vector from the reduced unknowns.
    pub fn expand(&self, x: &[f64]) -> Vec<f64> {
        (0..2 * self.mesh.nodes.len())
            .map(|d| self.terms(d).iter().map(|&(r, c)| c * x[r]).sum())
            .collect()
    }

    /// Element-nodal stresses `[σxx, σyy, τxy]` at the six nodes of every element.
    pub fn element_stresses(&self, u: &[f64]) -> Vec<[[f64; 3]; 6]> {
        const AT: [[f64; 3]; 6] = [
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.5, 0.5, 0.0],
            [0.0, 0.5, 0.5],
            [0.5, 0.0, 0.5],
        ];
        (0..self.mesh.elements.len())
            .into_par_iter()
            .map(|e| {
                let dofs = self.element_dofs(e);
                let ue: [f64; 12] = std::array::from_fn(|k| u[dofs[k]]);
                let x = self.corners(e);
                AT.map(|l| t6::stress(&x, &self.material, &ue, l))
            })
            .collect()
    }

    /// Nodal stresses averaged over the elements that share each node.
    pub fn nodal_average(&self, element: &[[[f64; 3]; 6]]) -> Vec<[f64; 3]> {
        let nn = self.mesh.nodes.len();
        let mut sum = vec![[0.0; 3]; nn];
        let mut count = vec![0u32; nn];
        for (el, s) in self.mesh.elements.iter().zip(element) {
            for a in 0..6 {
                for c in 0..3 {
                    sum[el[a]][c] += s[a][c];
                }
                count[el[a]] += 1;
            }
        }
        sum.iter()
            .zip(&count)
            .map(|(s, &n)| s.map(|v| v / n.max(1) as f64))
            .collect()
    }
}
