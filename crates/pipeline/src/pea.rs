//! The piezo actuators (Section 3.1, Appendix B): simulated PEA records from the Bouc–Wen
//! model (Eq. 18, Table A1), their identification by parallel RLS (Algorithm A1) and a batch
//! fit, and the hysteresis before and after inverse compensation (Eq. 21).

use std::path::{Path, PathBuf};

use flexstage_figures::plot::{Figure, Series};
use flexstage_piezo::{
    BoucWenParams, CompensatorParams, LoopMetrics, LoopParams, PeaData, WaveShape, Waveform,
    compensated_loop, loop_metrics, steady_state_loop, synthesize,
};
use flexstage_run::layout::{self, PeaIdentification};
use flexstage_run::{RunError, Table, write_atomic};
use flexstage_scenario::Scenario;

use crate::error::{PipelineError, Result, require};
use crate::folder::RunFolder;

/// The most samples of one simulated record (10⁸: 10⁴ s at 10 kHz).
pub const MAX_RECORD_SAMPLES: f64 = 1e8;

/// Options of the PEA simulation.
#[derive(Debug, Clone, PartialEq)]
pub struct PeaOptions {
    /// Which PEA of the scenario, 1 or 2. Default 1.
    pub pea: u8,
    /// Drive shape. Default [`WaveShape::Decaying`] (nested minor loops, rich for
    /// identification).
    pub shape: WaveShape,
    /// Drive frequency \[Hz\], in (0, 10 000]. Default 1.
    pub frequency: f64,
    /// Number of periods, in [1, 100 000]. Default 10.
    pub cycles: u32,
    /// Standard deviation of the sensor noise on x \[nm\], in [0, 10 000]. Default 10 (a
    /// capacitive sensor; 0 gives a noise-free record).
    pub noise_nm: f64,
    /// Sample time \[s\], in (0, 0.01]; `None`: the scenario's `simulation.sample_time`.
    pub dt: Option<f64>,
    /// Noise seed; `None`: the scenario's `simulation.seed`.
    pub seed: Option<u64>,
}

impl Default for PeaOptions {
    fn default() -> Self {
        PeaOptions {
            pea: 1,
            shape: WaveShape::Decaying,
            frequency: 1.0,
            cycles: 10,
            noise_nm: 10.0,
            dt: None,
            seed: None,
        }
    }
}

impl PeaOptions {
    /// Checks every option.
    pub fn validate(&self) -> Result<()> {
        check_pea("pea.pea", self.pea)?;
        let f = self.frequency;
        require(
            f.is_finite() && f > 0.0 && f <= 1e4,
            "pea.frequency",
            f,
            "a frequency in (0, 10000] Hz",
        )?;
        require(
            (1..=100_000).contains(&self.cycles),
            "pea.cycles",
            self.cycles,
            "an integer in [1, 100000]",
        )?;
        let n = self.noise_nm;
        require(
            n.is_finite() && (0.0..=1e4).contains(&n),
            "pea.noise_nm",
            n,
            "a standard deviation in [0, 10000] nm",
        )?;
        if let Some(dt) = self.dt {
            require(
                dt.is_finite() && dt > 0.0 && dt <= 0.01,
                "pea.dt",
                dt,
                "a sample time in (0, 0.01] s",
            )?;
        }
        Ok(())
    }
}

fn check_pea(option: &'static str, pea: u8) -> Result<()> {
    require((1..=2).contains(&pea), option, pea, "1 or 2")
}

/// The parameters of PEA `n` of the scenario.
fn scenario_pea(s: &Scenario, n: u8) -> BoucWenParams {
    BoucWenParams::from(if n == 1 {
        &s.hysteresis.pea1
    } else {
        &s.hysteresis.pea2
    })
}

/// A simulated PEA record and its steady loop.
#[derive(Debug, Clone)]
pub struct PeaRecord {
    /// The options used.
    pub options: PeaOptions,
    /// The record t \[s\], U \[V\], x \[µm\].
    pub data: PeaData,
    /// Duration of the record \[s\].
    pub duration: f64,
    /// Voltage range \[V\].
    pub voltage_range: [f64; 2],
    /// Steady loop of a plain full-range sine at the drive frequency.
    pub steady: LoopMetrics,
}

/// Simulates PEA `options.pea` of the scenario from a virgin state (U = 0, h = 0), with white
/// Gaussian noise on x.
pub fn simulate_pea(s: &Scenario, options: &PeaOptions) -> Result<PeaRecord> {
    options.validate()?;
    let hyst = &s.hysteresis;
    let params = scenario_pea(s, options.pea);
    let wave = Waveform {
        shape: options.shape,
        low: hyst.voltage_min,
        high: hyst.voltage_max,
        frequency: options.frequency,
        cycles: options.cycles,
    };
    let dt = options.dt.unwrap_or(s.simulation.sample_time);
    let samples = wave.duration() / dt;
    // The record length is cycles / frequency / dt: name the option that made it too long.
    let (option, value) = (
        "pea.cycles, pea.frequency, pea.dt",
        format!(
            "{} cycles at {:e} Hz every {dt:e} s",
            options.cycles, options.frequency
        ),
    );
    require(
        samples <= MAX_RECORD_SAMPLES,
        option,
        value,
        &format!("at most {MAX_RECORD_SAMPLES:e} samples; this record would have {samples:.3e}"),
    )?;
    let seed = options.seed.unwrap_or(s.simulation.seed);
    let data = synthesize(&params, &wave, dt, options.noise_nm * 1e-3, seed)?;
    let sine = Waveform {
        shape: WaveShape::Sine,
        cycles: 1,
        ..wave
    };
    let loop_settings = LoopParams {
        dt,
        ..LoopParams::default()
    };
    let steady = steady_state_loop(
        &params,
        |t| sine.value(t),
        1.0 / options.frequency,
        loop_settings,
    )?;
    Ok(PeaRecord {
        options: options.clone(),
        duration: wave.duration(),
        voltage_range: [hyst.voltage_min, hyst.voltage_max],
        steady: loop_metrics(&steady.input, &steady.output)?,
        data,
    })
}

/// Writes the record to the run folder ([`layout::pea::record`], and its loop figure).
/// Returns the files and whether they replaced earlier ones.
pub fn write_pea_record(folder: &RunFolder, rec: &PeaRecord) -> Result<(Vec<PathBuf>, bool)> {
    let n = rec.options.pea;
    let run = folder.dir();
    let replaced = run.exists(layout::pea::record(n));
    let csv = run.write(&layout::pea::record(n), rec.data.to_csv().as_bytes())?;
    let points = rec
        .data
        .u()
        .iter()
        .copied()
        .zip(rec.data.x().iter().copied())
        .collect();
    let fig = Figure::new(
        format!(
            "pea{n}: simulated record ({} drive)",
            crate::names::name(&crate::names::SHAPES, rec.options.shape)
        ),
        "U [V]",
        "x [µm]",
    )
    .with(Series::line("x(U)", points));
    let svg = run.write(&layout::pea::loop_svg(n), fig.to_svg()?.as_bytes())?;
    Ok((vec![csv, svg], replaced))
}

/// Writes only the record's CSV to `path`; an existing file is kept unless `force`.
pub fn write_pea_csv(path: &Path, rec: &PeaRecord, force: bool) -> Result<()> {
    if path.exists() && !force {
        return Err(RunError::Exists {
            path: path.to_path_buf(),
        }
        .into());
    }
    write_atomic(path, rec.data.to_csv().as_bytes())?;
    Ok(())
}

/// Options of the PEA identification.
#[derive(Debug, Clone, PartialEq)]
pub struct PeaIdOptions {
    /// Which PEA of the scenario the record belongs to (1 or 2): the results go to
    /// `identify/pea<N>/` and are compared with its parameters. Default 1.
    pub pea: u8,
    /// The record (CSV with columns t \[s\], U \[V\], x \[µm\]); `None`: the run's simulated
    /// record of that PEA ([`layout::pea::record`]).
    pub data: Option<PathBuf>,
    /// Forgetting factor λ_f of both RLS estimators, in (0, 1]. Default 1 (converges to the
    /// batch least-squares fit).
    pub forgetting: f64,
    /// Passes of the parallel RLS over the record, in [1, 100]. Default 1.
    pub passes: u32,
}

impl Default for PeaIdOptions {
    fn default() -> Self {
        PeaIdOptions {
            pea: 1,
            data: None,
            forgetting: flexstage_piezo::IdentifyParams::default().forgetting,
            passes: flexstage_piezo::IdentifyParams::default().passes,
        }
    }
}

impl PeaIdOptions {
    /// Checks every option.
    pub fn validate(&self) -> Result<()> {
        check_pea("identify_pea.pea", self.pea)?;
        let l = self.forgetting;
        require(
            l.is_finite() && (flexstage_piezo::identify::MIN_FORGETTING..=1.0).contains(&l),
            "identify_pea.forgetting",
            l,
            "a factor in [0.9, 1]",
        )?;
        require(
            (1..=100).contains(&self.passes),
            "identify_pea.passes",
            self.passes,
            "an integer in [1, 100]",
        )
    }
}

/// One estimate of the Bouc–Wen parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeaEstimate {
    /// The parameters.
    pub params: BoucWenParams,
    /// RMS of x − x_model along the record \[µm\].
    pub rms_error: f64,
}

/// What the PEA identification found.
#[derive(Debug, Clone)]
pub struct PeaIdSummary {
    /// The PEA.
    pub pea: u8,
    /// The record identified.
    pub data: PathBuf,
    /// Samples of the record.
    pub samples: usize,
    /// Hysteresis width of the record [% of range].
    pub record_width_pct: f64,
    /// Parallel RLS (Algorithm A1).
    pub online: PeaEstimate,
    /// Batch least squares.
    pub batch: PeaEstimate,
    /// Which estimate is recommended ("batch" or "parallel_rls": the lower RMS error).
    pub recommended: &'static str,
    /// Inverse compensation built on the recommended estimate.
    pub compensation: CompensationSummary,
    /// The result folder.
    pub dir: PathBuf,
    /// Whether earlier results were replaced.
    pub replaced: bool,
}

/// Hysteresis without and with inverse compensation.
#[derive(Debug, Clone, Copy)]
pub struct CompensationSummary {
    /// Loop width of the uncompensated actuator [% of range].
    pub width_before_pct: f64,
    /// Loop width behind the compensator [% of range].
    pub width_after_pct: f64,
    /// Largest |x − x_desired| behind the compensator \[µm\].
    pub max_error_um: f64,
}

/// Identifies the Bouc–Wen parameters of a record (Appendix B) and writes
/// `identify/pea<N>/` ([`PeaIdentification`]): estimates, convergence (Figure A2), the record
/// against the model, and the compensation figure.
pub fn identify_pea(folder: &RunFolder, options: &PeaIdOptions) -> Result<PeaIdSummary> {
    options.validate()?;
    let run = folder.dir();
    let path = match &options.data {
        Some(p) => p.clone(),
        None => run.path(layout::pea::record(options.pea)),
    };
    if options.data.is_none() && !path.is_file() {
        return Err(PipelineError::Missing {
            what: "PEA record",
            path,
            hint: "simulate one with `flexstage pea simulate`, or give a record".into(),
        });
    }
    let file = std::fs::File::open(&path).map_err(|source| PipelineError::Read {
        path: path.clone(),
        source,
    })?;
    let data = PeaData::from_csv(std::io::BufReader::new(file), &path.display().to_string())?;
    identify_pea_data(folder, options, &path, &data)
}

/// [`identify_pea`] on a record in memory (e.g. arrays from Python); `path` names it in
/// messages and in the summary (the file it was read from, or a description).
pub fn identify_pea_data(
    folder: &RunFolder,
    options: &PeaIdOptions,
    path: &Path,
    data: &PeaData,
) -> Result<PeaIdSummary> {
    let run = folder.dir();
    let path = path.to_path_buf();
    let params = flexstage_piezo::IdentifyParams {
        forgetting: options.forgetting,
        passes: options.passes,
        record_every: (data.len() / 2000).max(1),
        ..flexstage_piezo::IdentifyParams::default()
    };
    // A record the estimators cannot use is a fault of the record: name it.
    let of_record = |e: flexstage_piezo::PiezoError| PipelineError::Format {
        path: path.display().to_string(),
        reason: e.to_string(),
    };
    let online = flexstage_piezo::identify(data, &params).map_err(of_record)?;
    let batch = flexstage_piezo::fit_batch(data).map_err(of_record)?;
    let (recommended, best) =
        if batch.rms_error <= online.rms_error || !online.rms_error.is_finite() {
            ("batch", batch.estimate)
        } else {
            ("parallel_rls", online.estimate)
        };
    let out = PeaIdentification { pea: options.pea };
    let replaced = folder.has_results(&out.dir());
    let record = loop_metrics(data.u(), data.x()).map_err(of_record)?;
    identifiable(&path, record.width_pct, &best)?;
    let reference = scenario_pea(folder.scenario(), options.pea);
    let summary = PeaIdSummary {
        pea: options.pea,
        data: path,
        samples: data.len(),
        record_width_pct: record.width_pct,
        online: PeaEstimate {
            params: online.estimate,
            rms_error: online.rms_error,
        },
        batch: PeaEstimate {
            params: batch.estimate,
            rms_error: batch.rms_error,
        },
        recommended,
        compensation: compensation(folder, out, &reference, &best)?,
        dir: run.path(out.dir()),
        replaced,
    };
    if summary.compensation.width_after_pct > summary.compensation.width_before_pct {
        return Err(PipelineError::Format {
            path: summary.data.display().to_string(),
            reason: format!(
                "the {recommended} estimate does not describe the actuator: compensation built \
                 on it widens the loop from {:.2} % to {:.2} % of the range (a record too short \
                 or too narrow to identify from)",
                summary.compensation.width_before_pct, summary.compensation.width_after_pct
            ),
        });
    }
    let files = crate::pea_files::Outputs {
        run,
        out,
        data,
        summary: &summary,
        reference,
        best,
        record,
        history: &online.history,
    };
    files.write()?;
    Ok(summary)
}

/// The PEAs of the paper's stage (Table A1 has a column for each).
pub const PEAS: [u8; 2] = [1, 2];

/// The PEA stage of `run`: simulates a record of every PEA ([`PEAS`]) with `record`'s drive
/// and noise, and identifies each with `id`'s estimator settings (Table A1 and Figure A2 for
/// both). The `pea` fields of the options are replaced by each PEA's number; PEA `n` draws
/// its noise from seed + n − 1, so the two records do not share their noise. The two run in
/// parallel.
pub fn simulate_and_identify_each(
    folder: &RunFolder,
    record: &PeaOptions,
    id: &PeaIdOptions,
) -> Result<Vec<PeaIdSummary>> {
    let one = |n: u8| -> Result<PeaIdSummary> {
        let seed = record.seed.unwrap_or(folder.scenario().simulation.seed);
        let options = PeaOptions {
            pea: n,
            seed: Some(seed.wrapping_add(u64::from(n - 1))),
            ..record.clone()
        };
        let rec = simulate_pea(folder.scenario(), &options)?;
        write_pea_record(folder, &rec)?;
        let options = PeaIdOptions {
            pea: n,
            data: None,
            ..id.clone()
        };
        // The record just written is identified from memory, not read back.
        let path = folder.dir().path(layout::pea::record(n));
        options.validate()?;
        identify_pea_data(folder, &options, &path, &rec.data)
    };
    let (a, b) = rayon::join(|| one(PEAS[0]), || one(PEAS[1]));
    Ok(vec![a?, b?])
}

/// Smallest loop width of a record to identify from [% of the displacement range].
pub const MIN_RECORD_WIDTH_PCT: f64 = 0.1;

/// Refuses a record without hysteresis and an estimate that is not a bounded Bouc–Wen model
/// (finite, d_p > 0, B_bw ≥ 0, B_bw + Γ_bw > 0, as `hysteresis.pea*` in the scenario).
fn identifiable(path: &Path, width_pct: f64, p: &BoucWenParams) -> Result<()> {
    let fail = |reason: String| {
        Err(PipelineError::Format {
            path: path.display().to_string(),
            reason,
        })
    };
    if width_pct.is_nan() || width_pct < MIN_RECORD_WIDTH_PCT {
        return fail(format!(
            "the record's hysteresis loop is {width_pct:.3} % of its range, below the \
             {MIN_RECORD_WIDTH_PCT} % needed to identify a Bouc–Wen model (record at least one \
             full cycle of the voltage range)"
        ));
    }
    let values = [p.d_p, p.a_bw, p.b_bw, p.gamma_bw, p.delta_bw];
    let bounded = p.d_p > 0.0 && p.b_bw >= 0.0 && p.b_bw + p.gamma_bw > 0.0;
    if !values.iter().all(|v| v.is_finite()) || !bounded {
        return fail(format!(
            "the identification gives no valid Bouc–Wen model (d_p = {:e}, A_bw = {:e}, \
             B_bw = {:e}, Γ_bw = {:e}, δ_bw = {:e}; needed: finite, d_p > 0, B_bw ≥ 0, \
             B_bw + Γ_bw > 0)",
            p.d_p, p.a_bw, p.b_bw, p.gamma_bw, p.delta_bw
        ));
    }
    Ok(())
}

/// Hysteresis before and after inverse compensation (Section 3.3, Eq. 21): the scenario's PEA
/// driven by a plain 1 Hz full-range voltage sine (displacement against the nominal d_p·U),
/// and the same PEA behind the compensator built on the *identified* parameters (displacement
/// against the desired one, 5 %–95 % of the nominal stroke).
fn compensation(
    folder: &RunFolder,
    out: PeaIdentification,
    truth: &BoucWenParams,
    model: &BoucWenParams,
) -> Result<CompensationSummary> {
    let s = folder.scenario();
    let (lo, hi) = (s.hysteresis.voltage_min, s.hysteresis.voltage_max);
    let dt = s.simulation.sample_time;
    let sine = Waveform {
        shape: WaveShape::Sine,
        low: lo,
        high: hi,
        frequency: 1.0,
        cycles: 1,
    };
    let settings = LoopParams {
        dt,
        ..LoopParams::default()
    };
    let before = steady_state_loop(truth, |t| sine.value(t), 1.0, settings)?;
    let nominal: Vec<f64> = before.input.iter().map(|u| truth.d_p * u).collect();
    let margin = 0.05 * truth.d_p * (hi - lo);
    let desired = Waveform {
        low: truth.d_p * lo + margin,
        high: truth.d_p * hi - margin,
        ..sine
    };
    let limits = CompensatorParams {
        u_min: lo,
        u_max: hi,
        ..CompensatorParams::default()
    };
    let after = compensated_loop(truth, model, limits, &desired, 3, dt)?;
    let pairs = |x: &[f64], y: &[f64]| x.iter().copied().zip(y.iter().copied()).collect();
    let fig = Figure::new(
        format!(
            "PEA{}: hysteresis without and with inverse compensation",
            out.pea
        ),
        "nominal d_p·U / desired displacement [µm]",
        "actuator displacement [µm]",
    )
    .with(Series::line(
        "without compensation",
        pairs(&nominal, &before.output),
    ))
    .with(Series::line(
        "with compensation (identified model)",
        pairs(&after.x_desired, &after.x),
    ));
    let run = folder.dir();
    run.write(&out.compensation_svg(), fig.to_svg()?.as_bytes())?;
    let table = Table::of(
        &[
            "nominal_um",
            "x_uncompensated_um",
            "x_desired_um",
            "x_compensated_um",
        ],
        &[&nominal, &before.output, &after.x_desired, &after.x],
    );
    run.store(&out.compensation_csv(), table)?;
    Ok(CompensationSummary {
        width_before_pct: loop_metrics(&nominal, &before.output)
            .map(|m| m.width_pct)
            .unwrap_or(f64::NAN),
        width_after_pct: after.metrics.width_pct,
        max_error_um: after.max_error,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_are_bounded() {
        PeaOptions::default().validate().unwrap();
        PeaIdOptions::default().validate().unwrap();
        let e = PeaOptions {
            pea: 3,
            ..PeaOptions::default()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(e.contains("pea.pea = 3") && e.contains("1 or 2"), "{e}");
        let e = PeaIdOptions {
            forgetting: 0.0,
            ..PeaIdOptions::default()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(e.contains("identify_pea.forgetting = 0"), "{e}");
        // Bounded work: 10⁵ periods at 0.001 Hz would be 10⁸ s of record.
        let s = crate::folder::preset("quick").unwrap();
        let long = PeaOptions {
            frequency: 1e-3,
            cycles: 100_000,
            ..PeaOptions::default()
        };
        let e = simulate_pea(&s, &long).unwrap_err().to_string();
        assert!(e.contains("samples"), "{e}");
    }

    #[test]
    fn the_pea_stage_identifies_both_peas_of_table_a1() {
        // Reference: Table A1, both columns (PEA1 and PEA2 differ in A_bw, Γ_bw and δ), the
        // paper preset's hysteresis.pea1 and .pea2. Goal: the PEA stage of `run` simulates
        // and identifies each PEA into its own folder; on noise-free records every estimate
        // is within 1 % of that PEA's own column, and the two records are different.
        let root = std::env::temp_dir().join(format!("flexstage-peas-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let folder =
            RunFolder::open(crate::folder::preset("paper").unwrap(), &root, false).unwrap();
        let record = PeaOptions {
            noise_nm: 0.0,
            cycles: 4,
            ..PeaOptions::default()
        };
        let sums = simulate_and_identify_each(&folder, &record, &PeaIdOptions::default()).unwrap();
        assert_eq!(sums.iter().map(|s| s.pea).collect::<Vec<_>>(), PEAS);
        for sum in &sums {
            let truth = scenario_pea(folder.scenario(), sum.pea);
            let best = if sum.recommended == "batch" {
                sum.batch.params
            } else {
                sum.online.params
            };
            for (name, v, t) in [
                ("d_p", best.d_p, truth.d_p),
                ("a_bw", best.a_bw, truth.a_bw),
                ("b_bw", best.b_bw, truth.b_bw),
                ("gamma_bw", best.gamma_bw, truth.gamma_bw),
                ("delta_bw", best.delta_bw, truth.delta_bw),
            ] {
                assert!(
                    ((v - t) / t).abs() < 0.01,
                    "PEA{}: {name} = {v}, truth {t}",
                    sum.pea
                );
            }
            let out = PeaIdentification { pea: sum.pea };
            assert!(folder.dir().exists(out.estimates()), "PEA{}", sum.pea);
        }
        let records: Vec<Vec<u8>> = PEAS
            .iter()
            .map(|&n| folder.dir().read(&layout::pea::record(n)).unwrap().unwrap())
            .collect();
        assert_ne!(records[0], records[1]);
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn identify_pea_on_a_noise_free_record_recovers_table_a1() {
        // Reference: Table A1 (PEA1), the scenario's hysteresis.pea1.
        // Goal: a noise-free simulated record of PEA1 identifies to within 1 % of Table A1;
        // every output file is written; a record with NaN fails naming its line and column.
        let root = std::env::temp_dir().join(format!("flexstage-pea-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let folder =
            RunFolder::open(crate::folder::preset("paper").unwrap(), &root, false).unwrap();
        let rec = simulate_pea(
            folder.scenario(),
            &PeaOptions {
                noise_nm: 0.0,
                ..PeaOptions::default()
            },
        )
        .unwrap();
        write_pea_record(&folder, &rec).unwrap();
        let sum = identify_pea(&folder, &PeaIdOptions::default()).unwrap();
        let truth = scenario_pea(folder.scenario(), 1);
        let best = if sum.recommended == "batch" {
            sum.batch.params
        } else {
            sum.online.params
        };
        for (name, v, t) in [
            ("d_p", best.d_p, truth.d_p),
            ("a_bw", best.a_bw, truth.a_bw),
            ("b_bw", best.b_bw, truth.b_bw),
            ("gamma_bw", best.gamma_bw, truth.gamma_bw),
            ("delta_bw", best.delta_bw, truth.delta_bw),
        ] {
            assert!(((v - t) / t).abs() < 0.01, "{name} = {v}, truth {t}");
        }
        assert!(sum.compensation.width_after_pct < sum.compensation.width_before_pct);
        let out = PeaIdentification { pea: 1 };
        for f in [
            out.estimates(),
            out.convergence_csv(),
            out.convergence_svg(),
            out.loop_csv(),
            out.loop_svg(),
            out.compensation_csv(),
            out.compensation_svg(),
        ] {
            assert!(folder.dir().exists(&f), "{f} missing");
        }
        let bad = folder
            .dir()
            .write("bad.csv", b"t,U,x\n0,0,0\n0.1,1,NaN\n0.2,2,0.1\n")
            .unwrap();
        let opts = PeaIdOptions {
            data: Some(bad),
            ..PeaIdOptions::default()
        };
        let e = identify_pea(&folder, &opts).unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("column x"), "{e}");
        std::fs::remove_dir_all(&root).unwrap();
    }
}
