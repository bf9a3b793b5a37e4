//! The discrete model: mesh + material + kinematics + boundary conditions, the cached sparsity
//! pattern, and parallel global assembly of `R(u, ρ)` and `K_T = ∂R/∂u` (paper Eq. (A6)).
//!
//! # Boundary conditions and DOF numbering
//!
//! Fixed DOFs (prescribed zero displacement; a roller fixes one component) are **eliminated**:
//! the linear algebra works on the *free* DOFs only, numbered in increasing order of their full
//! DOF index ([`DofMap`]). This keeps the reduced tangent symmetric and, for a stable state,
//! positive definite, so that LLᵀ applies. All `Model` methods take and return *full* vectors
//! (length `2·n_nodes`, fixed entries zero on input; residual entries at fixed DOFs are the
//! reaction forces). [`SparseMatrix`], [`crate::Factor`] and [`crate::pcg`] work on reduced
//! vectors; convert with [`DofMap::gather`] / [`DofMap::scatter`].
//!
//! Grounded linear springs `k` at a DOF add `k·u_dof` to `R` and `k` to the tangent diagonal.
//! This is the PEA model of paper Eq. (2)–(3): a spring `K_pea` to ground plus the external force
//! `K_pea·x_nom` at the input node (see [`pea_force`]).
//!
//! A [`LinkSpring`] acts on a linear combination of DOFs, `g = Σ cᵢ u_{dᵢ}`, with the energy
//! `½ k g²`: it adds `k g cᵢ` to `R` at each `dᵢ` and `k cᵢ cⱼ` to the tangent. flexstage uses it
//! for a load that acts relative to a moving frame, e.g. the output load on the deformation
//! `u_ox − ½(u_in1 + u_in2)` of Eq. (22).
//!
//! Equilibrium is `R(u, ρ) = P` (paper Eq. (A7); Eq. (10) writes `ℜ = P − R`).

use std::sync::Arc;

use multiversion::multiversion;
use rayon::prelude::*;

use crate::element::{ElementCoefficients, ElementKernel};
use crate::error::{ParamError, check_len, check_range};
use crate::material::{AdditiveYeoh, Kinematics, Material};
use crate::mesh::{Edge, Mesh};

/// Displacement component selector.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Component {
    /// x only (a roller with normal x).
    X,
    /// y only (a roller with normal y, e.g. the PEA input ports in DECISIONS.md).
    Y,
    /// Both (clamp).
    Both,
}

/// A grounded linear spring on one DOF.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spring {
    /// Full DOF index.
    pub dof: usize,
    /// Stiffness, N/m (> 0).
    pub stiffness: f64,
}

/// A linear spring on a combination of DOFs: energy `½ k (Σᵢ cᵢ u_{dᵢ})²` (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct LinkSpring {
    /// `(full DOF dᵢ, coefficient cᵢ)`; a DOF may appear once.
    pub terms: Vec<(usize, f64)>,
    /// Stiffness k, N/m (≥ 0).
    pub stiffness: f64,
}

impl LinkSpring {
    /// `g = Σ cᵢ u_{dᵢ}` (the spring's elongation).
    #[inline]
    pub fn elongation(&self, u: &[f64]) -> f64 {
        self.terms.iter().map(|&(d, c)| c * u[d]).sum()
    }
}

/// Supports and grounded springs. Loads are per load case and passed as vectors.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BoundaryConditions {
    /// Fixed (prescribed-zero) DOFs, full numbering. Duplicates are allowed.
    pub fixed: Vec<usize>,
    /// Grounded springs. Several springs on the same DOF add up.
    pub springs: Vec<Spring>,
    /// Springs on combinations of DOFs ([`LinkSpring`]).
    pub links: Vec<LinkSpring>,
}

impl BoundaryConditions {
    /// Empty set.
    pub fn new() -> Self {
        Self::default()
    }
    /// Fix component(s) of one node.
    pub fn fix_node(&mut self, node: usize, c: Component) -> &mut Self {
        match c {
            Component::X => self.fixed.push(2 * node),
            Component::Y => self.fixed.push(2 * node + 1),
            Component::Both => self.fixed.extend([2 * node, 2 * node + 1]),
        }
        self
    }
    /// Fix component(s) of several nodes.
    pub fn fix_nodes(&mut self, nodes: &[usize], c: Component) -> &mut Self {
        for &n in nodes {
            self.fix_node(n, c);
        }
        self
    }
    /// Fix component(s) of every node on a mesh edge.
    pub fn fix_edge(&mut self, mesh: &Mesh, edge: Edge, c: Component) -> &mut Self {
        self.fix_nodes(&mesh.nodes_on_edge(edge), c)
    }
    /// Add a grounded spring on `dof`.
    pub fn add_spring(&mut self, dof: usize, stiffness: f64) -> &mut Self {
        self.springs.push(Spring { dof, stiffness });
        self
    }
    /// Add a spring of stiffness `k` on `Σ cᵢ u_{dᵢ}` (`terms` = `(dᵢ, cᵢ)`).
    pub fn add_link(&mut self, terms: &[(usize, f64)], stiffness: f64) -> &mut Self {
        self.links.push(LinkSpring {
            terms: terms.to_vec(),
            stiffness,
        });
        self
    }
}

/// PEA force of paper Eq. (2)–(3) in statics: with a spring `K_pea` to ground on the input DOF,
/// the actuator adds the external force `K_pea·x_nom` (global sign: positive `x_nom` pushes the
/// actuator tip towards +x).
#[inline]
pub fn pea_force(k_pea: f64, x_nom: f64) -> f64 {
    k_pea * x_nom
}

/// Map between full DOFs and free (reduced) DOFs.
#[derive(Debug, Clone, PartialEq)]
pub struct DofMap {
    /// `free_index[dof]` = reduced index, or `u32::MAX` if fixed.
    free_index: Vec<u32>,
    /// Full index of each free DOF, increasing.
    free: Vec<usize>,
}

impl DofMap {
    fn new(n_dofs: usize, fixed: &[usize]) -> Result<Self, ParamError> {
        let mut is_fixed = vec![false; n_dofs];
        for &d in fixed {
            if d >= n_dofs {
                return Err(ParamError::Index {
                    what: "fixed dof",
                    index: d,
                    bound: n_dofs,
                });
            }
            is_fixed[d] = true;
        }
        let mut free_index = vec![u32::MAX; n_dofs];
        let mut free = Vec::with_capacity(n_dofs);
        for d in 0..n_dofs {
            if !is_fixed[d] {
                free_index[d] = free.len() as u32;
                free.push(d);
            }
        }
        Ok(Self { free_index, free })
    }
    /// Number of full DOFs.
    #[inline]
    pub fn n_full(&self) -> usize {
        self.free_index.len()
    }
    /// Number of free DOFs (order of the reduced system).
    #[inline]
    pub fn n_free(&self) -> usize {
        self.free.len()
    }
    /// Reduced index of full DOF `dof`, `None` if fixed.
    #[inline]
    pub fn reduced(&self, dof: usize) -> Option<usize> {
        let i = self.free_index[dof];
        (i != u32::MAX).then_some(i as usize)
    }
    /// Whether `dof` is fixed.
    #[inline]
    pub fn is_fixed(&self, dof: usize) -> bool {
        self.free_index[dof] == u32::MAX
    }
    /// Full indices of the free DOFs.
    #[inline]
    pub fn free_dofs(&self) -> &[usize] {
        &self.free
    }
    /// `reduced[i] = full[free_dofs[i]]`.
    #[inline]
    pub fn gather(&self, full: &[f64], reduced: &mut [f64]) {
        for (r, &d) in reduced.iter_mut().zip(&self.free) {
            *r = full[d];
        }
    }
    /// `full[free_dofs[i]] = reduced[i]`, fixed entries set to 0.
    #[inline]
    pub fn scatter(&self, reduced: &[f64], full: &mut [f64]) {
        full.fill(0.0);
        for (r, &d) in reduced.iter().zip(&self.free) {
            full[d] = *r;
        }
    }
}

/// Number of upper-triangle entries of an 8×8 element matrix.
pub const ELEM_PACKED: usize = 36;

#[inline(always)]
fn pack_index(p: usize, q: usize) -> usize {
    // p ≤ q; row-major upper triangle.
    p * 8 - p * (p + 1) / 2 + q
}

/// Lower-triangle CSC pattern of the reduced tangent (computed once per model) and the maps
/// from element matrix entries / spring DOFs to CSC value slots.
#[derive(Debug, Clone, PartialEq)]
pub struct SparsityPattern {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// Slot of packed local entry `(p ≤ q)` of each element, `u32::MAX` if a DOF is fixed.
    elem_slots: Vec<[u32; ELEM_PACKED]>,
    /// CSC slot of each diagonal entry.
    diag_slots: Vec<usize>,
    /// Per link spring: `(term i, term j, slot)` for the free pairs with `i ≤ j` in reduced order.
    link_slots: Vec<Vec<(u16, u16, u32)>>,
}

impl SparsityPattern {
    fn build(mesh: &Mesh, dofs: &DofMap, links: &[LinkSpring]) -> Self {
        let n = dofs.n_free();
        let ne = mesh.n_elements();
        let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(ne * ELEM_PACKED + n);
        for i in 0..n as u32 {
            pairs.push((i, i));
        }
        for e in 0..ne {
            let ed = mesh.element_dofs(e);
            for p in 0..8 {
                let Some(a) = dofs.reduced(ed[p]) else {
                    continue;
                };
                for &dq in &ed[p..] {
                    let Some(b) = dofs.reduced(dq) else { continue };
                    let (col, row) = if a <= b { (a, b) } else { (b, a) };
                    pairs.push((col as u32, row as u32));
                }
            }
        }
        let link_pairs = |l: &LinkSpring| {
            let free: Vec<(usize, usize)> = (l.terms.iter().enumerate())
                .filter_map(|(i, &(d, _))| dofs.reduced(d).map(|r| (i, r)))
                .collect();
            let mut out = Vec::new();
            for &(i, a) in &free {
                for &(j, b) in &free {
                    if a <= b {
                        out.push((i, j, a, b));
                    }
                }
            }
            out
        };
        for l in links {
            pairs.extend(
                link_pairs(l)
                    .iter()
                    .map(|&(_, _, a, b)| (a as u32, b as u32)),
            );
        }
        pairs.par_sort_unstable();
        pairs.dedup();
        let mut col_ptr = vec![0usize; n + 1];
        let mut row_idx = Vec::with_capacity(pairs.len());
        for &(c, r) in &pairs {
            col_ptr[c as usize + 1] += 1;
            row_idx.push(r as usize);
        }
        for c in 0..n {
            col_ptr[c + 1] += col_ptr[c];
        }
        let find = |col: usize, row: usize| -> u32 {
            let s = &row_idx[col_ptr[col]..col_ptr[col + 1]];
            (col_ptr[col] + s.binary_search(&row).expect("entry in pattern")) as u32
        };
        let elem_slots = (0..ne)
            .into_par_iter()
            .map(|e| {
                let ed = mesh.element_dofs(e);
                let mut slots = [u32::MAX; ELEM_PACKED];
                for p in 0..8 {
                    for q in p..8 {
                        if let (Some(a), Some(b)) = (dofs.reduced(ed[p]), dofs.reduced(ed[q])) {
                            slots[pack_index(p, q)] = find(a.min(b), a.max(b));
                        }
                    }
                }
                slots
            })
            .collect();
        let diag_slots = (0..n).map(|c| find(c, c) as usize).collect();
        let link_slots = links
            .iter()
            .map(|l| {
                (link_pairs(l).into_iter())
                    .map(|(i, j, a, b)| (i as u16, j as u16, find(a, b)))
                    .collect()
            })
            .collect();
        Self {
            n,
            col_ptr,
            row_idx,
            elem_slots,
            diag_slots,
            link_slots,
        }
    }
    /// Order of the reduced system.
    #[inline]
    pub fn n(&self) -> usize {
        self.n
    }
    /// Number of stored (lower-triangle) entries.
    #[inline]
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }
    /// CSC column pointers.
    #[inline]
    pub fn col_ptr(&self) -> &[usize] {
        &self.col_ptr
    }
    /// CSC row indices (sorted within each column, lower triangle `row ≥ col`).
    #[inline]
    pub fn row_idx(&self) -> &[usize] {
        &self.row_idx
    }
    /// CSC slot of each diagonal entry.
    #[inline]
    pub fn diag_slots(&self) -> &[usize] {
        &self.diag_slots
    }
}

/// A symmetric matrix on the reduced DOFs, stored as its lower triangle in CSC with a shared,
/// fixed pattern. Values are refilled in place by [`Model::assemble`].
#[derive(Debug, Clone, PartialEq)]
pub struct SparseMatrix {
    pattern: Arc<SparsityPattern>,
    values: Vec<f64>,
}

impl SparseMatrix {
    /// Zero matrix with the given pattern.
    pub fn zeros(pattern: Arc<SparsityPattern>) -> Self {
        let values = vec![0.0; pattern.nnz()];
        Self { pattern, values }
    }
    /// The pattern.
    #[inline]
    pub fn pattern(&self) -> &Arc<SparsityPattern> {
        &self.pattern
    }
    /// Lower-triangle CSC values.
    #[inline]
    pub fn values(&self) -> &[f64] {
        &self.values
    }
    /// Mutable values.
    #[inline]
    pub fn values_mut(&mut self) -> &mut [f64] {
        &mut self.values
    }
    /// Order `n`.
    #[inline]
    pub fn n(&self) -> usize {
        self.pattern.n
    }
    /// Diagonal entry `i`.
    #[inline]
    pub fn diag(&self, i: usize) -> f64 {
        self.values[self.pattern.diag_slots[i]]
    }
    /// Entry `(i, j)` of the full symmetric matrix (binary search; for tests/diagnostics).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let (c, r) = if i <= j { (i, j) } else { (j, i) };
        let p = &self.pattern;
        let s = &p.row_idx[p.col_ptr[c]..p.col_ptr[c + 1]];
        s.binary_search(&r)
            .map(|k| self.values[p.col_ptr[c] + k])
            .unwrap_or(0.0)
    }
    /// faer view of the stored lower triangle (use with `Side::Lower`).
    pub fn as_faer(&self) -> faer::sparse::SparseColMatRef<'_, usize, f64> {
        let p = &self.pattern;
        let sym = faer::sparse::SymbolicSparseColMatRef::new_checked(
            p.n, p.n, &p.col_ptr, None, &p.row_idx,
        );
        faer::sparse::SparseColMatRef::new(sym, &self.values)
    }
    /// `y = A x` for the full symmetric matrix (both triangles).
    pub fn matvec(&self, x: &[f64], y: &mut [f64]) {
        let p = &*self.pattern;
        y.fill(0.0);
        for c in 0..p.n {
            let xc = x[c];
            let mut acc = 0.0;
            for k in p.col_ptr[c]..p.col_ptr[c + 1] {
                let r = p.row_idx[k];
                let v = self.values[k];
                if r != c {
                    y[r] += v * xc;
                    acc += v * x[r];
                } else {
                    acc += v * xc;
                }
            }
            y[c] += acc;
        }
    }
}

impl SparseMatrix {
    /// `Y = A X` for `k` column-major vectors (`x`, `y` of length `n·k`). The matrix is read
    /// once for up to four columns (sparse mat-vecs are bound by reading the matrix, so a
    /// block of columns costs little more than one). `scratch` holds the columns interleaved
    /// node by node (resized to `8n`; keep it between calls), so that the four updates of a
    /// matrix entry are one vector operation; each column is summed in the order of
    /// [`SparseMatrix::matvec`], so the result is bitwise the same.
    pub fn matvec_columns(&self, x: &[f64], y: &mut [f64], k: usize, scratch: &mut Vec<f64>) {
        let n = self.pattern.n;
        assert!(
            x.len() == n * k && y.len() == n * k,
            "matvec_columns lengths"
        );
        let mut done = 0;
        while done < k {
            let w = (k - done).min(4);
            let (xb, yb) = (
                &x[done * n..(done + w) * n],
                &mut y[done * n..(done + w) * n],
            );
            match w {
                1 => self.matvec(xb, yb),
                2 => self.matvec_block::<2>(xb, yb, scratch),
                3 => self.matvec_block::<3>(xb, yb, scratch),
                _ => self.matvec_block::<4>(xb, yb, scratch),
            }
            done += w;
        }
    }

    /// `Y = A X` for exactly `K` columns, one sweep over the matrix (interleaved in `scratch`).
    fn matvec_block<const K: usize>(&self, x: &[f64], y: &mut [f64], scratch: &mut Vec<f64>) {
        let p = &*self.pattern;
        let n = p.n;
        scratch.clear();
        scratch.resize(2 * n * K, 0.0);
        let (xi, yi) = scratch.split_at_mut(n * K);
        for (t, xt) in x.chunks_exact(n).enumerate() {
            for (c, v) in xt.iter().enumerate() {
                xi[c * K + t] = *v;
            }
        }
        for c in 0..n {
            let xc: [f64; K] = std::array::from_fn(|t| xi[c * K + t]);
            let mut acc = [0.0; K];
            for k in p.col_ptr[c]..p.col_ptr[c + 1] {
                let r = p.row_idx[k];
                let v = self.values[k];
                if r != c {
                    let xr: [f64; K] = std::array::from_fn(|t| xi[r * K + t]);
                    let yr = &mut yi[r * K..(r + 1) * K];
                    for t in 0..K {
                        yr[t] += v * xc[t];
                        acc[t] += v * xr[t];
                    }
                } else {
                    for t in 0..K {
                        acc[t] += v * xc[t];
                    }
                }
            }
            for t in 0..K {
                yi[c * K + t] += acc[t];
            }
        }
        for (t, yt) in y.chunks_exact_mut(n).enumerate() {
            for (c, v) in yt.iter_mut().enumerate() {
                *v = yi[c * K + t];
            }
        }
    }
}

/// Element residuals (and packed tangents when `need_k`) of the elements `e0, e0 + 1, …`.
/// Compiled for AVX-512 and AVX2 + FMA as well as baseline x86-64 and chosen at run time:
/// the kernel's rows of eight (B, D·B, k_e) then map onto vector registers, about twice as
/// fast as baseline x86-64 on the 120×60 assembly.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"))]
fn element_chunk(
    model: &Model,
    design: &Design,
    u: &[f64],
    e0: usize,
    ke: &mut [[f64; ELEM_PACKED]],
    re: &mut [[f64; 8]],
    need_k: bool,
) {
    let kernel = &model.kernel;
    for (i, (ke, re)) in ke.iter_mut().zip(re.iter_mut()).enumerate() {
        let e = e0 + i;
        let c = model.coefficients(design, e);
        let ue = model.element_displacement(e, u);
        if need_k {
            let mut k = [[0.0; 8]; 8];
            kernel.residual_tangent(&c, &ue, re, Some(&mut k));
            for p in 0..8 {
                for q in p..8 {
                    ke[pack_index(p, q)] = k[p][q];
                }
            }
        } else {
            kernel.residual_tangent(&c, &ue, re, None);
        }
    }
}

/// Element residuals of every element into `re` and each element's tangent added into the CSC
/// values `vals` as soon as it is computed (no element-matrix buffer), in element order and
/// the packed order of [`Model::assemble`]'s scatter, so the sums are bitwise the same.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"))]
fn element_scatter(
    model: &Model,
    design: &Design,
    u: &[f64],
    re: &mut [[f64; 8]],
    vals: &mut [f64],
) {
    let kernel = &model.kernel;
    for (e, (re, slots)) in re.iter_mut().zip(&model.pattern.elem_slots).enumerate() {
        let c = model.coefficients(design, e);
        let ue = model.element_displacement(e, u);
        let mut k = [[0.0; 8]; 8];
        kernel.residual_tangent(&c, &ue, re, Some(&mut k));
        let mut i = 0;
        for (p, row) in k.iter().enumerate() {
            for v in &row[p..] {
                let s = slots[i];
                if s != u32::MAX {
                    vals[s as usize] += v;
                }
                i += 1;
            }
        }
    }
}

/// Densities and optional additive-material coefficients for one evaluation.
#[derive(Debug, Clone, Copy)]
pub struct Design<'a> {
    /// Physical element densities ρ_e ∈ [0, 1] (after filtering/projection and passive
    /// overrides, see [`Mesh::apply_passive`]).
    pub rho: &'a [f64],
    /// Additive Yeoh material (paper Eq. (A2)); `None` switches it off.
    pub yeoh: Option<&'a AdditiveYeoh>,
}

impl<'a> Design<'a> {
    /// Densities without the additive material.
    pub fn new(rho: &'a [f64]) -> Self {
        Self { rho, yeoh: None }
    }
    /// Densities with the additive material.
    pub fn with_yeoh(rho: &'a [f64], yeoh: &'a AdditiveYeoh) -> Self {
        Self {
            rho,
            yeoh: Some(yeoh),
        }
    }
    /// Check lengths and ranges.
    pub fn validate(&self, n_elements: usize) -> Result<(), ParamError> {
        check_len("Design::rho", self.rho.len(), n_elements)?;
        for &r in self.rho {
            check_range("Design::rho", r, 0.0, 1.0, "[0, 1]")?;
        }
        if let Some(y) = self.yeoh {
            y.validate(n_elements)?;
        }
        Ok(())
    }
}

/// Per-thread element buffers for assembly (one per concurrent load case).
#[derive(Debug, Clone)]
pub struct AssemblyWorkspace {
    ke: Vec<[f64; ELEM_PACKED]>,
    re: Vec<[f64; 8]>,
}

impl AssemblyWorkspace {
    /// Buffers for `n_elements` elements.
    pub fn new(n_elements: usize) -> Self {
        Self {
            ke: vec![[0.0; ELEM_PACKED]; n_elements],
            re: vec![[0.0; 8]; n_elements],
        }
    }

    /// The element internal forces `r_e` of the last [`Model::assemble`] with this workspace
    /// (springs excluded), element order. With the additive material off, `r_e` is linear in
    /// the element modulus, so `∂r_e/∂ρ_e = (E'(ρ_e)/E(ρ_e)) r_e`.
    pub fn element_residuals(&self) -> &[[f64; 8]] {
        &self.re
    }
}

/// Minimum number of elements per rayon task.
const CHUNK: usize = 128;

/// The FE model. Immutable after construction and `Sync`: share `&Model` between threads.
#[derive(Debug, Clone)]
pub struct Model {
    mesh: Mesh,
    material: Material,
    kernel: ElementKernel,
    dofs: DofMap,
    bcs: BoundaryConditions,
    pattern: Arc<SparsityPattern>,
}

impl Model {
    /// Build the model and its sparsity pattern.
    pub fn new(
        mesh: Mesh,
        material: Material,
        kinematics: Kinematics,
        bcs: BoundaryConditions,
    ) -> Result<Self, ParamError> {
        material.validate()?;
        let nd = mesh.n_dofs();
        for s in &bcs.springs {
            if s.dof >= nd {
                return Err(ParamError::Index {
                    what: "spring dof",
                    index: s.dof,
                    bound: nd,
                });
            }
            check_range(
                "Spring::stiffness",
                s.stiffness,
                0.0,
                f64::MAX,
                "[0, ∞) N/m",
            )?;
        }
        for l in &bcs.links {
            for (i, &(d, c)) in l.terms.iter().enumerate() {
                if d >= nd {
                    return Err(ParamError::Index {
                        what: "link spring dof",
                        index: d,
                        bound: nd,
                    });
                }
                check_range(
                    "LinkSpring::terms",
                    c,
                    f64::MIN,
                    f64::MAX,
                    "a finite number",
                )?;
                if l.terms[..i].iter().any(|&(e, _)| e == d) {
                    return Err(ParamError::Duplicate {
                        what: "LinkSpring::terms",
                        index: d,
                    });
                }
            }
            check_range(
                "LinkSpring::stiffness",
                l.stiffness,
                0.0,
                f64::MAX,
                "[0, ∞) N/m",
            )?;
        }
        let dofs = DofMap::new(nd, &bcs.fixed)?;
        let pattern = Arc::new(SparsityPattern::build(&mesh, &dofs, &bcs.links));
        let kernel =
            ElementKernel::new(&material, kinematics, mesh.dx(), mesh.dy(), mesh.thickness);
        Ok(Self {
            mesh,
            material,
            kernel,
            dofs,
            bcs,
            pattern,
        })
    }

    /// The mesh.
    #[inline]
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }
    /// The material.
    #[inline]
    pub fn material(&self) -> &Material {
        &self.material
    }
    /// Kinematics.
    #[inline]
    pub fn kinematics(&self) -> Kinematics {
        self.kernel.kinematics
    }
    /// The shared element kernel.
    #[inline]
    pub fn kernel(&self) -> &ElementKernel {
        &self.kernel
    }
    /// Boundary conditions.
    #[inline]
    pub fn bcs(&self) -> &BoundaryConditions {
        &self.bcs
    }
    /// DOF map (full ↔ free).
    #[inline]
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }
    /// Cached sparsity pattern of the reduced tangent.
    #[inline]
    pub fn pattern(&self) -> &Arc<SparsityPattern> {
        &self.pattern
    }
    /// Number of full DOFs.
    #[inline]
    pub fn n_dofs(&self) -> usize {
        self.mesh.n_dofs()
    }
    /// A zero full vector.
    pub fn zero_vector(&self) -> Vec<f64> {
        vec![0.0; self.n_dofs()]
    }
    /// A zero tangent with this model's pattern.
    pub fn new_matrix(&self) -> SparseMatrix {
        SparseMatrix::zeros(self.pattern.clone())
    }
    /// Assembly buffers for this model.
    pub fn new_workspace(&self) -> AssemblyWorkspace {
        AssemblyWorkspace::new(self.mesh.n_elements())
    }

    /// Density-dependent coefficients of element `e`.
    #[inline]
    pub fn coefficients(&self, design: &Design, e: usize) -> ElementCoefficients {
        let yeoh = design.yeoh.map(|y| (y.c1[e], y.c2[e]));
        ElementCoefficients::new(&self.material, design.rho[e], yeoh)
    }

    /// Element displacement vector.
    #[inline]
    pub fn element_displacement(&self, e: usize, u: &[f64]) -> [f64; 8] {
        let d = self.mesh.element_dofs(e);
        std::array::from_fn(|k| u[d[k]])
    }

    fn check_sizes(&self, design: &Design, u: &[f64]) {
        assert_eq!(
            design.rho.len(),
            self.mesh.n_elements(),
            "Design::rho length"
        );
        assert_eq!(u.len(), self.n_dofs(), "displacement length");
    }

    /// Assemble the residual `R(u, ρ)` (internal + spring forces, full vector; entries at fixed
    /// DOFs are reactions) and/or the reduced tangent `K_T = ∂R/∂u` into caller-owned buffers.
    /// Element kernels run in parallel (rayon), the scatter into the cached CSC slots is serial.
    ///
    /// # Panics
    /// If the lengths of `design.rho`, `u` or `residual` do not match the model.
    pub fn assemble(
        &self,
        design: &Design,
        u: &[f64],
        residual: Option<&mut [f64]>,
        tangent: Option<&mut SparseMatrix>,
        ws: &mut AssemblyWorkspace,
    ) {
        self.check_sizes(design, u);
        let need_k = tangent.is_some();
        ws.ke
            .par_chunks_mut(CHUNK)
            .zip(ws.re.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(c, (ke, re))| {
                element_chunk(self, design, u, c * CHUNK, ke, re, need_k);
            });
        if let Some(r) = residual {
            self.scatter_residual(u, &ws.re, r);
        }
        if let Some(kt) = tangent {
            assert!(
                Arc::ptr_eq(&kt.pattern, &self.pattern),
                "tangent pattern is not this model's"
            );
            let vals = &mut kt.values;
            vals.fill(0.0);
            for (slots, ke) in self.pattern.elem_slots.iter().zip(&ws.ke) {
                for k in 0..ELEM_PACKED {
                    let s = slots[k];
                    if s != u32::MAX {
                        vals[s as usize] += ke[k];
                    }
                }
            }
            self.add_spring_tangent(kt);
        }
    }

    /// [`Model::assemble`] on the calling thread, for callers that already run one load case
    /// per thread (the lock-step groups of the design analysis): no nested rayon tasks, and the
    /// tangent is scattered element by element as it is computed, without the element-matrix
    /// buffer (which at 120 × 60 is 2 MB written and read again per assembly). Same summation
    /// order, so the result is bitwise that of [`Model::assemble`].
    ///
    /// # Panics
    /// As [`Model::assemble`].
    pub fn assemble_serial(
        &self,
        design: &Design,
        u: &[f64],
        residual: Option<&mut [f64]>,
        tangent: Option<&mut SparseMatrix>,
        ws: &mut AssemblyWorkspace,
    ) {
        self.check_sizes(design, u);
        match tangent {
            Some(kt) => {
                assert!(
                    Arc::ptr_eq(&kt.pattern, &self.pattern),
                    "tangent pattern is not this model's"
                );
                kt.values.fill(0.0);
                element_scatter(self, design, u, &mut ws.re, &mut kt.values);
                self.add_spring_tangent(kt);
            }
            None => element_chunk(self, design, u, 0, &mut ws.ke, &mut ws.re, false),
        }
        if let Some(r) = residual {
            self.scatter_residual(u, &ws.re, r);
        }
    }

    /// `r = Σ_e r_e` (element residuals `re`) plus the spring forces.
    fn scatter_residual(&self, u: &[f64], re: &[[f64; 8]], r: &mut [f64]) {
        assert_eq!(r.len(), self.n_dofs(), "residual length");
        r.fill(0.0);
        for (e, re) in re.iter().enumerate() {
            let d = self.mesh.element_dofs(e);
            for k in 0..8 {
                r[d[k]] += re[k];
            }
        }
        self.add_spring_forces(u, 1.0, r);
    }

    /// Adds the grounded and link springs' stiffness to an assembled tangent.
    fn add_spring_tangent(&self, kt: &mut SparseMatrix) {
        let vals = &mut kt.values;
        for s in &self.bcs.springs {
            if let Some(i) = self.dofs.reduced(s.dof) {
                vals[self.pattern.diag_slots[i]] += s.stiffness;
            }
        }
        for (l, slots) in self.bcs.links.iter().zip(&self.pattern.link_slots) {
            for &(i, j, s) in slots {
                let (ci, cj) = (l.terms[i as usize].1, l.terms[j as usize].1);
                vals[s as usize] += l.stiffness * ci * cj;
            }
        }
    }

    /// Adds `scale · K_s u`, the spring forces (grounded springs and link springs, the only
    /// part of `R` that is not strain energy), to the full vector `out`.
    pub fn add_spring_forces(&self, u: &[f64], scale: f64, out: &mut [f64]) {
        for s in &self.bcs.springs {
            out[s.dof] += scale * s.stiffness * u[s.dof];
        }
        for l in &self.bcs.links {
            let f = scale * l.stiffness * l.elongation(u);
            for &(d, c) in &l.terms {
                out[d] += f * c;
            }
        }
    }

    /// Residual only (see [`Model::assemble`]).
    pub fn residual(&self, design: &Design, u: &[f64], r: &mut [f64], ws: &mut AssemblyWorkspace) {
        self.assemble(design, u, Some(r), None, ws);
    }

    /// Per-element contraction `out[e] = λ_eᵀ ∂r_e/∂ρ_e` (= `∂(λᵀR)/∂ρ_e`, the design term of
    /// the adjoint sensitivity; springs do not depend on ρ). Entries of `λ` at fixed DOFs are
    /// ignored (treated as zero).
    pub fn contract_drho(&self, design: &Design, u: &[f64], lambda: &[f64], out: &mut [f64]) {
        self.check_sizes(design, u);
        assert_eq!(lambda.len(), self.n_dofs(), "lambda length");
        assert_eq!(out.len(), self.mesh.n_elements(), "out length");
        out.par_iter_mut()
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(e, o)| {
                let c = self.coefficients(design, e);
                let ue = self.element_displacement(e, u);
                let d = self.mesh.element_dofs(e);
                let mut dr = [0.0; 8];
                self.kernel.drho(&c, &ue, &mut dr);
                *o = (0..8)
                    .filter(|&k| !self.dofs.is_fixed(d[k]))
                    .map(|k| lambda[d[k]] * dr[k])
                    .sum();
            });
    }

    /// `out[e] = a_eᵀ (∂K₀/∂ρ_e) a_e` for the stiffness `K₀` at `u = 0` (springs do not depend
    /// on ρ): the stiffness part of an eigenvalue sensitivity `φᵀ(∂K/∂ρ_e − λ ∂M/∂ρ_e)φ`. At
    /// `u = 0` the total Lagrangian tangent is the small-strain stiffness (F = I, no stress, so no
    /// geometric part; the additive material's tangent at zero strain is its linearization), so
    /// both kinematics use the small-strain `∂r_e/∂ρ_e`. Entries of `a` at fixed DOFs must be
    /// zero.
    pub fn stiffness_drho_forms(&self, design: &Design, a: &[f64], out: &mut [f64]) {
        self.check_sizes(design, a);
        assert_eq!(out.len(), self.mesh.n_elements(), "out length");
        let kernel = ElementKernel {
            kinematics: Kinematics::Linear,
            ..self.kernel
        };
        out.par_iter_mut()
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(e, o)| {
                let c = self.coefficients(design, e);
                let ae = self.element_displacement(e, a);
                let mut dr = [0.0; 8];
                kernel.drho(&c, &ae, &mut dr);
                *o = ae.iter().zip(&dr).map(|(x, y)| x * y).sum();
            });
    }

    /// Element strain energies `W_e` (J) into `out`; returns the total (springs excluded).
    pub fn element_energies(&self, design: &Design, u: &[f64], out: &mut [f64]) -> f64 {
        self.check_sizes(design, u);
        out.par_iter_mut()
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(e, o)| {
                let c = self.coefficients(design, e);
                *o = self.kernel.energy(&c, &self.element_displacement(e, u));
            });
        out.iter().sum()
    }

    /// Total strain energy `Σ_e W_e` of the structure (springs excluded).
    pub fn strain_energy(&self, design: &Design, u: &[f64]) -> f64 {
        let mut w = vec![0.0; self.mesh.n_elements()];
        self.element_energies(design, u, &mut w)
    }

    /// `∂W_e/∂ρ_e` at fixed `u` into `out` (the explicit design derivative of the strain energy).
    pub fn energy_drho(&self, design: &Design, u: &[f64], out: &mut [f64]) {
        self.check_sizes(design, u);
        out.par_iter_mut()
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(e, o)| {
                let c = self.coefficients(design, e);
                let mut dr = [0.0; 8];
                *o = self
                    .kernel
                    .drho(&c, &self.element_displacement(e, u), &mut dr);
            });
    }

    /// Element von Mises stress (Pa, Cauchy, averaged over Gauss points).
    pub fn von_mises_stresses(&self, design: &Design, u: &[f64], out: &mut [f64]) {
        self.check_sizes(design, u);
        out.par_iter_mut()
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(e, o)| {
                let c = self.coefficients(design, e);
                *o = self
                    .kernel
                    .von_mises_stress(&c, &self.element_displacement(e, u));
            });
    }

    /// Element strain energy density `W_e / V_e` (J/m³).
    pub fn energy_densities(&self, design: &Design, u: &[f64], out: &mut [f64]) {
        self.element_energies(design, u, out);
        let v = self.kernel.geometry.volume;
        out.iter_mut().for_each(|x| *x /= v);
    }

    /// Element-average von Mises strain `ε_e` for the `c2` update of paper Eq. (A3).
    pub fn element_von_mises_strains(&self, u: &[f64], out: &mut [f64]) {
        assert_eq!(u.len(), self.n_dofs(), "displacement length");
        out.par_iter_mut()
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(e, o)| {
                *o = self
                    .kernel
                    .von_mises_strain(&self.element_displacement(e, u));
            });
    }

    /// Full load vector from point loads `(dof, force)`; loads on the same DOF add up.
    pub fn load_vector(&self, loads: &[(usize, f64)]) -> Result<Vec<f64>, ParamError> {
        let mut p = self.zero_vector();
        for &(d, f) in loads {
            if d >= p.len() {
                return Err(ParamError::Index {
                    what: "load dof",
                    index: d,
                    bound: p.len(),
                });
            }
            p[d] += f;
        }
        Ok(p)
    }
}
