//! General mechanism problems (`[[ports]]`, `output.direction`) parse from
//! the shipped example scenarios, and every bad new field is refused with a message naming
//! the field, the value and the accepted range (or the contradicting fields).

use flexstage_scenario::Scenario;

const INVERTER: &str = include_str!("../../../examples/scenarios/inverter.toml");
const GRIPPER: &str = include_str!("../../../examples/scenarios/gripper.toml");

fn error_of(text: &str) -> String {
    match Scenario::from_toml_str(text, "test.toml") {
        Ok(_) => panic!("scenario was accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// The inverter with one exact line replaced (it must occur).
fn inverter_with(old: &str, new: &str) -> String {
    assert!(INVERTER.contains(old), "{old:?} not in inverter.toml");
    INVERTER.replacen(old, new, 1)
}

#[test]
fn the_example_mechanisms_parse_with_their_ports() {
    for (text, d) in [(INVERTER, [-1.0, 0.0]), (GRIPPER, [0.0, 1.0])] {
        let s = Scenario::from_toml_str(text, "example").unwrap();
        assert_eq!(s.ports.len(), 1);
        assert_eq!(s.ports[0].nominal_stroke(), 10.0); // force 1 / spring 0.1 along +x
        assert_eq!(s.ports[0].component(), 0);
        assert_eq!(s.output.unit_direction(), Some(d));
        assert!(!s.optimization.energy_constraint && !s.optimization.stress_constraint);
    }
}

#[test]
fn a_port_direction_sign_and_a_displacement_load_give_the_signed_stroke() {
    let text = inverter_with("direction = [1.0, 0.0]", "direction = [-2.0, 0.0]")
        .replace("force = 1.0", "displacement = 0.5");
    let s = Scenario::from_toml_str(&text, "t").unwrap();
    assert_eq!(s.ports[0].nominal_stroke(), -0.5);
}

#[test]
fn bad_mechanism_fields_name_the_field_value_and_range() {
    let cases = [
        // zero output direction
        (
            inverter_with("direction = [-1.0, 0.0]", "direction = [0.0, 0.0]"),
            vec!["output.direction", "[0e0, 0e0]", "non-zero"],
        ),
        // oblique port direction
        (
            inverter_with("direction = [1.0, 0.0]", "direction = [1.0, 1.0]"),
            vec!["ports[0].direction", "along x or y"],
        ),
        // zero port direction
        (
            inverter_with("direction = [1.0, 0.0]", "direction = [0.0, 0.0]"),
            vec!["ports[0].direction", "non-zero"],
        ),
        // non-positive input spring
        (
            inverter_with("spring = 0.1", "spring = -0.1"),
            vec!["ports[0].spring", "-1e-1", "> 0"],
        ),
        // both force and displacement
        (
            inverter_with("force = 1.0", "force = 1.0\ndisplacement = 0.1"),
            vec!["ports[0].force, ports[0].displacement", "exactly one"],
        ),
        // neither
        (
            inverter_with("force = 1.0", ""),
            vec!["ports[0].force, ports[0].displacement", "exactly one"],
        ),
        // zero force
        (
            inverter_with("force = 1.0", "force = 0.0"),
            vec!["ports[0].force", "non-zero"],
        ),
        // the workspace objective with ports
        (
            inverter_with("objective = \"displacement\"", "objective = \"workspace\""),
            vec!["ports, optimization.objective", "displacement"],
        ),
        // no output direction
        (
            inverter_with("direction = [-1.0, 0.0]", ""),
            vec!["ports, output.direction"],
        ),
        // the stage's stress constraint left on
        (
            inverter_with("stress_constraint = false", "stress_constraint = true"),
            vec!["ports, optimization.stress_constraint"],
        ),
        // a port on a support that fixes its driven DOF (the clamped bottom-left nodes)
        (
            inverter_with("point = [0.0, 2.0]", "point = [0.0, 0.0]"),
            vec![
                "supports[1].fix, ports[0]",
                "fixes the DOF that port 0 drives",
            ],
        ),
        // the output held along its direction by a support
        (
            inverter_with("direction = [-1.0, 0.0]", "direction = [0.0, 1.0]"),
            vec!["supports[0].at, output.at, output.direction"],
        ),
        // the output on the input node
        (
            inverter_with("point = [4.0, 2.0]", "point = [0.0, 2.0]"),
            vec!["ports[0].at, output.at", "input node"],
        ),
    ];
    for (text, needles) in &cases {
        let e = error_of(text);
        for n in needles {
            assert!(e.contains(n), "error {e:?} does not mention {n:?}");
        }
    }
}

#[test]
fn a_floating_mechanism_is_refused() {
    // Only the input spring (x at one node) holds it: the supports removed.
    let clamp =
        "[[supports]]\nfix = \"xy\"\nat = { kind = \"box\", min = [0.0, 0.0], max = [0.0, 0.1] }\n";
    let roller = "[[supports]]\nfix = \"y\"\nat = { kind = \"edge\", edge = \"top\" }\n";
    let text = inverter_with(clamp, "")
        .replace(roller, "")
        .replace("output_spring = 0.1", "output_spring = 0.0");
    let e = error_of(&text);
    assert!(e.contains("floats"), "{e}");
}

#[test]
fn more_than_two_ports_are_refused() {
    let port = "[[ports]]\nat = { kind = \"nearest\", point = [0.0, 2.0] }\ndirection = [1.0, 0.0]\nspring = 0.1\nforce = 1.0\n";
    let extra = port.replace("point = [0.0, 2.0]", "point = [1.0, 2.0]")
        + &port.replace("point = [0.0, 2.0]", "point = [2.0, 2.0]");
    let text = inverter_with(port, &format!("{port}\n{extra}"));
    let e = error_of(&text);
    assert!(e.contains("ports") && e.contains('3'), "{e}");
}
