//! `twin`: the digital twin of the run's designed stage (`flexstage-twin`) and its report data
//! in `twin/` ([`layout::twin`]).
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

use flexstage_run::files::twin::{
    CaseRow, ModeCheck, ModeRow, TransientCheck, TwinValidity, VERSION,
};
use flexstage_run::format::Rows;
use flexstage_run::{Table, layout};
use flexstage_twin::reference::{mode_check, validate};
use flexstage_twin::report::bode_for;
use flexstage_twin::{Twin, ValidationParams, Validity};

use crate::error::Result;
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

/// The twin of a run's design, built once: [`build`].
#[derive(Debug)]
pub struct Built {
    /// The twin.
    pub twin: Twin,
    /// Wall-clock seconds its build took.
    pub seconds: f64,
}

/// The twin of the run's finished design and the seconds it took to build.
///
/// `run` builds it once, in its twin stage, and hands the same twin to `track`
/// ([`crate::track::track_on`]); the single-stage commands build their own.
pub fn build(folder: &RunFolder) -> Result<Built> {
    let t0 = Instant::now();
    let s = folder.scenario();
    crate::design::two_pea_stage(s, "twin")?;
    let problem = flexstage_reduce::reduction_problem(s, false)?;
    let rho = load_design(folder, &DesignSource::Run, &problem)?;
    let twin = Twin::from_scenario(s, &rho)?;
    Ok(Built {
        twin,
        seconds: t0.elapsed().as_secs_f64(),
    })
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
    progress.note(crate::track::BUILDING_TWIN);
    write_twin_of(folder, options, progress, &build(folder)?)
}

/// Writes the report data of an already built twin of the run's design to `twin/`.
pub fn write_twin_of(
    folder: &RunFolder,
    options: &TwinOptions,
    progress: &dyn Progress,
    built: &Built,
) -> Result<TwinSummary> {
    options.validate()?;
    let (twin, build_seconds) = (&built.twin, built.seconds);
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
    // The lumped model beside the twin: the reduced model of the design, else the truth.
    let lumped = Plant::of_run(folder)?.scenario.stage.truth;
    let transient = if run_it {
        Ok((ValidationParams::default(), reason))
    } else {
        Err(reason)
    };
    let validity = validity(twin, build_seconds, transient)?;
    let bode = bode_for(twin, &lumped)?;
    let replaced = folder.has_results(layout::twin::DIR);
    let run = folder.dir();
    let modes = validity.modes.iter().map(|m| ModeRow {
        mode: m.index,
        frequency_hz: m.twin,
        fe_frequency_hz: m.fe,
        relative_difference: m.relative,
    });
    run.store(layout::twin::MODES, Rows(modes.collect()))?;
    let (header, columns) = bode.columns();
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    run.store(layout::twin::BODE, Table::new(&header, columns))?;
    let [mag, phase] = bode.svg()?;
    run.write(layout::twin::BODE_MAGNITUDE_SVG, mag.as_bytes())?;
    run.write(layout::twin::BODE_PHASE_SVG, phase.as_bytes())?;
    let validity = run.store(layout::twin::VALIDITY, validity)?;
    Ok(TwinSummary {
        validity: (*validity).clone(),
        dir: folder.dir().path(layout::twin::DIR),
        replaced,
    })
}

/// The twin's validity: its modes against the FE modal analysis and, with `transient` =
/// `Ok(params)`, the check against the full nonlinear transient (recorded as not run, with
/// the reason, for `Err(reason)`).
fn validity(
    twin: &Twin,
    build_seconds: f64,
    transient: std::result::Result<(ValidationParams, String), String>,
) -> Result<TwinValidity> {
    let t0 = Instant::now();
    let (ran, reason, modes, full) = match transient {
        Ok((p, reason)) => {
            let v = validate(twin, &p)?;
            (true, reason, v.modes.clone(), Some(v))
        }
        Err(reason) => (false, reason, mode_check(twin)?, None),
    };
    let modes: Vec<ModeCheck> = modes
        .iter()
        .map(|m| ModeCheck {
            index: m.index,
            twin: m.twin,
            fe: m.fe,
            relative: m.relative,
            damping: m.damping,
        })
        .collect();
    Ok(TwinValidity {
        version: VERSION,
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
            ran,
            reason,
            cases: full.as_ref().map(case_rows).unwrap_or_default(),
            seconds: t0.elapsed().as_secs_f64(),
        },
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
