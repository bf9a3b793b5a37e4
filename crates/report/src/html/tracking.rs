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
    for line in verdict(&text, b.text(&margins).as_deref()) {
        b.note(&line);
    }
    // Issue #18, item 5: error against scan frequency (on the twin only).
    if b.exists(&track.scan_frequency_svg()) {
        b.img(
            &track.scan_frequency_svg(),
            "RMS error of every controller on the Lissajous 3:1 against the frequency of its \
             fast component, 1–30 % of the twin's first resonance (scan_frequency.csv)",
        );
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

/// Which controller wins where, from `metrics.csv` and `margins.csv`: per trajectory the
/// controller with the smallest planar RMS error √(RMS₁² + RMS₂²) among those that keep the
/// margins (≥ 6 dB / 40° with the rig's delay, issue #18) and did not diverge, then the
/// runners-up; controllers below the margins are named apart, whatever their error, because
/// a practitioner would not ship them. Without margins (the lumped plant) every controller
/// competes and the text says so.
pub(super) fn verdict(metrics: &str, margins: Option<&str>) -> Vec<String> {
    // Controllers whose margins fall short, from `meets_targets`.
    let flagged: Vec<String> = margins
        .map(|t| {
            let mut lines = t.lines();
            let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
            let col = |n: &str| header.iter().position(|h| *h == n);
            let (Some(c), Some(m)) = (col("controller"), col("meets_targets")) else {
                return Vec::new();
            };
            let mut out: Vec<String> = lines
                .filter_map(|l| {
                    let f: Vec<&str> = l.split(',').collect();
                    (f.get(m)? != &"true").then(|| f.get(c).map(|s| s.to_string()))?
                })
                .collect();
            out.dedup();
            out
        })
        .unwrap_or_default();
    let mut order: Vec<String> = Vec::new();
    let rows = metric_rows(metrics);
    for r in &rows {
        if !order.contains(&r.trajectory) {
            order.push(r.trajectory.clone());
        }
    }
    let mut out = Vec::new();
    for t in &order {
        let mut ranked: Vec<(f64, &MetricRow, [f64; 2])> = rows
            .iter()
            .filter(|r| &r.trajectory == t && !flagged.contains(&r.controller))
            .filter_map(|r| {
                let (a, b) = (r.rms[0].parse::<f64>().ok()?, r.rms[1].parse::<f64>().ok()?);
                let planar = a.hypot(b);
                planar.is_finite().then_some((planar, r, [a, b]))
            })
            .collect();
        ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
        let Some((_, best, e)) = ranked.first() else {
            out.push(format!(
                "{t}: no controller both keeps its margins and tracks."
            ));
            continue;
        };
        let rest: Vec<String> = ranked[1..]
            .iter()
            .map(|(_, r, e)| format!("{} {:.1} / {:.1} nm", r.controller, e[0], e[1]))
            .collect();
        out.push(format!(
            "{t}: {} wins with {:.1} / {:.1} nm RMS (q1 / q2){}{}.",
            best.controller,
            e[0],
            e[1],
            if margins.is_some() {
                " among the controllers that keep ≥ 6 dB / 40°"
            } else {
                " (no margins measured on this plant: every controller competes)"
            },
            if rest.is_empty() {
                String::new()
            } else {
                format!("; then {}", rest.join(", "))
            }
        ));
    }
    if !flagged.is_empty() {
        out.push(format!(
            "Below the 6 dB / 40° margins on this plant, so not ranked whatever their error: {}.",
            flagged.join(", ")
        ));
    }
    out
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

#[cfg(test)]
mod tests {
    use super::verdict;

    const METRICS: &str = "trajectory,variant,rms1_nm,rms2_nm\n\
        circle,robust,2.0,2.0\n\
        circle,pi-notch-ff,4.3,5.0\n\
        circle,pid-ff,7.0,8.7\n\
        line,pi-notch-ff,NaN,1.0\n\
        line,pid-ff,9.0,9.0\n";

    #[test]
    fn the_winner_keeps_its_margins_and_the_flagged_are_named_apart() {
        // Goal: a controller below the margins never wins, even with the smallest error; a
        // diverged (NaN) row is not ranked; runners-up follow in order.
        let margins = "controller,delay_samples,loop,gain_margin_dB,meets_targets\n\
            pi-notch-ff,1,q1,6.0,true\n\
            pi-notch-ff,1,q2,9.5,true\n\
            robust,1,q1,unstable,false\n\
            robust,1,q2,unstable,false\n\
            pid-ff,1,q1,6.2,true\n\
            pid-ff,1,q2,15.0,true\n";
        let v = verdict(METRICS, Some(margins));
        assert_eq!(v.len(), 3, "{v:?}");
        assert!(
            v[0].starts_with("circle: pi-notch-ff wins with 4.3 / 5.0 nm"),
            "{v:?}"
        );
        assert!(v[0].ends_with("; then pid-ff 7.0 / 8.7 nm."), "{v:?}");
        assert!(v[1].starts_with("line: pid-ff wins"), "{v:?}");
        assert!(
            v[2].contains("not ranked") && v[2].ends_with(": robust."),
            "{v:?}"
        );
    }

    #[test]
    fn without_margins_every_controller_competes() {
        let v = verdict(METRICS, None);
        assert!(
            v[0].starts_with("circle: robust wins with 2.0 / 2.0 nm"),
            "{v:?}"
        );
        assert!(v[0].contains("every controller competes"), "{v:?}");
        assert_eq!(v.len(), 2, "{v:?}");
    }
}
