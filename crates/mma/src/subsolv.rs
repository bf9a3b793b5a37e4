//! Primal–dual interior-point solver of the MMA subproblem (`subsolv` of Svanberg's
//! `mmasub.m`), restructured for large `n` and small `m`.
//!
//! The algorithm is exactly `subsolv`: the same starting point, the same relaxed KKT system
//! with barrier parameter ε (1, 0.1, … down to `epsimin`), the same Newton directions, the
//! same fraction-to-the-boundary factor 1.01 and the same backtracking on the residual norm.
//! Only the order of the floating-point work differs:
//!
//! * The per-variable data of the subproblem (`low`, `upp`, `α`, `β`, `p₀`, `q₀`, `P`, `Q`) is
//!   stored variable-major in one array (`nodes`), and the per-variable iterate
//!   (`x`, `ξ`, `η`, `Δx`) in another (`state`), so that every O(n) pass streams two arrays.
//! * One *evaluation* pass at a trial point computes the residual norm (for ε and ε/10) and
//!   the whole reduced Newton system for the next step (`gvec`, `Σ GGᵀ/diagx`, and
//!   `Σ G·delx/diagx` split into its ε-free and ε-linear parts). A second *direction* pass
//!   computes Δx from Δλ and the largest feasible step. Trial points `x + t·Δx` are never
//!   stored: they are recomputed from the base point and Δx, so the line search only reads.
//! * The O(n) passes are split in fixed chunks; each chunk reduces into its own slot and the
//!   slots are summed in order, so the result does not depend on the number of threads.

use rayon::prelude::*;

use crate::dense::solve_in_place;

/// Calls `$func::<M>(args)` with `M` the compile-time value of `m` for m ≤ 4, so that the
/// inner loops over the constraints are unrolled, and with `M = DYN` otherwise.
macro_rules! dispatch_m {
    ($m:expr, $func:ident, $($arg:expr),*) => {
        match $m {
            0 => $func::<0>($($arg),*),
            1 => $func::<1>($($arg),*),
            2 => $func::<2>($($arg),*),
            3 => $func::<3>($($arg),*),
            4 => $func::<4>($($arg),*),
            _ => $func::<DYN>($($arg),*),
        }
    };
}

/// Variables per chunk of the O(n) passes.
pub(crate) const CHUNK: usize = 4096;
/// Marker for "m not known at compile time".
const DYN: usize = usize::MAX;

/// Offsets inside one variable's record of `nodes`.
pub(crate) const LOW: usize = 0;
pub(crate) const UPP: usize = 1;
pub(crate) const ALFA: usize = 2;
pub(crate) const BETA: usize = 3;
pub(crate) const P0: usize = 4;
pub(crate) const Q0: usize = 5;
/// `P[i]` is at `PQ + i`, `Q[i]` at `PQ + m + i`.
pub(crate) const PQ: usize = 6;

/// Newton steps per barrier level before giving up on the level (as in `subsolv`).
const MAX_NEWTON_PER_LEVEL: usize = 200;
/// Halvings of the step in the line search (as in `subsolv`).
const MAX_HALVINGS: usize = 50;

/// Number of scalar slots (6 residual pieces, gvec, b0, b1, H) before the scratch area.
fn reduced_len(m: usize) -> usize {
    6 + 3 * m + m * m
}

/// Per-variable iterate of the interior-point method.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct XState {
    pub x: f64,
    pub xsi: f64,
    pub eta: f64,
    pub dx: f64,
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
    pub stride: usize,
    pub parallel: bool,
    /// Variable-major records `[low, upp, α, β, p₀, q₀, P₀..P_{m-1}, Q₀..Q_{m-1}]`.
    pub nodes: Vec<f64>,
    /// `b` of the subproblem constraints.
    pub b: Vec<f64>,
    pub state: Vec<XState>,
    /// Per-chunk reduction slots.
    pub acc: Vec<f64>,
    pub slot: usize,
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
    /// The stored `state` is the base point; the current point is
    /// `base + steg·Δ(eps)` with `(steg, eps) = pending`.
    pending: (f64, f64),
}

impl SubSolver {
    pub(crate) fn new(n: usize, m: usize, parallel: bool) -> Self {
        let stride = PQ + 2 * m;
        let nchunks = n.div_ceil(CHUNK);
        let slot = reduced_len(m) + m;
        let small = n <= m;
        let k = if small { n + 1 } else { m + 1 };
        Self {
            n,
            m,
            stride,
            parallel,
            nodes: vec![0.0; n * stride],
            b: vec![0.0; m],
            state: vec![XState::default(); n],
            acc: vec![0.0; nchunks * slot],
            slot,
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
            pending: (0.0, 1.0),
        }
    }

    fn small_branch(&self) -> bool {
        self.n <= self.m
    }

    /// Solves the subproblem whose data is in `nodes` and `b`. On return `state[j].x`,
    /// `.xsi`, `.eta` and the m-dimensional fields hold the solution.
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
        self.pending = (0.0, 1.0);

        let mut epsi = 1.0f64;
        let need_h = !self.small_branch();
        let mut ev = self.eval(0.0, 1.0, epsi, need_h);
        let mut itera = 0usize;
        let mut resnorm = f64::NAN;
        while epsi > k.epsimin {
            if ev.eps_a != epsi && ev.eps_b != epsi {
                let (st, ep) = self.pending;
                ev = self.eval(st, ep, epsi, need_h);
            }
            let (mut rn, mut rmax) = self.residual(&ev, epsi, k);
            resnorm = rn;
            let mut ittt = 0;
            while rmax > 0.9 * epsi && ittt < MAX_NEWTON_PER_LEVEL {
                ittt += 1;
                itera += 1;
                self.newton_prelude(epsi, k);
                let stm_n = if self.small_branch() {
                    self.small_direction(epsi, k)
                } else {
                    self.large_direction(epsi, k)
                };
                // Directions of the m-dimensional variables and the step length.
                let mut stm = stm_n;
                for i in 0..m {
                    let dy = (self.dlam[i] - self.dely[i]) / self.diagy[i];
                    self.dy[i] = dy;
                    self.dmu[i] = -self.mu[i] + epsi / self.y[i] - self.mu[i] * dy / self.y[i];
                    self.ds[i] =
                        -self.s[i] + epsi / self.lam[i] - self.s[i] * self.dlam[i] / self.lam[i];
                    stm = stm
                        .max(-1.01 * dy / self.y[i])
                        .max(-1.01 * self.dlam[i] / self.lam[i])
                        .max(-1.01 * self.dmu[i] / self.mu[i])
                        .max(-1.01 * self.ds[i] / self.s[i]);
                }
                let dz = self.rhs_dz();
                let dzet = -self.zet + epsi / self.z - self.zet * dz / self.z;
                stm = stm.max(-1.01 * dz / self.z).max(-1.01 * dzet / self.zet);
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
                    ev = self.eval(steg, epsi, epsi, need_h);
                    let (n2, mx) = self.residual(&ev, epsi, k);
                    resinew = n2;
                    rmax = mx;
                    accepted = steg;
                    steg /= 2.0;
                }
                self.pending = (accepted, epsi);
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

    /// x = (α+β)/2, ξ = max(1/(x−α), 1), η = max(1/(β−x), 1).
    fn init_state(&mut self) {
        let stride = self.stride;
        let nodes = &self.nodes;
        let f = |(c, st): (usize, &mut [XState])| {
            let start = c * CHUNK;
            for (k, s) in st.iter_mut().enumerate() {
                let nd = &nodes[(start + k) * stride..];
                let (alfa, beta) = (nd[ALFA], nd[BETA]);
                let x = 0.5 * (alfa + beta);
                *s = XState {
                    x,
                    xsi: (1.0 / (x - alfa)).max(1.0),
                    eta: (1.0 / (beta - x)).max(1.0),
                    dx: 0.0,
                };
            }
        };
        if self.parallel {
            self.state.par_chunks_mut(CHUNK).enumerate().for_each(f);
        } else {
            self.state.chunks_mut(CHUNK).enumerate().for_each(f);
        }
    }

    /// Applies the pending step to the stored base point.
    fn materialize(&mut self) {
        let (steg, eps) = self.pending;
        if steg == 0.0 {
            return;
        }
        let stride = self.stride;
        let nodes = &self.nodes;
        let f = |(c, st): (usize, &mut [XState])| {
            let start = c * CHUNK;
            for (k, s) in st.iter_mut().enumerate() {
                let nd = &nodes[(start + k) * stride..];
                let (x, xsi, eta) = trial(s, nd[ALFA], nd[BETA], steg, eps);
                *s = XState {
                    x,
                    xsi,
                    eta,
                    dx: 0.0,
                };
            }
        };
        if self.parallel {
            self.state.par_chunks_mut(CHUNK).enumerate().for_each(f);
        } else {
            self.state.chunks_mut(CHUNK).enumerate().for_each(f);
        }
        self.pending = (0.0, eps);
    }

    /// Evaluation pass at the point `base + steg·Δ(eps_dir)` with the current m-dimensional
    /// variables; fills `gvec` (and `b0`, `b1`, `h` when `need_h`).
    fn eval(&mut self, steg: f64, eps_dir: f64, eps_a: f64, need_h: bool) -> Eval {
        let eps_b = 0.1 * eps_a;
        let ctx = EvalCtx {
            n: self.n,
            m: self.m,
            stride: self.stride,
            nodes: &self.nodes,
            state: &self.state,
            lam: &self.lam,
            steg,
            eps_dir,
            eps_a,
            eps_b,
            need_h,
        };
        dispatch_m!(
            self.m,
            eval_pass,
            &ctx,
            &mut self.acc,
            self.slot,
            self.parallel
        );
        // Ordered reduction over chunks.
        let m = self.m;
        let r = reduced_len(m);
        let mut e = Eval {
            eps_a,
            eps_b,
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

    /// The (m+1)×(m+1) branch (`m < n`): solves for Δλ, Δz, then the direction pass gives
    /// Δx. Returns the largest step ratio of the n-dimensional variables.
    fn large_direction(&mut self, eps: f64, k: &SubConsts) -> f64 {
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

        let (steg_p, eps_p) = self.pending;
        let ctx = DirCtx {
            m,
            stride: self.stride,
            nodes: &self.nodes,
            lam: &self.lam,
            dlam: &self.dlam,
            eps,
            steg_p,
            eps_p,
        };
        dispatch_m!(
            m,
            direction_pass,
            &ctx,
            &mut self.state,
            &mut self.acc,
            self.slot,
            self.parallel
        );
        self.pending = (0.0, eps);
        self.acc
            .chunks_exact(self.slot)
            .fold(f64::NEG_INFINITY, |acc, a| acc.max(a[0]))
    }

    /// The (n+1)×(n+1) branch (`n <= m`), as in `subsolv`. Serial: n is small here.
    fn small_direction(&mut self, eps: f64, k: &SubConsts) -> f64 {
        self.materialize();
        let (n, m) = (self.n, self.m);
        let kk = n + 1;
        for j in 0..n {
            let nd = &self.nodes[j * self.stride..(j + 1) * self.stride];
            let s = self.state[j];
            let t = Terms::new(nd, m, &self.lam, s.x, s.xsi, s.eta);
            for i in 0..m {
                self.gg[j * m + i] = nd[PQ + i] * t.uxinv2 - nd[PQ + m + i] * t.xlinv2;
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
            let nd = &self.nodes[j * self.stride..];
            let s = &mut self.state[j];
            s.dx = dx;
            stm = stm.max(step_ratio(s.x, s.xsi, s.eta, dx, nd[ALFA], nd[BETA], eps));
        }
        stm
    }
}

/// Trial point `base + steg·Δ`, where Δξ, Δη follow from Δx at the base point and level `eps`.
#[inline(always)]
fn trial(s: &XState, alfa: f64, beta: f64, steg: f64, eps: f64) -> (f64, f64, f64) {
    if steg == 0.0 {
        return (s.x, s.xsi, s.eta);
    }
    let xa = s.x - alfa;
    let bx = beta - s.x;
    let dxsi = -s.xsi + eps / xa - s.xsi * s.dx / xa;
    let deta = -s.eta + eps / bx + s.eta * s.dx / bx;
    (s.x + steg * s.dx, s.xsi + steg * dxsi, s.eta + steg * deta)
}

/// Largest ratio `-1.01·Δv/v` over x−α, β−x, ξ, η (the step is `1/max(ratio, 1)`).
#[inline(always)]
fn step_ratio(x: f64, xsi: f64, eta: f64, dx: f64, alfa: f64, beta: f64, eps: f64) -> f64 {
    let xa = x - alfa;
    let bx = beta - x;
    let dxsi = -xsi + eps / xa - xsi * dx / xa;
    let deta = -eta + eps / bx + eta * dx / bx;
    (-1.01 * dx / xa)
        .max(1.01 * dx / bx)
        .max(-1.01 * dxsi / xsi)
        .max(-1.01 * deta / eta)
}

/// Quantities of one variable at a point, shared by the passes.
struct Terms {
    uxinv: f64,
    xlinv: f64,
    uxinv2: f64,
    xlinv2: f64,
    dpsidx: f64,
    /// ∂²ψ/∂x² + ξ/(x−α) + η/(β−x).
    diagx: f64,
    /// 1/(β−x) − 1/(x−α): `delx = dpsidx + ε·e`.
    e: f64,
}

impl Terms {
    #[inline(always)]
    fn new(nd: &[f64], m: usize, lam: &[f64], x: f64, xsi: f64, eta: f64) -> Self {
        let uxinv = 1.0 / (nd[UPP] - x);
        let xlinv = 1.0 / (x - nd[LOW]);
        let uxinv2 = uxinv * uxinv;
        let xlinv2 = xlinv * xlinv;
        let mut plam = nd[P0];
        let mut qlam = nd[Q0];
        for i in 0..m {
            plam += nd[PQ + i] * lam[i];
            qlam += nd[PQ + m + i] * lam[i];
        }
        let xainv = 1.0 / (x - nd[ALFA]);
        let bxinv = 1.0 / (nd[BETA] - x);
        Self {
            uxinv,
            xlinv,
            uxinv2,
            xlinv2,
            dpsidx: plam * uxinv2 - qlam * xlinv2,
            diagx: 2.0 * (plam * uxinv2 * uxinv + qlam * xlinv2 * xlinv)
                + xsi * xainv
                + eta * bxinv,
            e: bxinv - xainv,
        }
    }
}

struct EvalCtx<'a> {
    n: usize,
    m: usize,
    stride: usize,
    nodes: &'a [f64],
    state: &'a [XState],
    lam: &'a [f64],
    steg: f64,
    eps_dir: f64,
    eps_a: f64,
    eps_b: f64,
    need_h: bool,
}

fn eval_pass<const M: usize>(ctx: &EvalCtx<'_>, acc: &mut [f64], slot: usize, parallel: bool) {
    let f = |(c, a): (usize, &mut [f64])| eval_chunk::<M>(ctx, c, a);
    if parallel {
        acc.par_chunks_mut(slot).enumerate().for_each(f);
    } else {
        acc.chunks_mut(slot).enumerate().for_each(f);
    }
}

#[inline(always)]
fn eval_chunk<const M: usize>(ctx: &EvalCtx<'_>, c: usize, a: &mut [f64]) {
    let m = if M == DYN { ctx.m } else { M };
    let stride = if M == DYN { ctx.stride } else { PQ + 2 * M };
    let start = c * CHUNK;
    let end = (start + CHUNK).min(ctx.n);
    let nodes = &ctx.nodes[start * stride..end * stride];
    let states = &ctx.state[start..end];
    let lam = &ctx.lam[..m];
    let r = reduced_len(m);
    let (red, scratch) = a.split_at_mut(r);
    red.fill(0.0);
    let (head, rest) = red.split_at_mut(6);
    let (gvec, rest) = rest.split_at_mut(m);
    let (b0, rest) = rest.split_at_mut(m);
    let (b1, h) = rest.split_at_mut(m);
    let g = &mut scratch[..m];
    let (eps_a, eps_b) = (ctx.eps_a, ctx.eps_b);
    let (mut sx, mut mx, mut sa, mut ma, mut sb, mut mb) =
        (0.0f64, 0.0f64, 0.0, 0.0f64, 0.0, 0.0f64);
    for (nd, s) in nodes.chunks_exact(stride).zip(states) {
        let (alfa, beta) = (nd[ALFA], nd[BETA]);
        let (x, xsi, eta) = trial(s, alfa, beta, ctx.steg, ctx.eps_dir);
        let t = Terms::new(nd, m, lam, x, xsi, eta);
        let rex = t.dpsidx - xsi + eta;
        sx += rex * rex;
        mx = mx.max(rex.abs());
        let cx = xsi * (x - alfa);
        let ce = eta * (beta - x);
        let (r1, r2) = (cx - eps_a, ce - eps_a);
        sa += r1 * r1 + r2 * r2;
        ma = ma.max(r1.abs()).max(r2.abs());
        let (r1, r2) = (cx - eps_b, ce - eps_b);
        sb += r1 * r1 + r2 * r2;
        mb = mb.max(r1.abs()).max(r2.abs());
        let p = &nd[PQ..PQ + m];
        let q = &nd[PQ + m..PQ + 2 * m];
        for i in 0..m {
            gvec[i] += p[i] * t.uxinv + q[i] * t.xlinv;
        }
        if ctx.need_h {
            let dinv = 1.0 / t.diagx;
            let w0 = t.dpsidx * dinv;
            let w1 = t.e * dinv;
            for i in 0..m {
                let gi = p[i] * t.uxinv2 - q[i] * t.xlinv2;
                g[i] = gi;
                b0[i] += gi * w0;
                b1[i] += gi * w1;
                let gd = gi * dinv;
                for k in 0..=i {
                    h[i * m + k] += gd * g[k];
                }
            }
        }
    }
    head.copy_from_slice(&[sx, mx, sa, ma, sb, mb]);
}

struct DirCtx<'a> {
    m: usize,
    stride: usize,
    nodes: &'a [f64],
    lam: &'a [f64],
    dlam: &'a [f64],
    eps: f64,
    steg_p: f64,
    eps_p: f64,
}

fn direction_pass<const M: usize>(
    ctx: &DirCtx<'_>,
    state: &mut [XState],
    acc: &mut [f64],
    slot: usize,
    parallel: bool,
) {
    let f =
        |(c, (st, a)): (usize, (&mut [XState], &mut [f64]))| direction_chunk::<M>(ctx, c, st, a);
    if parallel {
        state
            .par_chunks_mut(CHUNK)
            .zip(acc.par_chunks_mut(slot))
            .enumerate()
            .for_each(f);
    } else {
        state
            .chunks_mut(CHUNK)
            .zip(acc.chunks_mut(slot))
            .enumerate()
            .for_each(f);
    }
}

#[inline(always)]
fn direction_chunk<const M: usize>(ctx: &DirCtx<'_>, c: usize, st: &mut [XState], a: &mut [f64]) {
    let m = if M == DYN { ctx.m } else { M };
    let stride = if M == DYN { ctx.stride } else { PQ + 2 * M };
    let start = c * CHUNK;
    let nodes = &ctx.nodes[start * stride..(start + st.len()) * stride];
    let lam = &ctx.lam[..m];
    let dlam = &ctx.dlam[..m];
    let eps = ctx.eps;
    let mut stm = f64::NEG_INFINITY;
    for (nd, s) in nodes.chunks_exact(stride).zip(st.iter_mut()) {
        let (alfa, beta) = (nd[ALFA], nd[BETA]);
        let (x, xsi, eta) = trial(s, alfa, beta, ctx.steg_p, ctx.eps_p);
        let t = Terms::new(nd, m, lam, x, xsi, eta);
        let mut rhs = t.dpsidx + eps * t.e;
        for i in 0..m {
            rhs += (nd[PQ + i] * t.uxinv2 - nd[PQ + m + i] * t.xlinv2) * dlam[i];
        }
        let dx = -rhs / t.diagx;
        *s = XState { x, xsi, eta, dx };
        stm = stm.max(step_ratio(x, xsi, eta, dx, alfa, beta, eps));
    }
    a[0] = stm;
}
