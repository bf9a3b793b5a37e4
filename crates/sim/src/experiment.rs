//! The simulated tracking experiment (Section 4, Figures 9–11): a controller variant, a
//! plant and a reference, run sample by sample, with the time series and the metrics.
//!
//! The runner takes any [`StagePlant`]: the lumped plant in its minimal loop
//! ([`experiment`], the controller's ideal-loop tests), the lumped plant in the scenario's
//! rig ([`Setup::lumped_plant`]) or the finite-element twin of the designed stage
//! (`flexstage-twin`), through [`experiment_on`]. Before a run, [`Setup::check_reference`]
//! refuses references the rig cannot follow (above the Nyquist frequency, beyond the
//! amplifier range, the amplifier current or the controller's stroke).

use flexstage_piezo::BoucWenParams;
use flexstage_scenario::Scenario;

use crate::actuator::{ActuatorParams, Compensation};
use crate::backstepping::LawParams;
use crate::controller::{
    BacksteppingController, ControllerParams, Estimator, Inner, PidController, PidParams,
    StageControl, Velocity,
};
use crate::error::{ControlError, Result};
use crate::estimator::KalmanParams;
use crate::observer::ObserverParams;
use crate::pi_notch::{PiNotchController, PiNotchParams};
use crate::plant::{LumpedStage, Plant, PlantActuator, PlantParams};
use crate::rig::{RigParams, RigPlant, StagePlant};
use crate::trajectory::{Feasibility, Reference, Workspace, feasibility};

/// The controller variants compared.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variant {
    /// Backstepping with the robust terms (Figure 9b).
    Robust,
    /// Backstepping without the robust terms (Figure 9a).
    NonRobust,
    /// PID with inverse-hysteresis feedforward, tuned on the simulated plant's sampled
    /// frequency response by the same procedure as [`Variant::PiNotch`] ([`crate::tuning`],
    /// [`Setup::pid_tuned`]); where nothing was tuned (the lumped plant), the scenario's
    /// gains (`controller.pid`), as [`Variant::PidScenario`].
    PidFeedforward,
    /// PID with inverse-hysteresis feedforward with the scenario's gains (`controller.pid`)
    /// and the controller model's static gain, untuned: not among the defaults
    /// ([`Variant::ALL`]), run only when asked for by name (`--variant pid-ff-scenario`).
    PidScenario,
    /// PI + notches + inverse-hysteresis feedforward tuned on the simulated plant's sampled
    /// frequency response ([`crate::tuning`], [`Setup::pi_notch`]): the default, the one
    /// controller that meets 6 dB / 40° on the twin with one sample of delay.
    PiNotch,
}

impl Variant {
    /// All variants, in report order (the default first).
    pub const ALL: [Variant; 4] = [
        Variant::PiNotch,
        Variant::Robust,
        Variant::NonRobust,
        Variant::PidFeedforward,
    ];

    /// The default controller (DECISIONS.md, Control).
    pub const DEFAULT: Variant = Variant::PiNotch;

    /// Short name for files and tables.
    pub fn name(self) -> &'static str {
        match self {
            Variant::Robust => "robust",
            Variant::NonRobust => "nonrobust",
            Variant::PidFeedforward => "pid-ff",
            Variant::PidScenario => "pid-ff-scenario",
            Variant::PiNotch => "pi-notch-ff",
        }
    }

    /// Every variant that can be asked for by name: [`Variant::ALL`] and
    /// [`Variant::PidScenario`].
    pub const NAMED: [Variant; 5] = [
        Variant::PiNotch,
        Variant::Robust,
        Variant::NonRobust,
        Variant::PidFeedforward,
        Variant::PidScenario,
    ];

    /// Parses [`Variant::name`] (any of [`Variant::NAMED`]).
    pub fn from_name(s: &str) -> Option<Variant> {
        Variant::NAMED.into_iter().find(|v| v.name() == s)
    }
}

/// Everything needed to run experiments: controller, baseline and plant settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Setup {
    /// Backstepping controller settings (robust on; the non-robust variant switches it off).
    pub controller: ControllerParams,
    /// PID baseline gains.
    pub pid: PidParams,
    /// The lumped plant (truth parameters, cross terms) in its minimal loop.
    pub plant: PlantParams,
    /// The loop of the scenario's rig (`[rig]`), for [`Setup::lumped_plant`] and the twin.
    pub rig: RigParams,
    /// The PI + notch gains of [`Variant::PiNotch`], tuned on the plant that is simulated
    /// ([`crate::tuning::tune`]); `None` until tuned (that variant is then refused).
    pub pi_notch: Option<PiNotchParams>,
    /// The PID gains of [`Variant::PidFeedforward`] tuned by the same procedure
    /// ([`crate::tuning::tune`] with [`crate::tuning::Structure::Pid`]); `None`: that variant
    /// runs the scenario's gains.
    pub pid_tuned: Option<PiNotchParams>,
}

impl Setup {
    /// The setup of a scenario: controller model = `stage.guess`, plant = `stage.truth`
    /// with the cross terms, gains from `controller`, sensors, timing and hysteresis from the
    /// scenario. The bias voltage is the middle of the amplifier range.
    pub fn from_scenario(s: &Scenario) -> Setup {
        let h = &s.hysteresis;
        let hysteresis = [BoucWenParams::from(&h.pea1), BoucWenParams::from(&h.pea2)];
        let voltage_range = [h.voltage_min, h.voltage_max];
        let bias_voltage = 0.5 * (h.voltage_min + h.voltage_max);
        let c = &s.controller;
        let t = s.stage.truth.clone();
        let coupling = s.stage.coupling * (2.0 * t.k_qo1 * t.k_qo2).sqrt();
        Setup {
            controller: ControllerParams {
                model: s.stage.guess.clone(),
                coupling: 0.0,
                observer: ObserverParams {
                    gain: c.observer_gain,
                    sample_time: s.simulation.sample_time,
                    disturbance_gain: c.disturbance_gain,
                },
                law: LawParams {
                    error_gain: c.error_gain,
                    eta_gain: c.eta_gain,
                    feedback_gain: c.feedback_gain,
                    robust: true,
                    eta_bound: c.eta_bound,
                    a_bound: c.a_bound,
                    boundary_layer: c.boundary_layer,
                },
                velocity: if c.observer_velocity {
                    Velocity::Observer
                } else {
                    Velocity::FiniteDifference
                },
                inner: Inner::Command,
                estimator: Estimator::Kalman(KalmanParams::with_sensor_noise(s.sensors.noise_std)),
                disturbance_feedback: true,
                measurement_notches: [[None; 2]; 2],
                delay: RigParams::from_scenario(s).delay,
                actuator: ActuatorParams {
                    hysteresis,
                    voltage_range,
                    bias_voltage,
                    stroke: s.controller.stroke,
                    compensation: Compensation::Inverse,
                },
            },
            pid: PidParams {
                kp: c.pid[0],
                ki: c.pid[1],
                kd: c.pid[2],
            },
            plant: PlantParams {
                truth: t,
                coupling,
                hysteresis,
                voltage_range,
                bias_voltage,
                amplifier_bandwidth: s.simulation.amplifier_bandwidth,
                resolution: s.sensors.resolution,
                noise_std: s.sensors.noise_std,
                seed: s.simulation.seed,
                sample_time: s.simulation.sample_time,
                substeps: s.simulation.substeps,
                actuator: PlantActuator::Hysteretic,
            },
            rig: RigParams::from_scenario(s),
            pi_notch: None,
            pid_tuned: None,
        }
    }

    /// The lumped plant (truth parameters and cross terms of [`Setup::plant`]) inside the
    /// scenario's rig ([`Setup::rig`]): delay, amplifier limits, the rig's own PEAs with creep,
    /// sensor dynamics and noise, floor vibration.
    pub fn lumped_plant(&self) -> Result<RigPlant<LumpedStage>> {
        let mech = LumpedStage::new(&self.plant.truth, self.plant.coupling, self.rig.substep())?;
        RigPlant::new(self.rig.clone(), mech)
    }

    /// Whether `reference` over `duration` seconds can be followed on this rig, with the
    /// static gain `dc_gain` (x_nom → q) of the plant it will run on (`None`: the controller
    /// model's). Errors name what is exceeded and by how much ([`feasibility`]).
    pub fn check_reference(
        &self,
        reference: &Reference,
        duration: f64,
        dc_gain: Option<[[f64; 2]; 2]>,
    ) -> Result<Feasibility> {
        let gain = match dc_gain {
            Some(g) => g,
            None => {
                let g = crate::model::StageModel::new(&self.controller.model)?.dc_gain()?;
                [[g[(0, 0)], g[(0, 1)]], [g[(1, 0)], g[(1, 1)]]]
            }
        };
        feasibility(
            reference,
            duration,
            self.controller.observer.sample_time,
            gain,
            &self.controller.actuator,
            &self.rig.amplifier,
        )
    }

    /// The designed workspace of the controller's model: the image of |x_nom,i| ≤ stroke.
    pub fn workspace(&self) -> Result<Workspace> {
        let m = crate::model::StageModel::new(&self.controller.model)?;
        let g = m
            .dc_gain()?
            .try_inverse()
            .ok_or_else(|| crate::error::ControlError::Singular {
                what: "static gain G_dc".into(),
            })?;
        Ok(Workspace {
            inverse_gain: [[g[(0, 0)], g[(0, 1)]], [g[(1, 0)], g[(1, 1)]]],
            stroke: self.controller.actuator.stroke,
        })
    }

    /// Builds the controller of a variant with the given compensation mode.
    pub fn controller(
        &self,
        variant: Variant,
        compensation: Compensation,
        reference: Reference,
    ) -> Result<Box<dyn StageControl>> {
        let mut actuator = self.controller.actuator;
        actuator.compensation = compensation;
        Ok(match variant {
            Variant::Robust | Variant::NonRobust => {
                let mut p = self.controller.clone();
                p.actuator = actuator;
                p.law.robust = variant == Variant::Robust;
                Box::new(BacksteppingController::new(&p, reference)?)
            }
            Variant::PidFeedforward if self.pid_tuned.is_some() => {
                let p = self.pid_tuned.expect("checked");
                Box::new(PiNotchController::new(p, actuator, reference)?)
            }
            Variant::PidFeedforward | Variant::PidScenario => Box::new(PidController::new(
                &self.controller.model,
                self.pid,
                actuator,
                self.controller.observer.sample_time,
                reference,
            )?),
            Variant::PiNotch => {
                let p = self.pi_notch.ok_or_else(|| ControlError::Infeasible {
                    what: "controller pi-notch-ff".into(),
                    detail: "its gains are tuned on the simulated plant's frequency response \
                             (Setup::pi_notch), and none were given"
                        .into(),
                })?;
                Box::new(PiNotchController::new(p, actuator, reference)?)
            }
        })
    }
}

/// The time series of one run (one entry per sample).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Record {
    /// Time \[s\].
    pub t: Vec<f64>,
    /// Reference q_d \[m\].
    pub reference: [Vec<f64>; 2],
    /// Measured y \[m\].
    pub measured: [Vec<f64>; 2],
    /// True output q_o \[m\].
    pub truth: [Vec<f64>; 2],
    /// Tracking error q_o − q_d \[m\].
    pub error: [Vec<f64>; 2],
    /// Applied voltages \[V\].
    pub voltage: [Vec<f64>; 2],
    /// Commanded x_nom \[m\].
    pub x_nom: [Vec<f64>; 2],
    /// Estimated state ẑ and input disturbance d̂ \[SI\] (zeros for the PID baseline).
    pub estimate: [Vec<f64>; 10],
    /// Samples at which the command saturated.
    pub saturated: usize,
    /// Samples with a sensor dropout.
    pub dropouts: usize,
}

impl Record {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The CSV column names of [`Record::columns`].
    pub fn header() -> Vec<&'static str> {
        vec![
            "t_s", "ref1_m", "ref2_m", "meas1_m", "meas2_m", "true1_m", "true2_m", "err1_m",
            "err2_m", "volt1_V", "volt2_V", "xnom1_m", "xnom2_m", "zhat1", "zhat2", "zhat3",
            "zhat4", "zhat5", "zhat6", "zhat7", "zhat8", "dhat1_m", "dhat2_m",
        ]
    }

    /// The columns in [`Record::header`] order.
    pub fn columns(&self) -> Vec<&[f64]> {
        let mut c: Vec<&[f64]> = vec![&self.t];
        for group in [
            &self.reference,
            &self.measured,
            &self.truth,
            &self.error,
            &self.voltage,
            &self.x_nom,
        ] {
            c.extend(group.iter().map(|v| v.as_slice()));
        }
        c.extend(self.estimate.iter().map(|v| v.as_slice()));
        c
    }

    /// Metrics of the run; `half_range` per axis \[m\] (for % of range), as from
    /// [`Reference::half_range`].
    ///
    /// A non-finite sample (NaN or ∞: a diverged simulation) is never hidden: it is counted in
    /// [`Metrics::non_finite`], and the RMS, maximum and settling of its axis become NaN or ∞
    /// (the maximum propagates NaN, unlike `f64::max`, which would drop it and report 0).
    pub fn metrics(&self, half_range: [f64; 2]) -> Metrics {
        let n = self.len();
        let mut m = Metrics::default();
        if n == 0 {
            return m;
        }
        let mut settle = 0usize;
        for i in 0..2 {
            let e = &self.error[i];
            m.rms[i] = (e.iter().map(|x| x * x).sum::<f64>() / n as f64).sqrt();
            m.max[i] = max_abs(e);
            let range = 2.0 * half_range[i];
            let pct = |x: f64| if range > 0.0 { 100.0 * x / range } else { 0.0 };
            m.rms_pct[i] = pct(m.rms[i]);
            m.max_pct[i] = pct(m.max[i]);
            // Settling of the initial transient: the last sample whose error exceeds five
            // times the RMS error of the second half of the run.
            let tail = &e[n / 2..];
            let band = 5.0 * (tail.iter().map(|x| x * x).sum::<f64>() / tail.len() as f64).sqrt();
            m.steady_rms[i] = band / 5.0;
            if let Some(k) = e.iter().rposition(|x| x.abs() > band) {
                settle = settle.max(k + 1);
            }
        }
        m.non_finite = [&self.error, &self.truth, &self.voltage]
            .iter()
            .flat_map(|g| g.iter().flatten())
            .filter(|x| !x.is_finite())
            .count();
        m.settling = if m.non_finite > 0 {
            f64::NAN
        } else if settle < n {
            self.t[settle.min(n - 1)]
        } else {
            self.t[n - 1]
        };
        m.peak_voltage = fold_nan(self.voltage.iter().flatten().copied(), 0.0, f64::max);
        m.min_voltage = fold_nan(
            self.voltage.iter().flatten().copied(),
            f64::INFINITY,
            f64::min,
        );
        m.saturated = self.saturated;
        m.dropouts = self.dropouts;
        m
    }
}

/// `max |x|` over `x`, NaN if any element is NaN (where `f64::max` would skip it).
fn max_abs(x: &[f64]) -> f64 {
    fold_nan(x.iter().map(|v| v.abs()), 0.0, f64::max)
}

/// Folds with `f`, but any NaN element makes the result NaN.
fn fold_nan(x: impl Iterator<Item = f64>, init: f64, f: fn(f64, f64) -> f64) -> f64 {
    x.fold(init, |a, v| {
        if a.is_nan() || v.is_nan() {
            f64::NAN
        } else {
            f(a, v)
        }
    })
}

/// Tracking metrics of one run (errors against the true output).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Metrics {
    /// RMS error per axis \[m\].
    pub rms: [f64; 2],
    /// Max |error| per axis \[m\].
    pub max: [f64; 2],
    /// RMS error in % of the reference range (peak to peak).
    pub rms_pct: [f64; 2],
    /// Max error in % of the reference range.
    pub max_pct: [f64; 2],
    /// RMS error over the second half of the run (after the transient) \[m\].
    pub steady_rms: [f64; 2],
    /// Settling time of the initial transient \[s\].
    pub settling: f64,
    /// Highest applied voltage \[V\].
    pub peak_voltage: f64,
    /// Lowest applied voltage \[V\].
    pub min_voltage: f64,
    /// Saturated samples.
    pub saturated: usize,
    /// Sensor dropouts.
    pub dropouts: usize,
    /// Non-finite samples (NaN or ∞) in the error, true output and voltage series: a
    /// diverged run. Its metrics are NaN or ∞, never a finite-looking number.
    pub non_finite: usize,
}

impl Metrics {
    /// Whether the run diverged: a non-finite sample, or a non-finite RMS or maximum.
    pub fn diverged(&self) -> bool {
        self.non_finite > 0
            || self
                .rms
                .iter()
                .chain(&self.max)
                .chain(&self.steady_rms)
                .any(|x| !x.is_finite())
    }

    /// The combined RMS error over both axes \[m\].
    pub fn rms_total(&self) -> f64 {
        ((self.rms[0].powi(2) + self.rms[1].powi(2)) / 2.0).sqrt()
    }
}

/// Runs `controller` on `plant` for `duration` seconds and records everything. Allocates only
/// the record (once, up front).
pub fn run(
    controller: &mut dyn StageControl,
    plant: &mut dyn StagePlant,
    duration: f64,
    sample_time: f64,
    mut progress: impl FnMut(usize),
) -> Record {
    let n = (duration / sample_time).round() as usize;
    let mut rec = Record {
        t: Vec::with_capacity(n),
        ..Record::default()
    };
    for v in rec
        .reference
        .iter_mut()
        .chain(rec.measured.iter_mut())
        .chain(rec.truth.iter_mut())
        .chain(rec.error.iter_mut())
        .chain(rec.voltage.iter_mut())
        .chain(rec.x_nom.iter_mut())
        .chain(rec.estimate.iter_mut())
    {
        v.reserve_exact(n);
    }
    for k in 0..n {
        let y = plant.measure();
        let q = plant.output();
        let zh = controller.estimate();
        let cmd = controller.step(y);
        rec.t.push(k as f64 * sample_time);
        for i in 0..2 {
            rec.reference[i].push(cmd.reference[i]);
            rec.measured[i].push(y[i]);
            rec.truth[i].push(q[i]);
            rec.error[i].push(q[i] - cmd.reference[i]);
            rec.voltage[i].push(cmd.voltage[i]);
            rec.x_nom[i].push(cmd.x_nom[i]);
        }
        for (j, e) in rec.estimate.iter_mut().enumerate() {
            e.push(zh[j]);
        }
        rec.saturated += cmd.saturated as usize;
        rec.dropouts += cmd.dropout as usize;
        plant.apply(&cmd);
        if k % 1000 == 999 {
            progress(1000);
        }
    }
    rec
}

/// One experiment: variant, compensation, reference and duration on the setup's lumped
/// plant in its minimal loop ([`Setup::plant`]: the controller's ideal-loop conditions).
pub fn experiment(
    setup: &Setup,
    variant: Variant,
    compensation: Compensation,
    reference: Reference,
    duration: f64,
) -> Result<Record> {
    experiment_with_progress(setup, variant, compensation, reference, duration, |_| {})
}

/// [`experiment`] with a progress callback (called with the number of samples done since the
/// last call, every 1000 samples).
pub fn experiment_with_progress(
    setup: &Setup,
    variant: Variant,
    compensation: Compensation,
    reference: Reference,
    duration: f64,
    progress: impl FnMut(usize),
) -> Result<Record> {
    crate::error::positive("duration", duration)?;
    // The minimal loop has no delay: the controller predicts over none.
    let mut minimal = setup.clone();
    minimal.controller.delay = 0;
    let mut c = minimal.controller(variant, compensation, reference)?;
    let mut plant = Plant::new(setup.plant.clone())?;
    Ok(run(
        c.as_mut(),
        &mut plant,
        duration,
        setup.controller.observer.sample_time,
        progress,
    ))
}

/// One experiment on a given plant (e.g. [`Setup::lumped_plant`] or the twin of
/// `flexstage-twin`), from the plant's current state. `progress` is called with the number of
/// samples done since the last call, every 1000 samples.
pub fn experiment_on(
    setup: &Setup,
    variant: Variant,
    compensation: Compensation,
    reference: Reference,
    duration: f64,
    plant: &mut dyn StagePlant,
    progress: impl FnMut(usize),
) -> Result<Record> {
    crate::error::positive("duration", duration)?;
    let mut c = setup.controller(variant, compensation, reference)?;
    Ok(run(
        c.as_mut(),
        plant,
        duration,
        setup.controller.observer.sample_time,
        progress,
    ))
}
