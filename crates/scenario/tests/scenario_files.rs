//! Acceptance: the commented default scenario round-trips, and bad values are
//! rejected with messages that name the field (one bad value per parameter group).

use flexstage_scenario::{Preset, Scenario, ScenarioError};

fn paper_text() -> String {
    Scenario::paper().to_commented_toml()
}

/// Replaces the first line starting with `key =` after the header `[table]`.
fn with_value(table: &str, key: &str, value: &str) -> String {
    let text = paper_text();
    let mut in_table = table.is_empty();
    let mut done = false;
    let mut out = String::new();
    for line in text.lines() {
        let t = line.trim();
        if t.starts_with('[') {
            in_table = t == format!("[{table}]") || t == format!("[[{table}]]");
        }
        if in_table && !done && t.starts_with(&format!("{key} =")) {
            out.push_str(&format!("{key} = {value}\n"));
            done = true;
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    assert!(done, "key {table}.{key} not found");
    out
}

fn error_of(text: &str) -> String {
    match Scenario::from_toml_str(text, "test.toml") {
        Ok(_) => panic!("scenario was accepted"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn init_output_round_trips_for_every_preset() {
    for preset in [Preset::Paper, Preset::Quick, Preset::Fine] {
        let s = Scenario::preset(preset);
        s.validate().unwrap();
        let back = Scenario::from_toml_str(&s.to_commented_toml(), "round-trip").unwrap();
        assert_eq!(back, s);
    }
}

#[test]
fn paper_preset_reproduces_the_tables() {
    let s = Scenario::paper();
    // Table 3
    assert_eq!((s.mesh.nl, s.mesh.nw), (120, 60));
    assert_eq!(s.material.youngs_modulus, 73e9);
    assert_eq!(s.optimization.samples, 40);
    // Table 1
    assert_eq!(s.actuators.stiffness, 2.5e8);
    // Table 4: guess and estimate
    assert_eq!(s.stage.guess.k_qo1, 5e6);
    assert_eq!(s.stage.truth.k_qo1, 3.78e6);
    assert_eq!(s.stage.truth.k_in2, 0.89e5);
    // Table A1
    assert_eq!(s.hysteresis.pea2.gamma_bw, 5.3e-3);
    // Table 4's weighed mass, 46 g, of the 195 g solid domain (DECISIONS.md, Constraints).
    let solid = s.mesh.length * s.mesh.width * s.mesh.thickness * s.material.density;
    assert!((s.optimization.volume_fraction * solid - 0.046).abs() < 0.001);
    assert_eq!(
        s.optimization.initial_density,
        s.optimization.volume_fraction
    );
    // DECISIONS.md: damping ratio 2 % of the vertical output mode: c = 2ζ√(kM)
    let c = 2.0 * 0.02 * (4.03e6f64 * 0.046).sqrt();
    assert!((s.stage.truth.c_qo2 - c).abs() < 1e-12 * c);
}

#[test]
fn tilted_output_with_mirror_symmetry_is_rejected() {
    let e = error_of(&with_value("output", "tilt_deg", "20.0"));
    assert!(e.contains("optimization.mirror_symmetry"), "{e}");
    let text = with_value("output", "tilt_deg", "20.0");
    let text = text.replace("mirror_symmetry = true", "mirror_symmetry = false");
    Scenario::from_toml_str(&text, "test.toml").unwrap();
}

#[test]
fn negative_youngs_modulus_names_the_field() {
    let e = error_of(&with_value("material", "youngs_modulus", "-73e9"));
    assert!(e.contains("material.youngs_modulus"), "{e}");
    assert!(e.contains("> 0"), "{e}");
}

#[test]
fn density_above_one_names_the_field() {
    let e = error_of(&with_value("optimization", "initial_density", "1.5"));
    assert!(e.contains("optimization.initial_density"), "{e}");
}

#[test]
fn mesh_with_zero_elements_names_the_field() {
    let e = error_of(&with_value("mesh", "nl", "0"));
    assert!(e.contains("mesh.nl"), "{e}");
    assert!(e.contains("[4, 4000]"), "{e}");
}

#[test]
fn unknown_key_is_rejected_with_its_name() {
    let text = paper_text().replace("[mesh]\n", "[mesh]\nnx = 3\n");
    let e = Scenario::from_toml_str(&text, "test.toml").unwrap_err();
    assert!(matches!(e, ScenarioError::Parse { .. }));
    // The parser's diagnosis is the error's source (messages do not repeat their cause).
    let cause = std::error::Error::source(&e)
        .expect("the TOML error")
        .to_string();
    let msg = format!("{e}: {cause}");
    assert!(msg.contains("nx") && msg.contains("test.toml"), "{msg}");
}

#[test]
fn one_bad_value_per_group_is_rejected() {
    let cases = [
        ("mesh", "thickness", "0.0", "mesh.thickness"),
        ("material", "poisson_ratio", "0.5", "material.poisson_ratio"),
        ("material", "min_modulus", "1e12", "material.min_modulus"),
        (
            "actuators",
            "stroke_amplitude",
            "40e-6",
            "actuators.stroke_amplitude",
        ),
        (
            "actuators.pea1",
            "point",
            "[1.0, 0.03]",
            "actuators.pea1.point",
        ),
        ("output", "tilt_deg", "90.0", "output.tilt_deg"),
        ("optimization", "samples", "42", "optimization.samples"),
        ("optimization", "penalty", "0.5", "optimization.penalty"),
        (
            "optimization.additive",
            "strain_threshold",
            "0.0",
            "strain_threshold",
        ),
        (
            "hysteresis",
            "voltage_max",
            "-1.0",
            "hysteresis.voltage_max",
        ),
        ("hysteresis.pea1", "d_p", "0.0", "hysteresis.pea1.d_p"),
        ("stage", "damping_ratio", "1.5", "stage.damping_ratio"),
        ("stage.truth", "mass", "-0.046", "stage.truth.mass"),
        (
            "controller",
            "observer_gain",
            "[1e5, -1.0]",
            "controller.observer_gain[1]",
        ),
        (
            "sensors",
            "noise_std",
            "[-1e-9, 1e-9]",
            "sensors.noise_std[0]",
        ),
        ("simulation", "substeps", "0", "simulation.substeps"),
        ("limits", "safety_factor", "0.5", "limits.safety_factor"),
        ("limits", "min_slot_width", "0.0", "limits.min_slot_width"),
        (
            "limits",
            "fatigue_strength",
            "300e6",
            "limits.fatigue_strength, limits.yield_strength",
        ),
        (
            "trajectories",
            "frequency",
            "0.0",
            "trajectories[0].frequency",
        ),
        ("supports.at", "point", "[0.5, 0.5]", "supports[0].at.point"),
    ];
    for (table, key, value, field) in cases {
        let e = error_of(&with_value(table, key, value));
        assert!(
            e.contains(field),
            "{table}.{key} = {value}: message does not name {field}: {e}"
        );
    }
}
