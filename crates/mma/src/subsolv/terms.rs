//! Per-variable formulas (Svanberg 2007, section 5: the relaxed KKT conditions and the
//! reduced Newton system), written once for f64 and for lanes.

use crate::lanes::Real;

/// Quantities of one variable at a point, shared by the passes.
#[derive(Clone, Copy)]
pub(super) struct Terms<T> {
    pub(super) uxinv: T,
    pub(super) xlinv: T,
    pub(super) uxinv2: T,
    pub(super) xlinv2: T,
    /// 1/(x−α), 1/(β−x).
    pub(super) xainv: T,
    pub(super) bxinv: T,
    /// ∂ψ/∂x = (p₀ + λᵀP)/(u−x)² − (q₀ + λᵀQ)/(x−l)².
    pub(super) dpsidx: T,
    /// ∂²ψ/∂x² + ξ/(x−α) + η/(β−x).
    pub(super) diagx: T,
    /// 1/(β−x) − 1/(x−α): `delx = dpsidx + ε·e`.
    pub(super) e: T,
}

/// [`Terms`] at `(x, ξ, η)`, with `plam = p₀ + λᵀP`, `qlam = q₀ + λᵀQ`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn terms<T: Real>(
    low: T,
    upp: T,
    alfa: T,
    beta: T,
    plam: T,
    qlam: T,
    x: T,
    xsi: T,
    eta: T,
) -> Terms<T> {
    let one = T::splat(1.0);
    let uxinv = one / (upp - x);
    let xlinv = one / (x - low);
    let xainv = one / (x - alfa);
    let bxinv = one / (beta - x);
    let uxinv2 = uxinv * uxinv;
    let xlinv2 = xlinv * xlinv;
    let pu = plam * uxinv2;
    let ql = qlam * xlinv2;
    Terms {
        uxinv,
        xlinv,
        uxinv2,
        xlinv2,
        xainv,
        bxinv,
        dpsidx: pu - ql,
        diagx: T::splat(2.0) * (pu * uxinv + ql * xlinv) + xsi * xainv + eta * bxinv,
        e: bxinv - xainv,
    }
}

/// Δξ, Δη and the step ratio of one variable.
pub(super) struct Step<T> {
    pub(super) dxsi: T,
    pub(super) deta: T,
    /// Largest ratio `-1.01·Δv/v` over x−α, β−x, ξ, η (the step is `1/max(ratio, 1)`).
    pub(super) ratio: T,
}

/// Δξ = −ξ + ε/(x−α) − ξΔx/(x−α), Δη = −η + ε/(β−x) + ηΔx/(β−x), and the step ratio.
#[inline(always)]
pub(super) fn step<T: Real>(xsi: T, eta: T, dx: T, xainv: T, bxinv: T, eps: f64) -> Step<T> {
    let epsv = T::splat(eps);
    let dxsi = epsv * xainv - xsi - xsi * dx * xainv;
    let deta = epsv * bxinv - eta + eta * dx * bxinv;
    let c = T::splat(1.01);
    let mc = T::splat(-1.01);
    let ratio = (mc * dx * xainv)
        .maxv(c * dx * bxinv)
        .maxv(mc * dxsi / xsi)
        .maxv(mc * deta / eta);
    Step { dxsi, deta, ratio }
}
