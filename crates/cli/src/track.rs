//! `flexstage track`: the simulated tracking experiment (Section 4, Figures 9–11).

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use flexstage_control::actuator::Compensation;
use flexstage_control::experiment::{Metrics, Record, Setup, Variant, experiment_with_progress};
use flexstage_control::trajectory::Reference;
use flexstage_report::plot::{Figure, Series};
use flexstage_scenario::StageParams;

use crate::run_dir::{open_run, progress};
use crate::scenario_args::ScenarioArgs;

/// Options of `track`.
#[derive(Debug, Args)]
pub struct TrackArgs {
    #[command(flatten)]
    pub scenario: ScenarioArgs,
    /// Trajectory name from the scenario, or "all".
    #[arg(long, default_value = "all")]
    pub trajectory: String,
    /// Controller variant: "robust", "nonrobust", "pid-ff" or "all".
    #[arg(long, default_value = "all", value_parser = ["robust", "nonrobust", "pid-ff", "all"])]
    pub variant: String,
    /// Hysteresis compensation: "inverse" (Eq. 21, in the loop) or "off" (straight line).
    #[arg(long, default_value = "inverse", value_parser = ["inverse", "off"])]
    pub compensation: String,
    /// Controller model parameters (a StageParams TOML, as written by `flexstage reduce` or
    /// `identify stage`) in place of the scenario's stage.guess.
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// Duration [s] of every run (default: each trajectory's own).
    #[arg(long)]
    pub duration: Option<f64>,
    /// Run folder (default runs/<scenario name>).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs `track`.
pub fn run(args: TrackArgs) -> anyhow::Result<()> {
    let scenario = args.scenario.load()?;
    let mut setup = Setup::from_scenario(&scenario);
    if let Some(path) = &args.params {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let p: StageParams = toml::from_str(&text)
            .with_context(|| format!("{}: not a stage parameter table", path.display()))?;
        p.validate("params")
            .with_context(|| format!("invalid parameters in {}", path.display()))?;
        setup.controller.model = p;
    }
    let compensation = match args.compensation.as_str() {
        "off" => Compensation::Off,
        _ => Compensation::Inverse,
    };
    let variants: Vec<Variant> = if args.variant == "all" {
        Variant::ALL.to_vec()
    } else {
        vec![Variant::from_name(&args.variant).context("unknown --variant")?]
    };
    let trajectories: Vec<_> = scenario
        .trajectories
        .iter()
        .filter(|t| args.trajectory == "all" || t.name() == args.trajectory)
        .collect();
    if trajectories.is_empty() {
        let names: Vec<&str> = scenario.trajectories.iter().map(|t| t.name()).collect();
        anyhow::bail!(
            "no trajectory named {:?}: the scenario has {}",
            args.trajectory,
            names.join(", ")
        );
    }
    if let Some(d) = args.duration {
        anyhow::ensure!(
            d > 0.0 && d.is_finite(),
            "--duration must be > 0 s, got {d}"
        );
    }
    let dt = scenario.simulation.sample_time;
    let workspace = setup
        .workspace()
        .context("the controller model has no static inverse")?;
    let run = open_run(args.out, &scenario)?;

    let plan: Vec<(Reference, f64, &str)> = trajectories
        .iter()
        .map(|t| {
            let (r, d) = Reference::from_scenario(t);
            (r, args.duration.unwrap_or(d), t.name())
        })
        .collect();
    let total: f64 = plan.iter().map(|p| p.1).sum::<f64>() * variants.len() as f64;
    let bar = progress((total / dt).round() as u64, "track");
    let mut table = Vec::new();
    for (reference, duration, name) in &plan {
        let usage = workspace.max_usage(reference, *duration, dt);
        if usage > 1.0 {
            eprintln!(
                "warning: trajectory {name} leaves the designed workspace (uses {:.0} % of the stroke); expect saturation",
                100.0 * usage
            );
        }
        // The variants run side by side (one thread each).
        let records: Vec<anyhow::Result<Record>> = std::thread::scope(|s| {
            let handles: Vec<_> = variants
                .iter()
                .map(|&v| {
                    let (setup, bar) = (&setup, bar.clone());
                    s.spawn(move || {
                        experiment_with_progress(
                            setup,
                            v,
                            compensation,
                            *reference,
                            *duration,
                            |n| bar.inc(n as u64),
                        )
                        .map_err(anyhow::Error::from)
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("experiment thread"))
                .collect()
        });
        let half = reference.half_range(*duration, dt);
        let mut paths = vec![Series::line(
            "reference",
            decimate(&records_ref(&records)?.reference, 1e6),
        )];
        for (v, rec) in variants.iter().zip(records) {
            let rec = rec?;
            let tag = format!("{name}_{}", v.name());
            let csv = flexstage_report::csv_columns(&Record::header(), &rec.columns());
            run.write(format!("track/{tag}.csv"), csv.as_bytes())?;
            let err = |i: usize| -> Vec<(f64, f64)> {
                let n = rec.len();
                let step = (n / 4000).max(1);
                (0..n)
                    .step_by(step)
                    .map(|k| (rec.t[k], rec.error[i][k] * 1e9))
                    .collect()
            };
            let fig = Figure::new(
                format!("{name}, {}: tracking error (Figures 9-10)", v.name()),
                "t [s]",
                "error [nm]",
            )
            .with(Series::line("q1 (horizontal)", err(0)))
            .with(Series::line("q2 (vertical)", err(1)));
            run.write(format!("track/{tag}_error.svg"), fig.to_svg()?.as_bytes())?;
            paths.push(Series::line(v.name(), decimate(&rec.truth, 1e6)));
            table.push((name.to_string(), *v, rec.metrics(half), usage));
        }
        let mut fig = Figure::new(
            format!("{name}: output trajectory (Figure 11)"),
            "q1 [µm]",
            "q2 [µm]",
        )
        .equal_aspect();
        for s in paths {
            fig = fig.with(s);
        }
        run.write(format!("track/{name}_2d.svg"), fig.to_svg()?.as_bytes())?;
    }
    bar.finish_and_clear();
    let metrics_csv = metrics_table(&table, &args.compensation);
    run.write("track/metrics.csv", metrics_csv.as_bytes())?;
    print_table(&table, &args.compensation);
    eprintln!("wrote {}", run.path("track").display());
    Ok(())
}

/// The reference of the first successful record.
fn records_ref(records: &[anyhow::Result<Record>]) -> anyhow::Result<&Record> {
    match records.iter().find(|r| r.is_ok()) {
        Some(Ok(r)) => Ok(r),
        _ => match records.iter().find_map(|r| r.as_ref().err()) {
            Some(e) => Err(anyhow::anyhow!("{e:#}")),
            None => Err(anyhow::anyhow!("no controller variant ran")),
        },
    }
}

/// (x, y) points of a pair of series scaled by `scale`, at most ~4000 of them.
fn decimate(xy: &[Vec<f64>; 2], scale: f64) -> Vec<(f64, f64)> {
    let n = xy[0].len();
    let step = (n / 4000).max(1);
    (0..n)
        .step_by(step)
        .map(|k| (xy[0][k] * scale, xy[1][k] * scale))
        .collect()
}

fn metrics_table(rows: &[(String, Variant, Metrics, f64)], compensation: &str) -> String {
    let mut out = String::from(
        "trajectory,variant,compensation,rms1_nm,rms2_nm,rms1_pct,rms2_pct,max1_nm,max2_nm,max1_pct,max2_pct,settling_s,peak_voltage_V,saturated_samples,dropouts,workspace_usage\n",
    );
    for (name, v, m, usage) in rows {
        out.push_str(&format!(
            "{name},{},{compensation},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            v.name(),
            m.rms[0] * 1e9,
            m.rms[1] * 1e9,
            m.rms_pct[0],
            m.rms_pct[1],
            m.max[0] * 1e9,
            m.max[1] * 1e9,
            m.max_pct[0],
            m.max_pct[1],
            m.settling,
            m.peak_voltage,
            m.saturated,
            m.dropouts,
            usage
        ));
    }
    out
}

fn print_table(rows: &[(String, Variant, Metrics, f64)], compensation: &str) {
    println!(
        "{:<14} {:<10} {:>17} {:>15} {:>17} {:>15} {:>9} {:>8} {:>5}",
        "trajectory",
        "variant",
        "RMS q1/q2 [nm]",
        "RMS [% range]",
        "max q1/q2 [nm]",
        "max [% range]",
        "settle[s]",
        "peak [V]",
        "sat"
    );
    for (name, v, m, _) in rows {
        println!(
            "{:<14} {:<10} {:>8.1}/{:<8.1} {:>7.3}/{:<7.3} {:>8.1}/{:<8.1} {:>7.3}/{:<7.3} {:>9.4} {:>8.0} {:>5}",
            name,
            v.name(),
            m.rms[0] * 1e9,
            m.rms[1] * 1e9,
            m.rms_pct[0],
            m.rms_pct[1],
            m.max[0] * 1e9,
            m.max[1] * 1e9,
            m.max_pct[0],
            m.max_pct[1],
            m.settling,
            m.peak_voltage,
            m.saturated
        );
    }
    println!("(hysteresis compensation: {compensation}; errors against the true output)");
}
