//! The design loop, paper Algorithm 1, written with the paper's symbols (top88 style):
//!
//! ```text
//! x⁰ = V*;  β = 1;  c2 = c2⁰
//! for k = 0, 1, …:
//!     ρ_r = P_{β,η_r}(H S x / Hs)              filter, projections (crate::realization)
//!     u_rj:  R(u_rj, ρ_r) = P_j                FE analysis of every realization r, j = 1..p_m
//!     Φ_r = J(u_r) = ½ Σ_j u_oj × u_oj+1        objective of each realization, Eq. (4)
//!     g = [Σ/Σ0 − 1, ‖u_in/max x_nom‖ − 1, tilt, c·Σ_S − 1, V/V* − 1]   constraints, Eq. (5)
//!     ∇Φ_r, ∇g by adjoints                       crate::analysis
//!     stop if k ≥ max_iter, or β = β_max ∧ KKT < tol_kkt ∧ (Δx < tol_x ∨ stagnated)
//!     x ← MMA(x, f0, g)                        density update
//!     c2 ← c2·√ω or c2·ω                       additive material update, Eq. (A3)
//!     β ← 2β every `interval` iterations up to β_max
//! ```
//!
//! # Objective and constraints
//!
//! Without the robust formulation, `f0 = −s_obj·Φ/|Φ⁰|` (Φ⁰ the objective of the initial
//! design). With it (Wang, Lazarov & Sigmund 2011, §5; DECISIONS.md "Robust formulation"), the
//! worst case `min_r Φ_r` over the eroded, blueprint and dilated realizations is maximized in the
//! **bound formulation**: one more MMA variable ξ ∈ [0, 1], the bound `τ = T·ξ` (units of |Φ⁰|),
//! `f0 = −s_obj·τ` and one constraint `τ − Φ_r/|Φ⁰| ≤ 0` per realization. Before every MMA
//! update the bound is set to its optimum for the current densities, the worst case
//! `τ = min_r Φ_r/|Φ⁰|`, in the unit `T = 2τ` (ξ = ½), and MMA's history of ξ (previous
//! iterates, asymptotes, bound multipliers) is expressed in that unit. The bound is kept at or
//! above `BOUND_FLOOR` = 10⁻³ times the largest worst case so far (at least |Φ⁰|): a worst
//! case at or below zero (a realization whose output polygon turns inside out, seen when the
//! start is almost void) would give a unit of zero and rescale the history to infinity. Above
//! the floor the worst realization's constraint is violated, and MMA restores it; the rescale
//! stays within a factor 10³ per iteration. The worst realization's
//! constraint is then active at the start of every subproblem, so the densities always see its
//! gradient; a bound left behind by the move limit (the worst case grows ~50-fold from the
//! uniform start) would leave them without any objective gradient. The volume bound acts on the dilated design, with
//! its target `V*_d = V*·V_d/V_b` refreshed every `update_interval` iterations so that the
//! blueprint meets `V*`; the fatigue stress acts on the eroded design, the strain energy, input
//! strokes and tilt on the blueprint.
//!
//! **Inactive constraints.** A constraint whose scaled value was below `INACTIVE_BELOW = −0.5`
//! at the last design enters MMA with a zero gradient (its linearization is the constant it
//! has, an ε-active-set strategy): to become active it would have to grow by half its bound in
//! one move-limited step. Its value is still evaluated every iteration, and its gradient is
//! computed again as soon as it is above the threshold. This saves the adjoints of the
//! strain-energy bound (derived from the allowable stress, it binds only if the stress does)
//! and of the input strokes, one per load case each.
//!
//! The stress constraint is `c·Σ_S − 1 ≤ 0` with the p-norm `Σ_S` of [`crate::stress`] and Le et
//! al.'s adaptive normalization `c ← α·max s/Σ_S + (1 − α)·c` (SMO 41 (2010), Eq. 14), updated
//! with the volume target every `update_interval` iterations and constant in between (so the
//! gradient is `c·∇Σ_S` and MMA sees a fixed function; updating every iteration made the
//! stress and the design oscillate by ±10 %). The tilt constraint is the
//! scale-invariant angle error `√(φ² + ε²)/(0.75 τ) − 1` of [`crate::responses::tilt`], linear
//! in the angle (earlier measures divided by the initial |D⁰|², which grows by the workspace
//! growth factor squared, or were quadratic in tan φ and reached 10³, and left θ = 20° at
//! 15–18° after 25 iterations).
//!
//! # Stopping rule
//!
//! `KKT` is Svanberg's `kktcheck` residual (max norm) of the *scaled* MMA problem at the new
//! design with the multipliers of the last subproblem, divided by `max(1, |f0|)` so that it is
//! a residual per unit objective. An earlier version divided by `max_j |∂f0/∂x_j|`; at a
//! converged 0/1 design the projection makes every gradient tiny and the largest gradient sits
//! on the one grey element MMA keeps oscillating, whose residual *is* its gradient: the ratio
//! was ≈ 1.07 forever and the run always hit the iteration cap.
//!
//! The classic test `max |Δx| < tol_x` alone never passes either, because of that oscillating
//! element. The loop therefore also stops on *stagnation*, only once β has reached β_max for
//! the whole window: over the last `stagnation_window` = W iterations (records k−W..k) the
//! objective Φ (the worst case with the robust formulation) varies by at most
//! `stagnation_tolerance · |Φ_k|`, every update moved the densities by a mean |Δx| below
//! `change_tolerance`, the constraints are satisfied (every scaled gᵢ ≤ `kkt_tolerance`) and
//! KKT < `kkt_tolerance`. W = 0 disables it. With the robust formulation the KKT condition is
//! dropped from the stagnation test: the multipliers of the three realizations' bound
//! constraints, whose objectives differ by about a percent, do not settle, and the residual
//! with the last subproblem's multipliers stays of order one at a stationary design.
//!
//! [`Optimizer::checkpoint`] captures everything the future of the run depends on (design,
//! MMA history, β, c2, the stress normalization, the volume target, the warm starts of every
//! case of every realization, scales and history), so that [`Optimizer::resume`] continues
//! identically.

mod checkpoint;
mod params;

use std::time::Instant;

use flexstage_fem::{AdditiveYeoh, YeohUpdate};
use flexstage_mma::Mma;
use serde::{Deserialize, Serialize};

pub use params::{AdditiveParams, OptimizerParams, ProjectionSchedule};

use crate::error::{Result, TopoptError};
use crate::filter::Projection;
use crate::problem::Problem;
use crate::realization::{Densities, DesignEvaluator, Evaluation, Realization};
use crate::responses::{PerResponse, ResponseKind};

/// Constraints below this value at the last design enter MMA with a zero gradient (module
/// docs, "Inactive constraints").
pub const INACTIVE_BELOW: f64 = -0.5;

/// Floor of the robust bound τ, as a fraction of the largest worst case so far (module docs,
/// "Objective and constraints"): a worst case at or below zero cannot set the bound's unit.
pub const BOUND_FLOOR: f64 = 1e-3;

/// One line of the history (CSV/JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IterationRecord {
    /// Design iteration k (0 = initial design).
    pub iteration: usize,
    /// Shoelace area J of the blueprint's output polygon \[m²\] (workspace objective; 0
    /// otherwise).
    pub area: f64,
    /// Maximized objective Φ (signed area \[m²\] or output displacement \[m\]); with the robust
    /// formulation the worst case over the realizations.
    pub objective: f64,
    /// Normalized MMA objective f0.
    pub f0: f64,
    /// Normalized constraints (≤ 0 feasible), named in [`Optimizer::constraint_names`].
    pub constraints: Vec<f64>,
    /// Aggregated strain energy of the blueprint \[J\].
    pub energy: f64,
    /// Aggregated input stroke / max stroke of the blueprint.
    pub stroke: f64,
    /// Volume fraction of the blueprint's design elements.
    pub volume: f64,
    /// Fraction of design elements of the blueprint with 0.1 < ρ < 0.9.
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
    /// Newton iterations summed over the cases and realizations.
    pub newton_total: usize,
    /// Largest Newton iteration count of a case.
    pub newton_max: usize,
    /// Load cases that needed a cutback retry (logged).
    pub retried_cases: Vec<usize>,
    /// Wall time of this iteration \[s\].
    pub time: f64,
    /// Area of the eroded design's output polygon \[m²\] (robust formulation).
    #[serde(default)]
    pub area_eroded: Option<f64>,
    /// Area of the dilated design's output polygon \[m²\] (robust formulation).
    #[serde(default)]
    pub area_dilated: Option<f64>,
    /// Largest relaxed von Mises stress on the design mesh at the stress cases \[Pa\] (stress
    /// constraint).
    #[serde(default)]
    pub stress: Option<f64>,
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
    /// |Φ⁰| of the blueprint.
    pub objective: f64,
    /// Σ0 \[J\].
    pub energy_limit: f64,
    /// |D⁰|² \[m²\] at the initial design (diagnostic; the tilt constraint is normalized by the
    /// current |D|²).
    pub tilt: f64,
    /// Range T of the bound τ = T·ξ of the robust formulation (units of |Φ⁰|; 0 without it).
    #[serde(default)]
    pub bound: f64,
}

/// A constraint of the MMA problem.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Constraint {
    /// Bound formulation: `τ − Φ_r/|Φ⁰| ≤ 0` for a realization r (robust formulation).
    Worst(Realization),
    /// Strain energy `Σ/Σ0 − 1 ≤ 0` (Eq. 5).
    Energy,
    /// Input strokes `‖u_in/max x_nom‖ − 1 ≤ 0` (Eq. 5).
    Stroke,
    /// Orientation of the tilted output.
    Tilt,
    /// Fatigue stress `c·Σ_S − 1 ≤ 0`.
    Stress,
    /// Volume `V/V* − 1 ≤ 0` (the dilated design's with the robust formulation).
    Volume,
}

impl Constraint {
    /// Its name in histories.
    pub fn name(self) -> &'static str {
        match self {
            Constraint::Worst(Realization::Eroded) => "worst_eroded",
            Constraint::Worst(Realization::Blueprint) => "worst_blueprint",
            Constraint::Worst(Realization::Dilated) => "worst_dilated",
            Constraint::Energy => "energy",
            Constraint::Stroke => "stroke",
            Constraint::Tilt => "tilt",
            Constraint::Stress => "stress",
            Constraint::Volume => "volume",
        }
    }
}

/// The MMA problem at one design: `f0`, its gradient, the constraints and their gradients
/// (row-major, one row per constraint).
struct Scaled {
    f0: f64,
    df0: Vec<f64>,
    g: Vec<f64>,
    dg: Vec<f64>,
}

/// The optimizer: state of Algorithm 1 between iterations.
pub struct Optimizer<'p> {
    /// The evaluator (realizations, FE cases and warm starts).
    pub evaluator: DesignEvaluator<'p>,
    params: OptimizerParams,
    mma: Mma,
    /// MMA variables: the design variables, then ξ with the robust formulation.
    x: Vec<f64>,
    beta: f64,
    iteration: usize,
    yeoh: Option<AdditiveYeoh>,
    yeoh_rule: Option<YeohUpdate>,
    scales: Option<Scales>,
    /// Adaptive stress normalization c (module docs).
    stress_norm: Option<f64>,
    /// Volume bound of the dilated design (robust formulation).
    volume_target: Option<f64>,
    constraints: Vec<Constraint>,
    last_change: f64,
    last_mean_change: f64,
    history: Vec<IterationRecord>,
    last: Option<(Densities, Evaluation)>,
    stopped: Option<StopReason>,
}

impl<'p> Optimizer<'p> {
    /// Starts at the uniform initial design of the problem.
    pub fn new(problem: &'p Problem, params: OptimizerParams) -> Result<Self> {
        params.validate()?;
        let eta = params.projection.map_or(0.5, |p| p.eta);
        let evaluator = DesignEvaluator::new(
            problem,
            params.effective_filter_radius(),
            params.thresholds(),
            eta,
            params.analysis,
        )?;
        let n = evaluator.n();
        let constraints = Self::constraint_list(problem, params.robust.is_some());
        let robust = params.robust.is_some() as usize;
        let (mut xmin, mut xmax) = (vec![problem.rho_min; n], vec![1.0; n]);
        xmin.resize(n + robust, 0.0);
        xmax.resize(n + robust, 1.0);
        let mma = Mma::new(n + robust, constraints.len(), xmin, xmax, params.mma)?;
        let (yeoh, yeoh_rule) = Self::additive(problem, &params);
        let mut x = vec![problem.initial_density; n];
        x.resize(n + robust, 0.0);
        Ok(Self {
            evaluator,
            mma,
            x,
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
            stress_norm: None,
            volume_target: None,
            constraints,
            last_change: 0.0,
            last_mean_change: 0.0,
            history: Vec::new(),
            last: None,
            stopped: None,
        })
    }

    fn additive(
        problem: &Problem,
        params: &OptimizerParams,
    ) -> (Option<AdditiveYeoh>, Option<YeohUpdate>) {
        let Some(a) = params.additive else {
            return (None, None);
        };
        let mat = problem.model.material();
        let ne = problem.mesh().n_elements();
        let mut y = AdditiveYeoh::paper(ne, mat.e0, problem.rho_min, mat.penalty);
        y.c2.iter_mut()
            .for_each(|c| *c = a.initial_coefficient * mat.e0);
        let rule = YeohUpdate {
            eps_star: a.strain_threshold,
            ..YeohUpdate::paper(mat.e0)
        };
        (Some(y), Some(rule))
    }

    /// The constraints of a problem, in MMA order.
    pub fn constraint_list(p: &Problem, robust: bool) -> Vec<Constraint> {
        let mut v = Vec::new();
        if robust {
            v.extend(
                [
                    Realization::Eroded,
                    Realization::Blueprint,
                    Realization::Dilated,
                ]
                .map(Constraint::Worst),
            );
        }
        if p.energy_limit.is_some() {
            v.push(Constraint::Energy);
        }
        if p.max_stroke.is_some() {
            v.push(Constraint::Stroke);
        }
        if p.tilt.is_some() {
            v.push(Constraint::Tilt);
        }
        if p.stress.is_some() {
            v.push(Constraint::Stress);
        }
        if p.volume_fraction.is_some() {
            v.push(Constraint::Volume);
        }
        v
    }

    /// Names of the constraints, in the order of [`IterationRecord::constraints`].
    pub fn constraint_names(&self) -> Vec<&'static str> {
        self.constraints.iter().map(|c| c.name()).collect()
    }

    /// The current design variables (without the bound variable of the robust formulation).
    pub fn x(&self) -> &[f64] {
        &self.x[..self.evaluator.n()]
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
    /// Current projection sharpness β (0: no projection).
    pub fn beta(&self) -> f64 {
        self.beta
    }
    /// Current projection of the blueprint.
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
    /// The additive material's current coefficients (None when it is off).
    pub fn additive_material(&self) -> Option<&AdditiveYeoh> {
        self.yeoh.as_ref()
    }

    /// One iteration of Algorithm 1. Returns the record of the design just analysed; after
    /// it, [`Optimizer::stopped`] tells whether the loop is done.
    pub fn step(&mut self) -> Result<IterationRecord> {
        let t0 = Instant::now();
        let k = self.iteration;
        let n = self.evaluator.n();
        // FE analysis of every realization, objective, constraints and their gradients.
        let skip = self.inactive();
        let (dens, ev) = self
            .evaluator
            .evaluate_with(&self.x[..n], self.beta, self.yeoh.as_ref(), &skip)
            .map_err(|e| match e {
                TopoptError::NonFinite { what, .. } => {
                    TopoptError::NonFinite { what, iteration: k }
                }
                e => e,
            })?;
        self.init_state(&ev)?;
        let sc = self.scaled(&ev);
        if !sc.f0.is_finite() || sc.g.iter().any(|v| !v.is_finite()) {
            return Err(TopoptError::NonFinite {
                what: "objective or constraint",
                iteration: k,
            });
        }
        let kkt = if k > 0 {
            // Per unit objective of the scaled problem (module docs, "Stopping rule").
            Some(self.mma.kkt_residual(&self.x, &sc.df0, &sc.g, &sc.dg)?.max / sc.f0.abs().max(1.0))
        } else {
            None
        };
        let mut rec = self.record(&dens, &ev, &sc, kkt);
        self.stopped = self.stop_test(&rec, kkt);
        if self.stopped.is_none() {
            self.update(&sc, &ev)?;
        }
        rec.time = t0.elapsed().as_secs_f64();
        self.history.push(rec.clone());
        self.last = Some((dens, ev));
        Ok(rec)
    }

    /// The FE responses of the constraints that were inactive at the last design (module docs).
    fn inactive(&self) -> PerResponse<bool> {
        let mut skip = PerResponse::default();
        let Some(last) = self.history.last() else {
            return skip;
        };
        for (c, g) in self.constraints.iter().zip(&last.constraints) {
            let q = match c {
                Constraint::Energy => ResponseKind::Energy,
                Constraint::Stroke => ResponseKind::Stroke,
                Constraint::Tilt => ResponseKind::Tilt,
                Constraint::Stress => ResponseKind::Stress,
                _ => continue,
            };
            skip[q] = *g < INACTIVE_BELOW;
        }
        skip
    }

    /// Scales, the stress normalization, the volume target and the bound variable at the first
    /// iteration.
    fn init_state(&mut self, ev: &Evaluation) -> Result<()> {
        let problem = self.evaluator.problem;
        let bp = ev.blueprint();
        if self.scales.is_none() {
            let (kc, kt) = problem.differential_corners();
            let o = &bp.response.outputs;
            let d2 = if o.len() > kt {
                (o[kc][0] - o[kt][0]).powi(2) + (o[kc][1] - o[kt][1]).powi(2)
            } else {
                1.0
            };
            let phi0 = bp.values[ResponseKind::Objective]
                .abs()
                .max(f64::MIN_POSITIVE);
            // The bound starts at the worst case with ξ = ½ (a feasible start), in a unit kept
            // above the floor of the module docs ("Objective and constraints").
            let worst = (self.worst(ev) / phi0).max(BOUND_FLOOR);
            let bound = if self.params.robust.is_some() {
                2.0 * worst
            } else {
                0.0
            };
            self.scales = Some(Scales {
                objective: phi0,
                energy_limit: problem.energy_limit.unwrap_or(1.0).max(f64::MIN_POSITIVE),
                tilt: d2.max(f64::MIN_POSITIVE),
                bound,
            });
            if bound > 0.0 {
                let n = self.evaluator.n();
                self.x[n] = 0.5;
            }
        } else {
            let phi0 = self.scales.map_or(1.0, |s| s.objective);
            // The largest worst case so far, in units of |Φ⁰| (at least 1, the start's scale).
            let best = self
                .history
                .iter()
                .map(|r| r.objective / phi0)
                .fold(1.0, f64::max);
            let worst = self.worst(ev) / phi0;
            self.reset_bound(worst.max(BOUND_FLOOR * best))?;
        }
        if problem.stress.is_some() && self.stress_norm.is_none() {
            self.stress_norm = Some(stress_ratio(ev.get(Realization::Eroded).unwrap_or(bp)));
        }
        if let (None, Some(vf), Some(d)) = (
            self.volume_target,
            problem.volume_fraction,
            ev.get(Realization::Dilated),
        ) {
            self.volume_target = Some(volume_target(vf, d, bp));
        }
        Ok(())
    }

    /// Sets the bound to `tau`, the worst case of the current design τ = min_r Φ_r/|Φ⁰| (its
    /// optimum for the current densities) kept above the floor of the module docs, in the unit
    /// `T = 2τ` that puts ξ = ½, and expresses MMA's history of ξ in the new unit.
    ///
    /// # Errors
    /// [`TopoptError::NonFinite`] if the rescaled history is not finite.
    fn reset_bound(&mut self, tau: f64) -> Result<()> {
        let n = self.evaluator.n();
        let Some(sc) = self.scales.as_mut().filter(|s| s.bound > 0.0) else {
            return Ok(());
        };
        let t_new = 2.0 * tau;
        // Old ξ values in the new unit: ξ' = ξ·T/T'.
        let f = sc.bound / t_new;
        sc.bound = t_new;
        self.x[n] = 0.5;
        if self.mma.iteration() == 0 {
            return Ok(());
        }
        let mut st = self.mma.state();
        for v in [&mut st.xold1, &mut st.xold2, &mut st.low, &mut st.upp] {
            v[n] *= f;
        }
        st.xsi[n] /= f;
        st.eta[n] /= f;
        // The reset value must lie between the asymptotes; otherwise restart them there.
        if !(st.low[n] < 0.5 && 0.5 < st.upp[n]) {
            let d = self.params.mma.asyinit;
            (st.low[n], st.upp[n]) = (0.5 - d, 0.5 + d);
            (st.xold1[n], st.xold2[n]) = (0.5, 0.5);
        }
        let iteration = self.iteration;
        self.mma.restore(&st).map_err(|_| TopoptError::NonFinite {
            what: "MMA history of the robust bound, rescaled to its new unit",
            iteration,
        })
    }

    /// The worst objective over the realizations (the blueprint's without robustness).
    fn worst(&self, ev: &Evaluation) -> f64 {
        ev.realizations
            .iter()
            .map(|r| r.values[ResponseKind::Objective])
            .fold(f64::INFINITY, f64::min)
    }

    /// The scaled MMA problem (module docs, "Objective and constraints").
    fn scaled(&self, ev: &Evaluation) -> Scaled {
        let problem = self.evaluator.problem;
        let sc = self.scales.expect("set by init_state");
        let n = self.evaluator.n();
        let nx = self.x.len();
        let s = self.params.objective_scale;
        let bp = ev.blueprint();
        // A response without a gradient (an inactive constraint) has a zero row.
        let grad = |r: &crate::realization::RealizationEvaluation, q: ResponseKind, scale: f64| {
            let mut g: Vec<f64> = r.gradients[q]
                .as_ref()
                .map_or_else(Vec::new, |g| g.iter().map(|v| v * scale).collect());
            g.resize(nx, 0.0);
            g
        };
        let (f0, df0) = if sc.bound > 0.0 {
            let mut d = vec![0.0; nx];
            d[n] = -s * sc.bound;
            (-s * sc.bound * self.x[n], d)
        } else {
            let phi = bp.values[ResponseKind::Objective];
            (
                -s * phi / sc.objective,
                grad(bp, ResponseKind::Objective, -s / sc.objective),
            )
        };
        let (mut g, mut dg) = (Vec::new(), Vec::new());
        for c in &self.constraints {
            let (value, row) = match *c {
                Constraint::Worst(kind) => {
                    let r = ev.get(kind).expect("robust realization");
                    let mut row = grad(r, ResponseKind::Objective, -1.0 / sc.objective);
                    row[n] = sc.bound;
                    let phi = r.values[ResponseKind::Objective] / sc.objective;
                    (sc.bound * self.x[n] - phi, row)
                }
                Constraint::Energy => {
                    let v = bp.values[ResponseKind::Energy];
                    (
                        v / sc.energy_limit - 1.0,
                        grad(bp, ResponseKind::Energy, 1.0 / sc.energy_limit),
                    )
                }
                Constraint::Stroke => (
                    bp.values[ResponseKind::Stroke] - 1.0,
                    grad(bp, ResponseKind::Stroke, 1.0),
                ),
                Constraint::Tilt => (
                    bp.values[ResponseKind::Tilt],
                    grad(bp, ResponseKind::Tilt, 1.0),
                ),
                Constraint::Stress => {
                    let r = ev.get(Realization::Eroded).unwrap_or(bp);
                    let c = self.stress_norm.unwrap_or(1.0);
                    (
                        c * r.values[ResponseKind::Stress] - 1.0,
                        grad(r, ResponseKind::Stress, c),
                    )
                }
                Constraint::Volume => {
                    let (r, target) = match ev.get(Realization::Dilated) {
                        Some(d) => (d, self.volume_target.unwrap_or(1.0)),
                        None => (bp, problem.volume_fraction.unwrap_or(1.0)),
                    };
                    (
                        r.values[ResponseKind::Volume] / target - 1.0,
                        grad(r, ResponseKind::Volume, 1.0 / target),
                    )
                }
            };
            g.push(value);
            dg.extend(row);
        }
        Scaled { f0, df0, g, dg }
    }

    /// The history record of the design just evaluated.
    fn record(
        &self,
        dens: &Densities,
        ev: &Evaluation,
        sc: &Scaled,
        kkt: Option<f64>,
    ) -> IterationRecord {
        let k = self.iteration;
        let space = &self.evaluator.space;
        let nd = space.n_design_elements() as f64;
        let grey = space
            .design_elements()
            .filter(|&e| dens.physical[e] > 0.1 && dens.physical[e] < 0.9)
            .count() as f64
            / nd;
        let bp = ev.blueprint();
        let its = ev
            .realizations
            .iter()
            .flat_map(|r| r.response.newton_iterations.iter().copied());
        let stress_real = ev.get(Realization::Eroded).unwrap_or(bp);
        let allowable = self.evaluator.problem.stress.as_ref().map(|s| s.allowable);
        IterationRecord {
            iteration: k,
            area: bp.area,
            objective: self.worst(ev),
            f0: sc.f0,
            constraints: sc.g.clone(),
            energy: bp.values[ResponseKind::Energy],
            stroke: bp.values[ResponseKind::Stroke],
            volume: bp.values[ResponseKind::Volume],
            grey,
            change: if k > 0 { self.last_change } else { 0.0 },
            mean_change: if k > 0 { self.last_mean_change } else { 0.0 },
            kkt,
            beta: self.beta,
            newton_total: its.clone().sum(),
            newton_max: its.max().unwrap_or(0),
            retried_cases: (0..bp.response.retries.len())
                .filter(|&c| ev.realizations.iter().any(|r| r.response.retries[c] > 0))
                .collect(),
            time: 0.0,
            area_eroded: ev.get(Realization::Eroded).map(|r| r.area),
            area_dilated: ev.get(Realization::Dilated).map(|r| r.area),
            stress: stress_real.stress_max.zip(allowable).map(|(s, a)| s * a),
        }
    }

    /// Stopping test (Algorithm 1 "while not convergent").
    fn stop_test(&self, rec: &IterationRecord, kkt: Option<f64>) -> Option<StopReason> {
        let k = self.iteration;
        let beta_done = match self.params.projection {
            Some(p) => self.beta >= p.beta_max,
            None => true,
        };
        let kkt_ok = kkt.is_some_and(|v| v < self.params.kkt_tolerance);
        // With the bound formulation the multipliers of the realizations' constraints, whose
        // objectives differ by about a percent, do not settle and the KKT residual with the
        // last subproblem's multipliers stays O(1) at a stationary design: stagnation then
        // rests on the objective, the densities and feasibility (module docs).
        let kkt_stagnation = kkt_ok || self.params.robust.is_some();
        if k > 0 && beta_done && kkt_ok && self.last_change < self.params.change_tolerance {
            Some(StopReason::Converged)
        } else if beta_done && kkt_stagnation && self.stagnated(rec) {
            Some(StopReason::Stagnated)
        } else if k >= self.params.max_iterations {
            Some(StopReason::MaxIterations)
        } else {
            None
        }
    }

    /// MMA update, additive material, β continuation, stress normalization, volume target.
    fn update(&mut self, sc: &Scaled, ev: &Evaluation) -> Result<()> {
        let k = self.iteration;
        let n = self.evaluator.n();
        let x_old = self.x[..n].to_vec();
        let up = self
            .mma
            .update(&mut self.x, sc.f0, &sc.df0, &sc.g, &sc.dg)?;
        self.last_change = up.max_change;
        self.last_mean_change = x_old
            .iter()
            .zip(&self.x)
            .map(|(a, b)| (a - b).abs())
            .sum::<f64>()
            / n.max(1) as f64;
        // Additive material update, Eq. (A3), with the largest strains of any realization.
        if let (Some(y), Some(rule)) = (self.yeoh.as_mut(), self.yeoh_rule.as_ref()) {
            let mut strains = vec![0.0f64; self.evaluator.problem.mesh().n_elements()];
            for e in &self.evaluator.evaluators {
                for (s, v) in strains.iter_mut().zip(e.max_element_strains()) {
                    *s = s.max(v);
                }
            }
            y.update_c2(&strains, rule)?;
        }
        // β continuation.
        if let Some(p) = self.params.projection {
            if (k + 1) % p.interval == 0 && self.beta < p.beta_max {
                self.beta = (2.0 * self.beta).min(p.beta_max);
            }
        }
        // Every `update_interval` iterations: the adaptive stress normalization (Le et al.
        // 2010, Eq. 14) and the volume target of the dilated design (Wang et al. 2011, §5).
        // Between updates the constraint functions stay fixed, which MMA's history needs.
        let bp = ev.blueprint();
        if (k + 1) % self.params.update_interval == 0 {
            if let Some(c) = self.stress_norm.as_mut() {
                let a = self.params.stress_normalization_damping;
                let ratio = stress_ratio(ev.get(Realization::Eroded).unwrap_or(bp));
                *c = a * ratio + (1.0 - a) * *c;
            }
            if let (Some(vf), Some(d)) = (
                self.evaluator.problem.volume_fraction,
                ev.get(Realization::Dilated),
            ) {
                self.volume_target = Some(volume_target(vf, d, bp));
            }
        }
        self.iteration += 1;
        Ok(())
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
}

/// `max s / Σ_S` of a realization's stress response (1 when there is no stress).
fn stress_ratio(r: &crate::realization::RealizationEvaluation) -> f64 {
    let sigma = r.values[ResponseKind::Stress];
    match r.stress_max {
        Some(m) if sigma > 0.0 && m > 0.0 => m / sigma,
        _ => 1.0,
    }
}

/// `V*_d = V*·V_d/V_b`: the dilated design's volume bound that puts the blueprint at `V*`.
fn volume_target(
    vf: f64,
    dilated: &crate::realization::RealizationEvaluation,
    blueprint: &crate::realization::RealizationEvaluation,
) -> f64 {
    let (vd, vb) = (
        dilated.values[ResponseKind::Volume],
        blueprint.values[ResponseKind::Volume],
    );
    if vb > 0.0 {
        (vf * vd / vb).min(1.0)
    } else {
        vf
    }
}
