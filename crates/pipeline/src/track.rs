//! `track`: the simulated tracking experiment (Section 4, Figures 9–11) on the run's stage.
//!
//! * **Plant** ([`TrackOptions::plant`]): by default the digital twin of the run's finished
//!   design (`flexstage-twin`: the design's FE model reduced by Craig–Bampton, with the PEA
//!   sets and the geometric nonlinearity) inside the scenario's rig (`[rig]`: delay,
//!   amplifier limits, the plant's own Bouc–Wen PEAs with creep, sensor dynamics, white + 1/f
//!   noise, quantization). Before the run has a design, `track` falls back to the lumped
//!   8-state model and says so. [`PlantKind::Lumped`] asks for the lumped model (the run's
//!   [`Plant::of_run`]: the reduced model of the design once it exists, else the scenario's
//!   `stage.truth`) in its minimal loop, as before the twin.
//! * **Trajectories** are checked before anything runs ([`Setup::check_reference`] with the
//!   simulated plant's static gain): one that would need more than the controller's stroke,
//!   voltages outside the amplifier range, more current or slew than the amplifier has, or
//!   that reaches the Nyquist frequency is refused with a message naming it, the value and
//!   the limit.
//! * **Hysteresis compensation** uses the identified Bouc–Wen parameters of each PEA
//!   (`identify/pea<N>/estimates.toml`, `recommended_params`) when the run has them, else the
//!   scenario's `[hysteresis]`; the plant keeps its own (truth) PEAs, which only simulate
//!   and score. [`TrackSummary::compensator`] says which were used.
//! * **Controller's model**: [`TrackOptions::params`] if given; else the run's identified
//!   parameters (`identify/stage/params.toml`) if the run has them; else the guess. On the
//!   twin the controllers are designed from its loop measured in its rig at the
//!   controller's sample time (multisine with the scenario's noise, stored as
//!   `measured_response.csv` of the result folder; the same experiments recorded by a fast
//!   ADC on the sensor's analog output, stored as `lifted_response.csv`, which the linear
//!   controllers' feed-forward is fitted to at the samples); the twin's truth only scores
//!   them.
//! * **Folder**: `track/` for the default conditions (inverse compensation, the default
//!   model, each trajectory's own duration); other conditions get their own folder
//!   ([`TrackOptions::conditions`]), e.g. `track/compensation-off/` or
//!   `track/params-reduce/`, so they never overwrite each other. Running a subset of the
//!   trajectories or controllers updates those rows of `metrics.csv` and keeps the others.
//!
//! * **Learning** ([`TrackOptions::learning`], `--learning`): every selected controller
//!   also runs with the iterative-learning layer (`flexstage_control::learning`) on every
//!   trajectory, which must be periodic. Per pair: the controller's design under learning
//!   (`Designs::for_learning`, tuned to wider margins), the learning plant measured from the
//!   ADC readings of its loop, both laws designed from it (monotone-convergence factor
//!   ρ < 1 with the measurement's uncertainty) and the one that learns better on a trial
//!   kept, told the sensor's datasheet lag; it learns for the given number of trials
//!   (periods), on the twin with the lab's fast ADC correcting the reading it learns
//!   toward after every trial (`Learning::retarget`), then the trajectory's run is scored
//!   with learning still on. Its row is
//!   `<controller>+learning`; its design's margins are in `margins.csv` under that name.
//!
//! Every (trajectory, controller) pair is independent and runs in parallel (rayon).

use flexstage_scenario::RecordEstimate;
use std::path::{Path, PathBuf};

use crate::scan::{ScanFrequency, scan_frequency};
use flexstage_assess::Bench;
use flexstage_assess::inject::InjectionParams;
use flexstage_assess::lab::{LabMeasurement, LabParams, operating_fast_adc};
use flexstage_assess::margins::{MarginRow, MarginTargets, learning_margins_table, margins_table};
use flexstage_assess::montecarlo::{MonteCarlo, MonteCarloParams, PlantDesign, monte_carlo};
use flexstage_control::ControlError;
use flexstage_control::actuator::ActuatorParams;
use flexstage_control::actuator::Compensation;
use flexstage_control::experiment::Setup;
use flexstage_control::learning::{
    self, DesignParams, Learning, Readings, SensorDatasheet, SensorLag, measure_learning_plant,
};
use flexstage_control::registry::{Controller, Design, Designs, Stage};
use flexstage_control::tuning::{FeedForwardFit, TuningParams};
use flexstage_figures::plot::{Figure, Series};
use flexstage_identify::measured::{
    FastAdc, FastChannel, FastRecorded, LiftedResponse, MeasuredResponse,
};
use flexstage_piezo::BoucWenParams;
use flexstage_run::files::lifted::LiftedLineRow;
use flexstage_run::files::measured::MeasuredLineRow;
use flexstage_run::files::pea::PeaEstimates;
use flexstage_run::files::stage::StageParamsFile;
use flexstage_run::files::track::LEARNING_SUFFIX;
use flexstage_run::format::{Format, Rows};
use flexstage_run::layout::{self, Tracking};
use flexstage_run::{RunDir, Table};
use flexstage_sim::experiment::StageControl;
use flexstage_sim::experiment::{Metrics, Record, Status, WatchParams, run_watched};
use flexstage_sim::rig::StagePlant;
use flexstage_sim::trajectory::{Reference, Shape};
use rayon::prelude::*;

use crate::error::{PipelineError, Result, require};
use crate::folder::RunFolder;
use crate::plant::{ModelParams, Plant, PlantSource, read_model_params};
use crate::progress::Progress;
use crate::source::plain;
use crate::twin::Built;

/// The longest tracking run \[s\] (bounded work: 6·10⁶ samples at 10 kHz).
pub const MAX_DURATION: f64 = 600.0;

/// The learning trials (periods) of `--learning` without `--trials`: on the twin the error
/// settles within 10 % of its last value in 2–8 periods (docs/verification.md).
pub const LEARNING_TRIALS: usize = 20;

/// The most learning trials (bounded work: with the longest period below, 4·10⁶ samples).
pub const MAX_LEARNING_TRIALS: usize = 200;

/// The most Monte-Carlo plants (bounded work: a plant is measured, designed on and run, a few
/// CPU-seconds on the quick design, so 10 000 plants are hours, never unbounded).
pub const MAX_MONTECARLO_PLANTS: usize = 10_000;

/// The longest period learning accepts \[samples\]: measuring the learning plant takes a
/// DFT bin at every harmonic, O(N²) (seconds at this N; 0.5 Hz at 10 kHz).
pub const MAX_LEARNING_PERIOD: usize = 20_000;

/// RMS per axis \[m\] of the multisine that measures the learning plant: well above the
/// sensors' quantization, far below the workspace (0.1 % of the quick stroke).
pub const LEARNING_AMPLITUDE: f64 = 20e-9;

/// Which stage `track` simulates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlantKind {
    /// The digital twin of the run's design in the scenario's rig (falls back to
    /// [`PlantKind::Lumped`] before the run has a design). The default.
    #[default]
    Twin,
    /// The lumped 8-state model (A13–A14) of the run in its minimal loop.
    Lumped,
}

impl PlantKind {
    /// Both, in the order of the CLI's `--plant` values.
    pub const ALL: [PlantKind; 2] = [PlantKind::Twin, PlantKind::Lumped];

    /// The name in `--plant`, tables and `metrics.csv`.
    pub fn name(self) -> &'static str {
        match self {
            PlantKind::Twin => "twin",
            PlantKind::Lumped => "lumped",
        }
    }

    /// The kind of a name.
    pub fn from_name(name: &str) -> Option<PlantKind> {
        PlantKind::ALL.into_iter().find(|k| k.name() == name)
    }
}

/// Options of `track`.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackOptions {
    /// The simulated stage. Default [`PlantKind::Twin`].
    pub plant: PlantKind,
    /// One trajectory of the scenario by name; `None`: all.
    pub trajectory: Option<String>,
    /// The controllers to run. Default: the registry's defaults ([`Controller::defaults`]).
    pub controllers: Vec<&'static Controller>,
    /// Hysteresis compensation. Default [`Compensation::Inverse`] (Eq. 21, in the loop).
    pub compensation: Compensation,
    /// The controller's model (a `StageParams` TOML); `None`: the run's identified parameters
    /// if it has them, else the scenario's `stage.guess` (with the design's mass and α).
    pub params: Option<PathBuf>,
    /// Accept a `params` file from another run folder (refused by default, so that a
    /// parameter file never silently sends results to an unrelated run).
    pub allow_foreign_params: bool,
    /// Duration of every run \[s\], in (0, 600]; `None`: each trajectory's own.
    pub duration: Option<f64>,
    /// Iterative learning on top of every selected controller, this many trials (periods)
    /// before the scored run, in 1..=200 (module docs); its rows are
    /// `<controller>+learning`, beside the controller's own. `None`: off, the default
    /// (docs/DECISIONS.md, "Learning in track").
    pub learning: Option<usize>,
    /// Perturbed twins of the Monte-Carlo study on the twin, ≥ 1 (default 100; each one
    /// measured and designed on, seconds apiece: tests use a few).
    pub montecarlo_plants: usize,
}

impl Default for TrackOptions {
    fn default() -> Self {
        TrackOptions {
            plant: PlantKind::Twin,
            trajectory: None,
            controllers: Controller::defaults(),
            compensation: Compensation::Inverse,
            params: None,
            allow_foreign_params: false,
            duration: None,
            learning: None,
            montecarlo_plants: MonteCarloParams::default().plants,
        }
    }
}

impl TrackOptions {
    /// Checks every option.
    pub fn validate(&self) -> Result<()> {
        require(
            !self.controllers.is_empty(),
            "track.controllers",
            "none",
            "at least one controller",
        )?;
        if let Some(d) = self.duration {
            require(
                d.is_finite() && d > 0.0 && d <= MAX_DURATION,
                "track.duration",
                d,
                "a duration in (0, 600] s",
            )?;
        }
        if let Some(n) = self.learning {
            require(
                (1..=MAX_LEARNING_TRIALS).contains(&n),
                "track.learning",
                n,
                "a number of trials in 1..=200",
            )?;
        }
        require(
            (1..=MAX_MONTECARLO_PLANTS).contains(&self.montecarlo_plants),
            "track.montecarlo_plants",
            self.montecarlo_plants,
            "a number of plants in 1..=10000",
        )?;
        Ok(())
    }

    /// The folder name of the conditions: empty for the defaults, else the non-default
    /// conditions joined by `_` (`plant-lumped`, `compensation-off`, `params-<name>`,
    /// `duration-<d>s`).
    pub fn conditions(&self, folder: &RunFolder) -> String {
        let mut parts = Vec::new();
        if self.plant != PlantKind::Twin {
            parts.push(format!("plant-{}", self.plant.name()));
        }
        match self.compensation {
            Compensation::Inverse => {}
            Compensation::Off => parts.push("compensation-off".to_string()),
            Compensation::Ideal => parts.push("compensation-ideal".to_string()),
        }
        if let Some(p) = &self.params {
            let same = |rel: &str| same_file(p, &folder.dir().path(rel));
            let name = if same(layout::reduce::PARAMS) {
                "reduce".to_string()
            } else if same(layout::stage::PARAMS) {
                "identified".to_string()
            } else {
                plain(&p.file_stem().unwrap_or_default().to_string_lossy())
            };
            parts.push(format!("params-{name}"));
        }
        if let Some(d) = self.duration {
            parts.push(format!("duration-{d}s"));
        }
        plain_or_empty(&parts.join("_"))
    }
}

fn plain_or_empty(s: &str) -> String {
    if s.is_empty() {
        String::new()
    } else {
        plain(s)
    }
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

/// Where the controller's model comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum ModelSource {
    /// A parameter file given by the caller.
    File(PathBuf),
    /// The run's identified parameters.
    Identified(PathBuf),
    /// The scenario's `stage.guess` (mass and α from the design when it is reduced).
    Guess,
}

impl ModelSource {
    /// A short label for tables: the file, or `guess`.
    pub fn label(&self) -> String {
        match self {
            ModelSource::File(p) | ModelSource::Identified(p) => p.display().to_string(),
            ModelSource::Guess => "guess".into(),
        }
    }
}

impl std::fmt::Display for ModelSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ModelSource::File(p) => write!(f, "{}", p.display()),
            ModelSource::Identified(p) => write!(f, "the identified parameters ({})", p.display()),
            ModelSource::Guess => write!(f, "the scenario's stage.guess"),
        }
    }
}

/// One row of the metrics table.
#[derive(Debug, Clone)]
pub struct TrackRow {
    /// Trajectory name.
    pub trajectory: String,
    /// Controller.
    pub controller: &'static Controller,
    /// Whether the controller ran with the learning layer.
    pub learning: bool,
    /// Errors against the true output.
    pub metrics: Metrics,
    /// Largest fraction of the designed workspace the reference uses.
    pub usage: f64,
}

impl TrackRow {
    /// The row's name in `metrics.csv`, tables and file names: the controller's, with
    /// [`LEARNING_SUFFIX`] under learning.
    pub fn variant(&self) -> String {
        variant_name(self.controller, self.learning)
    }

    /// The error columns of `metrics.csv` and the printed table, in their order: RMS q1, q2
    /// \[nm\], RMS q1, q2 \[% of range\], max q1, q2 \[nm\], max q1, q2 \[% of range\], settling
    /// time \[s\], peak voltage \[V\].
    pub fn error_columns(&self) -> [f64; 10] {
        let m = &self.metrics;
        [
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
        ]
    }
}

/// What `track` did.
#[derive(Debug, Clone)]
pub struct TrackSummary {
    /// The stage that was simulated: the twin, or the lumped model.
    pub simulated: PlantKind,
    /// Where the lumped model's parameters come from (also the twin's Bode comparison).
    pub plant: PlantSource,
    /// The Bouc–Wen parameters of the hysteresis compensation, per PEA: `identified
    /// (<file>)` or `scenario [hysteresis]`.
    pub compensator: [String; 2],
    /// The controller's model.
    pub model: ModelSource,
    /// Hysteresis compensation.
    pub compensation: Compensation,
    /// The rows of this call (the folder's `metrics.csv` may hold more).
    pub rows: Vec<TrackRow>,
    /// Warnings (e.g. a trajectory leaving the designed workspace).
    pub warnings: Vec<String>,
    /// The result folder.
    pub dir: PathBuf,
    /// Whether earlier results were replaced.
    pub replaced: bool,
    /// Loop-at-a-time margins of each controller on the twin's sampled loop with the rig's
    /// delay (`flexstage-assess`; empty on the lumped plant).
    pub margins: Vec<MarginRow>,
    /// The rig's sample time \[s\] (delay margins in samples).
    pub sample_time: f64,
    /// The controllers written for a real-time target (`controllers/` of the result
    /// folder: coefficients JSON, C99 source and header).
    pub exported: crate::controllers::Exported,
    /// What the linear controllers' feed-forward is fitted to: the lifted response at the
    /// samples on the twin (its fast ADC's `lifted_response.csv`), the static inverse on
    /// the lumped plant.
    pub feedforward: FeedForwardFit,
}

impl TrackSummary {
    /// The margins as a table: per controller and loop the gain margin, phase margin, gain
    /// crossover and delay margin, `FLAGGED` below 6 dB / 40°; empty when none
    /// were measured.
    pub fn margins_table(&self) -> String {
        if self.margins.is_empty() {
            return String::new();
        }
        let mut s = format!(
            "margins with {} sample(s) of delay (loop at a time, the other loop closed):\n\
             controller           loop  GM [dB]  PM [deg]  f_c [Hz]  DM [samples]  MC pass\n",
            self.margins[0].delay
        );
        for r in &self.margins {
            for l in 0..2 {
                let m = r.loop_columns(l, self.sample_time);
                let flag = if r.meets { "" } else { "  FLAGGED" };
                let mc = match r.montecarlo_pass {
                    Some(p) if l == 0 => format!("  {:>5.0} %", 100.0 * p),
                    _ => String::new(),
                };
                s.push_str(&format!(
                    "{:<20} q{}   {m}{mc}{flag}\n",
                    variant_name(r.candidate, r.learning),
                    l + 1
                ));
            }
        }
        s
    }
}

/// The controllers designed for the simulated stage, their margins and robustness.
type Designed = (
    Designs,
    FeedForwardFit,
    Vec<MarginRow>,
    Option<MonteCarlo>,
    Option<ScanFrequency>,
    Option<MeasuredFiles>,
);

/// The run files of the lab measurement `track` designs from: the measured response
/// (`measured_response.csv`) and, from a fast ADC during the same experiments, the lifted
/// response (`lifted_response.csv`).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MeasuredFiles {
    /// The measured response's rows.
    pub response: Rows<MeasuredLineRow>,
    /// The lifted response's rows; `None` without a fast ADC.
    pub lifted: Option<Rows<LiftedLineRow>>,
}

/// On the twin: measures its loop in its rig at the controller's sample time and designs
/// every controller of the registry from that measurement alone ([`measured_bench`]:
/// `flexstage_assess::Bench::from_measurement`, the loop-shaping ones tuned by
/// `flexstage_control::tuning` on the measured loop model with the allowance for its
/// uncertainty, the backstepping's model fitted to it; the controllers' model in `setup`
/// becomes that fit), returns the measurement's file rows, scores every selected
/// controller's margins on the twin's exact loop and runs the Monte-Carlo study
/// (`flexstage_assess::montecarlo`, default settings but `montecarlo_plants` plants: each
/// perturbed twin measured and every controller designed from its measurement; on the
/// scenario's first trajectory),
/// whose pass rates go into the margin rows, and the error against scan frequency
/// ([`crate::scan`]; with `--learning` the sweep learns too). On the lumped plant the controllers are designed from the scenario's
/// settings alone: one that needs the twin's response is skipped with a warning, and
/// `pid-ff` runs the scenario's gains.
fn tune_and_margins(
    setup: &mut Setup,
    sim: &Simulated,
    options: &TrackOptions,
    scenario: &flexstage_scenario::Scenario,
    progress: &dyn Progress,
    warnings: &mut Vec<String>,
) -> Result<Designed> {
    let controllers: &[&'static Controller] = &options.controllers;
    let montecarlo_plants = options.montecarlo_plants;
    let Simulated::Twin(twin) = sim else {
        let stage = Stage::scenario(setup);
        let designs = Designs::for_stage(&stage)?;
        let feedforward = FeedForwardFit::of(&stage);
        for c in controllers.iter().filter(|c| designs.get(c).is_none()) {
            warnings.push(format!(
                "{} is tuned on the twin's frequency response and is not run on the lumped \
                 plant",
                c.name
            ));
        }
        return Ok((designs, feedforward, Vec::new(), None, None, None));
    };
    let (bench, measured) = measured_bench(setup, twin, options.learning.is_some(), progress)?;
    let scenario_setup = setup.clone();
    setup.controller = bench.setup.controller.clone();
    let mut rows = margins_table(
        &bench,
        controllers,
        setup.rig.delay,
        MarginTargets::default(),
        &InjectionParams::default(),
    )?;
    let Some(first) = scenario.trajectories.first() else {
        return Ok((
            bench.designs,
            bench.feedforward,
            rows,
            None,
            None,
            Some(measured),
        ));
    };
    let (reference, _) = Reference::from_scenario(first);
    let t0 = std::time::Instant::now();
    let mp = MonteCarloParams {
        plants: montecarlo_plants,
        ..MonteCarloParams::default()
    };
    // Identified: the nominal stage as the scenario gives it; each plant is designed on.
    let scenario_bench;
    let base = match mp.design {
        PlantDesign::Identified => {
            scenario_bench = Bench::scenario(scenario_setup, (**twin).clone())?;
            &scenario_bench
        }
        PlantDesign::Nominal => &bench,
    };
    let mc = monte_carlo(base, controllers, reference, &mp)?;
    progress.note(&format!(
        "Monte-Carlo ({} design): {} perturbed twins × {} controller(s) in {:.1} s",
        mp.design.name(),
        mp.plants,
        controllers.len(),
        t0.elapsed().as_secs_f64()
    ));
    for (j, r) in rows.iter_mut().enumerate() {
        r.montecarlo_pass = Some(mc.pass_rate(j));
    }
    if options.learning.is_some() {
        // The designs learning runs on, where they differ: their own margins on the twin.
        rows.extend(learning_margins_table(
            &bench,
            controllers,
            setup.rig.delay,
            MarginTargets::default(),
            &InjectionParams::default(),
        )?);
    }
    let t0 = std::time::Instant::now();
    let scan = scan_frequency(&bench, scenario, controllers, options.learning)?;
    if let Some(sc) = &scan {
        progress.note(&format!(
            "error against scan frequency: {} frequencies × {} controller(s) in {:.1} s",
            sc.points.len(),
            controllers.len(),
            t0.elapsed().as_secs_f64()
        ));
        for p in &sc.points {
            for (name, why) in &p.refused {
                warnings.push(format!(
                    "no learning for {name} at {:.0} % of f1 on the sweep: {why}",
                    100.0 * p.fraction
                ));
            }
        }
    }
    Ok((
        bench.designs,
        bench.feedforward,
        rows,
        Some(mc),
        scan,
        Some(measured),
    ))
}

/// The bench of the twin with every controller designed from its loop measured in its rig
/// at the controller's sample time (`flexstage_assess::lab`, default settings: the
/// multisine with the scenario's noise, commands through the inverse compensation, a fast
/// ADC of `lab::FAST_ADC_RATIO` samples per sample on the sensor's analog output during the
/// same experiments) and from nothing of its truth: the measurement goes through the typed
/// rows of its run files and the designs come from what the files hold. The twin stays on
/// the bench to score.
pub(crate) fn measured_bench(
    setup: &Setup,
    twin: &flexstage_twin::Twin,
    learning: bool,
    progress: &dyn Progress,
) -> Result<(Bench, MeasuredFiles)> {
    let t0 = std::time::Instant::now();
    let lab = LabParams::default();
    let measured = flexstage_assess::lab::measure(twin, setup, &lab)?;
    progress.note(&format!(
        "the twin measured in its rig ({}) in {:.1} s",
        match &measured.lifted {
            Some(l) => format!("with a fast ADC at {} samples per sample", l.ratio()),
            None => "no fast ADC".into(),
        },
        t0.elapsed().as_secs_f64()
    ));
    let files = MeasuredFiles {
        response: crate::convert::measured_rows(&measured.response),
        lifted: measured.lifted.as_ref().map(crate::convert::lifted_rows),
    };
    let bench = bench_from_rows(setup, twin, &files, learning, progress, t0)?;
    Ok((bench, files))
}

/// The bench of the twin with every controller designed from the measurement's run files
/// `files` (what [`measured_bench`] measures and stores, or the run's stored files read
/// back): the linear designs' feed-forward fitted to the lifted response at the samples
/// when there is one (`Bench::from_measurement`). With `learning` also the designs that run
/// under the learning layer (`Designs::for_learning`); without, none are made.
pub(crate) fn bench_from_rows(
    setup: &Setup,
    twin: &flexstage_twin::Twin,
    files: &MeasuredFiles,
    learning: bool,
    progress: &dyn Progress,
    t0: std::time::Instant,
) -> Result<Bench> {
    let lab = LabParams::default();
    let bytes = |what: &str, r: std::result::Result<Vec<u8>, String>| {
        r.map_err(|reason| PipelineError::Format {
            path: what.into(),
            reason,
        })
    };
    let response = bytes("the measured response", files.response.encode())?;
    let response = MeasuredResponse::from_csv(&response[..], "the measured response")?;
    let mut measured = LabMeasurement::from_response(response, &lab.fit)?;
    if let Some(rows) = &files.lifted {
        let lifted = bytes("the lifted response", rows.encode())?;
        measured = measured.with_lifted(LiftedResponse::from_csv(
            &lifted[..],
            "the lifted response",
        )?);
    }
    let tuning = TuningParams {
        learning_widening: if learning {
            TuningParams::default().learning_widening
        } else {
            [0.0; 2]
        },
        ..TuningParams::default()
    };
    let bench = Bench::from_measurement(setup.clone(), twin.clone(), tuning, &lab, &measured)?;
    progress.note(&format!(
        "the controllers designed from the twin measured in its rig ({} lines at {} Hz, loop \
         model order {}, delay {}; feed-forward fitted to the {} response) in {:.1} s",
        measured.response.lines().len(),
        1.0 / setup.rig.sample_time,
        measured.model.order(),
        measured.model.delay(),
        bench.feedforward.name(),
        t0.elapsed().as_secs_f64()
    ));
    Ok(bench)
}

/// The name of a controller's row, with [`LEARNING_SUFFIX`] under learning.
pub fn variant_name(controller: &Controller, learning: bool) -> String {
    if learning {
        format!("{}{LEARNING_SUFFIX}", controller.name)
    } else {
        controller.name.to_string()
    }
}

/// One planned run.
struct Job<'a> {
    trajectory: &'a str,
    reference: Reference,
    duration: f64,
    controller: &'static Controller,
    /// With the learning layer: its trials, period and the sensor's datasheet lag.
    learning: Option<Learn>,
}

/// The learning layer of a job.
#[derive(Debug, Clone, Copy)]
struct Learn {
    trials: usize,
    period: usize,
    lag: SensorLag,
    /// The lab's fast ADC on the sensor during the trials (the twin only).
    fast_adc: Option<FastAdc>,
}

impl Job<'_> {
    /// The samples the job advances the progress by (learning trials and the scored run).
    fn samples(&self, dt: f64) -> f64 {
        let trials = self.learning.map_or(0, |l| l.trials * l.period);
        trials as f64 + self.duration / dt
    }
}

/// Samples per period N of a periodic reference, for the learning layer: a circle, or a
/// Lissajous curve of whole frequency ratio, whose period is a whole number of samples
/// (relative 1e-6) in 4..=[`MAX_LEARNING_PERIOD`]; a typed error naming the trajectory
/// otherwise.
pub fn learning_period(reference: &Reference, dt: f64, trajectory: &str) -> Result<usize> {
    let refuse = |why: String| PipelineError::Option {
        option: "track.learning",
        value: format!("trajectory {trajectory:?}"),
        expected: format!(
            "a periodic trajectory (circle, or Lissajous of whole ratio) whose period is a \
             whole number of 4..={MAX_LEARNING_PERIOD} samples: {why}"
        ),
    };
    let frequency = match reference.shape {
        Shape::Circle { frequency, .. } => frequency,
        Shape::Lissajous {
            ratio, frequency, ..
        } if (ratio - ratio.round()).abs() < 1e-9 && ratio >= 1.0 => frequency,
        Shape::Lissajous { ratio, .. } => {
            return Err(refuse(format!("its frequency ratio {ratio} is not whole")));
        }
        Shape::Step { .. } | Shape::Ramp { .. } => {
            return Err(refuse("it is not periodic".into()));
        }
    };
    let n = 1.0 / (frequency * dt);
    let whole = n.round();
    if !(n.is_finite() && (n - whole).abs() <= 1e-6 * n) {
        return Err(refuse(format!("its period is {n} samples")));
    }
    if !(4.0..=MAX_LEARNING_PERIOD as f64).contains(&whole) {
        return Err(refuse(format!("its period is {whole} samples")));
    }
    Ok(whole as usize)
}

/// The stage a `track` call simulates.
pub(crate) enum Simulated {
    /// The twin of the run's design (built once, a fresh rig plant per run).
    Twin(Box<flexstage_twin::Twin>),
    /// The lumped model in its minimal loop.
    Lumped,
}

/// The plant of `options.plant`: the twin of the run's design, or the lumped model (also when
/// the run has no finished design yet; a note says so).
fn simulated(
    folder: &RunFolder,
    options: &TrackOptions,
    progress: &dyn Progress,
    prebuilt: Option<TwinBuild>,
    warnings: &mut Vec<String>,
) -> Result<Simulated> {
    if options.plant == PlantKind::Lumped {
        return Ok(Simulated::Lumped);
    }
    if !folder.dir().exists(layout::design::DESIGN) {
        warnings.push(
            "the run has no finished design yet, so tracking runs on the lumped 8-state model \
             (`flexstage design` first for the twin of the designed stage)"
                .into(),
        );
        return Ok(Simulated::Lumped);
    }
    let reused = prebuilt.is_some();
    let built = match prebuilt {
        Some(b) => b,
        None => try_build(folder, progress)?,
    };
    let Built { twin, seconds } = match built {
        Ok(t) => t,
        // A design far from converged can leave solid islands that the twin (void removed
        // as air) cannot hold; the lumped model still runs, and the warning says why.
        Err(e) => {
            warnings.push(format!(
                "the twin of this design could not be built ({e}), so tracking runs on the \
                 lumped 8-state model"
            ));
            return Ok(Simulated::Lumped);
        }
    };
    progress.note(&format!(
        "twin: {} modes, first resonance {:.0} Hz, built in {seconds:.1} s{}",
        twin.modal.modes.len(),
        twin.first_resonance(),
        if reused { " (earlier in this run)" } else { "" }
    ));
    Ok(Simulated::Twin(Box::new(twin)))
}

/// Sets the compensator's Bouc–Wen parameters to the run's identified ones where they exist;
/// returns what each PEA uses.
fn identified_peas(folder: &RunFolder, setup: &mut Setup) -> Result<[String; 2]> {
    let mut used = [String::new(), String::new()];
    for n in [1u8, 2] {
        let rel = layout::PeaIdentification { pea: n }.estimates();
        let i = usize::from(n - 1);
        used[i] = match folder.dir().load::<PeaEstimates>(&rel)? {
            Some(e) => {
                setup.controller.actuator.hysteresis[i] = recommended(&e)?;
                format!("identified ({rel})")
            }
            None => "scenario [hysteresis]".into(),
        };
    }
    Ok(used)
}

/// The recommended parameters of a PEA's estimates, checked.
fn recommended(e: &PeaEstimates) -> Result<BoucWenParams> {
    let p = BoucWenParams::from(&e.recommended_params);
    p.validate()?;
    Ok(p)
}

/// The outcome of building the twin of the run's design: the twin, or why the twin could not
/// model this design (a `TwinError`'s message; tracking then runs on the lumped model).
pub type TwinBuild = std::result::Result<Built, String>;

/// What a twin build says on the progress before it starts.
pub(crate) const BUILDING_TWIN: &str =
    "building the twin of the design (FE model, Craig–Bampton, nonlinear fit)";

/// Builds the twin of the run's design (saying so on `progress`); a design the twin cannot
/// model is an `Ok(Err(why))`, any other failure (an unreadable design) an error.
pub fn try_build(folder: &RunFolder, progress: &dyn Progress) -> Result<TwinBuild> {
    progress.note(BUILDING_TWIN);
    match crate::twin::build(folder) {
        Ok(b) => Ok(Ok(b)),
        Err(PipelineError::Twin(e)) => Ok(Err(e.to_string())),
        Err(e) => Err(e),
    }
}

/// What `track` sets up before it designs and runs: the run's plant, the controllers' setup
/// (model, identified PEAs), the simulated stage and the identified response fit.
pub(crate) struct Prepared {
    pub plant: Plant,
    pub setup: Setup,
    pub model: ModelSource,
    pub compensator: [String; 2],
    pub warnings: Vec<String>,
    pub sim: Simulated,
}

/// The set-up of `track` ([`Prepared`]), read from the run folder.
pub(crate) fn prepare(
    folder: &RunFolder,
    options: &TrackOptions,
    progress: &dyn Progress,
    prebuilt: Option<TwinBuild>,
) -> Result<Prepared> {
    options.validate()?;
    let plant = Plant::of_run(folder)?;
    if let Some(d) = options.duration {
        let min = flexstage_scenario::limit::MIN_TRACK_SAMPLES;
        RecordEstimate::track(&plant.scenario, d).check("track.duration", d, min)?;
    }
    let mut setup = Setup::from_scenario(&plant.scenario);
    let model = model_source(folder, options)?;
    let params = match &model {
        ModelSource::File(p) => Some(read_model_params(p)?),
        // The parameters this run identified: from memory when the stage ran in this process.
        ModelSource::Identified(_) => folder
            .dir()
            .load::<StageParamsFile>(layout::stage::PARAMS)?
            .map(|f| ModelParams::from(&*f)),
        ModelSource::Guess => None,
    };
    if let Some(m) = params {
        (setup.controller.model, setup.controller.coupling) = (m.params, m.coupling);
    }
    let compensator = identified_peas(folder, &mut setup)?;
    let mut warnings = Vec::new();
    let sim = simulated(folder, options, progress, prebuilt, &mut warnings)?;
    Ok(Prepared {
        plant,
        setup,
        model,
        compensator,
        warnings,
        sim,
    })
}

/// Runs `track` (building the twin of the design when it simulates on the twin).
pub fn track(
    folder: &RunFolder,
    options: &TrackOptions,
    progress: &dyn Progress,
) -> Result<TrackSummary> {
    track_on(folder, options, progress, None)
}

/// Runs `track` with the twin `run` built in its twin stage (`None`: builds it, as [`track`]).
/// The twin is used only when `options.plant` is the twin and the run has a finished design.
pub fn track_on(
    folder: &RunFolder,
    options: &TrackOptions,
    progress: &dyn Progress,
    prebuilt: Option<TwinBuild>,
) -> Result<TrackSummary> {
    let Prepared {
        plant,
        mut setup,
        model,
        compensator,
        mut warnings,
        sim,
    } = prepare(folder, options, progress, prebuilt)?;
    const STOPPED_HINT: &str = "its earlier results are unchanged; run track again";
    crate::progress::check_stop(progress, "track stopped before tuning", STOPPED_HINT)?;
    let kind = match sim {
        Simulated::Twin(_) => PlantKind::Twin,
        Simulated::Lumped => PlantKind::Lumped,
    };
    let (designs, feedforward, margins, montecarlo, scan, measured) = tune_and_margins(
        &mut setup,
        &sim,
        options,
        &plant.scenario,
        progress,
        &mut warnings,
    )?;
    crate::progress::check_stop(progress, "track stopped after tuning", STOPPED_HINT)?;
    let jobs = plan(
        &plant.scenario,
        &setup,
        &designs,
        &sim,
        options,
        &mut warnings,
    )?;
    for w in &warnings {
        progress.note(&format!("warning: {w}"));
    }
    let dt = plant.scenario.simulation.sample_time;
    let samples: f64 = jobs.iter().map(|(j, _)| j.samples(dt)).sum();
    progress.start("track", samples.round() as u64);
    let runs: Vec<Result<(Record, Option<Learned>)>> = jobs
        .par_iter()
        .map(|(j, _)| run_job(&setup, &designs, &sim, options.compensation, j, progress))
        .collect();
    progress.finish();
    let mut learned = Vec::new();
    let mut records = Vec::with_capacity(runs.len());
    for ((j, _), run) in jobs.iter().zip(runs) {
        records.push(run.map(|(record, table)| {
            if let Some(table) = table {
                learned.push(crate::controllers::LearnedTable {
                    controller: j.controller,
                    trajectory: j.trajectory.to_string(),
                    table,
                });
            }
            record
        }));
    }
    let out = Tracking::variant(&options.conditions(folder));
    let replaced = folder.has_results(out.dir());
    let (rows, paths) = write_results(folder.dir(), &out, &jobs, records, dt)?;
    let merged = crate::track_files::write_metrics(
        folder.dir(),
        &out,
        &rows,
        crate::names::compensation(options.compensation),
        &model.label(),
        kind.name(),
        &mut warnings,
    )?;
    let trajectories = jobs_by_trajectory(&jobs);
    crate::track_files::write_paths(folder.dir(), &out, &trajectories, &merged, &paths)?;
    if !margins.is_empty() {
        let rows = crate::convert::margin_rows(&margins, dt);
        folder.dir().store(&out.margins(), Rows(rows))?;
    }
    if let Some(m) = measured {
        folder.dir().store(&out.measured_response(), m.response)?;
        if let Some(lifted) = m.lifted {
            folder.dir().store(&out.lifted_response(), lifted)?;
        }
    }
    if let Some(mc) = &montecarlo {
        let rows = crate::convert::montecarlo_rows(mc);
        folder.dir().store(&out.montecarlo(), Rows(rows))?;
    }
    if let Some(sc) = &scan {
        sc.write(folder.dir(), &out)?;
    }
    for r in rows
        .iter()
        .filter(|r| r.metrics.status() == Status::Saturated)
    {
        warnings.push(format!(
            "{}/{}: {} (metrics.csv, status)",
            r.trajectory,
            r.controller.name,
            r.metrics.status_detail()
        ));
    }
    let exported = crate::controllers::write_controllers(
        folder.dir(),
        &out,
        &designs,
        &options.controllers,
        &learned,
        setup.actuator(options.compensation),
        match sim {
            // The minimal loop has no delay: the controller predicts over none.
            Simulated::Twin(_) => setup.controller.delay,
            Simulated::Lumped => 0,
        },
        feedforward,
    )?;
    crate::error::require_converged_tracking(&rows)?;
    Ok(TrackSummary {
        simulated: kind,
        plant: plant.source,
        compensator,
        model,
        compensation: options.compensation,
        rows,
        warnings,
        dir: folder.dir().path(out.dir()),
        replaced,
        margins,
        sample_time: dt,
        exported,
        feedforward,
    })
}

/// The correction a learning run learned, per sample of its period \[m\].
type Learned = Vec<[f64; 2]>;

/// One (trajectory, controller) run on the simulated stage, with the table it learned when
/// it learned one.
fn run_job(
    setup: &Setup,
    designs: &Designs,
    sim: &Simulated,
    compensation: Compensation,
    j: &Job,
    progress: &dyn Progress,
) -> Result<(Record, Option<Learned>)> {
    let advance = |n: usize| progress.advance(n as u64);
    // Under learning, the design tuned for it (`Designs::for_learning`).
    let design = match j.learning {
        Some(_) => designs.for_learning(j.controller),
        None => designs.get(j.controller),
    };
    let design = &**design.expect("planned jobs are designed");
    let dt = setup.controller.observer.sample_time;
    let watch = watch(&j.reference, j.duration, dt);
    let actuator = setup.actuator(compensation);
    if let Some(learn) = j.learning {
        return run_learning(setup, design, sim, actuator, j, learn, progress);
    }
    // As `flexstage_control::experiment::{experiment_on, experiment_with_progress}`, watched.
    let record = match sim {
        Simulated::Twin(twin) => {
            let mut p = twin.plant(&setup.rig)?;
            let mut c = design.build(actuator, setup.controller.delay, j.reference)?;
            run_watched(c.as_mut(), &mut p, j.duration, dt, &watch, advance)
        }
        Simulated::Lumped => {
            // The minimal loop has no delay: the controller predicts over none.
            let mut c = design.build(actuator, 0, j.reference)?;
            let mut p = flexstage_sim::plant::Plant::new(setup.plant.clone())?;
            run_watched(c.as_mut(), &mut p, j.duration, dt, &watch, advance)
        }
    };
    Ok((record, None))
}

/// The rig's readings of a fresh simulated stage (the twin in its rig, or the lumped model).
fn readings(setup: &Setup, sim: &Simulated) -> Result<(Box<dyn StagePlant>, usize)> {
    Ok(match sim {
        Simulated::Twin(twin) => (Box::new(twin.plant(&setup.rig)?), setup.controller.delay),
        // The minimal loop has no delay: the controller predicts over none.
        Simulated::Lumped => (
            Box::new(flexstage_sim::plant::Plant::new(setup.plant.clone())?),
            0,
        ),
    })
}

/// One (trajectory, controller) run with the learning layer (module docs): the learning
/// plant measured from the readings of fresh loops, the layer designed from it, `trials`
/// periods of learning, then the scored run (learning on), with the correction learned over
/// its last complete period (what the layer replays when frozen; the exported table). A
/// learning phase that the watch stops is returned as the record, with no table.
fn run_learning(
    setup: &Setup,
    design: &dyn Design,
    sim: &Simulated,
    actuator: ActuatorParams,
    j: &Job,
    learn: Learn,
    progress: &dyn Progress,
) -> Result<(Record, Option<Learned>)> {
    let dt = setup.controller.observer.sample_time;
    let infeasible = |e: PipelineError| ControlError::Infeasible {
        what: "learning loop".into(),
        detail: e.to_string(),
    };
    let mut factory = || -> flexstage_control::Result<(Box<dyn StageControl>, Readings)> {
        let (plant, delay) = readings(setup, sim).map_err(infeasible)?;
        let c = design.build(actuator, delay, j.reference)?;
        Ok((c, Readings::boxed(plant)))
    };
    let measured = measure_learning_plant(
        &mut factory,
        learn.period,
        learning::MEASURE_PERIODS,
        LEARNING_AMPLITUDE,
    )?;
    let (law, rho) = learning::choose_law(
        &mut factory,
        &measured,
        &DesignParams::default(),
        learn.lag,
        learn.trials,
    )?;
    progress.note(&format!(
        "{} on {}: learning {}, ρ = {rho:.3}, datasheet lag {:.3} samples",
        j.controller.name,
        j.trajectory,
        law.describe(),
        learn.lag.samples()[0]
    ));
    let (mut plant, delay) = readings(setup, sim)?;
    let inner = design.build(actuator, delay, j.reference)?;
    let mut c = Learning::with_law(inner, &law)?.with_sensor_lag(learn.lag)?;
    let watch = watch(&j.reference, j.duration, dt);
    let advance = |n: usize| progress.advance(n as u64);
    // The trials a period at a time, so that only one period is ever recorded. On the twin
    // with the lab's fast ADC, the reading learned toward is corrected after every trial by
    // what the fast record shows the reading to exceed the output by (`Learning::retarget`).
    let period = learn.period as f64 * dt;
    let mut fast = match (sim, learn.fast_adc) {
        (Simulated::Twin(twin), Some(adc)) => {
            let mut rig = twin.plant(&setup.rig)?;
            let channel = FastChannel::attach(&adc, &mut rig)?;
            Some((rig, channel))
        }
        _ => None,
    };
    for _ in 0..learn.trials {
        let trial = match &mut fast {
            Some((rig, channel)) => {
                let mut recorded = FastRecorded {
                    plant: rig,
                    fast: channel,
                };
                let trial = run_watched(&mut c, &mut recorded, period, dt, &watch, advance);
                if trial.stopped.is_none() {
                    let record = channel.take_period(learn.period, dt)?;
                    c.retarget(&record.output_at_samples(&setup.rig.sensor)?)?;
                }
                trial
            }
            None => run_watched(&mut c, plant.as_mut(), period, dt, &watch, advance),
        };
        if trial.stopped.is_some() {
            return Ok((trial, None));
        }
    }
    let plant: &mut dyn StagePlant = match &mut fast {
        Some((rig, _)) => rig,
        None => plant.as_mut(),
    };
    let record = run_watched(&mut c, plant, j.duration, dt, &watch, advance);
    let table =
        (record.stopped.is_none() && c.ilc().periods() > 0).then(|| c.ilc().learned().to_vec());
    Ok((record, table))
}

/// An error beyond this many times the reference's range (peak to peak, the larger axis)
/// stops a run as diverged ([`watch`]).
pub const ERROR_BOUND_RANGES: f64 = 10.0;

/// The least error bound \[m\] ([`watch`]): a reference of zero or a few nm range still
/// allows the noise-level errors of a stage at rest.
pub const ERROR_BOUND_FLOOR: f64 = 1e-6;

/// The longest saturation without a break \[s\] before a run is stopped ([`watch`]).
pub const MAX_SATURATED: f64 = 0.2;

/// The bounds that stop a tracking run while it runs: an error beyond
/// [`ERROR_BOUND_RANGES`] × the reference's range (at least [`ERROR_BOUND_FLOOR`]), which
/// no stage that follows its reference reaches, or a command saturated for more than
/// [`MAX_SATURATED`] on end, during which the loop is open.
pub fn watch(reference: &Reference, duration: f64, dt: f64) -> WatchParams {
    let half = reference.half_range(duration, dt);
    WatchParams {
        max_error: (ERROR_BOUND_RANGES * 2.0 * half[0].max(half[1])).max(ERROR_BOUND_FLOOR),
        max_saturated: MAX_SATURATED,
    }
}

/// The jobs of the selected trajectories and controllers, each trajectory checked against the
/// rig and the simulated plant's static gain first (refused with the reason otherwise).
fn plan<'a>(
    s: &'a flexstage_scenario::Scenario,
    setup: &Setup,
    designs: &Designs,
    sim: &Simulated,
    options: &TrackOptions,
    warnings: &mut Vec<String>,
) -> Result<Vec<(Job<'a>, f64)>> {
    let trajectories: Vec<_> = s
        .trajectories
        .iter()
        .filter(|t| options.trajectory.as_deref().is_none_or(|n| t.name() == n))
        .collect();
    if trajectories.is_empty() {
        let names: Vec<&str> = s.trajectories.iter().map(|t| t.name()).collect();
        return Err(PipelineError::Option {
            option: "track.trajectory",
            value: format!("{:?}", options.trajectory.as_deref().unwrap_or("")),
            expected: format!("a trajectory of the scenario: {}", names.join(", ")),
        });
    }
    let dt = s.simulation.sample_time;
    let workspace = setup.workspace()?;
    let gain = match sim {
        Simulated::Twin(t) => Some(t.dc_gain()),
        Simulated::Lumped => None,
    };
    let mut jobs = Vec::new();
    let lag = SensorDatasheet::from_scenario(s).lag(dt)?;
    for t in &trajectories {
        let (reference, d) = Reference::from_scenario(t);
        let duration = options.duration.unwrap_or(d);
        let learning = match options.learning {
            Some(trials) => Some(Learn {
                trials,
                period: learning_period(&reference, dt, t.name())?,
                lag,
                fast_adc: LabParams::default()
                    .fast_adc
                    .map(|ratio| operating_fast_adc(&setup.rig, ratio)),
            }),
            None => None,
        };
        setup
            .check_reference(&reference, duration, gain)
            .map_err(|e| PipelineError::Format {
                path: format!("trajectory {:?}", t.name()),
                reason: format!("refused before the run: {e}"),
            })?;
        let usage = workspace.max_usage(&reference, duration, dt);
        if usage > 1.0 {
            warnings.push(format!(
                "trajectory {} leaves the designed workspace (uses {:.0} % of the stroke); \
                 expect saturation",
                t.name(),
                100.0 * usage
            ));
        }
        for &controller in &options.controllers {
            if designs.get(controller).is_none() {
                continue;
            }
            for learning in std::iter::once(None).chain(learning.map(Some)) {
                jobs.push((
                    Job {
                        trajectory: t.name(),
                        reference,
                        duration,
                        controller,
                        learning,
                    },
                    usage,
                ));
            }
        }
    }
    Ok(jobs)
}

/// The trajectories of the jobs, each with its reference, in order.
fn jobs_by_trajectory<'a>(jobs: &[(Job<'a>, f64)]) -> Vec<(&'a str, Reference, f64)> {
    let mut out: Vec<(&str, Reference, f64)> = Vec::new();
    for (j, _) in jobs {
        if !out.iter().any(|(t, _, _)| *t == j.trajectory) {
            out.push((j.trajectory, j.reference, j.duration));
        }
    }
    out
}

/// The controller's model: the given file (refused if it belongs to another run folder,
/// unless allowed), else the run's identified parameters, else the guess.
fn model_source(folder: &RunFolder, options: &TrackOptions) -> Result<ModelSource> {
    if let Some(p) = &options.params {
        if !options.allow_foreign_params
            && let Some(owner) = layout::run_of(p)
            && !same_file(&owner, folder.root())
        {
            return Err(PipelineError::ForeignParams {
                params: p.clone(),
                owner,
                target: folder.root().to_path_buf(),
            });
        }
        return Ok(ModelSource::File(p.clone()));
    }
    let identified = folder.dir().path(layout::stage::PARAMS);
    Ok(if identified.is_file() {
        ModelSource::Identified(identified)
    } else {
        ModelSource::Guess
    })
}

/// The true output path [µm] of one (trajectory, controller) pair, for Figure 11.
pub(crate) type Path2D = ((String, String), Vec<(f64, f64)>);

/// Writes each record's time series and error figure (Figures 9–10); returns the rows and
/// the output paths.
fn write_results(
    run: &RunDir,
    out: &Tracking,
    jobs: &[(Job, f64)],
    records: Vec<Result<Record>>,
    dt: f64,
) -> Result<(Vec<TrackRow>, Vec<Path2D>)> {
    let mut rows = Vec::with_capacity(jobs.len());
    let mut paths = Vec::with_capacity(jobs.len());
    for ((job, usage), rec) in jobs.iter().zip(records) {
        let rec = rec?;
        let variant = variant_name(job.controller, job.learning.is_some());
        let (t, v) = (job.trajectory, variant.as_str());
        // Written, not stored: the series is large, and its paths stay in memory for
        // Figure 11.
        let table = Table::of(&Record::header(), &rec.columns());
        run.write(&out.record(t, v), &table.to_csv())?;
        // Every sample: the figure draws the M4 envelope of each pixel column, which keeps
        // the peaks that taking every k-th sample would hide.
        let err = |i: usize| -> Vec<(f64, f64)> {
            (0..rec.len())
                .map(|k| (rec.t[k], rec.error[i][k] * 1e9))
                .collect()
        };
        let fig = Figure::new(
            format!("{t}, {v}: tracking error (Figures 9-10)"),
            "t [s]",
            "error [nm]",
        )
        .with(Series::line("q1 (horizontal)", err(0)))
        .with(Series::line("q2 (vertical)", err(1)));
        run.write(&out.error_svg(t, v), fig.to_svg()?.as_bytes())?;
        let key = (t.to_string(), v.to_string());
        paths.push((key, crate::track_files::scaled(&rec.truth, 1e6)));
        let half = job.reference.half_range(job.duration, dt);
        rows.push(TrackRow {
            trajectory: t.to_string(),
            controller: job.controller,
            learning: job.learning.is_some(),
            metrics: rec.metrics(half),
            usage: *usage,
        });
    }
    Ok((rows, paths))
}

/// The true output paths of a record \[m\] (columns `true1_m`, `true2_m`).
pub(crate) fn record_paths(t: &Table) -> Option<[Vec<f64>; 2]> {
    let c = t.columns(&["true1_m", "true2_m"]).ok()?;
    Some([c[0].to_vec(), c[1].to_vec()])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conditions_name_their_folder() {
        // Goal: the cases that used to overwrite `track/` get their own folders.
        let root = std::env::temp_dir().join(format!("flexstage-track-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let folder =
            RunFolder::open(crate::folder::preset("quick").unwrap(), &root, false).unwrap();
        let d = TrackOptions::default();
        assert_eq!(d.conditions(&folder), "");
        let off = TrackOptions {
            compensation: Compensation::Off,
            ..d.clone()
        };
        assert_eq!(off.conditions(&folder), "compensation-off");
        let reduced = folder.dir().write(layout::reduce::PARAMS, b"").unwrap();
        let p = TrackOptions {
            params: Some(reduced),
            duration: Some(0.5),
            ..off
        };
        assert_eq!(
            p.conditions(&folder),
            "compensation-off_params-reduce_duration-0.5s"
        );
        assert_eq!(
            Tracking::variant(&p.conditions(&folder)).dir(),
            "track/compensation-off_params-reduce_duration-0.5s"
        );
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn plant_names_round_trip_and_the_lumped_plant_gets_its_own_folder() {
        // Goal: `--plant` values, `metrics.csv` labels and folder names agree.
        for k in PlantKind::ALL {
            assert_eq!(PlantKind::from_name(k.name()), Some(k));
        }
        assert_eq!(PlantKind::from_name("rig"), None);
        assert_eq!(TrackOptions::default().plant, PlantKind::Twin);
        let root = std::env::temp_dir().join(format!("flexstage-plant-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let folder =
            RunFolder::open(crate::folder::preset("quick").unwrap(), &root, false).unwrap();
        let lumped = TrackOptions {
            plant: PlantKind::Lumped,
            ..TrackOptions::default()
        };
        assert_eq!(lumped.conditions(&folder), "plant-lumped");
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_trajectory_beyond_the_stroke_is_refused_before_the_run_naming_it() {
        // Reference: the digital-twin requirements: refused with the trajectory, the value and the limit.
        let mut s = crate::folder::preset("quick").unwrap();
        let name = s.trajectories[0].name().to_string();
        if let flexstage_scenario::Trajectory::Lissajous { amplitude, .. } = &mut s.trajectories[0]
        {
            amplitude[0] *= 5.0;
        }
        let setup = Setup::from_scenario(&s);
        let designs = Designs::for_stage(&Stage::scenario(&setup)).unwrap();
        let options = TrackOptions {
            trajectory: Some(name.clone()),
            ..TrackOptions::default()
        };
        let mut warnings = Vec::new();
        let e = plan(
            &s,
            &setup,
            &designs,
            &Simulated::Lumped,
            &options,
            &mut warnings,
        )
        .err()
        .expect("refused");
        let m = e.to_string();
        assert!(
            m.contains(&name) && m.contains("stroke") && m.contains("µm"),
            "{m}"
        );
        // The defaults fit.
        let all = TrackOptions::default();
        let s = crate::folder::preset("quick").unwrap();
        let setup = Setup::from_scenario(&s);
        let designs = Designs::for_stage(&Stage::scenario(&setup)).unwrap();
        assert!(
            plan(
                &s,
                &setup,
                &designs,
                &Simulated::Lumped,
                &all,
                &mut warnings
            )
            .is_ok()
        );
    }

    /// Goal: learning accepts the periodic references whose period is a whole number of
    /// samples (the 3:1 Lissajous at 2 Hz: 5000 samples at 10 kHz; a circle) and refuses a
    /// step, a non-whole ratio and a fractional period with a typed error naming the
    /// option and the trajectory; the trials are checked against their range.
    #[test]
    fn learning_needs_a_periodic_reference_of_whole_samples() {
        let dt = 1e-4;
        let liss = |ratio: f64, frequency: f64| {
            Reference::new(Shape::Lissajous {
                ratio,
                amplitude: [1e-6, 1e-6],
                frequency,
            })
        };
        assert_eq!(learning_period(&liss(3.0, 2.0), dt, "l").unwrap(), 5000);
        let circle = Reference::new(Shape::Circle {
            radius: 1e-6,
            frequency: 4.0,
        });
        assert_eq!(learning_period(&circle, dt, "c").unwrap(), 2500);
        let step = Reference::new(Shape::Step { target: [1e-6; 2] });
        for (r, why) in [
            (step, "not periodic"),
            (liss(1.5, 2.0), "ratio 1.5"),
            (liss(3.0, 3.0), "3333.3"),
        ] {
            let e = learning_period(&r, dt, "scan").unwrap_err().to_string();
            assert!(
                e.contains("track.learning") && e.contains("\"scan\"") && e.contains(why),
                "{e}"
            );
        }
        for (n, ok) in [(0, false), (1, true), (200, true), (201, false)] {
            let o = TrackOptions {
                learning: Some(n),
                ..TrackOptions::default()
            };
            assert_eq!(o.validate().is_ok(), ok, "{n}");
        }
    }

    #[test]
    fn a_damaged_pea_estimates_file_is_an_error_not_the_scenario() {
        // Goal: without estimates the compensator keeps the scenario's PEAs and says so; an
        // estimates file that exists but does not parse stops `track` with its name, never
        // falls back to the scenario silently.
        let root = std::env::temp_dir().join(format!("flexstage-peaest-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let s = crate::folder::preset("quick").unwrap();
        let folder = RunFolder::open(s.clone(), &root, false).unwrap();
        let mut setup = Setup::from_scenario(&s);
        let used = identified_peas(&folder, &mut setup).unwrap();
        assert_eq!(used, ["scenario [hysteresis]", "scenario [hysteresis]"]);
        let rel = layout::PeaIdentification { pea: 2 }.estimates();
        folder.dir().write(&rel, b"d_p = 1\n").unwrap();
        let e = identified_peas(&folder, &mut setup)
            .unwrap_err()
            .to_string();
        assert!(e.contains(&rel), "{e}");
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn params_of_another_run_are_refused_unless_allowed() {
        let base = std::env::temp_dir().join(format!("flexstage-foreign-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&base);
        let quick = crate::folder::preset("quick").unwrap();
        let a = RunFolder::open(quick.clone(), base.join("a"), false).unwrap();
        let b = RunFolder::open(quick, base.join("b"), false).unwrap();
        let p = a.dir().write(layout::reduce::PARAMS, b"").unwrap();
        let mut o = TrackOptions {
            params: Some(p.clone()),
            ..TrackOptions::default()
        };
        assert_eq!(model_source(&a, &o).unwrap(), ModelSource::File(p.clone()));
        let e = model_source(&b, &o).unwrap_err();
        assert!(matches!(e, PipelineError::ForeignParams { .. }), "{e}");
        o.allow_foreign_params = true;
        assert_eq!(model_source(&b, &o).unwrap(), ModelSource::File(p));
        std::fs::remove_dir_all(&base).unwrap();
    }

    /// Reference: the designs of `Bench::measured` from the same measurement in memory
    /// (same twin, rig, seeds and lab settings: the fast ADC's lifted response included).
    /// Goal: `track`'s designs, made from the measurement after it went through its run
    /// files' typed rows (`measured_response.csv`, `lifted_response.csv`) and was read back,
    /// are the same bitwise, feedback and feed-forward (the files lose nothing a design
    /// uses), the feed-forward fitted to the lifted response; on the rhombus fixture.
    #[test]
    fn track_designs_from_its_measured_response_file_as_from_the_measurement() {
        let (s, rho) = flexstage_twin::samples::quick_rhombus().unwrap();
        let twin = flexstage_twin::Twin::from_scenario(&s, &rho).unwrap();
        let setup = Setup::from_scenario(&s);
        let (bench, files) =
            measured_bench(&setup, &twin, false, &crate::progress::Silent).unwrap();
        assert_eq!(files.response.0.len(), 999);
        let lifted = files.lifted.clone().unwrap();
        assert_eq!(lifted.0.len(), 999 * flexstage_assess::lab::FAST_ADC_RATIO);
        // The rows stored in a run folder and loaded by a fresh session (what the
        // Monte-Carlo study reads when `track` stored them).
        let dir = std::env::temp_dir().join(format!("flexstage-measured-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let out = Tracking::main();
        let run = RunDir::create(&dir).unwrap();
        run.store(&out.measured_response(), files.response.clone())
            .unwrap();
        run.store(&out.lifted_response(), lifted).unwrap();
        let fresh = RunDir::create(&dir).unwrap();
        let loaded = MeasuredFiles {
            response: (*fresh
                .load::<Rows<MeasuredLineRow>>(&out.measured_response())
                .unwrap()
                .unwrap())
            .clone(),
            lifted: fresh
                .load::<Rows<LiftedLineRow>>(&out.lifted_response())
                .unwrap()
                .map(|l| (*l).clone()),
        };
        assert_eq!(loaded, files);
        let stored = bench_from_rows(
            &setup,
            &twin,
            &loaded,
            false,
            &crate::progress::Silent,
            std::time::Instant::now(),
        )
        .unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        let (direct, _) =
            Bench::measured(setup, twin, TuningParams::default(), &LabParams::default()).unwrap();
        for b in [&bench, &stored, &direct] {
            assert_eq!(b.feedforward, FeedForwardFit::Lifted);
        }
        for c in [
            &flexstage_control::pi_notch::PI_NOTCH_FF,
            &flexstage_control::pid::PID_FF,
        ] {
            let of = |b: &Bench| {
                let d = b.design(c).unwrap();
                let ff = d.feedforward().unwrap();
                format!(
                    "{:?} {} {} {:?}",
                    b.linear_params(c).unwrap().unwrap(),
                    ff.preview(),
                    ff.lag(),
                    ff.taps()
                )
            };
            let want = of(&direct);
            for from in [&bench, &stored] {
                assert_eq!(of(from), want, "{c}");
            }
        }
        assert_eq!(bench.identified, direct.identified);
        assert_eq!(stored.identified, direct.identified);
    }
}
