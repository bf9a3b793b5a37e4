//! `flexstage run`: the paper's whole scheme on one scenario — design → export → reduce →
//! PEA identification → stage identification → tracking → report — in one run folder.
//!
//! Each stage reads what the previous one wrote in the run folder and calls the stage's own
//! subcommand function directly (no child processes). Finished stages are recorded in
//! `<run>/run_state.json` together with a fingerprint of the scenario, so running the same
//! command again resumes after the last finished stage (an interrupted design continues from
//! its checkpoint); a changed scenario or `--restart` starts over.
//!
//! The simulated experiments (stage identification and tracking) run on the *designed*
//! mechanism: after `reduce`, `plant.toml` is the recorded scenario with `stage.truth`
//! replaced by `reduce/params.toml`. The identification and the controller still start from
//! `stage.guess` (Table 4's guess), except for what the paper treats as known (Section 4.2:
//! the weighed mass M and α from Eq. 27), which comes from the design.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use clap::Args;
use flexstage_piezo::{
    BoucWenParams, CompensatorParams, LoopParams, WaveShape, Waveform, compensated_loop,
    steady_state_loop,
};
use flexstage_report::plot::{Figure, Series};
use flexstage_report::{RunDir, html, outline::Unit};
use flexstage_scenario::{Preset, Scenario, StageParams};
use serde::{Deserialize, Serialize};

use crate::scenario_args::ScenarioArgs;
use crate::{design, export, identify, identify_stage, pea, reduce, track};

/// Arguments of `flexstage run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// Scenario file (TOML). Without it, the built-in preset is used.
    pub scenario: Option<PathBuf>,
    /// Built-in scenario when no file is given: "quick" (coarse, about 10 s) or "paper"
    /// (Tables 1, 3, 4, A1).
    #[arg(long, default_value = "quick", value_parser = flexstage_scenario::Preset::NAMES)]
    pub preset: String,
    /// Run folder (default runs/<scenario name>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Run every stage again, ignoring finished ones.
    #[arg(long)]
    pub restart: bool,
}

/// The stages in order.
const STAGES: [&str; 7] = [
    "design",
    "export",
    "reduce",
    "pea",
    "identify-stage",
    "track",
    "report",
];

/// What `run_state.json` records.
#[derive(Debug, Default, Serialize, Deserialize)]
struct RunState {
    /// FNV-1a hash of the scenario TOML the stages ran with.
    scenario_hash: String,
    /// Finished stages, in order.
    finished: Vec<String>,
    /// Seconds each finished stage took.
    seconds: Vec<f64>,
}

fn fnv1a(text: &str) -> String {
    let mut h: u64 = 0xcbf29ce484222325;
    for b in text.bytes() {
        h ^= b as u64;
        h = h.wrapping_mul(0x100000001b3);
    }
    format!("{h:016x}")
}

fn save_state(run: &RunDir, state: &RunState) -> anyhow::Result<()> {
    run.write(
        "run_state.json",
        serde_json::to_string_pretty(state)?.as_bytes(),
    )?;
    Ok(())
}

/// Runs `flexstage run`.
pub fn run(args: RunArgs) -> anyhow::Result<()> {
    let t0 = Instant::now();
    let scenario = match &args.scenario {
        Some(p) => Scenario::load(p).context("invalid scenario")?,
        None => Scenario::preset(
            Preset::from_name(&args.preset)
                .with_context(|| format!("unknown preset {:?}", args.preset))?,
        ),
    };
    let root = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("runs").join(&scenario.name));
    let text = scenario.to_commented_toml();
    let hash = fnv1a(&text);
    let run = RunDir::create(&root).context("cannot create the run folder")?;
    let mut state: RunState = std::fs::read(run.path("run_state.json"))
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .unwrap_or_default();
    if args.restart || state.scenario_hash != hash {
        if !state.finished.is_empty() {
            eprintln!(
                "{}: starting over",
                if args.restart {
                    "--restart"
                } else {
                    "the scenario changed"
                }
            );
        }
        state = RunState {
            scenario_hash: hash,
            ..RunState::default()
        };
        save_state(&run, &state)?;
    } else if !state.finished.is_empty() {
        eprintln!(
            "resuming {}: finished {}",
            root.display(),
            state.finished.join(", ")
        );
    }
    run.write("scenario.toml", text.as_bytes())?;
    // Every stage reads the scenario exactly as recorded in the run folder.
    let scen = || ScenarioArgs {
        scenario: Some(run.path("scenario.toml")),
        preset: "paper".into(),
    };
    let out = || Some(root.clone());
    for (k, &stage) in STAGES.iter().enumerate() {
        if state.finished.iter().any(|s| s == stage) {
            eprintln!(
                "[{}/{}] {stage}: done earlier, skipped",
                k + 1,
                STAGES.len()
            );
            continue;
        }
        eprintln!("[{}/{}] {stage} ...", k + 1, STAGES.len());
        let ts = Instant::now();
        match stage {
            "design" => {
                let resume = run.path("design/checkpoint.bin").is_file()
                    && !run.path("design/design.json").is_file();
                if resume {
                    eprintln!("  continuing the interrupted design from its checkpoint");
                }
                design::run(design::DesignArgs {
                    scenario: scen(),
                    out: if resume { None } else { out() },
                    resume: if resume { out() } else { None },
                    check_gradients: false,
                    checkpoint_every: 10,
                    snapshot_every: 25,
                    max_iterations: None,
                })?
            }
            "export" => {
                let s = export::execute(&scenario, &run, None, Unit::Millimetres, 0.5, 10)?;
                println!(
                    "outline: {} closed loop(s), {:.1} mm²; wrote {}",
                    s.loops,
                    s.area * 1e6,
                    run.path("export").display()
                );
            }
            "reduce" => reduce::run(reduce::ReduceArgs {
                scenario: scen(),
                design: Some(root.display().to_string()),
                out: out(),
                operating_point: None,
                modes: 6,
                lumped: false,
                no_plate_mass: false,
                scales: "0.1,0.25,0.5,0.75,1".into(),
                keep_output_spring: false,
            })?,
            "pea" => {
                pea::run(pea::PeaCommand::Simulate(pea::SimulateArgs {
                    scenario: scen(),
                    pea: 1,
                    shape: "decaying".into(),
                    frequency: 1.0,
                    cycles: 10,
                    noise_nm: 10.0,
                    dt: None,
                    seed: None,
                    output: None,
                    out: out(),
                }))?;
                identify::run(identify::IdentifyCommand::Pea(identify::PeaArgs {
                    data: run.path("pea/pea1.csv"),
                    scenario: scen(),
                    pea: 1,
                    forgetting: 1.0,
                    passes: 1,
                    out: out(),
                }))?;
                compensation_figure(&scenario, &run)?;
            }
            "identify-stage" => identify::run(identify::IdentifyCommand::Stage(
                identify_stage::StageArgs {
                    data: None,
                    simulate: true,
                    scenario: plant(&scenario, &run)?,
                    duration: 4.0,
                    f_max: 150.0,
                    plant: "hysteretic".into(),
                    noise_free: false,
                    forgetting: 1.0,
                    prefilter: 300.0,
                    decimation: 1,
                    scheme: "numerov".into(),
                    no_coupling: false,
                    out: out(),
                },
            ))?,
            "track" => {
                let params = run.path("identify/stage/params.toml");
                track::run(track::TrackArgs {
                    scenario: plant(&scenario, &run)?,
                    trajectory: "all".into(),
                    variant: "all".into(),
                    compensation: "inverse".into(),
                    params: params.is_file().then_some(params),
                    duration: None,
                    out: out(),
                })?
            }
            "report" => {
                let html = html::build_report(run.root());
                run.write("report.html", html.as_bytes())?;
            }
            _ => unreachable!("unknown stage {stage}"),
        }
        let secs = ts.elapsed().as_secs_f64();
        eprintln!("[{}/{}] {stage}: done in {secs:.1} s", k + 1, STAGES.len());
        state.finished.push(stage.to_string());
        state.seconds.push(secs);
        save_state(&run, &state)?;
    }
    print_summary(&run, t0.elapsed().as_secs_f64());
    Ok(())
}

/// The scenario of the simulated stage: the recorded scenario with `stage.truth` replaced by
/// the reduced model of this run's design (`reduce/params.toml`), written to `plant.toml`.
fn plant(scenario: &Scenario, run: &RunDir) -> anyhow::Result<ScenarioArgs> {
    let path = run.path("reduce/params.toml");
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("cannot read {}", path.display()))?;
    let truth: StageParams = toml::from_str(&text)
        .with_context(|| format!("{}: not a stage parameter table", path.display()))?;
    let mut plant = scenario.clone();
    // The quantities the paper treats as known (Section 4.2: masses weighed, α from Eq. 27)
    // are known here from the design; the stiffnesses and dampings start from the guess.
    plant.stage.guess.mass = truth.mass;
    plant.stage.guess.alpha = truth.alpha;
    plant.stage.truth = truth;
    plant
        .validate()
        .context("the reduced model of the design is not a valid simulated stage")?;
    Ok(ScenarioArgs {
        scenario: Some(run.write("plant.toml", plant.to_commented_toml().as_bytes())?),
        preset: "paper".into(),
    })
}

fn print_summary(run: &RunDir, seconds: f64) {
    println!();
    println!(
        "== flexstage run: {} ({seconds:.1} s)",
        run.root().display()
    );
    for (k, v) in html::summary_rows(run.root()) {
        println!("  {k:<48} {v}");
    }
    if let Ok(text) = std::fs::read_to_string(run.path("identify/stage/table.csv")) {
        println!("  identified stage parameters (estimate vs truth):");
        for l in text.lines().skip(1) {
            let c: Vec<&str> = l.split(',').collect();
            if c.len() >= 6 && !c[4].is_empty() {
                let f = |s: &str| s.parse::<f64>().map(html::fmt_num).unwrap_or_default();
                println!(
                    "    {:<8} {:>12} vs {:>12} {:<6} ({:>6} %)",
                    c[0],
                    f(c[3]),
                    f(c[4]),
                    c[1],
                    f(c[5])
                );
            }
        }
    }
    println!("report: {}", report_path(run.root()).display());
}

fn report_path(root: &Path) -> PathBuf {
    let p = root.join("report.html");
    std::fs::canonicalize(&p).unwrap_or(p)
}

/// Hysteresis before and after inverse compensation (Section 3.3, Eq. 21): the scenario's PEA
/// driven by a plain 1 Hz voltage sine (displacement against the nominal d_p·U), and the same
/// PEA behind the compensator built on the *identified* parameters (displacement against the
/// desired one). Writes `identify/pea/compensation.{svg,csv}`.
fn compensation_figure(s: &Scenario, run: &RunDir) -> anyhow::Result<()> {
    let truth = BoucWenParams::from(&s.hysteresis.pea1);
    let text = std::fs::read_to_string(run.path("identify/pea/estimates.toml"))
        .context("identify/pea/estimates.toml missing")?;
    let table: toml::Table = text.parse().context("identify/pea/estimates.toml")?;
    let est = table
        .get("recommended_params")
        .cloned()
        .context("estimates.toml has no [recommended_params]")?;
    let model: BoucWenParams = est.try_into().context("[recommended_params]")?;
    let (lo, hi) = (s.hysteresis.voltage_min, s.hysteresis.voltage_max);
    let dt = s.simulation.sample_time;
    let sine = Waveform {
        shape: WaveShape::Sine,
        low: lo,
        high: hi,
        frequency: 1.0,
        cycles: 1,
    };
    let before = steady_state_loop(
        &truth,
        |t| sine.value(t),
        1.0,
        LoopParams {
            dt,
            ..LoopParams::default()
        },
    )?;
    let nominal: Vec<f64> = before.input.iter().map(|u| truth.d_p * u).collect();
    let desired = Waveform {
        low: truth.d_p * lo + 0.05 * truth.d_p * (hi - lo),
        high: truth.d_p * hi - 0.05 * truth.d_p * (hi - lo),
        ..sine
    };
    let after = compensated_loop(
        &truth,
        &model,
        CompensatorParams {
            u_min: lo,
            u_max: hi,
            ..CompensatorParams::default()
        },
        &desired,
        3,
        dt,
    )?;
    let fig = Figure::new(
        "PEA1: hysteresis without and with inverse compensation",
        "nominal d_p·U / desired displacement [µm]",
        "actuator displacement [µm]",
    )
    .with(Series::line(
        "without compensation",
        nominal
            .iter()
            .copied()
            .zip(before.output.iter().copied())
            .collect(),
    ))
    .with(Series::line(
        "with compensation (identified model)",
        after
            .x_desired
            .iter()
            .copied()
            .zip(after.x.iter().copied())
            .collect(),
    ));
    run.write("identify/pea/compensation.svg", fig.to_svg()?.as_bytes())?;
    let csv = flexstage_report::csv_columns(
        &[
            "nominal_um",
            "x_uncompensated_um",
            "x_desired_um",
            "x_compensated_um",
        ],
        &[&nominal, &before.output, &after.x_desired, &after.x],
    );
    run.write("identify/pea/compensation.csv", csv.as_bytes())?;
    println!(
        "compensation: loop width {:.2} % → {:.3} % of the range, max error {:.3} µm",
        flexstage_piezo::loop_metrics(&nominal, &before.output)
            .map(|m| m.width_pct)
            .unwrap_or(f64::NAN),
        after.metrics.width_pct,
        after.max_error
    );
    Ok(())
}
