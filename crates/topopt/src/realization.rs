//! One design, seen as up to three physical designs: the density chain
//! `x → x_full → x̃ → x̄_r → ρ_r` and the evaluation of every realization r (Algorithm 1,
//! "Finite element analysis" and "Objective and constraints evaluation").
//!
//! * `x_full = S x`: the design variables set the design elements ([`DesignSpace`], mirror
//!   symmetry by construction), passive solid 1 and void ρ_min;
//! * `x̃ = H x_full / Hs`: one density-filter pass shared by all realizations;
//! * `x̄_r = P_{β,η_r}(x̃)`: one Heaviside projection per realization, with the thresholds of the
//!   robust formulation (Wang, Lazarov & Sigmund 2011): eroded `η_e > ½`, blueprint (the
//!   intermediate design, the one that is made) `η = ½`, dilated `η_d < ½`
//!   ([`crate::length_scale`]);
//! * `ρ_r`: passive overrides; the FE input of realization r.
//!
//! Each realization evaluates the responses it is needed for: with the robust formulation the
//! objective on all three (the worst case is maximized), the fatigue stress on the eroded design
//! (the thinnest hinges), the volume on the dilated design (the most material), the strain
//! energy, input strokes and tilt on the blueprint, the stage's resonance ([`crate::modal`]) on
//! the eroded design and the blueprint, and a lower volume bound on the blueprint; without it
//! everything on the blueprint. Gradients flow back through the adjoint of each map.

use flexstage_fem::{AdditiveYeoh, Design, Passive};
use rayon::prelude::*;

use crate::analysis::{AnalysisParams, CaseResults, Evaluator, Workspace};
use crate::design_space::DesignSpace;
use crate::error::{Result, TopoptError};
use crate::filter::{DensityFilter, Projection};
use crate::modal::ModalWorkspace;
use crate::problem::Problem;
use crate::responses::{self, PerResponse, ResponseCoefficients, ResponseKind};
use crate::stress::stress_measure;

/// One of the physical designs of the robust formulation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Realization {
    /// Threshold `η_e > ½`: every member thinner by the erosion depth.
    Eroded,
    /// Threshold ½: the intermediate design, the one that is made.
    Blueprint,
    /// Threshold `η_d < ½`: every member thicker by the dilation depth.
    Dilated,
}

impl Realization {
    /// Its name in tables.
    pub fn name(self) -> &'static str {
        match self {
            Realization::Eroded => "eroded",
            Realization::Blueprint => "blueprint",
            Realization::Dilated => "dilated",
        }
    }
}

/// The thresholds of the robust formulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobustThresholds {
    /// Erosion threshold η_e ∈ (½, 1).
    pub eroded: f64,
    /// Dilation threshold η_d ∈ (0, ½).
    pub dilated: f64,
}

/// A realization and the responses it evaluates.
#[derive(Debug, Clone, PartialEq)]
pub struct RealizationSpec {
    /// Which one.
    pub kind: Realization,
    /// Its projection threshold.
    pub eta: f64,
    /// The responses it evaluates (with gradients).
    pub responses: PerResponse<bool>,
}

/// The density chain of one evaluation.
#[derive(Debug, Clone)]
pub struct Densities {
    /// Design variables scattered to all elements (passive solid 1, void ρ_min).
    pub x_full: Vec<f64>,
    /// Filtered `x̃`.
    pub filtered: Vec<f64>,
    /// Projected `x̄` of the blueprint.
    pub projected: Vec<f64>,
    /// Physical densities ρ of the blueprint (passive overrides applied), the design.
    pub physical: Vec<f64>,
    /// Physical densities of every realization, in the evaluator's order.
    pub realizations: Vec<(Realization, Vec<f64>)>,
}

impl Densities {
    /// The physical densities of a realization.
    pub fn of(&self, kind: Realization) -> Option<&[f64]> {
        self.realizations
            .iter()
            .find(|(k, _)| *k == kind)
            .map(|(_, r)| r.as_slice())
    }
}

/// The responses of one realization.
#[derive(Debug, Clone)]
pub struct RealizationEvaluation {
    /// Which realization.
    pub kind: Realization,
    /// Case results.
    pub response: CaseResults,
    /// Value of every evaluated response (0 for the others).
    pub values: PerResponse<f64>,
    /// Gradients of the evaluated responses w.r.t. the design variables.
    pub gradients: PerResponse<Option<Vec<f64>>>,
    /// Workspace area `sign · J` of the output polygon in the configuration's orientation
    /// \[m²\] (Eq. 4; 0 for the displacement objective).
    pub area: f64,
    /// Largest relaxed stress over the stress cases, in units of the design allowable (stress
    /// evaluated only).
    pub stress_max: Option<f64>,
    /// The stage's lowest natural frequencies (resonance evaluated only).
    pub modes: Option<crate::modal::StageModes>,
}

/// The responses of all realizations of one design.
#[derive(Debug, Clone)]
pub struct Evaluation {
    /// In the evaluator's order (eroded, blueprint, dilated).
    pub realizations: Vec<RealizationEvaluation>,
}

impl Evaluation {
    /// A realization's responses.
    pub fn get(&self, kind: Realization) -> Option<&RealizationEvaluation> {
        self.realizations.iter().find(|r| r.kind == kind)
    }
    /// The blueprint's responses.
    pub fn blueprint(&self) -> &RealizationEvaluation {
        self.get(Realization::Blueprint)
            .expect("every evaluation has a blueprint")
    }
}

/// Evaluates all realizations of a design (module docs).
pub struct DesignEvaluator<'p> {
    /// The problem.
    pub problem: &'p Problem,
    /// Design variables ↔ elements.
    pub space: DesignSpace,
    /// The density filter.
    pub filter: DensityFilter,
    /// The realizations and their responses.
    pub specs: Vec<RealizationSpec>,
    /// One FE analysis (warm starts) per realization, same order.
    pub evaluators: Vec<Evaluator<'p>>,
    /// One set of FE buffers per realization (same order, one symbolic factorization), so that
    /// the realizations are analysed concurrently.
    workspaces: Vec<Workspace>,
    /// The stage's eigen-analysis buffers of each realization that evaluates the resonance
    /// (same order).
    modal: Vec<Option<ModalWorkspace>>,
}

/// Which responses a problem has.
fn problem_responses(p: &Problem) -> PerResponse<bool> {
    PerResponse::from_fn(|q| match q {
        ResponseKind::Objective => true,
        ResponseKind::Energy => p.energy_limit.is_some(),
        ResponseKind::Stroke => p.max_stroke.is_some(),
        ResponseKind::Tilt => p.tilt.is_some(),
        ResponseKind::Stress => p.stress.is_some(),
        ResponseKind::Volume => p.volume_fraction.is_some() || p.min_volume_fraction.is_some(),
        ResponseKind::Resonance => p.resonance.is_some(),
    })
}

/// The realizations of the module docs.
pub fn realization_specs(
    p: &Problem,
    robust: Option<RobustThresholds>,
    eta: f64,
) -> Vec<RealizationSpec> {
    let has = problem_responses(p);
    let Some(t) = robust else {
        return vec![RealizationSpec {
            kind: Realization::Blueprint,
            eta,
            responses: has,
        }];
    };
    let only = |kinds: &[ResponseKind]| PerResponse::from_fn(|q| has[q] && kinds.contains(&q));
    use ResponseKind::*;
    vec![
        RealizationSpec {
            kind: Realization::Eroded,
            eta: t.eroded,
            responses: only(&[Objective, Stress, Resonance]),
        },
        RealizationSpec {
            kind: Realization::Blueprint,
            eta,
            responses: PerResponse::from_fn(|q| {
                has[q]
                    && match q {
                        Volume => p.min_volume_fraction.is_some(),
                        Stress => false,
                        _ => true,
                    }
            }),
        },
        RealizationSpec {
            kind: Realization::Dilated,
            eta: t.dilated,
            responses: only(&[Objective, Volume]),
        },
    ]
}

impl<'p> DesignEvaluator<'p> {
    /// The evaluator of `problem` with a filter of `filter_radius` element sizes, the robust
    /// thresholds (None: the blueprint only) and the blueprint threshold `eta`.
    pub fn new(
        problem: &'p Problem,
        filter_radius: f64,
        robust: Option<RobustThresholds>,
        eta: f64,
        params: AnalysisParams,
    ) -> Result<Self> {
        problem.validate()?;
        let space = DesignSpace::new(problem.mesh(), problem.mirror_symmetry)?;
        let specs = realization_specs(problem, robust, eta);
        let first = Workspace::new(problem)?;
        let evaluators = specs
            .iter()
            .map(|s| {
                let mut ev = Evaluator::with_workspace_of(problem, params, &first)?;
                ev.compute_energies = s.responses[ResponseKind::Energy];
                Ok(ev)
            })
            .collect::<Result<Vec<_>>>()?;
        let mut workspaces = Vec::with_capacity(specs.len());
        for _ in 1..specs.len() {
            workspaces.push(Workspace::sharing(problem, first.symbolic().clone())?);
        }
        workspaces.insert(0, first);
        let modal = specs
            .iter()
            .map(|s| {
                s.responses[ResponseKind::Resonance]
                    .then(|| ModalWorkspace::new(problem))
                    .transpose()
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Self {
            problem,
            space,
            filter: DensityFilter::new(problem.mesh(), filter_radius),
            specs,
            evaluators,
            workspaces,
            modal,
        })
    }

    /// Number of design variables.
    pub fn n(&self) -> usize {
        self.space.n()
    }

    /// The projection of realization `i` at sharpness β (β = 0: none).
    pub fn projection(&self, i: usize, beta: f64) -> Projection {
        Maps::projection(&self.specs[i], beta)
    }

    /// `x → x_full → x̃ → x̄_r → ρ_r` (module docs).
    pub fn densities(&self, x: &[f64], beta: f64) -> Densities {
        let mesh = self.problem.mesh();
        let rho_min = self.problem.rho_min;
        let mut x_full: Vec<f64> = mesh
            .passive
            .iter()
            .map(|p| if *p == Passive::Solid { 1.0 } else { rho_min })
            .collect();
        self.space.scatter(x, &mut x_full);
        let mut filtered = vec![0.0; x_full.len()];
        self.filter.apply(&x_full, &mut filtered);
        let mut realizations = Vec::with_capacity(self.specs.len());
        let (mut projected, mut physical) = (Vec::new(), Vec::new());
        for (i, spec) in self.specs.iter().enumerate() {
            let proj = self.projection(i, beta);
            let xbar: Vec<f64> = filtered.iter().map(|&v| proj.value(v)).collect();
            let mut rho: Vec<f64> = xbar.iter().map(|v| v.clamp(0.0, 1.0)).collect();
            mesh.apply_passive(&mut rho, rho_min);
            if spec.kind == Realization::Blueprint {
                projected = xbar;
                physical = rho.clone();
            }
            realizations.push((spec.kind, rho));
        }
        Densities {
            x_full,
            filtered,
            projected,
            physical,
            realizations,
        }
    }

    /// Chain rule `dQ/dρ_r → dQ/dx` through the passive overrides, the projection of
    /// realization r, the filter and the design space.
    pub fn chain(&self, filtered: &[f64], proj: Projection, g_rho: &[f64]) -> Vec<f64> {
        self.maps().chain(filtered, proj, g_rho)
    }

    /// The read-only maps of the density chain.
    fn maps(&self) -> Maps<'_> {
        Maps {
            problem: self.problem,
            space: &self.space,
            filter: &self.filter,
        }
    }

    /// Full evaluation at the design variables `x` and sharpness β: densities, FE analysis of
    /// every realization, responses and their exact gradients w.r.t. `x`.
    pub fn evaluate(
        &mut self,
        x: &[f64],
        beta: f64,
        yeoh: Option<&AdditiveYeoh>,
    ) -> Result<(Densities, Evaluation)> {
        self.evaluate_with(x, beta, yeoh, &PerResponse::default())
    }

    /// [`DesignEvaluator::evaluate`] without the gradients of the responses marked in `skip`
    /// (their values are still computed; the objective's and the volume's gradients are
    /// always computed).
    pub fn evaluate_with(
        &mut self,
        x: &[f64],
        beta: f64,
        yeoh: Option<&AdditiveYeoh>,
        skip: &PerResponse<bool>,
    ) -> Result<(Densities, Evaluation)> {
        if x.len() != self.n() {
            return Err(TopoptError::Problem(format!(
                "{} design variables given, the problem has {}",
                x.len(),
                self.n()
            )));
        }
        let dens = self.densities(x, beta);
        // The realizations are independent FE problems: analysed concurrently (each with its
        // own workspace), so that one's serial parts (factorization, predictor, adjoint basis,
        // stress measure, chain rule) overlap the others' parallel ones.
        let maps = Maps {
            problem: self.problem,
            space: &self.space,
            filter: &self.filter,
        };
        let results: Vec<Result<RealizationEvaluation>> = self
            .evaluators
            .par_iter_mut()
            .zip(self.workspaces.par_iter_mut())
            .zip(self.modal.par_iter_mut())
            .zip(self.specs.par_iter())
            .enumerate()
            .map(|(i, (((ev, ws), modal), spec))| {
                let mut r = maps.evaluate_realization(
                    spec,
                    ev,
                    ws,
                    &dens.realizations[i].1,
                    &dens,
                    beta,
                    yeoh,
                    skip,
                )?;
                if let Some(mw) = modal.as_mut() {
                    maps.resonance(
                        mw,
                        ev,
                        ws,
                        &dens.realizations[i].1,
                        &dens,
                        spec,
                        beta,
                        yeoh,
                        &mut r,
                    )?;
                }
                Ok(r)
            })
            .collect();
        let realizations = results.into_iter().collect::<Result<Vec<_>>>()?;
        Ok((dens, Evaluation { realizations }))
    }
}

/// The read-only maps of the density chain (design space, filter) and the problem.
struct Maps<'a> {
    problem: &'a Problem,
    space: &'a DesignSpace,
    filter: &'a DensityFilter,
}

impl Maps<'_> {
    /// The projection of a realization at sharpness β (β = 0: none).
    fn projection(spec: &RealizationSpec, beta: f64) -> Projection {
        if beta == 0.0 {
            Projection::off()
        } else {
            Projection {
                beta,
                eta: spec.eta,
            }
        }
    }

    /// See [`DesignEvaluator::chain`].
    fn chain(&self, filtered: &[f64], proj: Projection, g_rho: &[f64]) -> Vec<f64> {
        let mesh = self.problem.mesh();
        let g_tilde: Vec<f64> = (0..g_rho.len())
            .map(|e| {
                if mesh.passive[e] == Passive::Design {
                    g_rho[e] * proj.derivative(filtered[e])
                } else {
                    0.0
                }
            })
            .collect();
        let mut g_full = vec![0.0; g_rho.len()];
        self.filter.apply_adjoint(&g_tilde, &mut g_full);
        let mut g = vec![0.0; self.space.n()];
        self.space.gather(&g_full, &mut g);
        g
    }

    /// Volume fraction of the design elements and its gradient w.r.t. ρ.
    fn volume(&self, rho: &[f64]) -> (f64, Vec<f64>) {
        let nd = self.space.n_design_elements() as f64;
        let mut g = vec![0.0; rho.len()];
        let mut v = 0.0;
        for e in self.space.design_elements() {
            v += rho[e];
            g[e] = 1.0 / nd;
        }
        (v / nd, g)
    }

    #[allow(clippy::too_many_arguments)]
    fn evaluate_realization(
        &self,
        spec: &RealizationSpec,
        ev: &mut Evaluator,
        ws: &mut Workspace,
        rho: &[f64],
        dens: &Densities,
        beta: f64,
        yeoh: Option<&AdditiveYeoh>,
        skip: &PerResponse<bool>,
    ) -> Result<RealizationEvaluation> {
        let problem = self.problem;
        let response = ev.solve_cases_in(ws, rho, yeoh)?;
        let (mut coef, area, stress_max) = fe_coefficients(problem, spec, rho, ev, &response);
        let mut values = PerResponse::from_fn(|q| coef[q].as_ref().map_or(0.0, |c| c.value));
        for q in ResponseKind::FE {
            if skip[q] && q != ResponseKind::Objective {
                coef[q] = None;
            }
        }
        let g_rho = ev.gradients_in(ws, rho, yeoh, &coef)?;
        let proj = Self::projection(spec, beta);
        let mut gradients = PerResponse::from_fn(|q| {
            g_rho[q]
                .as_ref()
                .map(|g| self.chain(&dens.filtered, proj, g))
        });
        let (v, gv) = self.volume(rho);
        values[ResponseKind::Volume] = v;
        if spec.responses[ResponseKind::Volume] {
            gradients[ResponseKind::Volume] = Some(self.chain(&dens.filtered, proj, &gv));
        }
        Ok(RealizationEvaluation {
            kind: spec.kind,
            response,
            values,
            gradients,
            area,
            stress_max,
            modes: None,
        })
    }

    /// The stage's eigen-analysis of a realization ([`crate::modal`]) on the factorization its
    /// load cases just used: the aggregate `Λ` and its gradient w.r.t. the design variables.
    #[allow(clippy::too_many_arguments)]
    fn resonance(
        &self,
        mw: &mut ModalWorkspace,
        ev: &Evaluator,
        ws: &mut Workspace,
        rho: &[f64],
        dens: &Densities,
        spec: &RealizationSpec,
        beta: f64,
        yeoh: Option<&AdditiveYeoh>,
        r: &mut RealizationEvaluation,
    ) -> Result<()> {
        let design = match yeoh {
            Some(y) => Design::with_yeoh(rho, y),
            None => Design::new(rho),
        };
        let (k, factor) = ev.stiffness_at_rest();
        let modes = mw.solve(
            self.problem,
            &design,
            crate::modal::Factored { k, factor },
            &mut ws.groups[0].sws,
            &ev.params.modal,
            true,
        )?;
        let proj = Self::projection(spec, beta);
        r.values[ResponseKind::Resonance] = modes.aggregate;
        r.gradients[ResponseKind::Resonance] = modes
            .gradient
            .as_ref()
            .map(|g| self.chain(&dens.filtered, proj, g));
        r.modes = Some(modes);
        Ok(())
    }
}

/// Values and case coefficients of the FE responses a realization evaluates, the output
/// polygon's area and the largest relaxed stress.
fn fe_coefficients(
    problem: &Problem,
    spec: &RealizationSpec,
    rho: &[f64],
    ev: &Evaluator,
    r: &CaseResults,
) -> (PerResponse<Option<ResponseCoefficients>>, f64, Option<f64>) {
    let mut coef: PerResponse<Option<ResponseCoefficients>> = PerResponse::default();
    let (obj, area) = responses::objective(problem, r);
    coef[ResponseKind::Objective] = Some(obj);
    let wants = |q| spec.responses[q];
    if wants(ResponseKind::Energy) {
        coef[ResponseKind::Energy] = Some(responses::energy(r));
    }
    if let (true, Some(ms)) = (wants(ResponseKind::Stroke), problem.max_stroke) {
        coef[ResponseKind::Stroke] = Some(responses::stroke(ms, r));
    }
    if let (true, Some(t)) = (wants(ResponseKind::Tilt), problem.tilt) {
        coef[ResponseKind::Tilt] = Some(responses::tilt(t, problem.differential_corners(), r));
    }
    let mut stress_max = None;
    if let (true, Some(sc)) = (wants(ResponseKind::Stress), &problem.stress) {
        let m = stress_measure(&problem.model, sc, rho, &ev.cases);
        stress_max = Some(m.max);
        coef[ResponseKind::Stress] = Some(m.coefficients);
    }
    (coef, area, stress_max)
}
