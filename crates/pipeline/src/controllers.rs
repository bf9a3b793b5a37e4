//! The tuned controllers taken to a real-time target: every registry design (PI + notch and
//! PID with their FIR feed-forward, PPF + PI + notch through their linear target law; the
//! backstepping through its own, with the rig's delay it predicts over; with learning, the
//! learned table) with its actuator stage as a coefficients file
//! (`track/[<conditions>/]controllers/<controller>.json`, [`ControllerFile`]) and a
//! self-contained C99 source and header generated from it
//! (`flexstage_control::target::TargetLaw::c_source`,
//! `flexstage_control::target_backstepping::BacksteppingLaw::c_source`). `track` writes them
//! for the controllers it ran; [`export_controller`] writes the C of any controller file (one
//! edited by hand, or into another folder). A file read back gives the law it was written
//! from, bitwise.

use std::path::{Path, PathBuf};

use flexstage_control::actuator::{ActuatorParams, Compensation};
use flexstage_control::controller::{Inner, Velocity};
use flexstage_control::experiment::Setup;
use flexstage_control::feedforward::FirFeedForward;
use flexstage_control::registry::{CONTROLLERS, Controller, Design, Designs, Stage};
use flexstage_control::target::{CSource, TargetLaw, c_prefix, compensation_name, compensation_of};
use flexstage_control::target_backstepping::{BacksteppingLaw, matrix, rows};
use flexstage_control::tuning::{FeedForwardFit, TuningParams};
use flexstage_control_core::{Biquad, PidGains};
use flexstage_identify::measured::{
    FitParams, LabLog, LiftedResponse, MeasuredResponse, WelchParams,
};
use flexstage_piezo::{BoucWenParams, CompensatorParams};
use flexstage_run::files::controller::{
    ActuatorFile, AxisFile, BacksteppingFile, ControllerFile, FeedForwardFile, SectionFile, VERSION,
};
use flexstage_run::layout::Tracking;
use flexstage_run::{Format, RunDir};
use flexstage_scenario::Scenario;

use crate::error::{PipelineError, Result};

/// The file of the actuator stage `a`.
fn actuator_file(a: &ActuatorParams) -> ActuatorFile {
    let comp = a.compensator();
    ActuatorFile {
        compensation: compensation_name(a.compensation).to_string(),
        stroke_m: a.stroke,
        voltage_range_v: a.voltage_range,
        bias_voltage_v: a.bias_voltage,
        compensator_tolerance_um: comp.tolerance,
        compensator_max_iterations: comp.max_iterations,
        hysteresis: a.hysteresis.map(|p| (&p).into()),
        max_voltage_step_v: a.max_voltage_step,
    }
}

fn section_file(s: &Biquad) -> SectionFile {
    SectionFile {
        b: s.numerator(),
        a: s.denominator(),
    }
}

/// The coefficients file of `law`, the law of the registry controller `c`.
pub fn controller_file(c: &Controller, law: &TargetLaw) -> ControllerFile {
    ControllerFile {
        version: VERSION,
        controller: c.name.to_string(),
        label: c.label.to_string(),
        sample_time_s: law.sample_time,
        axes: Some([0, 1].map(|i| AxisFile {
            kp: law.gains[i].kp,
            ki_per_s: law.gains[i].ki,
            kd_s: law.gains[i].kd,
            sections: law.sections[i].map(|s| section_file(&s)),
        })),
        inverse_static_gain: Some(law.inverse_gain),
        actuator: actuator_file(&law.actuator),
        damping: law.damping.map(|d| d.map(|s| section_file(&s))),
        feedforward: law.feedforward.as_ref().map(|f| FeedForwardFile {
            preview_samples: f.preview(),
            lag_samples: f.lag(),
            taps: f.taps().to_vec(),
            reading_taps: f.reading().map(<[_]>::to_vec),
            fitted_to: None,
        }),
        learned_m: law.learned.clone(),
        backstepping: None,
    }
}

/// `file` with what its feed-forward was fitted to recorded (`fit`, the designs' on their
/// stage).
fn fitted(mut file: ControllerFile, fit: FeedForwardFit) -> ControllerFile {
    if let Some(ff) = &mut file.feedforward {
        ff.fitted_to = Some(fit.name().to_string());
    }
    file
}

/// The coefficients file of the backstepping law `law` of the registry controller `c`.
pub fn backstepping_file(c: &Controller, law: &BacksteppingLaw) -> ControllerFile {
    let p = &law.law;
    ControllerFile {
        version: VERSION,
        controller: c.name.to_string(),
        label: c.label.to_string(),
        sample_time_s: law.sample_time,
        axes: None,
        inverse_static_gain: None,
        actuator: actuator_file(&law.actuator),
        damping: None,
        feedforward: None,
        learned_m: law.learned.clone(),
        backstepping: Some(BacksteppingFile {
            delay_samples: law.delay,
            robust: p.robust,
            error_gain_per_s: p.error_gain,
            eta_gain_per_s: p.eta_gain,
            feedback_gain_per_s: p.feedback_gain,
            eta_bound_m_per_s2: p.eta_bound,
            a_bound_m_per_s: p.a_bound,
            boundary_layer: p.boundary_layer,
            velocity: match law.velocity {
                Velocity::Observer => "observer",
                Velocity::FiniteDifference => "finite-difference",
            }
            .to_string(),
            inner: match law.inner {
                Inner::Estimate => "estimate",
                Inner::Command => "command",
            }
            .to_string(),
            disturbance_feedback: law.disturbance_feedback,
            notches: law.notches.map(|a| a.map(|s| section_file(&s))),
            notch_delay_s: law.notch_delay,
            model_b: rows(&law.b),
            g_inv: rows(&law.g_inv),
            d_inv: rows(&law.d_inv),
            phi: rows(&law.phi),
            gamma: rows(&law.gamma),
            filter_f: rows(&law.f),
            filter_l: rows(&law.l),
        }),
    }
}

/// The actuator stage of a file, checked against the compensator settings this flexstage
/// runs.
fn actuator_of(a: &ActuatorFile) -> Result<ActuatorParams> {
    let expected = CompensatorParams::default();
    if a.compensator_tolerance_um != expected.tolerance
        || a.compensator_max_iterations != expected.max_iterations
    {
        return Err(PipelineError::Option {
            option: "actuator.compensator_tolerance_um, compensator_max_iterations",
            value: format!(
                "{}, {}",
                a.compensator_tolerance_um, a.compensator_max_iterations
            ),
            expected: format!(
                "{}, {} (the compensator settings this flexstage runs)",
                expected.tolerance, expected.max_iterations
            ),
        });
    }
    Ok(ActuatorParams {
        hysteresis: [
            BoucWenParams::from(&a.hysteresis[0]),
            BoucWenParams::from(&a.hysteresis[1]),
        ],
        voltage_range: a.voltage_range_v,
        bias_voltage: a.bias_voltage_v,
        stroke: a.stroke_m,
        compensation: compensation_of(&a.compensation)?,
        max_voltage_step: a.max_voltage_step_v,
    })
}

/// The law a coefficients file holds, checked.
#[derive(Debug, Clone, PartialEq)]
pub enum FileLaw {
    /// The linear law (PI(D) + notch, feed-forward, PPF; boxed as the other).
    Linear(Box<TargetLaw>),
    /// The backstepping law (boxed: its matrices are 3 kB).
    Backstepping(Box<BacksteppingLaw>),
}

/// The law of a coefficients file, checked (every coefficient in its range, the
/// compensator settings the ones this flexstage runs).
pub fn file_law(f: &ControllerFile) -> Result<FileLaw> {
    match (&f.backstepping, &f.axes, &f.inverse_static_gain) {
        (Some(b), None, None) if f.damping.is_none() && f.feedforward.is_none() => {
            Ok(FileLaw::Backstepping(Box::new(backstepping_law(f, b)?)))
        }
        (None, Some(axes), Some(g)) => Ok(FileLaw::Linear(Box::new(target_law(f, axes, *g)?))),
        _ => Err(PipelineError::Option {
            option: "controller file: backstepping, axes, inverse_static_gain, damping, \
                     feedforward",
            value: f.controller.clone(),
            expected: "either the linear law (axes, inverse_static_gain, optionally damping \
                       and feedforward) or the backstepping law alone"
                .into(),
        }),
    }
}

fn target_law(f: &ControllerFile, axes: &[AxisFile; 2], g: [[f64; 2]; 2]) -> Result<TargetLaw> {
    let law = TargetLaw {
        gains: axes.map(|x| PidGains {
            kp: x.kp,
            ki: x.ki_per_s,
            kd: x.kd_s,
        }),
        sections: axes.map(|x| x.sections.map(|s| Biquad::new(s.b, s.a))),
        inverse_gain: g,
        sample_time: f.sample_time_s,
        actuator: actuator_of(&f.actuator)?,
        damping: f.damping.map(|d| d.map(|s| Biquad::new(s.b, s.a))),
        feedforward: f
            .feedforward
            .as_ref()
            .map(|x| {
                let ff =
                    FirFeedForward::from_taps(x.preview_samples, x.taps.clone(), x.lag_samples)?;
                match &x.reading_taps {
                    Some(c) => ff.with_reading(c.clone()),
                    None => Ok(ff),
                }
            })
            .transpose()?,
        learned: f.learned_m.clone(),
    };
    law.controller()?;
    Ok(law)
}

fn backstepping_law(f: &ControllerFile, b: &BacksteppingFile) -> Result<BacksteppingLaw> {
    use flexstage_control::backstepping::LawParams;
    let choice = |option: &'static str, value: &str, accepted: &[&str]| PipelineError::Option {
        option,
        value: value.to_string(),
        expected: accepted.join(" or "),
    };
    let velocity = match b.velocity.as_str() {
        "observer" => Velocity::Observer,
        "finite-difference" => Velocity::FiniteDifference,
        v => {
            return Err(choice(
                "backstepping.velocity",
                v,
                &["observer", "finite-difference"],
            ));
        }
    };
    let inner = match b.inner.as_str() {
        "estimate" => Inner::Estimate,
        "command" => Inner::Command,
        v => return Err(choice("backstepping.inner", v, &["estimate", "command"])),
    };
    let law = BacksteppingLaw {
        sample_time: f.sample_time_s,
        delay: b.delay_samples,
        phi: matrix(&b.phi),
        gamma: matrix(&b.gamma),
        f: matrix(&b.filter_f),
        l: matrix(&b.filter_l),
        b: matrix(&b.model_b),
        g_inv: matrix(&b.g_inv),
        d_inv: matrix(&b.d_inv),
        law: LawParams {
            error_gain: b.error_gain_per_s,
            eta_gain: b.eta_gain_per_s,
            feedback_gain: b.feedback_gain_per_s,
            robust: b.robust,
            eta_bound: b.eta_bound_m_per_s2,
            a_bound: b.a_bound_m_per_s,
            boundary_layer: b.boundary_layer,
        },
        velocity,
        inner,
        disturbance_feedback: b.disturbance_feedback,
        notches: b.notches.map(|a| a.map(|s| Biquad::new(s.b, s.a))),
        notch_delay: b.notch_delay_s,
        actuator: actuator_of(&f.actuator)?,
        learned: f.learned_m.clone(),
    };
    law.controller()?;
    Ok(law)
}

/// The C source and header of a coefficients file: functions and types prefixed by the
/// controller's name with `-` as `_` (`pi_notch_ff_step`), the header named
/// `<controller>.h`.
pub fn c_files(f: &ControllerFile) -> Result<CSource> {
    let (prefix, header) = (c_prefix(&f.controller), format!("{}.h", f.controller));
    Ok(match file_law(f)? {
        FileLaw::Linear(law) => law.c_source(&prefix, &header)?,
        FileLaw::Backstepping(law) => law.c_source(&prefix, &header)?,
    })
}

/// The controllers `track` wrote for a target.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Exported {
    /// The controllers written (JSON, C and header; a learned table as
    /// `<controller>+learning-<trajectory>`).
    pub written: Vec<String>,
}

/// The correction a learning run of `track` learned on one trajectory
/// (`track` exports it with its controller).
#[derive(Debug, Clone, PartialEq)]
pub struct LearnedTable {
    /// The controller the learning layer ran on.
    pub controller: &'static Controller,
    /// The trajectory it learned (the table holds one of its periods).
    pub trajectory: String,
    /// c\[k\] \[m\] per sample k of the period, k = 0 at the reference's start.
    pub table: Vec<[f64; 2]>,
}

impl LearnedTable {
    /// The exported controller's name: `<controller>+learning-<trajectory>` (characters of
    /// the trajectory's name other than letters, digits, `-`, `_` and `.` as `_`).
    pub fn name(&self) -> String {
        let trajectory: String = self
            .trajectory
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        format!(
            "{}-{trajectory}",
            crate::track::variant_name(self.controller, true)
        )
    }
}

/// Writes the coefficients file, the C source and the header of every controller of
/// `controllers` that `designs` holds (its linear target law, or its backstepping law
/// predicting over `delay` samples), and of each of them with a table of `learned` (as
/// `<controller>+learning-<trajectory>`), with the actuator stage `actuator`, into `out`'s
/// `controllers/` folder, each feed-forward with what it was fitted to (`fit`). A design
/// with neither law is an error.
#[allow(clippy::too_many_arguments)]
pub(crate) fn write_controllers(
    run: &RunDir,
    out: &Tracking,
    designs: &Designs,
    controllers: &[&'static Controller],
    learned: &[LearnedTable],
    actuator: ActuatorParams,
    delay: usize,
    fit: FeedForwardFit,
) -> Result<Exported> {
    let mut done = Exported::default();
    for &c in controllers {
        let Some(design) = designs.get(c) else {
            continue;
        };
        let mut files = vec![(
            c.name.to_string(),
            design_file(c, &**design, None, actuator, delay, fit)?,
        )];
        // A learned table goes with the design that learned it (the learning layer's).
        let under_learning = designs.for_learning(c).unwrap_or(design);
        for l in learned.iter().filter(|l| l.controller == c) {
            let table = Some(l.table.clone());
            let mut file = design_file(c, &**under_learning, table, actuator, delay, fit)?;
            file.controller = l.name();
            file.label = format!("{}, with the table learned on {}", c.label, l.trajectory);
            files.push((l.name(), file));
        }
        for (name, file) in files {
            let src = c_files(&file)?;
            run.store(&out.controller_json(&name), file)?;
            run.write(&out.controller_c(&name), src.source.as_bytes())?;
            run.write(&out.controller_h(&name), src.header.as_bytes())?;
            done.written.push(name);
        }
    }
    Ok(done)
}

/// The coefficients file of `design` (controller `c`): its linear target law, or its
/// backstepping law predicting over `delay` samples, with the learned `table` when given.
fn design_file(
    c: &'static Controller,
    design: &dyn Design,
    table: Option<Vec<[f64; 2]>>,
    actuator: ActuatorParams,
    delay: usize,
    fit: FeedForwardFit,
) -> Result<ControllerFile> {
    Ok(match TargetLaw::of_design(design, actuator)? {
        Some(l) => match table {
            None => fitted(controller_file(c, &l), fit),
            Some(t) => fitted(controller_file(c, &l.with_learned(t)), fit),
        },
        None => {
            let law = design.backstepping(actuator, delay)?;
            let law = law.ok_or_else(|| PipelineError::Option {
                option: "controller",
                value: c.name.to_string(),
                expected: "a controller with a target law (linear or backstepping)".into(),
            })?;
            match table {
                None => backstepping_file(c, &law),
                Some(t) => backstepping_file(c, &law.with_learned(t)),
            }
        }
    })
}

/// What [`export_controller`] wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ExportedController {
    /// The controller's name (from the file).
    pub controller: String,
    /// The C source.
    pub source: PathBuf,
    /// The C header.
    pub header: PathBuf,
}

/// Reads the coefficients file `json` and writes its C source and header
/// (`<controller>.c`, `<controller>.h`) into the folder `dir` (created if missing), each
/// atomically.
pub fn export_controller(json: &Path, dir: &Path) -> Result<ExportedController> {
    let bytes = std::fs::read(json).map_err(|source| PipelineError::Read {
        path: json.to_path_buf(),
        source,
    })?;
    let file = ControllerFile::decode(&bytes).map_err(|reason| PipelineError::Format {
        path: json.display().to_string(),
        reason,
    })?;
    let src = c_files(&file)?;
    let name = &file.controller;
    let source = dir.join(format!("{name}.c"));
    let header = dir.join(format!("{name}.h"));
    flexstage_run::write_atomic(&source, src.source.as_bytes())?;
    flexstage_run::write_atomic(&header, src.header.as_bytes())?;
    Ok(ExportedController {
        controller: name.clone(),
        source,
        header,
    })
}

/// A measured loop given as a file (`docs/formats.md`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Measurement<'a> {
    /// A measured response (`MeasuredResponse` CSV).
    Response(&'a Path),
    /// A time log (`LabLog` CSV), estimated by H1 with the default segments.
    Log(&'a Path),
}

/// The coefficients files of every controller of the registry designed from `response`
/// alone (no design, no twin), as `track` designs them: its loop model
/// (`flexstage_assess::lab::LabMeasurement::loop_model`: the z-domain fit with the static
/// gain read off the lowest lines) to tune the PI + notch and the PID on (to the margins
/// raised by the default allowance for the measurement's uncertainty,
/// `flexstage_assess::lab::LabParams::allowing`), the model's response fit for the
/// feed-forward and the backstepping's model, the backstepping's gains sized by their margins
/// on the measured loop model run in the time domain (`flexstage_assess::bench::MeasuredLoop`)
/// and its prediction over the delay the fit measured, and the scenario's settings for the
/// actuator stage (inverse compensation). With the `lifted` response of a fast ADC during the
/// same experiments (the output between the samples, the sensor's datasheet filter divided
/// out) the linear controllers' feed-forward is fitted to it at the samples (its phase 0), as
/// `track` fits it; without one to the sampled response; each file says which. A response
/// read back from its file gives the same files, bitwise.
pub fn measured_controller_files(
    response: &MeasuredResponse,
    lifted: Option<&LiftedResponse>,
    scenario: &Scenario,
) -> Result<Vec<ControllerFile>> {
    let measured = flexstage_assess::lab::LabMeasurement::from_response(
        response.clone(),
        &FitParams::default(),
    )?;
    let model = measured.loop_model();
    let fit = measured.response_fit();
    let mut setup = Setup::from_scenario(scenario);
    setup.rig.sample_time = response.sample_time();
    // The same allowance for the measurement's uncertainty as `track`'s designs.
    let tuning = flexstage_assess::lab::LabParams::default().allowing(&TuningParams::default())?;
    let probe = flexstage_assess::bench::MeasuredLoop {
        model: &measured.model,
        setup: &setup,
    };
    let mut stage = Stage::new(&setup, Some(&model), Some(fit), Some(&probe), tuning);
    stage.lifted = lifted;
    let designs = Designs::for_stage(&stage)?;
    let feedforward = FeedForwardFit::of(&stage);
    let actuator = setup.actuator(Compensation::Inverse);
    let delay = measured.model.delay();
    let mut files = Vec::new();
    for &c in &CONTROLLERS {
        let Some(design) = designs.get(c) else {
            continue;
        };
        if let Some(law) = TargetLaw::of_design(&**design, actuator)? {
            files.push(fitted(controller_file(c, &law), feedforward));
        } else if let Some(law) = design.backstepping(actuator, delay)? {
            files.push(backstepping_file(c, &law));
        }
    }
    Ok(files)
}

/// Designs every controller from a measured response or a time log alone, with the lifted
/// response file `lifted` of a fast ADC when given ([`measured_controller_files`], the
/// actuator settings of `scenario`: its PEAs' hysteresis model for the inverse compensation
/// and its stage's stroke) and writes each one's coefficients file, C source and header
/// (`<controller>.json`, `.c`, `.h`) into `dir` (created if missing), each atomically.
pub fn export_measured(
    source: Measurement<'_>,
    lifted: Option<&Path>,
    scenario: &Scenario,
    dir: &Path,
) -> Result<Vec<ExportedController>> {
    let path = match source {
        Measurement::Response(p) | Measurement::Log(p) => p,
    };
    let file = std::fs::File::open(path).map_err(|source| PipelineError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let origin = path.display().to_string();
    let response = match source {
        Measurement::Response(_) => MeasuredResponse::from_csv(file, &origin)?,
        Measurement::Log(_) => {
            let log = LabLog::from_csv(file, &origin)?;
            MeasuredResponse::from_log(&log, &WelchParams::default())?
        }
    };
    let lifted = match lifted {
        Some(p) => {
            let file = std::fs::File::open(p).map_err(|source| PipelineError::Read {
                path: p.to_path_buf(),
                source,
            })?;
            Some(LiftedResponse::from_csv(file, &p.display().to_string())?)
        }
        None => None,
    };
    let mut out = Vec::new();
    for f in measured_controller_files(&response, lifted.as_ref(), scenario)? {
        let name = f.controller.clone();
        let src = c_files(&f)?;
        let json = f.encode().map_err(|reason| PipelineError::Format {
            path: name.clone(),
            reason,
        })?;
        let source = dir.join(format!("{name}.c"));
        let header = dir.join(format!("{name}.h"));
        flexstage_run::write_atomic(&dir.join(format!("{name}.json")), &json)?;
        flexstage_run::write_atomic(&source, src.source.as_bytes())?;
        flexstage_run::write_atomic(&header, src.header.as_bytes())?;
        out.push(ExportedController {
            controller: name,
            source,
            header,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexstage_control::actuator::Compensation;
    use flexstage_control::experiment::Setup;
    use flexstage_control::pi_notch::{AxisGains, Notch, PiNotchParams};
    use flexstage_control::registry::{DEFAULT, Stage};
    use flexstage_control::target::{Recorded, recorded_sequence};

    fn law(compensation: Compensation) -> TargetLaw {
        let axis = |f: f64| AxisGains {
            kp: 0.1,
            ki: 1234.5678,
            kd: 0.0,
            notches: [
                Some(Notch {
                    frequency: f,
                    zero_damping: 0.03,
                    pole_damping: 0.6,
                }),
                Some(Notch {
                    frequency: 2.0 * f,
                    zero_damping: 0.0,
                    pole_damping: 0.3,
                }),
            ],
        };
        let p = PiNotchParams {
            axes: [axis(1010.0), axis(1700.0)],
            static_gain: [[0.93, 0.0123], [-0.0456, 1.07]],
            sample_time: 1e-4,
        };
        let setup = Setup::from_scenario(&flexstage_scenario::Scenario::paper());
        TargetLaw::of_linear(&p, setup.actuator(compensation)).unwrap()
    }

    /// The linear law of a file.
    fn linear(f: &ControllerFile) -> TargetLaw {
        match file_law(f).unwrap() {
            FileLaw::Linear(l) => *l,
            FileLaw::Backstepping(_) => panic!("{}: a linear law expected", f.controller),
        }
    }

    fn bits(seq: &[Recorded]) -> Vec<u64> {
        seq.iter()
            .flat_map(|r| {
                let c = r.command;
                [c.voltage, c.x_nom]
                    .into_iter()
                    .flatten()
                    .map(f64::to_bits)
                    .chain([u64::from(c.saturated)])
            })
            .collect()
    }

    /// Goal: a controller written to its JSON file and read back is the same controller,
    /// bitwise: the same coefficients, and the same commands on the recorded sequence (every
    /// compensation mode, two notches per axis, the scenario's PID; the PI + notch and the
    /// PID with their FIR feed-forward and the PPF controller designed on a sampled two-mode
    /// stage, the default with a learned table and with a reading correction); a version 3
    /// file still reads.
    #[test]
    fn controller_file_reads_back_the_same_controller_bitwise() {
        let setup = Setup::from_scenario(&flexstage_scenario::Scenario::paper());
        let inverse = setup.actuator(Compensation::Inverse);
        let designs = Designs::for_stage(&Stage::scenario(&setup)).unwrap();
        let pid = &flexstage_control::pid::PID_FF_SCENARIO;
        let scenario_pid = TargetLaw::of_design(&**designs.get(pid).unwrap(), inverse)
            .unwrap()
            .unwrap();
        let mut laws = vec![
            (DEFAULT, law(Compensation::Inverse)),
            (DEFAULT, law(Compensation::Off)),
            (DEFAULT, law(Compensation::Ideal)),
            (pid, scenario_pid),
        ];
        let sampled = flexstage_control::samples::decoupled_designs(&setup).unwrap();
        for c in [
            DEFAULT,
            &flexstage_control::pid::PID_FF,
            &flexstage_control::damping::PPF_PI_FF,
        ] {
            let l = TargetLaw::of_design(&**sampled.get(c).unwrap(), inverse)
                .unwrap()
                .unwrap();
            assert!(l.feedforward.is_some() || l.damping.is_some(), "{c}");
            laws.push((c, l));
        }
        let table = (0..500)
            .map(|k| [1e-9 / (1.0 + k as f64), -3e-9 * (k as f64 * 0.1).sin()])
            .collect();
        let learned = laws[4].1.clone().with_learned(table);
        laws.push((DEFAULT, learned));
        let ff = laws[4].1.feedforward.clone().unwrap();
        let correction = (0..ff.taps().len())
            .map(|u| {
                let v = [0.03, -0.02, -0.01]
                    .get(u.wrapping_sub(ff.preview()))
                    .copied();
                let v = v.unwrap_or(0.0);
                [[v, 1e-3 * v], [0.0, 0.5 * v]]
            })
            .collect();
        let reading = laws[4]
            .1
            .clone()
            .with_feedforward(ff.with_reading(correction).unwrap());
        laws.push((DEFAULT, reading));
        // A version 3 file (no reading correction) still reads.
        let mut v3 = controller_file(DEFAULT, &laws[4].1);
        v3.version = 3;
        let back = linear(&ControllerFile::decode(&v3.encode().unwrap()).unwrap());
        assert_eq!(back, laws[4].1);
        for (c, l) in laws {
            let bytes = controller_file(c, &l).encode().unwrap();
            let back = linear(&ControllerFile::decode(&bytes).unwrap());
            assert_eq!(back, l);
            assert_eq!(
                bits(&recorded_sequence(&back, 3).unwrap().samples),
                bits(&recorded_sequence(&l, 3).unwrap().samples)
            );
        }
    }

    /// Goal: the backstepping controllers written to their JSON file and read back are the
    /// same laws, bitwise: the same coefficients and the same commands on their recorded
    /// sequence (`robust` with one and two samples of delay, with a learned table,
    /// `nonrobust`, designed on a sampled two-mode stage); and a file of version 2 with the
    /// backstepping, or with both laws, is refused.
    #[test]
    fn backstepping_file_reads_back_the_same_controller_bitwise() {
        use flexstage_control::controller::{NONROBUST, ROBUST};
        use flexstage_control::target_backstepping::recorded_sequence;
        let setup = Setup::from_scenario(&flexstage_scenario::Scenario::paper());
        let inverse = setup.actuator(Compensation::Inverse);
        let designs = flexstage_control::samples::decoupled_designs(&setup).unwrap();
        let of = |c, delay| {
            designs
                .get(c)
                .unwrap()
                .backstepping(inverse, delay)
                .unwrap()
                .unwrap()
        };
        let table: Vec<[f64; 2]> = (0..500)
            .map(|k| [1e-9 / (1.0 + k as f64), -3e-9 * (k as f64 * 0.1).sin()])
            .collect();
        let laws = [
            (&ROBUST, of(&ROBUST, 1)),
            (&ROBUST, of(&ROBUST, 2)),
            (&ROBUST, of(&ROBUST, 1).with_learned(table)),
            (&NONROBUST, of(&NONROBUST, 1)),
        ];
        let commands = |l: &BacksteppingLaw| -> Vec<u64> {
            recorded_sequence(l, 3)
                .unwrap()
                .commands()
                .iter()
                .flat_map(|c| [c.voltage, c.x_nom].into_iter().flatten().map(f64::to_bits))
                .collect()
        };
        for (c, l) in laws {
            let file = backstepping_file(c, &l);
            let bytes = file.encode().unwrap();
            let back = match file_law(&ControllerFile::decode(&bytes).unwrap()).unwrap() {
                FileLaw::Backstepping(b) => *b,
                FileLaw::Linear(_) => panic!("a backstepping law expected"),
            };
            assert_eq!(back, l);
            assert_eq!(commands(&back), commands(&l));
            let src = c_files(&file).unwrap();
            assert!(src.header.contains("#define robust_BACKSTEPPING 1") || c != &ROBUST);
        }
        let mut v = backstepping_file(&ROBUST, &of(&ROBUST, 1));
        v.version = 2;
        let e = ControllerFile::decode(&flexstage_run::format::json(&v).unwrap()).unwrap_err();
        assert!(e.contains("backstepping"), "{e}");
        let mut v = backstepping_file(&ROBUST, &of(&ROBUST, 1));
        v.axes = controller_file(DEFAULT, &law(Compensation::Inverse)).axes;
        v.inverse_static_gain = Some([[1.0, 0.0], [0.0, 1.0]]);
        let e = ControllerFile::decode(&flexstage_run::format::json(&v).unwrap()).unwrap_err();
        assert!(e.contains("not both"), "{e}");
        let mut v = backstepping_file(&ROBUST, &of(&ROBUST, 1));
        v.backstepping.as_mut().unwrap().inner = "guess".into();
        let e = file_law(&v).unwrap_err().to_string();
        assert!(e.contains("backstepping.inner"), "{e}");
    }

    /// Goal: `track --learning` exports each controller once more with the table it learned
    /// on each trajectory (`<controller>+learning-<trajectory>`): one period of the circle
    /// (5000 samples at 10 kHz), not all zero, in the JSON and as the C's table, and the law
    /// read back is the controller's own with that table; the backstepping as well, with
    /// the minimal loop's delay (none).
    #[test]
    fn track_with_learning_exports_the_learned_table() {
        use crate::track::{PlantKind, TrackOptions, track};
        let root = std::env::temp_dir().join(format!("flexstage-learned-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let folder =
            crate::RunFolder::open(crate::folder::preset("quick").unwrap(), &root, false).unwrap();
        let pid = &flexstage_control::pid::PID_FF_SCENARIO;
        let options = TrackOptions {
            plant: PlantKind::Lumped,
            trajectory: Some("circle".into()),
            controllers: vec![pid, &flexstage_control::controller::ROBUST],
            duration: Some(0.05),
            learning: Some(2),
            ..TrackOptions::default()
        };
        let summary = track(&folder, &options, &crate::progress::Silent).unwrap();
        let name = "pid-ff-scenario+learning-circle";
        assert_eq!(
            summary.exported.written,
            ["pid-ff-scenario", name, "robust", "robust+learning-circle"]
        );
        let dir = summary.dir.join("controllers");
        let file =
            ControllerFile::decode(&std::fs::read(dir.join(format!("{name}.json"))).unwrap())
                .unwrap();
        let own = ControllerFile::decode(&std::fs::read(dir.join("pid-ff-scenario.json")).unwrap())
            .unwrap();
        let table = file.learned_m.clone().unwrap();
        assert_eq!(table.len(), 5000);
        assert!(table.iter().any(|c| c[0] != 0.0 && c[1] != 0.0));
        assert_eq!(linear(&file), linear(&own).with_learned(table));
        let source = std::fs::read_to_string(dir.join(format!("{name}.c"))).unwrap();
        assert!(source.contains("static const double LEARNED[5000][2]"));
        assert!(source.contains("#include \"pid-ff-scenario+learning-circle.h\""));
        // The backstepping with its table, predicting over no delay (the minimal loop).
        let read = |n: &str| {
            let f = ControllerFile::decode(&std::fs::read(dir.join(format!("{n}.json"))).unwrap())
                .unwrap();
            match file_law(&f).unwrap() {
                FileLaw::Backstepping(b) => *b,
                FileLaw::Linear(_) => panic!("{n}: a backstepping law expected"),
            }
        };
        let robust = read("robust+learning-circle");
        assert_eq!(robust.delay, 0);
        assert_eq!(robust.learned.as_ref().map(Vec::len), Some(5000));
        assert_eq!(
            robust,
            read("robust").with_learned(robust.learned.clone().unwrap())
        );
        std::fs::remove_dir_all(&root).unwrap();
    }

    /// A file of another version (than 1, 2 or 3), an unknown compensation or other
    /// compensator settings is refused with the field named.
    #[test]
    fn a_bad_controller_file_is_refused_naming_the_field() {
        let file = controller_file(DEFAULT, &law(Compensation::Inverse));
        let mut v = file.clone();
        v.version = 99;
        let e = ControllerFile::decode(&flexstage_run::format::json(&v).unwrap()).unwrap_err();
        assert!(e.contains("format version 99"), "{e}");
        // A version 1 file (no damping, FIR or learned table) still reads.
        v.version = 1;
        let back = ControllerFile::decode(&flexstage_run::format::json(&v).unwrap()).unwrap();
        assert_eq!(linear(&back), law(Compensation::Inverse));
        // A version 2 file has no rate limit: it reads as the law without one.
        assert!(file.actuator.max_voltage_step_v > 0.0);
        let mut json: serde_json::Value =
            serde_json::from_slice(&flexstage_run::format::json(&file).unwrap()).unwrap();
        json["version"] = 2.into();
        let actuator = json["actuator"].as_object_mut().unwrap();
        assert!(actuator.remove("max_voltage_step_v").is_some());
        let old = ControllerFile::decode(&serde_json::to_vec(&json).unwrap()).unwrap();
        let mut want = law(Compensation::Inverse);
        want.actuator.max_voltage_step = 0.0;
        assert_eq!(linear(&old), want);
        let mut v = file.clone();
        v.actuator.compensation = "sometimes".into();
        let e = file_law(&v).unwrap_err().to_string();
        assert!(e.contains("actuator.compensation"), "{e}");
        let mut v = file.clone();
        v.actuator.compensator_max_iterations = 3;
        let e = file_law(&v).unwrap_err().to_string();
        assert!(e.contains("compensator_max_iterations"), "{e}");
        let mut v = file;
        v.axes.as_mut().unwrap()[1].ki_per_s = -1.0;
        let e = file_law(&v).unwrap_err().to_string();
        assert!(e.contains("pid.ki"), "{e}");
    }

    /// `export_controller` writes the C of a file into a folder, named by the controller.
    #[test]
    fn export_controller_writes_source_and_header() {
        let dir = std::env::temp_dir().join(format!("flexstage-ctl-{}", std::process::id()));
        let json = dir.join("in.json");
        let file = controller_file(DEFAULT, &law(Compensation::Inverse));
        flexstage_run::write_atomic(&json, &file.encode().unwrap()).unwrap();
        let e = export_controller(&json, &dir.join("out")).unwrap();
        let source = std::fs::read_to_string(&e.source).unwrap();
        assert!(e.header.ends_with("pi-notch-ff.h"));
        assert!(source.contains("#include \"pi-notch-ff.h\""));
        assert!(source.contains("pi_notch_ff_step("));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A multisine measurement of the two decoupled 1 %-damped modes
    /// (`flexstage_sim::samples::decoupled_modes`) with one sample of delay at 10 kHz,
    /// simulated by each mode's exact ZOH discretization, with 10 nm of reading noise.
    fn measured() -> MeasuredResponse {
        use flexstage_identify::measured::MultisinePlan;
        let t = 1e-4;
        let modes = flexstage_sim::samples::decoupled_modes();
        let plan = MultisinePlan {
            period: 1000,
            lines: (1..500).collect(),
            periods: 4,
            settle: 3,
            amplitude: 1e-6,
            ..MultisinePlan::new(t)
        };
        let disc: Vec<_> = modes
            .iter()
            .map(|m| {
                let w = std::f64::consts::TAU * m.frequency;
                let a = nalgebra::DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -w * w, -0.02 * w]);
                let b = nalgebra::DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
                flexstage_sim::linalg::c2d(&a, &b, t).unwrap()
            })
            .collect();
        let log = |input: usize| {
            let cmds = plan.commands(input).unwrap();
            let mut noise = flexstage_numerics::noise::GaussianNoise::new(10e-9, input as u64);
            let mut x = vec![[0.0f64; 2]; modes.len()];
            let (mut c, mut r) = ([Vec::new(), Vec::new()], [Vec::new(), Vec::new()]);
            for k in 0..cmds.len() {
                for i in 0..2 {
                    let y: f64 = modes.iter().zip(&x).map(|(m, s)| m.output[i] * s[0]).sum();
                    r[i].push(y + noise.sample());
                    c[i].push(cmds[k][i]);
                }
                let u = if k > 0 { cmds[k - 1] } else { [0.0; 2] };
                for ((m, (phi, gam)), s) in modes.iter().zip(&disc).zip(x.iter_mut()) {
                    let v = m.input[0] * u[0] + m.input[1] * u[1];
                    *s = [
                        phi[(0, 0)] * s[0] + phi[(0, 1)] * s[1] + gam[0] * v,
                        phi[(1, 0)] * s[0] + phi[(1, 1)] * s[1] + gam[1] * v,
                    ];
                }
            }
            LabLog::new(t, c, r).unwrap()
        };
        let (a, b) = (log(0), log(1));
        MeasuredResponse::from_multisine([&a, &b], &plan).unwrap()
    }

    /// Goal: every controller (the PI + notch, the PID, the PPF and both backstepping
    /// controllers) is designed from a measured response alone, and a response written to
    /// its file and read back designs the same controllers, bitwise (every coefficient of
    /// their files).
    #[test]
    fn controllers_from_a_response_read_back_are_bitwise_the_same() {
        let r = measured();
        let scenario = Scenario::paper();
        let direct = measured_controller_files(&r, None, &scenario).unwrap();
        let back =
            MeasuredResponse::from_csv(r.to_csv().as_bytes(), "the written response").unwrap();
        let again = measured_controller_files(&back, None, &scenario).unwrap();
        let names: Vec<&str> = direct.iter().map(|f| f.controller.as_str()).collect();
        for want in ["pi-notch-ff", "pid-ff", "ppf-pi-ff", "robust", "nonrobust"] {
            assert!(names.contains(&want), "{want} missing: {names:?}");
        }
        let robust = direct.iter().find(|f| f.controller == "robust").unwrap();
        assert!(matches!(
            file_law(robust).unwrap(),
            FileLaw::Backstepping(_)
        ));
        assert_eq!(direct.len(), again.len());
        for (a, b) in direct.iter().zip(&again) {
            assert_eq!(a.encode().unwrap(), b.encode().unwrap(), "{}", a.controller);
        }
    }

    /// Reference: `track`'s designs on the rhombus fixture's twin, from its measurement's
    /// run files (`crate::track::measured_bench`: the measured and the lifted response).
    /// Goal: `flexstage controller --response FILE --lifted FILE` on those two files writes
    /// the same coefficients files, bitwise, for every linear controller (the feed-forward
    /// fitted to the lifted response, and saying so); without `--lifted` the feed-forward is
    /// fitted to the sampled response and says that.
    #[test]
    fn controllers_from_the_response_and_lifted_files_are_tracks_designs() {
        let (s, rho) = flexstage_twin::samples::quick_rhombus().unwrap();
        let twin = flexstage_twin::Twin::from_scenario(&s, &rho).unwrap();
        let setup = Setup::from_scenario(&s);
        let (bench, files) =
            crate::track::measured_bench(&setup, &twin, false, &crate::progress::Silent).unwrap();
        let dir = std::env::temp_dir().join(format!("flexstage-lifted-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (response, lifted) = (dir.join("h.csv"), dir.join("g.csv"));
        std::fs::write(&response, files.response.encode().unwrap()).unwrap();
        std::fs::write(&lifted, files.lifted.unwrap().encode().unwrap()).unwrap();
        let with = dir.join("with");
        export_measured(Measurement::Response(&response), Some(&lifted), &s, &with).unwrap();
        let without = dir.join("without");
        export_measured(Measurement::Response(&response), None, &s, &without).unwrap();
        let actuator = setup.actuator(Compensation::Inverse);
        let mut linear = 0;
        for &c in &CONTROLLERS {
            let Some(design) = bench.designs.get(c) else {
                continue;
            };
            let Some(law) = TargetLaw::of_design(&**design, actuator).unwrap() else {
                continue;
            };
            let want = fitted(controller_file(c, &law), bench.feedforward);
            let read = |d: &Path| std::fs::read(d.join(format!("{}.json", c.name))).unwrap();
            assert_eq!(read(&with), want.encode().unwrap(), "{c}");
            let other = ControllerFile::decode(&read(&without)).unwrap();
            if let Some(ff) = &want.feedforward {
                assert_eq!(ff.fitted_to.as_deref(), Some("lifted"), "{c}");
                let o = other.feedforward.unwrap();
                assert_eq!(o.fitted_to.as_deref(), Some("sampled"), "{c}");
                assert_ne!(o.taps, ff.taps, "{c}");
            }
            linear += 1;
        }
        assert!(linear >= 3, "{linear} linear controllers");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Goal: `export_measured` takes the actuator settings from the scenario it is given: the
    /// paper scenario writes what `measured_controller_files` designs with it, and a scenario
    /// whose PEA1 hysteresis differs writes a different inverse compensation.
    #[test]
    fn exported_controllers_take_the_given_scenarios_actuator() {
        let r = measured();
        let dir = std::env::temp_dir().join(format!("flexstage-export-{}", std::process::id()));
        let file = dir.join("measured.csv");
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(&file, r.to_csv()).unwrap();
        let read = |name: &str, to: &Path| std::fs::read(to.join(format!("{name}.json"))).unwrap();
        let paper = Scenario::paper();
        let written = export_measured(Measurement::Response(&file), None, &paper, &dir).unwrap();
        for (f, e) in measured_controller_files(&r, None, &paper)
            .unwrap()
            .iter()
            .zip(&written)
        {
            assert_eq!(read(&e.controller, &dir), f.encode().unwrap());
        }
        let mut other = Scenario::paper();
        other.hysteresis.pea1.d_p *= 1.5;
        let to = dir.join("other");
        export_measured(Measurement::Response(&file), None, &other, &to).unwrap();
        for e in &written {
            assert_ne!(
                read(&e.controller, &dir),
                read(&e.controller, &to),
                "{}",
                e.controller
            );
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
