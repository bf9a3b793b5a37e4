//! The tables and figures of a tracking folder that span several runs: `metrics.csv` (merged
//! by trajectory and controller) and the 2D paths of Figure 11.

use flexstage_report::RunDir;
use flexstage_report::layout::Tracking;
use flexstage_report::plot::{Figure, Series};
use flexstage_sim::trajectory::Reference;

use crate::error::Result;
use crate::track::{Path2D, TrackRow, read_paths};

/// The header of `metrics.csv`.
const HEADER: &str = "trajectory,variant,compensation,model,plant,rms1_nm,rms2_nm,rms1_pct,rms2_pct,\
max1_nm,max2_nm,max1_pct,max2_pct,settling_s,peak_voltage_V,saturated_samples,dropouts,\
workspace_usage";

fn line(r: &TrackRow, compensation: &str, model: &str, plant: &str) -> String {
    let errors: Vec<String> = r.error_columns().iter().map(f64::to_string).collect();
    let m = &r.metrics;
    format!(
        "{},{},{compensation},{model},{plant},{},{},{},{}",
        r.trajectory,
        r.controller.name,
        errors.join(","),
        m.saturated,
        m.dropouts,
        r.usage
    )
}

/// Writes `metrics.csv` with the rows of this call. Rows of other (trajectory, controller)
/// pairs already in the file are kept when they were made under the same compensation,
/// model and plant (`twin` or `lumped`); the rows of this call replace theirs in place, new ones are appended. Returns the
/// (trajectory, controller) pairs of the file, in order.
pub(crate) fn write_metrics(
    run: &RunDir,
    out: &Tracking,
    rows: &[TrackRow],
    compensation: &str,
    model: &str,
    plant: &str,
) -> Result<Vec<(String, String)>> {
    let key = |l: &str| -> Option<(String, String)> {
        let mut c = l.split(',');
        Some((c.next()?.to_string(), c.next()?.to_string()))
    };
    let mut lines: Vec<String> = Vec::new();
    if let Some(text) = run.read_to_string(out.metrics()) {
        let mut it = text.lines();
        if it.next() == Some(HEADER) {
            // Same conditions only: a changed model or compensation replaces the table.
            lines = it
                .filter(|l| {
                    let c: Vec<&str> = l.split(',').collect();
                    c.get(2) == Some(&compensation)
                        && c.get(3) == Some(&model)
                        && c.get(4) == Some(&plant)
                })
                .map(str::to_string)
                .collect();
        }
    }
    for r in rows {
        let new = line(r, compensation, model, plant);
        let k = key(&new);
        match lines.iter_mut().find(|l| key(l) == k) {
            Some(l) => *l = new,
            None => lines.push(new),
        }
    }
    let text = format!("{HEADER}\n{}\n", lines.join("\n"));
    run.write(out.metrics(), text.as_bytes())?;
    Ok(lines.iter().filter_map(|l| key(l)).collect())
}

/// (x, y) points of a pair of series scaled by `scale`, every sample (the figure reduces
/// them for display without dropping extremes, [`flexstage_report::simplify`]).
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
                    .read_to_string(out.record(name, &key.1))
                    .and_then(|text| read_paths(&text))
                    .map(|p| scaled(&p, 1e6)),
            };
            if let Some(points) = points {
                fig = fig.with(Series::line(key.1.clone(), points));
            }
        }
        run.write(out.paths_svg(name), fig.to_svg()?.as_bytes())?;
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
        write_metrics(&run, &out, &all, "inverse", "guess", "twin").unwrap();
        let keys = write_metrics(
            &run,
            &out,
            &[row(&ROBUST, 3e-9)],
            "inverse",
            "guess",
            "twin",
        )
        .unwrap();
        assert_eq!(
            keys,
            [
                ("circle".to_string(), "robust".to_string()),
                ("circle".to_string(), "nonrobust".to_string())
            ]
        );
        let text = run.read_to_string(out.metrics()).unwrap();
        let rms = flexstage_report::read_csv_columns(&text, &["rms1_nm"]).unwrap();
        assert_eq!(
            rms[0],
            [3.0, 2.0],
            "robust updated in place, nonrobust kept"
        );
        let keys = write_metrics(
            &run,
            &out,
            &[row(&ROBUST, 4e-9)],
            "inverse",
            "x.toml",
            "twin",
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
        )
        .unwrap();
        assert_eq!(keys.len(), 1, "another plant starts a new table");
        let text = run.read_to_string(out.metrics()).unwrap();
        assert!(text.contains(",x.toml,lumped,"), "the plant column: {text}");
        std::fs::remove_dir_all(&root).unwrap();
    }
}
