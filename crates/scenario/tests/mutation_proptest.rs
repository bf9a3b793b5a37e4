//! Reference: the input-bounds and fault-handling requirements, "Property-based tests (proptest) that mutate the default scenario …
//! and assert no panic, no hang (bounded work) and a message naming the field".
//! Goal: every leaf of the quick preset's TOML (numbers, integers, booleans, strings, array
//! elements) is replaced by a hostile value (0, negative, NaN, ±∞, huge, tiny, wrong type,
//! arrays one longer or shorter, names empty, duplicated, very long or with '/'); parsing and
//! validating the mutant never panics, ends within 2 s, and a refusal names the mutated key or
//! its group.

use std::time::{Duration, Instant};

use flexstage_scenario::{Preset, Scenario};
use proptest::prelude::*;
use toml::Value;

/// Every leaf of a TOML value as a path of keys and indices.
fn leaves(v: &Value, path: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    match v {
        Value::Table(t) => {
            for (k, x) in t {
                path.push(k.clone());
                leaves(x, path, out);
                path.pop();
            }
        }
        Value::Array(a) => {
            out.push(path.clone()); // the array itself (longer / shorter)
            for (i, x) in a.iter().enumerate() {
                path.push(format!("[{i}]"));
                leaves(x, path, out);
                path.pop();
            }
        }
        _ => out.push(path.clone()),
    }
}

fn at<'a>(v: &'a mut Value, path: &[String]) -> &'a mut Value {
    path.iter().fold(v, |v, k| match k.strip_prefix('[') {
        Some(i) => {
            &mut v.as_array_mut().unwrap()[i.trim_end_matches(']').parse::<usize>().unwrap()]
        }
        None => v.as_table_mut().unwrap().get_mut(k).unwrap(),
    })
}

/// A hostile replacement, chosen by `k`, for the value `old`.
fn hostile(old: &Value, k: usize) -> Value {
    let floats = [
        0.0,
        -1.0,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        1e308,
        1e-308,
        -1e-300,
        1e12,
    ];
    match old {
        Value::Array(a) => {
            let mut a = a.clone();
            if k % 2 == 0 && !a.is_empty() {
                a.pop();
            } else if let Some(x) = a.first().cloned() {
                a.push(x);
            }
            Value::Array(a)
        }
        Value::String(s) => Value::String(match k % 5 {
            0 => String::new(),
            1 => "x".repeat(5000),
            2 => "a/b".into(),
            3 => "lissajous-3".into(), // duplicates the first trajectory's name
            _ => format!("{s}\u{0}"),
        }),
        Value::Integer(_) => match k % 4 {
            0 => Value::Integer(0),
            1 => Value::Integer(-1),
            2 => Value::Integer(i64::MAX),
            _ => Value::Float(f64::NAN),
        },
        Value::Boolean(b) => {
            if k % 2 == 0 {
                Value::Boolean(!b)
            } else {
                Value::Float(1.0)
            }
        }
        _ => Value::Float(floats[k % floats.len()]),
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

fn base() -> (Value, Vec<Vec<String>>) {
    let v: Value = toml::from_str(&Scenario::preset(Preset::Quick).to_toml()).unwrap();
    let mut out = Vec::new();
    leaves(&v, &mut Vec::new(), &mut out);
    (v, out)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1500, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn a_mutated_scenario_is_refused_naming_the_field_or_accepted(leaf in any::<prop::sample::Index>(), k in 0usize..64) {
        let (mut v, paths) = base();
        let path = &paths[leaf.index(paths.len())];
        let slot = at(&mut v, path);
        *slot = hostile(slot, k);
        let text = toml::to_string(&v).unwrap();
        let t0 = Instant::now();
        let result = Scenario::from_toml_str(&text, "mutant.toml");
        prop_assert!(t0.elapsed() < Duration::from_secs(2), "validation took {:?}", t0.elapsed());
        if let Err(e) = result {
            let m = chain(&e);
            let key = path.iter().rev().find(|k| !k.starts_with('[')).unwrap();
            let group = &path[0];
            prop_assert!(
                m.contains(key.as_str()) || m.contains(group.as_str()),
                "{}: the message names neither {key} nor {group}: {m}", path.join(".")
            );
        }
    }
}

/// Every leaf with every hostile value (the exhaustive version of the property above).
#[test]
fn every_leaf_with_every_hostile_value() {
    let (v0, paths) = base();
    let mut failures = Vec::new();
    for path in &paths {
        for k in 0..36 {
            let mut v = v0.clone();
            let slot = at(&mut v, path);
            *slot = hostile(slot, k);
            let text = toml::to_string(&v).unwrap();
            let t0 = Instant::now();
            let result = Scenario::from_toml_str(&text, "mutant.toml");
            assert!(t0.elapsed() < Duration::from_secs(2), "{}", path.join("."));
            if let Err(e) = result {
                let m = chain(&e);
                let key = path.iter().rev().find(|k| !k.starts_with('[')).unwrap();
                if !(m.contains(key.as_str()) || m.contains(path[0].as_str())) {
                    failures.push(format!("{} ({k}): {m}", path.join(".")));
                }
            }
        }
    }
    failures.dedup();
    assert!(
        failures.is_empty(),
        "{} mutants:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
