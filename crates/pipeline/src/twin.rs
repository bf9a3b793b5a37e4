//! `twin`: the digital twin of the run's designed stage (`flexstage-twin`, issue #15) and its
//! report data in `twin/` ([`layout::twin`]).
//!
//! * [`build`] makes the twin of the run's finished design with the scenario's `[twin]` group
//!   (Craig–Bampton reduction of the design's FE model with the PEA sets of Eq. 1–3, Rayleigh
//!   damping, the geometric-nonlinearity fit). `track` simulates on it ([`crate::plant`]).
//! * [`write_twin`] writes what the report shows: the twin's modes against the FE modal
//!   analysis of the same assembled stage (`modes.csv`), its frequency response x_nom → q
//!   beside the lumped 8-state model of the run (`bode.csv`, `bode_magnitude.svg`,
//!   `bode_phase.svg`), and its validity (`validity.json`): the mode errors and, when the
//!   check runs, the step and 200 Hz sine errors against the full nonlinear transient
//!   (`flexstage_twin::validate`) in % of the full model's range.
//!
//! The full transient costs minutes on the paper mesh (about 95 s of CPU per 20 ms case at
//! 14 444 DOF), so [`TwinValidation::Auto`] runs it only on models up to
//! [`AUTO_VALIDATION_DOFS`] free DOFs (the quick preset) and says why it did not otherwise;
//! [`TwinValidation::On`] forces it. It is never skipped silently: `validity.json` records
//! whether it ran and why.

use std::time::Instant;

use flexstage_report::layout;
use flexstage_twin::reference::{ModeCheck, mode_check};
use flexstage_twin::report::bode_for;
use flexstage_twin::{Twin, ValidationParams, Validity, validate};
use serde::Serialize;

use crate::error::{PipelineError, Result};
use crate::folder::RunFolder;
use crate::plant::Plant;
use crate::progress::Progress;
use crate::source::{DesignSource, load_design};

/// Largest FE model (free DOFs) on which [`TwinValidation::Auto`] runs the full transient
/// (the quick preset has 2 398, the paper preset 14 444).
pub const AUTO_VALIDATION_DOFS: usize = 5_000;

/// Whether to check the twin against the full nonlinear transient.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TwinValidation {
    /// On for FE models up to [`AUTO_VALIDATION_DOFS`] free DOFs, off (with the reason)
    /// above. The default.
    #[default]
    Auto,
    /// Always (minutes on the paper mesh).
    On,
    /// Never (the reason is recorded).
    Off,
}

/// Options of the twin's report data.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TwinOptions {
    /// The check against the full transient. Default [`TwinValidation::Auto`].
    pub validation: TwinValidation,
}

impl TwinOptions {
    /// Checks every option (all values are valid).
    pub fn validate(&self) -> Result<()> {
        Ok(())
    }
}

/// The twin of the run's finished design and the seconds it took to build.
pub fn build(folder: &RunFolder) -> Result<(Twin, f64)> {
    let t0 = Instant::now();
    let s = folder.scenario();
    let problem = flexstage_reduce::reduction_problem(s, false)?;
    let rho = load_design(folder, &DesignSource::Run, &problem)?;
    let twin = Twin::from_scenario(s, &rho)?;
    Ok((twin, t0.elapsed().as_secs_f64()))
}

/// One step / sine case of the validity check, in % of the full model's range.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CaseRow {
    /// "step", "sine" or "fast step".
    pub name: String,
    /// Largest |q_twin − q_full| per axis (q1, q2) in % of the full model's range.
    pub error_pct: [f64; 2],
    /// The same for the twin without its nonlinear correction.
    pub linear_error_pct: [f64; 2],
    /// Range (peak to peak) of the full model's output per axis \[m\].
    pub range_m: [f64; 2],
    /// Wall-clock seconds of the full transient of this case.
    pub reference_seconds: f64,
    /// Free DOFs of the full model.
    pub dofs: usize,
    /// Time steps of the full transient.
    pub steps: usize,
}

/// The check against the full nonlinear transient.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TransientCheck {
    /// Whether it ran.
    pub ran: bool,
    /// Why it ran or not.
    pub reason: String,
    /// The cases (empty when it did not run).
    pub cases: Vec<CaseRow>,
    /// Wall-clock seconds of the whole check.
    pub seconds: f64,
}

/// `twin/validity.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TwinValidity {
    /// Number of modes of the twin.
    pub order: usize,
    /// Fixed-interface modes of the Craig–Bampton reduction.
    pub fixed_interface_modes: usize,
    /// The twin's natural frequencies \[Hz\], lowest first.
    pub frequencies_hz: Vec<f64>,
    /// The twin's damping ratios, per mode.
    pub damping_ratios: Vec<f64>,
    /// Coverage × the first resonance \[Hz\]: the band whose modes the twin claims.
    pub covered_frequency_hz: f64,
    /// Whether the geometric-nonlinearity correction is in.
    pub nonlinear: bool,
    /// Seconds to build the twin.
    pub build_seconds: f64,
    /// Every claimed mode against the FE modal analysis of the same assembled stage.
    pub modes: Vec<ModeCheck>,
    /// Largest |relative mode error| in %.
    pub max_mode_error_pct: f64,
    /// Step and sine against the full nonlinear transient.
    pub transient: TransientCheck,
}

/// What [`write_twin`] did.
#[derive(Debug, Clone)]
pub struct TwinSummary {
    /// The validity data (as written to `validity.json`).
    pub validity: TwinValidity,
    /// The folder written.
    pub dir: std::path::PathBuf,
    /// Whether earlier results were replaced.
    pub replaced: bool,
}

/// Builds the twin of the run's design and writes its report data to `twin/`.
pub fn write_twin(
    folder: &RunFolder,
    options: &TwinOptions,
    progress: &dyn Progress,
) -> Result<TwinSummary> {
    options.validate()?;
    progress.note("building the twin of the design (FE model, Craig–Bampton, nonlinear fit)");
    let (twin, build_seconds) = build(folder)?;
    let dofs = twin.fe.model.dofs().n_free();
    let (run_it, reason) = match options.validation {
        TwinValidation::On => (true, "requested".to_string()),
        TwinValidation::Off => (false, "switched off".to_string()),
        TwinValidation::Auto if dofs <= AUTO_VALIDATION_DOFS => (
            true,
            format!("on by default for FE models up to {AUTO_VALIDATION_DOFS} free DOF ({dofs})"),
        ),
        TwinValidation::Auto => (
            false,
            format!(
                "off by default: the FE model has {dofs} free DOF (> {AUTO_VALIDATION_DOFS}), \
                 where the full nonlinear transient costs minutes per 20 ms case; \
                 `flexstage track --write-twin --twin-validate on` runs it"
            ),
        ),
    };
    progress.note(&format!(
        "twin: {} modes, built in {build_seconds:.1} s; check against the full transient: {}",
        twin.modal.modes.len(),
        if run_it { "on" } else { "off" }
    ));
    if !run_it {
        progress.note(&format!("twin: full-transient check {reason}"));
    }
    let t0 = Instant::now();
    let (modes, cases) = if run_it {
        let v = validate(&twin, &ValidationParams::default())?;
        let cases = case_rows(&v);
        (v.modes, cases)
    } else {
        (mode_check(&twin)?, Vec::new())
    };
    let validity = TwinValidity {
        order: twin.modal.modes.len(),
        fixed_interface_modes: twin.reduction.modes(),
        frequencies_hz: twin.frequencies(),
        damping_ratios: twin.modal.modes.iter().map(|m| m.damping).collect(),
        covered_frequency_hz: twin.covered_frequency(),
        nonlinear: twin.nonlinear.is_some(),
        build_seconds,
        max_mode_error_pct: 100.0 * modes.iter().map(|m| m.relative.abs()).fold(0.0, f64::max),
        modes,
        transient: TransientCheck {
            ran: run_it,
            reason,
            cases,
            seconds: t0.elapsed().as_secs_f64(),
        },
    };
    let replaced = folder.has_results(layout::twin::DIR);
    write_files(folder, &twin, &validity)?;
    Ok(TwinSummary {
        validity,
        dir: folder.dir().path(layout::twin::DIR),
        replaced,
    })
}

fn case_rows(v: &Validity) -> Vec<CaseRow> {
    v.cases
        .iter()
        .map(|c| CaseRow {
            name: c.name.clone(),
            error_pct: c.twin.relative().map(|r| 100.0 * r),
            linear_error_pct: c.linear_twin.relative().map(|r| 100.0 * r),
            range_m: c.twin.range,
            reference_seconds: c.cost.seconds,
            dofs: c.cost.dofs,
            steps: c.cost.steps,
        })
        .collect()
}

/// `modes.csv`, `bode.csv`, the two Bode figures (twin beside the run's lumped model: the
/// reduced model of the design, else the scenario's truth) and `validity.json`.
fn write_files(folder: &RunFolder, twin: &Twin, validity: &TwinValidity) -> Result<()> {
    let run = folder.dir();
    let mut csv = String::from("mode,frequency_Hz,fe_frequency_Hz,relative_difference\n");
    for m in &validity.modes {
        csv.push_str(&format!("{},{},{},{}\n", m.index, m.twin, m.fe, m.relative));
    }
    run.write(layout::twin::MODES, csv.as_bytes())?;
    let lumped = Plant::of_run(folder)?.scenario.stage.truth;
    let bode = bode_for(twin, &lumped)?;
    run.write(layout::twin::BODE, bode.csv().as_bytes())?;
    let [mag, phase] = bode.svg()?;
    run.write(layout::twin::BODE_MAGNITUDE_SVG, mag.as_bytes())?;
    run.write(layout::twin::BODE_PHASE_SVG, phase.as_bytes())?;
    let json = serde_json::to_string_pretty(validity).map_err(|e| PipelineError::Format {
        path: layout::twin::VALIDITY.into(),
        reason: e.to_string(),
    })?;
    run.write(layout::twin::VALIDITY, json.as_bytes())?;
    Ok(())
}
