//! Verification of the assessment machinery on the twin of the rhombus sample design
//! (`flexstage_twin::samples::quick_rhombus`).

use flexstage_assess::inject::{InjectionParams, return_ratio};
use flexstage_assess::montecarlo::{MonteCarloParams, monte_carlo};
use flexstage_assess::{Bench, Candidate};
use flexstage_control::experiment::Setup;
use flexstage_control::trajectory::Reference;
use flexstage_control::tuning::{LoopPlant, loop_response};

fn bench() -> Bench {
    let (s, rho) = flexstage_twin::samples::quick_rhombus().unwrap();
    let twin = flexstage_twin::Twin::from_scenario(&s, &rho).unwrap();
    Bench::new(Setup::from_scenario(&s), twin, Default::default()).unwrap()
}

/// Reference: the analytic loop-at-a-time return ratio of a linear controller (its discrete
/// transfer function on the twin's exact ZOH modal response, one sample of delay). Goal:
/// sine injection into the running closed loop (the method used for the nonlinear
/// controllers) measures the same ratio, within 1 %, from 20 Hz to 4 kHz; and the tuned
/// baselines meet 6 dB / 40°.
#[test]
fn injection_equals_transfer_function_for_the_pi_notch() {
    let b = bench();
    let plant =
        flexstage_assess::bench::modal_plant(&b.twin, 1e-4, 1, &b.setup.rig.sensor).unwrap();
    assert!(plant.sample_time() == 1e-4);
    let p = b.linear_params(Candidate::PiNotch).unwrap().unwrap();
    for f in [20.0, 150.0, 700.0, 2500.0, 4000.0] {
        for axis in 0..2 {
            let measured = return_ratio(
                &b,
                Candidate::PiNotch,
                1,
                axis,
                f,
                &InjectionParams::default(),
            )
            .unwrap();
            let expect = loop_response(&plant, &p, f)[axis];
            assert!(
                (measured - expect).norm() < 1e-2 * expect.norm(),
                "f = {f}, axis {axis}: {measured} vs {expect}"
            );
        }
    }
    for t in [&b.pid, &b.pi_notch] {
        assert!(t.margins.iter().all(|m| m.meets(6.0, 40.0)), "{t:?}");
    }
}

/// Goal: a Monte-Carlo "perturbation" of zero spread, zero coupling, the nominal delay and
/// the twin's own damping reproduces the nominal run exactly (the perturbation path changes
/// nothing it should not).
#[test]
fn zero_perturbation_reproduces_the_nominal_run() {
    let b = bench();
    let (s, _) = flexstage_twin::samples::quick_rhombus().unwrap();
    let (r, _) = Reference::from_scenario(&s.trajectories[0]);
    let zeta = b.twin.modal.modes[0].damping;
    let mut b1 = b.clone();
    for m in &mut b1.twin.modal.modes {
        m.damping = zeta;
    }
    let d = b.setup.rig.delay;
    let p = MonteCarloParams {
        plants: 1,
        duration: 0.05,
        spread: 0.0,
        coupling: 0.0,
        damping: [zeta, zeta],
        max_delay: d,
        ..MonteCarloParams::default()
    };
    for seed in 0..40 {
        let mc = monte_carlo(
            &b1,
            &[Candidate::PiNotch],
            r,
            &MonteCarloParams { seed, ..p },
        )
        .unwrap();
        if mc.plants[0].delay != d {
            continue;
        }
        let m = flexstage_assess::track::track_on(
            &b1,
            &b1.setup,
            &b1.twin,
            &b1.setup.rig,
            Candidate::PiNotch,
            r,
            0.05,
        )
        .unwrap();
        assert!(m.rms[0] > 0.0);
        assert_eq!(mc.plants[0].results[0].1, m.rms);
        return;
    }
    panic!("no plant with the nominal delay in 40 seeds");
}
