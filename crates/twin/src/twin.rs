//! The twin of a design: build it ([`Twin::build`], [`Twin::from_scenario`]) and turn it into a
//! ready plant inside the scenario's rig ([`Twin::plant`], [`plant`]).

use flexstage_fem::RayleighDamping;
use flexstage_scenario::Scenario;
use flexstage_sim::rig::{RigParams, RigPlant};
use serde::Serialize;

use crate::craig_bampton::{CraigBampton, craig_bampton};
use crate::error::{Result, check};
use crate::modal::ModalStage;
use crate::nonlinear::{NonlinearMap, fit};
use crate::stage::TwinStage;
use crate::structure::StageFe;

/// How the twin is built (scenario `[twin]`). Ranges as in the scenario's validation.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TwinParams {
    /// The fixed-interface modes cover this multiple of the first resonance, in [1, 20].
    pub coverage: f64,
    /// At least this many fixed-interface modes, in [1, 160].
    pub min_modes: usize,
    /// Damping ratio ζ at the first resonance and at max(coverage, 2)× it (Rayleigh), in
    /// [0, 0.5).
    pub damping_ratio: f64,
    /// Fit the geometric nonlinearity.
    pub nonlinear: bool,
    /// Grid points per axis of the nonlinear fit, in [3, 15].
    pub fit_points: usize,
    /// Half-width of the fit's stroke square \[m\], in (0, 1e-3].
    pub fit_amplitude: f64,
    /// The sampled loop's rate f_s \[Hz\] (0: no sampled loop), ≥ 0: the twin's reach covers
    /// f_s + [`SCAN_REACH`] × the first resonance ([`Twin::covered_frequency`]).
    pub sample_rate: f64,
}

/// The fastest scan the sweep runs, as a fraction of the first resonance (`flexstage_assess`'s
/// sweep: 1–30 % of f1). The loop sees the zero-order hold's images of such a scan at
/// f_s ± f and the modes that fold onto it from about f_s, so the twin covers f_s + this × f1.
pub const SCAN_REACH: f64 = 0.3;

impl TwinParams {
    /// The parameters of a scenario: `[twin]`, with the fit over ± `fit_span` ×
    /// `actuators.stroke_amplitude`.
    pub fn from_scenario(s: &Scenario) -> TwinParams {
        let t = &s.twin;
        TwinParams {
            coverage: t.coverage,
            min_modes: t.min_modes,
            damping_ratio: t.damping_ratio,
            nonlinear: t.nonlinear,
            fit_points: t.fit_points,
            fit_amplitude: t.fit_span * s.actuators.stroke_amplitude,
            sample_rate: 1.0 / s.simulation.sample_time,
        }
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        check(
            "twin.coverage",
            self.coverage,
            (1.0..=20.0).contains(&self.coverage),
            "a number in [1, 20]",
        )?;
        check(
            "twin.min_modes",
            self.min_modes as f64,
            (1..=MAX_MODES).contains(&self.min_modes),
            "an integer in [1, 160]",
        )?;
        check(
            "twin.damping_ratio",
            self.damping_ratio,
            (0.0..0.5).contains(&self.damping_ratio),
            "a number in [0, 0.5)",
        )?;
        check(
            "twin.fit_points",
            self.fit_points as f64,
            (3..=15).contains(&self.fit_points),
            "an integer in [3, 15]",
        )?;
        check(
            "simulation.sample_time (twin sample rate)",
            self.sample_rate,
            self.sample_rate.is_finite() && self.sample_rate >= 0.0,
            "a rate ≥ 0 Hz",
        )?;
        check(
            "twin fit amplitude",
            self.fit_amplitude,
            self.fit_amplitude > 0.0 && self.fit_amplitude <= 1e-3,
            "(0, 1e-3] m",
        )
    }
}

/// The digital twin of a design (crate docs).
#[derive(Debug, Clone)]
pub struct Twin {
    /// The assembled stage's FE model (the full reference uses it too).
    pub fe: StageFe,
    /// The Craig–Bampton reduction.
    pub reduction: CraigBampton,
    /// The reduced stage in modal coordinates, damped.
    pub modal: ModalStage,
    /// The geometric-nonlinearity correction (`None`: linear twin).
    pub nonlinear: Option<NonlinearMap>,
    /// The parameters used.
    pub params: TwinParams,
}

/// Most fixed-interface modes the builder will add to reach the coverage.
const MAX_MODES: usize = 160;

/// The fixed-interface modes reach this multiple of the covered band (Craig–Bampton practice:
/// retain fixed-interface modes to about twice the highest frequency of interest, so that the
/// twin's own modes in the band converge).
pub const FIXED_INTERFACE_FACTOR: f64 = 2.0;

impl Twin {
    /// Builds the twin of `fe`: Craig–Bampton with at least `min_modes` fixed-interface modes,
    /// doubled until they reach [`FIXED_INTERFACE_FACTOR`] × the twin's reach (the larger of
    /// `coverage` × the first resonance and f_s + [`SCAN_REACH`] × it; at most 160), Rayleigh
    /// damping, the nonlinear fit.
    pub fn build(fe: StageFe, params: &TwinParams) -> Result<Twin> {
        params.validate()?;
        let mut m = params.min_modes;
        let (reduction, f1) = loop {
            let cb = craig_bampton(&fe, m)?;
            let undamped = ModalStage::new(&cb, fe.k_pea, RayleighDamping::none())?;
            let f1 = undamped.modes[0].frequency;
            let top = cb
                .fixed_interface_frequencies
                .last()
                .copied()
                .unwrap_or(0.0);
            if top >= FIXED_INTERFACE_FACTOR * reach(params, f1) || m >= MAX_MODES {
                break (cb, f1);
            }
            m = (2 * m).min(MAX_MODES);
        };
        let damping = RayleighDamping::from_ratios(
            [f1, params.coverage.max(2.0) * f1],
            [params.damping_ratio; 2],
        )?;
        let modal = ModalStage::new(&reduction, fe.k_pea, damping)?;
        let nonlinear = if params.nonlinear {
            Some(fit(
                &fe,
                &reduction,
                &modal,
                params.fit_amplitude,
                params.fit_points,
            )?)
        } else {
            None
        };
        Ok(Twin {
            fe,
            reduction,
            modal,
            nonlinear,
            params: params.clone(),
        })
    }

    /// The twin of a scenario and a design (physical densities in fem element order, e.g.
    /// `DesignFile::rho`).
    pub fn from_scenario(scenario: &Scenario, rho: &[f64]) -> Result<Twin> {
        let fe = StageFe::from_scenario(scenario, rho)?;
        Twin::build(fe, &TwinParams::from_scenario(scenario))
    }

    /// The mechanics for substeps of `h` seconds, at rest.
    pub fn stage(&self, h: f64) -> TwinStage {
        TwinStage::new(&self.modal, self.nonlinear.clone(), h)
    }

    /// The twin inside a rig, at rest at the bias.
    pub fn plant(&self, rig: &RigParams) -> Result<RigPlant<TwinStage>> {
        Ok(RigPlant::new(rig.clone(), self.stage(rig.substep()))?)
    }

    /// The first resonance \[Hz\].
    pub fn first_resonance(&self) -> f64 {
        self.modal.modes[0].frequency
    }

    /// The natural frequencies of the twin \[Hz\], lowest first.
    pub fn frequencies(&self) -> Vec<f64> {
        self.modal.modes.iter().map(|m| m.frequency).collect()
    }

    /// The twin's reach \[Hz\], the frequency up to which it claims its modes: the larger of
    /// coverage × the first resonance and f_s + [`SCAN_REACH`] × it (the hold's images and
    /// the folded modes of the sweep's fastest scan).
    pub fn covered_frequency(&self) -> f64 {
        reach(&self.params, self.first_resonance())
    }

    /// Static gain x_nom → q of the linear twin.
    pub fn dc_gain(&self) -> [[f64; 2]; 2] {
        self.modal.dc_gain()
    }
}

/// The reach of a twin of parameters `p` and first resonance `f1` \[Hz\]
/// ([`Twin::covered_frequency`]).
fn reach(p: &TwinParams, f1: f64) -> f64 {
    (p.coverage * f1).max(p.sample_rate + SCAN_REACH * f1)
}

/// The twin of `scenario`'s design `rho`, in the scenario's rig, at rest: the plant `track`
/// and `run` simulate on. Returns the twin too (modes, frequency response, validity).
pub fn plant(scenario: &Scenario, rho: &[f64]) -> Result<(Twin, RigPlant<TwinStage>)> {
    let twin = Twin::from_scenario(scenario, rho)?;
    let plant = twin.plant(&RigParams::from_scenario(scenario))?;
    Ok((twin, plant))
}
