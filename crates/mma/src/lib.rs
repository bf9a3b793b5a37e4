//! # flexstage-mma — the Method of Moving Asymptotes
//!
//! A standalone implementation of Svanberg's MMA for
//!
//! ```text
//! minimize    f₀(x)
//! subject to  fᵢ(x) ≤ 0,          i = 1..m
//!             xminⱼ ≤ xⱼ ≤ xmaxⱼ,  j = 1..n
//! ```
//!
//! following exactly the `mmasub`/`subsolv`/`kktcheck` formulation of
//! K. Svanberg, *MMA and GCMMA – two methods for nonlinear optimization* (KTH, 2007), which
//! refines the original method of K. Svanberg, *The method of moving asymptotes — a new
//! method for structural optimization*, Int. J. Numer. Meth. Engng 24 (1987) 359–373.
//!
//! ## The problem actually solved
//!
//! Artificial variables `y ∈ ℝᵐ`, `z ∈ ℝ` make every subproblem feasible:
//!
//! ```text
//! minimize    f₀(x) + a₀ z + Σᵢ (cᵢ yᵢ + ½ dᵢ yᵢ²)
//! subject to  fᵢ(x) − aᵢ z − yᵢ ≤ 0,   xmin ≤ x ≤ xmax,   y ≥ 0,   z ≥ 0
//! ```
//!
//! with the defaults `a₀ = 1`, `aᵢ = 0`, `cᵢ = 1000`, `dᵢ = 1` (see [`MmaParams`]); for a
//! feasible problem and large `cᵢ` the optimum has `y = 0`, `z = 0`.
//!
//! ## The MMA subproblem at iteration k
//!
//! Asymptotes `lⱼ < xⱼᵏ < uⱼ`: for k ≤ 2, `lⱼ = xⱼᵏ − asyinit·(xmaxⱼ − xminⱼ)` and
//! `uⱼ = xⱼᵏ + asyinit·(xmaxⱼ − xminⱼ)`. Later, with `γⱼ = asyincr` if
//! `(xⱼᵏ − xⱼᵏ⁻¹)(xⱼᵏ⁻¹ − xⱼᵏ⁻²) > 0`, `asydecr` if `< 0` and 1 otherwise,
//!
//! ```text
//! lⱼ = xⱼᵏ − γⱼ (xⱼᵏ⁻¹ − lⱼᵏ⁻¹),     uⱼ = xⱼᵏ + γⱼ (uⱼᵏ⁻¹ − xⱼᵏ⁻¹),
//! ```
//!
//! both kept between `asymin` and `asymax` times `xmaxⱼ − xminⱼ` from `xⱼᵏ`. Move limits:
//!
//! ```text
//! αⱼ = max(xminⱼ, lⱼ + albefa (xⱼᵏ − lⱼ), xⱼᵏ − move (xmaxⱼ − xminⱼ))
//! βⱼ = min(xmaxⱼ, uⱼ − albefa (uⱼ − xⱼᵏ), xⱼᵏ + move (xmaxⱼ − xminⱼ))
//! ```
//!
//! Each fᵢ (i = 0..m) is replaced by the convex separable approximation
//!
//! ```text
//! f̃ᵢ(x) = Σⱼ ( pᵢⱼ / (uⱼ − xⱼ) + qᵢⱼ / (xⱼ − lⱼ) ) + rᵢ
//! pᵢⱼ = (uⱼ − xⱼᵏ)² ( (∂fᵢ/∂xⱼ)⁺ + 0.001 |∂fᵢ/∂xⱼ| + raa0 / (xmaxⱼ − xminⱼ) )
//! qᵢⱼ = (xⱼᵏ − lⱼ)² ( (∂fᵢ/∂xⱼ)⁻ + 0.001 |∂fᵢ/∂xⱼ| + raa0 / (xmaxⱼ − xminⱼ) )
//! ```
//!
//! (`raa0 = 1e-5`), which matches fᵢ and ∇fᵢ at xᵏ. The subproblem
//!
//! ```text
//! minimize    f̃₀(x) + a₀ z + Σᵢ (cᵢ yᵢ + ½ dᵢ yᵢ²)
//! subject to  f̃ᵢ(x) − aᵢ z − yᵢ ≤ 0,   α ≤ x ≤ β,   y ≥ 0,   z ≥ 0
//! ```
//!
//! is solved by the primal–dual interior-point method `subsolv` (the default,
//! [`Subsolver::PrimalDual`]): Newton's method on the
//! KKT conditions perturbed by ε (ε = 1, 0.1, …, down to `subproblem_tolerance`), with
//! multipliers λ, ξ, η, μ, ζ, s. The Newton system is reduced to the (m+1)×(m+1) system
//! in (Δλ, Δz)
//!
//! ```text
//! [ D_λ + G D_x⁻¹ Gᵀ   a       ] [Δλ]   [ δ_λ + δ_y / D_y − G D_x⁻¹ δ_x ]
//! [ aᵀ                 −ζ / z  ] [Δz] = [ δ_z                          ]
//! ```
//!
//! (`G` the m × n Jacobian of the approximations, `D_x` diagonal), followed by the
//! componentwise back-substitution `Δx = −D_x⁻¹ (δ_x + Gᵀ Δλ)`. Each Newton step therefore
//! costs O(n·m² + m³); when `n ≤ m` the (n+1)×(n+1) system of `subsolv` is used instead.
//!
//! For large `n`, [`Subsolver::Dual`] solves the same subproblem through its Lagrangian
//! dual, whose unknowns are m-dimensional: x(λ) has a closed form, each Newton step is one
//! read-only pass over the variables, and the solve is warm-started from the previous
//! multipliers (typically 2–3 steps). Its iterates agree with those of `subsolv` to the
//! subproblem tolerance; if it fails, the update falls back to `subsolv`.
//!
//! ## Usage
//!
//! Build an [`Mma`] once, then iterate: evaluate, [`Mma::update`], repeat. [`minimize`]
//! runs that loop for a [`Problem`], and [`samples`] holds test problems with known
//! solutions. [`kkt_residual`] (Svanberg's `kktcheck`) measures optimality using the
//! multipliers exposed by [`Mma::multipliers`].
//!
//! The O(n) loops of the subproblem solver run on 8 variables at a time (SIMD, with the
//! instruction set chosen at run time) over fixed chunks of 1024 variables. Problems with
//! `n ≥ parallel_threshold` (6144 by default) spread the chunks over threads with rayon;
//! reductions are done per chunk and summed in order, so results do not depend on the
//! number of threads (nor on the instruction set: no fused multiply–add is used).

#![warn(missing_docs)]

#[macro_use]
mod lanes;
mod dense;
mod dual;
mod error;
mod input;
mod kkt;
mod mma;
mod params;
pub mod samples;
mod solve;
mod subproblem;
mod subsolv;

pub use error::{MmaError, ParamError};
pub use kkt::{KktProblem, KktResidual, Multipliers, kkt_residual};
pub use mma::{Mma, MmaState, UpdateReport};
pub use params::{MmaParams, Subsolver};
pub use solve::{Problem, Solution, StopCriteria, minimize};
