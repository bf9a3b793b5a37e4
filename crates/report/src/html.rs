//! The run report: one self-contained `report.html` that puts every result of the paper next
//! to the scenario that produced it (Figure 4, workspace polygons, convergence, reduced model
//! and validity map, mode shapes, hysteresis and Figure A2, Table 4, Figures 9–11).
//!
//! The report only *reads* a run folder, so it works on any run, also a partial one: a
//! missing result is shown as "not run". Images are embedded as `data:` URIs (SVG and PNG):
//! the file opens offline and can be mailed around.

use std::fmt::Write as _;
use std::fs;
use std::path::Path;

use crate::layout::{self, PeaIdentification, Tracking};
use crate::plot::{Figure, Series};
use crate::read_csv_columns as csv_cols;

/// The sections of the report, in order: `(id, title)`.
pub const SECTIONS: [(&str, &str); 9] = [
    ("summary", "Summary"),
    ("design", "Design (Figure 4) and workspace"),
    ("convergence", "Convergence history"),
    ("reduce", "Reduced model and validity map"),
    ("modes", "Mode shapes"),
    ("pea", "Hysteresis and PEA identification (Figure A2)"),
    ("stage", "Stage identification (Table 4)"),
    ("tracking", "Tracking (Figures 9-11)"),
    ("export", "Manufacturing outline"),
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

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Builds the HTML while reading the run folder.
struct Builder<'a> {
    root: &'a Path,
    html: String,
}

impl Builder<'_> {
    fn read(&self, rel: &str) -> Option<Vec<u8>> {
        fs::read(self.root.join(rel)).ok()
    }

    fn text(&self, rel: &str) -> Option<String> {
        fs::read_to_string(self.root.join(rel)).ok()
    }

    fn exists(&self, rel: &str) -> bool {
        self.root.join(rel).is_file()
    }

    fn img_bytes(&mut self, mime: &str, bytes: &[u8], caption: &str, class: &str) {
        let _ = writeln!(
            self.html,
            "<figure class=\"{class}\"><img alt=\"{c}\" src=\"data:{mime};base64,{}\"/>\
             <figcaption>{c}</figcaption></figure>",
            base64(bytes),
            c = esc(caption)
        );
    }

    /// Embeds an SVG or PNG file of the run, or notes it as missing.
    fn img(&mut self, rel: &str, caption: &str) -> bool {
        match self.read(rel) {
            Some(bytes) => {
                let mime = if rel.ends_with(".png") {
                    "image/png"
                } else {
                    "image/svg+xml"
                };
                let class = if rel.ends_with(".png") { "px" } else { "" };
                self.img_bytes(mime, &bytes, &format!("{caption} ({rel})"), class);
                true
            }
            None => {
                self.not_run(&format!("{rel} missing"));
                false
            }
        }
    }

    fn svg(&mut self, svg: &str, caption: &str) {
        self.img_bytes("image/svg+xml", svg.as_bytes(), caption, "");
    }

    fn not_run(&mut self, why: &str) {
        let _ = writeln!(
            self.html,
            "<p class=\"notrun\">not run <span>({})</span></p>",
            esc(why)
        );
    }

    fn open(&mut self, id: &str, title: &str) {
        let _ = writeln!(self.html, "<section id=\"{id}\">\n<h2>{}</h2>", esc(title));
    }

    fn close(&mut self) {
        self.html.push_str("</section>\n");
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

    /// A CSV file of the run as a table, numbers shortened to `digits` significant digits.
    fn csv_table(&mut self, rel: &str, keep: impl Fn(&str) -> bool) -> bool {
        let Some(text) = self.text(rel) else {
            self.not_run(&format!("{rel} missing"));
            return false;
        };
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
        let cols: Vec<usize> = (0..header.len()).filter(|&i| keep(header[i])).collect();
        let rows: Vec<Vec<String>> = lines
            .map(|l| {
                let cells: Vec<&str> = l.split(',').collect();
                cols.iter()
                    .map(|&i| short(cells.get(i).copied().unwrap_or("")))
                    .collect()
            })
            .collect();
        let head: Vec<String> = cols.iter().map(|&i| header[i].to_string()).collect();
        self.table(&head, &rows);
        true
    }

    fn kv(&mut self, rows: &[(String, String)]) {
        self.html.push_str("<table class=\"kv\"><tbody>\n");
        for (k, v) in rows {
            let _ = writeln!(self.html, "<tr><th>{}</th><td>{}</td></tr>", esc(k), esc(v));
        }
        self.html.push_str("</tbody></table>\n");
    }
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

fn json(b: &Builder, rel: &str) -> Option<serde_json::Value> {
    serde_json::from_str(&b.text(rel)?).ok()
}

fn num(v: &serde_json::Value, path: &[&str]) -> Option<f64> {
    let mut cur = v;
    for p in path {
        cur = match p.parse::<usize>() {
            Ok(i) => cur.get(i)?,
            Err(_) => cur.get(p)?,
        };
    }
    cur.as_f64()
}

/// Mode shapes of a `modes.vtu` written by `flexstage reduce`: one small SVG per mode, the
/// mesh cells with density ≥ 0.5 drawn deformed (largest displacement 6 % of the domain
/// length), shaded by displacement magnitude. At most `max_modes`.
pub fn mode_shape_svgs(vtu: &str, max_modes: usize) -> Vec<(String, String)> {
    let arrays = vtu_arrays(vtu);
    let get = |name: &str| arrays.iter().find(|(n, _)| n == name).map(|(_, v)| v);
    let (Some(points), Some(conn)) = (arrays.first().map(|(_, v)| v), get("connectivity")) else {
        return Vec::new();
    };
    let np = points.len() / 3;
    let nc = conn.len() / 4;
    let density = get("density").filter(|d| d.len() == nc);
    let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
    for p in points.chunks(3) {
        lo = [lo[0].min(p[0]), lo[1].min(p[1])];
        hi = [hi[0].max(p[0]), hi[1].max(p[1])];
    }
    let (w, h) = (hi[0] - lo[0], hi[1] - lo[1]);
    if !(w > 0.0 && h > 0.0) {
        return Vec::new();
    }
    let px = 320.0 / w;
    let margin = 0.08 * w;
    let mut out = Vec::new();
    for (name, u) in arrays.iter().filter(|(n, _)| n.starts_with("mode_")) {
        if out.len() >= max_modes || u.len() != 3 * np {
            continue;
        }
        let umax = u
            .chunks(3)
            .map(|d| (d[0] * d[0] + d[1] * d[1]).sqrt())
            .fold(0.0, f64::max);
        let scale = if umax > 0.0 { 0.06 * w / umax } else { 0.0 };
        let mut s = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {:.0} {:.0}\" width=\"{:.0}\" \
             height=\"{:.0}\"><rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n",
            (w + 2.0 * margin) * px,
            (h + 2.0 * margin) * px,
            (w + 2.0 * margin) * px,
            (h + 2.0 * margin) * px
        );
        for c in 0..nc {
            if density.is_some_and(|d| d[c] < 0.5) {
                continue;
            }
            let nodes = &conn[4 * c..4 * c + 4];
            let mut mag = 0.0;
            let mut d = String::from("M");
            for (k, &nf) in nodes.iter().enumerate() {
                let n = nf as usize;
                if n >= np {
                    continue;
                }
                let x = points[3 * n] + scale * u[3 * n] - lo[0] + margin;
                let y = points[3 * n + 1] + scale * u[3 * n + 1] - lo[1] + margin;
                mag += (u[3 * n].powi(2) + u[3 * n + 1].powi(2)).sqrt() / 4.0;
                let _ = write!(
                    d,
                    "{}{:.1} {:.1}",
                    if k == 0 { "" } else { "L" },
                    x * px,
                    (h + 2.0 * margin - y) * px
                );
            }
            let t = if umax > 0.0 { mag / umax } else { 0.0 };
            // White-blue-red ramp by displacement magnitude.
            let (r, g, b) = (
                (40.0 + 200.0 * t) as u8,
                (90.0 + 60.0 * (1.0 - t)) as u8,
                (200.0 * (1.0 - t) + 30.0) as u8,
            );
            let _ = writeln!(s, "<path d=\"{d}Z\" fill=\"rgb({r},{g},{b})\"/>");
        }
        s.push_str("</svg>\n");
        out.push((name.clone(), s));
    }
    out
}

/// Every `<DataArray>` of an ASCII VTU: (name, values); the unnamed points array is "".
fn vtu_arrays(vtu: &str) -> Vec<(String, Vec<f64>)> {
    let mut out = Vec::new();
    let mut rest = vtu;
    while let Some(start) = rest.find("<DataArray") {
        let after = &rest[start..];
        let Some(tag_end) = after.find('>') else {
            break;
        };
        let tag = &after[..tag_end];
        let name = tag
            .split("Name=\"")
            .nth(1)
            .and_then(|s| s.split('"').next())
            .unwrap_or("")
            .to_string();
        let body_start = tag_end + 1;
        let Some(body_len) = after[body_start..].find("</DataArray>") else {
            break;
        };
        let values = after[body_start..body_start + body_len]
            .split_whitespace()
            .filter_map(|t| t.parse::<f64>().ok())
            .collect();
        out.push((name, values));
        rest = &after[body_start + body_len..];
    }
    out
}

const STYLE: &str = "body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;\
margin:0;color:#1b2a41;background:#f5f6f8}header{background:#1b2a41;color:#fff;padding:18px 32px}\
header h1{margin:0;font-size:24px}header p{margin:4px 0 0;color:#c9d3e3}\
nav{padding:8px 32px;background:#e4e8ef}nav a{margin-right:14px;color:#1b2a41}\
main{padding:0 32px 40px}section{background:#fff;margin:18px 0;padding:14px 22px;\
border-radius:6px;box-shadow:0 1px 3px rgba(0,0,0,.12)}h2{margin-top:4px;font-size:20px}\
.grid{display:flex;flex-wrap:wrap;gap:12px;align-items:flex-start}\
figure{margin:0;flex:0 1 440px}figure img{width:100%;border:1px solid #dde}\
figure.px img{image-rendering:pixelated}figcaption{font-size:12px;color:#556}\
table{border-collapse:collapse;font-size:13px;margin:8px 0}td,th{border:1px solid #ccd;\
padding:3px 8px;text-align:right}th{background:#eef1f6}table.kv th{text-align:left}\
.notrun{color:#a33;font-style:italic}.notrun span{color:#888;font-size:12px}\
.note{color:#556;font-size:13px}";

/// Builds `report.html` for the run folder `root` and returns the HTML text (the caller
/// writes it, e.g. to `root/report.html`).
pub fn build_report(root: &Path) -> String {
    let mut b = Builder {
        root,
        html: String::with_capacity(1 << 20),
    };
    let scenario_name = b
        .text(layout::SCENARIO)
        .and_then(|t| {
            t.lines()
                .find(|l| l.trim_start().starts_with("name"))
                .and_then(|l| l.split('"').nth(1).map(str::to_string))
        })
        .unwrap_or_else(|| "unknown".into());
    let _ = write!(
        b.html,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"/>\
         <title>flexstage report: {n}</title><style>{STYLE}</style></head><body>\n\
         <header><h1>flexstage report — scenario “{n}”</h1><p>{}: design → reduce → identify \
         → control, after the paper's scheme. Every figure is computed from this run folder.\
         </p></header>\n<nav>",
        esc(&root.display().to_string()),
        n = esc(&scenario_name)
    );
    for (id, title) in SECTIONS {
        let _ = write!(b.html, "<a href=\"#{id}\">{}</a>", esc(title));
    }
    b.html.push_str("</nav>\n<main>\n");

    summary(&mut b);
    design(&mut b);
    convergence(&mut b);
    reduce(&mut b);
    modes(&mut b);
    pea(&mut b);
    stage(&mut b);
    tracking(&mut b);
    export(&mut b);

    b.html.push_str("</main></body></html>\n");
    b.html
}

/// The headline numbers of a run folder: workspace area and growth, α, first natural
/// frequency, identification error and tracking RMS per controller (what `flexstage run`
/// prints at the end and the report's summary table shows).
pub fn summary_rows(root: &Path) -> Vec<(String, String)> {
    let b = &Builder {
        root,
        html: String::new(),
    };
    let mut rows: Vec<(String, String)> = Vec::new();
    if let Some(d) = json(b, layout::design::SUMMARY) {
        if let (Some(a0), Some(a1), Some(g)) = (
            num(&d, &["area_initial_m2"]),
            num(&d, &["area_final_m2"]),
            num(&d, &["area_growth"]),
        ) {
            rows.push((
                "workspace area (initial → final)".into(),
                format!(
                    "{} µm² → {} µm² (×{})",
                    fmt_num(a0 * 1e12),
                    fmt_num(a1 * 1e12),
                    fmt_num(g)
                ),
            ));
        }
        if let Some(it) = num(&d, &["iterations"]) {
            rows.push((
                "design iterations".into(),
                format!(
                    "{it} in {} s ({})",
                    fmt_num(num(&d, &["seconds"]).unwrap_or(f64::NAN)),
                    d.get("stop").and_then(|s| s.as_str()).unwrap_or("?")
                ),
            ));
        }
    }
    if let Some(r) = json(b, layout::reduce::SUMMARY_JSON) {
        if let Some(a) = num(&r, &["alpha_scalar"]) {
            rows.push(("α (Eq. 27)".into(), fmt_num(a)));
        }
        if let Some(f) = num(&r, &["modal", "frequencies_hz", "0"]) {
            rows.push((
                "first natural frequency".into(),
                format!("{} Hz", fmt_num(f)),
            ));
        }
    }
    if let Some(text) = b.text(layout::stage::TABLE)
        && let Some(c) = csv_cols(&text, &["error_pct"])
    {
        let worst = c[0]
            .iter()
            .filter(|v| v.is_finite())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        rows.push((
            "stage identification, largest error vs truth".into(),
            format!("{} %", fmt_num(worst)),
        ));
    }
    if let Some(text) = b.text(&Tracking::main().metrics()) {
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
        let col = |n: &str| header.iter().position(|h| *h == n);
        if let (Some(tr), Some(va), Some(r1), Some(r2)) = (
            col("trajectory"),
            col("variant"),
            col("rms1_nm"),
            col("rms2_nm"),
        ) {
            for l in lines {
                let c: Vec<&str> = l.split(',').collect();
                if c.len() > tr.max(va).max(r1).max(r2) {
                    rows.push((
                        format!("tracking RMS {} / {}", c[tr], c[va]),
                        format!("{} / {} nm", short(c[r1]), short(c[r2])),
                    ));
                }
            }
        }
    }
    rows
}

fn summary(b: &mut Builder) {
    b.open("summary", SECTIONS[0].1);
    let rows = summary_rows(b.root);
    if rows.is_empty() {
        b.not_run("no stage results in this folder");
    } else {
        b.kv(&rows);
    }
    b.close();
}

fn design(b: &mut Builder) {
    b.open("design", SECTIONS[1].1);
    b.html.push_str(
        "<p class=\"note\">Optimized density (black = solid), as in the paper's Figure 4, and \
         the workspace polygon of the output point: initial (uniform) design against final.</p>\
         <div class=\"grid\">",
    );
    b.img(layout::design::DENSITY_PNG, "Final density ρ");
    if b.exists(layout::design::WORKSPACE_SVG) {
        b.img(
            layout::design::WORKSPACE_SVG,
            "Workspace polygons, initial vs final",
        );
    }
    b.html.push_str("</div>\n");
    b.close();
}

fn convergence(b: &mut Builder) {
    b.open("convergence", SECTIONS[2].1);
    b.html.push_str("<div class=\"grid\">");
    let mut any = false;
    if let Some(text) = b.text(layout::design::HISTORY_CSV)
        && let Some(c) = csv_cols(&text, &["iteration", "area_rel", "volume", "grey"])
    {
        let pts = |k: usize| -> Vec<(f64, f64)> {
            c[0].iter()
                .zip(&c[k])
                .filter(|(a, b)| a.is_finite() && b.is_finite())
                .map(|(a, b)| (*a, *b))
                .collect()
        };
        let fig = Figure::new(
            "Workspace area over the design iterations",
            "iteration",
            "area / initial area",
        )
        .with(Series::line("area growth", pts(1)));
        if let Ok(svg) = fig.to_svg() {
            b.svg(&svg, "Area growth (design/history.csv)");
            any = true;
        }
        let fig = Figure::new("Volume and grey fraction", "iteration", "fraction")
            .with(Series::line("volume", pts(2)))
            .with(Series::line("grey", pts(3)));
        if let Ok(svg) = fig.to_svg() {
            b.svg(&svg, "Volume and grey fraction (design/history.csv)");
        }
    }
    if b.exists(layout::design::WORKSPACE_HISTORY_SVG) {
        b.img(
            layout::design::WORKSPACE_HISTORY_SVG,
            "Workspace polygon snapshots",
        );
        any = true;
    }
    if !any {
        b.not_run(&format!("{} missing", layout::design::HISTORY_CSV));
    }
    b.html.push_str("</div>\n");
    b.close();
}

fn reduce(b: &mut Builder) {
    b.open("reduce", SECTIONS[3].1);
    match json(b, layout::reduce::SUMMARY_JSON) {
        Some(r) => {
            let f = |p: &[&str]| num(&r, p).map(fmt_num).unwrap_or_else(|| "–".into());
            let mut rows = vec![
                ("α (scalar, Eq. 27)".to_string(), f(&["alpha_scalar"])),
                ("tilt θ [°]".into(), f(&["theta_deg"])),
                ("K_qo1 [N/m]".into(), f(&["k_qo1"])),
                ("K_qo2 [N/m]".into(), f(&["k_qo2"])),
                ("moving mass M [kg]".into(), f(&["mass_kg"])),
                ("volume fraction".into(), f(&["volume_fraction"])),
            ];
            if let Some(fr) = r
                .get("modal")
                .and_then(|m| m.get("frequencies_hz"))
                .and_then(|v| v.as_array())
            {
                let list: Vec<String> = fr.iter().filter_map(|v| v.as_f64()).map(fmt_num).collect();
                rows.push(("natural frequencies [Hz]".into(), list.join(", ")));
            }
            if let Some(a2) = r
                .get("modal")
                .and_then(|m| m.get("assumption2"))
                .and_then(|v| v.as_str())
            {
                rows.push(("Assumption 2".into(), a2.to_string()));
            }
            if let Some(v) = num(&r, &["validity", "max_error_within_stroke"]) {
                rows.push((
                    "reduced vs nonlinear FE within the stroke".into(),
                    format!("max {} %", fmt_num(100.0 * v)),
                ));
            }
            b.kv(&rows);
        }
        None => b.not_run(&format!("{} missing", layout::reduce::SUMMARY_JSON)),
    }
    b.html.push_str("<div class=\"grid\">");
    if b.exists(layout::reduce::VALIDITY_SVG) {
        b.img(
            layout::reduce::VALIDITY_SVG,
            "Validity map: reduced model vs nonlinear FE",
        );
    }
    if b.exists(layout::reduce::VALIDITY_SCALE_SVG) {
        b.img(
            layout::reduce::VALIDITY_SCALE_SVG,
            "Model error against stroke scale",
        );
    }
    b.html.push_str("</div>\n");
    b.close();
}

fn modes(b: &mut Builder) {
    b.open("modes", SECTIONS[4].1);
    match b.text(layout::reduce::MODES_VTU) {
        Some(vtu) => {
            let shapes = mode_shape_svgs(&vtu, 4);
            if shapes.is_empty() {
                b.not_run(&format!("{} has no mode shapes", layout::reduce::MODES_VTU));
            }
            b.html.push_str("<div class=\"grid\">");
            for (name, svg) in shapes {
                let label = name.replace('_', " ").replacen("Hz", " Hz", 1);
                b.svg(&svg, &format!("{label} (solid cells, exaggerated)"));
            }
            b.html.push_str("</div>\n");
        }
        None => b.not_run(&format!("{} missing", layout::reduce::MODES_VTU)),
    }
    b.close();
}

fn pea(b: &mut Builder) {
    b.open("pea", SECTIONS[5].1);
    let mut any = false;
    let id = PeaIdentification { pea: 1 };
    if let Some(t) = b.text(&id.estimates())
        && let Ok(v) = t.parse::<toml::Table>()
    {
        let est = v.get("recommended_params").and_then(|x| x.as_table());
        let diff = v
            .get("parallel_rls")
            .and_then(|x| x.get("difference_to_scenario_pct"))
            .and_then(|x| x.as_table());
        if let Some(est) = est {
            let rows: Vec<Vec<String>> = est
                .iter()
                .map(|(k, val)| {
                    vec![
                        k.clone(),
                        val.as_float().map(fmt_num).unwrap_or_default(),
                        diff.and_then(|d| d.get(k))
                            .and_then(|x| x.as_float())
                            .map(fmt_num)
                            .unwrap_or_else(|| "–".into()),
                    ]
                })
                .collect();
            b.table(
                &[
                    "Bouc–Wen parameter".into(),
                    "estimate".into(),
                    "vs truth [%]".into(),
                ],
                &rows,
            );
            any = true;
        }
    }
    b.html.push_str("<div class=\"grid\">");
    for (rel, cap) in [
        (
            layout::pea::loop_svg(1),
            "Simulated PEA record: hysteresis loop",
        ),
        (
            id.compensation_svg(),
            "Hysteresis before and after inverse compensation",
        ),
        (id.loop_svg(), "Measured vs identified model"),
        (
            id.convergence_svg(),
            "Identification convergence (Figure A2)",
        ),
    ] {
        if b.exists(&rel) {
            b.img(&rel, cap);
            any = true;
        }
    }
    b.html.push_str("</div>\n");
    if !any {
        b.not_run(&format!("{} missing", id.dir()));
    }
    b.close();
}

fn stage(b: &mut Builder) {
    use layout::stage::{CONVERGENCE_SVG, TABLE};
    b.open("stage", SECTIONS[6].1);
    if b.exists(TABLE) {
        b.html.push_str(
            "<p class=\"note\">Initial guess (from the reduced model and weighing), online \
             least-squares estimate and the simulated truth, as in Table 4.</p>",
        );
        b.csv_table(TABLE, |_| true);
        b.html.push_str("<div class=\"grid\">");
        if b.exists(CONVERGENCE_SVG) {
            b.img(CONVERGENCE_SVG, "Estimate convergence");
        }
        b.html.push_str("</div>\n");
    } else {
        b.not_run(&format!("{TABLE} missing"));
    }
    b.close();
}

fn tracking(b: &mut Builder) {
    b.open("tracking", SECTIONS[7].1);
    let track = Tracking::main();
    let metrics = track.metrics();
    let Some(text) = b.text(&metrics) else {
        b.not_run(&format!("{metrics} missing"));
        b.close();
        return;
    };
    b.csv_table(&metrics, |h| {
        matches!(
            h,
            "trajectory"
                | "variant"
                | "rms1_nm"
                | "rms2_nm"
                | "max1_nm"
                | "max2_nm"
                | "rms1_pct"
                | "rms2_pct"
                | "peak_voltage_V"
                | "saturated_samples"
        )
    });
    // (trajectory, controller) pairs in the table's order, grouped by trajectory.
    let mut rows: Vec<(String, Vec<String>)> = Vec::new();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n);
    if let (Some(tr), Some(va)) = (col("trajectory"), col("variant")) {
        for l in lines {
            let c: Vec<&str> = l.split(',').collect();
            let (Some(t), Some(v)) = (c.get(tr), c.get(va)) else {
                continue;
            };
            match rows.iter_mut().find(|(name, _)| name == t) {
                Some((_, vs)) => vs.push(v.to_string()),
                None => rows.push((t.to_string(), vec![v.to_string()])),
            }
        }
    }
    for (t, controllers) in &rows {
        let _ = writeln!(b.html, "<h3>{}</h3><div class=\"grid\">", esc(t));
        b.img(&track.paths_svg(t), &format!("{t}: 2D trajectories"));
        for v in controllers {
            b.img(
                &track.error_svg(t, v),
                &format!("{t}, {v}: tracking error against time"),
            );
        }
        b.html.push_str("</div>\n");
    }
    b.close();
}

fn export(b: &mut Builder) {
    use layout::export::SVG;
    b.open("export", SECTIONS[8].1);
    if b.exists(SVG) {
        b.html.push_str(
            "<p class=\"note\">ρ = 0.5 iso-contour for wire cutting (Section 4.1): \
             export/outline.dxf, outline.svg and outline.stl (extruded by t).</p>\
             <div class=\"grid\">",
        );
        b.img(SVG, "Manufacturing outline");
        b.html.push_str("</div>\n");
    } else {
        b.not_run(&format!("{SVG} missing"));
    }
    b.close();
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
        let dir = std::env::temp_dir().join(format!("flexstage-html-empty-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let html = build_report(&dir);
        for (id, _) in SECTIONS {
            assert!(html.contains(&format!("<section id=\"{id}\">")), "{id}");
        }
        assert!(html.matches("class=\"notrun\"").count() >= SECTIONS.len());
        assert!(!html.contains("<img"));
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn mode_shapes_are_drawn_from_a_vtu() {
        // Goal: the VTU reader finds the mode arrays and draws one polygon per solid cell.
        use crate::vtk::{PointField, QuadMesh};
        let points = [
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0],
            [0.0, 1.0],
            [2.0, 0.0],
            [2.0, 1.0],
        ];
        let cells = [[0, 1, 2, 3], [1, 4, 5, 2]];
        let u: Vec<[f64; 2]> = (0..6).map(|i| [0.0, i as f64 * 0.1]).collect();
        let rho = [1.0, 0.2];
        let mesh = QuadMesh {
            points: &points,
            cells: &cells,
            point_data: vec![("mode_1_100Hz", PointField::Vector2(&u))],
            cell_data: vec![("density", &rho[..])],
        };
        let shapes = mode_shape_svgs(&mesh.to_vtu().unwrap(), 4);
        assert_eq!(shapes.len(), 1);
        assert_eq!(shapes[0].0, "mode_1_100Hz");
        assert_eq!(shapes[0].1.matches("<path").count(), 1, "void cell skipped");
    }
}
