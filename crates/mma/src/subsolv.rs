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
//! * Layout. The per-variable data of the subproblem (`low`, `upp`, `α`, `β`, `p₀`, `q₀`,
//!   `P`, `Q`) and the per-variable iterate (`x`, `ξ`, `η`, `Δx`, `Δξ`, `Δη`) are stored
//!   structure-of-arrays within fixed chunks of [`CHUNK`] variables: chunk `c` is one block
//!   of the array, holding field `f` at `f·CHUNK..(f+1)·CHUNK` (see [`idx`]). The last
//!   chunk is padded with harmless values that never enter a sum or the step length.
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

use multiversion::multiversion;
use rayon::prelude::*;

use crate::dense::solve_in_place;
use crate::lanes::{CHUNK, DYN, LANES, MAX_STATIC_M, Nodes, Real, V, chunk_len, min_len};

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
const DX: usize = 3;
const DXSI: usize = 4;
const DETA: usize = 5;
/// Number of fields of `state`.
pub(crate) const NSTATE: usize = 6;

/// Newton steps per barrier level before giving up on the level (as in `subsolv`).
const MAX_NEWTON_PER_LEVEL: usize = 200;
/// Halvings of the step in the line search (as in `subsolv`).
const MAX_HALVINGS: usize = 50;

/// Index of field `f` of variable `j` in a chunked array with `nf` fields per variable.
#[inline]
pub(crate) fn idx(j: usize, f: usize, nf: usize) -> usize {
    (j / CHUNK) * CHUNK * nf + f * CHUNK + j % CHUNK
}

/// Number of scalar slots (6 residual pieces, gvec, b0, b1, H) of a reduction.
fn reduced_len(m: usize) -> usize {
    6 + 3 * m + m * m
}

/// Per-chunk lane accumulators needed when `m` is not a compile-time constant: gvec, b0,
/// b1, the lower triangle of H, and G of the current block.
fn dyn_lanes(m: usize) -> usize {
    if m > MAX_STATIC_M {
        4 * m + m * (m + 1) / 2
    } else {
        1
    }
}

/// One chunk of a pass: its index, node block, state block (`S`), slot and lane scratch.
type ChunkItem<'x, S> = (usize, ((&'x [f64], S), (&'x mut [f64], &'x mut [V])));

/// Constants of the artificial variables and the stopping level.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SubConsts {
    pub a0: f64,
    pub a: f64,
    pub c: f64,
    pub d: f64,
    pub epsimin: f64,
}

/// The n-dimensional parts of one residual evaluation.
#[derive(Clone, Copy, Debug)]
struct Eval {
    eps_a: f64,
    eps_b: f64,
    sum_x: f64,
    max_x: f64,
    sum_a: f64,
    max_a: f64,
    sum_b: f64,
    max_b: f64,
}

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
        let m = self.m;
        // Starting point of subsolv.
        self.init_state();
        self.y.fill(1.0);
        self.lam.fill(1.0);
        self.mu.fill(1.0f64.max(0.5 * k.c));
        self.s.fill(1.0);
        self.z = 1.0;
        self.zet = 1.0;
        self.pending = 0.0;

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
                self.newton_prelude(epsi, k);
                // Directions, and whether the direction pass evaluated the full step.
                // Directions, and the step at which the direction pass evaluated the trial
                // point (the step of the m-dimensional variables alone).
                let (stm, speculated) = if self.small_branch() {
                    let stm_n = self.small_direction(epsi, k);
                    (stm_n.max(self.m_directions(epsi)), None)
                } else {
                    self.solve_reduced(epsi, k);
                    let stm_m = self.m_directions(epsi);
                    let steg_m = 1.0 / stm_m.max(1.0);
                    let stm_n = self.direction_pass(epsi, steg_m, need_h);
                    (stm_n.max(stm_m), Some(steg_m))
                };
                let dz = self.rhs_dz();
                let dzet = -self.zet + epsi / self.z - self.zet * dz / self.z;
                let mut steg = 1.0 / stm.max(1.0);

                self.yo.copy_from_slice(&self.y);
                self.lamo.copy_from_slice(&self.lam);
                self.muo.copy_from_slice(&self.mu);
                self.so.copy_from_slice(&self.s);
                let (zo, zeto) = (self.z, self.zet);

                let mut itto = 0;
                let mut resinew = 2.0 * rn;
                let mut accepted = steg;
                while resinew > rn && itto < MAX_HALVINGS {
                    itto += 1;
                    for i in 0..m {
                        self.y[i] = self.yo[i] + steg * self.dy[i];
                        self.lam[i] = self.lamo[i] + steg * self.dlam[i];
                        self.mu[i] = self.muo[i] + steg * self.dmu[i];
                        self.s[i] = self.so[i] + steg * self.ds[i];
                    }
                    self.z = zo + steg * dz;
                    self.zet = zeto + steg * dzet;
                    ev = if itto == 1 && speculated == Some(steg) {
                        // The direction pass evaluated exactly this point: the n-dimensional
                        // variables did not shorten the step.
                        self.reduce_eval(epsi)
                    } else {
                        self.eval(steg, epsi, need_h)
                    };
                    let (n2, mx) = self.residual(&ev, epsi, k);
                    resinew = n2;
                    rmax = mx;
                    accepted = steg;
                    steg /= 2.0;
                }
                self.pending = accepted;
                rn = resinew;
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

    /// `Δz`, stored by the direction functions in the last entry of `rhs`.
    fn rhs_dz(&self) -> f64 {
        self.rhs[self.rhs.len() - 1]
    }

    /// Δy, Δμ, Δs from Δλ (Δz is in `rhs`); returns the largest step ratio of y, λ, μ, s,
    /// z and ζ.
    fn m_directions(&mut self, epsi: f64) -> f64 {
        let mut stm = f64::NEG_INFINITY;
        for i in 0..self.m {
            let dy = (self.dlam[i] - self.dely[i]) / self.diagy[i];
            self.dy[i] = dy;
            self.dmu[i] = -self.mu[i] + epsi / self.y[i] - self.mu[i] * dy / self.y[i];
            self.ds[i] = -self.s[i] + epsi / self.lam[i] - self.s[i] * self.dlam[i] / self.lam[i];
            stm = stm
                .max(-1.01 * dy / self.y[i])
                .max(-1.01 * self.dlam[i] / self.lam[i])
                .max(-1.01 * self.dmu[i] / self.mu[i])
                .max(-1.01 * self.ds[i] / self.s[i]);
        }
        let dz = self.rhs_dz();
        let dzet = -self.zet + epsi / self.z - self.zet * dz / self.z;
        stm.max(-1.01 * dz / self.z).max(-1.01 * dzet / self.zet)
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

    /// Evaluation pass at the point `base + steg·Δ` with the current m-dimensional
    /// variables; fills `gvec` (and `b0`, `b1`, `h` when `need_h`).
    fn eval(&mut self, steg: f64, eps_a: f64, need_h: bool) -> Eval {
        let ctx = EvalCtx {
            n: self.n,
            m: self.m,
            lam: &self.lam,
            steg,
            eps_a,
            eps_b: 0.1 * eps_a,
            need_h,
        };
        let stride = self.stride;
        let lslot = self.lslot;
        let f = |(c, ((nd, st), (a, ln))): ChunkItem<'_, &[f64]>| {
            dispatch_m!(self.m, eval_chunk, &ctx, c, nd, st, a, ln)
        };
        self.nodes
            .par_chunks(CHUNK * stride)
            .zip(self.state.par_chunks(CHUNK * NSTATE))
            .zip(
                self.acc
                    .par_chunks_mut(self.slot)
                    .zip(self.lanes.par_chunks_mut(lslot)),
            )
            .enumerate()
            .with_min_len(min_len(self.parallel))
            .for_each(f);
        self.reduce_eval(eps_a)
    }

    /// Ordered reduction over the chunk slots of an evaluation (by [`Self::eval`] or the
    /// speculative part of [`Self::direction_pass`]).
    fn reduce_eval(&mut self, eps_a: f64) -> Eval {
        let m = self.m;
        let r = reduced_len(m);
        let mut e = Eval {
            eps_a,
            eps_b: 0.1 * eps_a,
            sum_x: 0.0,
            max_x: 0.0,
            sum_a: 0.0,
            max_a: 0.0,
            sum_b: 0.0,
            max_b: 0.0,
        };
        self.gvec.fill(0.0);
        self.b0.fill(0.0);
        self.b1.fill(0.0);
        self.h.fill(0.0);
        for a in self.acc.chunks_exact(self.slot) {
            e.sum_x += a[0];
            e.max_x = e.max_x.max(a[1]);
            e.sum_a += a[2];
            e.max_a = e.max_a.max(a[3]);
            e.sum_b += a[4];
            e.max_b = e.max_b.max(a[5]);
            let a = &a[6..r];
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

    /// Norm and max-norm of the full residual of the relaxed KKT conditions at level `eps`.
    fn residual(&self, ev: &Eval, eps: f64, k: &SubConsts) -> (f64, f64) {
        let (mut sum, mut mx) = (ev.sum_x, ev.max_x);
        if eps == ev.eps_a {
            sum += ev.sum_a;
            mx = mx.max(ev.max_a);
        } else {
            debug_assert_eq!(eps, ev.eps_b);
            sum += ev.sum_b;
            mx = mx.max(ev.max_b);
        }
        let mut alam = 0.0;
        for i in 0..self.m {
            let (y, lam, mu, s) = (self.y[i], self.lam[i], self.mu[i], self.s[i]);
            alam += k.a * lam;
            let rey = k.c + k.d * y - mu - lam;
            let relam = self.gvec[i] - k.a * self.z - y + s - self.b[i];
            let remu = mu * y - eps;
            let res = lam * s - eps;
            for r in [rey, relam, remu, res] {
                sum += r * r;
                mx = mx.max(r.abs());
            }
        }
        let rez = k.a0 - self.zet - alam;
        let rezet = self.zet * self.z - eps;
        for r in [rez, rezet] {
            sum += r * r;
            mx = mx.max(r.abs());
        }
        (sum.sqrt(), mx)
    }

    /// m-dimensional right-hand sides and diagonals of the Newton system.
    fn newton_prelude(&mut self, eps: f64, k: &SubConsts) {
        for i in 0..self.m {
            let (y, lam, mu, s) = (self.y[i], self.lam[i], self.mu[i], self.s[i]);
            self.dely[i] = k.c + k.d * y - lam - eps / y;
            self.dellam[i] = self.gvec[i] - k.a * self.z - y - self.b[i] + eps / lam;
            let diagy = k.d + mu / y;
            self.diagy[i] = diagy;
            self.diaglamyi[i] = s / lam + 1.0 / diagy;
        }
    }

    /// The (m+1)×(m+1) branch (`m < n`): solves for Δλ, Δz (Δz is left in `rhs[m]`).
    fn solve_reduced(&mut self, eps: f64, k: &SubConsts) {
        let m = self.m;
        let kk = m + 1;
        let alam: f64 = self.lam.iter().sum::<f64>() * k.a;
        let delz = k.a0 - alam - eps / self.z;
        for i in 0..m {
            self.rhs[i] =
                self.dellam[i] + self.dely[i] / self.diagy[i] - (self.b0[i] + eps * self.b1[i]);
            for j in 0..=i {
                let v = self.h[i * m + j];
                self.mat[i * kk + j] = v;
                self.mat[j * kk + i] = v;
            }
            self.mat[i * kk + i] += self.diaglamyi[i];
            self.mat[i * kk + m] = k.a;
            self.mat[m * kk + i] = k.a;
        }
        self.mat[m * kk + m] = -self.zet / self.z;
        self.rhs[m] = delz;
        solve_in_place(&mut self.mat, &mut self.rhs, kk);
        self.dlam.copy_from_slice(&self.rhs[..m]);
    }

    /// Direction pass of the (m+1)×(m+1) branch: moves the base point to the current point,
    /// stores Δx, Δξ, Δη there and returns the largest step ratio of the n-dimensional
    /// variables. Also evaluates the trial point `base + t·Δ` with λ + t·Δλ (`t = steg`, the
    /// step allowed by the m-dimensional variables) into the chunk slots, read by
    /// [`Self::reduce_eval`] if the n-dimensional variables allow that step too.
    fn direction_pass(&mut self, eps: f64, steg: f64, need_h: bool) -> f64 {
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
        let stride = self.stride;
        let lslot = self.lslot;
        let f = |(c, ((nd, st), (a, ln))): ChunkItem<'_, &mut [f64]>| {
            dispatch_m!(m, direction_chunk, &ctx, c, nd, st, a, ln)
        };
        self.nodes
            .par_chunks(CHUNK * stride)
            .zip(self.state.par_chunks_mut(CHUNK * NSTATE))
            .zip(
                self.acc
                    .par_chunks_mut(self.slot)
                    .zip(self.lanes.par_chunks_mut(lslot)),
            )
            .enumerate()
            .with_min_len(min_len(self.parallel))
            .for_each(f);
        self.pending = 0.0;
        let r = reduced_len(m);
        self.acc
            .chunks_exact(self.slot)
            .fold(f64::NEG_INFINITY, |acc, a| acc.max(a[r]))
    }

    /// The (n+1)×(n+1) branch (`n <= m`), as in `subsolv`. Serial: n is small here.
    /// Stores Δx, Δξ, Δη and returns the largest step ratio of the n-dimensional variables.
    fn small_direction(&mut self, eps: f64, k: &SubConsts) -> f64 {
        self.materialize();
        let (n, m, st) = (self.n, self.m, self.stride);
        let kk = n + 1;
        let nd = |j: usize, f: usize| self.nodes[idx(j, f, st)];
        for j in 0..n {
            let (x, xsi, eta) = (
                self.state[idx(j, X, NSTATE)],
                self.state[idx(j, XSI, NSTATE)],
                self.state[idx(j, ETA, NSTATE)],
            );
            let (mut plam, mut qlam) = (nd(j, P0), nd(j, Q0));
            for i in 0..m {
                plam += nd(j, PQ + i) * self.lam[i];
                qlam += nd(j, PQ + m + i) * self.lam[i];
            }
            let t = terms(
                nd(j, LOW),
                nd(j, UPP),
                nd(j, ALFA),
                nd(j, BETA),
                plam,
                qlam,
                x,
                xsi,
                eta,
            );
            for i in 0..m {
                self.gg[j * m + i] = nd(j, PQ + i) * t.uxinv2 - nd(j, PQ + m + i) * t.xlinv2;
            }
            self.delx[j] = t.dpsidx + eps * t.e;
            self.diagx[j] = t.diagx;
        }
        let alam: f64 = self.lam.iter().sum::<f64>() * k.a;
        let delz = k.a0 - alam - eps / self.z;
        // dellamyi / diaglamyi, stored temporarily in dy.
        for i in 0..m {
            self.dy[i] = (self.dellam[i] + self.dely[i] / self.diagy[i]) / self.diaglamyi[i];
        }
        let mut azz = self.zet / self.z;
        let mut bz = delz;
        for i in 0..m {
            azz += k.a * k.a / self.diaglamyi[i];
            bz -= k.a * self.dy[i];
        }
        for j in 0..n {
            for l in 0..=j {
                let mut v = 0.0;
                for i in 0..m {
                    v += self.gg[j * m + i] * self.gg[l * m + i] / self.diaglamyi[i];
                }
                self.mat[j * kk + l] = v;
                self.mat[l * kk + j] = v;
            }
            self.mat[j * kk + j] += self.diagx[j];
            let mut axz = 0.0;
            let mut bx = self.delx[j];
            for i in 0..m {
                axz -= self.gg[j * m + i] * k.a / self.diaglamyi[i];
                bx += self.gg[j * m + i] * self.dy[i];
            }
            self.mat[j * kk + n] = axz;
            self.mat[n * kk + j] = axz;
            self.rhs[j] = -bx;
        }
        self.mat[n * kk + n] = azz;
        self.rhs[n] = -bz;
        solve_in_place(&mut self.mat, &mut self.rhs, kk);
        let dz = self.rhs[n];
        for i in 0..m {
            let mut gdx = 0.0;
            for j in 0..n {
                gdx += self.gg[j * m + i] * self.rhs[j];
            }
            self.dlam[i] = gdx / self.diaglamyi[i] - dz * k.a / self.diaglamyi[i] + self.dy[i];
        }
        let mut stm = f64::NEG_INFINITY;
        for j in 0..n {
            let dx = self.rhs[j];
            let (alfa, beta) = (self.nodes[idx(j, ALFA, st)], self.nodes[idx(j, BETA, st)]);
            let (x, xsi, eta) = (
                self.state[idx(j, X, NSTATE)],
                self.state[idx(j, XSI, NSTATE)],
                self.state[idx(j, ETA, NSTATE)],
            );
            let xainv = 1.0 / (x - alfa);
            let bxinv = 1.0 / (beta - x);
            let d = step(xsi, eta, dx, xainv, bxinv, eps);
            self.state[idx(j, DX, NSTATE)] = dx;
            self.state[idx(j, DXSI, NSTATE)] = d.dxsi;
            self.state[idx(j, DETA, NSTATE)] = d.deta;
            stm = stm.max(d.ratio);
        }
        stm
    }
}

// ---------------------------------------------------------------------------------------
// Per-variable formulas (Svanberg 2007, section 5: the relaxed KKT conditions and the
// reduced Newton system), written once for f64 and for lanes.

/// Quantities of one variable at a point, shared by the passes.
#[derive(Clone, Copy)]
struct Terms<T> {
    uxinv: T,
    xlinv: T,
    uxinv2: T,
    xlinv2: T,
    /// 1/(x−α), 1/(β−x).
    xainv: T,
    bxinv: T,
    /// ∂ψ/∂x = (p₀ + λᵀP)/(u−x)² − (q₀ + λᵀQ)/(x−l)².
    dpsidx: T,
    /// ∂²ψ/∂x² + ξ/(x−α) + η/(β−x).
    diagx: T,
    /// 1/(β−x) − 1/(x−α): `delx = dpsidx + ε·e`.
    e: T,
}

/// [`Terms`] at `(x, ξ, η)`, with `plam = p₀ + λᵀP`, `qlam = q₀ + λᵀQ`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn terms<T: Real>(
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
struct Step<T> {
    dxsi: T,
    deta: T,
    /// Largest ratio `-1.01·Δv/v` over x−α, β−x, ξ, η (the step is `1/max(ratio, 1)`).
    ratio: T,
}

/// Δξ = −ξ + ε/(x−α) − ξΔx/(x−α), Δη = −η + ε/(β−x) + ηΔx/(β−x), and the step ratio.
#[inline(always)]
fn step<T: Real>(xsi: T, eta: T, dx: T, xainv: T, bxinv: T, eps: f64) -> Step<T> {
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

// ---------------------------------------------------------------------------------------
// Chunk kernels.

struct EvalCtx<'a> {
    n: usize,
    m: usize,
    lam: &'a [f64],
    /// The point is `base + steg·Δ`.
    steg: f64,
    eps_a: f64,
    eps_b: f64,
    need_h: bool,
}

/// Lane accumulators of one chunk's evaluation.
struct EvalAcc<'s> {
    head: [V; 6],
    gvec: &'s mut [V],
    b0: &'s mut [V],
    b1: &'s mut [V],
    /// Lower triangle of H, row by row.
    h: &'s mut [V],
    /// G of the current block.
    g: &'s mut [V],
}

/// Storage of [`EvalAcc`] for `m ≤ 4`, kept in registers by the compiler.
struct StaticAcc {
    gvec: [V; MAX_STATIC_M],
    b0: [V; MAX_STATIC_M],
    b1: [V; MAX_STATIC_M],
    h: [V; MAX_STATIC_M * (MAX_STATIC_M + 1) / 2],
    g: [V; MAX_STATIC_M],
}

impl StaticAcc {
    #[inline(always)]
    fn new() -> Self {
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
    fn new<const M: usize>(m: usize, st: &'s mut StaticAcc, ln: &'s mut [V]) -> Self {
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
            head: [V::splat(0.0); 6],
            gvec,
            b0,
            b1,
            h,
            g,
        }
    }

    /// Horizontal sums into a chunk slot (`reduced_len(m)` entries).
    #[inline(always)]
    fn finish(&self, m: usize, a: &mut [f64]) {
        a[0] = self.head[0].hsum();
        a[1] = self.head[1].hmax(0.0);
        a[2] = self.head[2].hsum();
        a[3] = self.head[3].hmax(0.0);
        a[4] = self.head[4].hsum();
        a[5] = self.head[5].hmax(0.0);
        let a = &mut a[6..];
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
fn eval_block<const MASK: bool>(
    ctx: &EvalCtx<'_>,
    m: usize,
    nd: Nodes<'_>,
    o: usize,
    valid: usize,
    (x, xsi, eta): (V, V, V),
    acc: &mut EvalAcc<'_>,
) {
    let (low, upp, alfa, beta) = (
        nd.get(LOW, o),
        nd.get(UPP, o),
        nd.get(ALFA, o),
        nd.get(BETA, o),
    );
    let (plam, qlam) = plam_qlam(nd, m, ctx.lam, o);
    let t = terms(low, upp, alfa, beta, plam, qlam, x, xsi, eta);
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
    hd[0] = hd[0] + rex * rex;
    hd[1] = hd[1].maxv(rex.absv());
    hd[2] = hd[2] + (ra1 * ra1 + ra2 * ra2);
    hd[3] = hd[3].maxv(ra1.absv()).maxv(ra2.absv());
    hd[4] = hd[4] + (rb1 * rb1 + rb2 * rb2);
    hd[5] = hd[5].maxv(rb1.absv()).maxv(rb2.absv());
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
fn point(st: &[f64], o: usize, steg: f64) -> (V, V, V) {
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
    let (low, upp, alfa, beta) = (
        nd.get(LOW, o),
        nd.get(UPP, o),
        nd.get(ALFA, o),
        nd.get(BETA, o),
    );
    let (plam, qlam) = plam_qlam(nd, m, ctx.lam, o);
    let t = terms(low, upp, alfa, beta, plam, qlam, x, xsi, eta);
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
