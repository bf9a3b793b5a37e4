//! Section "export verification": what `flexstage export` found when it re-analysed the
//! exported outline on a body-fitted mesh (`export/verification.json`, written by
//! `flexstage-verify`): the verdict and its reasons, the peak von Mises stress against the
//! allowable (and its re-check on a mesh of half the element size), α (Actuators 2022,
//! 11(7), 179, Eq. 27), θ (Eq. 26) and the first natural frequency beside the design mesh's
//! values, and the manufacturability findings.

use flexstage_run::files::export::{VerificationFile, Width};
use flexstage_run::layout::export::VERIFICATION_JSON;

use super::{Builder, fmt_num};

/// MPa text of a stress \[Pa\].
fn mpa(v: Option<f64>) -> String {
    v.map(|s| format!("{} MPa", fmt_num(s * 1e-6)))
        .unwrap_or_else(|| "–".into())
}

/// A number times `scale` with its unit, or "–".
fn val(v: Option<f64>, scale: f64, unit: &str) -> String {
    v.map(|x| format!("{}{unit}", fmt_num(x * scale)))
        .unwrap_or_else(|| "–".into())
}

/// The comparison table: body-fitted mesh against the design mesh.
pub(super) fn comparison(v: &VerificationFile) -> Vec<Vec<String>> {
    let (bf, dm) = (&v.body_fitted, v.design_mesh.as_ref());
    vec![
        vec![
            "peak von Mises (stroke corners)".into(),
            mpa(Some(bf.stress.von_mises)),
            mpa(dm.map(|d| d.stress.von_mises)),
        ],
        vec![
            "  re-check, half the element size".into(),
            mpa(bf.stress_refined.map(|s| s.von_mises)),
            "".into(),
        ],
        vec![
            "α (Eq. 27), output free".into(),
            val(Some(bf.transfer.alpha_scalar), 1.0, ""),
            val(dm.map(|d| d.transfer.alpha_scalar), 1.0, ""),
        ],
        vec![
            "θ (Eq. 26)".into(),
            val(Some(bf.transfer.theta_deg), 1.0, "°"),
            val(dm.map(|d| d.transfer.theta_deg), 1.0, "°"),
        ],
        vec![
            "first natural frequency, with the PEA plate masses".into(),
            val(bf.frequencies.first().copied(), 1.0, " Hz"),
            val(dm.map(|d| d.first_frequency), 1.0, " Hz"),
        ],
        vec![
            "mass".into(),
            val(Some(bf.mass), 1e3, " g"),
            val(dm.map(|d| d.mass), 1e3, " g"),
        ],
        vec![
            "elements".into(),
            val(Some(bf.elements as f64), 1.0, " T6"),
            val(dm.map(|d| d.elements as f64), 1.0, " Q4"),
        ],
    ]
}

/// The verdict line: "SAFE" or "NOT SAFE: reasons".
pub(super) fn verdict(v: &VerificationFile) -> String {
    if v.verdict.safe {
        return "Verdict: safe (stress within the allowable, manufacturable).".into();
    }
    if v.verdict.reasons.is_empty() {
        "Verdict: NOT SAFE.".into()
    } else {
        format!("Verdict: NOT SAFE: {}.", v.verdict.reasons.join("; "))
    }
}

/// Section "export verification".
pub(super) fn verification(b: &mut Builder) {
    let Some(v) = b.load::<VerificationFile>(VERIFICATION_JSON) else {
        b.missing(VERIFICATION_JSON);
        return;
    };
    b.note(&verdict(&v));
    let allowable = format!(
        "Allowable stress {} (fatigue strength / safety factor), yield strength {}. The \
         body-fitted mesh (quadratic triangles on the exported outline) is what is cut; the \
         design mesh is what the optimizer saw.",
        mpa(Some(v.allowable)),
        mpa(Some(v.yield_strength))
    );
    b.note(&allowable);
    let header = ["quantity", "body-fitted mesh", "design mesh"].map(String::from);
    b.table(&header, &comparison(&v));
    let m = &v.manufacturing;
    let width = |w: &Option<Width>| val(w.map(|w| w.width), 1e3, " mm");
    let mut rows = vec![
        ("thinnest ligament".into(), width(&m.min_ligament)),
        ("narrowest gap".into(), width(&m.min_gap)),
        (
            "islands (unconnected parts)".into(),
            val(Some(m.islands as f64), 1.0, ""),
        ),
        (
            "closed pockets (start holes)".into(),
            val(Some(m.pockets as f64), 1.0, ""),
        ),
    ];
    if !m.filled.is_empty() {
        rows.push((
            "pockets too small for a start hole, left solid (checked filled)".into(),
            format!(
                "{} ({} mm², +{} g)",
                m.filled.len(),
                val(Some(m.filled.iter().map(|f| f.area).sum()), 1e6, ""),
                val(Some(m.filled.iter().map(|f| f.mass).sum()), 1e3, "")
            ),
        ));
    }
    b.kv(&rows);
    let findings: Vec<Vec<String>> = m
        .findings
        .iter()
        .map(|f| {
            vec![
                f.severity.clone(),
                f.kind.replace('_', " "),
                format!(
                    "({}, {}) mm",
                    val(Some(f.at_mm[0]), 1.0, ""),
                    val(Some(f.at_mm[1]), 1.0, "")
                ),
                f.message.clone(),
            ]
        })
        .collect();
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
        use flexstage_run::files::export::*;
        let peak = |von_mises| StressPeak {
            von_mises,
            at: [0.0; 2],
            case: [0.0; 2],
        };
        let transfer = |alpha_scalar| Transfer {
            alpha_abs: [[0.0; 2]; 2],
            alpha: [[0.0; 2]; 2],
            alpha_scalar,
            theta_deg: 0.0,
        };
        let v = VerificationFile {
            version: VERSION,
            allowable: 63e6,
            yield_strength: 276e6,
            body_fitted: BodyFitted {
                nodes: 1900,
                elements: 900,
                dofs: 3800,
                edge_range: [1e-4, 1e-3],
                area: 1e-3,
                mass: 0.012,
                stress: peak(70e6),
                stress_refined: None,
                refined_elements: 0,
                transfer: transfer(2.1),
                frequencies: vec![412.0],
            },
            design_mesh: Some(DesignMesh {
                elements: 1152,
                element_size: 2.5e-3,
                mass: 0.012,
                stress: peak(50e6),
                stress_linear: 50e6,
                transfer: transfer(2.2),
                first_frequency: 420.0,
            }),
            manufacturing: Manufacturing {
                min_ligament: None,
                min_gap: None,
                islands: 0,
                pockets: 0,
                findings: Vec::new(),
                filled: Vec::new(),
            },
            verdict: Verdict {
                safe: false,
                stress_ok: false,
                manufacturable: true,
                reasons: vec!["stress 70 MPa > allowable 63 MPa".into()],
            },
        };
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
