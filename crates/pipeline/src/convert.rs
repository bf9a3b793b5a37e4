//! The stage crates' values as the typed files of the run folder (`flexstage-run`): the one
//! place where a domain type meets a file type.

use flexstage_assess::margins::MarginRow as Margins;
use flexstage_assess::montecarlo::MonteCarlo;
use flexstage_assess::sweep::SweepPoint;
use flexstage_run::files::design::{DesignRecord, MechanismRecord};
use flexstage_run::files::export as file;
use flexstage_run::files::track::{MarginRow, MonteCarloRow, ScanRow};
use flexstage_topopt::summary::{DesignSummary, MechanismSummary};
use flexstage_verify::Verification;

/// What a design delivers, as `design.json` and `design/summary.json` hold it.
pub(crate) fn design_record(s: &DesignSummary) -> DesignRecord {
    DesignRecord {
        area: s.area,
        area_ratio: s.area_ratio,
        alpha: s.alpha,
        theta_deg: s.theta_deg,
        theta_target_deg: s.theta_target_deg,
        mass: s.mass,
        volume_fraction: s.volume_fraction,
        area_eroded: s.area_eroded,
        area_dilated: s.area_dilated,
        peak_stress: s.peak_stress,
        constrained_stress: s.constrained_stress,
        allowable_stress: s.allowable_stress,
        design_allowable: s.design_allowable,
        one_node_hinges: s.one_node_hinges,
        thinnest_member: s.thinnest_member,
        thinnest_member_at: s.thinnest_member_at,
        narrowest_gap: s.narrowest_gap,
        narrowest_gap_at: s.narrowest_gap_at,
        guaranteed_member: s.guaranteed_member,
        guaranteed_gap: s.guaranteed_gap,
        mirror_asymmetry: s.mirror_asymmetry,
        first_frequency_hz: s.first_frequency_hz,
        frequencies_hz: s.frequencies_hz.clone(),
        mechanism: s.mechanism.as_ref().map(mechanism_record),
    }
}

fn mechanism_record(m: &MechanismSummary) -> MechanismRecord {
    MechanismRecord {
        direction: m.direction,
        output_displacement: m.output_displacement,
        output: m.output,
        inputs: m.inputs.clone(),
        geometric_advantage: m.geometric_advantage,
        eroded: m.eroded,
        dilated: m.dilated,
    }
}

/// The verification of the exported outline as `export/verification.json`.
pub(crate) fn verification(v: &Verification) -> file::VerificationFile {
    let peak = |p: &flexstage_verify::StressPeak| file::StressPeak {
        von_mises: p.von_mises,
        at: p.at,
        case: p.case,
    };
    let transfer = |t: &flexstage_verify::Transfer| file::Transfer {
        alpha_abs: t.alpha_abs,
        alpha: t.alpha,
        alpha_scalar: t.alpha_scalar,
        theta_deg: t.theta_deg,
    };
    let width = |w: &flexstage_verify::manufacture::Width| file::Width {
        width: w.width,
        at: w.at,
    };
    let b = &v.body_fitted;
    let m = &v.manufacturing;
    file::VerificationFile {
        version: file::VERSION,
        allowable: v.allowable,
        yield_strength: v.yield_strength,
        body_fitted: file::BodyFitted {
            nodes: b.nodes,
            elements: b.elements,
            dofs: b.dofs,
            edge_range: b.edge_range,
            area: b.area,
            mass: b.mass,
            stress: peak(&b.stress),
            stress_refined: b.stress_refined.as_ref().map(peak),
            refined_elements: b.refined_elements,
            transfer: transfer(&b.transfer),
            frequencies: b.frequencies.clone(),
        },
        design_mesh: v.design_mesh.as_ref().map(|d| file::DesignMesh {
            elements: d.elements,
            element_size: d.element_size,
            mass: d.mass,
            stress: peak(&d.stress),
            stress_linear: d.stress_linear,
            transfer: transfer(&d.transfer),
            first_frequency: d.first_frequency,
        }),
        manufacturing: file::Manufacturing {
            min_ligament: m.min_ligament.as_ref().map(width),
            min_gap: m.min_gap.as_ref().map(width),
            islands: m.islands,
            pockets: m.pockets,
            findings: m
                .findings
                .iter()
                .map(|f| file::Finding {
                    kind: snake(&format!("{:?}", f.kind)),
                    severity: snake(&format!("{:?}", f.severity)),
                    at_mm: f.at_mm,
                    size: f.size,
                    message: f.message.clone(),
                })
                .collect(),
            filled: m
                .filled
                .iter()
                .map(|f| file::FilledPocket {
                    at: f.at,
                    area: f.area,
                    inscribed: f.inscribed,
                    mass: f.mass,
                })
                .collect(),
        },
        verdict: file::Verdict {
            safe: v.verdict.safe,
            stress_ok: v.verdict.stress_ok,
            manufacturable: v.verdict.manufacturable,
            reasons: v.verdict.reasons.clone(),
        },
    }
}

/// `ThinLigament` → `thin_ligament` (the verification's serde names).
fn snake(name: &str) -> String {
    let mut out = String::new();
    for (i, c) in name.chars().enumerate() {
        if c.is_ascii_uppercase() {
            if i > 0 {
                out.push('_');
            }
            out.push(c.to_ascii_lowercase());
        } else {
            out.push(c);
        }
    }
    out
}

/// The margins of every controller as `margins.csv` rows (two loops each), delay margins in
/// samples of `sample_time`.
pub(crate) fn margin_rows(rows: &[Margins], sample_time: f64) -> Vec<MarginRow> {
    let mut out = Vec::with_capacity(2 * rows.len());
    for r in rows {
        for l in 0..2 {
            let m = r.margins.map(|m| m[l]);
            out.push(MarginRow {
                controller: crate::track::variant_name(r.candidate, r.learning),
                delay_samples: r.delay,
                axis: format!("q{}", l + 1),
                gain_margin_db: m.map(|m| m.gain_db),
                phase_crossover_hz: m.map(|m| m.phase_crossover),
                phase_margin_deg: m.map(|m| m.phase_deg),
                gain_crossover_hz: m.map(|m| m.gain_crossover),
                delay_margin_samples: m.map(|m| m.delay / sample_time),
                method: r.method.to_string(),
                meets_targets: m.is_some() && r.meets,
                montecarlo_pass_pct: r.montecarlo_pass.map(|p| 100.0 * p),
            });
        }
    }
    out
}

/// The Monte-Carlo study as `montecarlo.csv` rows: one per plant and controller.
pub(crate) fn montecarlo_rows(mc: &MonteCarlo) -> Vec<MonteCarloRow> {
    mc.plants
        .iter()
        .flat_map(|p| {
            let q = &p.perturbation;
            p.results.iter().map(move |(c, rms, pass)| MonteCarloRow {
                plant: p.index,
                stiffness: q.stiffness,
                mass: q.mass,
                alpha: q.alpha,
                damping: q.damping,
                coupling1: q.coupling[0],
                coupling2: q.coupling[1],
                delay: q.delay,
                controller: c.name.to_string(),
                rms1_nm: rms[0] * 1e9,
                rms2_nm: rms[1] * 1e9,
                pass: *pass,
            })
        })
        .collect()
}

/// The sweep as `scan_frequency.csv` rows: one per point and controller, then one per point
/// and controller with the learning layer (`<controller>+learning`) where the sweep learned.
pub(crate) fn scan_rows(points: &[SweepPoint]) -> Vec<ScanRow> {
    use flexstage_assess::sweep::Cause;
    use flexstage_control::feasibility::Limit;
    use flexstage_run::files::track::{ScanCause, ScanLimit};
    points
        .iter()
        .flat_map(|p| {
            p.results.iter().chain(&p.learning).map(move |r| {
                let (limit, factor) = match r.reduced {
                    None => (ScanLimit::None, 1.0),
                    Some((l, f)) => (
                        match l {
                            Limit::ControllerStroke => ScanLimit::ControllerStroke,
                            Limit::AmplifierRange => ScanLimit::AmplifierRange,
                            Limit::AmplifierCurrent => ScanLimit::AmplifierCurrent,
                            Limit::AmplifierSlew => ScanLimit::AmplifierSlew,
                        },
                        f,
                    ),
                };
                ScanRow {
                    fraction_of_f1: p.fraction,
                    fast_frequency_hz: p.frequency,
                    amplitude1_m: r.amplitude[0],
                    amplitude2_m: r.amplitude[1],
                    amplitude_limit: limit,
                    amplitude_factor: factor,
                    controller: crate::track::variant_name(r.controller, r.learned.is_some()),
                    rms1_nm: r.rms[0] * 1e9,
                    rms2_nm: r.rms[1] * 1e9,
                    rms1_pct_range: r.rms_pct[0],
                    rms1_between_pct_range: r.rms_between_pct[0],
                    rms2_between_pct_range: r.rms_between_pct[1],
                    rms2_pct_range: r.rms_pct[1],
                    peak1_nm: r.peak[0] * 1e9,
                    peak2_nm: r.peak[1] * 1e9,
                    peak1_pct_range: r.peak_pct[0],
                    peak2_pct_range: r.peak_pct[1],
                    cause: match r.cause {
                        Cause::Bandwidth => ScanCause::Bandwidth,
                        Cause::Distortion => ScanCause::Distortion,
                        Cause::Aliasing => ScanCause::Aliasing,
                        Cause::Unstable => ScanCause::Unstable,
                    },
                    dominant_hz: r.dominant,
                    learning_periods: r.learned.map_or(0, |l| l.periods),
                    learning_rho: r.learned.map_or(f64::NAN, |l| l.rho),
                    learning_law: r.learned.map_or(String::new(), |l| l.law.to_string()),
                }
            })
        })
        .collect()
}

/// The typed rows of a measured response's file (`docs/formats.md`), value for value.
pub fn measured_rows(
    r: &flexstage_identify::measured::MeasuredResponse,
) -> flexstage_run::format::Rows<flexstage_run::files::measured::MeasuredLineRow> {
    let ts = r.sample_time();
    flexstage_run::format::Rows(
        r.lines()
            .iter()
            .map(|l| flexstage_run::files::measured::MeasuredLineRow {
                f: l.f,
                line: line_cells(l, ts),
            })
            .collect(),
    )
}

/// The typed rows of a lifted response's file (`docs/formats.md`), value for value: the
/// phases of each line together, lines by frequency.
pub fn lifted_rows(
    r: &flexstage_identify::measured::LiftedResponse,
) -> flexstage_run::format::Rows<flexstage_run::files::lifted::LiftedLineRow> {
    let ts = r.sample_time();
    flexstage_run::format::Rows(
        r.lines()
            .iter()
            .flat_map(|line| {
                line.phase.iter().enumerate().map(move |(phase, l)| {
                    flexstage_run::files::lifted::LiftedLineRow {
                        f: line.f,
                        phase,
                        line: line_cells(l, ts),
                    }
                })
            })
            .collect(),
    )
}

/// The cells of a response file's row after `f` (and `phase`) for the line `l` of a
/// response at sample time `ts`, value for value.
fn line_cells(
    l: &flexstage_identify::measured::MeasuredLine,
    ts: f64,
) -> flexstage_run::files::measured::LineCells {
    flexstage_run::files::measured::LineCells {
        re11: l.h[0][0].re,
        im11: l.h[0][0].im,
        re12: l.h[0][1].re,
        im12: l.h[0][1].im,
        re21: l.h[1][0].re,
        im21: l.h[1][0].im,
        re22: l.h[1][1].re,
        im22: l.h[1][1].im,
        coh11: l.coherence[0][0],
        coh12: l.coherence[0][1],
        coh21: l.coherence[1][0],
        coh22: l.coherence[1][1],
        sample_time: ts,
        std11: l.std[0][0],
        std12: l.std[0][1],
        std21: l.std[1][0],
        std22: l.std[1][1],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finding_names_are_the_verifications_serde_names() {
        // Reference: flexstage-verify's `#[serde(rename_all = "snake_case")]`.
        use flexstage_verify::{FindingKind, Severity};
        for (k, name) in [
            (FindingKind::Island, "island"),
            (FindingKind::ThinLigament, "thin_ligament"),
            (FindingKind::PocketTooSmall, "pocket_too_small"),
        ] {
            assert_eq!(snake(&format!("{k:?}")), name);
            assert_eq!(serde_json::to_value(k).unwrap(), name);
        }
        assert_eq!(snake(&format!("{:?}", Severity::Error)), "error");
    }
}
