//! The tables and figures of a tracking folder that span several runs: `metrics.csv` (merged
//! by trajectory and controller) and the 2D paths of Figure 11.

use flexstage_figures::plot::{Figure, Series};
use flexstage_run::files::track::MetricsRow;
use flexstage_run::format::Rows;
use flexstage_run::layout::Tracking;
use flexstage_run::{RunDir, RunError, Table};
use flexstage_sim::trajectory::Reference;

use crate::error::Result;
use crate::track::{Path2D, TrackRow, record_paths};

fn row(r: &TrackRow, compensation: &str, model: &str, plant: &str) -> MetricsRow {
    let e = r.error_columns();
    let m = &r.metrics;
    MetricsRow {
        trajectory: r.trajectory.clone(),
        variant: r.variant(),
        compensation: compensation.to_string(),
        model: model.to_string(),
        plant: plant.to_string(),
        rms1_nm: e[0],
        rms2_nm: e[1],
        rms1_pct: e[2],
        rms2_pct: e[3],
        max1_nm: e[4],
        max2_nm: e[5],
        max1_pct: e[6],
        max2_pct: e[7],
        settling_s: e[8],
        peak_voltage_v: e[9],
        saturated_samples: m.saturated,
        dropouts: m.dropouts,
        workspace_usage: r.usage,
        status: m.status().name().to_string(),
        status_detail: m.status_detail(),
    }
}

/// Writes `metrics.csv` with the rows of this call. Rows of other (trajectory, controller)
/// pairs already in the file are kept when they were made under the same compensation,
/// model and plant (`twin` or `lumped`); the rows of this call replace theirs in place, new
/// ones are appended. A table that cannot be read is replaced (with a warning). Returns the
/// (trajectory, controller) pairs of the file, in order.
pub(crate) fn write_metrics(
    run: &RunDir,
    out: &Tracking,
    rows: &[TrackRow],
    compensation: &str,
    model: &str,
    plant: &str,
    warnings: &mut Vec<String>,
) -> Result<Vec<(String, String)>> {
    let key = |r: &MetricsRow| (r.trajectory.clone(), r.variant.clone());
    let earlier = match run.load::<Rows<MetricsRow>>(&out.metrics()) {
        Ok(t) => t.map(|t| t.0.clone()).unwrap_or_default(),
        Err(e @ RunError::Damaged { .. }) => {
            warnings.push(format!("{e}; it is replaced by the rows of this call"));
            Vec::new()
        }
        Err(e) => return Err(e.into()),
    };
    // Same conditions only: a changed model or compensation replaces the table.
    let mut lines: Vec<MetricsRow> = earlier
        .into_iter()
        .filter(|r| r.compensation == compensation && r.model == model && r.plant == plant)
        .collect();
    for r in rows {
        let new = row(r, compensation, model, plant);
        match lines.iter_mut().find(|l| key(l) == key(&new)) {
            Some(l) => *l = new,
            None => lines.push(new),
        }
    }
    let keys = lines.iter().map(key).collect();
    run.store(&out.metrics(), Rows(lines))?;
    Ok(keys)
}

/// (x, y) points of a pair of series scaled by `scale`, every sample (the figure reduces
/// them for display without dropping extremes, [`flexstage_figures::simplify`]).
pub(crate) fn scaled(xy: &[Vec<f64>; 2], scale: f64) -> Vec<(f64, f64)> {
    xy[0]
        .iter()
        .zip(&xy[1])
        .map(|(x, y)| (x * scale, y * scale))
        .collect()
}

/// Figure 11 for each trajectory: the reference and the true output of every controller the
/// folder's metrics list for it (`fresh` for those of this call, else read back from their
/// time series).
pub(crate) fn write_paths(
    run: &RunDir,
    out: &Tracking,
    trajectories: &[(&str, Reference, f64)],
    merged: &[(String, String)],
    fresh: &[Path2D],
) -> Result<()> {
    for (name, reference, duration) in trajectories {
        let n = 4000usize;
        let reference_path: [Vec<f64>; 2] = {
            let q: Vec<[f64; 2]> = (0..=n)
                .map(|k| reference.sample(k as f64 * duration / n as f64).q)
                .collect();
            [
                q.iter().map(|p| p[0]).collect(),
                q.iter().map(|p| p[1]).collect(),
            ]
        };
        let mut fig = Figure::new(
            format!("{name}: output trajectory (Figure 11)"),
            "q1 [µm]",
            "q2 [µm]",
        )
        .equal_aspect()
        .with(Series::line("reference", scaled(&reference_path, 1e6)));
        for key in merged.iter().filter(|(t, _)| t == name) {
            let points = match fresh.iter().find(|(k, _)| k == key) {
                Some((_, p)) => Some(p.clone()),
                None => run
                    .load::<Table>(&out.record(name, &key.1))?
                    .and_then(|t| record_paths(&t))
                    .map(|p| scaled(&p, 1e6)),
            };
            if let Some(points) = points {
                fig = fig.with(Series::line(key.1.clone(), points));
            }
        }
        run.write(&out.paths_svg(name), fig.to_svg()?.as_bytes())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexstage_control::controller::{NONROBUST, ROBUST};
    use flexstage_control::registry::Controller;
    use flexstage_sim::experiment::Metrics;

    fn row(controller: &'static Controller, rms: f64) -> TrackRow {
        TrackRow {
            trajectory: "circle".into(),
            controller,
            learning: false,
            metrics: Metrics {
                rms: [rms, rms],
                ..Metrics::default()
            },
            usage: 0.5,
        }
    }

    #[test]
    fn metrics_keep_other_rows_of_the_same_conditions() {
        // Goal: re-running one controller updates its row in place and keeps the others;
        // another controller model replaces the table.
        let root = std::env::temp_dir().join(format!("flexstage-metrics-{}", std::process::id()));
        let run = RunDir::create(&root).unwrap();
        let out = Tracking::main();
        let all = [row(&ROBUST, 1e-9), row(&NONROBUST, 2e-9)];
        let w = &mut Vec::new();
        write_metrics(&run, &out, &all, "inverse", "guess", "twin", w).unwrap();
        let keys = write_metrics(
            &run,
            &out,
            &[row(&ROBUST, 3e-9)],
            "inverse",
            "guess",
            "twin",
            w,
        )
        .unwrap();
        assert_eq!(
            keys,
            [
                ("circle".to_string(), "robust".to_string()),
                ("circle".to_string(), "nonrobust".to_string())
            ]
        );
        let back = RunDir::create(&root).unwrap();
        let table = back
            .load::<Rows<MetricsRow>>(&out.metrics())
            .unwrap()
            .unwrap();
        let rms: Vec<f64> = table.0.iter().map(|r| r.rms1_nm).collect();
        assert_eq!(rms, [3.0, 2.0], "robust updated in place, nonrobust kept");
        let keys = write_metrics(
            &run,
            &out,
            &[row(&ROBUST, 4e-9)],
            "inverse",
            "x.toml",
            "twin",
            w,
        )
        .unwrap();
        assert_eq!(keys.len(), 1, "another model starts a new table");
        let keys = write_metrics(
            &run,
            &out,
            &[row(&NONROBUST, 5e-9)],
            "inverse",
            "x.toml",
            "lumped",
            w,
        )
        .unwrap();
        assert_eq!(keys.len(), 1, "another plant starts a new table");
        let text = std::fs::read_to_string(run.path(out.metrics())).unwrap();
        assert!(text.contains(",x.toml,lumped,"), "the plant column: {text}");
        // A damaged table is replaced, with a warning.
        std::fs::write(run.path(out.metrics()), "trajectory,variant\ncircle\n").unwrap();
        let fresh = RunDir::create(&root).unwrap();
        let keys = write_metrics(&fresh, &out, &all, "inverse", "guess", "twin", w).unwrap();
        assert_eq!(keys.len(), 2);
        assert!(
            w.iter().any(|m| m.contains("metrics.csv is damaged")),
            "{w:?}"
        );
        std::fs::remove_dir_all(&root).unwrap();
    }
}
