// Reference: flexstage-control's `PidController` (PID + static feed-forward, conditional
// integration; Compensation::Ideal so that its command is x_nom), itself the baseline of
// Actuators 2022, 11(7), 179, Section 4.
// Goal: the no_std core law, fed the same measurements and the reference from outside,
// returns the same x_nom sample by sample (to rounding) on a closed-loop run of the lumped
// plant, through the smooth start, a stroke-clipping phase and a sensor dropout. The test
// fails if a gain, the feed-forward, the trapezoidal integral or the anti-windup differs.

use flexstage_control::actuator::Compensation;
use flexstage_control::controller::{PidController, PidParams};
use flexstage_control::experiment::Setup;
use flexstage_control_core::{PidGains, PidLaw};
use flexstage_sim::experiment::StageControl;
use flexstage_sim::model::StageModel;
use flexstage_sim::plant::Plant;
use flexstage_sim::trajectory::Reference;

fn compare(pid: PidParams, amplitude_scale: f64) -> (f64, usize) {
    let scenario = flexstage_scenario::Scenario::paper();
    let setup = Setup::from_scenario(&scenario);
    let (mut reference, _) = Reference::from_scenario(&scenario.trajectories[0]);
    if let flexstage_sim::trajectory::Shape::Lissajous { amplitude, .. } = &mut reference.shape {
        *amplitude = amplitude.map(|a| a * amplitude_scale);
    }
    let mut actuator = setup.controller.actuator;
    actuator.compensation = Compensation::Ideal;
    let t = setup.controller.observer.sample_time;
    let mut full =
        PidController::new(&setup.controller.model, pid, actuator, t, reference).unwrap();
    let g = StageModel::new(&setup.controller.model)
        .unwrap()
        .dc_gain()
        .unwrap()
        .try_inverse()
        .unwrap();
    let gains = PidGains {
        kp: pid.kp,
        ki: pid.ki,
        kd: pid.kd,
    };
    let mut core = PidLaw::new(
        gains,
        [[g[(0, 0)], g[(0, 1)]], [g[(1, 0)], g[(1, 1)]]],
        t,
        actuator.stroke,
    )
    .unwrap();
    let mut plant = Plant::new(setup.plant.clone()).unwrap();
    let (mut worst, mut saturated) = (0.0f64, 0);
    for k in 0..3000 {
        let mut y = plant.measure();
        if k == 1500 {
            y[0] = f64::NAN; // dropout: both keep the last finite sample
        }
        let cmd = full.step(y);
        let u = core.step(y, cmd.reference);
        for (a, b) in u.iter().zip(&cmd.x_nom) {
            worst = worst.max((a - b).abs());
        }
        assert_eq!(core.saturated(), cmd.saturated, "sample {k}");
        saturated += cmd.saturated as usize;
        plant.apply(&cmd);
    }
    (worst, saturated)
}

#[test]
fn core_pid_matches_flexstage_control_pid_controller() {
    let (worst, saturated) = compare(
        PidParams {
            kp: 0.1,
            ki: 300.0,
            kd: 2e-5,
        },
        1.0,
    );
    assert_eq!(saturated, 0);
    assert!(worst < 1e-18, "largest x_nom difference {worst:e} m");
}

#[test]
fn core_pid_matches_through_stroke_clipping() {
    // A reference beyond the stroke: both clip and stop integrating on the same samples.
    let (worst, saturated) = compare(
        PidParams {
            kp: 0.0,
            ki: 300.0,
            kd: 0.0,
        },
        20.0,
    );
    assert!(
        saturated > 100,
        "the stroke must clip ({saturated} samples)"
    );
    assert!(worst < 1e-18, "largest x_nom difference {worst:e} m");
}
