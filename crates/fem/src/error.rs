//! Typed errors. Every variant carries the offending field/value and, where it
//! applies, the accepted range, so that a message is actionable on its own.

use thiserror::Error;

/// A parameter outside its accepted range, or inconsistent input sizes.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ParamError {
    /// A scalar parameter is outside its accepted range.
    #[error("parameter `{field}` = {value} is outside the accepted range {range}")]
    OutOfRange {
        /// Name of the field (e.g. `"NewtonParams::residual_tol"`).
        field: &'static str,
        /// The rejected value (integers are converted to `f64`).
        value: f64,
        /// Human-readable accepted range, e.g. `"(0, 1)"`.
        range: &'static str,
    },
    /// A slice/vector has the wrong length.
    #[error("`{what}` has length {got}, expected {expected}")]
    Length {
        /// What was passed (e.g. `"densities"`).
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Actual length.
        got: usize,
    },
    /// A degree of freedom or node/element index is out of bounds.
    #[error("`{what}` index {index} is out of bounds (0..{bound})")]
    Index {
        /// What kind of index (e.g. `"dof"`).
        what: &'static str,
        /// The index given.
        index: usize,
        /// Exclusive upper bound.
        bound: usize,
    },
    /// An index that must appear once appears twice.
    #[error("`{what}` lists index {index} twice")]
    Duplicate {
        /// What was passed (e.g. `"LinkSpring::terms"`).
        what: &'static str,
        /// The repeated index.
        index: usize,
    },
    /// A non-finite value (NaN or infinity) was supplied.
    #[error("`{what}` contains a non-finite value at position {index}")]
    NonFinite {
        /// What was passed.
        what: &'static str,
        /// First non-finite position.
        index: usize,
    },
}

/// Failures of the sparse linear algebra layer.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SolverError {
    /// faer reported an error during symbolic analysis (out of memory, index overflow).
    #[error("symbolic Cholesky analysis failed: {0}")]
    Symbolic(String),
    /// Both the LLᵀ and the pivoted LBLᵀ factorization failed or produced non-finite values.
    #[error(
        "matrix could not be factorized: LLᵀ failed at pivot {llt_pivot} (matrix not positive \
         definite) and the LBLᵀ fallback produced non-finite factors: the matrix is singular. \
         For a stiffness matrix, the structure floats or has an unconnected part; fix the \
         supports ([[supports]]) or add a spring (optimization.output_spring > 0)"
    )]
    Singular {
        /// Pivot index (in the permuted ordering) at which LLᵀ failed.
        llt_pivot: usize,
    },
    /// A pivot of the factorization is zero within round-off: the matrix is singular. For a
    /// stiffness matrix this means the structure floats (a rigid-body motion is held by no
    /// support or spring) or a part of it is not connected.
    #[error(
        "the stiffness matrix is singular: pivot {pivot} (permuted order) is {value:.3e}, at or \
         below the round-off level {threshold:.3e} (n·ε·max diagonal). The structure floats or \
         has an unconnected part: a rigid-body motion is held by no support or spring. Fix the \
         supports (in a scenario: [[supports]], e.g. fix = \"y\" at the input nodes) or add a \
         spring (optimization.output_spring > 0)"
    )]
    SingularStiffness {
        /// Pivot index (in the permuted ordering).
        pivot: usize,
        /// Its magnitude (`L_kk²` for LLᵀ, `|B_kk|` or a 2×2 block's smaller `|λ|` for LBLᵀ).
        value: f64,
        /// The singularity threshold `n·ε·max |a_ii|`.
        threshold: f64,
    },
    /// LLᵀ failed and the caller disallowed the indefinite fallback.
    #[error(
        "matrix is not positive definite (LLᵀ failed at permuted pivot {pivot}); indefinite \
         fallback disabled"
    )]
    NotPositiveDefinite {
        /// Pivot index (in the permuted ordering) at which LLᵀ failed.
        pivot: usize,
    },
    /// The matrix pattern differs from the one the symbolic factorization was built for.
    #[error("matrix pattern does not match the symbolic factorization ({what})")]
    PatternMismatch {
        /// What differed.
        what: &'static str,
    },
    /// A solve was requested before any successful numeric factorization.
    #[error("no numeric factorization available: call `factorize` first")]
    NotFactorized,
    /// Preconditioned conjugate gradients did not reach the tolerance.
    #[error(
        "PCG did not converge: relative residual {relative_residual:.3e} > tolerance \
         {tolerance:.1e} after {iterations} iterations"
    )]
    PcgNotConverged {
        /// Iterations performed.
        iterations: usize,
        /// Final ‖r‖/‖b‖.
        relative_residual: f64,
        /// Requested tolerance.
        tolerance: f64,
    },
    /// PCG met a direction of non-positive curvature (matrix or preconditioner indefinite).
    #[error(
        "PCG breakdown at iteration {iteration}: pᵀAp = {curvature:.3e} ≤ 0 (indefinite matrix)"
    )]
    PcgIndefinite {
        /// Iteration at which the breakdown happened.
        iteration: usize,
        /// The offending curvature pᵀAp.
        curvature: f64,
    },
    /// Springs taken off a factored stiffness leave it singular (a low-rank update whose
    /// capacitance matrix cannot be inverted): the structure is no longer held.
    #[error(
        "the spring update leaves the stiffness singular: the springs taken off held the \
         structure"
    )]
    SingularUpdate,
    /// A vector contained NaN/∞ (input or result).
    #[error("non-finite value in `{what}`")]
    NonFinite {
        /// Which vector.
        what: &'static str,
    },
}

/// One Newton iteration, recorded for reports and error diagnosis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IterationRecord {
    /// Load factor λ ∈ (0, 1] of the increment this iteration belongs to.
    pub load_factor: f64,
    /// Iteration counter inside the increment (0 = first correction).
    pub iteration: usize,
    /// ‖P_λ − R(u)‖ over free DOFs *before* the correction.
    pub residual_norm: f64,
    /// The same, divided by the reference force norm (see [`crate::newton`]).
    pub relative_residual: f64,
    /// ‖Δu‖/max(‖u‖, tiny) of the correction actually applied (after line search).
    pub relative_increment: f64,
    /// Line-search step length applied (1 = full Newton step).
    pub step_length: f64,
    /// Inner linear iterations (1 for a direct solve, PCG count otherwise).
    pub linear_iterations: usize,
}

/// Why a Newton solve failed. Always carries the full iteration history.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum NewtonError {
    /// The parameters are invalid.
    #[error(transparent)]
    Params(#[from] ParamError),
    /// The load could not be applied: an increment failed even after the maximum number of
    /// cutbacks.
    #[error(
        "Newton-Raphson did not converge: stuck at load factor {reached:.4} (attempted \
         {attempted:.4}) after {cutbacks} cutbacks; last relative residual {last_residual:.3e}; \
         {n} iterations recorded",
        n = history.len()
    )]
    NotConverged {
        /// Last load factor that converged (0 if none).
        reached: f64,
        /// Load factor of the failed attempt.
        attempted: f64,
        /// Cutbacks used.
        cutbacks: usize,
        /// Relative residual of the last iteration.
        last_residual: f64,
        /// All iterations (including failed attempts).
        history: Vec<IterationRecord>,
    },
    /// A linear solve failed in a way cutbacks cannot fix.
    #[error("linear solver failure in Newton iteration")]
    Linear {
        /// The underlying error.
        source: SolverError,
        /// Iterations so far.
        history: Vec<IterationRecord>,
    },
}

impl NewtonError {
    /// The recorded iteration history (empty for parameter errors).
    pub fn history(&self) -> &[IterationRecord] {
        match self {
            NewtonError::Params(_) => &[],
            NewtonError::NotConverged { history, .. } | NewtonError::Linear { history, .. } => {
                history
            }
        }
    }
}

/// Check that `x` lies in `[lo, hi]` (closed) and is finite.
pub(crate) fn check_range(
    field: &'static str,
    x: f64,
    lo: f64,
    hi: f64,
    range: &'static str,
) -> Result<(), ParamError> {
    if x.is_finite() && x >= lo && x <= hi {
        Ok(())
    } else {
        Err(ParamError::OutOfRange {
            field,
            value: x,
            range,
        })
    }
}

/// Check that `x` lies in the open interval `(lo, hi)`.
pub(crate) fn check_open(
    field: &'static str,
    x: f64,
    lo: f64,
    hi: f64,
    range: &'static str,
) -> Result<(), ParamError> {
    if x.is_finite() && x > lo && x < hi {
        Ok(())
    } else {
        Err(ParamError::OutOfRange {
            field,
            value: x,
            range,
        })
    }
}

pub(crate) fn check_len(what: &'static str, got: usize, expected: usize) -> Result<(), ParamError> {
    if got == expected {
        Ok(())
    } else {
        Err(ParamError::Length {
            what,
            expected,
            got,
        })
    }
}
