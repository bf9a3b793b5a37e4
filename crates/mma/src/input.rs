//! Input checks of the optimizer and the KKT check: lengths and finiteness, vectorized and
//! (for large n) parallel, reporting the first offending index.

use rayon::prelude::*;

use crate::error::MmaError;
use crate::lanes::CHUNK;

/// `Ok` when the slice `name` has `expected` entries, else [`MmaError::DimensionMismatch`].
pub(crate) fn check_len(name: &'static str, s: &[f64], expected: usize) -> Result<(), MmaError> {
    if s.len() == expected {
        Ok(())
    } else {
        Err(MmaError::DimensionMismatch {
            name,
            expected,
            got: s.len(),
        })
    }
}

/// Values per job of the parallel input checks.
const CHECK_BLOCK: usize = 16 * CHUNK;

/// Whether `ok(i)` holds for all `i < len`: a branch-free (vectorizable) scan per block, the
/// blocks spread over threads when `parallel`.
pub(crate) fn all_ok(len: usize, parallel: bool, ok: impl Fn(usize) -> bool + Sync) -> bool {
    let block = |start: usize| (start..(start + CHECK_BLOCK).min(len)).fold(true, |a, i| a & ok(i));
    if parallel {
        (0..len.div_ceil(CHECK_BLOCK))
            .into_par_iter()
            .all(|b| block(b * CHECK_BLOCK))
    } else {
        (0..len).step_by(CHECK_BLOCK).all(block)
    }
}

/// `Ok` when every entry of the slice `name` is finite, else [`MmaError::NonFinite`] with the
/// first offending index.
pub(crate) fn check_finite(name: &'static str, s: &[f64], parallel: bool) -> Result<(), MmaError> {
    if all_ok(s.len(), parallel, |i| s[i].is_finite()) {
        return Ok(());
    }
    // Only on failure: the first offending index.
    let index = s.iter().position(|v| !v.is_finite()).unwrap_or(0);
    Err(MmaError::NonFinite {
        name,
        index,
        value: s[index],
    })
}
