//! Tunable constants of MMA, with Svanberg's defaults.

use flexstage_numerics::validate::Interval;

use crate::error::ParamError;

/// Parameters of MMA.
///
/// The defaults are those of Svanberg's `mmasub.m` and of the 2007 note
/// "MMA and GCMMA – two methods for nonlinear optimization":
///
/// | field | default | accepted range | meaning |
/// |---|---|---|---|
/// | `asyinit` | 0.5 | (0, 10] | initial asymptote distance, as a fraction of `xmax - xmin` |
/// | `asyincr` | 1.2 | [1, 10] | asymptote widening factor when two steps agree in sign |
/// | `asydecr` | 0.7 | (0, 1] | asymptote narrowing factor when two steps oscillate |
/// | `asymin` | 0.01 | (0, `asymax`) | least distance of an asymptote from `x`, fraction of `xmax - xmin` |
/// | `asymax` | 10 | (`asymin`, 1e6] | largest distance of an asymptote from `x`, fraction of `xmax - xmin` |
/// | `albefa` | 0.1 | (0, 1) | the subproblem bounds α, β stay this fraction of `x - low` (`upp - x`) away from the asymptotes |
/// | `move_limit` | 0.5 | (0, 1] | move limit, fraction of `xmax - xmin` |
/// | `raa0` | 1e-5 | (0, 1] | regularisation of the p/q coefficients (`raa0 / (xmax - xmin)`) |
/// | `a0` | 1 | (0, 1e12] | coefficient a₀ of the artificial variable z |
/// | `a` | 0 | [0, 1e12] | coefficients aᵢ of z in the constraints (same for all i) |
/// | `c` | 1000 | [0, 1e12] | linear cost cᵢ of the artificial variables yᵢ (same for all i) |
/// | `d` | 1 | [0, 1e12] | quadratic cost dᵢ of the artificial variables yᵢ (same for all i) |
/// | `subproblem_tolerance` | 1e-7 | [1e-15, 1e-2] | `epsimin`: the interior-point barrier parameter ε is reduced by 10 until below it |
/// | `parallel_threshold` | 6144 | any | use rayon for the O(n) loops when `n >= parallel_threshold` (results do not depend on it) |
/// | `subsolver` | `PrimalDual` | [`Subsolver`] | interior-point method for the subproblem |
///
/// With `a = 0` and large `c` the artificial variables yᵢ vanish at the solution whenever the
/// original problem is feasible, and the MMA iterates then solve the original problem.
///
/// The curvature of the MMA approximation of fᵢ at xᵏ is about `2·|∂fᵢ/∂xⱼ|/δ + 4·raa0/δ`
/// (δ the asymptote distance). At an optimum where the Lagrangian gradient of a free
/// variable vanishes without help from a constraint (e.g. an unconstrained interior
/// minimum), the default `raa0 = 1e-5` leaves the approximation too flat and plain MMA
/// oscillates with an amplitude near `asymin·(xmax − xmin)`; a larger `raa0` (e.g. 0.1 for
/// unit-scaled problems) restores convergence.
///
/// The norm of the KKT residual of the interior-point subproblem is of order
/// `subproblem_tolerance * sqrt(n)`; when the KKT residual of the original problem is used as
/// stopping criterion on large problems, reduce `subproblem_tolerance` accordingly.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MmaParams {
    /// Initial asymptote distance factor (`asyinit`).
    pub asyinit: f64,
    /// Asymptote increase factor (`asyincr`).
    pub asyincr: f64,
    /// Asymptote decrease factor (`asydecr`).
    pub asydecr: f64,
    /// Least asymptote distance factor (0.01 in `mmasub.m`).
    pub asymin: f64,
    /// Largest asymptote distance factor (10 in `mmasub.m`).
    pub asymax: f64,
    /// Distance of α, β from the asymptotes (`albefa`).
    pub albefa: f64,
    /// Move limit (`move`).
    pub move_limit: f64,
    /// Regularisation term of p and q (`raa0`).
    pub raa0: f64,
    /// a₀.
    pub a0: f64,
    /// aᵢ (all constraints).
    pub a: f64,
    /// cᵢ (all constraints).
    pub c: f64,
    /// dᵢ (all constraints).
    pub d: f64,
    /// `epsimin` of `subsolv`.
    pub subproblem_tolerance: f64,
    /// Problem size from which rayon is used. The default, six chunks of 1024 variables, is
    /// about where two threads start to pay for one update on a 2-core machine; the serial
    /// and parallel paths give bitwise the same results.
    pub parallel_threshold: usize,
    /// Interior-point method for the subproblem.
    pub subsolver: Subsolver,
}

/// The interior-point method that solves the MMA subproblem.
///
/// Both solve the same convex subproblem to the same tolerance (`subproblem_tolerance`), so
/// their iterates agree to about that tolerance, not bit for bit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Subsolver {
    /// Svanberg's primal–dual method `subsolv` on the KKT conditions in (x, y, z, λ, ξ, η, μ,
    /// ζ, s), exactly as in `mmasub.m` (the reference; the default). Each Newton step reads
    /// and writes the n-dimensional iterate.
    #[default]
    PrimalDual,
    /// A primal–dual interior-point method on the Lagrangian dual, whose unknowns are
    /// m-dimensional (λ and the multipliers of λ ≥ 0), with x(λ) in closed form; each Newton
    /// step is one read-only pass over the variables, and the solve is warm-started from the
    /// previous update's multipliers, so it is several times faster than `PrimalDual` for
    /// large n (6.6× at n = 10⁶ in the crate's benchmark). If it fails to converge (after a
    /// cold restart, 100 steps), the update falls back to `PrimalDual` on the same
    /// subproblem and says so in [`crate::UpdateReport::subsolver`]. Bounds that are active
    /// are met exactly (`subsolv` stays about ε/ξ inside them).
    Dual,
}

impl Default for MmaParams {
    fn default() -> Self {
        Self {
            asyinit: 0.5,
            asyincr: 1.2,
            asydecr: 0.7,
            asymin: 0.01,
            asymax: 10.0,
            albefa: 0.1,
            move_limit: 0.5,
            raa0: 1e-5,
            a0: 1.0,
            a: 0.0,
            c: 1000.0,
            d: 1.0,
            subproblem_tolerance: 1e-7,
            parallel_threshold: 6144,
            subsolver: Subsolver::PrimalDual,
        }
    }
}

/// `Ok` when `value` lies in `range` (NaN and ±∞ never do), else
/// [`ParamError::OutOfRange`] with `text`, the accepted range as documented.
fn check(
    field: &'static str,
    value: f64,
    range: Interval,
    text: &'static str,
) -> Result<(), ParamError> {
    if range.contains(value) {
        Ok(())
    } else {
        Err(ParamError::OutOfRange {
            field,
            value,
            range: text,
        })
    }
}

impl MmaParams {
    /// Checks every field against its documented range.
    ///
    /// # Errors
    /// [`ParamError::OutOfRange`] naming the first offending field and its accepted range, or
    /// [`ParamError::Inconsistent`] when `asymin >= asymax`.
    pub fn validate(&self) -> Result<(), ParamError> {
        let large = Interval::open_closed(0.0, 1e6);
        let cost = Interval::closed(0.0, 1e12);
        check(
            "asyinit",
            self.asyinit,
            Interval::open_closed(0.0, 10.0),
            "(0, 10]",
        )?;
        check(
            "asyincr",
            self.asyincr,
            Interval::closed(1.0, 10.0),
            "[1, 10]",
        )?;
        check(
            "asydecr",
            self.asydecr,
            Interval::open_closed(0.0, 1.0),
            "(0, 1]",
        )?;
        check("asymin", self.asymin, large, "(0, asymax)")?;
        check("asymax", self.asymax, large, "(asymin, 1e6]")?;
        if self.asymin >= self.asymax {
            return Err(ParamError::Inconsistent {
                field: "asymin",
                value: self.asymin,
                other: "asymax",
                other_value: self.asymax,
                reason: "asymin must be smaller than asymax",
            });
        }
        check("albefa", self.albefa, Interval::open(0.0, 1.0), "(0, 1)")?;
        check(
            "move_limit",
            self.move_limit,
            Interval::open_closed(0.0, 1.0),
            "(0, 1]",
        )?;
        check("raa0", self.raa0, Interval::open_closed(0.0, 1.0), "(0, 1]")?;
        check("a0", self.a0, Interval::open_closed(0.0, 1e12), "(0, 1e12]")?;
        check("a", self.a, cost, "[0, 1e12]")?;
        check("c", self.c, cost, "[0, 1e12]")?;
        check("d", self.d, cost, "[0, 1e12]")?;
        check(
            "subproblem_tolerance",
            self.subproblem_tolerance,
            Interval::closed(1e-15, 1e-2),
            "[1e-15, 1e-2]",
        )?;
        Ok(())
    }
}
