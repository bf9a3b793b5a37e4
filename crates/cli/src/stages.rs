//! The subcommands that produce results: arguments (defaults from the pipeline's options)
//! and the calls into `flexstage_pipeline`.

use std::path::PathBuf;

use clap::{Args, Subcommand};
use flexstage_pipeline::names::{self, COMPENSATIONS, SCHEMES, SHAPES, UNITS, name, parse};
use flexstage_pipeline::{
    AnalyzeOptions, DesignOptions, DesignSource, DesignStart, ExportOptions, FrontOptions,
    LimitOverrides, PeaIdOptions, PeaOptions, ReduceOptions, RunFolder, Simulation, StageData,
    StageIdOptions, TrackOptions, TwinOptions, VerifyParams,
};

/// The simulated actuators of `identify stage`: index 1 is the linear one.
const ACTUATORS: [&str; 2] = ["hysteretic", "linear"];

use crate::args::{
    ALL_VARIANTS, List, Pair, TRACK_PLANTS, TWIN_VALIDATIONS, Target, controllers, plant,
    twin_validation, variants,
};
use crate::bars::Bars;
use crate::print;

/// Arguments of `flexstage design`.
#[derive(Debug, Args)]
pub struct DesignArgs {
    #[command(flatten)]
    pub target: Target,
    /// Continue the interrupted design of RUN_DIR from its checkpoint (with RUN_DIR's
    /// recorded scenario).
    #[arg(long, value_name = "RUN_DIR", conflicts_with = "out")]
    pub resume: Option<PathBuf>,
    /// Compare adjoint gradients with central differences on a small nonlinear mesh
    /// (additive material on) and exit.
    #[arg(long)]
    pub check_gradients: bool,
    /// Save a checkpoint every N iterations.
    #[arg(long, value_name = "N", default_value_t = DesignOptions::default().checkpoint_every)]
    pub checkpoint_every: usize,
    /// Save the workspace polygon every N iterations (and at 0 and the end).
    #[arg(long, value_name = "N", default_value_t = DesignOptions::default().snapshot_every)]
    pub snapshot_every: usize,
    /// Override optimization.max_iterations.
    #[arg(long, value_name = "N")]
    pub max_iterations: Option<usize>,
}

pub fn design(a: DesignArgs) -> anyhow::Result<()> {
    if a.check_gradients {
        let r = flexstage_pipeline::gradient_check(&a.target.scenario.load()?)?;
        outln!("gradient check: {}", r.setup);
        for c in &r.checks {
            let ok = flexstage_pipeline::design::passed(c);
            outln!(
                "  {:<14} relative error {:.2e} over {} variables (max |grad| {:.3e})  {}",
                c.name,
                c.relative_error,
                c.checked,
                c.scale,
                if ok { "ok" } else { "FAIL" }
            );
        }
        return Ok(r.verdict()?);
    }
    let force = a.target.force;
    let (folder, start) = match &a.resume {
        Some(dir) => (
            crate::args::opened(RunFolder::existing(dir)?),
            DesignStart::Resume,
        ),
        None => (a.target.open()?, DesignStart::Fresh { force }),
    };
    let options = DesignOptions {
        checkpoint_every: a.checkpoint_every,
        snapshot_every: a.snapshot_every,
        max_iterations: a.max_iterations,
    };
    let s = flexstage_pipeline::design(&folder, &options, start, &Bars::default())?;
    print::summary(&s);
    Ok(())
}

/// Arguments of `flexstage analyze`.
#[derive(Debug, Args)]
pub struct AnalyzeArgs {
    #[command(flatten)]
    pub target: Target,
    /// The design: "run" (the run's), "uniform", "uniform:RHO", a density .csv/.png, a
    /// design.json or another run folder. Default: the run's design if it has a finished
    /// one, else the uniform start design.
    #[arg(long)]
    pub design: Option<String>,
    /// Actuator input pair "X1,X2" in µm (nominal strokes of PEA1 and PEA2); repeat for
    /// more cases. Without it, the p_m samples of the stroke-square perimeter are analysed.
    #[arg(long = "inputs", value_name = "X1,X2")]
    pub inputs: Vec<Pair>,
}

pub fn analyze(a: AnalyzeArgs) -> anyhow::Result<()> {
    let folder = a.target.open()?;
    let options = AnalyzeOptions {
        design: a.design.map(|d| d.parse()).transpose()?,
        inputs: a.inputs.iter().map(|p| p.0.map(|x| x * 1e-6)).collect(),
    };
    print::summary(&flexstage_pipeline::analyze(&folder, &options)?);
    Ok(())
}

/// Arguments of `flexstage export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    #[command(flatten)]
    pub target: Target,
    /// The design (as for analyze). Default: the run's finished design.
    #[arg(long)]
    pub design: Option<String>,
    /// Length unit of the DXF, SVG and STL files.
    #[arg(long, default_value = name(&UNITS, ExportOptions::default().unit),
          value_parser = names::names(&UNITS))]
    pub units: String,
    /// Density level of the contour, in (0, 1).
    #[arg(long, default_value_t = ExportOptions::default().level)]
    pub level: f64,
    /// Taubin smoothing passes (0: the raw marching-squares polygon).
    #[arg(long, default_value_t = ExportOptions::default().smoothing)]
    pub smoothing: usize,
    /// Longest chord [mm] of the exported curve (Catmull–Rom through the smoothed contour;
    /// 0: the polygon itself).
    #[arg(long, default_value_t = ExportOptions::default().max_chord * 1e3)]
    pub max_chord_mm: f64,
    /// Skip the verification (body-fitted re-analysis and manufacturability checks).
    #[arg(long)]
    pub no_verify: bool,
    /// Exit with status 2 when the verdict is "NOT safe" (files are written either way).
    #[arg(long)]
    pub require_safe: bool,
    /// Fatigue strength of the material [MPa]. Default: the scenario's
    /// limits.fatigue_strength (Al 6061-T6: 96.5).
    #[arg(long)]
    pub fatigue_strength_mpa: Option<f64>,
    /// Safety factor: allowable stress = fatigue strength / safety factor. Default: the
    /// scenario's limits.safety_factor (1.5).
    #[arg(long)]
    pub safety_factor: Option<f64>,
    /// Minimum hinge (ligament) thickness [mm]. Default: the scenario's
    /// limits.min_hinge_thickness (0.5).
    #[arg(long)]
    pub min_ligament_mm: Option<f64>,
    /// Minimum slot width [mm] (the wire-EDM kerf). Default: the scenario's
    /// limits.min_slot_width (0.4).
    #[arg(long)]
    pub min_gap_mm: Option<f64>,
    /// Wire-EDM start-hole diameter [mm].
    #[arg(long, default_value_t = VerifyParams::default().start_hole_diameter * 1e3)]
    pub start_hole_mm: f64,
}

pub fn export(a: ExportArgs) -> anyhow::Result<()> {
    let folder = a.target.open()?;
    let verify = (!a.no_verify).then(|| LimitOverrides {
        fatigue_strength: a.fatigue_strength_mpa.map(|v| v * 1e6),
        safety_factor: a.safety_factor,
        min_ligament: a.min_ligament_mm.map(|v| v * 1e-3),
        min_gap: a.min_gap_mm.map(|v| v * 1e-3),
        start_hole_diameter: Some(a.start_hole_mm * 1e-3),
    });
    let options = ExportOptions {
        design: a.design.map_or(Ok(DesignSource::Run), |d| d.parse())?,
        unit: parse(&UNITS, &a.units).expect("clap checks --units"),
        level: a.level,
        smoothing: a.smoothing,
        max_chord: a.max_chord_mm * 1e-3,
        verify,
    };
    let summary = flexstage_pipeline::export(&folder, &options)?;
    print::summary(&summary);
    if a.require_safe && options.verify.is_some() && !summary.safe() {
        errln!("--require-safe: the design is not verified safe");
        std::process::exit(2);
    }
    Ok(())
}

/// Arguments of `flexstage reduce`.
#[derive(Debug, Args)]
pub struct ReduceArgs {
    #[command(flatten)]
    pub target: Target,
    /// The design (as for analyze). Default: the run's design if it has a finished one, else
    /// the uniform start design.
    #[arg(long)]
    pub design: Option<String>,
    /// Take the tangent at this operating point "X1,X2" (nominal strokes, µm) instead of the
    /// undeformed state.
    #[arg(long, value_name = "X1,X2")]
    pub operating_point: Option<Pair>,
    /// Number of natural frequencies and mode shapes (0 skips the modal analysis).
    #[arg(long, default_value_t = ReduceOptions::default().modes)]
    pub modes: usize,
    /// Lumped (diagonal) instead of consistent mass matrices.
    #[arg(long)]
    pub lumped: bool,
    /// Leave the input-plate masses (stage.guess.m_in) out of the modal analysis.
    #[arg(long)]
    pub no_plate_mass: bool,
    /// Stroke scales of the validity map, comma separated (empty string skips it).
    #[arg(long, default_value_t = List(ReduceOptions::default().scales))]
    pub scales: List,
    /// Keep the optimizer's output spring (optimization.output_spring) in the model.
    #[arg(long)]
    pub keep_output_spring: bool,
}

pub fn reduce(a: ReduceArgs) -> anyhow::Result<()> {
    let folder = a.target.open()?;
    let options = ReduceOptions {
        design: a.design.map(|d| d.parse()).transpose()?,
        operating_point: a.operating_point.map(|p| p.0.map(|x| x * 1e-6)),
        modes: a.modes,
        lumped: a.lumped,
        plate_masses: !a.no_plate_mass,
        scales: a.scales.0,
        keep_output_spring: a.keep_output_spring,
    };
    print::summary(&flexstage_pipeline::reduce(
        &folder,
        &options,
        &Bars::default(),
    )?);
    Ok(())
}

/// PEA subcommands.
#[derive(Debug, Subcommand)]
pub enum PeaCommand {
    /// Simulate a PEA (Bouc–Wen, Eq. 18) and write a synthetic record t, U, x.
    #[command(
        after_help = "Parameters come from the scenario's hysteresis table (Table A1, µm, \
V, s), the voltage range from hysteresis.voltage_min/max, the sample time and seed from \
simulation. The record starts from a virgin actuator (U = 0, h = 0); the noise is white \
Gaussian on x. Writes <run>/pea/pea<N>.csv and pea<N>_loop.svg, or only --output FILE.csv.

Examples:
  flexstage pea simulate                              # PEA1, decaying 1 Hz sine, 10 nm noise
  flexstage pea simulate --noise-nm 0 --output pea1.csv
  flexstage pea simulate --pea 2 --shape triangle --frequency 5 --cycles 3"
    )]
    Simulate(PeaArgs),
}

/// Arguments of `flexstage pea simulate`.
#[derive(Debug, Args)]
pub struct PeaArgs {
    #[command(flatten)]
    pub target: Target,
    /// Which PEA of the scenario (1 or 2).
    #[arg(long, default_value_t = PeaOptions::default().pea)]
    pub pea: u8,
    /// Drive shape.
    #[arg(long, default_value = name(&SHAPES, PeaOptions::default().shape),
          value_parser = names::names(&SHAPES))]
    pub shape: String,
    /// Drive frequency [Hz].
    #[arg(long, default_value_t = PeaOptions::default().frequency)]
    pub frequency: f64,
    /// Number of periods.
    #[arg(long, default_value_t = PeaOptions::default().cycles)]
    pub cycles: u32,
    /// Standard deviation of the sensor noise added to x [nm].
    #[arg(long, default_value_t = PeaOptions::default().noise_nm)]
    pub noise_nm: f64,
    /// Sample time [s] (default: the scenario's simulation.sample_time).
    #[arg(long)]
    pub dt: Option<f64>,
    /// Noise seed (default: the scenario's simulation.seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Write only this CSV file instead of the run folder (kept if it exists, unless --force).
    #[arg(long)]
    pub output: Option<PathBuf>,
}

pub fn pea(PeaCommand::Simulate(a): PeaCommand) -> anyhow::Result<()> {
    let options = PeaOptions {
        pea: a.pea,
        shape: parse(&SHAPES, &a.shape).expect("clap checks --shape"),
        frequency: a.frequency,
        cycles: a.cycles,
        noise_nm: a.noise_nm,
        dt: a.dt,
        seed: a.seed,
    };
    if let Some(path) = &a.output {
        let r = flexstage_pipeline::simulate_pea(&a.target.scenario.load()?, &options)?;
        out!("{r}");
        flexstage_pipeline::write_pea_csv(path, &r, a.target.force)?;
        errln!("wrote {}", path.display());
        return Ok(());
    }
    let folder = a.target.open()?;
    let r = flexstage_pipeline::simulate_pea(folder.scenario(), &options)?;
    out!("{r}");
    let (files, replaced) = flexstage_pipeline::write_pea_record(&folder, &r)?;
    print::wrote(&files[0], replaced);
    Ok(())
}

/// What to identify.
#[derive(Debug, Subcommand)]
pub enum IdentifyCommand {
    /// Identify the Bouc–Wen parameters of one PEA (Appendix B) from a CSV record.
    #[command(
        after_help = "The CSV needs a header with the columns t [s], U [V] and x [µm] \
(any order, extra columns ignored, # comments allowed). Without --data, the run's simulated \
record of that PEA (pea/pea<N>.csv, from `flexstage pea simulate`). Writes \
<run>/identify/pea<N>/: estimates.toml, convergence.svg (Figure A2), loop.svg (record against \
model), compensation.svg (hysteresis without and with inverse compensation) and their CSVs.

Examples:
  flexstage identify pea                              # the run's pea/pea1.csv
  flexstage identify pea --data lab.csv --pea 2 --forgetting 0.99998"
    )]
    Pea(IdentifyPeaArgs),
    /// Identify the stage stiffnesses and dampings by online least squares (Section 4.2,
    /// Eq. 54-56, Table 4), from the run's simulated stage or a record.
    #[command(
        after_help = "Without --data, an 8 s two-band multisine (5-150 Hz, plus a band around \
the output modes of the run's lumped model for the dampings) excites the lumped model of the \
design (once `flexstage reduce` has run; the scenario's stage.truth before), scored against its \
own parameters. --plant twin instead identifies what the controller takes from the digital twin \
of the design: its frequency response (16 s multisine up to 1.2x the controller's Nyquist \
frequency, sampled 5x faster), the static gain and the output modes below Nyquist, scored \
against the same fit of the twin's exact modes; `track` on the twin sets the backstepping up \
from it. A record needs the columns t [s], x_nom1, x_nom2 [m] (or U1, U2 [V]), x_in1, x_in2, \
q1, q2 [m], sampled uniformly. Masses and alpha are the known values of the guess (Eq. 27). \
Writes <run>/identify/stage/: params.toml (the controller's model of `flexstage track` in this \
run), table.csv (guess / estimate / truth, like Table 4), convergence.svg/csv, record.csv; \
on the twin <run>/identify/stage/twin/: response_fit.toml, params.toml, table.csv, \
response.csv/svg.

Examples:
  flexstage identify stage                                # 8 s multisine on the lumped model
  flexstage identify stage --actuator linear --noise-free --duration 1
  flexstage identify stage --plant twin                   # the twin's response fit
  flexstage identify stage --data lab.csv --out runs/lab"
    )]
    Stage(IdentifyStageArgs),
}

/// Arguments of `flexstage identify pea`.
#[derive(Debug, Args)]
pub struct IdentifyPeaArgs {
    #[command(flatten)]
    pub target: Target,
    /// The record (CSV: t [s], U [V], x [µm]). Default: the run's pea/pea<N>.csv.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Which PEA the record belongs to (1 or 2).
    #[arg(long, default_value_t = PeaIdOptions::default().pea)]
    pub pea: u8,
    /// Forgetting factor λ_f of both RLS estimators, in [0.9, 1] (1 converges to the batch
    /// fit; below 1 the memory is about 1/(1 − λ_f) samples).
    #[arg(long, default_value_t = PeaIdOptions::default().forgetting)]
    pub forgetting: f64,
    /// Passes of the parallel RLS over the record.
    #[arg(long, default_value_t = PeaIdOptions::default().passes)]
    pub passes: u32,
}

/// Arguments of `flexstage identify stage`.
#[derive(Debug, Args)]
pub struct IdentifyStageArgs {
    #[command(flatten)]
    pub target: Target,
    /// A logged record instead of the simulated stage.
    #[arg(long, conflicts_with = "simulate")]
    pub data: Option<PathBuf>,
    /// Excite the simulated stage (the default without --data).
    #[arg(long)]
    pub simulate: bool,
    /// Excitation length for the simulation [s]. Default: 8 on the lumped model, 16 on the
    /// twin.
    #[arg(long)]
    pub duration: Option<f64>,
    /// Highest frequency of the low excitation band [Hz].
    #[arg(long, default_value_t = Simulation::default().f_max)]
    pub f_max: f64,
    /// Peak per PEA of the resonance band [µm] (around the lumped model's output modes; on
    /// the twin up to 1.2× Nyquist) (0: the low band alone; the dampings are then not
    /// identifiable).
    #[arg(long, default_value_t = Simulation::default().resonance_amplitude * 1e6)]
    pub resonance_um: f64,
    /// The simulated stage: the lumped 8-state model (the paper's regression), or the digital
    /// twin of the run's design in the scenario's rig (its response fit; the lumped model
    /// before the run has a design).
    #[arg(long, default_value = Simulation::default().plant.name(), value_parser = TRACK_PLANTS)]
    pub plant: String,
    /// Simulated actuator: "hysteretic" (Bouc–Wen PEAs, cross terms) or "linear" (x_nom
    /// applied directly; on the lumped model also no cross terms: the model of Eq. 36).
    #[arg(long, default_value = ACTUATORS[Simulation::default().linear as usize], value_parser = ACTUATORS)]
    pub actuator: String,
    /// Switch the simulated sensor noise and quantization off.
    #[arg(long)]
    pub noise_free: bool,
    /// Forgetting factor λ_f of the RLS rows, in [0.9, 1].
    #[arg(long, default_value_t = StageIdOptions::default().estimator.forgetting)]
    pub forgetting: f64,
    /// Prefilter cut-off [Hz] applied to every signal (0: off).
    #[arg(long, default_value_t = StageIdOptions::default().estimator.prefilter)]
    pub prefilter: f64,
    /// Regression at every d-th sample (d·T_s).
    #[arg(long, default_value_t = StageIdOptions::default().estimator.decimation)]
    pub decimation: usize,
    /// Stiffness regressors Numerov-weighted (default) or as printed in Eq. (54) (central).
    #[arg(long, default_value = name(&SCHEMES, StageIdOptions::default().estimator.scheme),
          value_parser = names::names(&SCHEMES))]
    pub scheme: String,
    /// Leave out the cross-term coupling column (the paper's two-column output rows).
    #[arg(long)]
    pub no_coupling: bool,
}

pub fn identify(cmd: IdentifyCommand) -> anyhow::Result<()> {
    match cmd {
        IdentifyCommand::Pea(a) => {
            let options = PeaIdOptions {
                pea: a.pea,
                data: a.data,
                forgetting: a.forgetting,
                passes: a.passes,
            };
            let s = flexstage_pipeline::identify_pea(&a.target.open()?, &options)?;
            print::summary(&s);
        }
        IdentifyCommand::Stage(a) => {
            let data = match a.data {
                Some(path) => StageData::Record(path),
                None => StageData::Simulate(Simulation {
                    plant: plant(&a.plant),
                    duration: a.duration,
                    f_max: a.f_max,
                    resonance_amplitude: a.resonance_um * 1e-6,
                    linear: a.actuator == ACTUATORS[1],
                    noise: !a.noise_free,
                }),
            };
            let mut options = StageIdOptions {
                data,
                ..StageIdOptions::default()
            };
            let e = &mut options.estimator;
            e.forgetting = a.forgetting;
            e.prefilter = a.prefilter;
            e.decimation = a.decimation;
            e.coupling = !a.no_coupling;
            e.scheme = parse(&SCHEMES, &a.scheme).expect("clap checks --scheme");
            let folder = a.target.open()?;
            let s = flexstage_pipeline::identify_stage(&folder, &options, &Bars::default())?;
            print::summary(&s);
        }
    }
    Ok(())
}

/// Arguments of `flexstage track`.
#[derive(Debug, Args)]
pub struct TrackArgs {
    #[command(flatten)]
    pub target: Target,
    /// Trajectory name from the scenario, or "all".
    #[arg(long, default_value = "all")]
    pub trajectory: String,
    /// Controller by name (each is listed with what it is), or all (the controllers that run
    /// by default).
    #[arg(long, default_value = ALL_VARIANTS, value_parser = variants())]
    pub variant: String,
    /// Hysteresis compensation: inverse (Eq. 21, in the loop) or off (straight line).
    #[arg(long, default_value = names::compensation(TrackOptions::default().compensation),
          value_parser = names::names(&COMPENSATIONS))]
    pub compensation: String,
    /// The controller's model: a StageParams TOML (e.g. the run's reduce/params.toml).
    /// Default: the run's identified parameters if it has them, else stage.guess. A file of
    /// another run folder is refused unless --out names the folder to write to.
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// Duration [s] of every run (default: each trajectory's own).
    #[arg(long)]
    pub duration: Option<f64>,
    /// The simulated stage: the digital twin of the run's design in the scenario's rig
    /// (falls back to the lumped model before the run has a design), or the lumped 8-state
    /// model in its minimal loop (results in track/plant-lumped/).
    #[arg(long, default_value = TrackOptions::default().plant.name(), value_parser = TRACK_PLANTS)]
    pub plant: String,
    /// Also run every controller with iterative learning on top (periodic trajectories
    /// only): the learning designed from the loop's readings, rows <controller>+learning.
    #[arg(long)]
    pub learning: bool,
    /// With --learning: the learning trials (periods) before the scored run, 1..=200.
    #[arg(long, default_value_t = flexstage_pipeline::track::LEARNING_TRIALS, requires = "learning")]
    pub trials: usize,
    /// First write the twin's report data to <run>/twin/ (modes, Bode data and figures beside
    /// the lumped model, validity.json), as `flexstage run` does.
    #[arg(long)]
    pub write_twin: bool,
    /// With --write-twin: check the twin against the full nonlinear transient: auto (on up to
    /// 5000 FE DOF, i.e. quick; off for paper, minutes per case), on, off.
    #[arg(long, default_value = "auto", value_parser = TWIN_VALIDATIONS, requires = "write_twin")]
    pub twin_validate: String,
    /// Perturbed twins of the Monte-Carlo study on the twin (each one measured and every
    /// controller designed from that measurement, then run on it), 1..=10000.
    #[arg(long, default_value_t = TrackOptions::default().montecarlo_plants)]
    pub montecarlo_plants: usize,
}

pub fn track(a: TrackArgs) -> anyhow::Result<()> {
    let options = TrackOptions {
        plant: plant(&a.plant),
        trajectory: (a.trajectory != "all").then_some(a.trajectory),
        controllers: controllers(&a.variant),
        compensation: parse(&COMPENSATIONS, &a.compensation).expect("clap checks it"),
        params: a.params,
        allow_foreign_params: a.target.out.is_some(),
        duration: a.duration,
        learning: a.learning.then_some(a.trials),
        montecarlo_plants: a.montecarlo_plants,
    };
    let folder = a.target.open()?;
    if a.write_twin {
        let o = TwinOptions {
            validation: twin_validation(&a.twin_validate),
        };
        print::summary(&flexstage_pipeline::write_twin(
            &folder,
            &o,
            &Bars::default(),
        )?);
    }
    print::summary(&flexstage_pipeline::track(
        &folder,
        &options,
        &Bars::default(),
    )?);
    Ok(())
}

/// Arguments of `flexstage front`.
#[derive(Debug, Args)]
pub struct FrontArgs {
    #[command(flatten)]
    pub target: Target,
    /// The scan speed you need: the fast component of a 3:1 Lissajous [Hz].
    #[arg(long, default_value_t = FrontOptions::default().scan_hz)]
    pub scan_hz: f64,
    /// The tracking error you accept at that speed [% of range]; picks the design.
    #[arg(long, default_value_t = FrontOptions::default().max_error_pct)]
    pub max_error_pct: f64,
    /// Designs on the front, the workspace design included.
    #[arg(long, default_value_t = FrontOptions::default().designs)]
    pub designs: usize,
    /// The last design's first-frequency bound, as a multiple of the workspace design's.
    #[arg(long, default_value_t = FrontOptions::default().max_ratio)]
    pub max_ratio: f64,
    /// Iterations of each continuation design (default: twice the β interval plus twice the
    /// stagnation window).
    #[arg(long)]
    pub iterations: Option<usize>,
}

pub fn front(a: FrontArgs) -> anyhow::Result<()> {
    let folder = a.target.open()?;
    let options = FrontOptions {
        designs: a.designs,
        max_ratio: a.max_ratio,
        scan_hz: a.scan_hz,
        max_error_pct: a.max_error_pct,
        iterations: a.iterations,
    };
    let summary = flexstage_pipeline::front(&folder, &options, &Bars::default())?;
    print::summary(&summary);
    Ok(())
}
