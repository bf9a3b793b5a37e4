//! `identify stage`: online least-squares identification of the stage stiffnesses and
//! dampings (Section 4.2, Eq. 54–56, Table 4) from a logged record or from the simulated
//! stage of the run ([`Plant::of_run`]).
//!
//! # Two methods, one per plant
//! * **Lumped model** (the default, [`Simulation::plant`]): the paper's time-domain
//!   regression (Eq. 54–56) on a two-band multisine, the low band (5–150 Hz) and a resonance
//!   band derived from the natural frequencies of the run's lumped model
//!   (`flexstage_identify::resonance_plan`), with the output rows' prefilter above it and the
//!   discretization corrected at the modes. Its truth is the plant's own parameters (the
//!   reduced design's `reduce/params.toml`, or the scenario's `stage.truth` before a design)
//!   and coupling; masses and α are known (Section 4.2).
//! * **On the twin** (`--plant twin`): no lumped parameter set is the twin (its modes, its
//!   second output mode above Nyquist, the plates inside the structure), so the regression's
//!   estimates have nothing to meet. What the controller takes from such a plant is the
//!   response fit (`flexstage_identify::response::ResponseFit`: static gain, the output modes
//!   below the controller's Nyquist frequency), and that is what is identified, by the
//!   frequency-response method of `flexstage_identify::response` on a multisine record
//!   acquired 5× faster than the controller samples (free of folded modes), with a band up
//!   to 1.2× the controller's Nyquist frequency. The identified fit becomes the parameter set
//!   by `fit_to_response` on the design's reduced model (K_in from the static gain, M from
//!   the q_o2 mode with the design's K_qo2, C_qo2 from its damping, α from the differential
//!   gain, K_qo1 and C_qo1 from a q_o1 mode when one lies below Nyquist, else the design's)
//!   and the coupling by `fit_coupling`. The truth is the same chain on the twin's exact
//!   modes (`ResponseFit::from_modes`), and only the identified quantities are scored
//!   (`docs/DECISIONS.md`, "Stage identification that closes the loop").
//!
//! The identified `params.toml` carries the cross-axis `coupling` k_c as a field; `track`
//! builds the controller's model with it ([`crate::plant::ModelParams`]).

use flexstage_scenario::RecordEstimate;
use std::path::PathBuf;

use flexstage_control::experiment::Setup;
use flexstage_control::fit::{fit_coupling, fit_to_response};
use flexstage_figures::plot::{Figure, Series};
use flexstage_identify::frequency::{C64, Response};
use flexstage_identify::regression::paper_theta;
use flexstage_identify::response::ResponseFit;
use flexstage_identify::response::{
    ACQUISITION_FACTOR, ResponseIdentification, ResponseParams, acquisition_rig, identify_response,
    response_excitation,
};
use flexstage_identify::{
    Band, Excitation, Identification, IdentifyParams, RESONANCE_AMPLITUDE, RigExperiment,
    StageRecord, resonance_plan, samples,
};
use flexstage_run::files::stage::{
    ParameterRow as TableRow, RESPONSE_FIT_VERSION, ResponseFitFile, ResponseRow, StageParamsFile,
};
use flexstage_run::format::Rows;
use flexstage_run::layout::{self, stage as files};
use flexstage_run::{RunDir, Table};
use flexstage_scenario::StageParams;
use flexstage_sim::model::StageModel;
use flexstage_sim::plant::PlantActuator;

use crate::error::{PipelineError, Result, require};
use crate::folder::RunFolder;
use crate::plant::{Plant, PlantSource};
use crate::progress::Progress;
use crate::track::{PlantKind, TwinBuild, try_build};

/// The longest simulated excitation \[s\] (bounded work: 6·10⁶ samples at 10 kHz).
pub const MAX_DURATION: f64 = 600.0;

/// Default length of the response experiment on the twin \[s\]. Measured on the quick
/// design with the default rig and sensors (`tests/stage_twin.rs`, 10 seeds): K_in, whose
/// effect on the static gain is 4·10⁻⁴ (the plate's spring against the PEA's), within 2.6 %
/// at 16 s and 3.1 % at 8 s; its scatter falls as 1/√duration. Every other identified
/// quantity is within 0.3 % (dampings 2.3 %) already at 4 s.
pub const TWIN_DURATION: f64 = 16.0;

/// Shortest excitation `run` gives the identification on the twin \[s\] (when its options ask
/// for less, e.g. in tests): two whole periods of the default 5 Hz multisine after the
/// default 0.2 s of settling.
pub const MIN_TWIN_DURATION: f64 = 0.6;

/// The simulated excitation of the stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Simulation {
    /// The simulated stage: the lumped model of the run (the default: the paper's method and
    /// its Table 4), or the digital twin of the run's design in the scenario's rig (`--plant
    /// twin`, as in `track`, identified by its frequency response, module docs; the lumped
    /// model before the run has a design or when the twin cannot be built, with a warning).
    pub plant: PlantKind,
    /// Excitation length \[s\], in (0, 600]; `None`: 8 s on the lumped model (the low band's
    /// K_in needs it with the default sensor noise; 1 s is enough without noise),
    /// [`TWIN_DURATION`] on the twin.
    pub duration: Option<f64>,
    /// Highest line of the low band \[Hz\] ([`Excitation::validate`]). Default 150.
    pub f_max: f64,
    /// Peak per PEA of the resonance band \[m\] around the reduced model's output modes
    /// ([`Band::around_modes`]), taken from the 90 %-of-stroke budget of the low band; 0
    /// switches the band off (the low band alone, the dampings then unidentifiable). Default
    /// [`RESONANCE_AMPLITUDE`].
    pub resonance_amplitude: f64,
    /// Linear actuators (x_nom applied directly, no cross terms on the lumped model: the model
    /// of Eq. 36; an ideal actuator in the rig on the twin) instead of the Bouc–Wen PEAs.
    /// Default false.
    pub linear: bool,
    /// Sensor noise and quantization on. Default true.
    pub noise: bool,
}

impl Default for Simulation {
    fn default() -> Self {
        Simulation {
            plant: PlantKind::Lumped,
            duration: None,
            f_max: Excitation::default().f_max,
            resonance_amplitude: RESONANCE_AMPLITUDE,
            linear: false,
            noise: true,
        }
    }
}

/// Where the record comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum StageData {
    /// Excite the run's simulated stage with a multisine and log it.
    Simulate(Simulation),
    /// A CSV with columns t \[s\], x_nom1, x_nom2 \[m\] (or U1, U2 \[V\]), x_in1, x_in2, q1, q2 \[m\],
    /// uniformly sampled.
    Record(PathBuf),
    /// The same columns in memory (e.g. arrays from Python), checked as a record file's;
    /// `origin` names them in messages and in the parameter file.
    Columns {
        /// Time \[s\], uniformly sampled.
        t: Vec<f64>,
        /// x_nom1, x_nom2 \[m\] or U1, U2 \[V\].
        input: flexstage_identify::data::Input,
        /// x_in1, x_in2, q1, q2 \[m\].
        columns: flexstage_identify::data::Columns,
        /// What the columns are, for messages.
        origin: String,
    },
}

impl Default for StageData {
    fn default() -> Self {
        StageData::Simulate(Simulation::default())
    }
}

/// Options of the stage identification.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StageIdOptions {
    /// The record.
    pub data: StageData,
    /// Estimator settings (forgetting factor, prefilter, decimation, regressor scheme,
    /// coupling column), checked by [`IdentifyParams::validate`].
    pub estimator: IdentifyParams,
}

impl StageIdOptions {
    /// Checks every option.
    pub fn validate(&self) -> Result<()> {
        if let StageData::Simulate(Simulation {
            duration,
            resonance_amplitude,
            ..
        }) = self.data
        {
            let duration = duration.unwrap_or(TWIN_DURATION);
            require(
                duration.is_finite() && duration > 0.0 && duration <= MAX_DURATION,
                "identify_stage.duration",
                duration,
                "a duration in (0, 600] s",
            )?;
            require(
                resonance_amplitude.is_finite() && resonance_amplitude >= 0.0,
                "identify_stage.resonance_amplitude",
                resonance_amplitude,
                "a displacement ≥ 0 m, below the low band's peak (0: no resonance band)",
            )?;
        }
        self.estimator.validate()?;
        Ok(())
    }
}

/// One row of the Table 4 comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterRow {
    /// Parameter name (e.g. `k_qo1`).
    pub name: String,
    /// Unit.
    pub unit: String,
    /// The initial guess.
    pub guess: f64,
    /// The estimate.
    pub estimate: f64,
    /// The truth, when the record is simulated.
    pub truth: Option<f64>,
}

impl ParameterRow {
    /// Relative error of the estimate against the truth \[%\].
    pub fn error_pct(&self) -> Option<f64> {
        self.truth.map(|t| 100.0 * (self.estimate - t) / t)
    }
}

impl From<&TableRow> for ParameterRow {
    fn from(r: &TableRow) -> Self {
        ParameterRow {
            name: r.parameter.clone(),
            unit: r.unit.clone(),
            guess: r.guess,
            estimate: r.estimate,
            truth: r.truth,
        }
    }
}

/// What the stage identification found.
#[derive(Debug, Clone)]
pub struct StageIdSummary {
    /// The lumped model of the run (for a simulated record): the reduced design or the
    /// scenario's truth.
    pub plant: Option<PlantSource>,
    /// The stage simulated (for a simulated record): the twin or the lumped model.
    pub simulated: Option<PlantKind>,
    /// The resonance band of the excitation (for a simulated record with one).
    pub band: Option<Band>,
    /// What the estimates are scored against (for a simulated record).
    pub truth: Option<Truth>,
    /// Samples of the record.
    pub samples: usize,
    /// The sample time of the record \[s\].
    pub sample_time: f64,
    /// The time-domain regression (on the lumped model or a logged record).
    pub identification: Option<Identification>,
    /// The frequency-response identification (on the twin), with the truth's fit.
    pub response: Option<(ResponseIdentification, ResponseFit)>,
    /// The identified parameter set.
    pub params: StageParams,
    /// The identified cross-axis coupling k_c \[N/m\].
    pub coupling: f64,
    /// What the user should know.
    pub warnings: Vec<String>,
    /// Guess / estimate / truth per parameter (Table 4).
    pub rows: Vec<ParameterRow>,
    /// The identified parameter file ([`files::PARAMS`], on the twin [`files::TWIN_PARAMS`]).
    pub params_file: PathBuf,
    /// The stage folder.
    pub dir: PathBuf,
    /// Whether earlier results were replaced.
    pub replaced: bool,
    /// `run`'s second identification, on the twin, after the lumped model's.
    pub on_twin: Option<Box<StageIdSummary>>,
}

/// The reference a simulated identification is scored against.
#[derive(Debug, Clone, PartialEq)]
pub struct Truth {
    /// The parameter set.
    pub params: StageParams,
    /// The cross-axis coupling k_c \[N/m\].
    pub coupling: f64,
}

/// Identifies the stage parameters and writes `identify/stage/` (on the twin:
/// `identify/stage/twin/`, building the twin of the design).
pub fn identify_stage(
    folder: &RunFolder,
    options: &StageIdOptions,
    progress: &dyn Progress,
) -> Result<StageIdSummary> {
    identify_stage_on(folder, options, progress, None)
}

/// A simulated record, what it is scored against and its band.
struct Simulated {
    record: StageRecord,
    truth: Truth,
    band: Option<Band>,
}

/// [`identify_stage`] with the twin `run` built in its twin stage (`None`: builds it when the
/// simulation runs on the twin).
pub fn identify_stage_on(
    folder: &RunFolder,
    options: &StageIdOptions,
    progress: &dyn Progress,
    prebuilt: Option<&TwinBuild>,
) -> Result<StageIdSummary> {
    options.validate()?;
    let plant = Plant::of_run(folder)?;
    let guess = plant.scenario.stage.guess.clone();
    let mut estimator = options.estimator.clone();
    let mut warnings = Vec::new();
    let (record, sim) = match &options.data {
        StageData::Simulate(sim) => {
            if sim.plant == PlantKind::Twin
                && let Some(twin) = twin_of(folder, progress, prebuilt, &mut warnings)?
            {
                return identify_on_twin(folder, &plant, sim, &twin, progress, warnings);
            }
            let s = simulate_stage(&plant, sim, &mut estimator, progress)?;
            (s.record.clone(), Some(s))
        }
        StageData::Record(path) => (read_record(folder, path, &estimator)?, None),
        StageData::Columns {
            t, input, columns, ..
        } => {
            let setup = Setup::from_scenario(folder.scenario());
            let record = StageRecord::from_input(
                t.clone(),
                input.clone(),
                columns.clone(),
                &setup.plant.hysteresis,
                setup.plant.bias_voltage,
                estimator.sampling_tolerance,
            )?;
            (record, None)
        }
    };
    let source = match &options.data {
        StageData::Simulate(_) => "a simulated record on the lumped model".to_string(),
        StageData::Record(p) => p.display().to_string(),
        StageData::Columns { origin, .. } => origin.clone(),
    };
    let id = flexstage_identify::identify(&record, &guess, &estimator)?;
    warnings.extend(id.warnings.iter().cloned());
    let run = folder.dir();
    let replaced = folder.has_results(files::DIR);
    if sim.is_some() {
        run.write(files::RECORD, record.to_csv().as_bytes())?;
    }
    run.store(files::PARAMS, params_file(&id, &source))?;
    let params_file = run.path(files::PARAMS);
    let truth = sim.as_ref().map(|s| s.truth.clone());
    let rows = rows(&guess, &id.raw.params, truth.as_ref().map(|t| &t.params));
    let kc = 0.5 * (id.raw.coupling[0] + id.raw.coupling[1]);
    run.store(
        files::TABLE,
        table(&rows, kc, truth.as_ref().map(|t| t.coupling)),
    )?;
    write_convergence(run, &id, truth.as_ref().map(|t| &t.params))?;
    Ok(StageIdSummary {
        plant: sim.as_ref().map(|_| plant.source.clone()),
        simulated: sim.as_ref().map(|_| PlantKind::Lumped),
        band: sim.as_ref().and_then(|s| s.band),
        truth,
        samples: record.len(),
        sample_time: record.sample_time(),
        params: id.params.clone(),
        coupling: id.coupling,
        identification: Some(id),
        response: None,
        warnings,
        rows,
        params_file,
        dir: run.path(files::DIR),
        replaced,
        on_twin: None,
    })
}

/// Simulates the excitation on the lumped model; sets the output rows' prefilter above the
/// resonance band.
fn simulate_stage(
    plant: &Plant,
    o: &Simulation,
    estimator: &mut IdentifyParams,
    progress: &dyn Progress,
) -> Result<Simulated> {
    let duration = o.duration.unwrap_or(Excitation::default().duration);
    let mut sim = samples::simulation(&plant.scenario, duration, o.linear, o.noise);
    sim.excitation.f_max = o.f_max;
    let ts = sim.plant.sample_time;
    // time, x_nom, x_in, q per axis, before the simulation allocates them.
    RecordEstimate::new(duration, ts, sim.oversample, 0, 7).check(
        "identify_stage.duration",
        duration,
        flexstage_identify::data::MIN_SAMPLES as f64,
    )?;
    estimator.validate_sampling(ts)?;
    // The band from the lumped model's output modes (the reduced design's, with the plant's
    // cross terms), as a practitioner would plan it from the design.
    let lumped = StageModel::with_coupling(&plant.scenario.stage.truth, sim.plant.coupling)?;
    let plan = resonance_plan(&lumped, ts, o.resonance_amplitude);
    let band = plan.map(|p| p.0);
    sim.excitation.resonance = band;
    sim.excitation.validate()?;
    if let Some((_, cut)) = plan {
        estimator.output_prefilter = Some(cut);
        estimator.resonant = true;
    }
    note_excitation(progress, &sim.excitation, &plant.source.to_string());
    if !o.linear {
        sim.plant.actuator = PlantActuator::Hysteretic;
    }
    let record = flexstage_identify::simulate(&sim)?;
    let truth = Truth {
        params: sim.plant.truth.clone(),
        coupling: sim.plant.coupling,
    };
    Ok(Simulated {
        record,
        truth,
        band,
    })
}

fn note_excitation(progress: &dyn Progress, e: &Excitation, on: &str) {
    progress.note(&format!(
        "simulating {} s of multisine excitation ({}–{} Hz, peak {:.1} µm{}) on {on}",
        e.duration,
        e.f_min,
        e.f_max,
        e.amplitude * 1e6,
        e.resonance
            .map(|b| format!(
                "; band {:.0}–{:.0} Hz, peak {:.1} µm",
                b.f_lo,
                b.f_hi,
                b.amplitude * 1e6
            ))
            .unwrap_or_default(),
    ));
}

/// The frequency-response identification on a twin, scored ([`identify_twin_response`]).
#[derive(Debug, Clone)]
pub struct TwinIdentification {
    /// The identification (fit, fitted peaks, measured lines).
    pub response: ResponseIdentification,
    /// The same fit from the twin's exact modes.
    pub exact: ResponseFit,
    /// The band of the experiment above its low band (`None` when switched off).
    pub band: Option<Band>,
    /// Samples and sample time \[s\] of the record.
    pub samples: usize,
    /// Sample time of the record \[s\].
    pub sample_time: f64,
    /// The identified parameter set (the controller's model).
    pub params: StageParams,
    /// The identified coupling k_c \[N/m\].
    pub coupling: f64,
    /// The same chain on the exact fit.
    pub truth: Truth,
    /// The identified quantities, guess / estimate / truth.
    pub rows: Vec<ParameterRow>,
}

/// Runs the response experiment of `o` on `twin` in the rig of `scenario` (whose
/// `stage.truth`, the design's reduced model in a designed run, is the prior the response
/// updates), identifies the response fit and scores
/// it against the fit of the twin's exact modes (module docs, "On the twin").
pub fn identify_twin_response(
    scenario: &flexstage_scenario::Scenario,
    twin: &flexstage_twin::Twin,
    o: &Simulation,
    progress: &dyn Progress,
) -> Result<TwinIdentification> {
    let setup = Setup::from_scenario(scenario);
    let mut rig = acquisition_rig(&setup.rig, ACQUISITION_FACTOR);
    if o.linear {
        rig.actuator = PlantActuator::Ideal;
    }
    if !o.noise {
        rig.resolution = [0.0; 2];
        rig.noise_std = [0.0; 2];
        rig.sensor.flicker_corner = 0.0;
    }
    let duration = o.duration.unwrap_or(TWIN_DURATION);
    // time, x_nom, x_in, q, voltage per axis, before the simulation allocates them.
    RecordEstimate::new(duration, rig.sample_time, 1, 0, 9).check(
        "identify_stage.duration",
        duration,
        flexstage_identify::data::MIN_SAMPLES as f64,
    )?;
    let sim = samples::simulation(scenario, duration, o.linear, o.noise);
    let nyquist = 0.5 / setup.rig.sample_time;
    let mut low = sim.excitation.clone();
    low.f_max = o.f_max;
    let mut e = response_excitation(&low, nyquist);
    match (&mut e.resonance, o.resonance_amplitude > 0.0) {
        (Some(b), true) => b.amplitude = o.resonance_amplitude,
        _ => e.resonance = None,
    }
    e.validate()?;
    note_excitation(
        progress,
        &e,
        &format!(
            "the twin of the design, sampled at {:.0} kHz",
            1e-3 / rig.sample_time
        ),
    );
    let exp = RigExperiment {
        excitation: e.clone(),
        plate_sensor: sim.plate_sensor,
        slope: sim.slope,
        bias_voltage: sim.plant.bias_voltage,
        voltage_range: sim.plant.voltage_range,
        seed: sim.plant.seed,
    };
    let record = flexstage_identify::simulate_rig(&mut twin.plant(&rig)?, &exp)?;
    let rp = ResponseParams::new(setup.rig.sample_time, setup.rig.sensor);
    let response = identify_response(&record, &e, &rp)?;
    // The prior is the design's reduced model (`stage.truth` of a designed run): what the
    // response cannot show (K_pea, the plate masses, K_qo2 with M, K_qo1 without a q_o1
    // mode below Nyquist) is the design's.
    let guess = &scenario.stage.truth;
    let params = fit_to_response(guess, &response.fit)?;
    let coupling = fit_coupling(&params, response.fit.dc_gain)?;
    let modes = twin.modal.plant_modes();
    let exact = ResponseFit::from_modes(&modes, nyquist, rp.share);
    let truth_params = fit_to_response(guess, &exact)?;
    let truth = Truth {
        coupling: fit_coupling(&truth_params, exact.dc_gain)?,
        params: truth_params,
    };
    let rows = response_rows(guess, &params, &truth.params, &response.fit, &exact);
    Ok(TwinIdentification {
        exact,
        band: e.resonance,
        samples: record.len(),
        sample_time: record.sample_time(),
        params,
        coupling,
        truth,
        rows,
        response,
    })
}

/// The response fit as its file ([`files::RESPONSE_FIT`], read back by
/// [`response_fit_of`]).
pub fn response_fit_file(fit: &ResponseFit) -> ResponseFitFile {
    ResponseFitFile {
        version: RESPONSE_FIT_VERSION,
        dc_gain: fit.dc_gain,
        frequency: fit.frequency.map(|f| f.unwrap_or(0.0)),
        damping: fit.damping,
    }
}

/// The response fit of its file, checked ([`ResponseFit::validate`]); `path` names it in
/// messages.
pub fn response_fit_of(file: &ResponseFitFile, path: &std::path::Path) -> Result<ResponseFit> {
    let fit = ResponseFit {
        dc_gain: file.dc_gain,
        frequency: file.frequency.map(|v| (v != 0.0).then_some(v)),
        damping: file.damping,
    };
    fit.validate().map_err(|e| PipelineError::Format {
        path: path.display().to_string(),
        reason: format!("not a response fit: {e}"),
    })?;
    Ok(fit)
}

/// [`identify_twin_response`] on the run's plant, written to `identify/stage/twin/`.
fn identify_on_twin(
    folder: &RunFolder,
    plant: &Plant,
    o: &Simulation,
    twin: &flexstage_twin::Twin,
    progress: &dyn Progress,
    warnings: Vec<String>,
) -> Result<StageIdSummary> {
    let t = identify_twin_response(&plant.scenario, twin, o, progress)?;
    let run = folder.dir();
    let replaced = folder.has_results(files::TWIN_DIR);
    run.store(
        files::TWIN_PARAMS,
        response_params_file(&t.params, t.coupling, &t.response.fit),
    )?;
    let params_file = run.path(files::TWIN_PARAMS);
    run.store(
        files::TWIN_TABLE,
        table(&t.rows, t.coupling, Some(t.truth.coupling)),
    )?;
    write_response(run, &t.response, twin)?;
    run.store(files::RESPONSE_FIT, response_fit_file(&t.response.fit))?;
    Ok(StageIdSummary {
        plant: Some(plant.source.clone()),
        simulated: Some(PlantKind::Twin),
        band: t.band,
        truth: Some(t.truth),
        samples: t.samples,
        sample_time: t.sample_time,
        identification: None,
        response: Some((t.response, t.exact)),
        params: t.params,
        coupling: t.coupling,
        warnings,
        rows: t.rows,
        params_file,
        dir: run.path(files::TWIN_DIR),
        replaced,
        on_twin: None,
    })
}

/// The rows of what the response fit identifies: K_in from the static gain, M from the q_o2
/// mode (K_qo2 kept), α, C_qo2, and K_qo1, C_qo1 when either fit has a q_o1 mode.
fn response_rows(
    guess: &StageParams,
    estimate: &StageParams,
    truth: &StageParams,
    fit: &ResponseFit,
    exact: &ResponseFit,
) -> Vec<ParameterRow> {
    let row = |name: &str, unit: &str, f: fn(&StageParams) -> f64| ParameterRow {
        name: name.into(),
        unit: unit.into(),
        guess: f(guess),
        estimate: f(estimate),
        truth: Some(f(truth)),
    };
    // Whether each axis has a mode (in either fit): its stiffness and damping are scored.
    let mode = [0, 1].map(|i| fit.frequency[i].is_some() || exact.frequency[i].is_some());
    let mut rows = Vec::new();
    if mode[0] {
        rows.push(row("k_qo1", "N/m", |p| p.k_qo1));
    }
    rows.push(row("k_in1", "N/m", |p| p.k_in1));
    rows.push(row("k_in2", "N/m", |p| p.k_in2));
    if mode[1] {
        rows.push(row("mass", "kg", |p| p.mass));
    }
    rows.push(row("alpha", "-", |p| p.alpha));
    if mode[0] {
        rows.push(row("c_qo1", "N s/m", |p| p.c_qo1));
    }
    if mode[1] {
        rows.push(row("c_qo2", "N s/m", |p| p.c_qo2));
    }
    rows
}

fn response_params_file(p: &StageParams, coupling: f64, fit: &ResponseFit) -> StageParamsFile {
    let mode = |i: usize| {
        fit.frequency[i].map_or(
            "none below Nyquist (stiffness and damping kept)".into(),
            |f| format!("{f:.2} Hz, damping ratio {:.5}", fit.damping[i]),
        )
    };
    let header = [
        "Stage parameters identified by `flexstage identify stage --plant twin` from the".into(),
        "twin's frequency response (static gain and the output modes below Nyquist,".into(),
        "ResponseFit -> fit_to_response; K_pea, plate masses and K_qo2 are the design's).".into(),
        format!("static gain x_nom -> q: {:?}", fit.dc_gain),
        format!("q_o1 mode: {}", mode(0)),
        format!("q_o2 mode: {}", mode(1)),
        "coupling: the cross-axis coupling stiffness k_c [N/m] of Eq. (30) that reproduces".into(),
        "the static gain's cross terms (fit_coupling).".into(),
        "A model for `flexstage track --params`; `track` on the twin sets the backstepping".into(),
        "up from response_fit.toml on the run's identified model.".into(),
    ];
    StageParamsFile {
        header: header.to_vec(),
        documented: false,
        coupling: Some(coupling),
        params: p.clone(),
    }
}

/// The measured response per line (`response.csv`) and its Bode magnitude against the twin's
/// exact response (`response.svg`).
fn write_response(
    run: &RunDir,
    id: &ResponseIdentification,
    twin: &flexstage_twin::Twin,
) -> Result<()> {
    let rows = id
        .lines
        .iter()
        .map(|l| {
            let (a, b) = (l.h(0), l.h(1));
            ResponseRow {
                f_hz: l.f,
                pea: l.driver + 1,
                h_q1_re: a.re,
                h_q1_im: a.im,
                h_q2_re: b.re,
                h_q2_im: b.im,
            }
        })
        .collect();
    run.store(files::RESPONSE_CSV, Rows(rows))?;
    let mut fig = Figure::new(
        "Stage identification on the twin: measured response (points) and exact (lines)",
        "f [Hz]",
        "|q / x_nom,1| [dB]",
    );
    let db = |h: C64| 20.0 * h.norm().log10();
    for i in 0..2 {
        let measured: Vec<(f64, f64)> = id
            .lines
            .iter()
            .filter(|l| l.driver == 0)
            .map(|l| (l.f, db(l.h(i))))
            .collect();
        let exact: Vec<(f64, f64)> = id
            .lines
            .iter()
            .map(|l| (l.f, db(twin_response(twin, l.f).q[0][i])))
            .collect();
        fig = fig
            .with(Series::points(format!("q_o{} measured", i + 1), measured))
            .with(Series::line(format!("q_o{} exact", i + 1), exact));
    }
    run.write(files::RESPONSE_SVG, fig.to_svg()?.as_bytes())?;
    Ok(())
}

/// The twin's linear response at `f` Hz to unit x_nom of each PEA: x_in and q from its
/// modes, `Σ_k c_k in_kᵀ / (ω_k² − ω² + 2jζ_kω_kω)` with c_k its plate or output shape.
pub fn twin_response(twin: &flexstage_twin::Twin, f: f64) -> Response {
    let w = std::f64::consts::TAU * f;
    let zero = C64::new(0.0, 0.0);
    let mut r = Response {
        f,
        x_in: [[zero; 2]; 2],
        q: [[zero; 2]; 2],
    };
    for m in &twin.modal.modes {
        let wk = std::f64::consts::TAU * m.frequency;
        let h = C64::new(1.0, 0.0) / C64::new(wk * wk - w * w, 2.0 * m.damping * wk * w);
        for j in 0..2 {
            for i in 0..2 {
                r.x_in[j][i] += m.plates[i] * m.input[j] * h;
                r.q[j][i] += m.output[i] * m.input[j] * h;
            }
        }
    }
    r
}

/// The twin of the run's design: the prebuilt one, else built now; `None` (with a warning)
/// before the run has a design or when the twin cannot model it.
fn twin_of(
    folder: &RunFolder,
    progress: &dyn Progress,
    prebuilt: Option<&TwinBuild>,
    warnings: &mut Vec<String>,
) -> Result<Option<flexstage_twin::Twin>> {
    if !folder.dir().exists(layout::design::DESIGN) {
        warnings.push(
            "the run has no finished design yet, so the stage is identified on the lumped \
             model (`flexstage design` first for the twin of the designed stage)"
                .into(),
        );
        return Ok(None);
    }
    let built;
    let built = match prebuilt {
        Some(b) => b,
        None => {
            built = try_build(folder, progress)?;
            &built
        }
    };
    match built {
        Ok(b) => Ok(Some(b.twin.clone())),
        Err(e) => {
            warnings.push(format!(
                "the twin of this design could not be built ({e}), so the stage is identified \
                 on the lumped model"
            ));
            Ok(None)
        }
    }
}

fn read_record(folder: &RunFolder, path: &PathBuf, params: &IdentifyParams) -> Result<StageRecord> {
    let setup = Setup::from_scenario(folder.scenario());
    let file = std::fs::File::open(path).map_err(|source| PipelineError::Read {
        path: path.clone(),
        source,
    })?;
    Ok(StageRecord::from_csv(
        std::io::BufReader::new(file),
        &path.display().to_string(),
        &setup.plant.hysteresis,
        setup.plant.bias_voltage,
        params.sampling_tolerance,
    )?)
}

fn params_file(id: &Identification, source: &str) -> StageParamsFile {
    let th = paper_theta(&id.theta);
    let header = [
        format!("Stage parameters identified by `flexstage identify stage` from {source}."),
        "Masses and alpha are the known (weighed / Eq. 27) values of the guess.".into(),
        format!(
            "theta of Eq. (55) (diagonals, regression at {} s): {th:?}",
            id.regression_time
        ),
        "coupling: the cross-axis coupling stiffness k_c [N/m] of Eq. (30), the mean of the".into(),
        format!(
            "q_o1 / q_o2 rows' estimates {:.6e}, {:.6e}; `track` builds the controller's model",
            id.raw.coupling[0], id.raw.coupling[1]
        ),
        "with it (StageModel::with_coupling).".into(),
        "The controller's model of `flexstage track` in this run folder.".into(),
    ];
    StageParamsFile {
        header: header.to_vec(),
        documented: false,
        coupling: Some(id.coupling),
        params: id.params.clone(),
    }
}

/// The identified parameters, in Table 4's order.
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

fn rows(
    guess: &StageParams,
    estimate: &StageParams,
    truth: Option<&StageParams>,
) -> Vec<ParameterRow> {
    let (g, e, t) = (fields(guess), fields(estimate), truth.map(fields));
    (0..g.len())
        .map(|i| ParameterRow {
            name: g[i].0.into(),
            unit: g[i].2.into(),
            guess: g[i].1,
            estimate: e[i].1,
            truth: t.map(|t| t[i].1),
        })
        .collect()
}

/// The rows of `table.csv`: the parameters, then the coupling k_c (no guess).
fn table(rows: &[ParameterRow], kc: f64, truth_kc: Option<f64>) -> Rows<TableRow> {
    let row = |r: &ParameterRow| TableRow {
        parameter: r.name.clone(),
        unit: r.unit.clone(),
        guess: r.guess,
        estimate: r.estimate,
        truth: r.truth,
        error_pct: r.error_pct(),
    };
    let coupling = ParameterRow {
        name: "k_c".into(),
        unit: "N/m".into(),
        guess: 0.0,
        estimate: kc,
        truth: truth_kc,
    };
    Rows(rows.iter().chain([&coupling]).map(row).collect())
}

/// The parameter rows of a `table.csv` written by [`identify_stage`] (the coupling row,
/// which has no guess, is left out).
pub fn table_rows(table: &Rows<TableRow>) -> Vec<ParameterRow> {
    table
        .0
        .iter()
        .filter(|r| r.parameter != "k_c")
        .map(ParameterRow::from)
        .collect()
}

/// Convergence of the stiffnesses, normalized by the truth (or the final estimate).
fn write_convergence(run: &RunDir, id: &Identification, truth: Option<&StageParams>) -> Result<()> {
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
    let mut columns = vec![t.clone()];
    columns.extend(cols.iter().cloned());
    run.store(files::CONVERGENCE_CSV, Table::new(&header, columns))?;
    let mut fig = Figure::new(
        "Stage identification: convergence (Eq. 54-56)",
        "t [s]",
        "estimate / reference",
    );
    // Against the truth; a parameter whose estimate stays outside [0, 2]× the truth (a
    // truth the lumped model cannot represent) is drawn against its final estimate.
    let reference = truth.map(fields).unwrap_or_else(|| fields(&id.raw.params));
    let estimate = fields(&id.raw.params);
    for i in 0..6 {
        let points = |r: f64| -> Vec<(f64, f64)> {
            t.iter()
                .zip(&cols[i])
                .map(|(&t, &v)| (t, v / r))
                .filter(|(_, v)| v.is_finite() && (0.0..=2.0).contains(v))
                .collect()
        };
        let mut pts = points(reference[i].1);
        let mut name = reference[i].0.to_string();
        if pts.is_empty() {
            pts = points(estimate[i].1);
            name.push_str(" (/ final estimate)");
        }
        if !pts.is_empty() {
            fig = fig.with(Series::line(name, pts));
        }
    }
    run.write(files::CONVERGENCE_SVG, fig.to_svg()?.as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn twin_response_matches_the_twins_own_frequency_response() {
        // Reference: flexstage-twin's `ModalStage::frequency_response` (x_nom → q) of a twin
        // of the quick scenario with uniform densities 0.5. Goal: the q part of
        // `twin_response` equals it to 1e-12 relative at 10 Hz–4 kHz, and its x_in part is
        // consistent with it (the kinematics of Eq. 32 at 10 Hz).
        let s = crate::folder::preset("quick").unwrap();
        let n = s.mesh.nl * s.mesh.nw;
        let twin = flexstage_twin::Twin::from_scenario(&s, &vec![0.5; n]).unwrap();
        for f in [10.0, 300.0, 1500.0, 4000.0] {
            let r = twin_response(&twin, f);
            let g = twin.modal.frequency_response(f);
            for (i, row) in g.iter().enumerate() {
                for (j, &(re, im)) in row.iter().enumerate() {
                    let d = (r.q[j][i] - C64::new(re, im)).norm();
                    assert!(d <= 1e-12 * (re.hypot(im)), "q{i}/x{j} at {f} Hz: {d:e}");
                }
            }
        }
        // The plates: at 10 Hz the output follows the mean of the plates (q_o1 = (x_in1 +
        // x_in2)/2, Eq. 32) within 1 %, for either PEA.
        let r = twin_response(&twin, 10.0);
        for j in 0..2 {
            let mean = 0.5 * (r.x_in[j][0] + r.x_in[j][1]);
            let d = (r.q[j][0] - mean).norm() / r.q[j][0].norm();
            assert!(d < 0.01, "PEA {j}: q1 {:?}, plate mean {mean:?}", r.q[j][0]);
        }
    }

    #[test]
    fn a_response_fit_reads_back_and_a_bad_one_names_its_field() {
        // Goal: `response_fit.toml` round-trips (0 Hz = no mode); a gain out of range is
        // refused naming the field.
        use flexstage_run::Format;
        let fit = ResponseFit {
            dc_gain: [[0.4998, 0.4997], [2.02, -2.019]],
            frequency: [None, Some(3221.5)],
            damping: [0.0, 0.0102],
        };
        let path = std::path::Path::new("fit.toml");
        let bytes = response_fit_file(&fit).encode().unwrap();
        let back = ResponseFitFile::decode(&bytes).unwrap();
        assert_eq!(response_fit_of(&back, path).unwrap(), fit);
        let mut bad = back;
        bad.dc_gain[0][0] = 0.7;
        let e = response_fit_of(&bad, path).unwrap_err().to_string();
        assert!(e.contains("fit.dc_gain[0][0]") && e.contains("0.5"), "{e}");
    }

    #[test]
    fn options_bound_the_excitation() {
        StageIdOptions::default().validate().unwrap();
        let o = StageIdOptions {
            data: StageData::Simulate(Simulation {
                duration: Some(1e6),
                ..Simulation::default()
            }),
            ..StageIdOptions::default()
        };
        let e = o.validate().unwrap_err().to_string();
        assert!(
            e.contains("identify_stage.duration") && e.contains("(0, 600]"),
            "{e}"
        );
    }

    #[test]
    fn noise_free_linear_identification_recovers_the_truth() {
        // Reference: the simulated stage's truth (Table 4 of the paper preset), identified
        // from a 1 s noise-free multisine on the linear plant (Eq. 36).
        // Goal: every stiffness within 1 % of the truth; the table is written.
        let root = std::env::temp_dir().join(format!("flexstage-stageid-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let folder =
            RunFolder::open(crate::folder::preset("quick").unwrap(), &root, false).unwrap();
        let o = StageIdOptions {
            data: StageData::Simulate(Simulation {
                duration: Some(1.0),
                linear: true,
                noise: false,
                ..Simulation::default()
            }),
            ..StageIdOptions::default()
        };
        let s = identify_stage(&folder, &o, &crate::Silent).unwrap();
        assert_eq!(s.plant, Some(PlantSource::Scenario));
        for r in s.rows.iter().filter(|r| r.name.starts_with("k_")) {
            let e = r.error_pct().unwrap();
            assert!(e.abs() < 1.0, "{}: {e} %", r.name);
        }
        let table = std::fs::read(folder.dir().path(files::TABLE)).unwrap();
        let back = table_rows(&flexstage_run::Format::decode(&table).unwrap());
        for (b, r) in back.iter().zip(&s.rows) {
            assert_eq!(
                (&b.name, b.estimate, b.truth),
                (&r.name, r.estimate, r.truth)
            );
        }
        assert_eq!(back.len(), s.rows.len(), "table.csv reads back");
        let model = crate::plant::read_model_params(&s.params_file).unwrap();
        assert_eq!(model.params, s.params, "params.toml reads back");
        assert_eq!(
            model.coupling, s.coupling,
            "the coupling is a field of params.toml"
        );
        std::fs::remove_dir_all(&root).unwrap();
    }
}
