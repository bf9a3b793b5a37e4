//! The twin's report data in one call ([`report_data`]): the modes against the FE modal
//! analysis, the Bode data beside the lumped model, and the validity summary (`validity.json`),
//! as the files of `flexstage_report::layout::twin`. The pipeline's `twin` stage and the
//! `validate` example both write these.
//!
//! The check against the full nonlinear transient ([`crate::validate`]) is optional because it
//! is expensive (about 95 s of CPU per 20 ms case on the paper mesh); when it does not run, the
//! reason is recorded in [`TransientCheck::reason`], never skipped silently.

use std::time::Instant;

use flexstage_report::layout;
use flexstage_scenario::StageParams;
use serde::Serialize;

use crate::error::Result;
use crate::reference::{ModeCheck, ValidationParams, Validity, mode_check, validate};
use crate::report::{Bode, bode_for};
use crate::twin::Twin;

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
    /// Wall-clock seconds of the whole check (with the FE modal analysis).
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

/// The twin's report data.
#[derive(Debug, Clone, PartialEq)]
pub struct ReportData {
    /// `validity.json`.
    pub validity: TwinValidity,
    /// The Bode data of the twin beside the lumped model.
    pub bode: Bode,
    /// The full validity result (time series of the cases), when the check ran.
    pub full: Option<Validity>,
}

/// Builds the report data of `twin` (built in `build_seconds`) beside the lumped model
/// `lumped`; the full-transient check runs with `transient` = `Ok(params)` and is recorded as
/// not run with `Err(reason)`.
pub fn report_data(
    twin: &Twin,
    lumped: &StageParams,
    build_seconds: f64,
    transient: std::result::Result<(ValidationParams, String), String>,
) -> Result<ReportData> {
    let t0 = Instant::now();
    let (ran, reason, modes, full) = match transient {
        Ok((p, reason)) => {
            let v = validate(twin, &p)?;
            (true, reason, v.modes.clone(), Some(v))
        }
        Err(reason) => (false, reason, mode_check(twin)?, None),
    };
    let cases = full.as_ref().map(case_rows).unwrap_or_default();
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
            ran,
            reason,
            cases,
            seconds: t0.elapsed().as_secs_f64(),
        },
    };
    Ok(ReportData {
        validity,
        bode: bode_for(twin, lumped)?,
        full,
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

impl ReportData {
    /// `modes.csv`: mode, the twin's frequency \[Hz\], the FE modal analysis's \[Hz\], and the
    /// relative difference (twin − FE)/FE.
    pub fn modes_csv(&self) -> String {
        let mut csv = String::from("mode,frequency_Hz,fe_frequency_Hz,relative_difference\n");
        for m in &self.validity.modes {
            csv.push_str(&format!("{},{},{},{}\n", m.index, m.twin, m.fe, m.relative));
        }
        csv
    }

    /// The files of `flexstage_report::layout::twin` (paths relative to a run folder) and
    /// their contents.
    pub fn files(&self) -> Result<Vec<(&'static str, String)>> {
        let [mag, phase] = self.bode.svg()?;
        // Plain structs of numbers and strings (non-finite numbers become null).
        let json = serde_json::to_string_pretty(&self.validity).expect("plain data serializes");
        Ok(vec![
            (layout::twin::MODES, self.modes_csv()),
            (layout::twin::BODE, self.bode.csv()),
            (layout::twin::BODE_MAGNITUDE_SVG, mag),
            (layout::twin::BODE_PHASE_SVG, phase),
            (layout::twin::VALIDITY, json),
        ])
    }
}
