//! Linear statics on the body-fitted T6 mesh with *distributing* port couplings.
//!
//! # Ports
//! The design model attaches a PEA, a roller or the output to **one node** of the Q4 mesh. On
//! a body-fitted mesh a point load is a stress singularity (the peak von Mises grows without
//! bound as the mesh is refined), so each port acts on the outline boundary within a radius of
//! its point through a distributing coupling (the "RBE3" element of commercial codes), with
//! the weights `w_i` of a uniform traction on the quadratic edges (`L/6, 2L/3, L/6` per edge
//! of length `L`, normalized to `Σ w = 1`). The port's displacement is that of its point `p`
//! moving with the nodes' weighted least-squares rigid motion: their weighted mean `ū = Σ w_i
//! u_i` at their centroid `c = Σ w_i x_i` and the rotation `θ = Σ w_i (r_i × u_i) / Σ w_i
//! |r_i|²` (`r_i = x_i − c`), carried to the point: `u_p = ū + θ e_z × (p − c)`. A rigid
//! rotation of the nodes about `p` leaves `u_p = 0`, so a roller or a spring on the port does
//! not hold the port's rotation, like the single node of the design model (the plain mean
//! `ū` would: on the edge of a port patch the nodes lie to one side of the port's point, and
//! a roller on their mean clamped the patch's rotation, which raised the first frequency by
//! 5–25 %). Everything on the port goes through the same linear map `u_p = A u`: a force `F`
//! is `Aᵀ F` (the uniform traction plus the moment that keeps it at `p`), a grounded spring
//! `k` adds `½ k u_{p,c}²`, a point mass `½ m u_{p,c}²`, and a roller `u_{p,c} = 0` is
//! eliminated exactly through the DOF of the node of largest weight. The coupling adds no
//! stiffness and removes the singularity (a uniform traction on a straight edge gives bounded
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
    /// Their positions \[m\].
    pub positions: Vec<[f64; 2]>,
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

    /// A point port: the one boundary node nearest `point`, weight 1 (`None` on an empty
    /// boundary).
    pub fn at_nearest_boundary_node(
        mesh: &TriMesh,
        name: &str,
        point: [f64; 2],
        fixed: [bool; 2],
    ) -> Option<Self> {
        let node = mesh.boundary.iter().flatten().copied().min_by(|&a, &b| {
            let d = |n: usize| {
                let q = mesh.nodes[n];
                (q[0] - point[0]).hypot(q[1] - point[1])
            };
            d(a).total_cmp(&d(b))
        })?;
        Some(Self {
            name: name.to_string(),
            point,
            nodes: vec![node],
            weights: vec![1.0],
            positions: vec![mesh.nodes[node]],
            fixed,
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
        let position = |n: usize| mesh.nodes[n];
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
            positions: w.keys().map(|&n| position(n)).collect(),
            fixed,
        })
    }

    /// The map `u_p = A u` (module docs) as `(full DOF, [A_xd, A_yd])` for each node's
    /// components `d`: the port's displacement components are `u_{p,c} = Σ A_cd u_d`.
    pub fn coefficients(&self) -> Vec<(usize, [f64; 2])> {
        let c = self
            .positions
            .iter()
            .zip(&self.weights)
            .fold([0.0; 2], |a, (x, w)| [a[0] + w * x[0], a[1] + w * x[1]]);
        let r: Vec<[f64; 2]> = self
            .positions
            .iter()
            .map(|x| [x[0] - c[0], x[1] - c[1]])
            .collect();
        let j: f64 = r
            .iter()
            .zip(&self.weights)
            .map(|(r, w)| w * (r[0] * r[0] + r[1] * r[1]))
            .sum();
        // e_z × (p − c): the point's velocity per unit rotation. A single node (or coincident
        // nodes) has no rotation to fit.
        let size = r.iter().fold(0.0f64, |m, r| m.max(r[0].hypot(r[1])));
        let lever = if j > 1e-12 * size * size && j > 0.0 {
            [-(self.point[1] - c[1]) / j, (self.point[0] - c[0]) / j]
        } else {
            [0.0; 2]
        };
        let mut out = Vec::with_capacity(2 * self.nodes.len());
        for ((&n, &w), r) in self.nodes.iter().zip(&self.weights).zip(&r) {
            // θ = Σ w_i (r_x u_y − r_y u_x) / J.
            out.push((2 * n, [w - lever[0] * w * r[1], -lever[1] * w * r[1]]));
            out.push((2 * n + 1, [lever[0] * w * r[0], w + lever[1] * w * r[0]]));
        }
        out
    }

    /// Displacement component `c` of the port (module docs) from the full displacement
    /// vector `u`.
    pub fn mean(&self, u: &[f64], c: usize) -> f64 {
        self.coefficients().iter().map(|&(d, a)| a[c] * u[d]).sum()
    }
}

/// The rollers' pivot DOFs as combinations of reduced unknowns: a held component `c` of a
/// port is `Σ_d A_cd u_d = 0` over its nodes; the held components' pivots (`pivot[d] = port`)
/// solve it (one or two equations) for the other DOFs, which are all reduced unknowns (ports
/// that hold a component share no nodes, directly fixed nodes are not on ports).
fn eliminate_rollers(
    attachments: &[Attachment],
    pivot: &[Option<usize>],
    reduced: &[usize],
) -> Result<std::collections::BTreeMap<usize, Vec<(usize, f64)>>> {
    let mut out = std::collections::BTreeMap::new();
    for (a, att) in attachments.iter().enumerate() {
        let held: Vec<usize> = (0..2).filter(|&c| att.fixed[c]).collect();
        if held.is_empty() {
            continue;
        }
        let coef = att.coefficients();
        let piv: Vec<usize> = coef
            .iter()
            .map(|t| t.0)
            .filter(|&d| pivot[d] == Some(a))
            .collect();
        // Equations k: Σ_j P[k][j] u_piv[j] + Σ_r R[k][r] x_r = 0.
        let mut p = [[0.0; 2]; 2];
        let mut rest: Vec<Vec<(usize, f64)>> = vec![Vec::new(); held.len()];
        for (k, &c) in held.iter().enumerate() {
            for &(d, ad) in &coef {
                if let Some(j) = piv.iter().position(|&q| q == d) {
                    p[k][j] += ad[c];
                } else if ad[c] != 0.0 {
                    rest[k].push((reduced[d], ad[c]));
                }
            }
        }
        let inv = match held.len() {
            1 => [[1.0 / p[0][0], 0.0], [0.0, 0.0]],
            _ => {
                let det = p[0][0] * p[1][1] - p[0][1] * p[1][0];
                [
                    [p[1][1] / det, -p[0][1] / det],
                    [-p[1][0] / det, p[0][0] / det],
                ]
            }
        };
        if !inv.iter().flatten().all(|v| v.is_finite()) {
            return Err(VerifyError::Outline(format!(
                "the roller of port {} cannot be eliminated (singular coupling)",
                att.name
            )));
        }
        for (j, &d) in piv.iter().enumerate() {
            let mut t: Vec<(usize, f64)> = Vec::new();
            for (k, r) in rest.iter().enumerate() {
                t.extend(r.iter().map(|&(x, v)| (x, -inv[j][k] * v)));
            }
            out.insert(d, t);
        }
    }
    Ok(out)
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
            att.positions = keep.iter().map(|&i| att.positions[i]).collect();
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
        // Pivot DOFs of the rollers: the held components of the node of largest weight.
        let mut pivot: Vec<Option<usize>> = vec![None; nd];
        for (a, att) in attachments.iter().enumerate() {
            let p = (0..att.nodes.len())
                .max_by(|&i, &j| att.weights[i].total_cmp(&att.weights[j]))
                .expect("non-empty");
            for c in 0..2 {
                if att.fixed[c] {
                    pivot[2 * att.nodes[p] + c] = Some(a);
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
        let eliminated = eliminate_rollers(&attachments, &pivot, &reduced)?;
        let mut offsets = Vec::with_capacity(nd + 1);
        let mut terms = Vec::with_capacity(nd);
        offsets.push(0);
        for (d, &r) in reduced.iter().enumerate() {
            if let Some(t) = eliminated.get(&d) {
                terms.extend_from_slice(t);
            } else if r != usize::MAX {
                terms.push((r, 1.0));
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

    /// `½ k u_{p,c}²` of each port `a` with `springs[a] = [k_x, k_y]` (a grounded spring or
    /// a point mass on the port's displacement, module docs): the outer product of the port's
    /// coefficients.
    fn port_entries(&self, per_port: &[[f64; 2]], out: &mut Vec<(usize, usize, f64)>) {
        for (att, k) in self.attachments.iter().zip(per_port) {
            let a = att.coefficients();
            for (c, &kc) in k.iter().enumerate() {
                if kc == 0.0 {
                    continue;
                }
                for &(di, ai) in &a {
                    for &(dj, aj) in &a {
                        let v = kc * ai[c] * aj[c];
                        self.scatter(&[di, dj], &[[0.0, v], [0.0, 0.0]], out);
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
                let coef_a = self.attachments[a].coefficients();
                for &(b, cb, wb) in &l.terms {
                    let coef_b = self.attachments[b].coefficients();
                    for &(di, ai) in &coef_a {
                        for &(dj, bj) in &coef_b {
                            let v = l.stiffness * wa * wb * ai[ca] * bj[cb];
                            self.scatter(&[di, dj], &[[0.0, v], [0.0, 0.0]], out);
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

    /// Reduced load of a force `f` on component `c` of port `a` (`Aᵀ f`: a uniform traction
    /// and the moment that keeps its resultant at the port's point).
    pub fn port_load(&self, a: usize, c: usize, f: f64, rhs: &mut [f64]) {
        for (d, ad) in self.attachments[a].coefficients() {
            for &(r, coef) in self.terms(d) {
                rhs[r] += coef * ad[c] * f;
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
