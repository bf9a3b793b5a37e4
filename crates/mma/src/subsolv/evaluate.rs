//! The evaluation pass: at a trial point `base + t·Δ`, the n-dimensional pieces of the
//! relaxed KKT residual (for ε and ε/10) and of the reduced Newton system (`gvec`,
//! `Σ GGᵀ/diagx`, and `Σ G·delx/diagx` split into its ε-free and ε-linear parts), chunk by
//! chunk into per-chunk slots, then reduced in order.

use multiversion::multiversion;
use rayon::prelude::*;

use super::terms::{Terms, terms};
use super::{ChunkItem, SubSolver};
use crate::lanes::{CHUNK, DYN, LANES, MAX_STATIC_M, Nodes, Real, V, chunk_len, min_len};
use crate::subproblem::{ALFA, BETA, DETA, DX, DXSI, ETA, LOW, NSTATE, P0, PQ, Q0, UPP, X, XSI};

/// The n-dimensional pieces of the relaxed KKT residual: the sums of squares and the largest
/// |r| of r_x = ∂ψ/∂x − ξ + η, and of the complementarity residuals ξ(x−α) − ε and
/// η(β−x) − ε at the two levels ε = `eps_a` (`_a`) and ε/10 (`_b`), so that the next barrier
/// level needs no new pass.
#[derive(Clone, Copy, Debug)]
pub(super) struct Pieces<T> {
    pub(super) sum_x: T,
    pub(super) max_x: T,
    pub(super) sum_a: T,
    pub(super) max_a: T,
    pub(super) sum_b: T,
    pub(super) max_b: T,
}

impl<T: Copy> Pieces<T> {
    #[inline(always)]
    fn splat(v: T) -> Self {
        Self {
            sum_x: v,
            max_x: v,
            sum_a: v,
            max_a: v,
            sum_b: v,
            max_b: v,
        }
    }
}

/// Where the [`Pieces`] are in a chunk's reduction slot; `gvec`, `b0`, `b1` (m each) and
/// `H` (m × m, lower triangle) follow from [`PIECES`] on, and the direction pass puts the step
/// ratio at [`reduced_len`].
const SUM_X: usize = 0;
const MAX_X: usize = 1;
const SUM_A: usize = 2;
const MAX_A: usize = 3;
const SUM_B: usize = 4;
const MAX_B: usize = 5;
/// Number of [`Pieces`] entries at the head of a slot.
const PIECES: usize = 6;

/// Number of scalar slots (the residual pieces, gvec, b0, b1, H) of a reduction.
pub(super) fn reduced_len(m: usize) -> usize {
    PIECES + 3 * m + m * m
}

/// Per-chunk lane accumulators needed when `m` is not a compile-time constant: gvec, b0,
/// b1, the lower triangle of H, and G of the current block.
pub(super) fn dyn_lanes(m: usize) -> usize {
    if m > MAX_STATIC_M {
        4 * m + m * (m + 1) / 2
    } else {
        1
    }
}

/// The n-dimensional parts of one residual evaluation, for the levels `eps_a` and
/// `eps_b` = ε/10.
#[derive(Clone, Copy, Debug)]
pub(super) struct Eval {
    pub(super) eps_a: f64,
    pub(super) eps_b: f64,
    pub(super) pieces: Pieces<f64>,
}

impl SubSolver {
    /// Evaluation pass at the point `base + steg·Δ` with the current m-dimensional
    /// variables; fills `gvec` (and `b0`, `b1`, `h` when `need_h`).
    pub(super) fn eval(&mut self, steg: f64, eps_a: f64, need_h: bool) -> Eval {
        let ctx = EvalCtx {
            n: self.n,
            m: self.m,
            lam: &self.lam,
            steg,
            eps_a,
            eps_b: 0.1 * eps_a,
            need_h,
        };
        let f = |(c, ((nd, st), (a, ln))): ChunkItem<'_, &[f64]>| {
            dispatch_m!(self.m, eval_chunk, &ctx, c, nd, st, a, ln)
        };
        for_each_chunk!(self, par_chunks, f);
        self.reduce_eval(eps_a)
    }

    /// Ordered reduction over the chunk slots of an evaluation (by [`Self::eval`] or the
    /// speculative part of [`Self::direction_pass`]).
    pub(super) fn reduce_eval(&mut self, eps_a: f64) -> Eval {
        let m = self.m;
        let r = reduced_len(m);
        let mut e = Eval {
            eps_a,
            eps_b: 0.1 * eps_a,
            pieces: Pieces::splat(0.0),
        };
        self.gvec.fill(0.0);
        self.b0.fill(0.0);
        self.b1.fill(0.0);
        self.h.fill(0.0);
        let p = &mut e.pieces;
        for a in self.acc.chunks_exact(self.slot) {
            p.sum_x += a[SUM_X];
            p.max_x = p.max_x.max(a[MAX_X]);
            p.sum_a += a[SUM_A];
            p.max_a = p.max_a.max(a[MAX_A]);
            p.sum_b += a[SUM_B];
            p.max_b = p.max_b.max(a[MAX_B]);
            let a = &a[PIECES..r];
            for i in 0..m {
                self.gvec[i] += a[i];
                self.b0[i] += a[m + i];
                self.b1[i] += a[2 * m + i];
            }
            for (hv, av) in self.h.iter_mut().zip(&a[3 * m..]) {
                *hv += av;
            }
        }
        e
    }
}

// Chunk kernels.

pub(super) struct EvalCtx<'a> {
    pub(super) n: usize,
    pub(super) m: usize,
    pub(super) lam: &'a [f64],
    /// The point is `base + steg·Δ`.
    pub(super) steg: f64,
    pub(super) eps_a: f64,
    pub(super) eps_b: f64,
    pub(super) need_h: bool,
}

/// Lane accumulators of one chunk's evaluation.
pub(super) struct EvalAcc<'s> {
    head: Pieces<V>,
    gvec: &'s mut [V],
    b0: &'s mut [V],
    b1: &'s mut [V],
    /// Lower triangle of H, row by row.
    h: &'s mut [V],
    /// G of the current block.
    g: &'s mut [V],
}

/// Storage of [`EvalAcc`] for `m ≤ 4`, kept in registers by the compiler.
pub(super) struct StaticAcc {
    gvec: [V; MAX_STATIC_M],
    b0: [V; MAX_STATIC_M],
    b1: [V; MAX_STATIC_M],
    h: [V; MAX_STATIC_M * (MAX_STATIC_M + 1) / 2],
    g: [V; MAX_STATIC_M],
}

impl StaticAcc {
    #[inline(always)]
    pub(super) fn new() -> Self {
        let z = V::splat(0.0);
        Self {
            gvec: [z; MAX_STATIC_M],
            b0: [z; MAX_STATIC_M],
            b1: [z; MAX_STATIC_M],
            h: [z; MAX_STATIC_M * (MAX_STATIC_M + 1) / 2],
            g: [z; MAX_STATIC_M],
        }
    }
}

impl<'s> EvalAcc<'s> {
    /// Zeroed accumulators for `m` constraints: in `st` when `M` is static, else in `ln`.
    #[inline(always)]
    pub(super) fn new<const M: usize>(m: usize, st: &'s mut StaticAcc, ln: &'s mut [V]) -> Self {
        let tri = m * (m + 1) / 2;
        let (gvec, b0, b1, h, g) = if M == DYN {
            ln.fill(V::splat(0.0));
            let (gvec, r) = ln.split_at_mut(m);
            let (b0, r) = r.split_at_mut(m);
            let (b1, r) = r.split_at_mut(m);
            let (h, g) = r.split_at_mut(tri);
            (gvec, b0, b1, h, g)
        } else {
            (
                &mut st.gvec[..m],
                &mut st.b0[..m],
                &mut st.b1[..m],
                &mut st.h[..tri],
                &mut st.g[..m],
            )
        };
        Self {
            head: Pieces::splat(V::splat(0.0)),
            gvec,
            b0,
            b1,
            h,
            g,
        }
    }

    /// Horizontal sums into a chunk slot (`reduced_len(m)` entries).
    #[inline(always)]
    pub(super) fn finish(&self, m: usize, a: &mut [f64]) {
        let hd = &self.head;
        a[SUM_X] = hd.sum_x.hsum();
        a[MAX_X] = hd.max_x.hmax(0.0);
        a[SUM_A] = hd.sum_a.hsum();
        a[MAX_A] = hd.max_a.hmax(0.0);
        a[SUM_B] = hd.sum_b.hsum();
        a[MAX_B] = hd.max_b.hmax(0.0);
        let a = &mut a[PIECES..];
        for i in 0..m {
            a[i] = self.gvec[i].hsum();
            a[m + i] = self.b0[i].hsum();
            a[2 * m + i] = self.b1[i].hsum();
            for k in 0..=i {
                a[3 * m + i * m + k] = self.h[i * (i + 1) / 2 + k].hsum();
            }
        }
    }
}

/// [`Terms`] of a block at `(x, ξ, η)` with the multipliers `lam`.
#[inline(always)]
pub(super) fn block_terms(
    nd: Nodes<'_>,
    m: usize,
    lam: &[f64],
    o: usize,
    (x, xsi, eta): (V, V, V),
) -> Terms<V> {
    let (low, upp, alfa, beta) = (
        nd.get(LOW, o),
        nd.get(UPP, o),
        nd.get(ALFA, o),
        nd.get(BETA, o),
    );
    let (plam, qlam) = plam_qlam(nd, m, lam, o);
    terms(low, upp, alfa, beta, plam, qlam, x, xsi, eta)
}

/// `p₀ + λᵀP` and `q₀ + λᵀQ` of a block.
#[inline(always)]
#[allow(clippy::needless_range_loop)]
fn plam_qlam(nd: Nodes<'_>, m: usize, lam: &[f64], o: usize) -> (V, V) {
    let mut plam = nd.get(P0, o);
    let mut qlam = nd.get(Q0, o);
    let lam = &lam[..m];
    for i in 0..m {
        let l = V::splat(lam[i]);
        plam = plam + nd.get(PQ + i, o) * l;
        qlam = qlam + nd.get(PQ + m + i, o) * l;
    }
    (plam, qlam)
}

/// Adds one block's residual pieces and reduced-system terms at `(x, ξ, η)` with the
/// multipliers `ctx.lam` to `acc`.
#[inline(always)]
pub(super) fn eval_block<const MASK: bool>(
    ctx: &EvalCtx<'_>,
    m: usize,
    nd: Nodes<'_>,
    o: usize,
    valid: usize,
    (x, xsi, eta): (V, V, V),
    acc: &mut EvalAcc<'_>,
) {
    let t = block_terms(nd, m, ctx.lam, o, (x, xsi, eta));
    let (alfa, beta) = (nd.get(ALFA, o), nd.get(BETA, o));
    let rex = (t.dpsidx - xsi + eta).keep::<MASK>(valid, 0.0);
    let cx = xsi * (x - alfa);
    let ce = eta * (beta - x);
    let (ea, eb) = (V::splat(ctx.eps_a), V::splat(ctx.eps_b));
    let (ra1, ra2) = (
        (cx - ea).keep::<MASK>(valid, 0.0),
        (ce - ea).keep::<MASK>(valid, 0.0),
    );
    let (rb1, rb2) = (
        (cx - eb).keep::<MASK>(valid, 0.0),
        (ce - eb).keep::<MASK>(valid, 0.0),
    );
    let hd = &mut acc.head;
    hd.sum_x = hd.sum_x + rex * rex;
    hd.max_x = hd.max_x.maxv(rex.absv());
    hd.sum_a = hd.sum_a + (ra1 * ra1 + ra2 * ra2);
    hd.max_a = hd.max_a.maxv(ra1.absv()).maxv(ra2.absv());
    hd.sum_b = hd.sum_b + (rb1 * rb1 + rb2 * rb2);
    hd.max_b = hd.max_b.maxv(rb1.absv()).maxv(rb2.absv());
    let (uxinv, xlinv) = (
        t.uxinv.keep::<MASK>(valid, 0.0),
        t.xlinv.keep::<MASK>(valid, 0.0),
    );
    for i in 0..m {
        let (p, q) = (nd.get(PQ + i, o), nd.get(PQ + m + i, o));
        acc.gvec[i] = acc.gvec[i] + (p * uxinv + q * xlinv);
    }
    if ctx.need_h {
        let dinv = (V::splat(1.0) / t.diagx).keep::<MASK>(valid, 0.0);
        let w0 = t.dpsidx * dinv;
        let w1 = t.e * dinv;
        for i in 0..m {
            let (p, q) = (nd.get(PQ + i, o), nd.get(PQ + m + i, o));
            let gi = p * t.uxinv2 - q * t.xlinv2;
            acc.g[i] = gi;
            acc.b0[i] = acc.b0[i] + gi * w0;
            acc.b1[i] = acc.b1[i] + gi * w1;
            let gd = gi * dinv;
            for k in 0..=i {
                let hk = i * (i + 1) / 2 + k;
                acc.h[hk] = acc.h[hk] + gd * acc.g[k];
            }
        }
    }
}

/// The point `base + steg·Δ` of a block.
#[inline(always)]
pub(super) fn point(st: &[f64], o: usize, steg: f64) -> (V, V, V) {
    let s = V::splat(steg);
    let f = |k: usize| V::load(&st[k * CHUNK..(k + 1) * CHUNK], o);
    (f(X) + s * f(DX), f(XSI) + s * f(DXSI), f(ETA) + s * f(DETA))
}

#[multiversion(targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"))]
fn eval_chunk<'a, const M: usize>(
    ctx: &EvalCtx<'a>,
    c: usize,
    nodes: &[f64],
    st: &[f64],
    a: &mut [f64],
    ln: &mut [V],
) {
    let m = if M == DYN { ctx.m } else { M };
    let nd = Nodes(nodes);
    let mut sacc = StaticAcc::new();
    let mut acc = EvalAcc::new::<M>(m, &mut sacc, ln);
    let (full, tail) = chunk_len(ctx.n, c);
    for b in 0..full {
        let o = b * LANES;
        let p = point(st, o, ctx.steg);
        eval_block::<false>(ctx, m, nd, o, LANES, p, &mut acc);
    }
    if tail > 0 {
        let o = full * LANES;
        let p = point(st, o, ctx.steg);
        eval_block::<true>(ctx, m, nd, o, tail, p, &mut acc);
    }
    acc.finish(m, a);
}
