//! Goal: the scenario fields of the design for bandwidth (`output.payload`,
//! `optimization.min_frequency`, `optimization.min_workspace`, `objective = "resonance"`)
//! default to "none" so older files still parse, round-trip through the commented TOML, and
//! are refused with the field, the value and the accepted range when out of range or
//! inconsistent.

use flexstage_scenario::{ObjectiveKind, Preset, Scenario};

fn refused(s: &Scenario) -> String {
    s.validate().unwrap_err().to_string()
}

#[test]
fn defaults_round_trip_and_older_files_parse() {
    let s = Scenario::preset(Preset::Paper);
    assert_eq!(
        (
            s.output.payload,
            s.optimization.min_frequency,
            s.optimization.min_workspace
        ),
        (0.0, 0.0, 0.0)
    );
    let mut t = s.clone();
    t.output.payload = 0.02;
    t.optimization.min_frequency = 6000.0;
    let back = Scenario::from_toml_str(&t.to_commented_toml(), "t").unwrap();
    assert_eq!(back, t);
    // A file written before these fields existed.
    let old: String = s
        .to_toml()
        .lines()
        .filter(|l| {
            !l.starts_with("payload")
                && !l.starts_with("min_frequency")
                && !l.starts_with("min_workspace")
        })
        .collect::<Vec<_>>()
        .join("\n");
    assert_eq!(Scenario::from_toml_str(&old, "old").unwrap(), s);
}

#[test]
fn out_of_range_and_inconsistent_values_are_refused_by_name() {
    let base = Scenario::preset(Preset::Quick);
    let mut s = base.clone();
    s.output.payload = -0.01;
    let e = refused(&s);
    assert!(e.contains("output.payload") && e.contains("[0"), "{e}");
    s.output.payload = f64::NAN;
    assert!(refused(&s).contains("output.payload"));
    let mut s = base.clone();
    s.optimization.min_frequency = 2e6;
    let e = refused(&s);
    assert!(
        e.contains("optimization.min_frequency") && e.contains("1e6"),
        "{e}"
    );
    let mut s = base.clone();
    s.optimization.objective = ObjectiveKind::Resonance;
    let e = refused(&s);
    assert!(
        e.contains("optimization.min_workspace") && e.contains("resonance"),
        "{e}"
    );
    s.optimization.min_workspace = 2e-9;
    assert!(s.validate().is_ok());
    s.optimization.min_frequency = 5000.0;
    let e = refused(&s);
    assert!(e.contains("optimization.min_frequency"), "{e}");
    let mut s = base;
    s.optimization.objective = ObjectiveKind::Displacement;
    s.optimization.min_frequency = 5000.0;
    assert!(refused(&s).contains("optimization.min_frequency"));
}
