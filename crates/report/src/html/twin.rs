//! Section "digital twin": the Craig–Bampton twin of the designed stage that the pipeline
//! writes into `twin/`: its modes against the FE modal analysis of the same assembled stage
//! (`modes.csv`), its frequency response beside the run's lumped model (Bode magnitude and
//! phase), and its validity (`validity.json`): order, build time, mode errors and the step
//! and sine errors against the full nonlinear transient in % of the output range.

use serde_json::Value;

use super::{Builder, Width, fmt_num, num};

use crate::layout::twin as files;

/// Key figures of `validity.json` as (quantity, value) rows.
pub(super) fn validity_rows(v: &Value) -> Vec<(String, String)> {
    let mut rows = Vec::new();
    let mut push = |k: &str, val: Option<String>| {
        if let Some(val) = val {
            rows.push((k.to_string(), val));
        }
    };
    push(
        "order (modes of the twin)",
        v.get("order").and_then(Value::as_u64).map(|o| {
            let fi = v
                .get("fixed_interface_modes")
                .and_then(Value::as_u64)
                .map(|f| format!(" ({f} fixed-interface modes)"))
                .unwrap_or_default();
            format!("{o}{fi}")
        }),
    );
    push(
        "band covered",
        num(v, &["covered_frequency_hz"]).map(|f| format!("up to {} Hz", fmt_num(f))),
    );
    push(
        "geometric-nonlinearity correction",
        v.get("nonlinear")
            .and_then(Value::as_bool)
            .map(|n| if n { "on" } else { "off" }.to_string()),
    );
    push(
        "largest mode error vs FE",
        num(v, &["max_mode_error_pct"]).map(|e| format!("{} %", fmt_num(e))),
    );
    push(
        "build time",
        num(v, &["build_seconds"]).map(|s| format!("{} s", fmt_num(s))),
    );
    let transient = v.get("transient").cloned().unwrap_or(Value::Null);
    let ran = transient.get("ran").and_then(Value::as_bool);
    if ran == Some(false) {
        let why = transient
            .get("reason")
            .and_then(Value::as_str)
            .unwrap_or("");
        push(
            "check against the full transient",
            Some(format!("not run: {why}")),
        );
    }
    for c in transient
        .get("cases")
        .and_then(Value::as_array)
        .into_iter()
        .flatten()
    {
        let name = c.get("name").and_then(Value::as_str).unwrap_or("case");
        let pct = |k: &str| match (num(c, &[k, "0"]), num(c, &[k, "1"])) {
            (Some(a), Some(b)) => format!("{} / {} %", fmt_num(a), fmt_num(b)),
            _ => "–".into(),
        };
        push(
            &format!("{name}: error q1 / q2 in % of range"),
            Some(format!(
                "{} (without the nonlinear correction {})",
                pct("error_pct"),
                pct("linear_error_pct")
            )),
        );
    }
    rows
}

/// Section "digital twin".
pub(super) fn twin(b: &mut Builder) {
    let any = [
        files::MODES,
        files::VALIDITY,
        files::BODE_MAGNITUDE_SVG,
        files::BODE_PHASE_SVG,
    ]
    .iter()
    .any(|f| b.exists(f));
    if !any {
        b.not_run(&format!("{}/ missing", files::DIR));
        return;
    }
    b.note(
        "Craig–Bampton twin of the designed stage: its modes against the FE modal analysis \
         of the same assembled stage, its frequency response beside the run's lumped model, \
         and its errors against the full nonlinear transient.",
    );
    if let Some(v) = b.json(files::VALIDITY) {
        b.kv(&validity_rows(&v));
    } else {
        b.not_run(&format!("{} missing", files::VALIDITY));
    }
    b.h3("Modes: twin against FE");
    b.csv_table(files::MODES, |_| true);
    for (rel, caption) in [
        (
            files::BODE_MAGNITUDE_SVG,
            "Bode magnitude: twin beside the lumped model",
        ),
        (
            files::BODE_PHASE_SVG,
            "Bode phase: twin beside the lumped model",
        ),
    ] {
        b.file_figure(rel, caption, Width::Full);
    }
    b.other_figures(files::DIR, "Further twin results");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validity_rows_show_errors_in_percent_and_a_skipped_check() {
        // Goal: the step/sine errors read as % of range; a check that did not run says why.
        let v: Value = serde_json::json!({
            "order": 4, "fixed_interface_modes": 6, "covered_frequency_hz": 3000.0,
            "nonlinear": true, "build_seconds": 1.25, "max_mode_error_pct": 0.5,
            "transient": {"ran": true, "reason": "requested", "cases": [
                {"name": "step", "error_pct": [1.5, 2.0], "linear_error_pct": [3.0, 4.0]}]}
        });
        let rows = validity_rows(&v);
        let get = |k: &str| rows.iter().find(|r| r.0.starts_with(k)).unwrap().1.clone();
        assert_eq!(get("order"), "4 (6 fixed-interface modes)");
        assert_eq!(get("largest mode error"), "0.5000 %");
        assert_eq!(
            get("step"),
            "1.500 / 2.000 % (without the nonlinear correction 3.000 / 4.000 %)"
        );
        let off: Value = serde_json::json!({"transient": {"ran": false, "reason": "too big"}});
        assert_eq!(validity_rows(&off)[0].1, "not run: too big");
    }

    #[test]
    fn fixture_twin_folder_shows_modes_both_bode_figures_and_validity() {
        // Goal: with hand-written twin files the section shows the modes table, both Bode
        // figures and the validity numbers; without them it is "not run".
        let dir = std::env::temp_dir().join(format!("flexstage-html-twin-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join(files::DIR)).unwrap();
        let w = |rel: &str, text: &str| std::fs::write(dir.join(rel), text).unwrap();
        w(
            files::MODES,
            "mode,frequency_Hz,fe_frequency_Hz,relative_difference\n1,412.5,412.0,0.0012\n\
             2,1530.0,1528.0,0.0013\n",
        );
        let svg = |t: &str| {
            format!(
                "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"800\" height=\"400\" \
                 viewBox=\"0 0 800 400\"><text x=\"10\" y=\"20\" font-size=\"16\">{t}</text>\
                 <polyline points=\"0,0 800,400\" stroke=\"black\"/></svg>"
            )
        };
        w(files::BODE_MAGNITUDE_SVG, &svg("magnitude"));
        w(files::BODE_PHASE_SVG, &svg("phase"));
        w(
            files::VALIDITY,
            r#"{"order": 2, "build_seconds": 0.5, "max_mode_error_pct": 0.13,
                "transient": {"ran": true, "cases": [{"name": "sine",
                "error_pct": [0.8, 0.9], "linear_error_pct": [1.0, 1.1]}]}}"#,
        );
        let html = crate::html::build_report(&dir);
        let section = html
            .split("<section id=\"twin\">")
            .nth(1)
            .unwrap()
            .split("</section>")
            .next()
            .unwrap();
        assert!(!section.contains("notrun"), "{section}");
        assert_eq!(section.matches("<figure").count(), 2);
        assert!(section.contains(">magnitude<") && section.contains(">phase<"));
        assert!(section.contains("<td>412.5</td>") && section.contains("<td>1528</td>"));
        assert!(section.contains("0.1300 %") && section.contains("sine: error q1 / q2"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
