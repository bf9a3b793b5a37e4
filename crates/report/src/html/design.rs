//! Design sections: Figure 4 (a)/(b) (the optimized densities, normal and tilted output
//! configuration, and their workspace polygons against the uniform start design), the
//! workspace evolution during the optimization, and the convergence history.

use flexstage_figures::plot::{Figure, Legend, Series};
use flexstage_run::Table;
use flexstage_run::files::design::{DesignSummaryFile, POLYGON};
use flexstage_run::layout::{self, design as files};
use flexstage_run::scenario::Scenario;

use super::{Builder, Width, fmt_num};

/// One design shown in Figure 4: the run's own, or the nested tilted run.
struct Shown {
    /// Prefix of its run folder inside the report's (`""` or `"tilted/"`).
    prefix: String,
    /// Output tilt θ \[°\] of its scenario.
    tilt: f64,
}

impl Shown {
    fn rel(&self, file: &str) -> String {
        format!("{}{file}", self.prefix)
    }

    /// "(a) normal configuration" or "(b) tilted output region, θ = …°".
    fn label(&self) -> String {
        if self.tilt == 0.0 {
            "(a) normal configuration, θ = 0°".into()
        } else {
            format!("(b) tilted output region, θ = {}°", fmt_num(self.tilt))
        }
    }

    fn short(&self) -> &'static str {
        if self.tilt == 0.0 { "(a)" } else { "(b)" }
    }
}

/// The designs of the run folder: its own and a nested tilted one, normal first.
fn designs(b: &mut Builder) -> Vec<Shown> {
    let mut out = Vec::new();
    for prefix in [String::new(), format!("{}/", layout::TILTED)] {
        if !b.exists(&format!("{prefix}{}", files::DENSITY_PNG)) {
            continue;
        }
        let tilt = b
            .load::<Scenario>(&format!("{prefix}{}", layout::SCENARIO))
            .map_or(0.0, |s| s.output.tilt_deg);
        out.push(Shown { prefix, tilt });
    }
    out.sort_by_key(|d| d.tilt != 0.0);
    out
}

/// Section "design": Figure 4.
pub(super) fn design(b: &mut Builder) {
    let shown = designs(b);
    if shown.is_empty() {
        b.not_run(&format!("{} missing", files::DENSITY_PNG));
        return;
    }
    b.note(
        "Optimized density (black = solid) as in the paper's Figure 4, and the workspace \
         polygon of the output point (Eq. 4): uniform start design against the optimum. \
         A tilted-output design (Figure 4 b) is shown when the run folder holds one in \
         tilted/ (a run folder of its own, e.g. `flexstage design tilted.toml --out \
         <run>/tilted`).",
    );
    b.grid_open();
    for d in &shown {
        let area = b
            .load::<DesignSummaryFile>(&d.rel(files::SUMMARY))
            .map(|s| format!(", workspace {} µm²", fmt_num(s.area_final_m2 * 1e12)))
            .unwrap_or_default();
        let caption = format!("{}: density ρ{area}", d.label());
        let rel = d.rel(files::DENSITY_PNG);
        let scenario = b.load::<Scenario>(&d.rel(layout::SCENARIO));
        match (scenario, b.exists(&rel)) {
            (Some(s), true) => {
                let Some(png) = b.read(&rel) else { continue };
                b.shown.push(rel.clone());
                let caption = format!(
                    "{caption}; supports, PEA input nodes and output as the scenario sets them"
                );
                b.svg(
                    &super::design_picture::svg(&png, &s),
                    &caption,
                    Some(&rel),
                    Width::Half,
                );
            }
            _ => {
                b.file_figure(&rel, &caption, Width::Half);
            }
        }
    }
    b.grid_close();
    workspace(b, &shown);
    for d in &shown {
        let rel = d.rel(files::WORKSPACE_HISTORY_SVG);
        if b.exists(&rel) {
            let caption = format!(
                "{}: workspace polygon during the optimization (Figure 4, evolution)",
                d.short()
            );
            b.img(&rel, &caption);
        }
    }
    b.other_figures(files::DIR, "Further design results");
}

/// The workspace polygons of every design against the start design, in one figure.
fn workspace(b: &mut Builder, shown: &[Shown]) {
    let read = |b: &mut Builder, rel: &str| -> Option<Vec<(f64, f64)>> {
        let t = b.load::<Table>(rel)?;
        match t.pairs(POLYGON[0], POLYGON[1]) {
            Ok(p) => Some(p),
            Err(reason) => {
                b.damaged(rel, reason);
                None
            }
        }
    };
    let mut fig = Figure::new(
        "Workspace of the output point (Figure 4)",
        "x_out [µm]",
        "y_out [µm]",
    )
    .equal_aspect()
    .with_legend(Legend::UpperRight);
    if let Some(p) = read(b, &shown[0].rel(files::WORKSPACE_INITIAL)) {
        fig = fig.with(Series::closed("uniform start design", p).with_color(6));
    }
    for (i, d) in shown.iter().enumerate() {
        if let Some(p) = read(b, &d.rel(files::WORKSPACE_FINAL)) {
            fig = fig.with(Series::closed(format!("{} optimized", d.short()), p).with_color(i));
        }
    }
    let n = fig.series.len();
    match fig.to_svg() {
        Ok(svg) if n > 1 => {
            for d in shown {
                b.shown.push(d.rel(files::WORKSPACE_SVG));
            }
            let caption = "Workspace polygons: start design against the optimized design(s)";
            b.svg(&svg, caption, Some(files::WORKSPACE_FINAL), Width::Full);
        }
        _ => {
            if b.exists(files::WORKSPACE_SVG) {
                b.img(files::WORKSPACE_SVG, "Workspace polygons, initial vs final");
            }
        }
    }
}

/// Section "convergence": the workspace area, volume and grey fraction over the iterations.
///
/// The area is drawn in µm² as the optimizer saw it at each iteration (`area_m2` of the
/// history: its own analysis of the filtered and projected iterate), with the final analyses
/// of the uniform start design and of the finished design as two markers: the summary's
/// growth factor is the ratio of those two, which a ratio to the history's first iterate
/// would not show (the two analyses of the start differ).
pub(super) fn convergence(b: &mut Builder) {
    let Some(history) = b.load::<Table>(files::HISTORY_CSV) else {
        b.missing(files::HISTORY_CSV);
        return;
    };
    let c = match history.columns(&["iteration", "area_m2", "volume_fraction", "grey"]) {
        Ok(c) => c,
        Err(reason) => return b.damaged(files::HISTORY_CSV, reason),
    };
    let pts = |k: usize, scale: f64| -> Vec<(f64, f64)> {
        c[0].iter()
            .zip(c[k])
            .filter(|(a, b)| a.is_finite() && b.is_finite())
            .map(|(a, b)| (*a, *b * scale))
            .collect()
    };
    let mut area = Figure::new(
        "Workspace area over the design iterations",
        "iteration",
        "workspace area [µm²]",
    )
    .with_legend(Legend::LowerRight)
    .with(Series::line(
        "optimizer's analysis of each iterate",
        pts(1, 1e12),
    ));
    let summary = b.load::<DesignSummaryFile>(files::SUMMARY);
    let last = c[0]
        .iter()
        .copied()
        .filter(|i| i.is_finite())
        .fold(0.0, f64::max);
    let mut caption = "Workspace area (history.csv, area_m2)".to_string();
    if let Some(s) = &summary {
        area = area.with(
            Series::points(
                "final analysis: uniform start, design",
                vec![
                    (0.0, s.area_initial_m2 * 1e12),
                    (last, s.area_final_m2 * 1e12),
                ],
            )
            .with_color(1),
        );
        caption = format!(
            "Workspace area: the optimizer's analysis of each iterate (filtered and projected \
             densities), and the final analysis (total Lagrangian, no additive material) of the \
             uniform start design, {} µm², and of the design, {} µm²: the growth ×{} of the \
             summary is between these two",
            fmt_num(s.area_initial_m2 * 1e12),
            fmt_num(s.area_final_m2 * 1e12),
            fmt_num(s.area_final_m2 / s.area_initial_m2)
        );
    }
    let fractions = Figure::new("Volume and grey fraction", "iteration", "fraction")
        .with(Series::line("volume", pts(2, 1.0)))
        .with(Series::line("grey (0.1 < ρ < 0.9)", pts(3, 1.0)));
    for (fig, caption) in [
        (area, caption.as_str()),
        (fractions, "Volume and grey fraction"),
    ] {
        if let Ok(svg) = fig.to_svg() {
            b.svg(&svg, caption, Some(files::HISTORY_CSV), Width::Full);
        }
    }
}
