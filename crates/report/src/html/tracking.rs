//! Tracking section (Section 4, Figures 9–11): the metrics table, and per trajectory the 2D
//! paths of every controller (Figure 11), the tracking error in the plane per controller
//! (Figure 11's error view), and the error of each controller against time (Figures 9–10).

use std::sync::Arc;

use flexstage_figures::cloud::Cloud;
use flexstage_figures::plot::{Figure, Legend, Multiples, Series};
use flexstage_run::Table;
use flexstage_run::files::track::{LEARNING_SUFFIX, MarginRow, MetricsRow, ScanLimit, ScanRow};
use flexstage_run::format::Rows;
use flexstage_run::layout::Tracking;

use super::{Builder, Width, cell, fmt_num};

/// One shown cell of a `metrics.csv` row.
type MetricCell = fn(&MetricsRow) -> String;

/// The columns of `metrics.csv` the report shows, in the file's order, with headers for
/// people (the file's column names are for programs).
const METRICS_SHOWN: [(&str, MetricCell); 11] = [
    ("trajectory", |r| r.trajectory.clone()),
    ("controller", |r| r.variant.clone()),
    ("RMS error q1 [nm]", |r| cell(r.rms1_nm)),
    ("RMS error q2 [nm]", |r| cell(r.rms2_nm)),
    ("RMS q1 [% of range]", |r| cell(r.rms1_pct)),
    ("RMS q2 [% of range]", |r| cell(r.rms2_pct)),
    ("largest error q1 [nm]", |r| cell(r.max1_nm)),
    ("largest error q2 [nm]", |r| cell(r.max2_nm)),
    ("peak voltage [V]", |r| cell(r.peak_voltage_v)),
    ("samples at the amplifier's limit", |r| {
        r.saturated_samples.to_string()
    }),
    ("status", |r| r.status.clone()),
];

/// The headers of the margins table: every column of `margins.csv` but the method.
const MARGIN_HEADER: [&str; 10] = [
    "controller",
    "loop delay [samples]",
    "loop",
    "gain margin [dB]",
    "phase crossover [Hz]",
    "phase margin [°]",
    "gain crossover [Hz]",
    "delay margin [samples]",
    "keeps 6 dB / 40°",
    "Monte-Carlo pass [%]",
];

/// A margin cell: the value to the file's precision, shortened; empty when there is none.
fn margin(v: Option<f64>, digits: usize) -> String {
    v.map(|v| super::short(&format!("{v:.digits$}")))
        .unwrap_or_default()
}

/// The rows of `margins.csv` as the report shows them (every column but the method).
fn margin_table(rows: &[MarginRow]) -> (Vec<String>, Vec<Vec<String>>) {
    let header = MARGIN_HEADER.map(String::from).to_vec();
    let rows = rows
        .iter()
        .map(|r| {
            vec![
                r.controller.clone(),
                r.delay_samples.to_string(),
                r.axis.clone(),
                r.gain_margin_db
                    .map_or_else(|| "unstable".into(), |v| margin(Some(v), 2)),
                margin(r.phase_crossover_hz, 1),
                margin(r.phase_margin_deg, 1),
                margin(r.gain_crossover_hz, 1),
                margin(r.delay_margin_samples, 2),
                ["no", "yes"][r.meets_targets as usize].to_string(),
                margin(r.montecarlo_pass_pct, 0),
            ]
        })
        .collect();
    (header, rows)
}

/// The scan sweep's table: one row per point and controller, the amplitude limit and what
/// limits the error.
fn scan_table(rows: &[ScanRow]) -> (Vec<String>, Vec<Vec<String>>) {
    let header = [
        "fast axis [% of f1]",
        "fast axis [Hz]",
        "amplitude q1 [µm]",
        "amplitude limit",
        "controller",
        "RMS q1 / q2 [% of range]",
        "peak q1 / q2 [% of range]",
        "cause",
        "largest error line [Hz]",
    ]
    .map(String::from)
    .to_vec();
    let rows = rows
        .iter()
        .map(|r| {
            vec![
                fmt_num(100.0 * r.fraction_of_f1),
                fmt_num(r.fast_frequency_hz),
                fmt_num(r.amplitude1_m * 1e6),
                match r.amplitude_limit {
                    ScanLimit::None => "none".to_string(),
                    l => format!("{} (× {})", l.name(), fmt_num(r.amplitude_factor)),
                },
                r.controller.clone(),
                format!(
                    "{} / {}",
                    fmt_num(r.rms1_pct_range),
                    fmt_num(r.rms2_pct_range)
                ),
                format!(
                    "{} / {}",
                    fmt_num(r.peak1_pct_range),
                    fmt_num(r.peak2_pct_range)
                ),
                r.cause.name().to_string(),
                fmt_num(r.dominant_hz),
            ]
        })
        .collect();
    (header, rows)
}

/// Section "tracking".
pub(super) fn tracking(b: &mut Builder) {
    let track = Tracking::main();
    let rel = track.metrics();
    let Some(metrics) = b.load::<Rows<MetricsRow>>(&rel) else {
        b.missing(&rel);
        return;
    };
    let header: Vec<String> = METRICS_SHOWN.iter().map(|(h, _)| h.to_string()).collect();
    let rows: Vec<Vec<String>> = metrics
        .0
        .iter()
        .map(|r| METRICS_SHOWN.iter().map(|(_, f)| f(r)).collect())
        .collect();
    b.table(&header, &rows);
    // Loop-at-a-time margins of each controller on the twin (flagged below 6 dB / 40°).
    let margins: Option<Arc<Rows<MarginRow>>> = b.load(&track.margins());
    if let Some(m) = &margins {
        let (header, rows) = margin_table(&m.0);
        b.table(&header, &rows);
    }
    for line in verdict(&metrics.0, margins.as_ref().map(|m| m.0.as_slice())) {
        b.note(&line);
    }
    // Error against scan frequency (on the twin only).
    if b.exists(&track.scan_frequency_svg()) {
        b.img(
            &track.scan_frequency_svg(),
            "RMS error of every controller on the Lissajous 3:1 against the frequency of its \
             fast component, 1–30 % of the twin's first resonance (scan_frequency.csv)",
        );
    }
    let scan: Option<Arc<Rows<ScanRow>>> = b.load(&track.scan_frequency_csv());
    if let Some(scan) = &scan {
        let (header, rows) = scan_table(&scan.0);
        b.table(&header, &rows);
        b.note(
            "Scan sweep: each point's amplitude is the scenario's, scaled by the binding \
             amplifier limit; RMS and peak over the second half of the run; cause: bandwidth \
             (error at the scan's own lines), distortion (elsewhere), aliasing (the true error \
             over twice what the loop reads), unstable.",
        );
    }
    // Trajectories in the table's order, each with its controllers.
    let mut groups: Vec<(String, Vec<&MetricsRow>)> = Vec::new();
    for r in &metrics.0 {
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
                &track.error_svg(t, &r.variant),
                &format!(
                    "{t}, {}: tracking error against time (Figures 9–10)",
                    r.variant
                ),
            );
        }
    }
}

/// Which controller wins where, from `metrics.csv` and `margins.csv`: per trajectory the
/// controller with the smallest planar RMS error √(RMS₁² + RMS₂²) among those that keep the
/// margins (≥ 6 dB / 40° with the rig's delay) and did not diverge, then the
/// runners-up; controllers below the margins are named apart, whatever their error, because
/// a practitioner would not ship them. Without margins (the lumped plant) every controller
/// competes and the text says so.
pub(super) fn verdict(rows: &[MetricsRow], margins: Option<&[MarginRow]>) -> Vec<String> {
    // Controllers whose margins fall short, from `meets_targets`.
    let mut flagged: Vec<String> = margins
        .unwrap_or_default()
        .iter()
        .filter(|m| !m.meets_targets)
        .map(|m| m.controller.clone())
        .collect();
    flagged.dedup();
    let mut order: Vec<String> = Vec::new();
    for r in rows {
        if !order.contains(&r.trajectory) {
            order.push(r.trajectory.clone());
        }
    }
    let mut out = Vec::new();
    for t in &order {
        let mut ranked: Vec<(f64, &MetricsRow, [f64; 2])> = rows
            .iter()
            .filter(|r| {
                // A controller with learning has its feedback controller's margins.
                let feedback = r
                    .variant
                    .strip_suffix(LEARNING_SUFFIX)
                    .unwrap_or(&r.variant);
                &r.trajectory == t && !flagged.iter().any(|f| f == feedback) && !refused(r)
            })
            .filter_map(|r| {
                let (a, b) = (r.rms1_nm, r.rms2_nm);
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
            .map(|(_, r, e)| format!("{} {:.1} / {:.1} nm", r.variant, e[0], e[1]))
            .collect();
        out.push(format!(
            "{t}: {} wins with {:.1} / {:.1} nm RMS (q1 / q2){}{}.",
            best.variant,
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
    let statuses: Vec<String> = rows
        .iter()
        .filter(|r| !r.status.is_empty() && r.status != "ok")
        .map(|r| format!("{}/{}: {}", r.trajectory, r.variant, r.status_detail))
        .collect();
    if !statuses.is_empty() {
        out.push(format!(
            "Flagged (status in metrics.csv; diverged or error-above-bound rows are refused and \
             not ranked): {}.",
            statuses.join("; ")
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

/// Whether a row's status refuses its result (`flexstage-sim`'s `Status::refused`).
fn refused(r: &MetricsRow) -> bool {
    r.status == "diverged" || r.status == "error-above-bound"
}

/// Figure 11's error view: per controller a panel of the error e = q − q_ref in the plane
/// \[nm\], on axes shared by all panels: the hull of every sample, the 2σ covariance ellipse
/// and the mean. The paths of Figure 11 differ by nanometres on a path of micrometres; here
/// the controllers' errors are side by side at their own scale.
fn error_view(b: &mut Builder, track: &Tracking, trajectory: &str, rows: &[&MetricsRow]) {
    let mut clouds = Vec::new();
    for (k, r) in rows.iter().enumerate() {
        let rel = track.record(trajectory, &r.variant);
        let Some(t) = b.load::<Table>(&rel) else {
            continue;
        };
        let pts: Vec<(f64, f64)> = match t.pairs("err1_m", "err2_m") {
            Ok(p) => p.into_iter().map(|(x, y)| (x * 1e9, y * 1e9)).collect(),
            Err(reason) => {
                b.damaged(&rel, reason);
                continue;
            }
        };
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
                r.variant,
                fmt_num(r.rms1_nm),
                fmt_num(r.rms2_nm)
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

#[cfg(test)]
mod tests {
    use super::*;
    use flexstage_run::format::Row;

    fn row(trajectory: &str, variant: &str, rms: [f64; 2]) -> MetricsRow {
        MetricsRow {
            trajectory: trajectory.into(),
            variant: variant.into(),
            compensation: "inverse".into(),
            model: "guess".into(),
            plant: "twin".into(),
            rms1_nm: rms[0],
            rms2_nm: rms[1],
            rms1_pct: 0.0,
            rms2_pct: 0.0,
            max1_nm: 0.0,
            max2_nm: 0.0,
            max1_pct: 0.0,
            max2_pct: 0.0,
            settling_s: 0.0,
            peak_voltage_v: 0.0,
            saturated_samples: 0,
            status: "ok".into(),
            status_detail: "ok".into(),
            dropouts: 0,
            workspace_usage: 0.5,
        }
    }

    fn metrics() -> Vec<MetricsRow> {
        vec![
            row("circle", "robust", [2.0, 2.0]),
            row("circle", "pi-notch-ff", [4.3, 5.0]),
            row("circle", "pid-ff", [7.0, 8.7]),
            row("line", "pi-notch-ff", [f64::NAN, 1.0]),
            row("line", "pid-ff", [9.0, 9.0]),
        ]
    }

    fn margin(controller: &str, axis: &str, gm: Option<f64>, meets: bool) -> MarginRow {
        MarginRow {
            controller: controller.into(),
            delay_samples: 1,
            axis: axis.into(),
            gain_margin_db: gm,
            phase_crossover_hz: None,
            phase_margin_deg: None,
            gain_crossover_hz: None,
            delay_margin_samples: None,
            method: "transfer function".into(),
            meets_targets: meets,
            montecarlo_pass_pct: Some(95.0),
        }
    }

    #[test]
    fn the_winner_keeps_its_margins_and_the_flagged_are_named_apart() {
        // Goal: a controller below the margins never wins, even with the smallest error; a
        // diverged (NaN) row is not ranked; runners-up follow in order.
        let margins = [
            margin("pi-notch-ff", "q1", Some(6.0), true),
            margin("pi-notch-ff", "q2", Some(9.5), true),
            margin("robust", "q1", None, false),
            margin("robust", "q2", None, false),
            margin("pid-ff", "q1", Some(6.2), true),
            margin("pid-ff", "q2", Some(15.0), true),
        ];
        let v = verdict(&metrics(), Some(&margins));
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
        let (header, shown) = margin_table(&margins);
        // One header per shown column of the file (every column but the method).
        assert_eq!(header.len(), <MarginRow as Row>::HEADER.len() - 1);
        assert_eq!(shown[0].len(), header.len());
        assert_eq!(shown[0][8], "yes");
        assert_eq!(shown[0][3], "6.000");
        assert_eq!(shown[2][3], "unstable");
        assert_eq!(shown[0][9], "95");
    }

    #[test]
    fn without_margins_every_controller_competes() {
        let v = verdict(&metrics(), None);
        assert!(
            v[0].starts_with("circle: robust wins with 2.0 / 2.0 nm"),
            "{v:?}"
        );
        assert!(v[0].contains("every controller competes"), "{v:?}");
        assert_eq!(v.len(), 2, "{v:?}");
    }
}
