//! Per-step cost of the controllers and the cost of the simulated experiment.
//! Budgets: one backstepping controller step (observer + law + input
//! transformation + inverse hysteresis compensation) ≤ 1 µs with no allocation; the simulated
//! experiment ≥ 50× faster than real time on 2 cores (≤ 40 ms per simulated second when two
//! experiments run side by side).

use divan::{Bencher, black_box};
use flexstage_control::actuator::Compensation;
use flexstage_control::controller::{NONROBUST, ROBUST};
use flexstage_control::experiment::{Setup, experiment};
use flexstage_control::pid::PID_FF;
use flexstage_control::registry::Controller;
use flexstage_scenario::Scenario;
use flexstage_sim::trajectory::Reference;

fn main() {
    divan::main();
}

fn setup() -> (Setup, Reference) {
    let s = Scenario::paper();
    let (r, _) = Reference::from_scenario(&s.trajectories[0]);
    (Setup::from_scenario(&s), r)
}

/// Measured outputs of a real closed-loop run, replayed into a fresh controller.
fn measurements(n: usize) -> Vec<[f64; 2]> {
    let (setup, r) = setup();
    let rec =
        experiment(&setup, &ROBUST, Compensation::Inverse, r, n as f64 * 1e-4).expect("experiment");
    (0..rec.len())
        .map(|k| [rec.measured[0][k], rec.measured[1][k]])
        .collect()
}

#[divan::bench(args = [&ROBUST, &NONROBUST, &PID_FF], sample_size = 1000)]
fn controller_step(b: Bencher, variant: &Controller) {
    let (setup, r) = setup();
    let y = measurements(4096);
    let mut c = setup
        .controller(variant, Compensation::Inverse, r)
        .expect("controller");
    let mut k = 0usize;
    b.bench_local(|| {
        k = (k + 1) & 4095;
        black_box(c.step(black_box(y[k])))
    });
}

#[divan::bench(sample_count = 10)]
fn experiment_one_second(b: Bencher) {
    let (setup, r) = setup();
    b.bench_local(|| black_box(experiment(&setup, &ROBUST, Compensation::Inverse, r, 1.0)));
}

#[divan::bench(sample_count = 10)]
fn experiment_one_second_two_in_parallel(b: Bencher) {
    let (setup, r) = setup();
    b.bench_local(|| {
        std::thread::scope(|s| {
            let h = s.spawn(|| experiment(&setup, &NONROBUST, Compensation::Inverse, r, 1.0));
            let a = experiment(&setup, &ROBUST, Compensation::Inverse, r, 1.0);
            black_box((a, h.join()))
        })
    });
}

/// One step of the PI + two notches + FF controller (inverse-hysteresis compensation on).
#[divan::bench(sample_size = 1000)]
fn pi_notch_step(b: Bencher) {
    use flexstage_control::pi_notch::{AxisGains, Notch, PiNotchController, PiNotchParams};
    use flexstage_sim::experiment::StageControl;
    let (setup, r) = setup();
    let y = measurements(4096);
    let notch = |f: f64| {
        Some(Notch {
            frequency: f,
            zero_damping: 0.02,
            pole_damping: 0.5,
        })
    };
    let axis = AxisGains {
        kp: 0.0,
        ki: 900.0,
        kd: 0.0,
        notches: [notch(1000.0), notch(3000.0)],
    };
    let p = PiNotchParams {
        axes: [axis; 2],
        static_gain: [[0.5, 0.5], [2.0, -2.0]],
        sample_time: 1e-4,
    };
    let mut c = PiNotchController::new(p, setup.controller.actuator, r).expect("controller");
    let mut k = 0usize;
    b.bench_local(|| {
        k = (k + 1) & 4095;
        black_box(c.step(black_box(y[k])))
    });
}

/// One step of a controller with the learning layer (≤ 1 µs including it): the
/// robust backstepping (Kalman estimate) under learning with the twin's design (γ = 0.7,
/// λ = 7, M = 1) and the sensor's datasheet lag, in its learning periods.
#[divan::bench(sample_size = 1000)]
fn learning_step(b: Bencher) {
    use flexstage_control::learning::{Learning, LearningParams, SensorDatasheet};
    use flexstage_sim::experiment::StageControl;
    let (setup, r) = setup();
    let y = measurements(4096);
    let c = setup
        .controller(&ROBUST, Compensation::Inverse, r)
        .expect("controller");
    let params = LearningParams {
        period: 5000,
        gain: 0.7,
        lead: 7,
        q_half_width: 1,
    };
    let mut c = Learning::new(c, params)
        .and_then(|l| {
            let sheet = SensorDatasheet {
                bandwidth: 15e3,
                anti_alias: 0.0,
            };
            l.with_sensor_lag(sheet.lag(1e-4)?)
        })
        .expect("learning");
    // Past the first period, so every step learns.
    for k in 0..6000 {
        c.step(y[k & 4095]);
    }
    let mut k = 0usize;
    b.bench_local(|| {
        k = (k + 1) & 4095;
        black_box(c.step(black_box(y[k])))
    });
}
