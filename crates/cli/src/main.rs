//! The `flexstage` command-line tool: parses arguments, calls `flexstage_pipeline`, prints.
//!
//! Every command uses the same default scenario (the `quick` preset) and writes into the run
//! folder of its scenario, `runs/<scenario name>/` unless `--out` says otherwise. Errors are
//! printed once, each cause once, with a non-zero exit status; never a backtrace.

// Doc comments of the argument structs are clap's --help text ("[Hz]", "<run>"), not rustdoc.
#![allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)]

#[macro_use]
mod out;
mod args;
mod bars;
mod print;
mod stages;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
use flexstage_pipeline::{
    DEFAULT_PRESET, PRESETS, RunFolder, RunOptions, Scenario, TrackOptions, default_root,
    default_run,
};

use anyhow::Context;
use args::ScenarioArgs;

/// flexstage: design, reduce, identify and control a piezo-driven compliant positioning stage.
#[derive(Debug, Parser)]
#[command(name = "flexstage", version, about, long_about = None)]
#[command(
    after_help = "Start with `flexstage run` (the whole scheme on the quick preset), or \
`flexstage init` for a scenario file to edit.
Every command uses the quick preset unless given a scenario file or --preset paper, and writes \
into runs/<scenario name>/ unless given --out. Each subcommand's --help shows examples."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Write a built-in scenario as a commented TOML file.
    #[command(after_help = "Examples:
  flexstage init                          # scenario.toml, quick preset
  flexstage init paper.toml --preset paper
  flexstage init -                        # print to standard output")]
    Init {
        /// Where to write ("-" for standard output).
        #[arg(default_value = flexstage_run::layout::SCENARIO)]
        path: PathBuf,
        /// Built-in scenario: "quick" (coarse and fast) or "paper" (Tables 1, 3, 4, A1).
        #[arg(long, default_value = DEFAULT_PRESET, value_parser = PRESETS)]
        preset: String,
        /// Overwrite an existing file.
        #[arg(long)]
        force: bool,
    },
    /// Parse and validate a scenario, and print a summary.
    #[command(after_help = "Examples:
  flexstage check scenario.toml
  flexstage check --preset paper")]
    Check(ScenarioArgs),
    /// Nonlinear statics of a design: output displacements, workspace polygon and area, VTK.
    #[command(
        after_help = "Analyses the run's finished design (the uniform start design if \
there is none; --design picks another). Each analysis has its own folder:
<run>/analyze/workspace/ (the p_m samples), <run>/analyze/inputs_30_-30/ (--inputs 30,-30),
<run>/analyze/uniform_workspace/ (--design uniform), ...; the same analysis again replaces it.

Examples:
  flexstage analyze                              # workspace of runs/quick's design
  flexstage analyze --inputs 30,-30              # one input pair (µm)
  flexstage analyze --design uniform"
    )]
    Analyze(stages::AnalyzeArgs),
    /// Workspace topology optimization (Section 2.2, Algorithm 1): density, polygons, history.
    #[command(
        after_help = "Writes <run>/design/. A finished or interrupted design is not \
replaced unless --force.

Examples:
  flexstage design                          # quick preset, about 2 s; runs/quick/design
  flexstage design --preset paper           # the paper's 120 x 60, p_m = 40 problem
  flexstage design --resume runs/quick      # continue after an interruption
  flexstage design --check-gradients        # adjoint vs central differences"
    )]
    Design(stages::DesignArgs),
    /// Reduced spring-mass model of a design (Section 3.2.1): transfer matrix, lumped
    /// parameters, natural frequencies, validity of the tangent model.
    #[command(
        after_help = "Writes <run>/reduce/. Its params.toml is the run's simulated stage \
from then on (identify stage, track).

Examples:
  flexstage reduce                                     # the run's design
  flexstage reduce --modes 10 --scales 0.5,1
  flexstage reduce --operating-point 30,-30 --scales \"\"  # tangent at a stroke, no map"
    )]
    Reduce(stages::ReduceArgs),
    /// Identify model parameters from measured or simulated records.
    #[command(after_help = "Examples:
  flexstage identify pea
  flexstage identify stage")]
    Identify {
        #[command(subcommand)]
        what: stages::IdentifyCommand,
    },
    /// The piezo actuator model (Bouc–Wen hysteresis) on its own.
    Pea {
        #[command(subcommand)]
        what: stages::PeaCommand,
    },
    /// Simulated tracking experiment (Section 4, Figures 9-11): controllers on the run's stage.
    #[command(
        after_help = "Runs each trajectory of the scenario with each controller on the \
run's simulated stage: the designed mechanism once `flexstage reduce` has run, else the \
scenario's stage.truth (Table 4), with Bouc-Wen PEAs, cross terms and sensor noise. The \
controller's model is --params FILE, else the run's identified parameters, else stage.guess; \
the output says which. Writes <run>/track/ (per run a CSV and an error plot, Figures 9-10; per \
trajectory the 2D paths, Figure 11; metrics.csv). Other conditions get their own folder: \
track/compensation-off/, track/params-reduce/, track/duration-0.5s/, ...

Examples:
  flexstage track                                   # all trajectories, all controllers
  flexstage track --trajectory lissajous-3 --variant robust
  flexstage track --compensation off                # into runs/quick/track/compensation-off
  flexstage track --params runs/quick/reduce/params.toml"
    )]
    Track(stages::TrackArgs),
    /// Manufacturing outline of a design (Section 4.1): the ρ = 0.5 iso-contour as DXF and
    /// SVG closed polylines, and a binary STL extruded by the thickness t; then its
    /// verification: body-fitted stress, α and first frequency beside the design mesh's,
    /// manufacturability findings and the verdict.
    #[command(
        after_help = "Writes <run>/export/outline.dxf (R2000 LWPOLYLINE), outline.svg, \
outline.stl, verification.json, verification.txt and body_fitted.vtu (ParaView). The last \
line printed is the verdict: \"safe\" only when the peak von Mises stress of the body-fitted \
model (re-checked on a mesh of half the size) is within fatigue strength / safety factor and \
no manufacturability error remains; otherwise \"NOT safe\" with the reasons. With \
--require-safe a design that is not verified safe exits with status 2.

Examples:
  flexstage export                    # the design of runs/quick, millimetres
  flexstage export --units m
  flexstage export --smoothing 0      # the raw marching-squares polygon
  flexstage export --safety-factor 2 --require-safe   # gate a script on the verdict"
    )]
    Export(stages::ExportArgs),
    /// The workspace–first-resonance front: designs from the workspace design to a
    /// first-frequency bound `--max-ratio` times its resonance (warm-started continuation),
    /// each verified (body-fitted frequency and stress), its twin built and its controllers'
    /// tracking error measured at the scan speed you name; picks the design.
    #[command(
        after_help = "Writes <run>/front/: front.svg (workspace against first resonance, each \
design's tracking error at --scan-hz in the legend), front.csv, front.json, and per design \
d<k>/design.json (usable as --design for analyze, export, reduce), outline.svg, modes.vtu. \
The controllers are designed on each design's twin as `track` designs them. The paper preset \
takes about 7 minutes on two quiet cores (12 CPU-minutes).

Examples:
  flexstage front                               # quick preset, 5 designs, 250 Hz scan
  flexstage front --preset paper --scan-hz 400 --max-error-pct 0.5
  flexstage front --designs 7 --max-ratio 2"
    )]
    Front(stages::FrontArgs),
    /// The whole scheme on one scenario: design, outline export, reduce, PEA and stage
    /// identification on simulated data, tracking with every controller, and an HTML report.
    #[command(
        after_help = "Each stage feeds the next through files in the run folder; the \
same command again resumes after the last finished stage (run_state.json). Ends with a \
summary and the path of <run>/report.html (self-contained, opens offline).

Examples:
  flexstage run                      # quick preset, runs/quick, about half a minute
  flexstage run --preset paper       # the paper's settings (Tables 1, 3, 4, A1)
  flexstage run my.toml --out runs/mine --restart"
    )]
    Run(RunArgs),
    /// A tuned controller for a real-time target: its C99 source and header from its
    /// coefficients file (written by `track` as <run>/track/controllers/<controller>.json).
    #[command(
        after_help = "`track` already writes every controller it ran (PI + notch, PIDs with their \
FIR feed-forward, PPF, the robust and non-robust backstepping; with --learning also with the \
learned table) as <controller>.json, .c and .h in <run>/track/controllers/ (or the conditions' \
folder). This command writes the C of one coefficients file again, e.g. after editing a gain, \
or into a firmware tree: <DIR>/<controller>.c and .h, C99 with <math.h> only, functions \
<controller>_init, _prime and _step (other characters as _; the backstepping's step takes the \
reference's first three derivatives, and _reference_time says when). \
docs/controller-export.md says how to call them at 10 kHz.

With --response or --log it designs every controller (PI + notch, PID, PPF, the backstepping sized on the measured loop model) from a measured loop alone, no design or twin: a measured response or a time log of your stage at the controller's sample time (formats in docs/formats.md). With --lifted, the lifted response a fast ADC on the sensor's analog output recorded during the same experiments (as track writes lifted_response.csv), the feed-forward of the linear controllers is fitted to the output at the samples, as track fits it; without it to the sampled response (each JSON says which: feedforward.fitted_to). The actuator settings (the PEAs' hysteresis model for the inverse compensation, the stroke) come from --scenario FILE, or from --preset (default: paper). It writes <controller>.json, .c and .h of each.

Examples:
  flexstage controller runs/quick/track/controllers/pi-notch-ff.json
  flexstage controller runs/quick/track/controllers/pid-ff.json --to firmware/control
  flexstage controller --response measured.csv --to firmware/control
  flexstage controller --response measured_response.csv --lifted lifted_response.csv
  flexstage controller --log lab_log.csv --scenario my_stage.toml"
    )]
    Controller {
        /// The coefficients file (JSON).
        #[arg(required_unless_present_any = ["response", "log"], conflicts_with_all = ["response", "log"])]
        json: Option<PathBuf>,
        /// Design from a measured response (CSV: f, re/im per entry, coherence, std, sample_time).
        #[arg(long, conflicts_with = "log", group = "measurement")]
        response: Option<PathBuf>,
        /// Design from a time log (CSV: t, command1, command2, reading1, reading2), by H1.
        #[arg(long, group = "measurement")]
        log: Option<PathBuf>,
        /// With --response or --log: the lifted response of a fast ADC during the same
        /// experiments (CSV: f, phase, re/im per entry, coherence, sample_time, std), which
        /// the linear controllers' feed-forward is fitted to at the samples.
        #[arg(long, requires = "measurement")]
        lifted: Option<PathBuf>,
        /// Folder for the files (default: the folder of the input file).
        #[arg(long)]
        to: Option<PathBuf>,
        /// With --response or --log: the scenario (TOML) whose actuator settings the
        /// controllers use.
        #[arg(long, requires = "measurement")]
        scenario: Option<PathBuf>,
        /// With --response or --log and no --scenario: the built-in scenario whose actuator
        /// settings the controllers use.
        #[arg(long, default_value = "paper", value_parser = PRESETS, requires = "measurement")]
        preset: String,
    },
    /// Rebuild <run>/report.html from a run folder (stages not run are marked "not run").
    #[command(after_help = "Examples:
  flexstage report                 # runs/quick
  flexstage report runs/paper")]
    Report {
        /// The run folder.
        #[arg(default_value_os_t = default_run())]
        run: PathBuf,
    },
}

/// Arguments of `flexstage run`.
#[derive(Debug, Args)]
struct RunArgs {
    #[command(flatten)]
    scenario: ScenarioArgs,
    /// Run folder (default runs/<scenario name>).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Run every stage again, ignoring finished ones.
    #[arg(long)]
    restart: bool,
    /// Perturbed twins of the tracking stage's Monte-Carlo study (each one measured and every
    /// controller designed from that measurement, then run on it), 1..=10000.
    #[arg(long, default_value_t = TrackOptions::default().montecarlo_plants)]
    montecarlo_plants: usize,
}

fn main() -> ExitCode {
    let command = Cli::parse().command;
    bars::plain_when_not_a_terminal(command.name());
    let result = dispatch(command);
    // A reader that went away (`| head`) ends the printing, never the command.
    let stdout_failure = out::finish();
    match (result, stdout_failure) {
        (Ok(()), None) => ExitCode::SUCCESS,
        (Ok(()), Some(e)) => {
            errln!(
                "error: cannot write standard output ({e}); printing stopped there, the command \
                 itself ran to its end"
            );
            ExitCode::FAILURE
        }
        (Err(e), _) => {
            errln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

impl Command {
    /// The subcommand's name, for progress lines.
    fn name(&self) -> &'static str {
        match self {
            Command::Init { .. } => "init",
            Command::Check(_) => "check",
            Command::Analyze(_) => "analyze",
            Command::Design(_) => "design",
            Command::Reduce(_) => "reduce",
            Command::Identify { .. } => "identify",
            Command::Pea { .. } => "pea",
            Command::Track(_) => "track",
            Command::Export(_) => "export",
            Command::Front(_) => "front",
            Command::Run(_) => "run",
            Command::Controller { .. } => "controller",
            Command::Report { .. } => "report",
        }
    }
}

fn dispatch(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Init {
            path,
            preset,
            force,
        } => init(&path, &preset, force),
        Command::Check(scenario) => check(&scenario),
        Command::Analyze(a) => stages::analyze(a),
        Command::Design(a) => stages::design(a),
        Command::Reduce(a) => stages::reduce(a),
        Command::Identify { what } => stages::identify(what),
        Command::Pea { what } => stages::pea(what),
        Command::Track(a) => stages::track(a),
        Command::Export(a) => stages::export(a),
        Command::Front(a) => stages::front(a),
        Command::Run(a) => run(a),
        Command::Controller {
            json,
            response,
            log,
            lifted,
            to,
            scenario,
            preset,
        } => {
            use flexstage_pipeline::Measurement;
            let (input, measured) = match (&json, &response, &log) {
                (_, Some(r), _) => (r.clone(), Some(Measurement::Response(r))),
                (_, _, Some(l)) => (l.clone(), Some(Measurement::Log(l))),
                (Some(j), _, _) => (j.clone(), None),
                _ => anyhow::bail!("give a coefficients file, --response or --log"),
            };
            let dir = match to {
                Some(d) => d,
                None => input
                    .parent()
                    .map(std::path::Path::to_path_buf)
                    .unwrap_or_default(),
            };
            let written = match measured {
                Some(m) => {
                    let scenario = flexstage_pipeline::load_scenario(scenario.as_deref(), &preset)
                        .context("invalid scenario")?;
                    let written =
                        flexstage_pipeline::export_measured(m, lifted.as_deref(), &scenario, &dir)?;
                    outln!(
                        "feed-forward of the linear controllers fitted to {}",
                        match &lifted {
                            Some(l) =>
                                format!("the lifted response at the samples ({})", l.display()),
                            None => "the sampled response (no --lifted)".to_string(),
                        }
                    );
                    written
                }
                None => vec![flexstage_pipeline::export_controller(&input, &dir)?],
            };
            for e in written {
                outln!(
                    "{}: {} and {}",
                    e.controller,
                    e.source.display(),
                    e.header.display()
                );
            }
            Ok(())
        }
        Command::Report { run } => {
            anyhow::ensure!(run.is_dir(), "{} is not a run folder", run.display());
            let folder = args::opened(RunFolder::existing(&run)?);
            outln!(
                "report: {}",
                flexstage_pipeline::write_report(&folder)?.display()
            );
            Ok(())
        }
    }
}

fn init(path: &std::path::Path, name: &str, force: bool) -> anyhow::Result<()> {
    let text = flexstage_pipeline::folder::preset(name)?.to_commented_toml();
    if path.as_os_str() == "-" {
        out!("{text}");
        return Ok(());
    }
    if path.exists() && !force {
        let path = path.to_path_buf();
        return Err(flexstage_run::RunError::Exists { path }.into());
    }
    flexstage_run::write_atomic(path, text.as_bytes())?;
    errln!("wrote {}", path.display());
    Ok(())
}

fn check(scenario: &ScenarioArgs) -> anyhow::Result<()> {
    let s: Scenario = scenario.load()?;
    flexstage_pipeline::design::check_problem(&s).context("invalid scenario")?;
    outln!("{}: valid", scenario.describe());
    let e = flexstage_pipeline::DesignEstimate::of(&s);
    let estimate = format!(
        "design estimate: {:.2} GiB of memory (allocated at the peak, limit {:.0} GiB), {:.1e} \
         flop (limit {:.0e})",
        e.bytes / GIB,
        flexstage_pipeline::limit::DESIGN_BYTES / GIB,
        e.flops,
        flexstage_pipeline::limit::DESIGN_FLOPS
    );
    let mesh = format!(
        "mesh {} x {} elements over {} x {} mm",
        s.mesh.nl,
        s.mesh.nw,
        s.mesh.length * 1e3,
        s.mesh.width * 1e3
    );
    if !s.ports.is_empty() {
        // A general mechanism ([[ports]]): no PEAs, stroke samples or trajectories.
        let d = s.output.direction.unwrap_or_default();
        outln!(
            "  mechanism: {mesh}, {} input port(s), output along ({}, {}), up to {} iterations",
            s.ports.len(),
            d[0],
            d[1],
            s.optimization.max_iterations
        );
        outln!(
            "  {} supports, {} passive regions; design and export apply (run, reduce and the \
             control stages are for the two-PEA stage); run folder {}",
            s.supports.len(),
            s.regions.len(),
            default_root(&s).display()
        );
        outln!("  {estimate}");
        return Ok(());
    }
    outln!(
        "  {mesh}, p_m = {} samples, up to {} iterations",
        s.optimization.samples,
        s.optimization.max_iterations
    );
    outln!(
        "  {} supports, {} passive regions, {} trajectories; run folder {}",
        s.supports.len(),
        s.regions.len(),
        s.trajectories.len(),
        default_root(&s).display()
    );
    outln!("  {estimate}");
    Ok(())
}

const GIB: f64 = 1024.0 * 1024.0 * 1024.0;

fn run(a: RunArgs) -> anyhow::Result<()> {
    let s = a.scenario.load()?;
    let root = a.out.unwrap_or_else(|| default_root(&s));
    let options = RunOptions {
        restart: a.restart,
        track: TrackOptions {
            montecarlo_plants: a.montecarlo_plants,
            ..TrackOptions::default()
        },
        ..RunOptions::default()
    };
    let summary = flexstage_pipeline::run::run(s, &root, &options, &bars::Bars::default())?;
    out!("{summary}");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexstage_pipeline::{CONTROLLERS, Controller};

    /// Goal: the controllers of `track --variant` are the registry's, in its words: every
    /// registry entry is accepted by its name and selects exactly itself, `all` selects the
    /// defaults, and a name outside the registry is refused by the parser.
    #[test]
    fn every_registry_controller_is_a_track_variant() {
        let variant = |name: &str| -> Vec<&'static Controller> {
            match Cli::try_parse_from(["flexstage", "track", "--variant", name]) {
                Ok(Cli {
                    command: Command::Track(a),
                }) => args::controllers(&a.variant),
                other => panic!("{name}: {other:?}"),
            }
        };
        for &c in &CONTROLLERS {
            assert_eq!(variant(c.name), vec![c]);
        }
        assert_eq!(variant("all"), Controller::defaults());
        assert!(Cli::try_parse_from(["flexstage", "track", "--variant", "pid"]).is_err());
    }
}
