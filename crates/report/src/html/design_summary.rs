//! Section "design summary": what the finished design delivers, in the terms users compare
//! (the `"design"` object of `design/summary.json`, written from `flexstage_topopt`'s
//! `DesignSummary`): the differential amplification α and output direction θ (Actuators
//! 2022, 11(7), 179, Eq. 24–29), the absolute workspace area J (Eq. 4), the mass, the peak and
//! the constrained von Mises stress against the allowable, the thinnest member and the
//! narrowest gap against the scenario's manufacturing limits, one-node hinges, the mirror
//! asymmetry and the first natural frequency; with the robust formulation also the
//! workspaces of the eroded and dilated designs.

use serde_json::Value;

use super::{Builder, fmt_num, num, toml_num};
use crate::layout::{self, design as files};

/// A length \[m\] in mm with its location, e.g. "0.512 mm at (12.0, 3.1) mm".
fn length_at(d: &Value, key: &str) -> Option<String> {
    let v = num(d, &[key])?;
    let at = match (
        num(d, &[&format!("{key}_at"), "0"]),
        num(d, &[&format!("{key}_at"), "1"]),
    ) {
        (Some(x), Some(y)) => format!(" at ({:.1}, {:.1}) mm", x * 1e3, y * 1e3),
        _ => String::new(),
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
pub(super) fn rows(d: &Value, limits: &dyn Fn(&str) -> Option<f64>) -> Vec<Vec<String>> {
    let mut out: Vec<Vec<String>> = Vec::new();
    let mut row = |q: &str, v: Option<String>, r: String| {
        if let Some(v) = v {
            out.push(vec![q.to_string(), v, r]);
        }
    };
    let mpa = |k: &str| num(d, &[k]).map(|s| format!("{} MPa", fmt_num(s * 1e-6)));
    let um2 = |k: &str| num(d, &[k]).map(|a| format!("{} µm²", fmt_num(a * 1e12)));
    row("α (Eq. 27)", num(d, &["alpha"]).map(fmt_num), String::new());
    row(
        "θ of the differential output",
        num(d, &["theta_deg"]).map(|t| {
            // Rounding noise of a symmetric design (1e-16°) reads as 0°.
            let t = if t.abs() < 1e-9 { 0.0 } else { t };
            format!("{}°", fmt_num(t))
        }),
        num(d, &["theta_target_deg"])
            .map(|t| format!("target {}°", fmt_num(t)))
            .unwrap_or_default(),
    );
    row(
        "workspace area J (Eq. 4)",
        um2("area"),
        num(d, &["area_ratio"])
            .map(|r| format!("{} × the input stroke square", fmt_num(r)))
            .unwrap_or_default(),
    );
    row(
        "workspace of the eroded design",
        um2("area_eroded"),
        "robust".into(),
    );
    row(
        "workspace of the dilated design",
        um2("area_dilated"),
        "robust".into(),
    );
    row(
        "mass",
        num(d, &["mass"]).map(|m| format!("{} g", fmt_num(m * 1e3))),
        num(d, &["volume_fraction"])
            .map(|v| format!("volume fraction {}", fmt_num(v)))
            .unwrap_or_default(),
    );
    let allowable = num(d, &["allowable_stress"]);
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
        mpa("peak_stress"),
        vs(num(d, &["peak_stress"]), allowable, "allowable"),
    );
    row(
        "constrained stress (relaxed, eroded design)",
        mpa("constrained_stress"),
        vs(
            num(d, &["constrained_stress"]),
            num(d, &["design_allowable"]),
            "design-mesh bound",
        ),
    );
    row(
        "thinnest member (ρ = ½)",
        length_at(d, "thinnest_member"),
        size_verdict(num(d, &["thinnest_member"]), limits("min_hinge_thickness")),
    );
    row(
        "narrowest gap (ρ = ½)",
        length_at(d, "narrowest_gap"),
        size_verdict(num(d, &["narrowest_gap"]), limits("min_slot_width")),
    );
    row(
        "one-node hinges",
        num(d, &["one_node_hinges"]).map(fmt_num),
        match num(d, &["one_node_hinges"]) {
            Some(0.0) => "none: ok".into(),
            Some(_) => "a one-node hinge cannot be manufactured".into(),
            None => String::new(),
        },
    );
    row(
        "mirror asymmetry max |ρ − ρ_mirror|",
        num(d, &["mirror_asymmetry"]).map(fmt_num),
        String::new(),
    );
    row(
        "first natural frequency",
        num(d, &["first_frequency_hz"]).map(|f| format!("{} Hz", fmt_num(f))),
        String::new(),
    );
    out
}

/// Section "design summary".
pub(super) fn design_summary(b: &mut Builder) {
    let Some(d) = b
        .json(files::SUMMARY)
        .and_then(|s| s.get("design").cloned())
    else {
        b.not_run(&format!(
            "{} missing or without a design summary",
            files::SUMMARY
        ));
        return;
    };
    let scenario = b.toml(layout::SCENARIO);
    let limits = |k: &str| scenario.as_ref().and_then(|t| toml_num(t, &["limits", k]));
    let rows = rows(&d, &limits);
    if rows.is_empty() {
        b.not_run(&format!("{}: no known quantity", files::SUMMARY));
        return;
    }
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
        let d: Value = serde_json::json!({
            "alpha": 2.5, "theta_deg": 0.0, "theta_target_deg": 0.0, "area": 4e-10,
            "thinnest_member": 0.3e-3, "thinnest_member_at": [0.01, 0.002],
            "narrowest_gap": 0.6e-3, "peak_stress": 90e6, "allowable_stress": 63e6,
            "one_node_hinges": 0
        });
        let limits = |k: &str| match k {
            "min_hinge_thickness" => Some(0.5e-3),
            "min_slot_width" => Some(0.4e-3),
            _ => None,
        };
        let rows = rows(&d, &limits);
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
