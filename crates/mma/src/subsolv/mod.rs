//! Primal–dual interior-point solver of the MMA subproblem (`subsolv` of Svanberg's
//! `mmasub.m`, K. Svanberg, *MMA and GCMMA – two methods for nonlinear optimization*, KTH
//! 2007, section 5), restructured for large `n` and small `m`.
//!
//! The algorithm is exactly `subsolv`: the same starting point, the same relaxed KKT system
//! with barrier parameter ε (1, 0.1, … down to `epsimin`), the same Newton directions
//! (the (m+1)×(m+1) reduced system of the note for `m < n`, the (n+1)×(n+1) one otherwise),
//! the same fraction-to-the-boundary factor 1.01 and the same backtracking on the residual
//! norm, so the same steps are accepted. Only the order of the floating-point work differs:
//!
//! * Layout. The subproblem data and the per-variable iterate are chunked
//!   structure-of-arrays ([`crate::subproblem`]).
//! * SIMD. The O(n) passes work on [`LANES`] variables at a time with `[f64; LANES]` values,
//!   accumulate the sums and maxima in per-lane accumulators and reduce the lanes in a fixed
//!   order at the end of each chunk. The chunk kernels are compiled for AVX-512, AVX2 and
//!   plain x86-64 (or any other architecture) and chosen at run time (`multiversion`). No
//!   fused multiply–add is used, so every variant gives bitwise the same results.
//! * Divisions. Each pass forms the reciprocals 1/(u−x), 1/(x−l), 1/(x−α), 1/(β−x) once
//!   per variable and multiplies by them; Δξ, Δη are stored with Δx instead of being
//!   recomputed at every trial point.
//! * Passes. An *evaluation* pass at a trial point `base + t·Δ` computes the residual norm
//!   (for ε and ε/10) and the whole reduced Newton system for the next step (`gvec`,
//!   `Σ GGᵀ/diagx`, and `Σ G·delx/diagx` split into its ε-free and ε-linear parts). A
//!   *direction* pass computes Δx, Δξ, Δη from Δλ and the largest feasible step, and stores
//!   the current point as the new base. The m-dimensional directions (Δy, Δλ, Δμ, Δs, Δz,
//!   Δζ) are known before the direction pass, and so is the step `t_m` they allow; the
//!   direction pass also evaluates the trial point at `t_m` (speculatively). If the
//!   n-dimensional variables allow that step too (the usual case: the step is 1 once a
//!   barrier level is nearly solved, and otherwise mostly limited by y, λ, μ or s), this is
//!   bitwise the first evaluation of the line search and no separate evaluation pass is
//!   needed; otherwise it is discarded and the line search runs as in `subsolv`. Trial
//!   points are never stored: they are recomputed from the base point and Δ, so the line
//!   search only reads.
//! * Threads. The O(n) passes run chunk by chunk (with rayon when `parallel`); each chunk
//!   reduces into its own slot and the slots are summed in order, so the result does not
//!   depend on the number of threads.
//!
//! # One file per operation
//!
//! * this file: the iterate, its start and the barrier loop of `subsolv` (ε = 1, 0.1, …);
//! * [`evaluate`]: the evaluation pass (residual pieces and the reduced Newton system);
//! * [`residual`]: the norm of the relaxed KKT residual;
//! * [`newton`]: the m-dimensional Newton system, solved for (Δλ, Δz), and Δy, Δμ, Δs;
//! * [`direction`]: the direction pass (Δx, Δξ, Δη, step ratio, speculative evaluation);
//! * [`small`]: the (n+1)×(n+1) Newton system used when `n ≤ m`;
//! * [`line_search`]: the backtracking line search on the residual norm;
//! * [`terms`]: the per-variable formulas shared by the passes.

use rayon::prelude::*;

use crate::lanes::{CHUNK, V, min_len};
use crate::subproblem::{ALFA, BETA, DX, ETA, LOW, NSTATE, PQ, SubConsts, UPP, X, XSI};
use evaluate::{dyn_lanes, reduced_len};

/// Newton steps per barrier level before giving up on the level (as in `subsolv`).
const MAX_NEWTON_PER_LEVEL: usize = 200;

/// One chunk of a pass: its index, node block, state block (`S`), slot and lane scratch.
type ChunkItem<'x, S> = (usize, ((&'x [f64], S), (&'x mut [f64], &'x mut [V])));

/// Runs `$kernel` on every chunk of a pass over the [`SubSolver`] `$s`, with rayon when
/// `$s.parallel`; `$state` is `par_chunks` (the pass reads the state) or `par_chunks_mut`
/// (it writes it). Each chunk gets a [`ChunkItem`] and writes only its own slot, which the
/// caller reduces in order afterwards. A macro rather than a method, so that the kernel's
/// context can borrow the other fields of `$s` (λ, Δλ).
macro_rules! for_each_chunk {
    ($s:expr, $state:ident, $kernel:expr) => {
        $s.nodes
            .par_chunks(CHUNK * $s.stride)
            .zip($s.state.$state(CHUNK * NSTATE))
            .zip(
                $s.acc
                    .par_chunks_mut($s.slot)
                    .zip($s.lanes.par_chunks_mut($s.lslot)),
            )
            .enumerate()
            .with_min_len(min_len($s.parallel))
            .for_each($kernel)
    };
}

mod direction;
mod evaluate;
mod line_search;
mod newton;
mod residual;
mod small;
mod terms;

/// Result of one subproblem solve.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SubReport {
    pub iterations: usize,
    pub residual_norm: f64,
}

/// Scratch and iterate of `subsolv`, allocated once for given `(n, m)`.
#[derive(Clone, Debug)]
pub(crate) struct SubSolver {
    pub n: usize,
    pub m: usize,
    /// Fields per variable in `nodes`: `PQ + 2m`.
    pub stride: usize,
    pub parallel: bool,
    /// Chunked records `[low, upp, α, β, p₀, q₀, P₀..P_{m-1}, Q₀..Q_{m-1}]` (see [`idx`]).
    pub nodes: Vec<f64>,
    /// `b` of the subproblem constraints.
    pub b: Vec<f64>,
    /// Chunked per-variable iterate `[x, ξ, η, Δx, Δξ, Δη]` (see [`idx`]).
    pub state: Vec<f64>,
    /// Per-chunk reduction slots.
    pub acc: Vec<f64>,
    pub slot: usize,
    /// Per-chunk lane accumulators for `m > 4`.
    lanes: Vec<V>,
    lslot: usize,
    // m-dimensional iterate.
    pub y: Vec<f64>,
    pub lam: Vec<f64>,
    pub mu: Vec<f64>,
    pub s: Vec<f64>,
    pub z: f64,
    pub zet: f64,
    yo: Vec<f64>,
    lamo: Vec<f64>,
    muo: Vec<f64>,
    so: Vec<f64>,
    dy: Vec<f64>,
    dlam: Vec<f64>,
    dmu: Vec<f64>,
    ds: Vec<f64>,
    /// λ + t·Δλ, the multipliers of the speculative trial point.
    lam1: Vec<f64>,
    // Reduced Newton system pieces.
    gvec: Vec<f64>,
    b0: Vec<f64>,
    b1: Vec<f64>,
    h: Vec<f64>,
    dely: Vec<f64>,
    diagy: Vec<f64>,
    dellam: Vec<f64>,
    diaglamyi: Vec<f64>,
    mat: Vec<f64>,
    rhs: Vec<f64>,
    // Only for n <= m (the (n+1)×(n+1) branch).
    gg: Vec<f64>,
    delx: Vec<f64>,
    diagx: Vec<f64>,
    /// The stored `state` holds the base point; the current point is `base + pending·Δ`.
    pending: f64,
}

impl SubSolver {
    pub(crate) fn new(n: usize, m: usize, parallel: bool) -> Self {
        let stride = PQ + 2 * m;
        let nchunks = n.div_ceil(CHUNK);
        let slot = reduced_len(m) + 1;
        let lslot = dyn_lanes(m);
        let small = n <= m;
        let k = if small { n + 1 } else { m + 1 };
        // Harmless data for the padding of the last chunk (overwritten for j < n).
        let mut nodes = vec![1.0; nchunks * CHUNK * stride];
        for c in 0..nchunks {
            let blk = &mut nodes[c * CHUNK * stride..][..CHUNK * stride];
            blk[LOW * CHUNK..][..CHUNK].fill(-1.0);
            blk[UPP * CHUNK..][..CHUNK].fill(2.0);
            blk[ALFA * CHUNK..][..CHUNK].fill(0.0);
        }
        Self {
            n,
            m,
            stride,
            parallel,
            nodes,
            b: vec![0.0; m],
            state: vec![0.0; nchunks * CHUNK * NSTATE],
            acc: vec![0.0; nchunks * slot],
            slot,
            lanes: vec![V::splat(0.0); nchunks * lslot],
            lslot,
            y: vec![1.0; m],
            lam: vec![1.0; m],
            mu: vec![1.0; m],
            s: vec![1.0; m],
            z: 1.0,
            zet: 1.0,
            yo: vec![0.0; m],
            lamo: vec![0.0; m],
            muo: vec![0.0; m],
            so: vec![0.0; m],
            dy: vec![0.0; m],
            dlam: vec![0.0; m],
            dmu: vec![0.0; m],
            ds: vec![0.0; m],
            lam1: vec![0.0; m],
            gvec: vec![0.0; m],
            b0: vec![0.0; m],
            b1: vec![0.0; m],
            h: vec![0.0; m * m],
            dely: vec![0.0; m],
            diagy: vec![0.0; m],
            dellam: vec![0.0; m],
            diaglamyi: vec![0.0; m],
            mat: vec![0.0; k * k],
            rhs: vec![0.0; k],
            gg: if small { vec![0.0; n * m] } else { Vec::new() },
            delx: if small { vec![0.0; n] } else { Vec::new() },
            diagx: if small { vec![0.0; n] } else { Vec::new() },
            pending: 0.0,
        }
    }

    fn small_branch(&self) -> bool {
        self.n <= self.m
    }

    /// Solves the subproblem whose data is in `nodes` and `b`. On return the fields `X`,
    /// `XSI`, `ETA` of `state` and the m-dimensional fields hold the solution.
    pub(crate) fn solve(&mut self, k: &SubConsts) -> SubReport {
        self.start(k);
        let mut epsi = 1.0f64;
        let need_h = !self.small_branch();
        let mut ev = self.eval(0.0, epsi, need_h);
        let mut itera = 0usize;
        let mut resnorm = f64::NAN;
        while epsi > k.epsimin {
            if ev.eps_a != epsi && ev.eps_b != epsi {
                ev = self.eval(self.pending, epsi, need_h);
            }
            let (mut rn, mut rmax) = self.residual(&ev, epsi, k);
            resnorm = rn;
            let mut ittt = 0;
            while rmax > 0.9 * epsi && ittt < MAX_NEWTON_PER_LEVEL {
                ittt += 1;
                itera += 1;
                let direction = self.newton_direction(epsi, k, need_h);
                (rn, rmax) = self.line_search(&direction, &mut ev, (rn, rmax), epsi, k, need_h);
                resnorm = rn;
            }
            epsi *= 0.1;
        }
        self.materialize();
        SubReport {
            iterations: itera,
            residual_norm: resnorm,
        }
    }

    /// The starting point of `subsolv`: x = (α+β)/2, ξ = max(1/(x−α), 1),
    /// η = max(1/(β−x), 1), y = λ = s = 1, μ = max(1, c/2), z = ζ = 1.
    fn start(&mut self, k: &SubConsts) {
        self.init_state();
        self.y.fill(1.0);
        self.lam.fill(1.0);
        self.mu.fill(1.0f64.max(0.5 * k.c));
        self.s.fill(1.0);
        self.z = 1.0;
        self.zet = 1.0;
        self.pending = 0.0;
    }

    /// `Δz`, stored by the direction functions in the last entry of `rhs`.
    fn rhs_dz(&self) -> f64 {
        self.rhs[self.rhs.len() - 1]
    }

    /// x = (α+β)/2, ξ = max(1/(x−α), 1), η = max(1/(β−x), 1), Δ = 0 (padding included).
    fn init_state(&mut self) {
        let stride = self.stride;
        let nodes = &self.nodes;
        let f = |(nd, st): (&[f64], &mut [f64])| {
            for k in 0..CHUNK {
                let (alfa, beta) = (nd[ALFA * CHUNK + k], nd[BETA * CHUNK + k]);
                let x = 0.5 * (alfa + beta);
                st[X * CHUNK + k] = x;
                st[XSI * CHUNK + k] = (1.0 / (x - alfa)).max(1.0);
                st[ETA * CHUNK + k] = (1.0 / (beta - x)).max(1.0);
            }
            st[DX * CHUNK..].fill(0.0);
        };
        nodes
            .par_chunks(CHUNK * stride)
            .zip(self.state.par_chunks_mut(CHUNK * NSTATE))
            .with_min_len(min_len(self.parallel))
            .for_each(f);
    }

    /// Applies the pending step to the stored base point.
    fn materialize(&mut self) {
        let steg = self.pending;
        if steg == 0.0 {
            return;
        }
        let f = |st: &mut [f64]| {
            let (pt, d) = st.split_at_mut(DX * CHUNK);
            for (p, d) in pt.iter_mut().zip(d.iter()) {
                *p += steg * d;
            }
        };
        self.state
            .par_chunks_mut(CHUNK * NSTATE)
            .with_min_len(min_len(self.parallel))
            .for_each(f);
        self.pending = 0.0;
    }
}
