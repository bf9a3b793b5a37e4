//! The twin measured as a lab measures its stage: the periodic multisine of
//! `flexstage_identify::measured` played through the twin's full rig at the controller's
//! sample time (zero-order hold, delay, amplifier, the hysteretic PEAs with creep, sensor
//! chain, the scenario's noise), the commands sent through the controllers' actuator stage
//! (the inverse hysteresis compensation by default), logged as a rig logs it, the response estimated from the
//! logs and fitted by a z-domain model. [`crate::Bench::measured`] designs the controllers
//! from this and nothing of the twin's truth.

use flexstage_control::actuator::{Actuator, ActuatorParams, Compensation};
use flexstage_control::experiment::Setup;
use flexstage_identify::frequency::C64;
use flexstage_identify::measured::{
    FastAdc, FastLog, FitParams, LabLog, LiftedResponse, MeasuredResponse, MultisinePlan, ZFit,
    run_fast_log, run_log,
};
use flexstage_identify::response::{RESPONSE_SHARE, ResponseFit};
use flexstage_sim::modal::LoopPlant;
use flexstage_sim::rig::RigParams;
use flexstage_twin::Twin;

use flexstage_control::tuning::TuningParams;

use crate::error::{Result, check};

/// Settings of the lab measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct LabParams {
    /// The multisine; `None` for [`MultisinePlan::new`] at the rig's sample time.
    pub plan: Option<MultisinePlan>,
    /// The z-domain fit.
    pub fit: FitParams,
    /// Whether the rig's noise (white, 1/f, quantization, floor) is on, as the scenario says;
    /// `false` for a noise-free measurement (a reference).
    pub noise: bool,
    /// How a command becomes the amplifiers' voltage: the controllers' actuator stage with
    /// this compensation, so that the command is the x_nom the controllers write. Default
    /// [`Compensation::Inverse`], as `track` runs them.
    pub compensation: Compensation,
    /// Relative uncertainty ε of the measured loop the designs allow for, 0 ≤ ε < 0.5
    /// (default 0.03): the linear designs are tuned to the gain margin raised by
    /// 20·log10(1 + ε) dB and the phase margin raised by asin(ε) (a loop off its model by a
    /// factor within 1 ± ε, in gain and direction, keeps the targets). The 3 % cover the
    /// measured gap between the rig and its linearization (1.1–1.8 %: the PEAs' small-signal
    /// gain under the inverse compensation) and the noise (std ≤ 1e-4 of |H| near the
    /// crossovers).
    pub uncertainty: f64,
    /// The lab's fast ADC on the sensor's analog output during the same experiments: its
    /// samples per controller sample L (a divisor of the rig's substeps), `None` without
    /// one. Default `Some(`[`FAST_ADC_RATIO`]`)`. With it the measurement carries the lifted
    /// response ([`LabMeasurement::lifted`]) the linear designs' feed-forward is fitted to.
    pub fast_adc: Option<usize>,
}

/// The fast ADC's samples per controller sample by default: L = 10 (100 kHz at a 10 kHz
/// loop). Measured on the quick design (the sweep's best q1 at the samples, % of range, at
/// 3 % / 10 % of f1): L = 10 0.41 / 2.08, L = 4 0.52 / 2.07 (the sensor's filter divided
/// out of fewer harmonics); the estimate's cost grows with L (`docs/verification.md`).
pub const FAST_ADC_RATIO: usize = 10;

impl LabParams {
    /// The tuning `tuning` with its margin targets raised by the allowance for the
    /// measurement's uncertainty ([`LabParams::uncertainty`]); errors name the field.
    pub fn allowing(&self, tuning: &TuningParams) -> Result<TuningParams> {
        let u = self.uncertainty;
        check("lab.uncertainty", u, (0.0..0.5).contains(&u), "0 ≤ ε < 0.5")?;
        let mut t = tuning.clone();
        t.gain_margin_db += 20.0 * u.ln_1p() / std::f64::consts::LN_10;
        t.phase_margin_deg += u.asin().to_degrees();
        Ok(t)
    }
}

impl Default for LabParams {
    fn default() -> Self {
        LabParams {
            plan: None,
            fit: FitParams::default(),
            noise: true,
            compensation: Compensation::Inverse,
            uncertainty: 0.03,
            fast_adc: Some(FAST_ADC_RATIO),
        }
    }
}

/// What the lab measured: the two logs' response and its loop model, and the lifted
/// response of a fast ADC when the lab had one.
#[derive(Debug, Clone, PartialEq)]
pub struct LabMeasurement {
    /// The measured response.
    pub response: MeasuredResponse,
    /// Its z-domain fit, the loop model the designs tune on.
    pub model: ZFit,
    /// The lifted response of the output from the fast ADC on the sensor's analog output
    /// during the same experiments, the sensor's datasheet filter divided out
    /// ([`measure_lifted`]); `None` without a fast ADC.
    pub lifted: Option<LiftedResponse>,
}

/// The lab's rig for its experiments (the noise off when `p.noise` is) and its multisine
/// plan, the same for the sampled ([`lab_logs`]) and the lifted ([`measure_lifted`])
/// measurement.
fn experiment(setup: &Setup, p: &LabParams) -> (RigParams, MultisinePlan) {
    let mut rig = setup.rig.clone();
    if !p.noise {
        rig.noise_std = [0.0; 2];
        rig.resolution = [0.0; 2];
        rig.sensor.flicker_corner = 0.0;
        rig.floor.velocity_rms = 0.0;
    }
    let plan = p
        .plan
        .clone()
        .unwrap_or_else(|| MultisinePlan::new(rig.sample_time));
    (rig, plan)
}

/// The rig of the experiment that drives PEA `input`, from rest with a noise seed of its own.
fn experiment_rig(rig: &RigParams, input: usize) -> RigParams {
    let mut r = rig.clone();
    r.seed = rig.seed.wrapping_add(101 * (input as u64 + 1));
    r
}

/// The lab's fast ADC while the loop runs (a learning layer's trials,
/// `flexstage_control::learning::Learning::retarget`): `ratio` samples per controller sample
/// on the sensor's analog output, its white noise the rig's sensor noise (as in
/// [`fast_logs`]), its own seed.
pub fn operating_fast_adc(rig: &RigParams, ratio: usize) -> FastAdc {
    FastAdc {
        ratio,
        noise_std: rig.noise_std,
        seed: rig.seed.wrapping_mul(31).wrapping_add(7),
    }
}

/// The actuator stage that drives the experiments. The excitation is open loop: the
/// controllers' rate limit (their anti-windup) is not part of the lab's drive, which meets
/// the amplifier's own limits in the rig.
fn drive(setup: &Setup, p: &LabParams) -> Result<Actuator> {
    Ok(Actuator::new(ActuatorParams {
        max_voltage_step: 0.0,
        ..setup.actuator(p.compensation)
    })?)
}

/// The two multisine logs of `twin` in the rig of `setup` (one experiment per PEA, each
/// from rest, with noise seeds of their own).
pub fn lab_logs(twin: &Twin, setup: &Setup, p: &LabParams) -> Result<([LabLog; 2], MultisinePlan)> {
    let (rig, plan) = experiment(setup, p);
    let log = |input: usize| -> Result<LabLog> {
        let r = experiment_rig(&rig, input);
        let mut plant = twin.plant(&r)?;
        let mut actuator = drive(setup, p)?;
        let t = r.sample_time;
        Ok(run_log(&mut plant, t, &plan.commands(input)?, |x| {
            actuator.command(x, t).voltage
        })?)
    };
    Ok(([log(0)?, log(1)?], plan))
}

/// The two experiments of [`lab_logs`] (the same plan, commands, seeds) with a fast ADC of
/// `ratio` samples per controller sample on the sensor's analog output, its white noise the
/// rig's (`noise_std`, none when `p.noise` is off). Each [`FastLog`]'s log at the
/// controller's rate is [`lab_logs`]' (the fast ADC has noise of its own).
pub fn fast_logs(
    twin: &Twin,
    setup: &Setup,
    p: &LabParams,
    ratio: usize,
) -> Result<([FastLog; 2], MultisinePlan)> {
    let (rig, plan) = experiment(setup, p);
    let log = |input: usize| -> Result<FastLog> {
        let r = experiment_rig(&rig, input);
        let adc = FastAdc {
            ratio,
            noise_std: r.noise_std,
            seed: r.seed.wrapping_mul(17).wrapping_add(3),
        };
        let mut plant = twin.plant(&r)?;
        let mut actuator = drive(setup, p)?;
        let t = r.sample_time;
        Ok(run_fast_log(
            &mut plant,
            t,
            &plan.commands(input)?,
            |x| actuator.command(x, t).voltage,
            &adc,
        )?)
    };
    Ok(([log(0)?, log(1)?], plan))
}

/// The lifted response of `twin`'s output in the rig of `setup`: the experiments of
/// [`fast_logs`] with the sensor's datasheet filter (the rig's sensor chain) divided out
/// ([`LiftedResponse::from_multisine`]).
pub fn measure_lifted(
    twin: &Twin,
    setup: &Setup,
    p: &LabParams,
    ratio: usize,
) -> Result<LiftedResponse> {
    let ([a, b], plan) = fast_logs(twin, setup, p, ratio)?;
    Ok(LiftedResponse::from_multisine(
        [&a, &b],
        &plan,
        &setup.rig.sensor,
    )?)
}

/// Measures `twin` in the rig of `setup` (module docs).
/// With a fast ADC (`p.fast_adc`) the two experiments are recorded by it too
/// ([`fast_logs`]: the response from their logs at the controller's rate is the one without
/// it, bitwise) and the measurement carries their lifted response.
pub fn measure(twin: &Twin, setup: &Setup, p: &LabParams) -> Result<LabMeasurement> {
    let Some(ratio) = p.fast_adc else {
        let ([a, b], plan) = lab_logs(twin, setup, p)?;
        let response = MeasuredResponse::from_multisine([&a, &b], &plan)?;
        return LabMeasurement::from_response(response, &p.fit);
    };
    let ([a, b], plan) = fast_logs(twin, setup, p, ratio)?;
    let response = MeasuredResponse::from_multisine([&a.log, &b.log], &plan)?;
    let lifted = LiftedResponse::from_multisine([&a, &b], &plan, &setup.rig.sensor)?;
    Ok(LabMeasurement::from_response(response, &p.fit)?.with_lifted(lifted))
}

impl LabMeasurement {
    /// A measured `response` (from the rig or its file) with its loop model fitted by `fit`.
    /// No lifted response ([`LabMeasurement::with_lifted`] adds one).
    pub fn from_response(response: MeasuredResponse, fit: &FitParams) -> Result<LabMeasurement> {
        let model = ZFit::fit(&response, fit)?;
        Ok(LabMeasurement {
            response,
            model,
            lifted: None,
        })
    }

    /// The measurement with the lifted response `lifted` of the same experiments (a fast
    /// ADC's, [`measure_lifted`], or read from its file).
    pub fn with_lifted(self, lifted: LiftedResponse) -> LabMeasurement {
        LabMeasurement {
            lifted: Some(lifted),
            ..self
        }
    }

    /// The static gain read off the measurement: per entry, the real part of the
    /// inverse-variance weighted mean of the lines below [`STATIC_SHARE`] of the loop
    /// model's lowest mode (at least the lowest line), where the loop is flat. Not the
    /// model's H(1): no line constrains the fit below the lowest one, and with noise a
    /// high-order fit can swing there (measured: a perturbed twin with twice the sensor
    /// noise, lines within 5 % of the truth from 5 Hz up, H(1) of the fit with the sign of
    /// H₂₂ flipped).
    pub fn static_gain(&self) -> [[f64; 2]; 2] {
        let lines = self.response.lines();
        let first_mode = self.model.modes().first().map_or(f64::INFINITY, |m| m.0);
        let top = STATIC_SHARE * first_mode;
        let mut g = [[0.0; 2]; 2];
        for (i, row) in g.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                let (mut sum, mut weight) = (0.0, 0.0);
                for (k, l) in lines.iter().enumerate() {
                    if k > 0 && l.f > top {
                        break;
                    }
                    let w = 1.0 / l.std[i][j].powi(2).max(f64::MIN_POSITIVE);
                    sum += w * l.h[i][j].re;
                    weight += w;
                }
                *v = sum / weight;
            }
        }
        g
    }

    /// What a response fit of the lumped model takes from the measurement: the loop model's
    /// (`ZFit::response_fit` with the share `RESPONSE_SHARE`) with the static gain read off
    /// the lines ([`LabMeasurement::static_gain`]).
    pub fn response_fit(&self) -> ResponseFit {
        let mut fit = self.model.response_fit(RESPONSE_SHARE);
        fit.dc_gain = self.static_gain();
        fit
    }

    /// The loop model the designs tune on: the z-domain fit's response and modes with the
    /// static gain read off the lines ([`LabMeasurement::static_gain`]), and that static
    /// gain as the response below the lowest line ([`MeasuredLoopModel::lowest_line`]).
    pub fn loop_model(&self) -> MeasuredLoopModel<'_> {
        MeasuredLoopModel {
            model: &self.model,
            static_gain: self.static_gain(),
            lowest_line: self.response.lines().first().map_or(0.0, |l| l.f),
        }
    }
}

/// Share of the lowest mode's frequency below which the measured lines give the static
/// gain: 1/20, where a mode's own response is within (1/20)² = 0.25 % of its static value.
pub const STATIC_SHARE: f64 = 0.05;

/// The measured loop model ([`LabMeasurement::loop_model`]): the z-domain fit where lines
/// were measured, the static gain read off the lowest lines below them.
///
/// Below the lowest line nothing constrains the fit, and with noise it swings there: on a
/// perturbed quick twin with two samples of delay and twice the sensor noise (Monte-Carlo
/// plant 48 of the default study), lines from 5 Hz up within a few % of the static gain,
/// the fit at 0.05 Hz had H₂₁ = −9.5 where the lines read +2.5, so that P G⁻¹ there had an
/// eigenvalue in the left half-plane: any integral action failed the Nyquist test on the
/// model, and no controller was designed for a stage the same procedure controls when
/// measured with other noise. The stage is flat there (its lowest mode is kHz), as the
/// lowest lines show: the model says what they say.
#[derive(Debug, Clone, Copy)]
pub struct MeasuredLoopModel<'a> {
    /// The z-domain fit.
    pub model: &'a ZFit,
    /// The static gain read off the lines.
    pub static_gain: [[f64; 2]; 2],
    /// The lowest measured line \[Hz\]: below it the response is `static_gain`.
    pub lowest_line: f64,
}

impl LoopPlant for MeasuredLoopModel<'_> {
    fn response(&self, f: f64) -> [[C64; 2]; 2] {
        if f.abs() < self.lowest_line {
            return self.static_gain.map(|row| row.map(|g| C64::new(g, 0.0)));
        }
        self.model.response(f)
    }

    fn static_gain(&self) -> [[f64; 2]; 2] {
        self.static_gain
    }

    fn modes(&self) -> Vec<(f64, f64)> {
        self.model.modes()
    }

    fn sample_time(&self) -> f64 {
        self.model.sample_time()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference: the measurement without a fast ADC ([`lab_logs`]) and the lifted response
    /// of [`measure_lifted`], each from experiments of their own. Goal: recording the same
    /// experiments with the fast ADC ([`measure`] with `fast_adc`) leaves the sampled
    /// response and its loop model bitwise as they were (the fast ADC reads the sensor's
    /// analog output with noise of its own) and gives that lifted response bitwise, on the
    /// rhombus fixture's twin.
    #[test]
    fn the_fast_adc_records_the_same_experiments_without_changing_them() {
        let (s, rho) = flexstage_twin::samples::quick_rhombus().unwrap();
        let twin = Twin::from_scenario(&s, &rho).unwrap();
        let setup = Setup::from_scenario(&s);
        let without = LabParams {
            fast_adc: None,
            ..LabParams::default()
        };
        let plain = measure(&twin, &setup, &without).unwrap();
        assert_eq!(plain.lifted, None);
        let with = measure(&twin, &setup, &LabParams::default()).unwrap();
        assert_eq!(with.response, plain.response);
        assert_eq!(with.model, plain.model);
        let lifted = measure_lifted(&twin, &setup, &without, FAST_ADC_RATIO).unwrap();
        assert_eq!(lifted.ratio(), FAST_ADC_RATIO);
        assert_eq!(with.lifted, Some(lifted));
    }

    /// Reference: a response known in closed form, G z⁻¹/(1 + j f/2 kHz) with G the 2 × 2
    /// gain of the quick stage's sign pattern, on the default multisine's lines (5 Hz to
    /// 4.995 kHz every 5 Hz), with a ±4 % ripple on the lines below 30 Hz as a noisy
    /// measurement has there. Goal: the loop model is the static gain read off the lines,
    /// exactly, at every frequency below the lowest line (where the z-fit is unconstrained),
    /// and the z-fit itself from the lowest line up; the static gain is G within the ripple.
    #[test]
    fn loop_model_below_the_lowest_line_is_the_measured_static_gain() {
        let g = [[0.23, 0.95], [2.5, -2.8]];
        let t = 1e-4;
        let mut csv = String::from(
            "f,re11,im11,re12,im12,re21,im21,re22,im22,coh11,coh12,coh21,coh22,sample_time,\
             std11,std12,std21,std22\n",
        );
        for k in 1..=999 {
            let f = 5.0 * k as f64;
            let ripple = if f < 30.0 {
                1.0 + 0.04 * (k as f64).sin()
            } else {
                1.0
            };
            let h =
                C64::from_polar(ripple, -std::f64::consts::TAU * f * t) / C64::new(1.0, f / 2000.0);
            csv.push_str(&format!("{f:e}"));
            for row in g {
                for v in row {
                    let e = h * v;
                    csv.push_str(&format!(",{:e},{:e}", e.re, e.im));
                }
            }
            csv.push_str(&format!(",1,1,1,1,{t:e}"));
            for row in g {
                for v in row {
                    csv.push_str(&format!(",{:e}", 0.01 * f64::abs(v)));
                }
            }
            csv.push('\n');
        }
        let response = MeasuredResponse::from_csv(csv.as_bytes(), "synthetic").unwrap();
        let m = LabMeasurement::from_response(response, &FitParams::default()).unwrap();
        let model = m.loop_model();
        let gain = m.static_gain();
        for (row, truth) in gain.iter().zip(g) {
            for (v, e) in row.iter().zip(truth) {
                assert!(
                    (v / e - 1.0).abs() < 0.04,
                    "static gain {gain:?} against {g:?}"
                );
            }
        }
        for f in [1e-3, 0.05, 1.0, 4.999] {
            let h = model.response(f);
            for (row, want) in h.iter().zip(gain) {
                for (v, w) in row.iter().zip(want) {
                    assert_eq!((v.re, v.im), (w, 0.0), "at {f} Hz");
                }
            }
        }
        for f in [5.0, 7.5, 1234.0] {
            assert_eq!(model.response(f), m.model.response(f), "at {f} Hz");
        }
    }

    /// Reference: by hand, ε = 3 %: 20·log10(1.03) = 0.25674 dB and asin(0.03) = 1.71913°.
    /// Goal: the allowance raises the targets by exactly that and nothing else; ε outside
    /// [0, 0.5) or NaN is refused naming the field.
    #[test]
    fn allowance_raises_the_targets_by_the_uncertainty() {
        let base = TuningParams::default();
        let t = LabParams::default().allowing(&base).unwrap();
        assert!((t.gain_margin_db - base.gain_margin_db - 0.256_744_4).abs() < 1e-6);
        assert!((t.phase_margin_deg - base.phase_margin_deg - 1.719_131).abs() < 1e-5);
        assert_eq!(t.zero_ratios, base.zero_ratios);
        for bad in [-0.01, 0.5, f64::NAN] {
            let p = LabParams {
                uncertainty: bad,
                ..LabParams::default()
            };
            let e = p.allowing(&base).unwrap_err().to_string();
            assert!(e.contains("lab.uncertainty"), "{e}");
        }
    }
}
