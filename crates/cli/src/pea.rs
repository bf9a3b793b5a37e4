//! `flexstage pea ...`: the piezo actuator model on its own.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Subcommand};
use flexstage_piezo::{
    BoucWenParams, LoopParams, WaveShape, Waveform, loop_metrics, steady_state_loop, synthesize,
};
use flexstage_report::plot::{Figure, Series};

use crate::run_dir::open_run;
use crate::scenario_args::ScenarioArgs;

/// PEA subcommands.
#[derive(Debug, Subcommand)]
pub enum PeaCommand {
    /// Simulate a PEA (Bouc–Wen, Eq. 18) and write a synthetic record t, U, x.
    #[command(
        after_help = "Parameters come from the scenario's hysteresis table (Table A1, µm, V, s),
the voltage range from hysteresis.voltage_min/max, the sample time and seed from
simulation. The record starts from a virgin actuator (U = 0, h = 0). Noise is white
Gaussian on x.
Writes <run>/pea/pea<N>.csv and pea<N>_loop.svg, or only --output FILE.csv.

Examples:
  flexstage pea simulate                              # PEA1, decaying 1 Hz sine, 10 s
  flexstage pea simulate --noise-nm 10 --output pea1.csv
  flexstage pea simulate --pea 2 --shape triangle --frequency 5 --cycles 3
  flexstage pea simulate my.toml --out runs/test"
    )]
    Simulate(SimulateArgs),
}

/// Options of `pea simulate`.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    #[command(flatten)]
    pub scenario: ScenarioArgs,
    /// Which PEA of the scenario (1 or 2).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=2))]
    pub pea: u8,
    /// Drive shape: "sine", "triangle", or "decaying" (sine with an amplitude decaying from
    /// 100 % to 30 %: nested minor loops, good for identification).
    #[arg(long, default_value = "decaying", value_parser = ["sine", "triangle", "decaying"])]
    pub shape: String,
    /// Drive frequency [Hz].
    #[arg(long, default_value_t = 1.0)]
    pub frequency: f64,
    /// Number of periods.
    #[arg(long, default_value_t = 10)]
    pub cycles: u32,
    /// Standard deviation of the sensor noise added to x [nm].
    #[arg(long, default_value_t = 0.0)]
    pub noise_nm: f64,
    /// Sample time [s] (default: the scenario's simulation.sample_time).
    #[arg(long)]
    pub dt: Option<f64>,
    /// Noise seed (default: the scenario's simulation.seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Write only this CSV file instead of the run folder.
    #[arg(long)]
    pub output: Option<PathBuf>,
    /// Run folder (default runs/<scenario name>).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Dispatches `pea ...`.
pub fn run(cmd: PeaCommand) -> anyhow::Result<()> {
    match cmd {
        PeaCommand::Simulate(args) => simulate(args),
    }
}

fn simulate(args: SimulateArgs) -> anyhow::Result<()> {
    let scenario = args.scenario.load()?;
    let hyst = &scenario.hysteresis;
    let params = BoucWenParams::from(if args.pea == 1 {
        &hyst.pea1
    } else {
        &hyst.pea2
    });
    let wave = Waveform {
        shape: WaveShape::from_name(&args.shape).context("unknown --shape")?,
        low: hyst.voltage_min,
        high: hyst.voltage_max,
        frequency: args.frequency,
        cycles: args.cycles,
    };
    let dt = args.dt.unwrap_or(scenario.simulation.sample_time);
    let seed = args.seed.unwrap_or(scenario.simulation.seed);
    let data = synthesize(&params, &wave, dt, args.noise_nm * 1e-3, seed)
        .context("invalid simulation settings (--frequency, --cycles, --dt, --noise-nm)")?;
    let name = format!("pea{}", args.pea);

    // Steady-state loop of a plain sine over the full range, for the summary.
    let sine = Waveform {
        shape: WaveShape::Sine,
        cycles: 1,
        ..wave
    };
    let steady = steady_state_loop(
        &params,
        |t| sine.value(t),
        1.0 / args.frequency,
        LoopParams {
            dt,
            ..LoopParams::default()
        },
    )?;
    let m = loop_metrics(&steady.input, &steady.output)?;
    println!(
        "{name}: {} samples over {} s; steady {} V sine loop at {} Hz: stroke {:.2} µm, width {:.2} % of range, max deviation from linear {:.2} %",
        data.len(),
        wave.duration(),
        hyst.voltage_max - hyst.voltage_min,
        args.frequency,
        m.range,
        m.width_pct,
        m.max_deviation_pct
    );

    let csv = data.to_csv();
    if let Some(path) = args.output {
        flexstage_report::write_atomic(&path, csv.as_bytes())?;
        eprintln!("wrote {}", path.display());
        return Ok(());
    }
    let run = open_run(args.out, &scenario)?;
    run.write(format!("pea/{name}.csv"), csv.as_bytes())?;
    let points = data
        .u()
        .iter()
        .copied()
        .zip(data.x().iter().copied())
        .collect();
    let fig = Figure::new(
        format!("{name}: simulated record ({} drive)", args.shape),
        "U [V]",
        "x [µm]",
    )
    .with(Series::line("x(U)", points));
    run.write(format!("pea/{name}_loop.svg"), fig.to_svg()?.as_bytes())?;
    eprintln!("wrote {}", run.path("pea").display());
    Ok(())
}
