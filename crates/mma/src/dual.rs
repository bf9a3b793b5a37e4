//! Dual interior-point solver of the MMA subproblem, for large `n` and small `m`.
//!
//! The MMA subproblem is convex and separable, so its Lagrangian dual (Svanberg 1987,
//! section 4) is a concave problem in the m multipliers λ alone:
//!
//! ```text
//! maximize  W(λ) = Σⱼ min_{αⱼ≤xⱼ≤βⱼ} ( pⱼ(λ)/(uⱼ−xⱼ) + qⱼ(λ)/(xⱼ−lⱼ) )
//!                  + Σᵢ min_{yᵢ≥0} ( cᵢyᵢ + ½dᵢyᵢ² − λᵢyᵢ ) − λᵀb
//! subject to λ ≥ 0,  aᵀλ ≤ a₀ (when a ≠ 0),  λᵢ ≤ cᵢ (when dᵢ = 0),
//! ```
//!
//! with `pⱼ(λ) = p₀ⱼ + Σᵢ λᵢ pᵢⱼ`, `qⱼ(λ) = q₀ⱼ + Σᵢ λᵢ qᵢⱼ`. The inner minimizations
//! have closed forms:
//!
//! ```text
//! xⱼ(λ) = clamp( (lⱼ √pⱼ + uⱼ √qⱼ) / (√pⱼ + √qⱼ), αⱼ, βⱼ ),    yᵢ(λ) = max(0, (λᵢ − cᵢ)/dᵢ),
//! ∂W/∂λᵢ  = gᵢ(x(λ)) − yᵢ − bᵢ,      gᵢ(x) = Σⱼ ( pᵢⱼ/(uⱼ−xⱼ) + qᵢⱼ/(xⱼ−lⱼ) ),
//! ∂²W/∂λᵢ∂λₖ = −Σ_{j free} Gᵢⱼ Gₖⱼ / ψ''ⱼ − [yᵢ > 0] δᵢₖ / dᵢ,
//! Gᵢⱼ = pᵢⱼ/(uⱼ−xⱼ)² − qᵢⱼ/(xⱼ−lⱼ)²,   ψ''ⱼ = 2pⱼ/(uⱼ−xⱼ)³ + 2qⱼ/(xⱼ−lⱼ)³,
//! ```
//!
//! (`j` free when `αⱼ < xⱼ < βⱼ`; W is C¹ and piecewise C²). The dual is solved by a
//! primal–dual interior-point method on the few constraints of λ, written `A λ ≤ ā` with
//! slacks `s = ā − Aλ` and multipliers `ν ≥ 0`: Newton's method on `∇W − Aᵀν = 0`,
//! `s ∘ ν = t`, i.e.
//!
//! ```text
//! (−∇²W + Aᵀ diag(ν/s) A) Δλ = ∇W − Aᵀ(t/s),   Δs = −A Δλ,   Δν = (t − s∘ν − ν∘Δs)/s,
//! ```
//!
//! with Mehrotra's predictor–corrector choice of the target `t` (predictor `t = 0`, then
//! `t = σ·sᵀν/k − Δs_aff∘Δν_aff` with `σ = (gap_aff/gap)³`) and a step of 0.99 of the way to
//! the boundary. This is the dual interior-point approach of the PETSc topology optimization
//! framework (N. Aage, E. Andreassen, B. S. Lazarov, *Topology optimization using PETSc*,
//! Struct. Multidisc. Optim. 51 (2015) 565–572), with the predictor–corrector target instead
//! of a fixed barrier schedule.
//!
//! Why it is fast for large `n`: every quantity of the interior-point method is
//! m-dimensional. One Newton step needs ∇W and ∇²W at one λ, i.e. one read-only pass over
//! the n variables; there is no n-dimensional iterate to store, and the pass recomputes the
//! p/q coefficients from the gradients instead of reading stored copies (72 bytes per
//! variable for m = 3 against 192 read and written per Newton step by `subsolv`).
//!
//! The term of y is written with an extra unknown wᵢ per constraint (when d > 0):
//! `min_y (c − λ)y + ½dy² = max_w { −wᵢ²/(2d) : wᵢ ≥ λᵢ − c }`, so that the kink of W at
//! λᵢ = c becomes a linear constraint of the interior-point method (its multiplier is yᵢ)
//! instead of a jump in Newton's model; without `w ≥ 0` the problem stays non-degenerate
//! when y = 0.
//!
//! Warm start: from the second update on, the solve starts from the previous subproblem's
//! multipliers (λ, y, s, z — the ones saved in `MmaState`, so a restored optimizer repeats
//! the same steps) moved `1e-3` into the interior; once the active constraints settle this
//! takes 2–3 Newton steps. A warm start that has not converged after 20 steps is abandoned
//! for the cold start λ = 1.
//!
//! Stopping: `max(‖∇W − Aᵀν‖∞, max sᵢνᵢ) ≤ epsimin`, the measure of `subsolv` at its last
//! barrier level. The solution is then the exact minimizer `x(λ)` of the Lagrangian for the
//! final λ, and the multipliers of `subsolv` follow from λ and ν (see
//! [`DualSolver::multipliers`]). If the method fails (no convergence in `MAX_STEPS` steps,
//! a non-finite value, or `c = d = 0`, which leaves the dual no interior), the caller falls
//! back to `subsolv`.

use multiversion::multiversion;
use rayon::prelude::*;

use crate::dense::solve_in_place;
use crate::lanes::{CHUNK, DYN, LANES, MAX_STATIC_M, Nodes, Real, V, chunk_len, min_len};
use crate::subproblem::{ALFA, BETA, LOW, SubConsts, UPP};

/// Newton steps after which the dual solver gives up.
const MAX_STEPS: usize = 100;
/// Newton steps after which a warm start is abandoned for a cold one.
const MAX_WARM_STEPS: usize = 20;
/// How far (in λ, w and the complementarity products) a warm start is moved into the
/// interior.
const WARM_DISTANCE: f64 = 1e-3;
/// Fraction of the distance to the boundary of `s ≥ 0`, `ν ≥ 0` that a step may go.
const TAU: f64 = 0.99;

/// The subproblem as read by the dual passes: asymptotes and move limits from the chunked
/// `nodes` (fields `LOW`, `UPP`, `ALFA`, `BETA`), the p/q coefficients recomputed from the
/// gradients at xᵏ with [`pq`].
#[derive(Clone, Copy)]
pub(crate) struct DualData<'a> {
    pub n: usize,
    pub m: usize,
    pub nodes: &'a [f64],
    pub stride: usize,
    pub df0dx: &'a [f64],
    /// m × n, row-major.
    pub dfdx: &'a [f64],
    /// `raa0 / max(xmax − xmin, 1e-5)`: one value for all variables, or n values.
    pub raa: &'a [f64],
    pub b: &'a [f64],
}

/// The p and q coefficients of one function (`mmasub`):
/// `p = ((∂f)⁺ + 0.001|∂f| + raa)·(u − xᵏ)²`, `q = ((∂f)⁻ + 0.001|∂f| + raa)·(xᵏ − l)²`.
#[inline(always)]
pub(crate) fn pq<T: Real>(g: T, ux2: T, xl2: T, raa: T) -> (T, T) {
    let zero = T::splat(0.0);
    let pp = g.maxv(zero);
    let qq = (-g).maxv(zero);
    let r = T::splat(0.001) * (pp + qq) + raa;
    ((pp + r) * ux2, (qq + r) * xl2)
}

/// What one dual solve did.
#[derive(Clone, Copy, Debug)]
pub(crate) struct DualReport {
    /// Newton steps (each one pass over the variables).
    pub iterations: usize,
    /// 2-norm of the m-dimensional KKT residual `(∇W − Aᵀν, s∘ν)` at the end.
    pub residual_norm: f64,
}

/// The previous subproblem's multipliers (notation of `subsolv`), to warm-start the next.
#[derive(Clone, Copy)]
pub(crate) struct WarmStart<'a> {
    pub lam: &'a [f64],
    pub y: &'a [f64],
    pub s: &'a [f64],
    pub z: f64,
}

/// The m-dimensional multipliers of the subproblem in the notation of `subsolv`.
pub(crate) struct SubMultipliers<'a> {
    pub lam: &'a mut [f64],
    pub y: &'a mut [f64],
    pub z: &'a mut f64,
    pub mu: &'a mut [f64],
    pub zet: &'a mut f64,
    pub s: &'a mut [f64],
}

/// Number of scalars a chunk reduces: g (m) and the lower triangle of Σ G Gᵀ/ψ'' (m²
/// slots, row-major, upper part unused).
fn reduced_len(m: usize) -> usize {
    m + m * m
}

/// Lane accumulators per chunk for `m > MAX_STATIC_M`: g, the triangle of H, G of a block.
fn dyn_lanes(m: usize) -> usize {
    if m > MAX_STATIC_M {
        2 * m + m * (m + 1) / 2
    } else {
        1
    }
}

/// Scratch and m-dimensional iterate of the dual solver, allocated once for `(n, m)`.
#[derive(Clone, Debug)]
pub(crate) struct DualSolver {
    m: usize,
    parallel: bool,
    acc: Vec<f64>,
    slot: usize,
    lanes: Vec<V>,
    lslot: usize,
    /// Unknowns in use: λ, and w when d > 0 (`nv = m` or `2m`).
    nv: usize,
    /// Rows of `A v ≤ ā`: `kind[r]` and `ā[r]`; `k` rows in use.
    kind: Vec<Row>,
    abar: Vec<f64>,
    k: usize,
    /// `v = (λ, w)`.
    v: Vec<f64>,
    nu: Vec<f64>,
    s: Vec<f64>,
    /// `g(x(λ)) − b` from the last pass, and Σ_free G Gᵀ/ψ'' (= −∇²_λλ W), m × m.
    gb: Vec<f64>,
    hx: Vec<f64>,
    /// ∇F and −∇²F of the objective in `v`.
    grad: Vec<f64>,
    hneg: Vec<f64>,
    mat: Vec<f64>,
    work: Vec<f64>,
    rhs: Vec<f64>,
    t: Vec<f64>,
    dv: Vec<f64>,
    ds: Vec<f64>,
    dnu: Vec<f64>,
}

/// One linear constraint `A_r v ≤ ā_r` of the dual.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Row {
    /// −λᵢ ≤ 0; its multiplier is the slack sᵢ of constraint i of the subproblem.
    Positive(usize),
    /// λᵢ − wᵢ ≤ c (d > 0); its multiplier is yᵢ.
    WCap(usize),
    /// λᵢ ≤ c (d = 0); its multiplier is yᵢ.
    Cap(usize),
    /// a Σλᵢ ≤ a₀ (a > 0); its multiplier is z.
    Z,
}

impl DualSolver {
    pub(crate) fn new(n: usize, m: usize, parallel: bool) -> Self {
        let nchunks = n.div_ceil(CHUNK);
        let slot = reduced_len(m).max(1);
        let lslot = dyn_lanes(m);
        let kmax = 2 * m + 1;
        let nvmax = 2 * m;
        Self {
            m,
            parallel,
            acc: vec![0.0; nchunks * slot],
            slot,
            lanes: vec![V::splat(0.0); nchunks * lslot],
            lslot,
            nv: m,
            kind: vec![Row::Z; kmax],
            abar: vec![0.0; kmax],
            k: 0,
            v: vec![0.0; nvmax],
            nu: vec![0.0; kmax],
            s: vec![0.0; kmax],
            gb: vec![0.0; m],
            hx: vec![0.0; m * m],
            grad: vec![0.0; nvmax],
            hneg: vec![0.0; nvmax * nvmax],
            mat: vec![0.0; nvmax * nvmax],
            work: vec![0.0; nvmax * nvmax],
            rhs: vec![0.0; nvmax],
            t: vec![0.0; kmax],
            dv: vec![0.0; nvmax],
            ds: vec![0.0; kmax],
            dnu: vec![0.0; kmax],
        }
    }

    /// The unknowns and constraints for the constants `k`.
    fn set_rows(&mut self, k: &SubConsts) {
        let m = self.m;
        let mut r = 0;
        let (kinds, abar) = (&mut self.kind, &mut self.abar);
        let mut push = |kind: Row, value: f64| {
            kinds[r] = kind;
            abar[r] = value;
            r += 1;
        };
        for i in 0..m {
            push(Row::Positive(i), 0.0);
        }
        if k.d > 0.0 {
            for i in 0..m {
                push(Row::WCap(i), k.c);
            }
        } else {
            for i in 0..m {
                push(Row::Cap(i), k.c);
            }
        }
        if k.a > 0.0 {
            push(Row::Z, k.a0);
        }
        self.k = r;
        self.nv = if k.d > 0.0 { 2 * m } else { m };
    }

    /// Solves the dual of the subproblem `data` (xᵏ in `x`), warm-started from the previous
    /// subproblem's multipliers when `warm` is given. Returns `None` when the method fails;
    /// the caller then uses `subsolv`.
    pub(crate) fn solve(
        &mut self,
        data: &DualData<'_>,
        x: &[f64],
        k: &SubConsts,
        warm: Option<WarmStart<'_>>,
    ) -> Option<DualReport> {
        if k.c == 0.0 && k.d == 0.0 {
            return None;
        }
        self.set_rows(k);
        let mut steps = 0;
        if let Some(w) = warm {
            if self.start_warm(&w, k) {
                self.evaluate(data, x);
                match self.iterate(data, x, k, MAX_WARM_STEPS) {
                    Ok(rep) => return Some(rep),
                    Err(n) => steps = n,
                }
            }
        }
        self.start_cold(k);
        self.evaluate(data, x);
        for r in 0..self.k {
            self.nu[r] = match self.kind[r] {
                Row::Positive(i) => self.gb[i].abs().max(1.0),
                _ => 1.0,
            };
        }
        let mut rep = self.iterate(data, x, k, MAX_STEPS).ok()?;
        rep.iterations += steps;
        Some(rep)
    }

    /// λ = 1 (inside the caps), w = max(0, λ − c + 1).
    fn start_cold(&mut self, k: &SubConsts) {
        let (m, nv) = (self.m, self.nv);
        self.v[..m].fill(1.0);
        for i in m..nv {
            self.v[i] = (1.0 - k.c + 1.0).max(0.0);
        }
        if k.d == 0.0 {
            self.v[..m].fill((0.5 * k.c).min(1.0));
        }
        if k.a > 0.0 {
            let tot = k.a * self.v[..m].iter().sum::<f64>();
            if tot > 0.5 * k.a0 {
                let f = 0.5 * k.a0 / tot;
                self.v[..m].iter_mut().for_each(|l| *l *= f);
            }
        }
    }

    /// The previous solution moved [`WARM_DISTANCE`] into the interior; false if that leaves
    /// a slack non-positive.
    fn start_warm(&mut self, w: &WarmStart<'_>, k: &SubConsts) -> bool {
        let (m, nv, nk) = (self.m, self.nv, self.k);
        let delta = WARM_DISTANCE;
        for i in 0..m {
            self.v[i] = w.lam[i].max(delta);
            if nv > m {
                self.v[m + i] = (k.d * w.y[i]).max(self.v[i] - k.c + delta);
            }
        }
        for r in 0..nk {
            let s = self.abar[r] - a_row(self.kind[r], &self.v, m, k.a);
            if s.is_nan() || s <= 0.0 {
                return false;
            }
            let prev = match self.kind[r] {
                Row::Positive(i) => w.s[i],
                Row::WCap(i) | Row::Cap(i) => w.y[i],
                Row::Z => w.z,
            };
            self.nu[r] = prev.max(delta / s);
        }
        true
    }

    /// Newton steps from the current point until convergence (`Ok`) or failure after at most
    /// `max_steps` steps (`Err` with the steps taken).
    fn iterate(
        &mut self,
        data: &DualData<'_>,
        x: &[f64],
        k: &SubConsts,
        max_steps: usize,
    ) -> Result<DualReport, usize> {
        let (m, nv, nk) = (self.m, self.nv, self.k);
        let mut steps = 0;
        loop {
            self.objective(k);
            // Slacks, dual residual ∇F − Aᵀν (in rhs), complementarity.
            for r in 0..nk {
                self.s[r] = self.abar[r] - a_row(self.kind[r], &self.v, m, k.a);
            }
            self.rhs[..nv].copy_from_slice(&self.grad[..nv]);
            add_at(
                &self.kind[..nk],
                &self.nu[..nk],
                -1.0,
                m,
                k.a,
                &mut self.rhs[..nv],
            );
            let (mut sum, mut mx) = (0.0f64, 0.0f64);
            for v in &self.rhs[..nv] {
                sum += v * v;
                mx = mx.max(v.abs());
            }
            let mut gap = 0.0;
            for r in 0..nk {
                let c = self.s[r] * self.nu[r];
                gap += c;
                sum += c * c;
                mx = mx.max(c.abs());
            }
            if !mx.is_finite() || steps == max_steps {
                return Err(steps);
            }
            if mx <= k.epsimin {
                return Ok(DualReport {
                    iterations: steps,
                    residual_norm: sum.sqrt(),
                });
            }
            steps += 1;
            // M = −∇²F + Aᵀ diag(ν/s) A.
            self.mat[..nv * nv].copy_from_slice(&self.hneg[..nv * nv]);
            for r in 0..nk {
                add_row_outer(
                    self.kind[r],
                    self.nu[r] / self.s[r],
                    m,
                    nv,
                    k.a,
                    &mut self.mat,
                );
            }
            // Predictor (t = 0), then Mehrotra's corrector.
            self.t[..nk].fill(0.0);
            self.direction(k.a);
            let step_aff = self.max_step().min(1.0);
            let gap = gap / nk as f64;
            let mut gap_aff = 0.0;
            for r in 0..nk {
                gap_aff +=
                    (self.s[r] + step_aff * self.ds[r]) * (self.nu[r] + step_aff * self.dnu[r]);
            }
            let sigma = (gap_aff / nk as f64 / gap).powi(3).min(1.0);
            for r in 0..nk {
                self.t[r] = sigma * gap - self.ds[r] * self.dnu[r];
            }
            self.direction(k.a);
            // Fraction to the boundary, tending to 1 as the gap closes (superlinear finish).
            let tau = TAU.max(1.0 - gap);
            let step = (tau * self.max_step()).min(1.0);
            for (v, dv) in self.v[..nv].iter_mut().zip(&self.dv) {
                *v += step * dv;
            }
            for r in 0..nk {
                self.nu[r] += step * self.dnu[r];
            }
            self.evaluate(data, x);
        }
    }

    /// ∇F and −∇²F at `v` from the last pass: F(λ, w) = W_x(λ) − λᵀb − Σ wᵢ²/(2d).
    fn objective(&mut self, k: &SubConsts) {
        let (m, nv) = (self.m, self.nv);
        self.grad[..m].copy_from_slice(&self.gb);
        self.hneg[..nv * nv].fill(0.0);
        for i in 0..m {
            for j in 0..m {
                self.hneg[i * nv + j] = self.hx[i * m + j];
            }
        }
        for i in m..nv {
            self.grad[i] = -self.v[i] / k.d;
            self.hneg[i * nv + i] = 1.0 / k.d;
        }
    }

    /// Δv, Δs, Δν for the target `t` with the matrix in `mat`.
    fn direction(&mut self, a: f64) {
        let (m, nv, nk) = (self.m, self.nv, self.k);
        // Δv = M⁻¹ (∇F − Aᵀ(t/s)); ds holds t/s meanwhile.
        self.rhs[..nv].copy_from_slice(&self.grad[..nv]);
        for r in 0..nk {
            self.ds[r] = self.t[r] / self.s[r];
        }
        add_at(
            &self.kind[..nk],
            &self.ds[..nk],
            -1.0,
            m,
            a,
            &mut self.rhs[..nv],
        );
        self.work[..nv * nv].copy_from_slice(&self.mat[..nv * nv]);
        solve_in_place(&mut self.work[..nv * nv], &mut self.rhs[..nv], nv);
        self.dv[..nv].copy_from_slice(&self.rhs[..nv]);
        for r in 0..nk {
            self.ds[r] = -a_row(self.kind[r], &self.dv, m, a);
            self.dnu[r] =
                (self.t[r] - self.s[r] * self.nu[r] - self.nu[r] * self.ds[r]) / self.s[r];
        }
    }

    /// Largest step keeping `s ≥ 0` and `ν ≥ 0` (∞ if unbounded).
    fn max_step(&self) -> f64 {
        let mut st = f64::INFINITY;
        for r in 0..self.k {
            if self.ds[r] < 0.0 {
                st = st.min(-self.s[r] / self.ds[r]);
            }
            if self.dnu[r] < 0.0 {
                st = st.min(-self.nu[r] / self.dnu[r]);
            }
        }
        st
    }

    /// One pass: `g(x(λ)) − b` and Σ_free G Gᵀ/ψ'' at the current λ.
    fn evaluate(&mut self, data: &DualData<'_>, x: &[f64]) {
        let m = self.m;
        if m == 0 {
            return;
        }
        let ctx = PassCtx {
            data: *data,
            x,
            lam: &self.v[..m],
        };
        let f = |(c, (a, ln)): (usize, (&mut [f64], &mut [V]))| {
            dispatch_m!(m, dual_chunk, &ctx, c, a, ln)
        };
        self.acc
            .par_chunks_mut(self.slot)
            .zip(self.lanes.par_chunks_mut(self.lslot))
            .enumerate()
            .with_min_len(min_len(self.parallel))
            .for_each(f);
        self.gb.fill(0.0);
        self.hx.fill(0.0);
        for a in self.acc.chunks_exact(self.slot) {
            for i in 0..m {
                self.gb[i] += a[i];
                for j in 0..=i {
                    self.hx[i * m + j] += a[m + i * m + j];
                }
            }
        }
        for i in 0..m {
            for j in 0..i {
                self.hx[j * m + i] = self.hx[i * m + j];
            }
            self.gb[i] -= data.b[i];
        }
    }

    /// The multipliers of the subproblem in the notation of `subsolv` (λ, y, z, μ, ζ, s)
    /// after a successful [`Self::solve`].
    pub(crate) fn multipliers(&self, k: &SubConsts, out: SubMultipliers<'_>) {
        let m = self.m;
        out.lam.copy_from_slice(&self.v[..m]);
        *out.z = 0.0;
        for r in 0..self.k {
            match self.kind[r] {
                Row::Positive(i) => out.s[i] = self.nu[r],
                Row::WCap(i) | Row::Cap(i) => out.y[i] = self.nu[r],
                Row::Z => *out.z = self.nu[r],
            }
        }
        for i in 0..m {
            out.mu[i] = (k.c + k.d * out.y[i] - self.v[i]).max(0.0);
        }
        *out.zet = k.a0 - k.a * self.v[..m].iter().sum::<f64>();
    }

    /// Writes the solution `x(λ)` into `x` (which held xᵏ) and xᵏ into `xold`, the
    /// multipliers ξ, η of `α ≤ x ≤ β` into `xsi`, `eta`; returns `max |x − xᵏ|`.
    pub(crate) fn finish(
        &self,
        data: &DualData<'_>,
        x: &mut [f64],
        xold: &mut [f64],
        xsi: &mut [f64],
        eta: &mut [f64],
    ) -> f64 {
        let m = self.m;
        let lam = &self.v[..m];
        type Out<'x> = (
            (&'x mut [f64], &'x mut [f64]),
            (&'x mut [f64], &'x mut [f64]),
        );
        let f = |(c, ((xs, xo), (xi, et))): (usize, Out<'_>)| {
            dispatch_m!(m, finish_chunk, data, lam, c, xs, xo, xi, et)
        };
        x.par_chunks_mut(CHUNK)
            .zip(xold.par_chunks_mut(CHUNK))
            .zip(xsi.par_chunks_mut(CHUNK).zip(eta.par_chunks_mut(CHUNK)))
            .enumerate()
            .with_min_len(min_len(self.parallel))
            .map(f)
            .reduce(|| 0.0, f64::max)
    }
}

/// `(A v)_r` for the row `kind` (`v = (λ, w)`, m multipliers).
fn a_row(kind: Row, v: &[f64], m: usize, a: f64) -> f64 {
    match kind {
        Row::Positive(i) => -v[i],
        Row::WCap(i) => v[i] - v[m + i],
        Row::Cap(i) => v[i],
        Row::Z => a * v[..m].iter().sum::<f64>(),
    }
}

/// `out += scale · Aᵀ w` for the rows `kind`.
fn add_at(kind: &[Row], w: &[f64], scale: f64, m: usize, a: f64, out: &mut [f64]) {
    for (&kd, &wr) in kind.iter().zip(w) {
        let v = scale * wr;
        match kd {
            Row::Positive(i) => out[i] -= v,
            Row::WCap(i) => {
                out[i] += v;
                out[m + i] -= v;
            }
            Row::Cap(i) => out[i] += v,
            Row::Z => out[..m].iter_mut().for_each(|o| *o += a * v),
        }
    }
}

/// `mat += wt · A_rᵀ A_r` (`nv × nv`).
fn add_row_outer(kind: Row, wt: f64, m: usize, nv: usize, a: f64, mat: &mut [f64]) {
    match kind {
        Row::Positive(i) | Row::Cap(i) => mat[i * nv + i] += wt,
        Row::WCap(i) => {
            let (l, w) = (i, m + i);
            mat[l * nv + l] += wt;
            mat[w * nv + w] += wt;
            mat[l * nv + w] -= wt;
            mat[w * nv + l] -= wt;
        }
        Row::Z => {
            for r in 0..m {
                for c in 0..m {
                    mat[r * nv + c] += wt * a * a;
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// Chunk kernels.

struct PassCtx<'a> {
    data: DualData<'a>,
    x: &'a [f64],
    lam: &'a [f64],
}

/// The minimizer `x(λ)` of one block and what the passes need at it.
struct Block {
    x: V,
    uxinv: V,
    xlinv: V,
    ux2: V,
    xl2: V,
    raa: V,
    /// `p(λ)`, `q(λ)`.
    p: V,
    q: V,
    alfa: V,
    beta: V,
}

/// `x(λ)` for the block of variables `j..j+LANES` (offset `o` in its chunk, `valid` lanes
/// real); `xk` holds xᵏ.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn minimizer<const MASK: bool>(
    d: &DualData<'_>,
    m: usize,
    lam: &[f64],
    nd: Nodes<'_>,
    xk: &[f64],
    j: usize,
    o: usize,
    valid: usize,
) -> Block {
    let (low, upp, alfa, beta) = (
        nd.get(LOW, o),
        nd.get(UPP, o),
        nd.get(ALFA, o),
        nd.get(BETA, o),
    );
    let xv = V::load_part::<MASK>(xk, o, valid, 0.5);
    let raa = if d.raa.len() == 1 {
        V::splat(d.raa[0])
    } else {
        V::load_part::<MASK>(d.raa, j, valid, 1.0)
    };
    let (ux1, xl1) = (upp - xv, xv - low);
    let (ux2, xl2) = (ux1 * ux1, xl1 * xl1);
    let (mut p, mut q) = pq(V::load_part::<MASK>(d.df0dx, j, valid, 0.0), ux2, xl2, raa);
    for (i, &l) in lam[..m].iter().enumerate() {
        let g = V::load_part::<MASK>(&d.dfdx[i * d.n..(i + 1) * d.n], j, valid, 0.0);
        let (pi, qi) = pq(g, ux2, xl2, raa);
        let l = V::splat(l);
        p = p + pi * l;
        q = q + qi * l;
    }
    let (sp, sq) = (p.sqrt(), q.sqrt());
    let x = ((sp * low + sq * upp) / (sp + sq)).maxv(alfa).minv(beta);
    let one = V::splat(1.0);
    Block {
        x,
        uxinv: one / (upp - x),
        xlinv: one / (x - low),
        ux2,
        xl2,
        raa,
        p,
        q,
        alfa,
        beta,
    }
}

/// Lane accumulators of one chunk's pass: g, the lower triangle of Σ G Gᵀ/ψ'' (row by
/// row) and G of the current block.
struct DualAcc<'s> {
    g: &'s mut [V],
    h: &'s mut [V],
    gc: &'s mut [V],
}

/// Adds one block's terms of g and Σ G Gᵀ/ψ'' at x(λ) to `acc`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn dual_block<const MASK: bool>(
    ctx: &PassCtx<'_>,
    m: usize,
    nd: Nodes<'_>,
    xk: &[f64],
    j: usize,
    o: usize,
    valid: usize,
    acc: &mut DualAcc<'_>,
) {
    let d = &ctx.data;
    let b = minimizer::<MASK>(d, m, ctx.lam, nd, xk, j, o, valid);
    let (uxinv, xlinv) = (
        b.uxinv.keep::<MASK>(valid, 0.0),
        b.xlinv.keep::<MASK>(valid, 0.0),
    );
    // Padding lanes are zeroed through `uxinv`, `xlinv` and `dinv`.
    let (uxinv2, xlinv2) = (uxinv * uxinv, xlinv * xlinv);
    let psi2 = V::splat(2.0) * (b.p * uxinv2 * uxinv + b.q * xlinv2 * xlinv);
    let dinv = (V::splat(1.0) / psi2)
        .where_inside(b.x, b.alfa, b.beta, V::splat(0.0))
        .keep::<MASK>(valid, 0.0);
    for i in 0..m {
        let gv = V::load_part::<MASK>(&d.dfdx[i * d.n..(i + 1) * d.n], j, valid, 0.0);
        let (pi, qi) = pq(gv, b.ux2, b.xl2, b.raa);
        acc.g[i] = acc.g[i] + (pi * uxinv + qi * xlinv);
        let gi = pi * uxinv2 - qi * xlinv2;
        acc.gc[i] = gi;
        let gd = gi * dinv;
        for k in 0..=i {
            let hk = i * (i + 1) / 2 + k;
            acc.h[hk] = acc.h[hk] + gd * acc.gc[k];
        }
    }
}

#[multiversion(targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"))]
fn dual_chunk<'a, const M: usize>(ctx: &PassCtx<'a>, c: usize, a: &mut [f64], ln: &mut [V]) {
    let d = &ctx.data;
    let m = if M == DYN { d.m } else { M };
    let nd = Nodes(&d.nodes[c * CHUNK * d.stride..(c + 1) * CHUNK * d.stride]);
    let xk = &ctx.x[c * CHUNK..];
    let tri = m * (m + 1) / 2;
    let z = V::splat(0.0);
    let mut sg = [z; MAX_STATIC_M];
    let mut sh = [z; MAX_STATIC_M * (MAX_STATIC_M + 1) / 2];
    let mut sgc = [z; MAX_STATIC_M];
    let mut acc = if M == DYN {
        ln.fill(z);
        let (g, r) = ln.split_at_mut(m);
        let (h, gc) = r.split_at_mut(tri);
        DualAcc { g, h, gc }
    } else {
        DualAcc {
            g: &mut sg[..m],
            h: &mut sh[..tri],
            gc: &mut sgc[..m],
        }
    };
    let (full, tail) = chunk_len(d.n, c);
    let j0 = c * CHUNK;
    for bl in 0..full {
        let o = bl * LANES;
        dual_block::<false>(ctx, m, nd, xk, j0 + o, o, LANES, &mut acc);
    }
    if tail > 0 {
        let o = full * LANES;
        dual_block::<true>(ctx, m, nd, xk, j0 + o, o, tail, &mut acc);
    }
    for i in 0..m {
        a[i] = acc.g[i].hsum();
        for k in 0..=i {
            a[m + i * m + k] = acc.h[i * (i + 1) / 2 + k].hsum();
        }
    }
}

/// Writes x(λ), xᵏ, ξ and η of one block; returns the lanes' |x(λ) − xᵏ|.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn finish_block<const MASK: bool>(
    d: &DualData<'_>,
    m: usize,
    lam: &[f64],
    nd: Nodes<'_>,
    j: usize,
    o: usize,
    valid: usize,
    (xs, xo, xsi, eta): (&mut [f64], &mut [f64], &mut [f64], &mut [f64]),
) -> V {
    let b = minimizer::<MASK>(d, m, lam, nd, xs, j, o, valid);
    // ∂L/∂x at x(λ): its positive part is ξ where x sits on α, its negative part η where x
    // sits on β.
    let dl = b.p * b.uxinv * b.uxinv - b.q * b.xlinv * b.xlinv;
    let (mut xi, mut et) = ([0.0; LANES], [0.0; LANES]);
    for l in 0..LANES {
        let x = b.x.0[l];
        if x <= b.alfa.0[l] {
            xi[l] = dl.0[l].max(0.0);
        } else if x >= b.beta.0[l] {
            et[l] = (-dl.0[l]).max(0.0);
        }
    }
    let xv = V::load_part::<MASK>(xs, o, valid, 0.0);
    let change = (b.x - xv).absv().keep::<MASK>(valid, 0.0);
    xv.store::<MASK>(xo, o, valid);
    b.x.store::<MASK>(xs, o, valid);
    V(xi).store::<MASK>(xsi, o, valid);
    V(et).store::<MASK>(eta, o, valid);
    change
}

#[multiversion(targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"))]
#[allow(clippy::too_many_arguments)]
fn finish_chunk<const M: usize>(
    d: &DualData<'_>,
    lam: &[f64],
    c: usize,
    xs: &mut [f64],
    xo: &mut [f64],
    xsi: &mut [f64],
    eta: &mut [f64],
) -> f64 {
    let m = if M == DYN { d.m } else { M };
    let nd = Nodes(&d.nodes[c * CHUNK * d.stride..(c + 1) * CHUNK * d.stride]);
    let (full, tail) = chunk_len(d.n, c);
    let j0 = c * CHUNK;
    let mut ch = V::splat(0.0);
    for bl in 0..full {
        let o = bl * LANES;
        let out = (&mut *xs, &mut *xo, &mut *xsi, &mut *eta);
        ch = ch.maxv(finish_block::<false>(d, m, lam, nd, j0 + o, o, LANES, out));
    }
    if tail > 0 {
        let o = full * LANES;
        let out = (&mut *xs, &mut *xo, &mut *xsi, &mut *eta);
        ch = ch.maxv(finish_block::<true>(d, m, lam, nd, j0 + o, o, tail, out));
    }
    ch.hmax(0.0)
}

#[cfg(test)]
mod tests {
    //! Reference: central finite differences of the dual function W(λ), evaluated by a plain
    //! scalar minimization per variable written independently of the SIMD passes.
    //! Goal: the pass's ∂W/∂λ and −∂²W/∂λ² (hand-written, eq. in the module docs) match.

    use super::*;

    /// A random subproblem: n = 37 (a partial SIMD block), m = 2.
    struct Case {
        nodes: Vec<f64>,
        x: Vec<f64>,
        df0: Vec<f64>,
        dfdx: Vec<f64>,
        raa: Vec<f64>,
        b: Vec<f64>,
    }

    const N: usize = 37;
    const M: usize = 2;
    const STRIDE: usize = 4;

    fn case() -> Case {
        let mut seed = 12345u64;
        let mut rnd = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut nodes = vec![0.0; CHUNK * STRIDE];
        let mut x = vec![0.0; N];
        for j in 0..N {
            let xv = 0.2 + 0.6 * rnd();
            let (low, upp) = (xv - 0.1 - 0.4 * rnd(), xv + 0.1 + 0.4 * rnd());
            x[j] = xv;
            nodes[LOW * CHUNK + j] = low;
            nodes[UPP * CHUNK + j] = upp;
            // Tight move limits, so that some minimizers sit on α or β.
            nodes[ALFA * CHUNK + j] = xv - 0.05 * rnd();
            nodes[BETA * CHUNK + j] = xv + 0.05 * rnd();
        }
        let df0 = (0..N).map(|_| rnd() - 0.7).collect();
        let dfdx = (0..M * N).map(|_| rnd() - 0.3).collect();
        Case {
            nodes,
            x,
            df0,
            dfdx,
            raa: vec![1e-3],
            b: vec![0.3, -0.2],
        }
    }

    fn data(c: &Case) -> DualData<'_> {
        DualData {
            n: N,
            m: M,
            nodes: &c.nodes,
            stride: STRIDE,
            df0dx: &c.df0,
            dfdx: &c.dfdx,
            raa: &c.raa,
            b: &c.b,
        }
    }

    /// W_x(λ) − λᵀb by a scalar closed-form minimization, and the number of clamped x.
    fn w_of(c: &Case, lam: &[f64]) -> (f64, usize) {
        let (mut w, mut clamped) = (0.0, 0);
        for j in 0..N {
            let nd = |f: usize| c.nodes[f * CHUNK + j];
            let (low, upp) = (nd(LOW), nd(UPP));
            let (ux2, xl2) = ((upp - c.x[j]).powi(2), (c.x[j] - low).powi(2));
            let (mut p, mut q) = pq(c.df0[j], ux2, xl2, c.raa[0]);
            for (i, l) in lam.iter().enumerate() {
                let (pi, qi) = pq(c.dfdx[i * N + j], ux2, xl2, c.raa[0]);
                p += l * pi;
                q += l * qi;
            }
            let xs = (low * p.sqrt() + upp * q.sqrt()) / (p.sqrt() + q.sqrt());
            let xc = xs.clamp(nd(ALFA), nd(BETA));
            clamped += usize::from(xc != xs);
            w += p / (upp - xc) + q / (xc - low);
        }
        let lb: f64 = lam.iter().zip(&c.b).map(|(l, b)| l * b).sum();
        (w - lb, clamped)
    }

    #[test]
    fn dual_gradient_and_hessian_match_central_differences() {
        let c = case();
        let d = data(&c);
        let mut solver = DualSolver::new(N, M, false);
        let lam = [0.7, 0.4];
        let eval = |s: &mut DualSolver, l: &[f64]| {
            s.v[..M].copy_from_slice(l);
            s.evaluate(&d, &c.x);
            (s.gb.clone(), s.hx.clone())
        };
        let (g, h) = eval(&mut solver, &lam);
        // Some variables are clamped at α or β and some are free, so both branches count.
        let clamped = w_of(&c, &lam).1;
        assert!(clamped > 3 && clamped < N - 3, "{clamped} of {N} clamped");
        let h_step = 1e-5;
        for i in 0..M {
            let (mut lp, mut lm) = (lam, lam);
            lp[i] += h_step;
            lm[i] -= h_step;
            let fd = (w_of(&c, &lp).0 - w_of(&c, &lm).0) / (2.0 * h_step);
            assert!(
                (g[i] - fd).abs() <= 1e-7 * fd.abs().max(1.0),
                "∂W/∂λ{i}: pass {} vs FD {fd}",
                g[i]
            );
            let (gp, _) = eval(&mut solver, &lp);
            let (gm, _) = eval(&mut solver, &lm);
            for k in 0..M {
                let fd2 = -(gp[k] - gm[k]) / (2.0 * h_step);
                let an = h[k * M + i];
                assert!(
                    (an - fd2).abs() <= 1e-6 * fd2.abs().max(1.0),
                    "-∂²W/∂λ{k}∂λ{i}: pass {an} vs FD {fd2}"
                );
            }
        }
        assert!(h[0] > 0.0 && h[0] * h[3] - h[1] * h[2] > 0.0, "H = {h:?}");
    }
}
