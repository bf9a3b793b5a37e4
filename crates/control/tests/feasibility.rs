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
