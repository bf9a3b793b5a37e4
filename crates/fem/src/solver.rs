//! Sparse direct and iterative solvers on the reduced (free-DOF) system.
//!
//! * [`SymbolicFactor`]: AMD ordering + symbolic Cholesky (faer low-level API), computed once per
//!   sparsity pattern and shared between threads via `Arc`.
//! * [`Factor`]: a numeric factorization with buffers it keeps; `factorize` refills them without
//!   allocating. It first tries LLᵀ; if the tangent is not positive definite (e.g. past a limit
//!   point) it falls back to faer's intranodal Bunch–Kaufman LBLᵀ and records
//!   [`FactorKind::Lblt`]. Solving takes `&self` plus a per-thread [`SolveWorkspace`], so one
//!   factor can serve many threads — as the adjoint solver of its own state or as a
//!   preconditioner for other load cases ([`pcg`]).
//! * All factorizations and solves use `Par::Seq` (faer's threading measured 30–40 % slower
//!   at these sizes; parallelize across load cases instead).

use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, IntranodeLbltRef, LltRef, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::{ColMut, Conj, Par, Side};

use crate::error::SolverError;
use crate::model::{SparseMatrix, SparsityPattern};

/// Symbolic factorization (fill-reducing ordering + structure), shareable via `Arc`.
#[derive(Debug)]
pub struct SymbolicFactor {
    inner: SymbolicCholesky<usize>,
    pattern: Arc<SparsityPattern>,
}

impl SymbolicFactor {
    /// Symbolic analysis of a model's pattern with the nested-dissection order of its mesh
    /// nodes ([`crate::Mesh::nested_dissection`], both DOFs of a node together): less fill
    /// than AMD on the structured grids, so faster factorizations and solves.
    pub fn for_model(model: &crate::Model) -> Result<Arc<Self>, SolverError> {
        let dofs = model.dofs();
        let perm: Vec<usize> = model
            .mesh()
            .nested_dissection()
            .into_iter()
            .flat_map(|n| [2 * n, 2 * n + 1])
            .filter_map(|d| dofs.reduced(d))
            .collect();
        Self::with_order(model.pattern().clone(), perm)
    }

    /// Symbolic analysis with a given elimination order (`order[k]` is the unknown eliminated
    /// k-th; a permutation of `0..n`).
    pub fn with_order(
        pattern: Arc<SparsityPattern>,
        order: Vec<usize>,
    ) -> Result<Arc<Self>, SolverError> {
        let n = pattern.n();
        if order.len() != n {
            return Err(SolverError::Symbolic(format!(
                "order has {} entries, the matrix order is {n}",
                order.len()
            )));
        }
        let mut inv = vec![usize::MAX; n];
        for (k, &i) in order.iter().enumerate() {
            if i >= n || inv[i] != usize::MAX {
                return Err(SolverError::Symbolic(format!(
                    "order is not a permutation of 0..{n} (entry {k} = {i})"
                )));
            }
            inv[i] = k;
        }
        let perm = faer::perm::PermRef::new_checked(&order, &inv, n);
        Self::analyze(pattern, SymmetricOrdering::Custom(perm))
    }

    /// AMD ordering and symbolic analysis of the pattern (≈7 ms at 120×60).
    pub fn new(pattern: Arc<SparsityPattern>) -> Result<Arc<Self>, SolverError> {
        Self::analyze(pattern, SymmetricOrdering::Amd)
    }

    fn analyze(
        pattern: Arc<SparsityPattern>,
        ordering: SymmetricOrdering<'_, usize>,
    ) -> Result<Arc<Self>, SolverError> {
        let sym = faer::sparse::SymbolicSparseColMatRef::new_checked(
            pattern.n(),
            pattern.n(),
            pattern.col_ptr(),
            None,
            pattern.row_idx(),
        );
        let inner = factorize_symbolic_cholesky(
            sym,
            Side::Lower,
            ordering,
            CholeskySymbolicParams::default(),
        )
        .map_err(|e| SolverError::Symbolic(format!("{e:?}")))?;
        Ok(Arc::new(Self { inner, pattern }))
    }

    /// Order of the system.
    pub fn n(&self) -> usize {
        self.inner.nrows()
    }
    /// Number of stored values of the factor `L`.
    pub fn factor_nnz(&self) -> usize {
        self.inner.len_val()
    }
    /// The pattern this analysis was made for.
    pub fn pattern(&self) -> &Arc<SparsityPattern> {
        &self.pattern
    }
    /// The underlying faer symbolic factorization.
    pub fn faer(&self) -> &SymbolicCholesky<usize> {
        &self.inner
    }
}

/// Pivot magnitude at or below which a factorization of `a` is numerically singular:
/// `n · ε · max_i |a_ii|`, the round-off level of an elimination on a matrix of that scale
/// (Golub & Van Loan, *Matrix Computations*, 4th ed., §3.3 and §4.2.6). A stiffness matrix
/// with a rigid-body motion held by nothing has an exactly zero pivot, which round-off turns
/// into one of about `ε · max |a_ii|`; a supported structure's smallest pivots (void material,
/// `E_min`) stay orders of magnitude above this.
pub fn singular_pivot_threshold(a: &SparseMatrix) -> f64 {
    let n = a.n();
    let max_diag = (0..n).map(|i| a.diag(i).abs()).fold(0.0, f64::max);
    n as f64 * f64::EPSILON * max_diag
}

/// Which numeric factorization is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FactorKind {
    /// Cholesky `LLᵀ`: the matrix was positive definite.
    Llt,
    /// Intranodal Bunch–Kaufman `LBLᵀ`: LLᵀ failed (indefinite tangent); the fallback was used.
    Lblt {
        /// Permuted pivot at which LLᵀ failed.
        llt_failed_at: usize,
    },
}

/// Per-thread scratch memory for [`Factor::solve_in_place`].
pub struct SolveWorkspace {
    mem: MemBuffer,
    columns: usize,
}

impl std::fmt::Debug for SolveWorkspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SolveWorkspace").finish_non_exhaustive()
    }
}

impl SolveWorkspace {
    /// Scratch for one right-hand side.
    pub fn new(symbolic: &SymbolicFactor) -> Self {
        Self::with_columns(symbolic, 1)
    }
    /// Scratch for up to `columns` right-hand sides solved together
    /// ([`Factor::solve_columns_in_place`]).
    pub fn with_columns(symbolic: &SymbolicFactor, columns: usize) -> Self {
        let req = symbolic
            .inner
            .solve_in_place_scratch::<f64>(columns.max(1), Par::Seq);
        Self {
            mem: MemBuffer::new(req),
            columns: columns.max(1),
        }
    }
}

/// Numeric factorization with reusable buffers.
pub struct Factor {
    symbolic: Arc<SymbolicFactor>,
    values: Vec<f64>,
    subdiag: Vec<f64>,
    perm_fwd: Vec<usize>,
    perm_inv: Vec<usize>,
    mem: MemBuffer,
    kind: Option<FactorKind>,
    /// Diagonal of the stored factor (scratch of the singularity check).
    pivots: Vec<f64>,
    /// Allow the LBLᵀ fallback when LLᵀ fails (default `true`).
    pub allow_indefinite: bool,
}

impl std::fmt::Debug for Factor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Factor")
            .field("n", &self.symbolic.n())
            .field("factor_nnz", &self.values.len())
            .field("kind", &self.kind)
            .field("allow_indefinite", &self.allow_indefinite)
            .finish_non_exhaustive()
    }
}

impl Factor {
    /// Allocate buffers for numeric factorizations with this symbolic structure.
    pub fn new(symbolic: Arc<SymbolicFactor>) -> Self {
        let s = &symbolic.inner;
        let n = s.nrows();
        let req = StackReq::any_of(&[
            s.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
            s.factorize_numeric_intranode_lblt_scratch::<f64>(Par::Seq, Default::default()),
        ]);
        Self {
            values: vec![0.0; s.len_val()],
            subdiag: vec![0.0; n],
            perm_fwd: vec![0; n],
            perm_inv: vec![0; n],
            mem: MemBuffer::new(req),
            kind: None,
            pivots: vec![0.0; n],
            allow_indefinite: true,
            symbolic,
        }
    }
    /// The shared symbolic factorization.
    pub fn symbolic(&self) -> &Arc<SymbolicFactor> {
        &self.symbolic
    }
    /// Kind of the stored factorization (`None` before the first success).
    pub fn kind(&self) -> Option<FactorKind> {
        self.kind
    }
    /// A workspace suitable for solving with this factor.
    pub fn new_solve_workspace(&self) -> SolveWorkspace {
        SolveWorkspace::new(&self.symbolic)
    }

    /// Numeric factorization of `a` (same pattern as the symbolic factor), in place.
    /// Tries LLᵀ; on a non-positive pivot falls back to LBLᵀ (if allowed). A failed call leaves
    /// the factor unusable (`kind() == None`).
    pub fn factorize(&mut self, a: &SparseMatrix) -> Result<FactorKind, SolverError> {
        if !Arc::ptr_eq(a.pattern(), &self.symbolic.pattern)
            && **a.pattern() != *self.symbolic.pattern
        {
            return Err(SolverError::PatternMismatch {
                what: "matrix pattern differs from the symbolic factorization's",
            });
        }
        self.kind = None;
        let s = &self.symbolic.inner;
        let stack = MemStack::new(&mut self.mem);
        let llt = s.factorize_numeric_llt::<f64>(
            &mut self.values,
            a.as_faer(),
            Side::Lower,
            Default::default(),
            Par::Seq,
            stack,
            Default::default(),
        );
        let threshold = singular_pivot_threshold(a);
        let pivot = match llt {
            Ok(_) => {
                // A singular (floating) stiffness often passes LLᵀ with a round-off pivot.
                if let Some((pivot, value)) = self.smallest_pivot(threshold, false) {
                    return Err(SolverError::SingularStiffness {
                        pivot,
                        value,
                        threshold,
                    });
                }
                self.kind = Some(FactorKind::Llt);
                return Ok(FactorKind::Llt);
            }
            Err(faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index }) => index,
        };
        if !self.allow_indefinite {
            return Err(SolverError::NotPositiveDefinite { pivot });
        }
        let stack = MemStack::new(&mut self.mem);
        s.factorize_numeric_intranode_lblt::<f64>(
            &mut self.values,
            &mut self.subdiag,
            &mut self.perm_fwd,
            &mut self.perm_inv,
            a.as_faer(),
            Side::Lower,
            Par::Seq,
            stack,
            Default::default(),
        );
        if self
            .values
            .iter()
            .chain(&self.subdiag)
            .any(|v| !v.is_finite())
        {
            return Err(SolverError::Singular { llt_pivot: pivot });
        }
        if let Some((pivot, value)) = self.smallest_pivot(threshold, true) {
            return Err(SolverError::SingularStiffness {
                pivot,
                value,
                threshold,
            });
        }
        let kind = FactorKind::Lblt {
            llt_failed_at: pivot,
        };
        self.kind = Some(kind);
        Ok(kind)
    }

    /// The first pivot (permuted index, value) of the stored factor whose magnitude is at most
    /// `threshold`, if any. LLᵀ pivots are `L_kk²`; LBLᵀ pivots are the 1×1 entries of `B` and
    /// the smaller eigenvalue magnitude of its 2×2 blocks (`lblt`). Reads the diagonal of each
    /// column of faer's simplicial layout (diagonal stored first) or of each supernode's dense
    /// diagonal block (column-major, `rows × cols`).
    fn smallest_pivot(&mut self, threshold: f64, lblt: bool) -> Option<(usize, f64)> {
        let n = self.symbolic.n();
        let diag = &mut self.pivots;
        match self.symbolic.inner.raw() {
            SymbolicCholeskyRaw::Simplicial(s) => {
                for (j, d) in diag.iter_mut().enumerate() {
                    *d = self.values[s.col_ptr()[j]];
                }
            }
            SymbolicCholeskyRaw::Supernodal(s) => {
                let begin = s.supernode_begin();
                let end = s.supernode_end();
                for k in 0..s.n_supernodes() {
                    let cols = end[k] - begin[k];
                    let rows = cols + s.col_ptr_for_row_idx()[k + 1] - s.col_ptr_for_row_idx()[k];
                    let block = &self.values[s.col_ptr_for_val()[k]..];
                    for j in 0..cols {
                        diag[begin[k] + j] = block[j * rows + j];
                    }
                }
            }
        }
        let mut k = 0;
        while k < n {
            let e = if lblt && k + 1 < n {
                self.subdiag[k]
            } else {
                0.0
            };
            if e == 0.0 {
                let v = if lblt {
                    diag[k].abs()
                } else {
                    diag[k] * diag[k]
                };
                if v <= threshold {
                    return Some((k, v));
                }
                k += 1;
            } else {
                // 2×2 block [[a, e], [e, b]]: smallest |λ| = |det| / largest |λ|.
                let (a, b) = (diag[k], diag[k + 1]);
                let big = 0.5 * (a + b).abs() + (0.25 * (a - b) * (a - b) + e * e).sqrt();
                let small = if big > 0.0 {
                    (a * b - e * e).abs() / big
                } else {
                    0.0
                };
                if small <= threshold {
                    return Some((k, small));
                }
                k += 2;
            }
        }
        None
    }

    /// Solve `A x = b` in place (`rhs` holds `b` on entry, `x` on exit), reduced numbering.
    pub fn solve_in_place(
        &self,
        rhs: &mut [f64],
        ws: &mut SolveWorkspace,
    ) -> Result<(), SolverError> {
        let kind = self.kind.ok_or(SolverError::NotFactorized)?;
        assert_eq!(rhs.len(), self.symbolic.n(), "rhs length");
        let stack = MemStack::new(&mut ws.mem);
        let col = ColMut::from_slice_mut(rhs);
        let s = &self.symbolic.inner;
        match kind {
            FactorKind::Llt => {
                LltRef::new(s, &self.values).solve_in_place_with_conj(
                    Conj::No,
                    col.as_mat_mut(),
                    Par::Seq,
                    stack,
                );
            }
            FactorKind::Lblt { .. } => {
                let perm =
                    faer::perm::PermRef::new_checked(&self.perm_fwd, &self.perm_inv, s.nrows());
                IntranodeLbltRef::new(s, &self.values, &self.subdiag, perm)
                    .solve_in_place_with_conj(Conj::No, col.as_mat_mut(), Par::Seq, stack);
            }
        }
        if rhs.iter().any(|v| !v.is_finite()) {
            return Err(SolverError::NonFinite { what: "solution" });
        }
        Ok(())
    }

    /// Solve `A X = B` in place for `ncols` right-hand sides stored column-major in `rhs`
    /// (length `n·ncols`). One sweep over the factor serves all columns, so a block of `k`
    /// solves costs much less than `k` single solves (the factor is streamed once).
    /// `ws` must come from [`SolveWorkspace::with_columns`] with at least `ncols` columns.
    pub fn solve_columns_in_place(
        &self,
        rhs: &mut [f64],
        ncols: usize,
        ws: &mut SolveWorkspace,
    ) -> Result<(), SolverError> {
        let kind = self.kind.ok_or(SolverError::NotFactorized)?;
        let n = self.symbolic.n();
        assert_eq!(rhs.len(), n * ncols, "rhs length");
        assert!(ncols <= ws.columns, "solve workspace has too few columns");
        let stack = MemStack::new(&mut ws.mem);
        let mat = faer::MatMut::from_column_major_slice_mut(rhs, n, ncols);
        let s = &self.symbolic.inner;
        match kind {
            FactorKind::Llt => {
                LltRef::new(s, &self.values).solve_in_place_with_conj(
                    Conj::No,
                    mat,
                    Par::Seq,
                    stack,
                );
            }
            FactorKind::Lblt { .. } => {
                let perm =
                    faer::perm::PermRef::new_checked(&self.perm_fwd, &self.perm_inv, s.nrows());
                IntranodeLbltRef::new(s, &self.values, &self.subdiag, perm)
                    .solve_in_place_with_conj(Conj::No, mat, Par::Seq, stack);
            }
        }
        if rhs.iter().any(|v| !v.is_finite()) {
            return Err(SolverError::NonFinite { what: "solution" });
        }
        Ok(())
    }

    /// Solve with full-length vectors: `b` and `x` have length `dofs.n_full()`; fixed entries of
    /// `b` are ignored and those of `x` set to 0. `tmp` must have length `n_free`.
    pub fn solve_full(
        &self,
        dofs: &crate::DofMap,
        b: &[f64],
        x: &mut [f64],
        tmp: &mut [f64],
        ws: &mut SolveWorkspace,
    ) -> Result<(), SolverError> {
        dofs.gather(b, tmp);
        self.solve_in_place(tmp, ws)?;
        dofs.scatter(tmp, x);
        Ok(())
    }
}

/// PCG parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PcgParams {
    /// Stop when `‖b − A x‖ ≤ rel_tol·‖b‖`, in (0, 1).
    pub rel_tol: f64,
    /// Maximum iterations, ≥ 1.
    pub max_iter: usize,
}

impl Default for PcgParams {
    fn default() -> Self {
        Self {
            rel_tol: 1e-10,
            max_iter: 200,
        }
    }
}

/// Result of a successful PCG solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PcgReport {
    /// Iterations performed (0 if the initial guess already satisfied the tolerance).
    pub iterations: usize,
    /// Final `‖r‖/‖b‖`.
    pub relative_residual: f64,
}

/// Vectors for [`pcg`] (reduced length), reusable across calls.
#[derive(Debug, Clone)]
pub struct PcgWorkspace {
    r: Vec<f64>,
    z: Vec<f64>,
    p: Vec<f64>,
    q: Vec<f64>,
}

impl PcgWorkspace {
    /// Buffers for systems of order `n`.
    pub fn new(n: usize) -> Self {
        Self {
            r: vec![0.0; n],
            z: vec![0.0; n],
            p: vec![0.0; n],
            q: vec![0.0; n],
        }
    }
}

#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Preconditioned conjugate gradients for `A x = b` (reduced numbering), with a numeric
/// factorization `m ≈ A` (e.g. of the tangent of another load case or an earlier state) as the
/// preconditioner. `x` holds the initial guess on entry. If `m` is an exact factor of `A` this
/// converges in one iteration.
pub fn pcg(
    a: &SparseMatrix,
    m: &Factor,
    b: &[f64],
    x: &mut [f64],
    params: PcgParams,
    ws: &mut PcgWorkspace,
    sws: &mut SolveWorkspace,
) -> Result<PcgReport, SolverError> {
    let n = a.n();
    assert!(
        b.len() == n && x.len() == n && ws.r.len() == n,
        "pcg vector lengths"
    );
    let bn = dot(b, b).sqrt();
    if !bn.is_finite() {
        return Err(SolverError::NonFinite { what: "pcg rhs" });
    }
    if bn == 0.0 {
        x.fill(0.0);
        return Ok(PcgReport {
            iterations: 0,
            relative_residual: 0.0,
        });
    }
    let PcgWorkspace { r, z, p, q } = ws;
    a.matvec(x, q);
    for i in 0..n {
        r[i] = b[i] - q[i];
    }
    let mut rn = dot(r, r).sqrt();
    if rn <= params.rel_tol * bn {
        return Ok(PcgReport {
            iterations: 0,
            relative_residual: rn / bn,
        });
    }
    z.copy_from_slice(r);
    m.solve_in_place(z, sws)?;
    p.copy_from_slice(z);
    let mut rz = dot(r, z);
    for it in 1..=params.max_iter {
        a.matvec(p, q);
        let pq = dot(p, q);
        if pq <= 0.0 || !pq.is_finite() {
            return Err(SolverError::PcgIndefinite {
                iteration: it,
                curvature: pq,
            });
        }
        let alpha = rz / pq;
        for i in 0..n {
            x[i] += alpha * p[i];
            r[i] -= alpha * q[i];
        }
        rn = dot(r, r).sqrt();
        if rn <= params.rel_tol * bn {
            return Ok(PcgReport {
                iterations: it,
                relative_residual: rn / bn,
            });
        }
        z.copy_from_slice(r);
        m.solve_in_place(z, sws)?;
        let rz_new = dot(r, z);
        let beta = rz_new / rz;
        rz = rz_new;
        for i in 0..n {
            p[i] = z[i] + beta * p[i];
        }
    }
    Err(SolverError::PcgNotConverged {
        iterations: params.max_iter,
        relative_residual: rn / bn,
        tolerance: params.rel_tol,
    })
}

/// Buffers for [`pcg_block`]: column-major blocks of up to `k` vectors of length `n`.
#[derive(Debug, Clone)]
pub struct BlockPcgWorkspace {
    n: usize,
    k: usize,
    r: Vec<f64>,
    z: Vec<f64>,
    p: Vec<f64>,
    q: Vec<f64>,
    bn: Vec<f64>,
    rz: Vec<f64>,
    running: Vec<usize>,
    /// Interleaved columns of the block mat-vecs ([`SparseMatrix::matvec_columns`]).
    mv: Vec<f64>,
}

impl BlockPcgWorkspace {
    /// Buffers for up to `k` right-hand sides of order `n`.
    pub fn new(n: usize, k: usize) -> Self {
        Self {
            n,
            k,
            r: vec![0.0; n * k],
            z: vec![0.0; n * k],
            p: vec![0.0; n * k],
            q: vec![0.0; n * k],
            bn: vec![0.0; k],
            rz: vec![0.0; k],
            running: Vec::with_capacity(k),
            mv: vec![0.0; 8 * n],
        }
    }
    /// Largest number of columns.
    pub fn columns(&self) -> usize {
        self.k
    }
}

/// Outcome of one column of [`pcg_block`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ColumnOutcome {
    /// Not finished (only while iterating).
    Running,
    /// Converged after this many iterations.
    Converged(usize),
    /// Non-positive curvature (the matrix or the preconditioner is not SPD).
    Indefinite,
    /// `max_iter` reached.
    NotConverged,
}

/// `q_j = A_j p_j` for the columns selected by `want`, with one sweep over each matrix for a
/// run of consecutive columns that share it (same reference).
fn block_matvec(
    mats: &[&SparseMatrix],
    p: &[f64],
    q: &mut [f64],
    n: usize,
    want: impl Fn(usize) -> bool,
    scratch: &mut Vec<f64>,
) {
    let k = mats.len();
    let mut a = 0;
    while a < k {
        let mut b = a + 1;
        while b < k && std::ptr::eq(mats[b], mats[a]) {
            b += 1;
        }
        if let (Some(f), Some(l)) = ((a..b).find(|&j| want(j)), (a..b).rev().find(|&j| want(j))) {
            let w = l + 1 - f;
            mats[a].matvec_columns(
                &p[f * n..(l + 1) * n],
                &mut q[f * n..(l + 1) * n],
                w,
                scratch,
            );
        }
        a = b;
    }
}

/// [`pcg`] for `k` systems `A_j x_j = b_j` at once, each column with its own matrix
/// (`mats[j]`, e.g. the tangents of several load cases) and one shared preconditioner `m`:
/// independent CG recurrences per column, but one sweep over the factor applies the
/// preconditioner to every running column ([`Factor::solve_columns_in_place`], ~3× cheaper
/// per column than single solves at 20 columns), and consecutive columns with the same
/// matrix share one sweep over it ([`SparseMatrix::matvec_columns`]). `b`, `x` are
/// column-major (`n·k`).
///
/// `x` holds the initial guesses (e.g. the solutions of a previous, similar system): each is
/// first scaled by `s = xᵀb / xᵀAx`, the multiple with the smallest A-norm error, so a guess
/// never starts CG worse than zero does. A column that fails (indefinite, not converged) is
/// frozen and reported in `outcome` while the others continue. Returns the summed
/// iterations; `sws` needs scratch for `k` columns ([`SolveWorkspace::with_columns`]).
#[allow(clippy::too_many_arguments)]
pub fn pcg_block(
    mats: &[&SparseMatrix],
    m: &Factor,
    b: &[f64],
    x: &mut [f64],
    params: PcgParams,
    ws: &mut BlockPcgWorkspace,
    sws: &mut SolveWorkspace,
    outcome: &mut [ColumnOutcome],
) -> Result<usize, SolverError> {
    let k = mats.len();
    let n = ws.n;
    assert!(
        k <= ws.k && b.len() == n * k && x.len() == n * k && outcome.len() == k,
        "pcg_block lengths"
    );
    let BlockPcgWorkspace {
        r,
        z,
        p,
        q,
        bn,
        rz,
        running,
        mv,
        ..
    } = ws;
    let (r, z, p, q) = (
        &mut r[..n * k],
        &mut z[..n * k],
        &mut p[..n * k],
        &mut q[..n * k],
    );
    let col = |j: usize| j * n..(j + 1) * n;
    for a in mats {
        assert_eq!(a.n(), n, "pcg_block matrix order");
    }
    block_matvec(mats, x, q, n, |_| true, mv);
    let mut total = 0;
    running.clear();
    for j in 0..k {
        bn[j] = dot(&b[col(j)], &b[col(j)]).sqrt();
        if !bn[j].is_finite() {
            return Err(SolverError::NonFinite { what: "pcg rhs" });
        }
        // Scaled initial guess (0 when x = 0, or when the curvature along it is not positive).
        let (xb, xq) = (dot(&x[col(j)], &b[col(j)]), dot(&x[col(j)], &q[col(j)]));
        let s = if xq > 0.0 && (xb / xq).is_finite() {
            xb / xq
        } else {
            0.0
        };
        for i in col(j) {
            x[i] *= s;
            r[i] = b[i] - s * q[i];
        }
        outcome[j] = if bn[j] == 0.0 {
            x[col(j)].fill(0.0);
            ColumnOutcome::Converged(0)
        } else if dot(&r[col(j)], &r[col(j)]).sqrt() <= params.rel_tol * bn[j] {
            ColumnOutcome::Converged(0)
        } else {
            running.push(j);
            ColumnOutcome::Running
        };
    }
    if running.is_empty() {
        return Ok(0);
    }
    // z (packed: the running columns first) = M⁻¹ r.
    let precondition = |running: &[usize], r: &[f64], z: &mut [f64], sws: &mut SolveWorkspace| {
        for (c, &j) in running.iter().enumerate() {
            z[col(c)].copy_from_slice(&r[col(j)]);
        }
        m.solve_columns_in_place(&mut z[..running.len() * n], running.len(), sws)
    };
    precondition(running, r, z, sws)?;
    for (c, &j) in running.iter().enumerate() {
        p[col(j)].copy_from_slice(&z[col(c)]);
        rz[j] = dot(&r[col(j)], &z[col(c)]);
    }
    for it in 1..=params.max_iter {
        block_matvec(mats, p, q, n, |j| outcome[j] == ColumnOutcome::Running, mv);
        for &j in running.iter() {
            let pq = dot(&p[col(j)], &q[col(j)]);
            total += 1;
            let stop = if pq <= 0.0 || !pq.is_finite() {
                Some(ColumnOutcome::Indefinite)
            } else {
                let alpha = rz[j] / pq;
                for i in col(j) {
                    x[i] += alpha * p[i];
                    r[i] -= alpha * q[i];
                }
                let rn = dot(&r[col(j)], &r[col(j)]).sqrt();
                if !rn.is_finite() {
                    Some(ColumnOutcome::Indefinite)
                } else if rn <= params.rel_tol * bn[j] {
                    Some(ColumnOutcome::Converged(it))
                } else if it == params.max_iter {
                    Some(ColumnOutcome::NotConverged)
                } else {
                    None
                }
            };
            if let Some(o) = stop {
                outcome[j] = o;
            }
        }
        running.retain(|&j| outcome[j] == ColumnOutcome::Running);
        if running.is_empty() {
            break;
        }
        precondition(running, r, z, sws)?;
        for (c, &j) in running.iter().enumerate() {
            let rz_new = dot(&r[col(j)], &z[col(c)]);
            let beta = rz_new / rz[j];
            rz[j] = rz_new;
            for (pi, zi) in p[col(j)].iter_mut().zip(&z[col(c)]) {
                *pi = zi + beta * *pi;
            }
        }
    }
    Ok(total)
}
