//! `flexstage identify stage`: online least-squares identification of the stage stiffnesses
//! and dampings (Section 4.2, Eq. 54–56, Table 4) from a logged or simulated record.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use flexstage_control::experiment::Setup;
use flexstage_control::plant::PlantActuator;
use flexstage_identify::regression::{Scheme, paper_theta};
use flexstage_identify::{
    Identification, IdentifyParams, StageRecord, identify, samples, simulate,
};
use flexstage_report::csv_columns;
use flexstage_report::plot::{Figure, Series};
use flexstage_scenario::StageParams;

use crate::run_dir::open_run;
use crate::scenario_args::ScenarioArgs;

/// Options of `identify stage`.
#[derive(Debug, Args)]
pub struct StageArgs {
    /// The record: CSV with columns t [s], x_nom1, x_nom2 [m] (or U1, U2 [V]), x_in1, x_in2,
    /// q1, q2 [m], uniformly sampled.
    #[arg(
        long,
        conflicts_with = "simulate",
        required_unless_present = "simulate"
    )]
    pub data: Option<PathBuf>,
    /// Excite the simulated stage (multisine within the stroke), log it and identify.
    #[arg(long)]
    pub simulate: bool,
    #[command(flatten)]
    pub scenario: ScenarioArgs,
    /// Excitation length for --simulate [s] (4 s meets 5 % on the stiffnesses with the
    /// default sensor noise; 1 s is enough without noise).
    #[arg(long, default_value_t = 4.0)]
    pub duration: f64,
    /// Highest excitation frequency for --simulate [Hz].
    #[arg(long, default_value_t = 150.0)]
    pub f_max: f64,
    /// Simulated actuator: "hysteretic" (Bouc–Wen PEAs, cross terms) or "linear" (x_nom
    /// applied directly, no cross terms: the model of Eq. 36).
    #[arg(long, default_value = "hysteretic", value_parser = ["hysteretic", "linear"])]
    pub plant: String,
    /// Switch the simulated sensor noise and quantization off.
    #[arg(long)]
    pub noise_free: bool,
    /// Forgetting factor λ_f of the RLS rows, in (0, 1].
    #[arg(long, default_value_t = 1.0)]
    pub forgetting: f64,
    /// Prefilter cut-off [Hz] applied to every signal (0: off).
    #[arg(long, default_value_t = 300.0)]
    pub prefilter: f64,
    /// Regression at every d-th sample (d·T_s).
    #[arg(long, default_value_t = 1)]
    pub decimation: usize,
    /// Stiffness regressors as printed in Eq. (54) (central), or Numerov-weighted (default).
    #[arg(long, default_value = "numerov", value_parser = ["numerov", "central"])]
    pub scheme: String,
    /// Leave out the cross-term coupling column (the paper's two-column output rows).
    #[arg(long)]
    pub no_coupling: bool,
    /// Run folder (default runs/<scenario name>).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs `identify stage`.
pub fn run(args: StageArgs) -> anyhow::Result<()> {
    let scenario = args.scenario.load()?;
    let setup = Setup::from_scenario(&scenario);
    let guess = scenario.stage.guess.clone();
    let params = IdentifyParams {
        forgetting: args.forgetting,
        prefilter: args.prefilter,
        decimation: args.decimation,
        coupling: !args.no_coupling,
        scheme: if args.scheme == "central" {
            Scheme::Central
        } else {
            Scheme::Numerov
        },
        ..IdentifyParams::default()
    };
    params
        .validate()
        .context("invalid identification settings")?;
    let (record, truth, source) = if args.simulate {
        let linear = args.plant == "linear";
        let mut sim = samples::simulation(&scenario, args.duration, linear, !args.noise_free);
        sim.excitation.f_max = args.f_max;
        if !linear {
            sim.plant.actuator = PlantActuator::Hysteretic;
        }
        eprintln!(
            "simulating {} s of multisine excitation ({}–{} Hz, peak {:.1} µm) on the {} plant",
            args.duration,
            sim.excitation.f_min,
            sim.excitation.f_max,
            sim.excitation.amplitude * 1e6,
            args.plant
        );
        let record = simulate(&sim).context("simulation failed")?;
        (
            record,
            Some(sim.plant.truth.clone()),
            "simulated".to_string(),
        )
    } else {
        let path = args
            .data
            .as_ref()
            .expect("clap requires --data or --simulate");
        let file =
            std::fs::File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
        let origin = path.display().to_string();
        let record = StageRecord::from_csv(
            std::io::BufReader::new(file),
            &origin,
            &setup.plant.hysteresis,
            setup.plant.bias_voltage,
            params.sampling_tolerance,
        )?;
        (record, None, origin)
    };
    let id = identify(&record, &guess, &params).context("stage identification failed")?;
    for w in &id.warnings {
        eprintln!("warning: {w}");
    }

    let run = open_run(args.out, &scenario)?;
    let dir = "identify/stage";
    if args.simulate {
        run.write(format!("{dir}/record.csv"), record.to_csv().as_bytes())?;
    }
    let params_path = run.write(
        format!("{dir}/params.toml"),
        params_toml(&id, &source).as_bytes(),
    )?;
    let table = table(&guess, &id, truth.as_ref());
    run.write(format!("{dir}/table.csv"), table.csv.as_bytes())?;
    write_convergence(&run, dir, &id, truth.as_ref())?;
    println!(
        "{} samples at T_s = {} s (regression at {} s), {} updates",
        record.len(),
        id.sample_time,
        id.regression_time,
        id.updates
    );
    print!("{}", table.text);
    println!(
        "condition numbers (q_o1, q_o2, x_in1, x_in2): {:.3e}, {:.3e}, {:.3e}, {:.3e}",
        id.conditioning[0], id.conditioning[1], id.conditioning[2], id.conditioning[3]
    );
    eprintln!(
        "wrote {} (use: flexstage track --params {})",
        run.path(dir).display(),
        params_path.display()
    );
    Ok(())
}

fn params_toml(id: &Identification, source: &str) -> String {
    let body = toml::to_string(&id.params).expect("StageParams serializes");
    let th = paper_theta(&id.theta);
    format!(
        "# Stage parameters identified by `flexstage identify stage` from {source}.\n\
         # Masses and alpha are the known (weighed / Eq. 27) values of the scenario's guess.\n\
         # theta of Eq. (55) (diagonals, regression at {} s): {:?}\n\
         # coupling k_c [N/m] from the q_o1 / q_o2 rows: {:.6e}, {:.6e}\n\
         # Read by: flexstage track --params <this file>\n{body}",
        id.regression_time, th, id.raw.coupling[0], id.raw.coupling[1]
    )
}

struct Table {
    csv: String,
    text: String,
}

fn fields(p: &StageParams) -> [(&'static str, f64, &'static str); 10] {
    [
        ("k_qo1", p.k_qo1, "N/m"),
        ("k_qo2", p.k_qo2, "N/m"),
        ("k_in1", p.k_in1, "N/m"),
        ("k_in2", p.k_in2, "N/m"),
        ("k_pea1", p.k_pea1, "N/m"),
        ("k_pea2", p.k_pea2, "N/m"),
        ("c_qo1", p.c_qo1, "N s/m"),
        ("c_qo2", p.c_qo2, "N s/m"),
        ("c_in1", p.c_in1, "N s/m"),
        ("c_in2", p.c_in2, "N s/m"),
    ]
}

fn table(guess: &StageParams, id: &Identification, truth: Option<&StageParams>) -> Table {
    let mut csv = String::from("parameter,unit,guess,estimate,truth,error_pct\n");
    let mut text = format!(
        "{:<8} {:>12} {:>12} {:>12} {:>9}  unit\n",
        "param", "guess", "estimate", "truth", "error %"
    );
    let g = fields(guess);
    let e = fields(&id.raw.params);
    let t = truth.map(fields);
    for i in 0..10 {
        let (name, gv, unit) = g[i];
        let ev = e[i].1;
        let tv = t.map(|t| t[i].1);
        let err = tv.map(|tv| 100.0 * (ev - tv) / tv);
        csv.push_str(&format!(
            "{name},{unit},{gv:e},{ev:e},{},{}\n",
            tv.map(|v| format!("{v:e}")).unwrap_or_default(),
            err.map(|v| format!("{v:.4}")).unwrap_or_default()
        ));
        text.push_str(&format!(
            "{name:<8} {gv:>12.4e} {ev:>12.4e} {:>12} {:>9}  {unit}\n",
            tv.map(|v| format!("{v:.4e}")).unwrap_or_else(|| "-".into()),
            err.map(|v| format!("{v:+.3}"))
                .unwrap_or_else(|| "-".into())
        ));
    }
    let kc = id.raw.coupling;
    csv.push_str(&format!(",N/m,0,{:e},,\n", 0.5 * (kc[0] + kc[1])).replacen(',', "k_c,", 1));
    text.push_str(&format!(
        "{:<8} {:>12} {:>12.4e} {:>12} {:>9}  N/m (cross terms, rows q_o1/q_o2: {:.3e}/{:.3e})\n",
        "k_c",
        "0",
        0.5 * (kc[0] + kc[1]),
        "-",
        "-",
        kc[0],
        kc[1]
    ));
    Table { csv, text }
}

fn write_convergence(
    run: &flexstage_report::RunDir,
    dir: &str,
    id: &Identification,
    truth: Option<&StageParams>,
) -> anyhow::Result<()> {
    let t: Vec<f64> = id.history.iter().map(|h| h.t).collect();
    let cols: Vec<Vec<f64>> = (0..10)
        .map(|i| {
            id.history
                .iter()
                .map(|h| fields(&h.estimate.params)[i].1)
                .collect()
        })
        .collect();
    let mut header = vec!["t"];
    header.extend(fields(&id.raw.params).iter().map(|f| f.0));
    let mut columns: Vec<&[f64]> = vec![&t];
    columns.extend(cols.iter().map(|c| c.as_slice()));
    run.write(
        format!("{dir}/convergence.csv"),
        csv_columns(&header, &columns).as_bytes(),
    )?;
    // Stiffnesses normalized by their final estimate (or truth, when known).
    let mut fig = Figure::new(
        "Stage identification: convergence (Eq. 54-56)",
        "t [s]",
        "estimate / reference",
    );
    let reference = truth.map(fields).unwrap_or_else(|| fields(&id.raw.params));
    for i in 0..6 {
        let r = reference[i].1;
        let pts: Vec<(f64, f64)> = t
            .iter()
            .zip(&cols[i])
            .map(|(&t, &v)| (t, v / r))
            .filter(|(_, v)| v.is_finite() && (0.0..=2.0).contains(v))
            .collect();
        if !pts.is_empty() {
            fig = fig.with(Series::line(reference[i].0, pts));
        }
    }
    run.write(format!("{dir}/convergence.svg"), fig.to_svg()?.as_bytes())?;
    Ok(())
}
