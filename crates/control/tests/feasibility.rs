//! Reference: the rig's limits (the Nyquist frequency, the controller's stroke, the
//! amplifier's range and current, PI piezo tutorial Eq. 4-15) and the designed workspace
//! (the image of the nominal strokes under the static gain).
//! Goal: the feasibility check accepts the scenario's trajectories and refuses what the rig
//! cannot do with a message that names the limit; the default curves sit inside the workspace.

use flexstage_control::experiment::Setup;
use flexstage_scenario::Scenario;
use flexstage_sim::trajectory::{Reference, Shape};

#[test]
fn feasibility_accepts_the_defaults_and_refuses_what_the_rig_cannot_do() {
    let s = Scenario::paper();
    let setup = Setup::from_scenario(&s);
    for t in &s.trajectories {
        let (r, d) = Reference::from_scenario(t);
        let f = setup.check_reference(&r, d, None).unwrap();
        println!("{}: {f:?}", t.name());
        assert!(f.stroke_usage < 0.7 && f.controller_stroke_usage < 1.0);
    }
    let lissajous = |amplitude: [f64; 2], frequency: f64| {
        Reference::new(Shape::Lissajous {
            ratio: 3.0,
            amplitude,
            frequency,
        })
    };
    // 93 % of the nominal ±30 µm: beyond the controller's stroke.
    let e = setup
        .check_reference(&lissajous([14e-6, 27.9e-6], 2.0), 1.0, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("controller.stroke"), "{e}");
    // With the controller allowed ±30 µm, the amplifier range is what fails.
    let mut wide = setup.clone();
    wide.controller.actuator.stroke = 30e-6;
    let e = wide
        .check_reference(&lissajous([14e-6, 27.9e-6], 2.0), 1.0, None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("amplifier range") && e.contains("scale the amplitude"),
        "{e}"
    );
    // Above the Nyquist frequency.
    let e = setup
        .check_reference(&lissajous([1e-6, 1e-6], 2000.0), 0.01, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("Nyquist"), "{e}");
    // Too fast for 0.1 A into 1.5 µF.
    let circle = Reference::new(Shape::Circle {
        radius: 8e-6,
        frequency: 200.0,
    });
    let e = setup
        .check_reference(&circle, 0.02, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("current"), "{e}");
}

#[test]
fn default_trajectories_are_inside_the_workspace() {
    let s = Scenario::paper();
    let ws = Setup::from_scenario(&s).workspace().unwrap();
    for t in &s.trajectories {
        let (r, d) = Reference::from_scenario(t);
        let u = ws.max_usage(&r, d, 1e-4);
        assert!(u > 0.1 && u < 0.9, "{}: usage {u}", t.name());
    }
}

/// Reference: a staircase of slope s through a first-order amplifier of bandwidth f_a (held
/// over T) starts every sample at the rate ω_a e₀ with e₀ = s T / (1 − e^{−ω_a T}), so its
/// peak rate is ω_a T / (1 − e^{−ω_a T}) times the mean rate |ΔU|/T of an ideal amplifier:
/// 2.2228 at 3 kHz and 10 kHz. Goal: the check rates the amplifier's output, not the held
/// command; a slow sine (rate nearly constant over 1/ω_a) meets the ratio to 1 %.
#[test]
fn the_rate_is_the_amplifier_outputs_through_its_bandwidth() {
    use flexstage_control::feasibility::{feasibility_of, static_inverse};
    let setup = Setup::from_scenario(&Scenario::paper());
    let r = Reference::new(Shape::Circle {
        radius: 2e-6,
        frequency: 20.0,
    });
    let inv = static_inverse(setup.controller_dc_gain().unwrap()).unwrap();
    let dt = 1e-4;
    let peak = |bandwidth: f64| {
        let mut amp = setup.rig.amplifier;
        amp.bandwidth = bandwidth;
        feasibility_of(&r, 0.06, dt, &setup.controller.actuator, &amp, |k| {
            let q = r.sample(k as f64 * dt).q;
            [0, 1].map(|i| inv[i][0] * q[0] + inv[i][1] * q[1])
        })
        .unwrap()
        .peak_rate
    };
    let wt = std::f64::consts::TAU * 3000.0 * dt;
    let want = wt / (1.0 - (-wt).exp());
    let ratio = peak(3000.0) / peak(0.0);
    assert!((ratio / want - 1.0).abs() < 0.01, "{ratio} vs {want}");
}

/// Goal: the binding limit is named with the factor that meets it: the 200 Hz, 8 µm circle
/// is limited by the current (0.1 A into 1.5 µF), and the circle scaled by 0.97 × that factor
/// passes the check; a reference that fits has no binding limit.
#[test]
fn the_binding_limit_and_its_factor_make_the_reference_fit() {
    use flexstage_control::feasibility::{Limit, feasibility_of, static_inverse};
    let setup = Setup::from_scenario(&Scenario::paper());
    let inv = static_inverse(setup.controller_dc_gain().unwrap()).unwrap();
    let dt = 1e-4;
    let check = |radius: f64| {
        let r = Reference::new(Shape::Circle {
            radius,
            frequency: 200.0,
        });
        feasibility_of(
            &r,
            0.02,
            dt,
            &setup.controller.actuator,
            &setup.rig.amplifier,
            |k| {
                let q = r.sample(k as f64 * dt).q;
                [0, 1].map(|i| inv[i][0] * q[0] + inv[i][1] * q[1])
            },
        )
        .unwrap()
    };
    let (limit, factor) = check(8e-6).binding().expect("too fast");
    assert_eq!(limit, Limit::AmplifierCurrent);
    assert!(factor > 0.0 && factor < 1.0, "{factor}");
    assert_eq!(check(8e-6 * 0.97 * factor).binding(), None);
}
