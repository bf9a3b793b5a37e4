//! `identify stage`: online least-squares identification of the stage stiffnesses and
//! dampings (Section 4.2, Eq. 54–56, Table 4) from a logged record or from the simulated
//! stage of the run ([`Plant::of_run`]).

use flexstage_scenario::RecordEstimate;
use std::path::PathBuf;

use flexstage_control::experiment::Setup;
use flexstage_control::plant::PlantActuator;
use flexstage_identify::regression::paper_theta;
use flexstage_identify::{Excitation, Identification, IdentifyParams, StageRecord, samples};
use flexstage_report::layout::stage as files;
use flexstage_report::plot::{Figure, Series};
use flexstage_report::{RunDir, csv_columns};
use flexstage_scenario::StageParams;

use crate::error::{PipelineError, Result, require};
use crate::folder::RunFolder;
use crate::plant::{Plant, PlantSource};
use crate::progress::Progress;

/// The longest simulated excitation \[s\] (bounded work: 6·10⁶ samples at 10 kHz).
pub const MAX_DURATION: f64 = 600.0;

/// The simulated excitation of the stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Simulation {
    /// Excitation length \[s\], in (0, 600]. Default 4 (5 % on the stiffnesses with the default
    /// sensor noise; 1 s is enough without noise).
    pub duration: f64,
    /// Highest excitation frequency \[Hz\] ([`Excitation::validate`]). Default 150.
    pub f_max: f64,
    /// Linear actuators (x_nom applied directly, no cross terms: the model of Eq. 36) instead
    /// of the Bouc–Wen PEAs. Default false.
    pub linear: bool,
    /// Sensor noise and quantization on. Default true.
    pub noise: bool,
}

impl Default for Simulation {
    fn default() -> Self {
        Simulation {
            duration: Excitation::default().duration,
            f_max: Excitation::default().f_max,
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
        if let StageData::Simulate(Simulation { duration, .. }) = self.data {
            require(
                duration.is_finite() && duration > 0.0 && duration <= MAX_DURATION,
                "identify_stage.duration",
                duration,
                "a duration in (0, 600] s",
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

/// What the stage identification found.
#[derive(Debug, Clone)]
pub struct StageIdSummary {
    /// The stage simulated (for a simulated record).
    pub plant: Option<PlantSource>,
    /// Samples of the record.
    pub samples: usize,
    /// The identification (estimates, conditioning, warnings).
    pub identification: Identification,
    /// Guess / estimate / truth per parameter (Table 4).
    pub rows: Vec<ParameterRow>,
    /// The identified parameter file ([`files::PARAMS`]).
    pub params_file: PathBuf,
    /// The stage folder.
    pub dir: PathBuf,
    /// Whether earlier results were replaced.
    pub replaced: bool,
}

/// Identifies the stage parameters and writes `identify/stage/`.
pub fn identify_stage(
    folder: &RunFolder,
    options: &StageIdOptions,
    progress: &dyn Progress,
) -> Result<StageIdSummary> {
    options.validate()?;
    let plant = Plant::of_run(folder)?;
    let guess = plant.scenario.stage.guess.clone();
    let (record, truth, source) = match &options.data {
        StageData::Simulate(Simulation {
            duration,
            f_max,
            linear,
            noise,
        }) => {
            let mut sim = samples::simulation(&plant.scenario, *duration, *linear, *noise);
            sim.excitation.f_max = *f_max;
            // time, x_nom, x_in, q per axis, before the simulation allocates them.
            RecordEstimate::new(*duration, sim.plant.sample_time, sim.oversample, 0, 7).check(
                "identify_stage.duration",
                *duration,
                flexstage_identify::data::MIN_SAMPLES as f64,
            )?;
            options.estimator.validate_sampling(sim.plant.sample_time)?;
            if !linear {
                sim.plant.actuator = PlantActuator::Hysteretic;
            }
            progress.note(&format!(
                "simulating {duration} s of multisine excitation ({}–{} Hz, peak {:.1} µm) on \
                 {}",
                sim.excitation.f_min,
                sim.excitation.f_max,
                sim.excitation.amplitude * 1e6,
                plant.source
            ));
            let record = flexstage_identify::simulate(&sim)?;
            (
                record,
                Some(sim.plant.truth.clone()),
                "simulated".to_string(),
            )
        }
        StageData::Record(path) => (read_record(folder, path, &options.estimator)?, None, {
            path.display().to_string()
        }),
    };
    let id = flexstage_identify::identify(&record, &guess, &options.estimator)?;
    let run = folder.dir();
    let replaced = folder.has_results(files::DIR);
    if matches!(options.data, StageData::Simulate(_)) {
        run.write(files::RECORD, record.to_csv().as_bytes())?;
    }
    let params_file = run.write(files::PARAMS, params_toml(&id, &source).as_bytes())?;
    let rows = rows(&guess, &id, truth.as_ref());
    run.write(files::TABLE, table_csv(&rows, &id).as_bytes())?;
    write_convergence(run, &id, truth.as_ref())?;
    Ok(StageIdSummary {
        plant: matches!(options.data, StageData::Simulate(_)).then_some(plant.source),
        samples: record.len(),
        identification: id,
        rows,
        params_file,
        dir: run.path(files::DIR),
        replaced,
    })
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

fn params_toml(id: &Identification, source: &str) -> String {
    let body = toml::to_string(&id.params).expect("StageParams serializes");
    let th = paper_theta(&id.theta);
    format!(
        "# Stage parameters identified by `flexstage identify stage` from {source}.\n\
         # Masses and alpha are the known (weighed / Eq. 27) values of the guess.\n\
         # theta of Eq. (55) (diagonals, regression at {} s): {:?}\n\
         # coupling k_c [N/m] from the q_o1 / q_o2 rows: {:.6e}, {:.6e}\n\
         # The controller's model of `flexstage track` in this run folder.\n{body}",
        id.regression_time, th, id.raw.coupling[0], id.raw.coupling[1]
    )
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
    id: &Identification,
    truth: Option<&StageParams>,
) -> Vec<ParameterRow> {
    let (g, e, t) = (fields(guess), fields(&id.raw.params), truth.map(fields));
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

fn table_csv(rows: &[ParameterRow], id: &Identification) -> String {
    let mut csv = String::from("parameter,unit,guess,estimate,truth,error_pct\n");
    for r in rows {
        csv.push_str(&format!(
            "{},{},{:e},{:e},{},{}\n",
            r.name,
            r.unit,
            r.guess,
            r.estimate,
            r.truth.map(|v| format!("{v:e}")).unwrap_or_default(),
            r.error_pct().map(|v| format!("{v:.4}")).unwrap_or_default()
        ));
    }
    let kc = id.raw.coupling;
    csv.push_str(&format!("k_c,N/m,0,{:e},,\n", 0.5 * (kc[0] + kc[1])));
    csv
}

/// The parameter rows of a `table.csv` written by [`identify_stage`] (the coupling row,
/// which has no guess, is left out).
pub fn read_table(text: &str) -> Vec<ParameterRow> {
    text.lines()
        .skip(1)
        .filter_map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            let num = |i: usize| c.get(i).and_then(|v| v.parse::<f64>().ok());
            Some(ParameterRow {
                name: c.first()?.to_string(),
                unit: c.get(1)?.to_string(),
                guess: num(2)?,
                estimate: num(3)?,
                truth: num(4),
            })
        })
        .filter(|r| r.name != "k_c")
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
    let mut columns: Vec<&[f64]> = vec![&t];
    columns.extend(cols.iter().map(Vec::as_slice));
    run.write(
        files::CONVERGENCE_CSV,
        csv_columns(&header, &columns).as_bytes(),
    )?;
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
    run.write(files::CONVERGENCE_SVG, fig.to_svg()?.as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_bound_the_excitation() {
        StageIdOptions::default().validate().unwrap();
        let o = StageIdOptions {
            data: StageData::Simulate(Simulation {
                duration: 1e6,
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
                duration: 1.0,
                f_max: 150.0,
                linear: true,
                noise: false,
            }),
            ..StageIdOptions::default()
        };
        let s = identify_stage(&folder, &o, &crate::Silent).unwrap();
        assert_eq!(s.plant, Some(PlantSource::Scenario));
        for r in s.rows.iter().filter(|r| r.name.starts_with("k_")) {
            let e = r.error_pct().unwrap();
            assert!(e.abs() < 1.0, "{}: {e} %", r.name);
        }
        let back = read_table(&folder.dir().read_to_string(files::TABLE).unwrap());
        assert_eq!(back, s.rows, "table.csv reads back");
        std::fs::remove_dir_all(&root).unwrap();
    }
}
