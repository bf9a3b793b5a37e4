//! The direction pass of the (m+1)×(m+1) branch: Δx = −D_x⁻¹ (δ_x + GᵀΔλ), Δξ, Δη and the
//! largest step of the n-dimensional variables, the current point stored as the new base,
//! and (speculatively) the evaluation of the trial point at the step the m-dimensional
//! variables allow.

use multiversion::multiversion;
use rayon::prelude::*;

use super::evaluate::{EvalAcc, EvalCtx, StaticAcc, block_terms, eval_block, point, reduced_len};
use super::terms::step;
use super::{ChunkItem, SubSolver};
use crate::lanes::{CHUNK, DYN, LANES, Nodes, Real, V, chunk_len, min_len};
use crate::subproblem::{DETA, DX, DXSI, ETA, NSTATE, PQ, X, XSI};

impl SubSolver {
    /// Direction pass of the (m+1)×(m+1) branch: moves the base point to the current point,
    /// stores Δx, Δξ, Δη there and returns the largest step ratio of the n-dimensional
    /// variables. Also evaluates the trial point `base + t·Δ` with λ + t·Δλ (`t = steg`, the
    /// step allowed by the m-dimensional variables) into the chunk slots, read by
    /// [`Self::reduce_eval`] if the n-dimensional variables allow that step too.
    pub(super) fn direction_pass(&mut self, eps: f64, steg: f64, need_h: bool) -> f64 {
        let m = self.m;
        for i in 0..m {
            self.lam1[i] = self.lam[i] + steg * self.dlam[i];
        }
        let ctx = DirCtx {
            n: self.n,
            m,
            lam: &self.lam,
            dlam: &self.dlam,
            eps,
            steg_p: self.pending,
            spec: Some(EvalCtx {
                n: self.n,
                m,
                lam: &self.lam1,
                steg,
                eps_a: eps,
                eps_b: 0.1 * eps,
                need_h,
            }),
        };
        let f = |(c, ((nd, st), (a, ln))): ChunkItem<'_, &mut [f64]>| {
            dispatch_m!(m, direction_chunk, &ctx, c, nd, st, a, ln)
        };
        for_each_chunk!(self, par_chunks_mut, f);
        self.pending = 0.0;
        let r = reduced_len(m);
        self.acc
            .chunks_exact(self.slot)
            .fold(f64::NEG_INFINITY, |acc, a| acc.max(a[r]))
    }
}

struct DirCtx<'a> {
    n: usize,
    m: usize,
    lam: &'a [f64],
    dlam: &'a [f64],
    eps: f64,
    /// The current point is `base + steg_p·Δ`.
    steg_p: f64,
    /// Evaluation of the trial point `point + steg·Δ`, when speculating.
    spec: Option<EvalCtx<'a>>,
}

/// One block of the direction pass: Δx = −(δx + GᵀΔλ)/diagx at the current point, Δξ, Δη,
/// the step ratio; stores the point and Δ; evaluates the trial step when speculating.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
#[allow(clippy::needless_range_loop)]
fn direction_block<const MASK: bool>(
    ctx: &DirCtx<'_>,
    m: usize,
    nd: Nodes<'_>,
    st: &mut [f64],
    o: usize,
    valid: usize,
    stm: &mut V,
    acc: &mut EvalAcc<'_>,
) {
    let (x, xsi, eta) = point(st, o, ctx.steg_p);
    let t = block_terms(nd, m, ctx.lam, o, (x, xsi, eta));
    let mut rhs = t.dpsidx + V::splat(ctx.eps) * t.e;
    let dlam = &ctx.dlam[..m];
    for i in 0..m {
        let (p, q) = (nd.get(PQ + i, o), nd.get(PQ + m + i, o));
        rhs = rhs + (p * t.uxinv2 - q * t.xlinv2) * V::splat(dlam[i]);
    }
    let dx = -rhs / t.diagx;
    let s = step(xsi, eta, dx, t.xainv, t.bxinv, ctx.eps);
    *stm = stm.maxv(s.ratio.keep::<MASK>(valid, f64::NEG_INFINITY));
    for (f, v) in [
        (X, x),
        (XSI, xsi),
        (ETA, eta),
        (DX, dx),
        (DXSI, s.dxsi),
        (DETA, s.deta),
    ] {
        v.store::<MASK>(&mut st[f * CHUNK..(f + 1) * CHUNK], o, valid);
    }
    if let Some(e) = &ctx.spec {
        // The same arithmetic as `point` at the next evaluation pass.
        let t = V::splat(e.steg);
        let p1 = (x + t * dx, xsi + t * s.dxsi, eta + t * s.deta);
        eval_block::<MASK>(e, m, nd, o, valid, p1, acc);
    }
}

#[multiversion(targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"))]
fn direction_chunk<'a, const M: usize>(
    ctx: &DirCtx<'a>,
    c: usize,
    nodes: &[f64],
    st: &mut [f64],
    a: &mut [f64],
    ln: &mut [V],
) {
    let m = if M == DYN { ctx.m } else { M };
    let nd = Nodes(nodes);
    let mut sacc = StaticAcc::new();
    let mut acc = EvalAcc::new::<M>(m, &mut sacc, ln);
    let mut stm = V::splat(f64::NEG_INFINITY);
    let (full, tail) = chunk_len(ctx.n, c);
    for b in 0..full {
        direction_block::<false>(ctx, m, nd, st, b * LANES, LANES, &mut stm, &mut acc);
    }
    if tail > 0 {
        direction_block::<true>(ctx, m, nd, st, full * LANES, tail, &mut stm, &mut acc);
    }
    if ctx.spec.is_some() {
        acc.finish(m, a);
    }
    a[reduced_len(m)] = stm.hmax(f64::NEG_INFINITY);
}
