//! Section "digital twin": the Craig–Bampton twin of the designed stage that the pipeline
//! writes into `twin/`: its modes against the FE modal analysis of the same assembled stage
//! (`modes.csv`), its frequency response beside the run's lumped model (Bode magnitude and
//! phase), and its validity (`validity.json`): order, build time, mode errors and the step
//! and sine errors against the full nonlinear transient in % of the output range.

use flexstage_run::files::twin::{ModeRow, TwinValidity};
use flexstage_run::format::Rows;
use flexstage_run::layout::twin as files;

use super::{Builder, Width, cell, fmt_num};

/// Key figures of `validity.json` as (quantity, value) rows.
pub(super) fn validity_rows(v: &TwinValidity) -> Vec<(String, String)> {
    let mut rows = vec![
        (
            "order (modes of the twin)".to_string(),
            format!(
                "{} ({} fixed-interface modes)",
                v.order, v.fixed_interface_modes
            ),
        ),
        (
            "reach (modes claimed)".into(),
            format!(
                "up to {} Hz (coverage × f1 or f_s + 0.3 f1, the larger)",
                fmt_num(v.covered_frequency_hz)
            ),
        ),
        (
            "geometric-nonlinearity correction".into(),
            if v.nonlinear { "on" } else { "off" }.to_string(),
        ),
        (
            "largest mode error vs FE".into(),
            format!("{} %", fmt_num(v.max_mode_error_pct)),
        ),
        (
            "build time".into(),
            format!("{} s", fmt_num(v.build_seconds)),
        ),
    ];
    let t = &v.transient;
    if !t.ran {
        rows.push((
            "check against the full transient".into(),
            format!("not run: {}", t.reason),
        ));
    }
    for c in &t.cases {
        let pct = |e: [f64; 2]| format!("{} / {} %", fmt_num(e[0]), fmt_num(e[1]));
        rows.push((
            format!("{}: error q1 / q2 in % of range", c.name),
            format!(
                "{} (without the nonlinear correction {})",
                pct(c.error_pct),
                pct(c.linear_error_pct)
            ),
        ));
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
    match b.load::<TwinValidity>(files::VALIDITY) {
        Some(v) => b.kv(&validity_rows(&v)),
        None => b.missing(files::VALIDITY),
    }
    b.h3("Modes: twin against FE");
    match b.load::<Rows<ModeRow>>(files::MODES) {
        Some(modes) => {
            let header: Vec<String> = [
                "mode",
                "twin [Hz]",
                "full FE model [Hz]",
                "relative difference (twin − FE) / FE",
            ]
            .map(String::from)
            .to_vec();
            let rows: Vec<Vec<String>> = modes
                .0
                .iter()
                .map(|m| {
                    vec![
                        m.mode.to_string(),
                        cell(m.frequency_hz),
                        cell(m.fe_frequency_hz),
                        cell(m.relative_difference),
                    ]
                })
                .collect();
            b.table(&header, &rows);
        }
        None => b.missing(files::MODES),
    }
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
    use flexstage_run::RunDir;
    use flexstage_run::files::twin::{CaseRow, TransientCheck, VERSION};

    fn validity(ran: bool, cases: Vec<CaseRow>) -> TwinValidity {
        TwinValidity {
            version: VERSION,
            order: 4,
            fixed_interface_modes: 6,
            frequencies_hz: vec![412.5],
            damping_ratios: vec![0.01],
            covered_frequency_hz: 3000.0,
            nonlinear: true,
            build_seconds: 1.25,
            modes: Vec::new(),
            max_mode_error_pct: 0.5,
            transient: TransientCheck {
                ran,
                reason: "too big".into(),
                cases,
                seconds: 0.0,
            },
        }
    }

    fn case(name: &str, error_pct: [f64; 2], linear_error_pct: [f64; 2]) -> CaseRow {
        CaseRow {
            name: name.into(),
            error_pct,
            linear_error_pct,
            range_m: [1e-6; 2],
            reference_seconds: 1.0,
            dofs: 100,
            steps: 10,
        }
    }

    #[test]
    fn validity_rows_show_errors_in_percent_and_a_skipped_check() {
        // Goal: the step/sine errors read as % of range; a check that did not run says why.
        let v = validity(true, vec![case("step", [1.5, 2.0], [3.0, 4.0])]);
        let rows = validity_rows(&v);
        let get = |k: &str| rows.iter().find(|r| r.0.starts_with(k)).unwrap().1.clone();
        assert_eq!(get("order"), "4 (6 fixed-interface modes)");
        assert_eq!(get("largest mode error"), "0.5000 %");
        assert_eq!(
            get("step"),
            "1.500 / 2.000 % (without the nonlinear correction 3.000 / 4.000 %)"
        );
        let off = validity_rows(&validity(false, Vec::new()));
        assert_eq!(off.last().unwrap().1, "not run: too big");
    }

    #[test]
    fn fixture_twin_folder_shows_modes_both_bode_figures_and_validity() {
        // Goal: with twin files the section shows the modes table, both Bode figures and the
        // validity numbers; a damaged file is an error on the page and in the report's list.
        let root = std::env::temp_dir().join(format!("flexstage-html-twin-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dir = RunDir::create(&root).unwrap();
        let mode = |mode, frequency_hz, fe_frequency_hz, relative_difference| ModeRow {
            mode,
            frequency_hz,
            fe_frequency_hz,
            relative_difference,
        };
        dir.store(
            files::MODES,
            Rows(vec![
                mode(1, 412.5, 412.0, 0.0012),
                mode(2, 1530.0, 1528.0, 0.0013),
            ]),
        )
        .unwrap();
        let svg = |t: &str| {
            format!(
                "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"800\" height=\"400\" \
                 viewBox=\"0 0 800 400\"><text x=\"10\" y=\"20\" font-size=\"16\">{t}</text>\
                 <polyline points=\"0,0 800,400\" stroke=\"black\"/></svg>"
            )
        };
        dir.write(files::BODE_MAGNITUDE_SVG, svg("magnitude").as_bytes())
            .unwrap();
        dir.write(files::BODE_PHASE_SVG, svg("phase").as_bytes())
            .unwrap();
        let mut v = validity(true, vec![case("sine", [0.8, 0.9], [1.0, 1.1])]);
        v.max_mode_error_pct = 0.13;
        dir.store(files::VALIDITY, v).unwrap();
        let report = crate::html::build_report(&RunDir::create(&root).unwrap());
        assert!(report.errors.is_empty(), "{:?}", report.errors);
        let section = |html: &str| {
            html.split("<section id=\"twin\">")
                .nth(1)
                .unwrap()
                .split("</section>")
                .next()
                .unwrap()
                .to_string()
        };
        let twin = section(&report.html);
        assert!(!twin.contains("notrun"), "{twin}");
        assert_eq!(twin.matches("<figure").count(), 2);
        assert!(twin.contains(">magnitude<") && twin.contains(">phase<"));
        assert!(twin.contains("<td>412.5</td>") && twin.contains("<td>1528</td>"));
        assert!(twin.contains("0.1300 %") && twin.contains("sine: error q1 / q2"));
        // A truncated validity.json: an error naming it, not "not run".
        std::fs::write(dir.path(files::VALIDITY), "{\"version\": 1, \"ord").unwrap();
        let report = crate::html::build_report(&RunDir::create(&root).unwrap());
        assert_eq!(report.errors.len(), 1, "{:?}", report.errors);
        assert!(report.errors[0].contains("validity.json is damaged"));
        let twin = section(&report.html);
        assert!(
            twin.contains("class=\"error\"") && !twin.contains("notrun"),
            "{twin}"
        );
        std::fs::remove_dir_all(&root).unwrap();
    }
}
