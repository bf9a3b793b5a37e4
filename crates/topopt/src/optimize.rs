//! The design loop, paper Algorithm 1, written with the paper's symbols (top88 style):
//!
//! ```text
//! x⁰ = ρ_init;  β = 1;  c2 = c2⁰
//! for k = 0, 1, …:
//!     ρ = P_β(H x / Hs)                       filter and projection (crate::filter)
//!     u_j:  R(u_j, ρ) = P_j,  j = 1..p_m      FE analysis of all cases (parallel, warm start)
//!     J = ½ Σ_j u_oj × u_oj+1                  objective, Eq. (4)
//!     g = [Σ/Σ0 − 1, ‖u_in/max x_nom‖ − 1, tilt, V/V* − 1]   constraints, Eq. (5)
//!     ∇J, ∇g by adjoints                       crate::analysis
//!     stop if k ≥ max_iter, or β = β_max ∧ KKT < tol_kkt ∧ (Δx < tol_x ∨ stagnated)
//!     x ← MMA(x, −J/|J⁰|, g)                   density update
//!     c2 ← c2·√ω or c2·ω                       additive material update, Eq. (A3)
//!     β ← 2β every `interval` iterations up to β_max
//! ```
//!
//! Normalization for MMA: `f0 = −s_obj·Φ/|Φ⁰|` (Φ the maximized objective at the initial design
//! x⁰), every constraint scaled to O(1) as above; the tilt constraint is the scale-invariant
//! `((D·n)² − tan²τ (D·d)²) / (tan²τ |D|²)` with the *current* |D| (an earlier version divided
//! by the initial |D⁰|², which grows by the workspace growth factor squared and left θ = 20°
//! at 15° after 25 iterations).
//!
//! # Stopping rule
//!
//! `KKT` is Svanberg's `kktcheck` residual (max norm) of the *scaled* MMA problem at the new
//! design with the multipliers of the last subproblem, divided by `max(1, |f0|)` so that it is
//! a residual per unit objective (the workspace objective grows ~40× during a paper run).
//! An earlier version divided by `max_j |∂f0/∂x_j|`; at a converged 0/1 design the projection
//! makes every gradient tiny (paper run: max |∂f0/∂x| ≈ 9e-4 for f0 ≈ −40) and the largest
//! gradient sits on the one grey element MMA keeps oscillating (x ≈ 0.24 ↔ 0.25, the sign of
//! its gradient flipping), whose residual *is* its gradient: the ratio was ≈ 1.07 forever and
//! the run always hit the iteration cap.
//!
//! The classic test `max |Δx| < tol_x` alone never passes either, because of that oscillating
//! element (|Δx| ≈ 0.0077 at MMA's smallest asymptote distance). The loop therefore also
//! stops on *stagnation*, only once β has reached β_max for the whole window: over the last
//! `stagnation_window` = W iterations (records k−W..k) the objective Φ varies by at most
//! `stagnation_tolerance · |Φ_k|`, every update moved the densities by a mean |Δx| (over all
//! design variables) below `change_tolerance`, the constraints are satisfied (every scaled
//! gᵢ ≤ `kkt_tolerance`) and KKT < `kkt_tolerance`. W = 0 disables it.
//!
//! [`Optimizer::checkpoint`] captures everything the future of the run depends on (design,
//! MMA history, β, c2, the warm starts of every case, scales and history), so that
//! [`Optimizer::resume`] continues bitwise identically.

use std::time::Instant;

use flexstage_fem::{AdditiveYeoh, YeohUpdate};
use flexstage_mma::{Mma, MmaParams, MmaState};
use flexstage_scenario::Scenario;
use serde::{Deserialize, Serialize};

use crate::analysis::{AnalysisParams, Densities, Evaluation, Evaluator};
use crate::error::{Result, TopoptError, check_range};
use crate::filter::Projection;
use crate::problem::{EnergyLimit, Problem};

/// β continuation of the Heaviside projection.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ProjectionSchedule {
    /// Final β, in [1, 1024].
    pub beta_max: f64,
    /// Iterations between doublings, ≥ 1.
    pub interval: usize,
    /// Threshold η ∈ (0, 1).
    pub eta: f64,
}

/// The additive material (Appendix A).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdditiveParams {
    /// Initial c2 as a fraction of E0 (Table 3: 1e-5), ≥ 0.
    pub initial_coefficient: f64,
    /// ε* of Eq. (A3) (Table 3: 0.5), > 0.
    pub strain_threshold: f64,
}

/// Parameters of the design loop.
#[derive(Debug, Clone, PartialEq)]
pub struct OptimizerParams {
    /// Density-filter radius in element sizes, in [0, 20] (≤ 1 = off).
    pub filter_radius: f64,
    /// Maximum design iterations, in [0, 100000] (Table 3: 1000).
    pub max_iterations: usize,
    /// Stop tolerance on max |Δx| (and on the mean |Δx| of the stagnation test), in (0, 1).
    pub change_tolerance: f64,
    /// Stop tolerance on the KKT residual of the scaled MMA problem (max norm, per unit
    /// `max(1, |f0|)`, see the module docs), > 0.
    pub kkt_tolerance: f64,
    /// Stagnation window W in iterations (0 = no stagnation test), in [0, 10000].
    pub stagnation_window: usize,
    /// Largest relative variation of the objective over the stagnation window, in (0, 1).
    pub stagnation_tolerance: f64,
    /// Projection schedule (None = no projection).
    pub projection: Option<ProjectionSchedule>,
    /// Additive material (None = off).
    pub additive: Option<AdditiveParams>,
    /// Objective scale `s_obj` of the normalized MMA objective, > 0.
    pub objective_scale: f64,
    /// MMA constants.
    pub mma: MmaParams,
    /// FE analysis settings.
    pub analysis: AnalysisParams,
}

impl OptimizerParams {
    /// The scenario's `optimization` settings.
    pub fn from_scenario(s: &Scenario) -> Self {
        let o = &s.optimization;
        Self {
            filter_radius: o.filter_radius,
            max_iterations: o.max_iterations,
            change_tolerance: o.change_tolerance,
            kkt_tolerance: o.kkt_tolerance,
            stagnation_window: o.stagnation_window,
            stagnation_tolerance: o.stagnation_tolerance,
            projection: o.projection.enabled.then_some(ProjectionSchedule {
                beta_max: o.projection.beta_max,
                interval: o.projection.interval,
                eta: o.projection.eta,
            }),
            additive: o.additive.enabled.then_some(AdditiveParams {
                initial_coefficient: o.additive.initial_coefficient,
                strain_threshold: o.additive.strain_threshold,
            }),
            ..Self::default()
        }
    }

    /// Check every field.
    pub fn validate(&self) -> Result<()> {
        check_range(
            "OptimizerParams::filter_radius",
            self.filter_radius,
            (0.0..=20.0).contains(&self.filter_radius),
            "[0, 20]",
        )?;
        check_range(
            "OptimizerParams::max_iterations",
            self.max_iterations as f64,
            self.max_iterations <= 100_000,
            "[0, 100000]",
        )?;
        check_range(
            "OptimizerParams::change_tolerance",
            self.change_tolerance,
            self.change_tolerance > 0.0 && self.change_tolerance < 1.0,
            "(0, 1)",
        )?;
        check_range(
            "OptimizerParams::kkt_tolerance",
            self.kkt_tolerance,
            self.kkt_tolerance > 0.0,
            "(0, ∞)",
        )?;
        check_range(
            "OptimizerParams::stagnation_window",
            self.stagnation_window as f64,
            self.stagnation_window <= 10_000,
            "[0, 10000]",
        )?;
        check_range(
            "OptimizerParams::stagnation_tolerance",
            self.stagnation_tolerance,
            self.stagnation_tolerance > 0.0 && self.stagnation_tolerance < 1.0,
            "(0, 1)",
        )?;
        check_range(
            "OptimizerParams::objective_scale",
            self.objective_scale,
            self.objective_scale > 0.0 && self.objective_scale.is_finite(),
            "(0, ∞)",
        )?;
        if let Some(p) = self.projection {
            check_range(
                "OptimizerParams::projection.beta_max",
                p.beta_max,
                (1.0..=1024.0).contains(&p.beta_max),
                "[1, 1024]",
            )?;
            check_range(
                "OptimizerParams::projection.interval",
                p.interval as f64,
                p.interval >= 1,
                "[1, ∞)",
            )?;
            check_range(
                "OptimizerParams::projection.eta",
                p.eta,
                p.eta > 0.0 && p.eta < 1.0,
                "(0, 1)",
            )?;
        }
        if let Some(a) = self.additive {
            check_range(
                "OptimizerParams::additive.initial_coefficient",
                a.initial_coefficient,
                a.initial_coefficient >= 0.0,
                "[0, ∞)",
            )?;
            check_range(
                "OptimizerParams::additive.strain_threshold",
                a.strain_threshold,
                a.strain_threshold > 0.0,
                "(0, ∞)",
            )?;
        }
        self.analysis.validate()?;
        self.mma.validate().map_err(flexstage_mma::MmaError::from)?;
        Ok(())
    }
}

impl Default for OptimizerParams {
    fn default() -> Self {
        Self {
            filter_radius: 1.5,
            max_iterations: 1000,
            change_tolerance: 1e-3,
            kkt_tolerance: 1e-3,
            stagnation_window: 20,
            stagnation_tolerance: 1e-5,
            projection: None,
            additive: None,
            objective_scale: 1.0,
            mma: MmaParams {
                move_limit: 0.2,
                ..MmaParams::default()
            },
            analysis: AnalysisParams::default(),
        }
    }
}

/// One line of the history (CSV/JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IterationRecord {
    /// Design iteration k (0 = initial design).
    pub iteration: usize,
    /// Shoelace area J of the output polygon [m²] (workspace objective; 0 otherwise).
    pub area: f64,
    /// Maximized objective Φ (signed area [m²] or output displacement [m]).
    pub objective: f64,
    /// Normalized MMA objective f0.
    pub f0: f64,
    /// Normalized constraints (≤ 0 feasible), named in [`Optimizer::constraint_names`].
    pub constraints: Vec<f64>,
    /// Aggregated strain energy [J].
    pub energy: f64,
    /// Aggregated input stroke / max stroke.
    pub stroke: f64,
    /// Volume fraction of the design elements.
    pub volume: f64,
    /// Fraction of design elements with 0.1 < ρ < 0.9.
    pub grey: f64,
    /// max |Δx| of the MMA update that produced this design (0 at k = 0).
    pub change: f64,
    /// Mean |Δx| over the design variables of that update (0 at k = 0).
    #[serde(default)]
    pub mean_change: f64,
    /// KKT residual of the scaled MMA problem (max norm per unit `max(1, |f0|)`, see the
    /// module docs) at this design with the multipliers of that update (None at k = 0).
    pub kkt: Option<f64>,
    /// Projection sharpness β used.
    pub beta: f64,
    /// Newton iterations summed over the cases.
    pub newton_total: usize,
    /// Largest Newton iteration count of a case.
    pub newton_max: usize,
    /// Load cases that needed a cutback retry (logged).
    pub retried_cases: Vec<usize>,
    /// Wall time of this iteration [s].
    pub time: f64,
}

/// Why the loop stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum StopReason {
    /// Change and KKT residual below their tolerances at the final β.
    Converged,
    /// Objective, mean density change, feasibility and KKT residual stagnant over the
    /// stagnation window at the final β (module docs).
    Stagnated,
    /// Iteration limit reached.
    MaxIterations,
}

/// Fixed normalization constants, set at the initial design.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Scales {
    /// |Φ⁰|.
    pub objective: f64,
    /// Σ0 [J].
    pub energy_limit: f64,
    /// |D⁰|² [m²] at the initial design (diagnostic; the tilt constraint is normalized by the
    /// current |D|², see [`crate::Evaluation::tilt`]).
    pub tilt: f64,
}

/// The optimizer: state of Algorithm 1 between iterations.
pub struct Optimizer<'p> {
    /// The evaluator (FE cases and warm starts).
    pub evaluator: Evaluator<'p>,
    params: OptimizerParams,
    mma: Mma,
    x: Vec<f64>,
    beta: f64,
    iteration: usize,
    yeoh: Option<AdditiveYeoh>,
    yeoh_rule: Option<YeohUpdate>,
    scales: Option<Scales>,
    last_change: f64,
    last_mean_change: f64,
    history: Vec<IterationRecord>,
    last: Option<(Densities, Evaluation)>,
    stopped: Option<StopReason>,
}

/// Version of the checkpoint format: 2 added the adjoint warm starts.
const CHECKPOINT_VERSION: u32 = 2;

/// Serializable scalars of a checkpoint.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct CheckpointHeader {
    version: u32,
    n: usize,
    m: usize,
    cases: usize,
    dofs: usize,
    iteration: usize,
    beta: f64,
    last_change: f64,
    #[serde(default)]
    last_mean_change: f64,
    scales: Option<Scales>,
    mma_iteration: usize,
    mma_z: f64,
    mma_zet: f64,
    history: Vec<IterationRecord>,
    has_yeoh: bool,
}

const MAGIC: &[u8; 8] = b"FSTOPCK1";

impl<'p> Optimizer<'p> {
    /// Starts at the uniform initial design of the problem.
    pub fn new(problem: &'p Problem, params: OptimizerParams) -> Result<Self> {
        params.validate()?;
        let evaluator = Evaluator::new(problem, params.filter_radius, params.analysis)?;
        let n = evaluator.n();
        let m = Self::count_constraints(problem);
        let mma = Mma::new(n, m, vec![problem.rho_min; n], vec![1.0; n], params.mma)?;
        let ne = problem.mesh().n_elements();
        let (yeoh, yeoh_rule) = match params.additive {
            Some(a) => {
                let mat = problem.model.material();
                let mut y = AdditiveYeoh::paper(ne, mat.e0, problem.rho_min, mat.penalty);
                y.c2.iter_mut()
                    .for_each(|c| *c = a.initial_coefficient * mat.e0);
                let rule = YeohUpdate {
                    eps_star: a.strain_threshold,
                    ..YeohUpdate::paper(mat.e0)
                };
                (Some(y), Some(rule))
            }
            None => (None, None),
        };
        Ok(Self {
            evaluator,
            mma,
            x: vec![problem.initial_density; n],
            beta: if params.projection.is_some() {
                1.0
            } else {
                0.0
            },
            params,
            iteration: 0,
            yeoh,
            yeoh_rule,
            scales: None,
            last_change: 0.0,
            last_mean_change: 0.0,
            history: Vec::new(),
            last: None,
            stopped: None,
        })
    }

    fn count_constraints(p: &Problem) -> usize {
        p.energy_limit.is_some() as usize
            + p.max_stroke.is_some() as usize
            + p.tilt.is_some() as usize
            + p.volume_fraction.is_some() as usize
    }

    /// Names of the constraints, in the order of [`IterationRecord::constraints`].
    pub fn constraint_names(&self) -> Vec<&'static str> {
        let p = self.evaluator.problem;
        let mut v = Vec::new();
        if p.energy_limit.is_some() {
            v.push("energy");
        }
        if p.max_stroke.is_some() {
            v.push("stroke");
        }
        if p.tilt.is_some() {
            v.push("tilt");
        }
        if p.volume_fraction.is_some() {
            v.push("volume");
        }
        v
    }

    /// The current design variables.
    pub fn x(&self) -> &[f64] {
        &self.x
    }
    /// The next iteration's index.
    pub fn iteration(&self) -> usize {
        self.iteration
    }
    /// History so far.
    pub fn history(&self) -> &[IterationRecord] {
        &self.history
    }
    /// Densities and evaluation of the last iteration.
    pub fn last(&self) -> Option<&(Densities, Evaluation)> {
        self.last.as_ref()
    }
    /// Normalization constants (after the first iteration).
    pub fn scales(&self) -> Option<Scales> {
        self.scales
    }
    /// Why the loop stopped (None while running).
    pub fn stopped(&self) -> Option<StopReason> {
        self.stopped
    }
    /// Current projection.
    pub fn projection(&self) -> Projection {
        match self.params.projection {
            Some(p) => Projection {
                beta: self.beta,
                eta: p.eta,
            },
            None => Projection::off(),
        }
    }
    /// Parameters.
    pub fn params(&self) -> &OptimizerParams {
        &self.params
    }

    /// One iteration of Algorithm 1. Returns the record of the design just analysed; after
    /// it, [`Optimizer::stopped`] tells whether the loop is done.
    pub fn step(&mut self) -> Result<IterationRecord> {
        let t0 = Instant::now();
        let k = self.iteration;
        let proj = self.projection();
        let problem = self.evaluator.problem;
        // FE analysis, objective, constraints and their adjoint gradients.
        let (dens, ev) = self
            .evaluator
            .evaluate(&self.x, proj, self.yeoh.as_ref())
            .map_err(|e| match e {
                TopoptError::NonFinite { what, .. } => {
                    TopoptError::NonFinite { what, iteration: k }
                }
                e => e,
            })?;
        let scales = *self.scales.get_or_insert_with(|| {
            let (kc, kt) = problem.differential_corners();
            let o = &ev.response.outputs;
            let d2 = if o.len() > kt {
                (o[kc][0] - o[kt][0]).powi(2) + (o[kc][1] - o[kt][1]).powi(2)
            } else {
                1.0
            };
            Scales {
                objective: ev.objective.abs().max(f64::MIN_POSITIVE),
                energy_limit: match problem.energy_limit {
                    Some(EnergyLimit::Absolute(v)) => v,
                    Some(EnergyLimit::Relative(f)) => f * ev.energy,
                    None => 1.0,
                }
                .max(f64::MIN_POSITIVE),
                tilt: d2.max(f64::MIN_POSITIVE),
            }
        });
        let n = self.x.len();
        let s0 = self.params.objective_scale / scales.objective;
        let f0 = -s0 * ev.objective;
        let df0: Vec<f64> = ev.gradients[0].iter().map(|g| -s0 * g).collect();
        let mut g = Vec::new();
        let mut dg = Vec::new();
        if problem.energy_limit.is_some() {
            g.push(ev.energy / scales.energy_limit - 1.0);
            dg.extend(ev.gradients[1].iter().map(|v| v / scales.energy_limit));
        }
        if problem.max_stroke.is_some() {
            g.push(ev.stroke - 1.0);
            dg.extend_from_slice(&ev.gradients[2]);
        }
        if problem.tilt.is_some() {
            // Already normalized (scale-invariant angle measure, see `Evaluation::tilt`).
            g.push(ev.tilt);
            dg.extend_from_slice(&ev.gradients[3]);
        }
        if let Some(vf) = problem.volume_fraction {
            g.push(ev.volume / vf - 1.0);
            dg.extend(ev.gradients[4].iter().map(|v| v / vf));
        }
        if !f0.is_finite() || g.iter().any(|v| !v.is_finite()) {
            return Err(TopoptError::NonFinite {
                what: "objective or constraint",
                iteration: k,
            });
        }
        let kkt = if k > 0 {
            // Per unit objective of the scaled problem (module docs, "Stopping rule").
            Some(self.mma.kkt_residual(&self.x, &df0, &g, &dg)?.max / f0.abs().max(1.0))
        } else {
            None
        };
        let design_rho: Vec<f64> = self
            .evaluator
            .design
            .iter()
            .map(|&e| dens.physical[e])
            .collect();
        let grey = design_rho.iter().filter(|&&r| r > 0.1 && r < 0.9).count() as f64
            / design_rho.len() as f64;
        let r = &ev.response;
        let mut rec = IterationRecord {
            iteration: k,
            area: ev.area,
            objective: ev.objective,
            f0,
            constraints: g.clone(),
            energy: ev.energy,
            stroke: ev.stroke,
            volume: ev.volume,
            grey,
            change: if k > 0 { self.last_change } else { 0.0 },
            mean_change: if k > 0 { self.last_mean_change } else { 0.0 },
            kkt,
            beta: proj.beta,
            newton_total: r.newton_iterations.iter().sum(),
            newton_max: r.newton_iterations.iter().copied().max().unwrap_or(0),
            retried_cases: (0..r.retries.len()).filter(|&c| r.retries[c] > 0).collect(),
            time: 0.0,
        };
        // Stopping test (Algorithm 1 "while not convergent").
        let beta_done = match self.params.projection {
            Some(p) => self.beta >= p.beta_max,
            None => true,
        };
        let converged = k > 0
            && beta_done
            && self.last_change < self.params.change_tolerance
            && kkt.is_some_and(|v| v < self.params.kkt_tolerance);
        let stagnated = !converged
            && beta_done
            && kkt.is_some_and(|v| v < self.params.kkt_tolerance)
            && self.stagnated(&rec);
        if converged {
            self.stopped = Some(StopReason::Converged);
        } else if stagnated {
            self.stopped = Some(StopReason::Stagnated);
        } else if k >= self.params.max_iterations {
            self.stopped = Some(StopReason::MaxIterations);
        } else {
            // Density update (MMA).
            let x_old = self.x.clone();
            let up = self.mma.update(&mut self.x, f0, &df0, &g, &dg)?;
            self.last_change = up.max_change;
            self.last_mean_change = x_old
                .iter()
                .zip(&self.x)
                .map(|(a, b)| (a - b).abs())
                .sum::<f64>()
                / n.max(1) as f64;
            // Additive material update, Eq. (A3).
            if let (Some(y), Some(rule)) = (self.yeoh.as_mut(), self.yeoh_rule.as_ref()) {
                let strains = self.evaluator.max_element_strains();
                y.update_c2(&strains, rule)?;
            }
            // β continuation.
            if let Some(p) = self.params.projection {
                if (k + 1) % p.interval == 0 && self.beta < p.beta_max {
                    self.beta = (2.0 * self.beta).min(p.beta_max);
                }
            }
            self.iteration += 1;
        }
        debug_assert_eq!(n, df0.len());
        rec.time = t0.elapsed().as_secs_f64();
        self.history.push(rec.clone());
        self.last = Some((dens, ev));
        Ok(rec)
    }

    /// The stagnation test of the module docs for the record `rec` of the current iteration
    /// k (β = β_max and KKT are checked by the caller): records k−W..k all at the final β,
    /// objective variation ≤ tol·|Φ_k|, mean |Δx| < `change_tolerance` for the W updates,
    /// every constraint ≤ `kkt_tolerance`.
    fn stagnated(&self, rec: &IterationRecord) -> bool {
        let w = self.params.stagnation_window;
        if w == 0 || self.history.len() < w {
            return false;
        }
        let window = &self.history[self.history.len() - w..];
        let beta_max = self.params.projection.map_or(1.0, |p| p.beta_max);
        let phi = rec.objective;
        let (lo, hi) = window.iter().fold((phi, phi), |(lo, hi), r| {
            (lo.min(r.objective), hi.max(r.objective))
        });
        window
            .iter()
            .all(|r| self.params.projection.is_none() || r.beta >= beta_max)
            && hi - lo <= self.params.stagnation_tolerance * phi.abs()
            && window[1..]
                .iter()
                .chain(std::iter::once(rec))
                .all(|r| r.mean_change < self.params.change_tolerance)
            && rec
                .constraints
                .iter()
                .all(|&g| g <= self.params.kkt_tolerance)
    }

    /// Runs until [`Optimizer::stopped`], calling `on_iteration` after every iteration (for
    /// progress, snapshots and checkpoints); an error from the callback aborts the run.
    pub fn run<F>(&mut self, mut on_iteration: F) -> Result<StopReason>
    where
        F: FnMut(&Optimizer<'p>, &IterationRecord) -> Result<()>,
    {
        loop {
            let rec = self.step()?;
            on_iteration(self, &rec)?;
            if let Some(s) = self.stopped {
                return Ok(s);
            }
        }
    }

    /// A checkpoint of the state before the next iteration (binary, self-describing).
    pub fn checkpoint(&self) -> Vec<u8> {
        let st = self.mma.state();
        let header = CheckpointHeader {
            version: CHECKPOINT_VERSION,
            n: self.x.len(),
            m: self.mma.m(),
            cases: self.evaluator.cases.len(),
            dofs: self.evaluator.problem.model.n_dofs(),
            iteration: self.iteration,
            beta: self.beta,
            last_change: self.last_change,
            last_mean_change: self.last_mean_change,
            scales: self.scales,
            mma_iteration: st.iteration,
            mma_z: st.z,
            mma_zet: st.zet,
            history: self.history.clone(),
            has_yeoh: self.yeoh.is_some(),
        };
        let json = serde_json::to_vec(&header).expect("checkpoint header serializes");
        let mut out = Vec::new();
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&(json.len() as u64).to_le_bytes());
        out.extend_from_slice(&json);
        let mut vecs: Vec<&[f64]> = vec![
            &self.x, &st.xold1, &st.xold2, &st.low, &st.upp, &st.lam, &st.y, &st.mu, &st.s,
            &st.xsi, &st.eta,
        ];
        if let Some(y) = &self.yeoh {
            vecs.push(&y.c2);
        }
        // Per case: the warm starts of the next evaluation (displacements, then each
        // response's adjoint, empty when there is none yet).
        for cs in &self.evaluator.cases {
            vecs.push(&cs.u);
            for q in 0..4 {
                vecs.push(if cs.warm[q] { &cs.lambdas[q] } else { &[] });
            }
        }
        for v in vecs {
            out.extend_from_slice(&(v.len() as u64).to_le_bytes());
            for x in v {
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
        out
    }

    /// Rebuilds an optimizer from [`Optimizer::checkpoint`] bytes, for the same problem and
    /// parameters; the run then continues bitwise identically.
    pub fn resume(problem: &'p Problem, params: OptimizerParams, bytes: &[u8]) -> Result<Self> {
        let bad = |reason: &str| TopoptError::Format {
            what: "checkpoint".into(),
            reason: reason.into(),
        };
        if bytes.len() < 16 || &bytes[..8] != MAGIC {
            return Err(bad("not a flexstage checkpoint (bad magic)"));
        }
        let hl = u64::from_le_bytes(bytes[8..16].try_into().unwrap()) as usize;
        let json = bytes
            .get(16..16 + hl)
            .ok_or_else(|| bad("truncated header"))?;
        let h: CheckpointHeader =
            serde_json::from_slice(json).map_err(|e| bad(&format!("header: {e}")))?;
        let mut pos = 16 + hl;
        let mut read = || -> Result<Vec<f64>> {
            let l = bytes
                .get(pos..pos + 8)
                .ok_or_else(|| bad("truncated vector length"))?;
            let len = u64::from_le_bytes(l.try_into().unwrap()) as usize;
            pos += 8;
            let data = bytes
                .get(pos..pos + 8 * len)
                .ok_or_else(|| bad("truncated vector"))?;
            pos += 8 * len;
            Ok(data
                .chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
                .collect())
        };
        if h.version != CHECKPOINT_VERSION {
            return Err(bad(&format!(
                "checkpoint format version {} (this flexstage reads version {}); start the \
                 design again",
                h.version, CHECKPOINT_VERSION
            )));
        }
        let mut o = Optimizer::new(problem, params)?;
        if h.n != o.x.len()
            || h.m != o.mma.m()
            || h.cases != o.evaluator.cases.len()
            || h.dofs != problem.model.n_dofs()
            || h.has_yeoh != o.yeoh.is_some()
        {
            return Err(bad(
                "checkpoint does not match the scenario (mesh, samples, constraints or \
                 additive material differ)",
            ));
        }
        let x = read()?;
        let st = MmaState {
            iteration: h.mma_iteration,
            xold1: read()?,
            xold2: read()?,
            low: read()?,
            upp: read()?,
            lam: read()?,
            y: read()?,
            mu: read()?,
            s: read()?,
            xsi: read()?,
            eta: read()?,
            z: h.mma_z,
            zet: h.mma_zet,
        };
        o.mma.restore(&st)?;
        if x.len() != o.x.len() {
            return Err(bad("design vector length"));
        }
        o.x = x;
        if let Some(y) = o.yeoh.as_mut() {
            let c2 = read()?;
            if c2.len() != y.c2.len() {
                return Err(bad("c2 length"));
            }
            y.c2 = c2;
        }
        for cs in o.evaluator.cases.iter_mut() {
            let u = read()?;
            if u.len() != cs.u.len() {
                return Err(bad("displacement length"));
            }
            cs.u = u;
            for q in 0..4 {
                let lam = read()?;
                cs.warm[q] = !lam.is_empty();
                if cs.warm[q] {
                    if lam.len() != cs.lambdas[q].len() {
                        return Err(bad("adjoint length"));
                    }
                    cs.lambdas[q] = lam;
                }
            }
        }
        o.iteration = h.iteration;
        o.beta = h.beta;
        o.last_change = h.last_change;
        o.last_mean_change = h.last_mean_change;
        o.scales = h.scales;
        o.history = h.history;
        Ok(o)
    }
}
