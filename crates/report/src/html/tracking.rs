//! Tracking section (Section 4, Figures 9–11): the metrics table, and per trajectory the 2D
//! paths of every controller (Figure 11), the tracking error in the plane per controller
//! (Figure 11's error view), and the error of each controller against time (Figures 9–10).

use super::{Builder, Width, fmt_num};
use crate::cloud::Cloud;
use crate::layout::Tracking;
use crate::plot::{Figure, Legend, Multiples, Series};
use crate::read_csv_columns as csv_cols;

/// One row of `metrics.csv`, as text.
pub(super) struct MetricRow {
    /// Trajectory name.
    pub trajectory: String,
    /// Controller name.
    pub controller: String,
    /// RMS error of q1 and q2 \[nm\].
    pub rms: [String; 2],
}

/// The (trajectory, controller, RMS) rows of a `metrics.csv`.
pub(super) fn metric_rows(text: &str) -> Vec<MetricRow> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n);
    let (Some(tr), Some(va), Some(r1), Some(r2)) = (
        col("trajectory"),
        col("variant"),
        col("rms1_nm"),
        col("rms2_nm"),
    ) else {
        return Vec::new();
    };
    lines
        .filter_map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            Some(MetricRow {
                trajectory: c.get(tr)?.to_string(),
                controller: c.get(va)?.to_string(),
                rms: [c.get(r1)?.to_string(), c.get(r2)?.to_string()],
            })
        })
        .collect()
}

/// Section "tracking".
pub(super) fn tracking(b: &mut Builder) {
    let track = Tracking::main();
    let metrics = track.metrics();
    let Some(text) = b.text(&metrics) else {
        b.not_run(&format!("{metrics} missing"));
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
    // Loop-at-a-time margins of each controller on the twin (flagged below 6 dB / 40°).
    let margins = track.margins();
    if b.text(&margins).is_some() {
        b.csv_table(&margins, |h| h != "method");
    }
    // Trajectories in the table's order, each with its controllers.
    let mut groups: Vec<(String, Vec<MetricRow>)> = Vec::new();
    for r in metric_rows(&text) {
        match groups.iter_mut().find(|(t, _)| *t == r.trajectory) {
            Some((_, rows)) => rows.push(r),
            None => groups.push((r.trajectory.clone(), vec![r])),
        }
    }
    for (t, rows) in &groups {
        b.h3(t);
        b.img(
            &track.paths_svg(t),
            &format!("{t}: output paths of every controller against the reference (Figure 11)"),
        );
        error_view(b, &track, t, rows);
        for r in rows {
            b.img(
                &track.error_svg(t, &r.controller),
                &format!(
                    "{t}, {}: tracking error against time (Figures 9–10)",
                    r.controller
                ),
            );
        }
    }
}

/// Figure 11's error view: per controller a panel of the error e = q − q_ref in the plane
/// \[nm\], on axes shared by all panels: the hull of every sample, the 2σ covariance ellipse
/// and the mean. The paths of Figure 11 differ by nanometres on a path of micrometres; here
/// the controllers' errors are side by side at their own scale.
fn error_view(b: &mut Builder, track: &Tracking, trajectory: &str, rows: &[MetricRow]) {
    let mut clouds = Vec::new();
    for (k, r) in rows.iter().enumerate() {
        let rel = track.record(trajectory, &r.controller);
        let Some(c) = b
            .text(&rel)
            .and_then(|t| csv_cols(&t, &["err1_m", "err2_m"]))
        else {
            continue;
        };
        let pts: Vec<(f64, f64)> = c[0]
            .iter()
            .zip(&c[1])
            .map(|(x, y)| (x * 1e9, y * 1e9))
            .collect();
        if let Some(cloud) = Cloud::of(&pts) {
            clouds.push((k, r, cloud));
        }
    }
    let reach = clouds
        .iter()
        .flat_map(|(_, _, c)| c.hull.iter())
        .fold(0.0f64, |m, p| m.max(p.0.abs()).max(p.1.abs()));
    if clouds.is_empty() || reach.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return;
    }
    let lim = 1.08 * reach;
    let columns = clouds.len().min(3);
    let mut multiples = Multiples::new(
        format!("{trajectory}: tracking error in the plane, e = q − q_ref (Figure 11, error view)"),
        columns,
        (340, 380),
    );
    for (i, (k, r, cloud)) in clouds.iter().enumerate() {
        let mean = vec![cloud.mean];
        let panel = Figure::new(
            format!(
                "{}: RMS {} / {} nm",
                r.controller,
                short_nm(&r.rms[0]),
                short_nm(&r.rms[1])
            ),
            "e1 [nm]",
            "e2 [nm]",
        )
        .equal_aspect()
        .with_range((-lim, lim), (-lim, lim))
        .with_legend(if i == 0 {
            Legend::LowerLeft
        } else {
            Legend::Hidden
        })
        .with(Series::closed("all samples", cloud.hull.clone()).with_color(6))
        .with(Series::line("2σ", cloud.ellipse(2.0, 72)).with_color(*k))
        .with(Series::points("mean", mean).with_color(*k));
        multiples = multiples.with(panel);
    }
    if let Ok(svg) = multiples.to_svg() {
        let caption = format!(
            "{trajectory}: the error of each controller in the plane (nm): outline of every \
             sample, 2σ covariance ellipse, mean; shared axes"
        );
        let source = track.record(trajectory, "<controller>");
        b.svg(&svg, &caption, Some(&source), Width::Full);
    }
}

/// A metrics cell in nm, shortened.
fn short_nm(cell: &str) -> String {
    cell.parse::<f64>()
        .map(fmt_num)
        .unwrap_or_else(|_| cell.to_string())
}
