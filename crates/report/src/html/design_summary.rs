//! Section "design summary": what the finished design delivers, in the terms users compare
//! (the `"design"` object of `design/summary.json`, written from `flexstage_topopt`'s
//! `DesignSummary`): the differential amplification α and output direction θ (Actuators
//! 2022, 11(7), 179, Eq. 24–29), the absolute workspace area J (Eq. 4), the mass, the peak and
//! the constrained von Mises stress against the allowable, the thinnest member and the
//! narrowest gap against the scenario's manufacturing limits, one-node hinges, the mirror
//! asymmetry and the first natural frequency; with the robust formulation also the
//! workspaces of the eroded and dilated designs.

use flexstage_run::files::design::{DesignRecord, DesignSummaryFile};
use flexstage_run::layout::design as files;

use super::{Builder, fmt_num};

/// A length \[m\] in mm with its location, e.g. "0.512 mm at (12.0, 3.1) mm".
fn length_at(v: Option<f64>, at: Option<[f64; 2]>) -> Option<String> {
    let v = v?;
    let at = match at {
        Some([x, y]) => format!(" at ({:.1}, {:.1}) mm", x * 1e3, y * 1e3),
        None => String::new(),
    };
    Some(format!("{} mm{at}", fmt_num(v * 1e3)))
}

/// "ok" or "BELOW the limit" for a size against its lower limit (both in m).
fn size_verdict(size: Option<f64>, limit: Option<f64>) -> String {
    match (size, limit) {
        (Some(s), Some(l)) if s + 1e-12 >= l => format!("≥ limit {} mm: ok", fmt_num(l * 1e3)),
        (Some(_), Some(l)) => format!("BELOW the limit {} mm", fmt_num(l * 1e3)),
        _ => String::new(),
    }
}

/// The rows of the design summary table: (quantity, value, reference or verdict).
/// The scenario's minimum member and gap \[m\], when known.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct SizeLimits {
    /// `limits.min_hinge_thickness`.
    pub member: Option<f64>,
    /// `limits.min_slot_width`.
    pub gap: Option<f64>,
}

pub(super) fn rows(d: &DesignRecord, limits: SizeLimits) -> Vec<Vec<String>> {
    let mut out: Vec<Vec<String>> = Vec::new();
    let mut row = |q: &str, v: Option<String>, r: String| {
        if let Some(v) = v {
            out.push(vec![q.to_string(), v, r]);
        }
    };
    let mpa = |s: Option<f64>| s.map(|s| format!("{} MPa", fmt_num(s * 1e-6)));
    let um2 = |a: Option<f64>| a.map(|a| format!("{} µm²", fmt_num(a * 1e12)));
    row(
        "α (Eq. 27)",
        Some(fmt_num(d.alpha)),
        "output loaded by the optimizer's spring, at the stroke".into(),
    );
    // Rounding noise of a symmetric design (1e-16°) reads as 0°.
    let theta = if d.theta_deg.abs() < 1e-9 {
        0.0
    } else {
        d.theta_deg
    };
    row(
        "θ of the differential output",
        Some(format!("{}°", fmt_num(theta))),
        format!("target {}°", fmt_num(d.theta_target_deg)),
    );
    row(
        "workspace area J (Eq. 4)",
        um2(Some(d.area)),
        format!("{} × the input stroke square", fmt_num(d.area_ratio)),
    );
    row(
        "workspace of the eroded design",
        um2(d.area_eroded),
        "robust".into(),
    );
    row(
        "workspace of the dilated design",
        um2(d.area_dilated),
        "robust".into(),
    );
    row(
        "mass",
        Some(format!("{} g", fmt_num(d.mass * 1e3))),
        format!("volume fraction {}", fmt_num(d.volume_fraction)),
    );
    let allowable = Some(d.allowable_stress);
    let vs = |s: Option<f64>, bound: Option<f64>, name: &str| match (s, bound) {
        (Some(s), Some(a)) => format!(
            "{} {name} {} MPa{}",
            if s <= a { "≤" } else { ">" },
            fmt_num(a * 1e-6),
            if s <= a { "" } else { " (over)" }
        ),
        _ => String::new(),
    };
    row(
        "peak von Mises (solid elements, stroke corners)",
        mpa(Some(d.peak_stress)),
        vs(Some(d.peak_stress), allowable, "allowable"),
    );
    row(
        "constrained stress (relaxed, eroded design)",
        mpa(d.constrained_stress),
        vs(
            d.constrained_stress,
            Some(d.design_allowable),
            "design-mesh bound",
        ),
    );
    row(
        "thinnest member (ρ = ½)",
        length_at(d.thinnest_member, d.thinnest_member_at),
        size_verdict(d.thinnest_member, limits.member),
    );
    row(
        "narrowest gap (ρ = ½)",
        length_at(d.narrowest_gap, d.narrowest_gap_at),
        size_verdict(d.narrowest_gap, limits.gap),
    );
    row(
        "one-node hinges",
        Some(fmt_num(d.one_node_hinges as f64)),
        match d.one_node_hinges {
            0 => "none: ok".into(),
            _ => "a one-node hinge cannot be manufactured".into(),
        },
    );
    row(
        "mirror asymmetry max |ρ − ρ_mirror|",
        Some(fmt_num(d.mirror_asymmetry)),
        String::new(),
    );
    row(
        "first natural frequency",
        d.first_frequency_hz.map(|f| format!("{} Hz", fmt_num(f))),
        "design mesh without the PEA plate masses".into(),
    );
    out
}

/// Section "design summary".
pub(super) fn design_summary(b: &mut Builder) {
    let Some(summary) = b.load::<DesignSummaryFile>(files::SUMMARY) else {
        b.missing(files::SUMMARY);
        return;
    };
    let limits = b.scenario().map_or(SizeLimits::default(), |s| SizeLimits {
        member: Some(s.limits.min_hinge_thickness),
        gap: Some(s.limits.min_slot_width),
    });
    let rows = rows(&summary.design, limits);
    b.note(
        "Final analysis of the blueprint design, geometrically nonlinear, without the \
         additive material; sizes measured at ρ = ½; limits from the scenario's [limits].",
    );
    let header = ["quantity", "value", "reference"].map(String::from);
    b.table(&header, &rows);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_are_judged_against_the_scenario_limits() {
        // Goal: a member thinner than the workshop limit is flagged, not shown as fine.
        let d = DesignRecord {
            area: 4e-10,
            area_ratio: 1.0,
            alpha: 2.5,
            theta_deg: 0.0,
            theta_target_deg: 0.0,
            mass: 0.05,
            volume_fraction: 0.25,
            area_eroded: None,
            area_dilated: None,
            peak_stress: 90e6,
            constrained_stress: None,
            allowable_stress: 63e6,
            design_allowable: 31.5e6,
            one_node_hinges: 0,
            thinnest_member: Some(0.3e-3),
            thinnest_member_at: Some([0.01, 0.002]),
            narrowest_gap: Some(0.6e-3),
            narrowest_gap_at: None,
            guaranteed_member: None,
            guaranteed_gap: None,
            mirror_asymmetry: 0.0,
            first_frequency_hz: None,
            frequencies_hz: Vec::new(),
            mechanism: None,
        };
        let limits = SizeLimits {
            member: Some(0.5e-3),
            gap: Some(0.4e-3),
        };
        let rows = rows(&d, limits);
        let find = |q: &str| rows.iter().find(|r| r[0].starts_with(q)).unwrap().clone();
        assert_eq!(find("thinnest")[1], "0.3000 mm at (10.0, 2.0) mm");
        assert!(find("thinnest")[2].starts_with("BELOW"));
        assert!(find("narrowest")[2].ends_with("ok"));
        assert!(find("peak von Mises")[2].contains("(over)"));
        assert_eq!(find("workspace area")[1], "400.0 µm²");
        assert!(find("one-node")[2].contains("ok"));
        assert!(!rows.iter().any(|r| r[0].contains("eroded")));
    }
}
