//! The `flexstage` command-line tool: a thin layer over the stage crates.
//!
//! Errors are printed as one message (with its causes) and a non-zero exit status; never a
//! backtrace.

mod analyze;
mod build;
mod design;
mod export;
mod identify;
mod identify_stage;
mod pea;
mod reduce;
mod report;
mod run;
mod run_dir;
mod scenario_args;
mod track;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use scenario_args::ScenarioArgs;

/// flexstage: design, reduce, identify and control a piezo-driven compliant positioning stage.
#[derive(Debug, Parser)]
#[command(name = "flexstage", version, about, long_about = None)]
#[command(
    after_help = "Start with `flexstage init` to get the paper's scenario as an annotated \
                        TOML file.\nEach subcommand's --help shows an example."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Write a built-in scenario as a commented TOML file.
    #[command(after_help = "Examples:
  flexstage init                          # scenario.toml, paper preset
  flexstage init my.toml --preset quick   # the coarse, fast preset
  flexstage init -                        # print to standard output")]
    Init {
        /// Where to write ("-" for standard output).
        #[arg(default_value = "scenario.toml")]
        path: PathBuf,
        /// Built-in scenario: "paper" (Tables 1, 3, 4, A1) or "quick" (coarse and fast).
        #[arg(long, default_value = "paper", value_parser = flexstage_scenario::Preset::NAMES)]
        preset: String,
        /// Overwrite an existing file.
        #[arg(long)]
        force: bool,
    },
    /// Parse and validate a scenario, and print a summary.
    #[command(after_help = "Examples:
  flexstage check scenario.toml
  flexstage check --preset quick")]
    Check {
        #[command(flatten)]
        scenario: ScenarioArgs,
    },
    /// Nonlinear statics of a design: output displacements, workspace polygon and area, VTK.
    #[command(after_help = "Examples:
  flexstage analyze --preset quick                          # uniform design, p_m workspace samples
  flexstage analyze --design runs/paper --inputs 30,-30     # a finished design, one input pair (µm)
  flexstage analyze my.toml --design density.png --out runs/check")]
    Analyze(analyze::AnalyzeArgs),
    /// Workspace topology optimization (Section 2.2, Algorithm 1): density, polygons, history.
    #[command(after_help = "Examples:
  flexstage design --preset quick                 # about 10 s; results in runs/quick/design
  flexstage design                                # the paper's 120 x 60, p_m = 40 problem
  flexstage design --resume runs/paper            # continue after an interruption
  flexstage design --check-gradients              # adjoint vs central differences")]
    Design(design::DesignArgs),
    /// Reduced spring-mass model of a design (Section 3.2.1): transfer matrix, lumped
    /// parameters for `track --params`, natural frequencies, validity of the tangent model.
    #[command(after_help = "Examples:
  flexstage reduce --preset quick                       # the run's design (or uniform)
  flexstage reduce --design runs/paper --modes 10       # a finished design
  flexstage reduce --operating-point 30,-30 --scales \"\"  # tangent at a stroke, no validity map")]
    Reduce(reduce::ReduceArgs),
    /// Identify model parameters from measured or simulated records.
    #[command(after_help = "Examples:
  flexstage identify pea --data pea1.csv
  flexstage identify stage --simulate")]
    Identify {
        #[command(subcommand)]
        what: identify::IdentifyCommand,
    },
    /// The piezo actuator model (Bouc–Wen hysteresis) on its own.
    #[command(after_help = "Examples:
  flexstage pea simulate --noise-nm 10 --output pea1.csv")]
    Pea {
        #[command(subcommand)]
        what: pea::PeaCommand,
    },
    /// Simulated tracking experiment (Section 4, Figures 9-11): controllers on the digital twin.
    #[command(
        after_help = "Runs each trajectory of the scenario with each controller variant on the
simulated stage (Table 4 estimates, Bouc-Wen PEAs, cross terms, sensor noise) and writes
<run>/track/<trajectory>_<variant>.csv (reference, measured, true, error, voltages, estimates),
<trajectory>_<variant>_error.svg (Figures 9-10), <trajectory>_2d.svg (Figure 11) and
metrics.csv; prints the metrics table.

Examples:
  flexstage track                                   # all trajectories, all variants
  flexstage track --trajectory lissajous-3 --variant robust
  flexstage track --compensation off                # hysteresis compensation switched off
  flexstage track --params stage.toml --duration 0.5 --out runs/test"
    )]
    Track(track::TrackArgs),
    /// Manufacturing outline of a design (Section 4.1): the ρ = 0.5 iso-contour as DXF and
    /// SVG closed polylines, and a binary STL extruded by the thickness t.
    #[command(
        after_help = "Writes <run>/export/outline.dxf (R2000 LWPOLYLINE), outline.svg and
outline.stl.

Examples:
  flexstage export --preset quick                 # the design of runs/quick, millimetres
  flexstage export --design runs/paper --units m  # metres
  flexstage export --smoothing 0                  # the raw marching-squares polygon"
    )]
    Export(export::ExportArgs),
    /// The whole scheme on one scenario: design, outline export, reduce, PEA and stage
    /// identification on simulated data, tracking with every controller, and an HTML report.
    #[command(
        after_help = "Each stage feeds the next through files in the run folder; running
the same command again resumes after the last finished stage (run_state.json).
Ends with a summary and the path of <run>/report.html (self-contained, opens offline).

Examples:
  flexstage run                      # quick preset, runs/quick, well under a minute
  flexstage run --preset paper       # the paper's settings (Tables 1, 3, 4, A1)
  flexstage run my.toml --out runs/mine --restart"
    )]
    Run(run::RunArgs),
    /// Rebuild <run>/report.html from a run folder (partial runs show \"not run\").
    #[command(after_help = "Examples:
  flexstage report runs/quick")]
    Report(report::ReportArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Init {
            path,
            preset,
            force,
        } => init(&path, &preset, force),
        Command::Check { scenario } => {
            let s = scenario.load()?;
            println!("{}: valid", scenario.describe());
            println!(
                "  mesh {} x {} elements over {} x {} mm, p_m = {} samples, up to {} iterations",
                s.mesh.nl,
                s.mesh.nw,
                s.mesh.length * 1e3,
                s.mesh.width * 1e3,
                s.optimization.samples,
                s.optimization.max_iterations
            );
            println!(
                "  {} supports, {} passive regions, {} trajectories",
                s.supports.len(),
                s.regions.len(),
                s.trajectories.len()
            );
            Ok(())
        }
        Command::Analyze(args) => analyze::run(args),
        Command::Design(args) => design::run(args),
        Command::Reduce(args) => reduce::run(args),
        Command::Identify { what } => identify::run(what),
        Command::Pea { what } => pea::run(what),
        Command::Track(args) => track::run(args),
        Command::Export(args) => export::run(args),
        Command::Run(args) => run::run(args),
        Command::Report(args) => report::run(args),
    }
}

fn init(path: &std::path::Path, preset: &str, force: bool) -> anyhow::Result<()> {
    let preset = flexstage_scenario::Preset::from_name(preset).ok_or_else(|| {
        anyhow::anyhow!("unknown preset {preset:?}: expected paper, quick or fine")
    })?;
    let text = flexstage_scenario::Scenario::preset(preset).to_commented_toml();
    if path.as_os_str() == "-" {
        print!("{text}");
        return Ok(());
    }
    if path.exists() && !force {
        return Err(flexstage_report::ReportError::Exists {
            path: path.to_path_buf(),
        }
        .into());
    }
    flexstage_report::write_atomic(path, text.as_bytes())?;
    eprintln!("wrote {}", path.display());
    Ok(())
}
