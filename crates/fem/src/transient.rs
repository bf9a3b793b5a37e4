//! Implicit nonlinear transient dynamics on the FE model: Newmark's average-acceleration rule
//! and its HHT-α generalization, with Newton iterations on the Total Lagrangian residual at
//! every step.
//!
//! # Equations
//! With the mass matrix `M` ([`crate::mass`]), Rayleigh damping `C = a_M M + b_K K₀` (`K₀` the
//! tangent at `u = 0`, springs included, so that `C` is constant) and the nonlinear residual
//! `R(u)` of [`crate::Model::assemble`] (internal forces + grounded springs), the semi-discrete
//! equation of motion is `M ü + C u̇ + R(u) = P(t)`. The HHT-α method (Hilber, Hughes & Taylor,
//! *Earthquake Eng. Struct. Dyn.* 5 (1977) 283–292) enforces, at every step,
//!
//! ```text
//! M a₊ + (1+α)(C v₊ + R(u₊)) − α(C v + R(u)) = (1+α) P₊ − α P,          α ∈ [−⅓, 0]
//! u₊ = u + Δt v + Δt²[(½ − β) a + β a₊],   v₊ = v + Δt[(1 − γ) a + γ a₊]
//! β = (1 − α)²/4,   γ = ½ − α
//! ```
//!
//! (`₊` = at `t + Δt`). `α = 0` is Newmark's average-acceleration (trapezoidal) rule:
//! unconditionally stable, second-order, no numerical damping, and for a linear undamped
//! system it conserves `½vᵀMv + ½uᵀKu` exactly. Its only error is a period elongation: a mode
//! of frequency ω is integrated with `ω̄ = (2/Δt)·atan(ωΔt/2)` ([`newmark_frequency`]).
//! `α < 0` damps the highest modes (HHT).
//!
//! # Newton per step
//! The unknown is `u₊`; `a₊ = c₀(u₊ − ũ)`, `v₊ = ṽ + γΔt a₊` with the predictors
//! `ũ = u + Δt v + Δt²(½ − β)a`, `ṽ = v + (1 − γ)Δt a` and `c₀ = 1/(βΔt²)`. The residual above
//! is linearized with the effective matrix `K* = c₀ M + (1+α)(c₁ C + K_T)`, `c₁ = γ/(βΔt)`.
//! The factorization of `K*` is kept across iterations and steps (modified Newton) and is
//! refreshed with the current tangent when an iteration reduces the residual by less than
//! [`TransientParams::refactor_ratio`]; with linear kinematics it is factored once. A step
//! converges when the free-DOF residual is below `residual_tol` times the force scale
//! (the load, the internal force or the inertial force, whichever is largest).
//!
//! The workspace is allocated once ([`Transient::new`]); a step allocates nothing.

use crate::error::{ParamError, SolverError, check_range};
use crate::model::{AssemblyWorkspace, Design, Model, SparseMatrix};
use crate::solver::{Factor, SolveWorkspace, SymbolicFactor};

/// Rayleigh damping `C = mass·M + stiffness·K₀`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RayleighDamping {
    /// Mass-proportional coefficient `a_M` [1/s], ≥ 0.
    pub mass: f64,
    /// Stiffness-proportional coefficient `b_K` \[s\], ≥ 0.
    pub stiffness: f64,
}

impl RayleighDamping {
    /// No damping.
    pub fn none() -> Self {
        Self::default()
    }

    /// The coefficients that give damping ratio `zeta[i]` at frequency `freq[i]` \[Hz\]
    /// (`ζ(ω) = a_M/(2ω) + b_K ω/2`). `freq[0] < freq[1]`, both > 0; ratios in [0, 1).
    pub fn from_ratios(freq: [f64; 2], zeta: [f64; 2]) -> Result<Self, ParamError> {
        check_range(
            "RayleighDamping::freq[0]",
            freq[0],
            1e-12,
            f64::MAX,
            "(0, ∞) Hz",
        )?;
        check_range(
            "RayleighDamping::freq[1]",
            freq[1],
            freq[0] * (1.0 + 1e-9),
            f64::MAX,
            "(freq[0], ∞) Hz",
        )?;
        for z in zeta {
            check_range("RayleighDamping::zeta", z, 0.0, 0.999, "[0, 1)")?;
        }
        let w = freq.map(|f| std::f64::consts::TAU * f);
        // [1/(2w0) w0/2; 1/(2w1) w1/2] [a; b] = [z0; z1]
        let det = 0.25 * (w[1] / w[0] - w[0] / w[1]);
        let a = (zeta[0] * w[1] / 2.0 - zeta[1] * w[0] / 2.0) / det;
        let b = (zeta[1] / (2.0 * w[0]) - zeta[0] / (2.0 * w[1])) / det;
        Ok(Self {
            mass: a.max(0.0),
            stiffness: b.max(0.0),
        })
    }

    /// Damping ratio at frequency `f` \[Hz\].
    pub fn ratio(&self, f: f64) -> f64 {
        let w = std::f64::consts::TAU * f;
        self.mass / (2.0 * w) + self.stiffness * w / 2.0
    }
}

/// The frequency [rad/s] with which average-acceleration Newmark integrates an undamped mode
/// of frequency `omega` [rad/s] at step `dt`: `ω̄ = (2/Δt)·atan(ωΔt/2)` (period elongation;
/// e.g. Hughes, *The Finite Element Method*, 1987, §9.3).
pub fn newmark_frequency(omega: f64, dt: f64) -> f64 {
    2.0 / dt * (0.5 * omega * dt).atan()
}

/// Parameters of the transient solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TransientParams {
    /// Time step Δt \[s\], in (0, 1].
    pub dt: f64,
    /// HHT parameter α, in [−⅓, 0]. 0 (default) = Newmark average acceleration.
    pub hht_alpha: f64,
    /// Residual tolerance relative to the force scale, in (0, 1e-3]. Default 1e-10.
    pub residual_tol: f64,
    /// Newton iterations per step, in [1, 100]. Default 25.
    pub max_iterations: usize,
    /// Refactor `K*` when an iteration reduces the residual by less than this factor
    /// (ratio new/old above it), in (0, 1). Default 0.1.
    pub refactor_ratio: f64,
}

impl Default for TransientParams {
    fn default() -> Self {
        Self {
            dt: 1e-6,
            hht_alpha: 0.0,
            residual_tol: 1e-10,
            max_iterations: 25,
            refactor_ratio: 0.1,
        }
    }
}

impl TransientParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_range("TransientParams::dt", self.dt, 1e-15, 1.0, "(0, 1] s")?;
        check_range(
            "TransientParams::hht_alpha",
            self.hht_alpha,
            -1.0 / 3.0,
            0.0,
            "[-1/3, 0]",
        )?;
        check_range(
            "TransientParams::residual_tol",
            self.residual_tol,
            1e-16,
            1e-3,
            "(0, 1e-3]",
        )?;
        check_range(
            "TransientParams::max_iterations",
            self.max_iterations as f64,
            1.0,
            100.0,
            "[1, 100]",
        )?;
        check_range(
            "TransientParams::refactor_ratio",
            self.refactor_ratio,
            1e-6,
            0.999,
            "(0, 1)",
        )
    }
}

/// Why a transient step failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TransientError {
    /// Invalid parameters or inputs.
    #[error(transparent)]
    Param(#[from] ParamError),
    /// A factorization or solve failed.
    #[error(transparent)]
    Solver(#[from] SolverError),
    /// Newton did not converge within the iteration limit.
    #[error(
        "transient step at t = {time:.6e} s did not converge: relative residual {residual:.3e} \
         after {iterations} iterations (tolerance {tolerance:.1e}); reduce the time step"
    )]
    NotConverged {
        /// Time at the end of the failed step \[s\].
        time: f64,
        /// Last relative residual.
        residual: f64,
        /// Iterations made.
        iterations: usize,
        /// Requested tolerance.
        tolerance: f64,
    },
    /// The initial acceleration needs `M⁻¹`, but `M` is singular (massless DOFs).
    #[error(
        "the mass matrix is singular (massless DOFs), so the initial acceleration cannot be \
         computed from an out-of-balance state; start from equilibrium or give it"
    )]
    SingularMass,
}

/// Counters of a transient run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TransientStats {
    /// Steps taken.
    pub steps: usize,
    /// Newton iterations (linear solves).
    pub iterations: usize,
    /// Residual assemblies.
    pub assemblies: usize,
    /// Numeric factorizations of `K*`.
    pub factorizations: usize,
}

/// The transient solver with its state `(t, u, v, a)` and all buffers.
pub struct Transient<'a> {
    model: &'a Model,
    design: Design<'a>,
    mass: SparseMatrix,
    k0: SparseMatrix,
    damping: RayleighDamping,
    params: TransientParams,
    beta: f64,
    gamma: f64,
    time: f64,
    u: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
    /// `C v + R(u)` at the current state (full), for the HHT balance.
    force: Vec<f64>,
    /// `P` at the current time (full).
    load: Vec<f64>,
    // Scratch.
    tangent: SparseMatrix,
    effective: SparseMatrix,
    factor: Factor,
    factored: bool,
    solve_ws: SolveWorkspace,
    assembly: AssemblyWorkspace,
    r_full: Vec<f64>,
    u_pred: Vec<f64>,
    v_pred: Vec<f64>,
    u_new: Vec<f64>,
    v_new: Vec<f64>,
    a_new: Vec<f64>,
    red_a: Vec<f64>,
    red_b: Vec<f64>,
    red_c: Vec<f64>,
    stats: TransientStats,
}

impl std::fmt::Debug for Transient<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Transient")
            .field("time", &self.time)
            .field("params", &self.params)
            .field("damping", &self.damping)
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

impl<'a> Transient<'a> {
    /// A solver at rest (`u = v = a = 0`, `P = 0`, `t = 0`) for `model` with densities
    /// `design`, mass matrix `mass` (from [`crate::mass::consistent_mass`] on this model) and
    /// Rayleigh damping.
    pub fn new(
        model: &'a Model,
        design: Design<'a>,
        mass: SparseMatrix,
        damping: RayleighDamping,
        params: TransientParams,
    ) -> Result<Self, TransientError> {
        params.validate()?;
        design.validate(model.mesh().n_elements())?;
        check_range(
            "RayleighDamping::mass",
            damping.mass,
            0.0,
            f64::MAX,
            "[0, ∞) 1/s",
        )?;
        check_range(
            "RayleighDamping::stiffness",
            damping.stiffness,
            0.0,
            f64::MAX,
            "[0, ∞) s",
        )?;
        if **mass.pattern() != **model.pattern() {
            return Err(SolverError::PatternMismatch {
                what: "the mass matrix is not in the model's pattern",
            }
            .into());
        }
        let nf = model.n_dofs();
        let n = model.dofs().n_free();
        let symbolic = SymbolicFactor::for_model(model)?;
        let mut assembly = model.new_workspace();
        let mut k0 = model.new_matrix();
        let zero = model.zero_vector();
        model.assemble(&design, &zero, None, Some(&mut k0), &mut assembly);
        let alpha = params.hht_alpha;
        Ok(Self {
            model,
            design,
            mass,
            k0,
            damping,
            params,
            beta: 0.25 * (1.0 - alpha) * (1.0 - alpha),
            gamma: 0.5 - alpha,
            time: 0.0,
            u: vec![0.0; nf],
            v: vec![0.0; nf],
            a: vec![0.0; nf],
            force: vec![0.0; nf],
            load: vec![0.0; nf],
            tangent: model.new_matrix(),
            effective: model.new_matrix(),
            solve_ws: SolveWorkspace::new(&symbolic),
            factor: Factor::new(symbolic),
            factored: false,
            assembly,
            r_full: vec![0.0; nf],
            u_pred: vec![0.0; nf],
            v_pred: vec![0.0; nf],
            u_new: vec![0.0; nf],
            v_new: vec![0.0; nf],
            a_new: vec![0.0; nf],
            red_a: vec![0.0; n],
            red_b: vec![0.0; n],
            red_c: vec![0.0; n],
            stats: TransientStats::default(),
        })
    }

    /// Sets the state at time `t`: displacement `u`, velocity `v` and load `p` (full vectors;
    /// fixed entries are ignored). The acceleration follows from `M a = P − C v − R(u)`; this
    /// needs a non-singular `M` unless the state is in equilibrium at rest.
    pub fn set_state(
        &mut self,
        t: f64,
        u: &[f64],
        v: &[f64],
        p: &[f64],
    ) -> Result<(), TransientError> {
        let nf = self.model.n_dofs();
        for (what, x) in [("u", u), ("v", v), ("p", p)] {
            crate::error::check_len(what, x.len(), nf)?;
            if let Some(i) = x.iter().position(|y| !y.is_finite()) {
                return Err(ParamError::NonFinite { what, index: i }.into());
            }
        }
        let dofs = self.model.dofs();
        dofs.scatter_clean(u, &mut self.u);
        dofs.scatter_clean(v, &mut self.v);
        self.load.copy_from_slice(p);
        self.time = t;
        self.update_force();
        // Out-of-balance force P − C v − R(u) on the free DOFs.
        let mut scale = 0.0f64;
        for (k, &d) in dofs.free_dofs().iter().enumerate() {
            self.red_a[k] = self.load[d] - self.force[d];
            scale = scale.max(self.load[d].abs()).max(self.force[d].abs());
        }
        self.a.fill(0.0);
        if norm(&self.red_a) <= 1e-14 * scale.max(f64::MIN_POSITIVE) * (dofs.n_free() as f64).sqrt()
        {
            return Ok(());
        }
        let mut mf = Factor::new(self.factor.symbolic().clone());
        mf.allow_indefinite = false;
        mf.factorize(&self.mass)
            .map_err(|_| TransientError::SingularMass)?;
        mf.solve_in_place(&mut self.red_a, &mut self.solve_ws)?;
        dofs.scatter(&self.red_a, &mut self.a);
        Ok(())
    }

    /// `force = C v + R(u)` at the current state.
    fn update_force(&mut self) {
        self.model.assemble(
            &self.design,
            &self.u,
            Some(&mut self.force),
            None,
            &mut self.assembly,
        );
        self.stats.assemblies += 1;
        let dofs = self.model.dofs();
        self.damping_force(true);
        for (k, &d) in dofs.free_dofs().iter().enumerate() {
            self.force[d] += self.red_b[k];
        }
    }

    /// `red_b = C v` for the current (`current = true`) or trial velocity, reduced numbering.
    fn damping_force(&mut self, current: bool) {
        let dofs = self.model.dofs();
        let v = if current { &self.v } else { &self.v_new };
        dofs.gather(v, &mut self.red_a);
        self.red_b.fill(0.0);
        if self.damping.mass != 0.0 {
            self.mass.matvec(&self.red_a, &mut self.red_c);
            for (b, c) in self.red_b.iter_mut().zip(&self.red_c) {
                *b += self.damping.mass * c;
            }
        }
        if self.damping.stiffness != 0.0 {
            self.k0.matvec(&self.red_a, &mut self.red_c);
            for (b, c) in self.red_b.iter_mut().zip(&self.red_c) {
                *b += self.damping.stiffness * c;
            }
        }
    }

    /// Refills `K* = c₀M + (1+α)(c₁C + K_T(u_new))` and factors it.
    fn refactor(&mut self) -> Result<(), TransientError> {
        let (dt, alpha) = (self.params.dt, self.params.hht_alpha);
        let c0 = 1.0 / (self.beta * dt * dt);
        let c1 = self.gamma / (self.beta * dt);
        self.model.assemble(
            &self.design,
            &self.u_new,
            None,
            Some(&mut self.tangent),
            &mut self.assembly,
        );
        let (am, bk) = (self.damping.mass, self.damping.stiffness);
        let ev = self.effective.values_mut();
        let (mv, kv, tv) = (self.mass.values(), self.k0.values(), self.tangent.values());
        for i in 0..ev.len() {
            ev[i] = c0 * mv[i] + (1.0 + alpha) * (c1 * (am * mv[i] + bk * kv[i]) + tv[i]);
        }
        self.factor.factorize(&self.effective)?;
        self.factored = true;
        self.stats.factorizations += 1;
        Ok(())
    }

    /// Residual of the HHT balance at the trial state `u_new` (with `a_new`, `v_new` set), into
    /// `red_a` (free DOFs); returns its norm and the force scale.
    fn balance(&mut self, p_next: &[f64]) -> (f64, f64) {
        let alpha = self.params.hht_alpha;
        self.model.assemble(
            &self.design,
            &self.u_new,
            Some(&mut self.r_full),
            None,
            &mut self.assembly,
        );
        self.stats.assemblies += 1;
        self.damping_force(false); // red_b = C v_new
        let dofs = self.model.dofs();
        dofs.gather(&self.a_new, &mut self.red_a);
        self.mass.matvec(&self.red_a, &mut self.red_c); // M a_new
        let mut scale = 0.0f64;
        for (k, &d) in dofs.free_dofs().iter().enumerate() {
            let internal = self.r_full[d] + self.red_b[k];
            let external = (1.0 + alpha) * p_next[d] - alpha * self.load[d];
            self.red_a[k] =
                external - self.red_c[k] - (1.0 + alpha) * internal + alpha * self.force[d];
            scale = scale
                .max(p_next[d].abs())
                .max(self.r_full[d].abs())
                .max(self.red_c[k].abs());
        }
        (norm(&self.red_a), scale * (dofs.n_free() as f64).sqrt())
    }

    /// Advances one step to `t + Δt` under the load `p_next` (full vector at `t + Δt`; fixed
    /// entries ignored). Allocates nothing.
    pub fn step(&mut self, p_next: &[f64]) -> Result<(), TransientError> {
        crate::error::check_len("p_next", p_next.len(), self.model.n_dofs())?;
        let dt = self.params.dt;
        let (beta, gamma) = (self.beta, self.gamma);
        let c0 = 1.0 / (beta * dt * dt);
        for i in 0..self.u.len() {
            self.u_pred[i] = self.u[i] + dt * self.v[i] + dt * dt * (0.5 - beta) * self.a[i];
            self.v_pred[i] = self.v[i] + (1.0 - gamma) * dt * self.a[i];
            // Initial guess: a₊ = a.
            self.a_new[i] = self.a[i];
            self.u_new[i] = self.u_pred[i] + beta * dt * dt * self.a[i];
            self.v_new[i] = self.v_pred[i] + gamma * dt * self.a[i];
        }
        for &d in &self.model.bcs().fixed {
            self.u_new[d] = 0.0;
            self.v_new[d] = 0.0;
            self.a_new[d] = 0.0;
        }
        let linear = self.model.kinematics() == crate::Kinematics::Linear;
        if !self.factored {
            self.refactor()?;
        }
        let (mut res, mut scale) = self.balance(p_next);
        let tol = self.params.residual_tol;
        let mut iterations = 0;
        while res > tol * scale.max(f64::MIN_POSITIVE) {
            if iterations >= self.params.max_iterations {
                return Err(TransientError::NotConverged {
                    time: self.time + dt,
                    residual: res / scale.max(f64::MIN_POSITIVE),
                    iterations,
                    tolerance: tol,
                });
            }
            self.factor
                .solve_in_place(&mut self.red_a, &mut self.solve_ws)?;
            iterations += 1;
            let dofs = self.model.dofs();
            for (k, &d) in dofs.free_dofs().iter().enumerate() {
                self.u_new[d] += self.red_a[k];
            }
            for i in 0..self.u.len() {
                self.a_new[i] = c0 * (self.u_new[i] - self.u_pred[i]);
                self.v_new[i] = self.v_pred[i] + gamma * dt * self.a_new[i];
            }
            for &d in &self.model.bcs().fixed {
                self.a_new[d] = 0.0;
                self.v_new[d] = 0.0;
            }
            let (r, s) = self.balance(p_next);
            if !linear && r > self.params.refactor_ratio * res && r > tol * s {
                self.refactor()?;
            }
            res = r;
            scale = s;
            if !res.is_finite() {
                return Err(SolverError::NonFinite {
                    what: "transient residual",
                }
                .into());
            }
        }
        self.stats.iterations += iterations;
        self.stats.steps += 1;
        // Accept: keep C v₊ + R(u₊) and P₊ for the next HHT balance.
        std::mem::swap(&mut self.u, &mut self.u_new);
        std::mem::swap(&mut self.v, &mut self.v_new);
        std::mem::swap(&mut self.a, &mut self.a_new);
        let dofs = self.model.dofs();
        for (k, &d) in dofs.free_dofs().iter().enumerate() {
            self.force[d] = self.r_full[d] + self.red_b[k];
        }
        self.load.copy_from_slice(p_next);
        self.time += dt;
        Ok(())
    }

    /// Current time \[s\].
    pub fn time(&self) -> f64 {
        self.time
    }
    /// Current displacement (full vector).
    pub fn displacement(&self) -> &[f64] {
        &self.u
    }
    /// Current velocity (full vector).
    pub fn velocity(&self) -> &[f64] {
        &self.v
    }
    /// Current acceleration (full vector).
    pub fn acceleration(&self) -> &[f64] {
        &self.a
    }
    /// Run counters.
    pub fn stats(&self) -> TransientStats {
        self.stats
    }
    /// The mass matrix.
    pub fn mass(&self) -> &SparseMatrix {
        &self.mass
    }
    /// The tangent at `u = 0` used for the Rayleigh damping.
    pub fn initial_stiffness(&self) -> &SparseMatrix {
        &self.k0
    }

    /// Mechanical energy `½vᵀMv + W(u) + Σ ½ k u_dof²` (kinetic + strain + spring) \[J\].
    pub fn energy(&mut self) -> f64 {
        let dofs = self.model.dofs();
        dofs.gather(&self.v, &mut self.red_a);
        self.mass.matvec(&self.red_a, &mut self.red_c);
        let kinetic = 0.5
            * self
                .red_a
                .iter()
                .zip(&self.red_c)
                .map(|(x, y)| x * y)
                .sum::<f64>();
        let strain = self.model.strain_energy(&self.design, &self.u);
        let springs: f64 = self
            .model
            .bcs()
            .springs
            .iter()
            .map(|s| 0.5 * s.stiffness * self.u[s.dof] * self.u[s.dof])
            .sum();
        kinetic + strain + springs
    }
}

/// Scatter into a full vector, zeroing the fixed DOFs (the input is already full-length).
trait ScatterClean {
    fn scatter_clean(&self, src: &[f64], dst: &mut [f64]);
}

impl ScatterClean for crate::model::DofMap {
    fn scatter_clean(&self, src: &[f64], dst: &mut [f64]) {
        dst.fill(0.0);
        for &d in self.free_dofs() {
            dst[d] = src[d];
        }
    }
}
