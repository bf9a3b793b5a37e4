//! Reference: the input-bounds and fault-handling requirements, "Accepted absurd values" and "Unbounded work" — the scenario mutants
//! that passed `flexstage check` and failed, hung or gave garbage later. Goal: each is refused
//! by `Scenario::validate` (so by `check`, before any work) with a message that names the
//! field, the value and the accepted range; the built-in presets still pass.

use flexstage_scenario::{Preset, Scenario, Selector, Trajectory};

fn quick() -> Scenario {
    Scenario::preset(Preset::Quick)
}

/// The validation message of a mutant of the quick preset; panics if it is accepted.
fn refused(mutate: impl FnOnce(&mut Scenario)) -> String {
    let mut s = quick();
    mutate(&mut s);
    match s.validate() {
        Ok(()) => panic!("the mutant was accepted"),
        Err(e) => e.to_string(),
    }
}

fn has(e: &str, parts: &[&str]) {
    for p in parts {
        assert!(e.contains(p), "{p:?} missing from: {e}");
    }
}

#[test]
fn presets_pass() {
    for p in [Preset::Quick, Preset::Paper, Preset::Fine] {
        Scenario::preset(p).validate().unwrap();
    }
}

#[test]
fn nan_and_infinite_box_corners_are_refused() {
    let e = refused(|s| {
        s.regions[0].at = Selector::Box {
            min: [f64::NAN, 0.02],
            max: [0.005, 0.03],
        }
    });
    has(&e, &["regions[0].at.min", "NaN", "finite"]);
    let e = refused(|s| {
        s.regions[1].at = Selector::Box {
            min: [0.1, 0.02],
            max: [f64::INFINITY, 0.03],
        }
    });
    has(&e, &["regions[1].at.max", "inf"]);
}

#[test]
fn a_one_by_one_mesh_is_refused() {
    let e = refused(|s| {
        s.mesh.nl = 1;
        s.mesh.nw = 1;
    });
    has(&e, &["mesh.nl = 1", "[4, 4000]"]);
}

#[test]
fn an_output_on_an_input_or_on_a_support_is_refused() {
    let e = refused(|s| s.output.at = Selector::Nearest { point: [0.0, 0.03] });
    has(&e, &["output.at", "actuators.pea1", "input node"]);
    let e = refused(|s| {
        s.supports[0].at = Selector::Nearest {
            point: [0.06, 0.06],
        }
    });
    has(&e, &["supports[0].at", "output"]);
}

#[test]
fn a_support_blocking_a_pea_is_refused() {
    let e = refused(|s| s.supports[0].fix = flexstage_scenario::Fix::Xy);
    has(&e, &["supports[0].fix", "actuators.pea1", "pushes"]);
}

#[test]
fn selectors_that_pick_nothing_or_several_ports_are_refused() {
    let e = refused(|s| {
        s.regions[0].at = Selector::Box {
            min: [0.0301, 0.0301],
            max: [0.0302, 0.0302],
        }
    });
    has(&e, &["regions[0].at", "at least one element"]);
    let e = refused(|s| {
        s.output.at = Selector::Edge {
            edge: flexstage_scenario::Edge::Top,
        }
    });
    has(&e, &["output.at", "49 nodes", "exactly one node"]);
}

#[test]
fn a_floating_structure_is_refused() {
    // Reference (known answer): with no support and no output spring only the two PEA springs
    // along x on the line y = w/2 hold the structure: y translation and rotation are free.
    let e = refused(|s| {
        s.supports.clear();
        s.optimization.output_spring = 0.0;
    });
    has(
        &e,
        &[
            "supports, optimization.output_spring",
            "floats",
            "two rigid-body motions",
        ],
    );
    // The output spring alone (y, and x relative to the inputs) holds the rest.
    let mut s = quick();
    s.supports.clear();
    s.validate().unwrap();
}

#[test]
fn a_huge_mesh_is_refused_with_its_estimate() {
    let e = refused(|s| {
        s.mesh.nl = 4000;
        s.mesh.nw = 4000;
    });
    has(
        &e,
        &["mesh.nl × mesh.nw", "16000000", "at most 250000 elements"],
    );
    let e = refused(|s| {
        s.mesh.nl = 500;
        s.mesh.nw = 500;
        s.optimization.samples = 4000;
    });
    has(&e, &["optimization.samples", "GiB", "at most 16 GiB"]);
    // The second hardening review: 4000 samples on the quick mesh passed `check` (an estimate of 1.4 GiB) and
    // aborted allocating past 4 and 9.5 GB caps.
    let e = refused(|s| s.optimization.samples = 4000);
    has(
        &e,
        &["optimization.samples", "4000 samples × 3", "at most 16 GiB"],
    );
}

#[test]
fn long_and_duplicate_names_are_refused() {
    let e = refused(|s| s.name = "a".repeat(300));
    has(&e, &["name = ", "(300 characters)", "1 to 64"]);
    let e = refused(|s| s.name = "a/b".into());
    has(&e, &["name = \"a/b\""]);
    let e = refused(|s| {
        let n = s.trajectories[0].name().to_string();
        if let Trajectory::Lissajous { name, .. } = &mut s.trajectories[1] {
            *name = n;
        }
    });
    has(
        &e,
        &["trajectories[0].name, trajectories[1].name", "unique"],
    );
}

#[test]
fn trajectories_beyond_nyquist_stroke_or_record_limits_are_refused() {
    let set = |s: &mut Scenario, f: f64, r: f64, d: f64| {
        if let Trajectory::Circle {
            frequency,
            radius,
            duration,
            ..
        } = &mut s.trajectories[2]
        {
            (*frequency, *radius, *duration) = (f, r, d);
        }
    };
    let e = refused(|s| set(s, 1e6, 8e-6, 1.0));
    has(&e, &["trajectories[2].frequency", "Nyquist", "5e3 Hz"]);
    let e = refused(|s| set(s, 2.0, 1e308, 1.0));
    has(&e, &["trajectories[2].radius = 1e308", "stroke"]);
    let e = refused(|s| set(s, 2.0, 8e-6, 1e9));
    has(&e, &["trajectories[2].duration", "samples"]);
    let e = refused(|s| s.simulation.sample_time = 1e-308);
    has(&e, &["simulation.sample_time = 1e-308", "[1e-7, 0.1]"]);
}

/// Reference: the second hardening review, "Lenient parsing" (`pid = [1, 2, 3, 4]`, a 3-element
/// `observer_gain`, 3 `rig.floor.bands` were accepted). Goal: every fixed-length array of the
/// scenario (the quick preset's and the mechanism example's `output.direction`,
/// `ports[].direction`), one element longer or shorter, is refused by the parser with its line
/// and the expected length.
#[test]
fn fixed_length_arrays_take_exactly_their_length() {
    let quick = toml::from_str::<toml::Value>(&quick().to_toml()).unwrap();
    let inverter: toml::Value = toml::from_str(
        &std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../examples/scenarios/inverter.toml"
        ))
        .unwrap(),
    )
    .unwrap();
    let mut checked = 0;
    for base in [quick, inverter] {
        let mut arrays = Vec::new();
        numeric_arrays(&base, &mut Vec::new(), &mut arrays);
        for path in arrays {
            for longer in [true, false] {
                let mut v = base.clone();
                let a = path
                    .iter()
                    .fold(&mut v, |v, k| match k.parse::<usize>() {
                        Ok(i) => &mut v.as_array_mut().unwrap()[i],
                        Err(_) => v.as_table_mut().unwrap().get_mut(k).unwrap(),
                    })
                    .as_array_mut()
                    .unwrap();
                let n = a.len();
                if longer {
                    a.push(a[0].clone());
                } else {
                    a.pop();
                }
                let len = a.len();
                let text = toml::to_string(&v).unwrap();
                let e = match Scenario::from_toml_str(&text, "mutant.toml") {
                    Ok(_) => panic!("{} with {len} elements was accepted", path.join(".")),
                    Err(e) => chain(&e),
                };
                has(
                    &e,
                    &[
                        "line",
                        &format!("invalid length {len}"),
                        &format!("exactly {n} elements"),
                    ],
                );
                checked += 1;
            }
        }
    }
    // 13 arrays of the quick preset's controller, sensors, rig and selectors, plus trajectories
    // and the inverter's directions: the walk must have found them.
    assert!(checked >= 2 * 25, "only {checked} mutants");
}

/// Paths of the arrays of numbers (arrays of tables are walked into, by index).
fn numeric_arrays(v: &toml::Value, path: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    match v {
        toml::Value::Table(t) => {
            for (k, x) in t {
                path.push(k.clone());
                numeric_arrays(x, path, out);
                path.pop();
            }
        }
        toml::Value::Array(a) if a.iter().all(|x| x.is_float() || x.is_integer()) => {
            out.push(path.clone());
        }
        toml::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                path.push(i.to_string());
                numeric_arrays(x, path, out);
                path.pop();
            }
        }
        _ => {}
    }
}

/// The message of an error and its sources.
fn chain(e: &dyn std::error::Error) -> String {
    let mut m = e.to_string();
    let mut s = e.source();
    while let Some(x) = s {
        m.push_str(": ");
        m.push_str(&x.to_string());
        s = x.source();
    }
    m
}

/// The second hardening review, "Messages": `E0 = 1e308` or `output_spring = 1e308` were
/// refused as "the structure floats" (by the solver's round-off pivot test, after the element
/// stiffness overflowed or the spring swamped every pivot), and `stroke_amplitude = 1e-308`
/// designed to an area of 0 ("NaN × the input stroke square"). Goal: each is refused by
/// `check`, by the field's own range.
#[test]
fn a_modulus_spring_or_stroke_beyond_what_the_solver_resolves_is_refused_by_its_range() {
    let e = refused(|s| s.material.youngs_modulus = 1e308);
    has(
        &e,
        &["material.youngs_modulus = 1e308", "at most", "min_modulus"],
    );
    assert!(!e.contains("floats"), "{e}");
    let e = refused(|s| s.optimization.output_spring = 1e308);
    has(&e, &["optimization.output_spring = 1e308", "at most"]);
    let e = refused(|s| s.actuators.stiffness = 1e300);
    has(&e, &["actuators.stiffness = 1e300", "at most"]);
    let e = refused(|s| s.material.min_modulus = 1e-6);
    has(&e, &["material.youngs_modulus", "min_modulus"]);
    let e = refused(|s| s.actuators.stroke_amplitude = 1e-308);
    has(&e, &["actuators.stroke_amplitude = 1e-308", "[1e-9, "]);
}
