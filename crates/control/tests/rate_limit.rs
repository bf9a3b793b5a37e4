//! The actuator stage's rate limit (the amplifier's current and slew as the controller's
//! anti-windup) on the rig model of the quick preset: 3 kHz amplifier, 0.1 A into 1.5 µF, one
//! sample of delay, the lumped stage with its Bouc–Wen PEAs.
//!
//! Goal: the limit derived from the datasheet values keeps a step's amplifier current under
//! the limit (the rig's own limits never act), and the integrator of the linear laws no
//! longer winds up while the amplifier slews.

use flexstage_control::actuator::{Actuator, Compensation};
use flexstage_control::experiment::Setup;
use flexstage_control::pid::PID_FF_SCENARIO;
use flexstage_control::registry::{Designs, Stage};
use flexstage_control::target::{TargetInput, TargetLaw};
use flexstage_scenario::{Preset, Scenario};
use flexstage_sim::experiment::Command;
use flexstage_sim::rig::StagePlant;

fn setup() -> Setup {
    Setup::from_scenario(&Scenario::preset(Preset::Quick))
}

/// The rig's voltages for the actuator stage's commands toward x_nom = `target` from rest,
/// with the amplifier as set and without its slew and current limits.
fn voltages(step: f64, target: [f64; 2], samples: usize) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let s = setup();
    let mut params = s.actuator(Compensation::Inverse);
    params.max_voltage_step = step;
    let mut actuator = Actuator::new(params).unwrap();
    let mut free = s.clone();
    free.rig.amplifier.slew_rate = 0.0;
    free.rig.amplifier.current_limit = 0.0;
    let mut limited = s.lumped_plant().unwrap();
    let mut unlimited = free.lumped_plant().unwrap();
    let (mut a, mut b) = (Vec::new(), Vec::new());
    let t = s.rig.sample_time;
    for _ in 0..samples {
        let act = actuator.command(target, t);
        let cmd = Command {
            voltage: act.voltage,
            x_nom: act.x_nom,
            ..Command::default()
        };
        limited.apply(&cmd);
        unlimited.apply(&cmd);
        a.push(limited.voltage());
        b.push(unlimited.voltage());
    }
    (a, b)
}

/// Reference: the amplifier of the rig (first order, 3 kHz, |dU/dt| ≤ I_max/C = 66.7 V/ms)
/// driven by a held command: δ = r_max T (1 − e^{−x})/x, x = 2π f_a T, = 3.00 V at 10 kHz.
/// A step of 20 µm on both PEAs, rate-limited by δ, never makes the rig's current limit act
/// (the voltages equal those of the same rig without slew and current limits, and the mean
/// current C ΔU/T of every sample stays under 0.1 A); without the limiter the rig's limit acts
/// (the voltages differ by volts).
#[test]
fn the_rate_limit_keeps_a_steps_current_under_the_amplifiers_limit_on_the_rig() {
    let s = setup();
    let step = s.actuator(Compensation::Inverse).max_voltage_step;
    let a = &s.rig.amplifier;
    let x = std::f64::consts::TAU * a.bandwidth * s.rig.sample_time;
    let want = a.current_limit / a.capacitance * s.rig.sample_time * (1.0 - (-x).exp()) / x;
    assert!(
        (step - want).abs() < 1e-12 * want && (step - 3.0).abs() < 0.01,
        "{step}"
    );
    let (limited, free) = voltages(step, [20e-6, -20e-6], 600);
    let mut worst: f64 = 0.0;
    for k in 0..limited.len() {
        for i in 0..2 {
            assert_eq!(limited[k][i], free[k][i], "sample {k}, PEA {}", i + 1);
            if k > 0 {
                let current =
                    a.capacitance * (limited[k][i] - limited[k - 1][i]).abs() / s.rig.sample_time;
                worst = worst.max(current);
            }
        }
    }
    println!("rate-limited step: largest mean current per sample {worst:.4} A");
    assert!(worst < a.current_limit && worst > 0.02, "{worst}");
    let (limited, free) = voltages(0.0, [20e-6, -20e-6], 600);
    let diff = limited
        .iter()
        .zip(&free)
        .map(|(p, q)| (p[0] - q[0]).abs().max((p[1] - q[1]).abs()))
        .fold(0.0, f64::max);
    println!("without the limiter: the rig's current limit moves the voltages by {diff:.1} V");
    assert!(diff > 5.0, "{diff}");
}

/// The PID + feed-forward law designed from the scenario (`pid-ff-scenario`) on the lumped
/// stage in the quick rig: a scan of `periods` periods of a `frequency` sine of amplitude
/// 15 µm on both axes (opposite signs) that the amplifier's current limit cannot follow,
/// then the reference held at zero. Returns per axis the largest |q| in the hold after the
/// amplifier has caught up (2 ms on) in % of the amplitude — what a wound-up integrator
/// leaves — and the samples the rate limit clipped.
fn scan_overshoot(limit: bool, frequency: f64, periods: f64) -> ([f64; 2], usize) {
    let s = setup();
    let designs = Designs::for_stage(&Stage::scenario(&s)).unwrap();
    let mut actuator = s.actuator(Compensation::Inverse);
    if !limit {
        actuator.max_voltage_step = 0.0;
    }
    let law = TargetLaw::of_design(&**designs.get(&PID_FF_SCENARIO).unwrap(), actuator)
        .unwrap()
        .unwrap();
    let mut c = law.controller().unwrap();
    let mut plant = s.lumped_plant().unwrap();
    let t = s.rig.sample_time;
    let amplitude = 15e-6;
    let scan = (periods / frequency / t).round() as usize;
    let mut excursion = [0.0f64; 2];
    let mut clipped = 0;
    for k in 0..scan + 500 {
        let w = (std::f64::consts::TAU * frequency * k as f64 * t).sin();
        let r = if k < scan {
            [amplitude * w, -amplitude * w]
        } else {
            [0.0; 2]
        };
        let y = plant.measure();
        let act = c.step(&TargetInput {
            ahead: r,
            reference: r,
            reading: y,
            index: k,
        });
        clipped += usize::from(act.rate_limited);
        plant.apply(&Command {
            voltage: act.voltage,
            x_nom: act.x_nom,
            reference: r,
            saturated: act.saturated,
            dropout: false,
        });
        if k >= scan + 20 {
            let q = plant.output();
            for i in 0..2 {
                excursion[i] = excursion[i].max(100.0 * q[i].abs() / amplitude);
            }
        }
    }
    (excursion, clipped)
}

/// Known answer of anti-windup: on scans the amplifier cannot follow (15 µm at 200 Hz for
/// four periods, at 800 Hz for 4.5: every sample needs more than the current limit), the
/// integrator that runs while the rig's current limit holds the amplifier back (invisible to
/// the law) winds up and leaves an excursion of 6–10 % of the amplitude once the reference
/// holds still; with the rate limit the law sees the limit, holds its integrator, and the
/// excursion is that of the amplifier catching up (≤ 2 %).
#[test]
fn without_the_rate_limit_the_integrator_winds_up_and_with_it_it_does_not() {
    for (f, n) in [(200.0, 4.0), (800.0, 4.5)] {
        let (without, none) = scan_overshoot(false, f, n);
        let (with, clipped) = scan_overshoot(true, f, n);
        println!(
            "{f} Hz x {n}: excursion after the scan without the rate limit {:.2} / {:.2} % of \
             the amplitude, with it {:.2} / {:.2} % ({clipped} samples clipped)",
            without[0], without[1], with[0], with[1]
        );
        assert_eq!(none, 0);
        assert!(clipped > 40, "{clipped}");
        for i in 0..2 {
            assert!(without[i] > 5.0, "axis {}: {without:?}", i + 1);
            assert!(with[i] < 2.0, "axis {}: {with:?}", i + 1);
        }
    }
}
