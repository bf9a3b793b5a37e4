//! The stateful MMA optimizer (`mmasub`).

use multiversion::multiversion;
use rayon::prelude::*;

use crate::dual::{DualData, DualSolver, SubMultipliers, WarmStart, pq};
use crate::error::MmaError;
use crate::input::{all_ok, check_finite, check_len};
use crate::kkt::{KktProblem, KktResidual, Multipliers, kkt_residual};
use crate::lanes::{CHUNK, min_len};
use crate::params::{MmaParams, Subsolver};
use crate::subproblem::{ALFA, BETA, ETA, LOW, NSTATE, P0, PQ, Q0, SubConsts, UPP, X, XSI, idx};
use crate::subsolv::SubSolver;

/// What one [`Mma::update`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateReport {
    /// Outer iteration number, starting at 1.
    pub iteration: usize,
    /// `max_j |x_new[j] - x_old[j]|`.
    pub max_change: f64,
    /// Newton steps taken by the interior-point subproblem solver.
    pub subproblem_iterations: usize,
    /// Norm of the relaxed KKT residual of the subproblem at its last barrier level.
    pub subproblem_residual: f64,
    /// The solver that solved the subproblem: [`Subsolver::Dual`] falls back to
    /// [`Subsolver::PrimalDual`] when it fails (see [`Subsolver`]).
    pub subsolver: Subsolver,
}

/// The history an [`Mma`] carries between updates, for checkpoints: restoring it into an
/// optimizer built with the same `n`, `m`, bounds and parameters makes the next
/// [`Mma::update`] (and [`Mma::kkt_residual`]) bitwise identical to the uninterrupted run.
#[derive(Debug, Clone, PartialEq)]
pub struct MmaState {
    /// Number of updates done ([`Mma::iteration`]).
    pub iteration: usize,
    /// Previous iterate `xᵏ⁻¹` (length n).
    pub xold1: Vec<f64>,
    /// Iterate before that, `xᵏ⁻²` (length n).
    pub xold2: Vec<f64>,
    /// Lower asymptotes of the last update (length n).
    pub low: Vec<f64>,
    /// Upper asymptotes of the last update (length n).
    pub upp: Vec<f64>,
    /// Multipliers λ of the last subproblem (length m).
    pub lam: Vec<f64>,
    /// Artificial variables y (length m).
    pub y: Vec<f64>,
    /// Artificial variable z.
    pub z: f64,
    /// Multipliers μ of y ≥ 0 (length m).
    pub mu: Vec<f64>,
    /// Multiplier ζ of z ≥ 0.
    pub zet: f64,
    /// Slacks s (length m).
    pub s: Vec<f64>,
    /// Multipliers ξ of the lower bounds (length n).
    pub xsi: Vec<f64>,
    /// Multipliers η of the upper bounds (length n).
    pub eta: Vec<f64>,
}

/// Svanberg's MMA for `min f₀(x)` s.t. `fᵢ(x) ≤ 0`, `xmin ≤ x ≤ xmax`.
///
/// Build it once for given dimensions, bounds and parameters; then, at each outer iteration,
/// evaluate the functions and gradients at `x` and call [`Mma::update`], which replaces `x`
/// by the solution of the MMA subproblem. The optimizer keeps the two previous iterates and
/// the asymptotes. All vectors are allocated in [`Mma::new`]; an update allocates nothing.
///
/// ```
/// use flexstage_mma::{Mma, MmaParams};
/// // min (x-1)² + (y-2)²  s.t.  x + y - 2 <= 0,  0 <= x, y <= 3
/// let (xmin, xmax) = (vec![0.0; 2], vec![3.0; 2]);
/// let mut mma = Mma::new(2, 1, xmin, xmax, MmaParams::default()).unwrap();
/// let mut x: Vec<f64> = vec![0.5, 0.5];
/// for _ in 0..50 {
///     let f0 = (x[0] - 1.0).powi(2) + (x[1] - 2.0).powi(2);
///     let df0 = [2.0 * (x[0] - 1.0), 2.0 * (x[1] - 2.0)];
///     let f = [x[0] + x[1] - 2.0];
///     let dfdx = [1.0, 1.0]; // m × n, row-major
///     let report = mma.update(&mut x, f0, &df0, &f, &dfdx).unwrap();
///     if report.max_change < 1e-9 { break; }
/// }
/// assert!((x[0] - 0.5).abs() < 1e-5 && (x[1] - 1.5).abs() < 1e-5);
/// ```
#[derive(Debug, Clone)]
pub struct Mma {
    n: usize,
    m: usize,
    params: MmaParams,
    xmin: Vec<f64>,
    xmax: Vec<f64>,
    iter: usize,
    xold1: Vec<f64>,
    xold2: Vec<f64>,
    sub: SubSolver,
    /// The dual solver, when `params.subsolver` is [`Subsolver::Dual`].
    dual: Option<DualSolver>,
    /// `raa0 / max(xmax − xmin, 1e-5)`: one value if all ranges are equal, else n values.
    raa: Vec<f64>,
    xsi: Vec<f64>,
    eta: Vec<f64>,
}

impl Mma {
    /// Creates an optimizer for `n` variables and `m` constraints (`m = 0` is allowed).
    ///
    /// # Errors
    /// [`MmaError::NoVariables`] if `n == 0`, [`MmaError::DimensionMismatch`] if a bound has
    /// the wrong length, [`MmaError::NonFinite`] / [`MmaError::InvalidBounds`] for bad
    /// bounds, [`MmaError::InvalidParams`] if `params.validate()` fails.
    pub fn new(
        n: usize,
        m: usize,
        xmin: Vec<f64>,
        xmax: Vec<f64>,
        params: MmaParams,
    ) -> Result<Self, MmaError> {
        if n == 0 {
            return Err(MmaError::NoVariables);
        }
        params.validate()?;
        check_len("xmin", &xmin, n)?;
        check_len("xmax", &xmax, n)?;
        check_finite("xmin", &xmin, false)?;
        check_finite("xmax", &xmax, false)?;
        if let Some(index) = (0..n).find(|&j| xmin[j] >= xmax[j]) {
            return Err(MmaError::InvalidBounds {
                index,
                lower: xmin[index],
                upper: xmax[index],
            });
        }
        let parallel = n >= params.parallel_threshold;
        let raa_of = |j: usize| raa_term(params.raa0, xmax[j] - xmin[j]);
        let raa = if (1..n).all(|j| xmax[j] - xmin[j] == xmax[0] - xmin[0]) {
            vec![raa_of(0)]
        } else {
            (0..n).map(raa_of).collect()
        };
        let dual = (params.subsolver == Subsolver::Dual).then(|| DualSolver::new(n, m, parallel));
        Ok(Self {
            n,
            m,
            params,
            xmin,
            xmax,
            iter: 0,
            xold1: vec![0.0; n],
            xold2: vec![0.0; n],
            sub: SubSolver::new(n, m, parallel),
            dual,
            raa,
            xsi: vec![0.0; n],
            eta: vec![0.0; n],
        })
    }

    /// Number of design variables.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of constraints.
    pub fn m(&self) -> usize {
        self.m
    }

    /// Parameters in use.
    pub fn params(&self) -> &MmaParams {
        &self.params
    }

    /// Lower bounds.
    pub fn xmin(&self) -> &[f64] {
        &self.xmin
    }

    /// Upper bounds.
    pub fn xmax(&self) -> &[f64] {
        &self.xmax
    }

    /// Number of updates done since construction or the last [`Mma::reset`].
    pub fn iteration(&self) -> usize {
        self.iter
    }

    /// Forgets the history: the next update re-initialises the asymptotes.
    pub fn reset(&mut self) {
        self.iter = 0;
    }

    /// A copy of the history (see [`MmaState`]), e.g. for a checkpoint.
    pub fn state(&self) -> MmaState {
        MmaState {
            iteration: self.iter,
            xold1: self.xold1.clone(),
            xold2: self.xold2.clone(),
            low: self.low().collect(),
            upp: self.upp().collect(),
            lam: self.sub.lam.clone(),
            y: self.sub.y.clone(),
            z: self.sub.z,
            mu: self.sub.mu.clone(),
            zet: self.sub.zet,
            s: self.sub.s.clone(),
            xsi: self.xsi.clone(),
            eta: self.eta.clone(),
        }
    }

    /// Restores a history saved by [`Mma::state`] from an optimizer with the same `n` and `m`.
    ///
    /// # Errors
    /// [`MmaError::DimensionMismatch`] if a vector has the wrong length, [`MmaError::NonFinite`]
    /// for NaN/∞; the optimizer is left unchanged then.
    pub fn restore(&mut self, state: &MmaState) -> Result<(), MmaError> {
        let (n, m) = (self.n, self.m);
        for (name, v, len) in [
            ("state.xold1", &state.xold1, n),
            ("state.xold2", &state.xold2, n),
            ("state.low", &state.low, n),
            ("state.upp", &state.upp, n),
            ("state.xsi", &state.xsi, n),
            ("state.eta", &state.eta, n),
            ("state.lam", &state.lam, m),
            ("state.y", &state.y, m),
            ("state.mu", &state.mu, m),
            ("state.s", &state.s, m),
        ] {
            check_len(name, v, len)?;
            check_finite(name, v, false)?;
        }
        check_finite("state.z", &[state.z, state.zet], false)?;
        self.iter = state.iteration;
        self.xold1.copy_from_slice(&state.xold1);
        self.xold2.copy_from_slice(&state.xold2);
        let stride = self.sub.stride;
        for j in 0..n {
            self.sub.nodes[idx(j, LOW, stride)] = state.low[j];
            self.sub.nodes[idx(j, UPP, stride)] = state.upp[j];
        }
        self.sub.lam.copy_from_slice(&state.lam);
        self.sub.y.copy_from_slice(&state.y);
        self.sub.mu.copy_from_slice(&state.mu);
        self.sub.s.copy_from_slice(&state.s);
        self.sub.z = state.z;
        self.sub.zet = state.zet;
        self.xsi.copy_from_slice(&state.xsi);
        self.eta.copy_from_slice(&state.eta);
        Ok(())
    }

    /// Lower asymptotes used by the last update (an empty-history optimizer returns zeros).
    pub fn low(&self) -> impl ExactSizeIterator<Item = f64> + '_ {
        (0..self.n).map(|j| self.sub.nodes[idx(j, LOW, self.sub.stride)])
    }

    /// Upper asymptotes used by the last update.
    pub fn upp(&self) -> impl ExactSizeIterator<Item = f64> + '_ {
        (0..self.n).map(|j| self.sub.nodes[idx(j, UPP, self.sub.stride)])
    }

    /// Lagrange multipliers λ of the constraints from the last subproblem.
    pub fn lambda(&self) -> &[f64] {
        &self.sub.lam
    }

    /// All multipliers of the last subproblem (λ, y, z, μ, ζ, s, ξ, η), as needed by
    /// [`kkt_residual`].
    pub fn multipliers(&self) -> Multipliers<'_> {
        Multipliers {
            lam: &self.sub.lam,
            y: &self.sub.y,
            z: self.sub.z,
            mu: &self.sub.mu,
            zet: self.sub.zet,
            s: &self.sub.s,
            xsi: &self.xsi,
            eta: &self.eta,
        }
    }

    /// KKT residual of the original problem at `x` (typically just after an update and a new
    /// evaluation), using this optimizer's bounds, parameters and [`Mma::multipliers`].
    ///
    /// # Errors
    /// As [`kkt_residual`].
    pub fn kkt_residual(
        &self,
        x: &[f64],
        df0dx: &[f64],
        f: &[f64],
        dfdx: &[f64],
    ) -> Result<KktResidual, MmaError> {
        kkt_residual(
            &KktProblem {
                x,
                xmin: &self.xmin,
                xmax: &self.xmax,
                df0dx,
                f,
                dfdx,
            },
            &self.multipliers(),
            &self.params,
        )
    }

    /// One MMA iteration: builds the subproblem at `x` from the function values and
    /// gradients, solves it, and overwrites `x` with its solution.
    ///
    /// * `x`: current iterate (length n, within the bounds); replaced by the new iterate.
    /// * `f0`: objective value (checked for finiteness; MMA itself only uses gradients).
    /// * `df0dx`: objective gradient (length n).
    /// * `f`: constraint values `fᵢ(x)` (length m), feasible when `≤ 0`.
    /// * `dfdx`: constraint gradients, `m × n` row-major: `dfdx[i * n + j] = ∂fᵢ/∂xⱼ`.
    ///
    /// # Errors
    /// [`MmaError::DimensionMismatch`], [`MmaError::NonFinite`] or [`MmaError::OutOfBounds`]
    /// for bad input; `x` and the internal state are left unchanged then.
    /// [`MmaError::NonFinite`] naming `x (new iterate)`, an asymptote or a multiplier when the
    /// update itself produced NaN or ∞ (checked where it is produced): the new state is then
    /// unusable (restore a saved [`MmaState`] or start over).
    pub fn update(
        &mut self,
        x: &mut [f64],
        f0: f64,
        df0dx: &[f64],
        f: &[f64],
        dfdx: &[f64],
    ) -> Result<UpdateReport, MmaError> {
        let (n, m) = (self.n, self.m);
        let par = self.sub.parallel;
        check_len("x", x, n)?;
        check_len("df0dx", df0dx, n)?;
        check_len("f", f, m)?;
        check_len("dfdx", dfdx, m * n)?;
        check_finite("f0", &[f0], false)?;
        check_finite("x", x, par)?;
        check_finite("df0dx", df0dx, par)?;
        check_finite("f", f, false)?;
        check_finite("dfdx", dfdx, par)?;
        let inside = |j: usize| self.xmin[j] <= x[j] && x[j] <= self.xmax[j];
        if !all_ok(n, par, inside) {
            let index = (0..n).find(|&j| !inside(j)).unwrap_or(0);
            return Err(MmaError::OutOfBounds {
                index,
                value: x[index],
                lower: self.xmin[index],
                upper: self.xmax[index],
            });
        }

        self.iter += 1;
        let p = self.params;
        let k = SubConsts {
            a0: p.a0,
            a: p.a,
            c: p.c,
            d: p.d,
            epsimin: p.subproblem_tolerance,
        };
        let report = match self.dual.take() {
            Some(mut dual) => {
                let report = self.dual_update(&mut dual, x, df0dx, f, dfdx, &k);
                self.dual = Some(dual);
                match report {
                    Some(report) => report,
                    None => {
                        // Fall back to subsolv on the same subproblem.
                        self.build_subproblem(x, df0dx, f, dfdx, Build::PqOnly);
                        self.primal_dual(x, &k)
                    }
                }
            }
            None => {
                self.build_subproblem(x, df0dx, f, dfdx, Build::Full);
                self.primal_dual(x, &k)
            }
        };
        self.check_new_state(x)?;
        Ok(report)
    }

    /// `Ok` when the new iterate, the asymptotes and the multipliers of the update are all
    /// finite, else [`MmaError::NonFinite`] naming the first that is not.
    fn check_new_state(&self, x: &[f64]) -> Result<(), MmaError> {
        let (n, par, stride) = (self.n, self.sub.parallel, self.sub.stride);
        check_finite("x (new iterate)", x, par)?;
        for (name, col) in [("low (asymptotes)", LOW), ("upp (asymptotes)", UPP)] {
            let at = |j: usize| self.sub.nodes[idx(j, col, stride)];
            if !all_ok(n, par, |j| at(j).is_finite()) {
                let index = (0..n).find(|&j| !at(j).is_finite()).unwrap_or(0);
                return Err(MmaError::NonFinite {
                    name,
                    index,
                    value: at(index),
                });
            }
        }
        check_finite("xsi (bound multipliers)", &self.xsi, par)?;
        check_finite("eta (bound multipliers)", &self.eta, par)?;
        check_finite("lam (constraint multipliers)", &self.sub.lam, false)?;
        check_finite("y (artificial variables)", &self.sub.y, false)?;
        check_finite("mu (multipliers of y)", &self.sub.mu, false)?;
        check_finite("s (slacks)", &self.sub.s, false)?;
        check_finite("z, zet", &[self.sub.z, self.sub.zet], false)
    }

    /// Builds the subproblem without p/q and solves it with the dual solver; `None` (with
    /// `x` and the history untouched) if that fails.
    fn dual_update(
        &mut self,
        dual: &mut DualSolver,
        x: &mut [f64],
        df0dx: &[f64],
        f: &[f64],
        dfdx: &[f64],
        k: &SubConsts,
    ) -> Option<UpdateReport> {
        let (n, m) = (self.n, self.m);
        self.build_subproblem(x, df0dx, f, dfdx, Build::Bounds);
        let data = DualData {
            n,
            m,
            nodes: &self.sub.nodes,
            stride: self.sub.stride,
            df0dx,
            dfdx,
            raa: &self.raa,
            b: &self.sub.b,
        };
        // Warm start from the previous subproblem's multipliers (part of MmaState, so a
        // restored optimizer starts from the same point).
        let warm = (self.iter > 1).then_some(WarmStart {
            lam: &self.sub.lam,
            y: &self.sub.y,
            s: &self.sub.s,
            z: self.sub.z,
        });
        let rep = dual.solve(&data, x, k, warm)?;
        std::mem::swap(&mut self.xold1, &mut self.xold2);
        let max_change = dual.finish(&data, x, &mut self.xold1, &mut self.xsi, &mut self.eta);
        let sub = &mut self.sub;
        dual.multipliers(
            k,
            SubMultipliers {
                lam: &mut sub.lam,
                y: &mut sub.y,
                z: &mut sub.z,
                mu: &mut sub.mu,
                zet: &mut sub.zet,
                s: &mut sub.s,
            },
        );
        Some(UpdateReport {
            iteration: self.iter,
            max_change,
            subproblem_iterations: rep.iterations,
            subproblem_residual: rep.residual_norm,
            subsolver: Subsolver::Dual,
        })
    }

    /// Solves the subproblem built in `nodes` with `subsolv` and writes the result back.
    fn primal_dual(&mut self, x: &mut [f64], k: &SubConsts) -> UpdateReport {
        let rep = self.sub.solve(k);
        // xold2 <- xold1, xold1 <- x, x <- xmma; expose ξ, η.
        std::mem::swap(&mut self.xold1, &mut self.xold2);
        let max_change = self.write_back(x);
        UpdateReport {
            iteration: self.iter,
            max_change,
            subproblem_iterations: rep.iterations,
            subproblem_residual: rep.residual_norm,
            subsolver: Subsolver::PrimalDual,
        }
    }

    /// Copies x into xold1 and the subproblem solution into x, ξ, η; returns the max change.
    fn write_back(&mut self, x: &mut [f64]) -> f64 {
        let sub = &self.sub;
        x.par_chunks_mut(CHUNK)
            .zip(self.xold1.par_chunks_mut(CHUNK))
            .zip(
                self.xsi
                    .par_chunks_mut(CHUNK)
                    .zip(self.eta.par_chunks_mut(CHUNK)),
            )
            .zip(sub.state.par_chunks(CHUNK * NSTATE))
            .with_min_len(min_len(sub.parallel))
            .map(|(((xs, xo), (xsi, eta)), st)| write_chunk(xs, xo, xsi, eta, st))
            .reduce(|| 0.0, f64::max)
    }

    /// Asymptotes, move limits α, β, and the p/q approximations (`mmasub`); `b`.
    fn build_subproblem(&mut self, x: &[f64], df0dx: &[f64], f: &[f64], dfdx: &[f64], what: Build) {
        let (n, m) = (self.n, self.m);
        let ctx = BuildCtx {
            n,
            m,
            p: self.params,
            init: self.iter <= 2,
            what,
            x,
            xold1: &self.xold1,
            xold2: &self.xold2,
            xmin: &self.xmin,
            xmax: &self.xmax,
            df0dx,
            dfdx,
        };
        let stride = self.sub.stride;
        let slot = self.sub.slot;
        let f_chunk = |(c, (nodes, acc)): (usize, (&mut [f64], &mut [f64]))| {
            build_chunk(&ctx, c, nodes, &mut acc[..m]);
        };
        self.sub
            .nodes
            .par_chunks_mut(CHUNK * stride)
            .zip(self.sub.acc.par_chunks_mut(slot))
            .enumerate()
            .with_min_len(min_len(self.sub.parallel))
            .for_each(f_chunk);
        for (b, fi) in self.sub.b.iter_mut().zip(f) {
            *b = -fi;
        }
        for acc in self.sub.acc.chunks_exact(slot) {
            for (b, a) in self.sub.b.iter_mut().zip(acc) {
                *b += a;
            }
        }
    }
}

/// Copies x into xold1, the new iterate into x and ξ, η out (one chunk of `state`);
/// returns the max change.
fn write_chunk(
    xs: &mut [f64],
    xo: &mut [f64],
    xsi: &mut [f64],
    eta: &mut [f64],
    st: &[f64],
) -> f64 {
    let mut ch = 0.0f64;
    for k in 0..xs.len() {
        let xn = st[X * CHUNK + k];
        xo[k] = xs[k];
        ch = ch.max((xn - xs[k]).abs());
        xs[k] = xn;
        xsi[k] = st[XSI * CHUNK + k];
        eta[k] = st[ETA * CHUNK + k];
    }
    ch
}

/// The regularisation `raa0 / max(xmax − xmin, 1e-5)` of the p/q coefficients.
fn raa_term(raa0: f64, range: f64) -> f64 {
    raa0 * (1.0 / range.max(1e-5))
}

/// What [`Mma::build_subproblem`] writes to `nodes`.
#[derive(Clone, Copy, PartialEq)]
enum Build {
    /// Asymptotes, α, β and the p/q coefficients (for `subsolv`).
    Full,
    /// Asymptotes, α and β only (the dual solver recomputes p and q).
    Bounds,
    /// The p/q coefficients for the asymptotes already in `nodes` (fallback to `subsolv`).
    PqOnly,
}

struct BuildCtx<'a> {
    n: usize,
    m: usize,
    p: MmaParams,
    init: bool,
    what: Build,
    x: &'a [f64],
    xold1: &'a [f64],
    xold2: &'a [f64],
    xmin: &'a [f64],
    xmax: &'a [f64],
    df0dx: &'a [f64],
    dfdx: &'a [f64],
}

#[multiversion(targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"))]
fn build_chunk<'a>(ctx: &BuildCtx<'a>, c: usize, nodes: &mut [f64], b: &mut [f64]) {
    let (n, m, p) = (ctx.n, ctx.m, &ctx.p);
    let stride = PQ + 2 * m;
    let start = c * CHUNK;
    let len = (n - start).min(CHUNK);
    debug_assert_eq!(nodes.len(), CHUNK * stride);
    b.fill(0.0);
    for k in 0..len {
        let j = start + k;
        let nd = |f: usize| f * CHUNK + k;
        let xv = ctx.x[j];
        let (xmin, xmax) = (ctx.xmin[j], ctx.xmax[j]);
        let range = xmax - xmin;
        let (low, upp) = if ctx.what == Build::PqOnly {
            (nodes[nd(LOW)], nodes[nd(UPP)])
        } else if ctx.init {
            (xv - p.asyinit * range, xv + p.asyinit * range)
        } else {
            let (xo1, xo2) = (ctx.xold1[j], ctx.xold2[j]);
            let zzz = (xv - xo1) * (xo1 - xo2);
            let factor = if zzz > 0.0 {
                p.asyincr
            } else if zzz < 0.0 {
                p.asydecr
            } else {
                1.0
            };
            let low = xv - factor * (xo1 - nodes[nd(LOW)]);
            let upp = xv + factor * (nodes[nd(UPP)] - xo1);
            let low = low.max(xv - p.asymax * range).min(xv - p.asymin * range);
            let upp = upp.min(xv + p.asymax * range).max(xv + p.asymin * range);
            (low, upp)
        };
        let alfa = (low + p.albefa * (xv - low))
            .max(xv - p.move_limit * range)
            .max(xmin);
        let beta = (upp - p.albefa * (upp - xv))
            .min(xv + p.move_limit * range)
            .min(xmax);
        let raa = raa_term(p.raa0, range);
        let ux1 = upp - xv;
        let xl1 = xv - low;
        let (ux2, xl2) = (ux1 * ux1, xl1 * xl1);
        let (uxinv, xlinv) = (1.0 / ux1, 1.0 / xl1);
        let store_pq = ctx.what != Build::Bounds;
        if ctx.what != Build::PqOnly {
            nodes[nd(LOW)] = low;
            nodes[nd(UPP)] = upp;
            nodes[nd(ALFA)] = alfa;
            nodes[nd(BETA)] = beta;
        }
        if store_pq {
            let (p0, q0) = pq(ctx.df0dx[j], ux2, xl2, raa);
            nodes[nd(P0)] = p0;
            nodes[nd(Q0)] = q0;
        }
        for i in 0..m {
            let (pij, qij) = pq(ctx.dfdx[i * n + j], ux2, xl2, raa);
            if store_pq {
                nodes[nd(PQ + i)] = pij;
                nodes[nd(PQ + m + i)] = qij;
            }
            b[i] += pij * uxinv + qij * xlinv;
        }
    }
}
