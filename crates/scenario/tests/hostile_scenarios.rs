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
    has(&e, &["optimization.samples", "GiB", "at most 8 GiB"]);
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
