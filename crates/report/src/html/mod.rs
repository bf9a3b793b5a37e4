//! The run report: one self-contained `report.html` that puts every result of the paper
//! (Actuators 2022, 11(7), 179) next to the scenario that produced it: Figure 4 (a)/(b),
//! workspace polygons, convergence, reduced model and validity map, mode shapes, Table A1
//! and Figure A2 for both PEAs, Table 4 with the estimator and controller gains, Figures
//! 9–11, the manufacturing outline; beyond the paper, the design summary (α, θ, area, mass,
//! stresses, minimum sizes, first frequency), the body-fitted verification of the exported
//! outline and the digital twin (modes, Bode, validity).
//!
//! The report only *reads* a run folder, through the typed files of `flexstage-run`, so it
//! works on any run, also a partial one: a missing result is shown as "not run", a file that
//! exists but does not parse as an error on the page and in [`Report::errors`] (the command
//! then fails). Figures are embedded: SVG inline (text stays
//! text, searchable and sharp at any zoom), PNG as `data:` URIs; the file opens offline
//! and can be mailed around. Each figure fills the page width (at most 960 px) with text
//! ≥ 11 px at 100 % zoom ([`flexstage_figures::plot::MIN_TEXT_PX`] at its own size), and a click
//! enlarges it to the whole window (a few lines of inline script, no network).
//!
//! # Adding a section
//!
//! A section is one [`Section`] entry in [`SECTIONS`] and one function that renders it
//! with the [`Builder`] helpers (figures, tables, notes), in a module of its own. Results
//! a stage writes as SVG or PNG into its folder can be shown without naming each file:
//! [`Builder::other_figures`] embeds every figure of a folder not shown yet.

mod design;
mod design_picture;
mod design_summary;
mod front;
mod page;
mod pea;
mod reduce;
mod stage;
mod tracking;
mod twin;
mod verify;

use std::fmt::Write as _;
use std::sync::Arc;

use flexstage_run::files::design::DesignSummaryFile;
use flexstage_run::files::reduce::{ReduceSummaryFile, ReduceSummaryJson};
use flexstage_run::files::stage::ParameterRow;
use flexstage_run::files::track::MetricsRow;
use flexstage_run::format::Rows;
use flexstage_run::layout::{self, Tracking};
use flexstage_run::scenario::Scenario;
use flexstage_run::{Format, RunDir};

/// One section of the report.
pub struct Section {
    /// Anchor id (`<section id>`).
    pub id: &'static str,
    /// Title (heading and navigation).
    pub title: &'static str,
    render: fn(&mut Builder),
}

/// The sections of the report, in order.
pub const SECTIONS: &[Section] = &[
    Section {
        id: "summary",
        title: "Summary",
        render: summary,
    },
    Section {
        id: "design",
        title: "Design (Figure 4) and workspace",
        render: design::design,
    },
    Section {
        id: "design-summary",
        title: "Design summary",
        render: design_summary::design_summary,
    },
    Section {
        id: "convergence",
        title: "Convergence history",
        render: design::convergence,
    },
    Section {
        id: "reduce",
        title: "Reduced model and validity map",
        render: reduce::reduce,
    },
    Section {
        id: "modes",
        title: "Mode shapes",
        render: reduce::modes,
    },
    Section {
        id: "pea",
        title: "PEA hysteresis (Table A1, Figure A2)",
        render: pea::pea,
    },
    Section {
        id: "stage",
        title: "Stage identification and gains (Table 4)",
        render: stage::stage,
    },
    Section {
        id: "tracking",
        title: "Tracking (Figures 9-11)",
        render: tracking::tracking,
    },
    Section {
        id: "export",
        title: "Manufacturing outline",
        render: export,
    },
    Section {
        id: "verification",
        title: "Export verification",
        render: verify::verification,
    },
    Section {
        id: "twin",
        title: "Digital twin",
        render: twin::twin,
    },
    Section {
        id: "front",
        title: "Workspace–first-resonance front",
        render: front::front,
    },
];

/// Encodes bytes as standard base64 (with padding).
pub fn base64(bytes: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(T[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Escapes text for HTML.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// How wide a figure is shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Width {
    /// The page width, at most 960 px (plots with text).
    Full,
    /// Half the page width in a two-column grid (pictures without text: densities, mode
    /// shapes).
    Half,
}

/// Builds the HTML while reading the run folder.
pub struct Builder<'a> {
    dir: &'a RunDir,
    html: String,
    /// Run folder files already embedded (so [`Builder::other_figures`] skips them).
    shown: Vec<String>,
    /// Files that exist but could not be read or parsed, with the reason.
    errors: Vec<String>,
}

impl<'a> Builder<'a> {
    fn new(dir: &'a RunDir) -> Self {
        Builder {
            dir,
            html: String::with_capacity(1 << 20),
            shown: Vec::new(),
            errors: Vec::new(),
        }
    }

    /// Records an error: on the page (where the section would show the file) and in the
    /// report's error list.
    fn error(&mut self, e: &flexstage_run::RunError) {
        let text = e.to_string();
        let _ = writeln!(self.html, "<p class=\"error\">error: {}</p>", esc(&text));
        self.errors.push(text);
    }

    /// Records that the file `rel` parses but lacks what the report needs.
    fn damaged(&mut self, rel: &str, reason: String) {
        let path = self.dir.path(rel);
        self.error(&flexstage_run::RunError::Damaged { path, reason });
    }

    /// The bytes of a file: `None` if it does not exist or cannot be read (an error then).
    fn read(&mut self, rel: &str) -> Option<Vec<u8>> {
        match self.dir.read(rel) {
            Ok(b) => b,
            Err(e) => {
                self.error(&e);
                None
            }
        }
    }

    /// The typed value of a file: `None` if it does not exist, or if it does not parse (an
    /// error on the page and in the report's list; never "not run").
    fn load<F: Format>(&mut self, rel: &str) -> Option<Arc<F>> {
        match self.dir.load::<F>(rel) {
            Ok(v) => v,
            Err(e) => {
                self.error(&e);
                None
            }
        }
    }

    fn exists(&self, rel: &str) -> bool {
        self.dir.exists(rel)
    }

    /// "not run" for a file that does not exist; nothing for one that exists (it could not
    /// be read, and [`Builder::load`] already said why).
    fn missing(&mut self, rel: &str) {
        if !self.exists(rel) {
            self.not_run(&format!("{rel} missing"));
        }
    }

    /// The run's scenario.
    fn scenario(&mut self) -> Option<Arc<Scenario>> {
        self.load(layout::SCENARIO)
    }

    /// Opens a figure: `<figure>` with the width class.
    fn figure_open(&mut self, width: Width) {
        let class = match width {
            Width::Full => "fig",
            Width::Half => "fig half",
        };
        let _ = write!(self.html, "<figure class=\"{class}\" tabindex=\"0\">");
    }

    fn figure_close(&mut self, caption: &str, source: Option<&str>) {
        let _ = write!(self.html, "<figcaption>{}", esc(caption));
        if let Some(src) = source {
            let _ = write!(self.html, " <span class=\"src\">{}</span>", esc(src));
        }
        self.html.push_str("</figcaption></figure>\n");
    }

    /// Embeds an SVG document: inline when it is a plain drawing, else as an image (an SVG
    /// in an `<img>` cannot run scripts).
    fn svg(&mut self, svg: &str, caption: &str, source: Option<&str>, width: Width) {
        self.figure_open(width);
        match page::inline_svg(svg) {
            Some(inline) => self.html.push_str(&inline),
            None => {
                let _ = write!(
                    self.html,
                    "<img alt=\"{}\" src=\"data:image/svg+xml;base64,{}\"/>",
                    esc(caption),
                    base64(svg.as_bytes())
                );
            }
        }
        self.figure_close(caption, source);
    }

    /// Embeds a PNG, scaled with sharp pixels.
    fn png(&mut self, bytes: &[u8], caption: &str, source: Option<&str>, width: Width) {
        self.figure_open(width);
        let _ = write!(
            self.html,
            "<img class=\"px\" alt=\"{}\" src=\"data:image/png;base64,{}\"/>",
            esc(caption),
            base64(bytes)
        );
        self.figure_close(caption, source);
    }

    /// Embeds an SVG or PNG file of the run at full width, or notes it as missing.
    fn img(&mut self, rel: &str, caption: &str) -> bool {
        self.file_figure(rel, caption, Width::Full)
    }

    /// Embeds an SVG or PNG file of the run, or notes it as missing.
    fn file_figure(&mut self, rel: &str, caption: &str, width: Width) -> bool {
        let Some(bytes) = self.read(rel) else {
            self.missing(rel);
            return false;
        };
        self.shown.push(rel.to_string());
        if rel.ends_with(".png") {
            self.png(&bytes, caption, Some(rel), width);
        } else {
            self.svg(&String::from_utf8_lossy(&bytes), caption, Some(rel), width);
        }
        true
    }

    /// Embeds every SVG and PNG of the run folder `dir` not shown yet, in name order, under
    /// a short heading: the place where new results of a stage appear before they get a
    /// section of their own.
    pub fn other_figures(&mut self, dir: &str, heading: &str) {
        let mut rels: Vec<String> = self
            .dir
            .files_in(dir)
            .into_iter()
            .filter(|n| n.ends_with(".svg") || n.ends_with(".png"))
            .map(|n| format!("{dir}/{n}"))
            .filter(|rel| !self.shown.contains(rel))
            .collect();
        if rels.is_empty() {
            return;
        }
        rels.sort();
        let _ = writeln!(self.html, "<h3>{}</h3>", esc(heading));
        for rel in rels {
            let width = if rel.ends_with(".png") {
                Width::Half
            } else {
                Width::Full
            };
            self.file_figure(&rel, &rel, width);
        }
    }

    fn not_run(&mut self, why: &str) {
        let _ = writeln!(
            self.html,
            "<p class=\"notrun\">not run <span>({})</span></p>",
            esc(why)
        );
    }

    fn note(&mut self, text: &str) {
        let _ = writeln!(self.html, "<p class=\"note\">{}</p>", esc(text));
    }

    fn h3(&mut self, text: &str) {
        let _ = writeln!(self.html, "<h3>{}</h3>", esc(text));
    }

    fn grid_open(&mut self) {
        self.html.push_str("<div class=\"grid\">");
    }

    fn grid_close(&mut self) {
        self.html.push_str("</div>\n");
    }

    fn table(&mut self, header: &[String], rows: &[Vec<String>]) {
        self.html.push_str("<table><thead><tr>");
        for h in header {
            let _ = write!(self.html, "<th>{}</th>", esc(h));
        }
        self.html.push_str("</tr></thead><tbody>\n");
        for r in rows {
            self.html.push_str("<tr>");
            for c in r {
                let _ = write!(self.html, "<td>{}</td>", esc(c));
            }
            self.html.push_str("</tr>\n");
        }
        self.html.push_str("</tbody></table>\n");
    }

    fn kv(&mut self, rows: &[(String, String)]) {
        self.html.push_str("<table class=\"kv\"><tbody>\n");
        for (k, v) in rows {
            let _ = writeln!(self.html, "<tr><th>{}</th><td>{}</td></tr>", esc(k), esc(v));
        }
        self.html.push_str("</tbody></table>\n");
    }
}

/// A number as a table cell: its shortest form shortened to 4 significant digits when it
/// has a fraction or an exponent (integers stay whole).
fn cell(v: f64) -> String {
    short(&v.to_string())
}

/// Shortens a numeric cell to 4 significant digits; other text is kept.
fn short(cell: &str) -> String {
    match cell.parse::<f64>() {
        Ok(v) if cell.contains('.') || cell.contains('e') || v.abs() >= 1e5 => fmt_num(v),
        _ => cell.to_string(),
    }
}

/// Formats a number with 4 significant digits.
pub fn fmt_num(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
        format!("{v:.decimals$}")
    } else {
        format!("{v:.3e}")
    }
}

/// A built report: the page, and the files it could not read (each also shown on the page
/// where its section would be).
#[derive(Debug, Clone)]
pub struct Report {
    /// The HTML page.
    pub html: String,
    /// Files that exist but could not be read or parsed, with the reason.
    pub errors: Vec<String>,
}

/// Builds `report.html` for the run folder `dir` (the caller writes it, e.g. to
/// `layout::REPORT`).
pub fn build_report(dir: &RunDir) -> Report {
    let mut b = Builder::new(dir);
    let scenario_name = b
        .scenario()
        .map(|s| s.name.clone())
        .unwrap_or_else(|| "unknown".into());
    page::head(
        &mut b.html,
        &scenario_name,
        &dir.root().display().to_string(),
    );
    for s in SECTIONS {
        let _ = writeln!(
            b.html,
            "<section id=\"{}\">\n<h2>{}</h2>",
            s.id,
            esc(s.title)
        );
        (s.render)(&mut b);
        b.html.push_str("</section>\n");
    }
    page::tail(&mut b.html);
    Report {
        html: b.html,
        errors: b.errors,
    }
}

/// The typed results the headline numbers come from.
#[derive(Debug, Default, Clone, Copy)]
pub struct Headline<'a> {
    /// The design stage's summary.
    pub design: Option<&'a DesignSummaryFile>,
    /// The reduced model's summary.
    pub reduce: Option<&'a ReduceSummaryFile>,
    /// The stage identification against the truth (Table 4).
    pub identified: Option<&'a [ParameterRow]>,
    /// The tracking metrics of the default conditions.
    pub tracking: Option<&'a [MetricsRow]>,
}

/// The headline numbers of a run: workspace area and growth, α, first natural frequency,
/// identification error and tracking RMS per controller (what `flexstage run` prints at the
/// end and the report's summary table shows).
pub fn headline_rows(h: &Headline) -> Vec<(String, String)> {
    let mut rows: Vec<(String, String)> = Vec::new();
    if let Some(d) = h.design {
        let (a0, a1) = (d.area_initial_m2, d.area_final_m2);
        // A growth factor needs a positive start (the uniform start of the reversed
        // configuration traces its polygon the other way: a negative area).
        let growth = if a0 > 0.0 {
            format!(" (×{})", fmt_num(a1 / a0))
        } else {
            String::new()
        };
        rows.push((
            "workspace area, final analyses (uniform start → design)".into(),
            format!(
                "{} µm² → {} µm²{growth}",
                fmt_num(a0 * 1e12),
                fmt_num(a1 * 1e12)
            ),
        ));
        rows.push((
            "mass of the design".into(),
            format!("{} g", fmt_num(d.design.mass * 1e3)),
        ));
        rows.push((
            "α (Eq. 27), design, output loaded by the optimizer's spring".into(),
            fmt_num(d.design.alpha),
        ));
        rows.push((
            "design iterations".into(),
            format!(
                "{} in {} s ({})",
                d.iterations,
                fmt_num(d.seconds),
                d.stop_in_words()
            ),
        ));
    }
    if let Some(r) = h.reduce {
        rows.push((
            "α (Eq. 27), reduced model, output free".into(),
            fmt_num(r.alpha_scalar),
        ));
        if let Some(f) = r.modal.as_ref().and_then(|m| m.frequencies_hz.first()) {
            rows.push((
                "first natural frequency, reduced model".into(),
                format!("{} Hz", fmt_num(*f)),
            ));
        }
    }
    if let Some(table) = h.identified {
        let worst = table
            .iter()
            .filter_map(|r| r.error_pct)
            .filter(|v| v.is_finite())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        rows.push((
            "stage identification, largest error vs truth".into(),
            format!("{} %", fmt_num(worst)),
        ));
    }
    for r in h.tracking.unwrap_or_default() {
        rows.push((
            format!("tracking RMS {} / {}", r.trajectory, r.variant),
            format!("{} / {} nm", cell(r.rms1_nm), cell(r.rms2_nm)),
        ));
    }
    rows
}

fn summary(b: &mut Builder) {
    let design = b.load::<DesignSummaryFile>(layout::design::SUMMARY);
    let reduce = b.load::<ReduceSummaryJson>(layout::reduce::SUMMARY_JSON);
    let table = b.load::<Rows<ParameterRow>>(layout::stage::TABLE);
    let metrics = b.load::<Rows<MetricsRow>>(&Tracking::main().metrics());
    let rows = headline_rows(&Headline {
        design: design.as_deref(),
        reduce: reduce.as_ref().map(|r| &r.0),
        identified: table.as_ref().map(|t| t.0.as_slice()),
        tracking: metrics.as_ref().map(|t| t.0.as_slice()),
    });
    if rows.is_empty() {
        b.not_run("no stage results in this folder");
    } else {
        b.kv(&rows);
    }
}

fn export(b: &mut Builder) {
    use layout::export::SVG;
    if b.exists(SVG) {
        b.note(
            "ρ = 0.5 iso-contour for wire cutting (Section 4.1): export/outline.dxf, \
             outline.svg and outline.stl (extruded by t).",
        );
        b.img(SVG, "Manufacturing outline");
    } else {
        b.not_run(&format!("{SVG} missing"));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc4648_vectors() {
        // Reference: RFC 4648 section 10 test vectors.
        for (i, o) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(i.as_bytes()), o);
        }
    }

    #[test]
    fn empty_run_folder_gives_every_section_as_not_run() {
        // Goal: the report works on a partial run: missing results are "not run", not errors.
        let root =
            std::env::temp_dir().join(format!("flexstage-html-empty-{}", std::process::id()));
        let dir = RunDir::create(&root).unwrap();
        let report = build_report(&dir);
        assert!(report.errors.is_empty(), "{:?}", report.errors);
        let html = report.html;
        for s in SECTIONS {
            assert!(
                html.contains(&format!("<section id=\"{}\">", s.id)),
                "{}",
                s.id
            );
        }
        assert!(html.matches("class=\"notrun\"").count() >= SECTIONS.len());
        assert!(!html.contains("<img") && !html.contains("<figure"));
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn numbers_are_shortened_to_four_digits() {
        assert_eq!(fmt_num(0.0123456), "0.01235");
        assert_eq!(fmt_num(12345.6), "12346");
        assert_eq!(fmt_num(1.5e-6), "1.500e-6");
        assert_eq!(short("42"), "42");
        assert_eq!(short("robust"), "robust");
    }
}
