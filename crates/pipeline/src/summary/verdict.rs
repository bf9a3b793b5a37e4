//! The run's verdict: what was designed, whether it is safe and why, which controller to use at
//! which scan speed, what failed or was limited, and the quantities the stages compute in
//! several ways, side by side with the reason they differ.
//!
//! Built from the typed results of a run folder (the values the stages stored in this process,
//! else their files, each parsed once); `Display` gives the last screen of `flexstage run`.
//! Each quantity has one name and one convention; where a convention could be misread (α with
//! the output loaded or free) it is said beside the value. New lines go in as new fields or
//! new [`Comparison`]s, so other callers (the CLI, bindings) keep their meaning.

use std::fmt;

use flexstage_control::registry;
use flexstage_run::RunDir;
pub use flexstage_run::files::design::stop_in_words;
use flexstage_run::files::design::{DesignRecord, DesignSummaryFile};
use flexstage_run::files::export::VerificationFile;
use flexstage_run::files::reduce::ReduceSummaryJson;
use flexstage_run::files::track::{LEARNING_SUFFIX, MarginRow, MetricsRow, ScanRow};
use flexstage_run::files::twin::TwinValidity;
use flexstage_run::format::Rows;
use flexstage_run::layout::{self, Tracking};

use crate::error::Result;

/// The scan error the verdict calls acceptable: RMS error of the worse axis \[% of range\].
pub const SCAN_ERROR_PCT: f64 = 1.0;

/// What was designed and whether it is safe.
#[derive(Debug, Clone, PartialEq)]
pub struct Designed {
    /// How the optimization ended, in words ([`stop_in_words`]).
    pub stop: String,
    /// Design iterations.
    pub iterations: usize,
    /// Mass of the design (blueprint on the design mesh) \[kg\].
    pub mass: f64,
    /// Workspace area of the output point, final nonlinear analysis (Eq. 4) \[m²\].
    pub area: f64,
    /// The same for the uniform start design \[m²\].
    pub area_start: f64,
    /// Workspace area in units of the input stroke square `(2a)²`.
    pub area_per_stroke_square: f64,
    /// The design-mesh stress the optimization bounds and its bound \[Pa\] (relaxed, eroded).
    pub constrained_stress: Option<[f64; 2]>,
    /// The body-fitted verification of the exported outline (`None`: not run).
    pub safety: Option<Safety>,
}

/// The body-fitted verification's verdict, with why.
#[derive(Debug, Clone, PartialEq)]
pub struct Safety {
    /// Stress within the allowable and no manufacturability error.
    pub safe: bool,
    /// Peak von Mises stress at the stroke corners on the body-fitted mesh \[Pa\].
    pub peak_stress: f64,
    /// The same on the mesh of half the size \[Pa\].
    pub peak_stress_refined: Option<f64>,
    /// Allowable stress (fatigue strength / safety factor) \[Pa\].
    pub allowable: f64,
    /// Why not safe, in words (empty when safe).
    pub reasons: Vec<String>,
}

/// One quantity the stages compute in several ways.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// Its name.
    pub quantity: &'static str,
    /// Unit of the values as shown.
    pub unit: &'static str,
    /// (how it was computed, value in `unit`).
    pub values: Vec<(String, f64)>,
    /// Why the values differ.
    pub why: &'static str,
}

/// One controller's result on the run's trajectories.
#[derive(Debug, Clone, PartialEq)]
pub struct ControllerResult {
    /// Its registry name.
    pub name: String,
    /// RMS error of q1 and q2 against the true output \[nm\].
    pub rms_nm: [f64; 2],
    /// Whether both loops keep the margin targets (`None`: not measured).
    pub meets_margins: Option<bool>,
    /// Monte-Carlo pass rate \[%\] (`None`: not run).
    pub montecarlo_pass_pct: Option<f64>,
}

impl ControllerResult {
    /// The planar RMS error √(RMS₁² + RMS₂²) \[nm\]: what "best" ranks by (as the report's
    /// tracking section does).
    pub fn planar(&self) -> f64 {
        self.rms_nm[0].hypot(self.rms_nm[1])
    }
}

/// The default and the best controller at one scan frequency (Lissajous 3:1).
#[derive(Debug, Clone, PartialEq)]
pub struct ScanPoint {
    /// Frequency of the fast component \[Hz\].
    pub frequency: f64,
    /// The same as a fraction of the first resonance.
    pub fraction_of_f1: f64,
    /// The default controller's RMS error of the worse axis \[% of range\] (infinite:
    /// diverged).
    pub default_pct: f64,
    /// The controller with the smallest such error, and its error (`None`: every controller
    /// diverged).
    pub best: Option<(String, f64)>,
}

/// The default and the best controller on one trajectory.
#[derive(Debug, Clone, PartialEq)]
pub struct TrajectoryAdvice {
    /// The trajectory.
    pub trajectory: String,
    /// The registry's default controller (`None`: not run).
    pub default: Option<ControllerResult>,
    /// The controller with the smallest planar RMS error among those that keep the
    /// margin targets (all, when no margins were measured).
    pub best: Option<ControllerResult>,
}

/// Which controller to use.
#[derive(Debug, Clone, PartialEq)]
pub struct ControlAdvice {
    /// The default and the best controller on each trajectory, in the run's order.
    pub trajectories: Vec<TrajectoryAdvice>,
    /// Error against scan frequency.
    pub scan: Vec<ScanPoint>,
    /// The fastest scan whose default error stays within [`SCAN_ERROR_PCT`] \[Hz\].
    pub default_fastest: Option<f64>,
}

/// The run's verdict (module docs).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Verdict {
    /// What was designed (`None`: no design).
    pub design: Option<Designed>,
    /// Quantities computed in several ways.
    pub comparisons: Vec<Comparison>,
    /// Which controller to use (`None`: no tracking).
    pub control: Option<ControlAdvice>,
    /// What failed or was limited, in words.
    pub limits: Vec<String>,
}

impl Verdict {
    /// The verdict of the run folder `dir` from its typed results, with the tracking results
    /// of `track` (the folder of the conditions the run tracked under, `track/` by default).
    pub fn of(dir: &RunDir, track: &Tracking) -> Result<Verdict> {
        let summary = dir.load::<DesignSummaryFile>(layout::design::SUMMARY)?;
        let verification = dir.load::<VerificationFile>(layout::export::VERIFICATION_JSON)?;
        let reduce = dir.load::<ReduceSummaryJson>(layout::reduce::SUMMARY_JSON)?;
        let twin = dir.load::<TwinValidity>(layout::twin::VALIDITY)?;
        let metrics = dir.load::<Rows<MetricsRow>>(&track.metrics())?;
        let margins = dir.load::<Rows<MarginRow>>(&track.margins())?;
        let scan = dir.load::<Rows<ScanRow>>(&track.scan_frequency_csv())?;
        let mut v = Verdict::default();
        if let Some(s) = &summary {
            v.design = Some(designed(s, verification.as_deref()));
        }
        let record = summary.as_ref().map(|s| &s.design);
        let first_reduce = reduce
            .as_ref()
            .and_then(|r| r.0.modal.as_ref())
            .and_then(|m| m.frequencies_hz.first().copied());
        v.comparisons = comparisons(
            record,
            verification.as_deref(),
            reduce.as_ref().map(|r| r.0.alpha_scalar),
            first_reduce,
            twin.as_ref()
                .and_then(|t| t.frequencies_hz.first().copied()),
        );
        if let Some(m) = &metrics {
            let margins = margins.as_ref().map_or(&[][..], |m| m.0.as_slice());
            let scan = scan.as_ref().map_or(&[][..], |s| s.0.as_slice());
            v.control = Some(advice(&m.0, margins, scan));
        }
        v.limits = limits(&v, metrics.as_ref().map_or(&[][..], |m| m.0.as_slice()));
        Ok(v)
    }
}

fn designed(s: &DesignSummaryFile, verification: Option<&VerificationFile>) -> Designed {
    let d = &s.design;
    Designed {
        stop: s.stop_in_words(),
        iterations: s.iterations,
        mass: d.mass,
        area: s.area_final_m2,
        area_start: s.area_initial_m2,
        area_per_stroke_square: d.area_ratio,
        constrained_stress: d.constrained_stress.map(|c| [c, d.design_allowable]),
        safety: verification.map(|v| Safety {
            safe: v.verdict.safe,
            peak_stress: v.body_fitted.stress.von_mises,
            peak_stress_refined: v.body_fitted.stress_refined.map(|r| r.von_mises),
            allowable: v.allowable,
            reasons: v.verdict.reasons.clone(),
        }),
    }
}

/// The values that exist, with how each was computed.
fn present(values: Vec<(String, Option<f64>)>) -> Vec<(String, f64)> {
    values
        .into_iter()
        .filter_map(|(k, x)| x.map(|x| (k, x)))
        .collect()
}

/// " at (x, y) mm" of a point in metres.
fn at_mm(p: Option<[f64; 2]>) -> String {
    p.map_or(String::new(), |p| {
        format!(" at ({:.1}, {:.1}) mm", p[0] * 1e3, p[1] * 1e3)
    })
}

/// The quantities computed in several ways; a comparison with fewer than two values is left
/// out (nothing to compare).
fn comparisons(
    d: Option<&DesignRecord>,
    v: Option<&VerificationFile>,
    alpha_reduced: Option<f64>,
    first_reduced: Option<f64>,
    first_twin: Option<f64>,
) -> Vec<Comparison> {
    let body = v.map(|v| &v.body_fitted);
    let mut out = vec![
        Comparison {
            quantity: "amplification α (Eq. 27)",
            unit: "",
            values: present(vec![
                (
                    "design, output loaded (optimizer's spring, at the stroke)".into(),
                    d.map(|d| d.alpha),
                ),
                ("reduced model, output free".into(), alpha_reduced),
                (
                    "cut outline (body-fitted), output free".into(),
                    body.map(|b| b.transfer.alpha_scalar),
                ),
            ]),
            why: "the design's α is taken with the optimizer's output spring \
                  (optimization.output_spring) on the output, which takes part of the motion; \
                  the free-output values differ by the mesh (2D pixels of the design against \
                  the body-fitted mesh of the smoothed outline)",
        },
        Comparison {
            quantity: "first natural frequency",
            unit: "Hz",
            values: present(vec![
                (
                    "design mesh, no plate masses".into(),
                    d.and_then(|d| d.first_frequency_hz),
                ),
                (
                    "design mesh with plate masses (reduced model)".into(),
                    first_reduced,
                ),
                (
                    "cut outline (body-fitted) with plate masses".into(),
                    body.and_then(|b| b.frequencies.first().copied()),
                ),
                ("twin (Craig–Bampton of the design mesh)".into(), first_twin),
            ]),
            why: "the PEA plate masses lower it; the design mesh keeps grey elements (mass ∝ ρ, \
                  stiffness ∝ ρ^p) and a staircase boundary that the smoothed outline does not \
                  have; the twin reduces the design mesh and keeps its first mode",
        },
        Comparison {
            quantity: "thinnest solid member",
            unit: "mm",
            values: present(vec![
                (
                    format!(
                        "design mesh, local thickness of the ρ = ½ field{}",
                        at_mm(d.and_then(|d| d.thinnest_member_at))
                    ),
                    d.and_then(|d| d.thinnest_member).map(|m| m * 1e3),
                ),
                (
                    "guaranteed by the length scale".into(),
                    d.and_then(|d| d.guaranteed_member).map(|m| m * 1e3),
                ),
                (
                    format!(
                        "cut outline, thinnest ligament{}",
                        at_mm(v.and_then(|v| v.manufacturing.min_ligament).map(|w| w.at))
                    ),
                    v.and_then(|v| v.manufacturing.min_ligament)
                        .map(|w| w.width * 1e3),
                ),
            ]),
            why: "they measure different geometry: the design-mesh value is the smallest \
                  local thickness (largest inscribed disk) anywhere in the interpolated density \
                  field at ρ = ½, the outline's the narrowest web between two cut edges of the \
                  smoothed contour, the one the manufacturability check judges; see where each \
                  is",
        },
        Comparison {
            quantity: "mass",
            unit: "g",
            values: present(vec![
                (
                    "design mesh (Σ ρ of the blueprint)".into(),
                    d.map(|d| d.mass * 1e3),
                ),
                ("cut outline".into(), body.map(|b| b.mass * 1e3)),
            ]),
            why: "grey elements count with their density on the design mesh; the outline is \
                  the ρ = ½ contour, smoothed",
        },
    ];
    out.retain(|c| c.values.len() >= 2);
    out
}

/// The controllers' results on each trajectory, the default and the best.
fn advice(metrics: &[MetricsRow], margins: &[MarginRow], scan: &[ScanRow]) -> ControlAdvice {
    // A controller with the learning layer has the margins of its feedback loop (learning
    // shifts the reference, outside the loop): the rows of the design it learns on where
    // that differs (`<controller>+learning`), else the controller's own.
    let base = |name: &str| -> String {
        if margins.iter().any(|m| m.controller == name) {
            return name.to_string();
        }
        name.strip_suffix(LEARNING_SUFFIX)
            .unwrap_or(name)
            .to_string()
    };
    let meets = |name: &str| -> Option<bool> {
        let name = base(name);
        let rows: Vec<&MarginRow> = margins.iter().filter(|m| m.controller == name).collect();
        (!rows.is_empty()).then(|| rows.iter().all(|m| m.meets_targets))
    };
    let pass = |name: &str| -> Option<f64> {
        let name = base(name);
        margins
            .iter()
            .find(|m| m.controller == name)
            .and_then(|m| m.montecarlo_pass_pct)
    };
    let result = |r: &MetricsRow| ControllerResult {
        name: r.variant.clone(),
        rms_nm: [r.rms1_nm, r.rms2_nm],
        meets_margins: meets(&r.variant),
        montecarlo_pass_pct: pass(&r.variant),
    };
    let mut trajectories: Vec<&str> = Vec::new();
    for r in metrics {
        if !trajectories.contains(&r.trajectory.as_str()) {
            trajectories.push(&r.trajectory);
        }
    }
    let default_name = registry::DEFAULT.name;
    let trajectories = trajectories
        .into_iter()
        .map(|t| {
            let rows: Vec<ControllerResult> = metrics
                .iter()
                .filter(|r| r.trajectory == t)
                .map(result)
                .collect();
            let best = rows
                .iter()
                .filter(|r| r.meets_margins != Some(false) && r.planar().is_finite())
                .min_by(|a, b| a.planar().total_cmp(&b.planar()))
                .cloned();
            TrajectoryAdvice {
                trajectory: t.to_string(),
                default: rows.into_iter().find(|r| r.name == default_name),
                best,
            }
        })
        .collect();
    let scan = scan_points(scan, default_name);
    let default_fastest = scan
        .iter()
        .take_while(|p| p.default_pct <= SCAN_ERROR_PCT)
        .last()
        .map(|p| p.frequency);
    ControlAdvice {
        trajectories,
        scan,
        default_fastest,
    }
}

/// The default and the best controller at each scan frequency, slowest first.
fn scan_points(rows: &[ScanRow], default_name: &str) -> Vec<ScanPoint> {
    let mut out: Vec<ScanPoint> = Vec::new();
    for r in rows {
        let err = r.rms1_pct_range.max(r.rms2_pct_range);
        let err = if err.is_nan() { f64::INFINITY } else { err };
        let i = match out.iter().position(|p| p.frequency == r.fast_frequency_hz) {
            Some(i) => i,
            None => {
                out.push(ScanPoint {
                    frequency: r.fast_frequency_hz,
                    fraction_of_f1: r.fraction_of_f1,
                    default_pct: f64::INFINITY,
                    best: None,
                });
                out.len() - 1
            }
        };
        let p = &mut out[i];
        if r.controller == default_name {
            p.default_pct = err;
        }
        if err.is_finite() && p.best.as_ref().is_none_or(|(_, e)| err < *e) {
            p.best = Some((r.controller.clone(), err));
        }
    }
    out.sort_by(|a, b| a.frequency.total_cmp(&b.frequency));
    out
}

/// What failed or was limited.
fn limits(v: &Verdict, metrics: &[MetricsRow]) -> Vec<String> {
    let mut out = Vec::new();
    if let Some(d) = &v.design {
        if d.stop.contains("not converged") {
            out.push(format!(
                "the design {} ({} iterations; more iterations, `--max-iterations`, may still \
                 change it)",
                d.stop, d.iterations
            ));
        }
        if let Some([c, bound]) = d.constrained_stress
            && c > bound
        {
            out.push(format!(
                "the design-mesh stress the optimization bounds is {:.1} MPa, {:.1} % over its \
                 bound {:.1} MPa (the body-fitted check of the outline decides whether the part \
                 is safe)",
                c * 1e-6,
                100.0 * (c / bound - 1.0),
                bound * 1e-6
            ));
        }
        if d.safety.is_none() {
            out.push("the exported outline was not verified: safety unknown".into());
        }
    }
    if let Some(c) = &v.control {
        let mut failing: Vec<&str> = c
            .trajectories
            .iter()
            .filter_map(|t| t.default.as_ref())
            .filter(|r| r.meets_margins == Some(false))
            .map(|r| r.name.as_str())
            .collect();
        failing.dedup();
        for name in failing {
            out.push(format!("{name} misses the 6 dB / 40° margin targets"));
        }
    }
    let saturated: Vec<String> = metrics
        .iter()
        .filter(|r| r.saturated_samples > 0)
        .map(|r| format!("{} on {}", r.variant, r.trajectory))
        .collect();
    if !saturated.is_empty() {
        out.push(format!(
            "the amplifier saturated for {}",
            saturated.join(", ")
        ));
    }
    for r in metrics
        .iter()
        .filter(|r| !matches!(r.status.as_str(), "" | "ok" | "saturated"))
    {
        out.push(format!(
            "{} on {}: {} ({})",
            r.variant, r.trajectory, r.status, r.status_detail
        ));
    }
    out
}

/// "q1/q2 nm" of a result.
fn rms(r: &ControllerResult) -> String {
    format!("{:.1} / {:.1} nm", r.rms_nm[0], r.rms_nm[1])
}

/// Margins and Monte-Carlo pass rate of a result, in words.
fn robustness(r: &ControllerResult) -> String {
    let margins = match r.meets_margins {
        Some(true) => "margins met",
        Some(false) => "margins MISSED",
        None => "margins not measured",
    };
    match r.montecarlo_pass_pct {
        Some(p) => format!("{margins}, Monte-Carlo pass {p:.0} %"),
        None => margins.to_string(),
    }
}

impl fmt::Display for Designed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "designed: a {:.1} g stage; workspace {:.0} µm² = {:.3} × the input stroke square \
             (×{:.1} the uniform start design's {:.1} µm²)",
            self.mass * 1e3,
            self.area * 1e12,
            self.area_per_stroke_square,
            self.area / self.area_start,
            self.area_start * 1e12
        )?;
        writeln!(
            f,
            "  the optimization {} ({} iterations)",
            self.stop, self.iterations
        )?;
        let Some(s) = &self.safety else {
            return writeln!(f, "safe: unknown (the outline was not verified)");
        };
        let refined = s
            .peak_stress_refined
            .map(|r| format!(", {:.1} MPa on a mesh of half the size", r * 1e-6))
            .unwrap_or_default();
        let text = if s.safe {
            format!(
                "safe: yes: peak von Mises of the cut outline {:.1} MPa{refined} ≤ allowable {:.1} \
                 MPa (fatigue strength / safety factor); no manufacturability error",
                s.peak_stress * 1e-6,
                s.allowable * 1e-6
            )
        } else {
            format!("safe: NO: {}", s.reasons.join("; "))
        };
        for line in wrap(&text, 96) {
            writeln!(f, "{line}")?;
        }
        Ok(())
    }
}

impl fmt::Display for Comparison {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.unit {
            "" => writeln!(f, "  {}", self.quantity)?,
            unit => writeln!(f, "  {} [{unit}]", self.quantity)?,
        }
        for (how, x) in &self.values {
            writeln!(f, "    {:>8}  {how}", fmt_value(*x, self.unit))?;
        }
        for line in wrap(&format!("why: {}", self.why), 88) {
            writeln!(f, "    {line}")?;
        }
        Ok(())
    }
}

/// `text` in lines of at most `width` characters (longer words stay whole), the lines after
/// the first indented by two spaces.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        let len = line.chars().count();
        if len > 0 && len + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut line));
            line.push_str("  ");
        }
        if !line.trim().is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.trim().is_empty() {
        lines.push(line);
    }
    lines
}

/// A value with the digits its unit needs.
fn fmt_value(x: f64, unit: &str) -> String {
    match unit {
        "Hz" => format!("{x:.0}"),
        "mm" => format!("{x:.2}"),
        "g" => format!("{x:.1}"),
        _ => format!("{x:.3}"),
    }
}

impl fmt::Display for ControlAdvice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let default = registry::DEFAULT.name;
        match self.default_fastest {
            Some(hz) => writeln!(
                f,
                "use: {default} (the default controller) for scans up to {hz:.0} Hz (RMS error \
                 within {SCAN_ERROR_PCT} % of range); per trajectory:"
            )?,
            None if !self.scan.is_empty() => writeln!(
                f,
                "use: {default} (the default controller; its scan error exceeds \
                 {SCAN_ERROR_PCT} % of range at every scan frequency tried); per trajectory:"
            )?,
            None => writeln!(
                f,
                "use: {default} (the default controller); per trajectory:"
            )?,
        }
        for t in &self.trajectories {
            let default = match &t.default {
                Some(d) => format!("default {} {} ({})", d.name, rms(d), robustness(d)),
                None => format!("default {} not run", registry::DEFAULT.name),
            };
            let best = match (&t.best, &t.default) {
                (Some(b), Some(d)) if b.name == d.name => "the default is the best".to_string(),
                (Some(b), _) => format!("best {} {} ({})", b.name, rms(b), robustness(b)),
                (None, _) => "no controller keeps the margin targets".to_string(),
            };
            for (i, line) in wrap(&format!("{default}; {best}"), 84)
                .into_iter()
                .enumerate()
            {
                let name = if i == 0 { t.trajectory.as_str() } else { "" };
                writeln!(f, "  {name:<12} {line}")?;
            }
        }
        if self.scan.is_empty() {
            return Ok(());
        }
        let note = "(RMS error q1 / q2 against the true output; best: the smallest planar RMS \
                    error √(q1² + q2²) among the controllers that keep the 6 dB / 40° margins)";
        for line in wrap(note, 96) {
            writeln!(f, "  {line}")?;
        }
        writeln!(
            f,
            "scan speed (Lissajous 3:1, fast axis; RMS error of the larger axis, % of range):"
        )?;
        let pct = |x: f64| {
            if x.is_finite() {
                format!("{x:.2} %")
            } else {
                "diverged".into()
            }
        };
        for p in &self.scan {
            let best = match &p.best {
                Some((name, e)) => format!("best {name} {}", pct(*e)),
                None => "every controller diverged".into(),
            };
            writeln!(
                f,
                "  {:>6.0} Hz ({:>4.0} % of f1): default {:<9} {best}",
                p.frequency,
                100.0 * p.fraction_of_f1,
                pct(p.default_pct)
            )?;
        }
        Ok(())
    }
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.design {
            Some(d) => d.fmt(f)?,
            None => writeln!(f, "designed: nothing (no design in this folder)")?,
        }
        if let Some(c) = &self.control {
            c.fmt(f)?;
        }
        if !self.comparisons.is_empty() {
            writeln!(f, "computed in several ways:")?;
            for c in &self.comparisons {
                c.fmt(f)?;
            }
        }
        if self.limits.is_empty() {
            writeln!(f, "limits: none found")
        } else {
            writeln!(f, "limits:")?;
            for l in &self.limits {
                for (i, line) in wrap(l, 92).into_iter().enumerate() {
                    let bullet = if i == 0 { "  - " } else { "  " };
                    writeln!(f, "{bullet}{line}")?;
                }
            }
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn metrics(trajectory: &str, variant: &str, rms: [f64; 2], saturated: usize) -> MetricsRow {
        MetricsRow {
            trajectory: trajectory.into(),
            variant: variant.into(),
            compensation: "inverse".into(),
            model: "guess".into(),
            plant: "twin".into(),
            rms1_nm: rms[0],
            rms2_nm: rms[1],
            rms1_pct: 0.0,
            rms2_pct: 0.0,
            max1_nm: 0.0,
            max2_nm: 0.0,
            max1_pct: 0.0,
            max2_pct: 0.0,
            settling_s: 0.0,
            peak_voltage_v: 0.0,
            saturated_samples: saturated,
            dropouts: 0,
            workspace_usage: 0.5,
            status: "ok".into(),
            status_detail: String::new(),
        }
    }

    fn margin(controller: &str, meets: bool, pass: f64) -> MarginRow {
        MarginRow {
            controller: controller.into(),
            delay_samples: 1,
            axis: "q1".into(),
            gain_margin_db: Some(6.0),
            phase_crossover_hz: None,
            phase_margin_deg: None,
            gain_crossover_hz: None,
            delay_margin_samples: None,
            method: "transfer function".into(),
            meets_targets: meets,
            montecarlo_pass_pct: Some(pass),
        }
    }

    fn scan(hz: f64, controller: &str, pct: [f64; 2]) -> ScanRow {
        ScanRow {
            fraction_of_f1: hz / 1000.0,
            fast_frequency_hz: hz,
            amplitude1_m: 1e-6,
            amplitude2_m: 1e-6,
            amplitude_limit: flexstage_run::files::track::ScanLimit::None,
            amplitude_factor: 1.0,
            controller: controller.into(),
            rms1_nm: 0.0,
            rms2_nm: 0.0,
            rms1_pct_range: pct[0],
            rms2_pct_range: pct[1],
            peak1_nm: 0.0,
            peak2_nm: 0.0,
            peak1_pct_range: 2.0 * pct[0],
            peak2_pct_range: 2.0 * pct[1],
            cause: flexstage_run::files::track::ScanCause::Bandwidth,
            dominant_hz: hz,
            rms1_between_pct_range: f64::NAN,
            rms2_between_pct_range: f64::NAN,
            learning_periods: 0,
            learning_rho: f64::NAN,
            learning_law: String::new(),
        }
    }

    #[test]
    fn stop_reasons_read_as_words() {
        assert_eq!(stop_in_words("Converged"), "converged");
        assert!(stop_in_words("MaxIterations").contains("iteration limit"));
        assert!(!stop_in_words("Stagnated").contains("Stagnated"));
    }

    #[test]
    fn a_controller_with_learning_is_judged_by_its_feedback_controllers_margins() {
        // Goal: `<controller>+learning` wins when it tracks best and its feedback controller
        // keeps its margins (with that controller's Monte-Carlo pass rate), and is never best
        // when the feedback controller misses them.
        let default = registry::DEFAULT.name;
        let rows = [
            metrics("circle", default, [4.0, 5.0], 0),
            metrics(
                "circle",
                &format!("{default}{LEARNING_SUFFIX}"),
                [2.0, 2.0],
                0,
            ),
            metrics("circle", &format!("fast{LEARNING_SUFFIX}"), [1.0, 1.0], 0),
        ];
        let margins = [margin(default, true, 95.0), margin("fast", false, 0.0)];
        let a = advice(&rows, &margins, &[]);
        let best = a.trajectories[0].best.as_ref().unwrap();
        assert_eq!(best.name, format!("{default}+learning"));
        assert_eq!(best.meets_margins, Some(true));
        assert_eq!(best.montecarlo_pass_pct, Some(95.0));
    }

    #[test]
    fn best_controller_keeps_the_margins_and_ranks_by_the_planar() {
        // Goal: a controller that misses its margins is never "best", however small its error;
        // among the others the smallest planar RMS √(q1² + q2²) wins (robust 5.85 nm against
        // the default's 6.40 and pid-ff's 6.43, though pid-ff has the smaller larger axis).
        let default = registry::DEFAULT.name;
        let rows = [
            metrics("circle", default, [4.0, 5.0], 0),
            metrics("circle", "robust", [2.0, 5.5], 0),
            metrics("circle", "pid-ff", [4.5, 4.6], 0),
            metrics("circle", "fast", [1.0, 1.0], 3),
        ];
        let margins = [
            margin(default, true, 95.0),
            margin("robust", true, 69.0),
            margin("pid-ff", true, 10.0),
            margin("fast", false, 0.0),
        ];
        let a = advice(&rows, &margins, &[]);
        let t = &a.trajectories[0];
        assert_eq!(t.default.as_ref().unwrap().name, default);
        assert_eq!(t.best.as_ref().unwrap().name, "robust");
        assert_eq!(t.best.as_ref().unwrap().montecarlo_pass_pct, Some(69.0));
        let v = Verdict {
            control: Some(a),
            ..Verdict::default()
        };
        let limits = limits(&v, &rows);
        assert!(
            limits
                .iter()
                .any(|l| l.contains("saturated for fast on circle")),
            "{limits:?}"
        );
    }

    #[test]
    fn scan_points_name_the_best_and_the_fastest_default_scan_within_the_bound() {
        let default = registry::DEFAULT.name;
        let rows = [
            scan(64.0, default, [0.7, 0.2]),
            scan(32.0, default, [0.3, 0.1]),
            scan(32.0, "robust", [0.2, 0.25]),
            scan(64.0, "robust", [0.9, 0.5]),
            scan(97.0, default, [2.3, 0.6]),
            scan(97.0, "robust", [f64::INFINITY, f64::INFINITY]),
            scan(966.0, default, [f64::INFINITY, f64::INFINITY]),
        ];
        let a = advice(&[], &[], &rows);
        let hz: Vec<f64> = a.scan.iter().map(|p| p.frequency).collect();
        assert_eq!(hz, [32.0, 64.0, 97.0, 966.0]);
        assert_eq!(a.scan[0].best, Some(("robust".into(), 0.25)));
        assert_eq!(a.scan[1].best, Some((default.into(), 0.7)));
        assert_eq!(a.scan[3].best, None);
        assert_eq!(a.default_fastest, Some(64.0));
        let text = a.to_string();
        assert!(text.contains("up to 64 Hz"), "{text}");
        assert!(text.contains("every controller diverged"), "{text}");
    }

    #[test]
    fn a_constrained_stress_over_its_bound_is_a_limit_and_the_screen_says_so() {
        let d = Designed {
            stop: stop_in_words("MaxIterations"),
            iterations: 101,
            mass: 0.0472,
            area: 4751e-12,
            area_start: 75.72e-12,
            area_per_stroke_square: 1.32,
            constrained_stress: Some([32.7e6, 32.2e6]),
            safety: None,
        };
        let v = Verdict {
            design: Some(d),
            ..Verdict::default()
        };
        let limits = limits(&v, &[]);
        assert_eq!(limits.len(), 3, "{limits:?}");
        assert!(
            limits[1].contains("1.6 % over its bound 32.2 MPa"),
            "{limits:?}"
        );
        let v = Verdict { limits, ..v };
        let text = v.to_string();
        assert!(
            text.contains("×62.7 the uniform start design's 75.7 µm²"),
            "{text}"
        );
        assert!(text.contains("safe: unknown"), "{text}");
        assert!(!text.contains("MaxIterations"), "{text}");
    }

    #[test]
    fn long_reasons_wrap_without_losing_words() {
        let text = "why: the design's α is taken with the optimizer's output spring on the output";
        let lines = wrap(text, 30);
        assert!(lines.iter().all(|l| l.chars().count() <= 30), "{lines:?}");
        let joined: Vec<&str> = lines.iter().flat_map(|l| l.split_whitespace()).collect();
        assert_eq!(joined, text.split_whitespace().collect::<Vec<_>>());
    }
}
