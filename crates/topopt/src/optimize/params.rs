//! Parameters of the design loop, with documented ranges and `validate()`.

use flexstage_mma::MmaParams;
use flexstage_scenario::Scenario;
use serde::{Deserialize, Serialize};

use crate::analysis::AnalysisParams;
use crate::error::{Result, check_range};
use crate::length_scale::{LengthScale, LengthScaleParams};
use crate::realization::RobustThresholds;

/// β continuation of the Heaviside projection.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ProjectionSchedule {
    /// Final β, in [1, 1024].
    pub beta_max: f64,
    /// Iterations between doublings, ≥ 1.
    pub interval: usize,
    /// Threshold η ∈ (0, 1) of the blueprint.
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
    /// Density-filter radius in element sizes, in [0, 20] (≤ 1 = off). With `robust`, the
    /// radius of the length scale is used instead.
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
    /// Projection schedule (None = no projection; the robust formulation needs one).
    pub projection: Option<ProjectionSchedule>,
    /// Robust formulation: the filter radius and thresholds of the minimum sizes (None = the
    /// blueprint alone).
    pub robust: Option<LengthScale>,
    /// Iterations between updates of the dilated design's volume bound (so that the blueprint
    /// meets the volume fraction; Wang, Lazarov & Sigmund 2011, §5: 20) and of the adaptive
    /// stress normalization, in [1, 10000].
    pub update_interval: usize,
    /// Damping α of the adaptive stress normalization `c ← α·max s/Σ_S + (1 − α)·c` (Le et al.
    /// 2010, Eq. 14: 0.5), in (0, 1].
    pub stress_normalization_damping: f64,
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
    /// The scenario's `optimization` settings; with `optimization.robust`, the length scale of
    /// `limits.min_hinge_thickness` and `limits.min_slot_width` on the scenario's mesh.
    pub fn from_scenario(s: &Scenario) -> Self {
        let o = &s.optimization;
        let (dx, dy) = s.mesh.element_size();
        let robust = (o.robust && o.projection.enabled).then(|| {
            LengthScale::map(&LengthScaleParams::new(
                s.limits.min_hinge_thickness,
                s.limits.min_slot_width,
                (dx * dy).sqrt(),
                o.filter_radius.clamp(1.5, 20.0),
            ))
        });
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
            robust,
            additive: o.additive.enabled.then_some(AdditiveParams {
                initial_coefficient: o.additive.initial_coefficient,
                strain_threshold: o.additive.strain_threshold,
            }),
            ..Self::default()
        }
    }

    /// The filter radius in element sizes that the design loop uses.
    pub fn effective_filter_radius(&self) -> f64 {
        self.robust
            .map_or(self.filter_radius, |l| l.radius_elements)
    }

    /// The robust thresholds, if the robust formulation is on.
    pub fn thresholds(&self) -> Option<RobustThresholds> {
        self.robust.map(|l| RobustThresholds {
            eroded: l.eta_eroded,
            dilated: l.eta_dilated,
        })
    }

    /// Check every field.
    pub fn validate(&self) -> Result<()> {
        self.validate_loop()?;
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
        if let Some(l) = self.robust {
            check_range(
                "OptimizerParams::robust (needs a projection)",
                l.eta_eroded,
                self.projection.is_some(),
                "a projection schedule",
            )?;
            check_range(
                "OptimizerParams::robust.eta_eroded",
                l.eta_eroded,
                l.eta_eroded > 0.5 && l.eta_eroded < 1.0,
                "(0.5, 1)",
            )?;
            check_range(
                "OptimizerParams::robust.eta_dilated",
                l.eta_dilated,
                l.eta_dilated > 0.0 && l.eta_dilated < 0.5,
                "(0, 0.5)",
            )?;
            check_range(
                "OptimizerParams::robust.radius_elements",
                l.radius_elements,
                (1.0..=40.0).contains(&l.radius_elements),
                "[1, 40]",
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

    fn validate_loop(&self) -> Result<()> {
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
            "OptimizerParams::update_interval",
            self.update_interval as f64,
            (1..=10_000).contains(&self.update_interval),
            "[1, 10000]",
        )?;
        check_range(
            "OptimizerParams::stress_normalization_damping",
            self.stress_normalization_damping,
            self.stress_normalization_damping > 0.0 && self.stress_normalization_damping <= 1.0,
            "(0, 1]",
        )?;
        check_range(
            "OptimizerParams::objective_scale",
            self.objective_scale,
            self.objective_scale > 0.0 && self.objective_scale.is_finite(),
            "(0, ∞)",
        )
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
            robust: None,
            update_interval: 20,
            stress_normalization_damping: 0.5,
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
