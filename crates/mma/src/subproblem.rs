//! The MMA subproblem as the solvers store it.
//!
//! The per-variable data of the subproblem (`low`, `upp`, `α`, `β`, `p₀`, `q₀`, `P`, `Q`) and
//! the per-variable iterate of `subsolv` (`x`, `ξ`, `η`, `Δx`, `Δξ`, `Δη`) are stored
//! structure-of-arrays within fixed chunks of [`CHUNK`] variables: chunk `c` is one block of
//! the array, holding field `f` at `f·CHUNK..(f+1)·CHUNK` (see [`idx`]). The last chunk is
//! padded with harmless values that never enter a sum or the step length. [`crate::Mma`]
//! writes the nodes, and both subproblem solvers read them.

use crate::lanes::CHUNK;

/// Fields of `nodes`: `P[i]` is field `PQ + i`, `Q[i]` field `PQ + m + i`.
pub(crate) const LOW: usize = 0;
pub(crate) const UPP: usize = 1;
pub(crate) const ALFA: usize = 2;
pub(crate) const BETA: usize = 3;
pub(crate) const P0: usize = 4;
pub(crate) const Q0: usize = 5;
pub(crate) const PQ: usize = 6;

/// Fields of `state`: the base point and the Newton direction.
pub(crate) const X: usize = 0;
pub(crate) const XSI: usize = 1;
pub(crate) const ETA: usize = 2;
pub(crate) const DX: usize = 3;
pub(crate) const DXSI: usize = 4;
pub(crate) const DETA: usize = 5;
/// Number of fields of `state`.
pub(crate) const NSTATE: usize = 6;

/// Index of field `f` of variable `j` in a chunked array with `nf` fields per variable.
#[inline]
pub(crate) fn idx(j: usize, f: usize, nf: usize) -> usize {
    (j / CHUNK) * CHUNK * nf + f * CHUNK + j % CHUNK
}

/// Constants of the artificial variables and the stopping level.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SubConsts {
    pub a0: f64,
    pub a: f64,
    pub c: f64,
    pub d: f64,
    pub epsimin: f64,
}
