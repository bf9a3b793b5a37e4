// Reference: Bristow, Tharayil & Alleyne, "A survey of iterative learning control", IEEE
// Control Systems Magazine 26(3), 2006, Eq. (3) (the update) and Eq. (24) (monotone
// convergence |Q(1 − L T)| < 1); the Fejér kernel as the DFT of the Bartlett window.
// Goal: the Q response and the convergence factor match closed forms; on the lumped plant in
// the rig (delay, noise) with the PID + feed-forward baseline, the design from the measured
// learning plant satisfies the monotone condition on every harmonic, and the true-output
// error falls period after period, well below the baseline's.

use flexstage_control::actuator::Compensation;
use flexstage_control::experiment::Setup;
use flexstage_control::learning::{
    DesignParams, Learning, LearningParams, LearningPlant, convergence_factor, design,
    measure_learning_plant, q_response, rms_per_period, sensor_lag,
};
use flexstage_control::pid::PID_FF;
use flexstage_sim::experiment::StageControl;
use flexstage_sim::experiment::run;
use flexstage_sim::rig::StagePlant;
use flexstage_sim::trajectory::Reference;

#[test]
fn bartlett_q_response_is_the_fejer_kernel() {
    // Direct DFT of the weights (M + 1 − |m|)/(M + 1)² against the closed form.
    for m in [0usize, 1, 4, 16] {
        let p = LearningParams {
            period: 1000,
            gain: 0.5,
            lead: 0,
            q_half_width: m,
        };
        for omega in [0.0, 0.01, 0.3, 1.0, 2.5, std::f64::consts::PI] {
            let direct: f64 = (-(m as isize)..=m as isize)
                .map(|k| p.q_weight(k) * (omega * k as f64).cos())
                .sum();
            let closed = q_response(m, omega);
            assert!(
                (direct - closed).abs() < 1e-12,
                "M {m} ω {omega}: {direct} vs {closed}"
            );
        }
    }
}

#[test]
fn convergence_factor_of_a_pure_delay_is_one_minus_gain() {
    // T = z^−d: with the lead λ = d and no Q filter, 1 − γ e^{jωλ} T = 1 − γ at every ω.
    let (n, d) = (200usize, 3usize);
    let response = core::array::from_fn(|_| {
        (1..=n / 2)
            .map(|k| {
                let w = std::f64::consts::TAU * k as f64 / n as f64;
                ((w * d as f64).cos(), -(w * d as f64).sin())
            })
            .collect()
    });
    let plant = LearningPlant {
        period: n,
        response,
        sensor_lag: [0.0; 2],
    };
    let mut p = LearningParams {
        period: n,
        gain: 0.4,
        lead: d,
        q_half_width: 0,
    };
    assert!((convergence_factor(&plant, &p) - 0.6).abs() < 1e-12);
    // Without the lead, high harmonics see 1 − γ e^{−jωd}: |·| up to 1 + γ, not monotone.
    p.lead = 0;
    assert!(convergence_factor(&plant, &p) > 1.3);
}

#[test]
fn learning_on_pid_converges_monotonically_on_the_lumped_rig() {
    let scenario = flexstage_scenario::Scenario::paper();
    let setup = Setup::from_scenario(&scenario);
    let (reference, _) = Reference::from_scenario(&scenario.trajectories[0]);
    let t = setup.controller.observer.sample_time;
    let period = (0.5 / t).round() as usize; // the 3:1 Lissajous at 2 Hz
    let make = |s: &Setup, r: Reference| {
        let c = s.controller(&PID_FF, Compensation::Inverse, r)?;
        let p: Box<dyn StagePlant> = Box::new(s.lumped_plant()?);
        Ok((c, p))
    };
    let plant = measure_learning_plant(&mut || make(&setup, reference), period, 3, 20e-9).unwrap();
    let (params, rho) = design(&plant, &DesignParams::default()).unwrap();
    assert!(rho < 1.0 && (rho - convergence_factor(&plant, &params)).abs() < 1e-15);

    let periods = 10;
    let (base, mut p) = make(&setup, reference).unwrap();
    let mut learning = Learning::new(base, params).unwrap();
    let rec = run(
        &mut learning as &mut dyn StageControl,
        p.as_mut(),
        periods as f64 * period as f64 * t,
        t,
        |_| {},
    );
    let rms = rms_per_period(&rec.error, period);
    let (c0, mut p0) = make(&setup, reference).unwrap();
    let mut c0 = c0;
    let rec0 = run(
        c0.as_mut(),
        p0.as_mut(),
        periods as f64 * period as f64 * t,
        t,
        |_| {},
    );
    let rms0 = rms_per_period(&rec0.error, period);
    eprintln!("design {params:?}, ρ = {rho:.3}");
    for (j, (a, b)) in rms.iter().zip(&rms0).enumerate() {
        eprintln!(
            "period {j}: learning {:.1}/{:.1} nm, baseline {:.1}/{:.1} nm",
            a[0] * 1e9,
            a[1] * 1e9,
            b[0] * 1e9,
            b[1] * 1e9
        );
    }
    // Period by period the error falls (from period 1, the first that learns, until it
    // reaches the noise level), and ends far below the baseline.
    for j in 2..5 {
        for a in 0..2 {
            assert!(rms[j][a] < rms[j - 1][a], "axis {a} period {j}: {:?}", rms);
        }
    }
    for a in 0..2 {
        assert!(
            rms[periods - 1][a] < 0.5 * rms0[periods - 1][a],
            "axis {a}: {rms:?} vs {rms0:?}"
        );
    }
}

/// Goal: the lag fit returns the fractional delay of a sampled sine (0.3 samples on one
/// axis, a 0.2-sample lead on the other), to 1e-3 sample.
#[test]
fn sensor_lag_of_a_delayed_sine() {
    let n = 1000;
    let w = std::f64::consts::TAU * 3.0 / n as f64;
    let truth: Vec<[f64; 2]> = (0..n)
        .map(|k| [(w * k as f64).sin(), (w * k as f64).cos()])
        .collect();
    let measured: Vec<[f64; 2]> = (0..n)
        .map(|k| {
            let k = k as f64;
            [(w * (k - 0.3)).sin() + 1e-3, (w * (k + 0.2)).cos()]
        })
        .collect();
    let lag = [0, 1].map(|a| sensor_lag(&truth, &measured, a));
    assert!(
        (lag[0] - 0.3).abs() < 1e-3 && (lag[1] + 0.2).abs() < 1e-3,
        "{lag:?}"
    );
}

/// A stage whose sensor reports one sample late (beyond the rig's own sensor chain).
struct LateSensor {
    inner: Box<dyn StagePlant>,
    last: Option<[f64; 2]>,
}

impl StagePlant for LateSensor {
    fn measure(&mut self) -> [f64; 2] {
        let now = self.inner.measure();
        self.last.replace(now).unwrap_or(now)
    }
    fn output(&self) -> [f64; 2] {
        self.inner.output()
    }
    fn apply(&mut self, cmd: &flexstage_sim::experiment::Command) {
        self.inner.apply(cmd)
    }
    fn voltage(&self) -> [f64; 2] {
        self.inner.voltage()
    }
    fn x_nom(&self) -> [f64; 2] {
        self.inner.x_nom()
    }
}

/// Reference: a measurement one sample late. Learning drives the measured error to zero, so
/// without knowing the lag the true output ends one sample ahead of the reference (RMS ≈ T
/// times the RMS velocity). Goal: `measure_learning_plant` finds the added sample (lag one
/// more than on the plain rig, to 0.05 sample), and learning told the lag
/// (`Learning::with_sensor_lag`) ends with less than half the true-output error of learning
/// that is not told, on both axes.
#[test]
fn learning_told_the_sensor_lag_tracks_the_true_output() {
    let scenario = flexstage_scenario::Scenario::paper();
    let setup = Setup::from_scenario(&scenario);
    let (reference, _) = Reference::from_scenario(&scenario.trajectories[0]);
    let t = setup.controller.observer.sample_time;
    let period = (0.5 / t).round() as usize;
    let make = |late: bool| {
        let c = setup.controller(&PID_FF, Compensation::Inverse, reference)?;
        let inner: Box<dyn StagePlant> = Box::new(setup.lumped_plant()?);
        let p: Box<dyn StagePlant> = if late {
            Box::new(LateSensor { inner, last: None })
        } else {
            inner
        };
        Ok((c, p))
    };
    let plain = measure_learning_plant(&mut || make(false), period, 3, 20e-9).unwrap();
    let plant = measure_learning_plant(&mut || make(true), period, 3, 20e-9).unwrap();
    for a in 0..2 {
        let added = plant.sensor_lag[a] - plain.sensor_lag[a];
        assert!(
            (added - 1.0).abs() < 0.05,
            "axis {a}: {plain:?} {:?}",
            plant.sensor_lag
        );
    }
    let (params, _) = design(&plant, &DesignParams::default()).unwrap();
    let periods = 8;
    let last = |told: bool| {
        let (c, mut p) = make(true).unwrap();
        let mut l = Learning::new(c, params).unwrap();
        if told {
            l = l.with_sensor_lag(plant.sensor_lag).unwrap();
        }
        let rec = run(
            &mut l,
            p.as_mut(),
            periods as f64 * period as f64 * t,
            t,
            |_| {},
        );
        rms_per_period(&rec.error, period)[periods - 1]
    };
    let (told, not_told) = (last(true), last(false));
    eprintln!("told {told:?}, not told {not_told:?}");
    for a in 0..2 {
        assert!(
            told[a] < 0.5 * not_told[a],
            "axis {a}: {told:?} vs {not_told:?}"
        );
    }
}
