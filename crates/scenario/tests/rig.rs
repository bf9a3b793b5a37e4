//! The `[rig]` and `[twin]` groups. Old scenario files without them still load
//! (with the realistic rig and the default twin), and a bad value in either group is rejected
//! with a message naming the field and the accepted range.

use flexstage_scenario::{Rig, Scenario};

/// The paper scenario's TOML without the `[rig…]` and `[twin]` tables (a file written before
/// they existed).
fn without_rig_and_twin() -> String {
    let mut out = String::new();
    let mut skip = false;
    for line in Scenario::paper().to_toml().lines() {
        let t = line.trim();
        if t.starts_with('[') {
            skip = t.starts_with("[rig") || t == "[twin]";
        }
        if !skip {
            out.push_str(line);
            out.push('\n');
        }
    }
    out
}

#[test]
fn files_without_rig_and_twin_get_the_defaults() {
    let text = without_rig_and_twin();
    assert!(!text.contains("[rig") && !text.contains("[twin]"));
    let s = Scenario::from_toml_str(&text, "old.toml").unwrap();
    assert_eq!(s, Scenario::paper());
}

#[test]
fn realistic_rig_has_every_effect_on_and_the_ideal_one_none() {
    let h = Scenario::paper().hysteresis;
    let r = Rig::realistic(&h);
    assert_eq!(r.delay, 1);
    assert!(r.amplifier.bandwidth > 0.0 && r.amplifier.current_limit > 0.0);
    assert!(r.sensor.bandwidth > 0.0 && r.sensor.flicker_corner > 0.0);
    assert!(r.creep.factor > 0.0 && r.floor.velocity_rms > 0.0);
    assert!((r.pea1.d_p / h.pea1.d_p - 1.03).abs() < 1e-9);
    assert!((r.pea2.a_bw / h.pea2.a_bw - 1.10).abs() < 1e-9);
    let i = Rig::ideal(&h);
    assert_eq!(i.delay, 0);
    assert_eq!(i.pea1, h.pea1);
    i.validate().unwrap();
}

/// An edit of the paper scenario.
type Edit = Box<dyn Fn(&mut Scenario)>;

fn error_with(edit: impl Fn(&mut Scenario)) -> String {
    let mut s = Scenario::paper();
    edit(&mut s);
    let text = s.to_toml();
    match Scenario::from_toml_str(&text, "bad.toml") {
        Ok(_) => panic!("accepted"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_rig_and_twin_values_name_the_field() {
    let cases: Vec<(Edit, &str)> = vec![
        (Box::new(|s| s.rig.delay = 3), "rig.delay"),
        (
            Box::new(|s| s.rig.amplifier.bandwidth = -1.0),
            "rig.amplifier.bandwidth",
        ),
        (
            Box::new(|s| s.rig.amplifier.capacitance = 0.0),
            "rig.amplifier.capacitance",
        ),
        (Box::new(|s| s.rig.creep.factor = 0.5), "rig.creep.factor"),
        (
            Box::new(|s| s.rig.floor.bands = [80.0, 8.0]),
            "rig.floor.bands[1]",
        ),
        (Box::new(|s| s.rig.pea2.d_p = 0.0), "rig.pea2.d_p"),
        (Box::new(|s| s.twin.coverage = 0.5), "twin.coverage"),
        (Box::new(|s| s.twin.min_modes = 0), "twin.min_modes"),
        (
            Box::new(|s| s.twin.damping_ratio = 0.7),
            "twin.damping_ratio",
        ),
    ];
    for (edit, field) in cases {
        let msg = error_with(edit);
        assert!(msg.contains(field), "{field}: {msg}");
        assert!(msg.contains("expected"), "{msg}");
    }
}
