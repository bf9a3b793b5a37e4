//! Section "export verification": what `flexstage export` found when it re-analysed the
//! exported outline on a body-fitted mesh (`export/verification.json`, written by
//! `flexstage-verify`): the verdict and its reasons, the peak von Mises stress against the
//! allowable (and its re-check on a mesh of half the element size), α (Actuators 2022,
//! 11(7), 179, Eq. 27), θ (Eq. 26) and the first natural frequency beside the design mesh's
//! values, and the manufacturability findings.

use serde_json::Value;

use super::{Builder, fmt_num, num};

/// The verification record `flexstage-verify` writes into the run folder.
pub const VERIFICATION_JSON: &str = "export/verification.json";

/// MPa text of a stress \[Pa\] at a JSON path.
fn mpa(v: &Value, path: &[&str]) -> String {
    num(v, path)
        .map(|s| format!("{} MPa", fmt_num(s * 1e-6)))
        .unwrap_or_else(|| "–".into())
}

/// A number at a JSON path, formatted, or "–".
fn val(v: &Value, path: &[&str], scale: f64, unit: &str) -> String {
    num(v, path)
        .map(|x| format!("{}{unit}", fmt_num(x * scale)))
        .unwrap_or_else(|| "–".into())
}

/// The comparison table: body-fitted mesh against the design mesh.
pub(super) fn comparison(v: &Value) -> Vec<Vec<String>> {
    fn bf<'a>(p: &[&'a str]) -> Vec<&'a str> {
        [&["body_fitted"][..], p].concat()
    }
    fn dm<'a>(p: &[&'a str]) -> Vec<&'a str> {
        [&["design_mesh"][..], p].concat()
    }
    vec![
        vec![
            "peak von Mises (stroke corners)".into(),
            mpa(v, &bf(&["stress", "von_mises"])),
            mpa(v, &dm(&["stress", "von_mises"])),
        ],
        vec![
            "  re-check, half the element size".into(),
            mpa(v, &bf(&["stress_refined", "von_mises"])),
            "".into(),
        ],
        vec![
            "α (Eq. 27)".into(),
            val(v, &bf(&["transfer", "alpha_scalar"]), 1.0, ""),
            val(v, &dm(&["transfer", "alpha_scalar"]), 1.0, ""),
        ],
        vec![
            "θ (Eq. 26)".into(),
            val(v, &bf(&["transfer", "theta_deg"]), 1.0, "°"),
            val(v, &dm(&["transfer", "theta_deg"]), 1.0, "°"),
        ],
        vec![
            "first natural frequency".into(),
            val(v, &bf(&["frequencies", "0"]), 1.0, " Hz"),
            val(v, &dm(&["first_frequency"]), 1.0, " Hz"),
        ],
        vec![
            "mass".into(),
            val(v, &bf(&["mass"]), 1e3, " g"),
            val(v, &dm(&["mass"]), 1e3, " g"),
        ],
        vec![
            "elements".into(),
            val(v, &bf(&["elements"]), 1.0, " T6"),
            val(v, &dm(&["elements"]), 1.0, " Q4"),
        ],
    ]
}

/// The verdict line: "SAFE" or "NOT SAFE: reasons".
pub(super) fn verdict(v: &Value) -> String {
    let safe = v
        .pointer("/verdict/safe")
        .and_then(Value::as_bool)
        .unwrap_or(false);
    if safe {
        return "Verdict: safe (stress within the allowable, manufacturable).".into();
    }
    let reasons: Vec<&str> = v
        .pointer("/verdict/reasons")
        .and_then(Value::as_array)
        .map(|r| r.iter().filter_map(Value::as_str).collect())
        .unwrap_or_default();
    if reasons.is_empty() {
        "Verdict: NOT SAFE.".into()
    } else {
        format!("Verdict: NOT SAFE: {}.", reasons.join("; "))
    }
}

/// Section "export verification".
pub(super) fn verification(b: &mut Builder) {
    let Some(v) = b.json(VERIFICATION_JSON) else {
        b.not_run(&format!("{VERIFICATION_JSON} missing"));
        return;
    };
    b.note(&verdict(&v));
    let allowable = format!(
        "Allowable stress {} (fatigue strength / safety factor), yield strength {}. The \
         body-fitted mesh (quadratic triangles on the exported outline) is what is cut; the \
         design mesh is what the optimizer saw.",
        mpa(&v, &["allowable"]),
        mpa(&v, &["yield_strength"])
    );
    b.note(&allowable);
    let header = ["quantity", "body-fitted mesh", "design mesh"].map(String::from);
    b.table(&header, &comparison(&v));
    let m = v.get("manufacturing").cloned().unwrap_or(Value::Null);
    let width = |k: &str| val(&m, &[k, "width"], 1e3, " mm");
    b.kv(&[
        ("thinnest ligament".into(), width("min_ligament")),
        ("narrowest gap".into(), width("min_gap")),
        (
            "islands (unconnected parts)".into(),
            val(&m, &["islands"], 1.0, ""),
        ),
        (
            "closed pockets (start holes)".into(),
            val(&m, &["pockets"], 1.0, ""),
        ),
    ]);
    let findings: Vec<Vec<String>> = m
        .get("findings")
        .and_then(Value::as_array)
        .map(|f| {
            f.iter()
                .map(|f| {
                    let s = |k: &str| f.get(k).and_then(Value::as_str).unwrap_or("").to_string();
                    vec![
                        s("severity"),
                        s("kind").replace('_', " "),
                        format!(
                            "({}, {}) mm",
                            val(f, &["at_mm", "0"], 1.0, ""),
                            val(f, &["at_mm", "1"], 1.0, "")
                        ),
                        s("message"),
                    ]
                })
                .collect()
        })
        .unwrap_or_default();
    if findings.is_empty() {
        b.note("Manufacturability: no findings.");
    } else {
        let header = ["severity", "finding", "where", "message"].map(String::from);
        b.table(&header, &findings);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn verdict_names_the_reasons_and_values_sit_beside_the_design_mesh() {
        // Goal: an unsafe outline says why; the body-fitted and design-mesh values of one
        // quantity share a row.
        let v: Value = serde_json::json!({
            "allowable": 63e6,
            "body_fitted": {"stress": {"von_mises": 70e6}, "transfer": {"alpha_scalar": 2.1},
                            "frequencies": [412.0], "mass": 0.012, "elements": 900},
            "design_mesh": {"stress": {"von_mises": 50e6}, "transfer": {"alpha_scalar": 2.2},
                            "first_frequency": 420.0},
            "verdict": {"safe": false, "reasons": ["stress 70 MPa > allowable 63 MPa"]}
        });
        assert_eq!(
            verdict(&v),
            "Verdict: NOT SAFE: stress 70 MPa > allowable 63 MPa."
        );
        let rows = comparison(&v);
        assert_eq!(rows[0][1..], ["70.00 MPa", "50.00 MPa"]);
        assert_eq!(rows[1][1], "–");
        assert_eq!(rows[2][1..], ["2.100", "2.200"]);
        assert_eq!(rows[4][1..], ["412.0 Hz", "420.0 Hz"]);
    }
}
