//! Reference: the second hardening review, "Look for the next ones yourselves: drive every numeric scenario
//! field … to its edges (minimum, maximum, just beyond, subnormal, huge, NaN)". Goal, for
//! `flexstage check` (`Scenario::from_toml_str`): every numeric leaf of the quick preset and of
//! the inverter example, at the edges of its own accepted range (found by bisection, so the
//! test follows the validation rather than a copy of it) and at the hostile classes, is either
//! accepted or refused within 2 s with a message that names the field (its key or its group)
//! in the scenario's words: no internal type name, no 300-digit number. What the accepted
//! edges do in `design` and `track` is the CLI's `edges_proptest`.

#[path = "common/leaves.rs"]
mod leaves;

use std::time::{Duration, Instant};

use flexstage_scenario::{Preset, Scenario};
use leaves::*;
use toml::Value;

fn bases() -> Vec<(&'static str, Value)> {
    let quick = toml::from_str(&Scenario::preset(Preset::Quick).to_toml()).unwrap();
    let inverter = toml::from_str(
        &std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../examples/scenarios/inverter.toml"
        ))
        .unwrap(),
    )
    .unwrap();
    vec![("quick", quick), ("inverter", inverter)]
}

#[test]
fn every_numeric_field_at_its_edges_is_accepted_or_refused_by_name() {
    let mut failures = Vec::new();
    let mut cases = 0;
    for (base_name, base) in bases() {
        for leaf in numeric_leaves(&base) {
            let field = name(&leaf);
            let key = leaf
                .iter()
                .rev()
                .find(|k| !k.starts_with('['))
                .unwrap()
                .clone();
            for (edge, x) in edges(&base, &leaf) {
                cases += 1;
                let text = toml::to_string(&with(&base, &leaf, x)).unwrap();
                let t0 = Instant::now();
                let result = Scenario::from_toml_str(&text, "edge.toml");
                if t0.elapsed() > Duration::from_secs(2) {
                    failures.push(format!(
                        "{base_name} {field} = {x:e} ({edge}): took {:?}",
                        t0.elapsed()
                    ));
                }
                let Err(e) = result else { continue };
                let m = chain(&e);
                if !(m.contains(key.as_str()) || m.contains(leaf[0].as_str())) {
                    failures.push(format!(
                        "{base_name} {field} = {x:e} ({edge}): names neither {key} nor {}: {m}",
                        leaf[0]
                    ));
                }
                if let Some(why) = unclear(&m) {
                    failures.push(format!("{base_name} {field} = {x:e} ({edge}): {why}: {m}"));
                }
            }
        }
    }
    println!("{cases} edge cases");
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
