//! The numeric leaves of a scenario's TOML and how to set one (shared by the scenario's and
//! the CLI's edge tests).

#![allow(dead_code)] // each test uses a part of it

use toml::Value;

/// A leaf of a TOML value as a path of keys and `[index]`es, e.g. `["controller", "pid", "[2]"]`.
pub type Leaf = Vec<String>;

/// Every numeric leaf (float or integer, also inside arrays and arrays of tables).
pub fn numeric_leaves(v: &Value) -> Vec<Leaf> {
    fn walk(v: &Value, path: &mut Leaf, out: &mut Vec<Leaf>) {
        match v {
            Value::Table(t) => {
                for (k, x) in t {
                    path.push(k.clone());
                    walk(x, path, out);
                    path.pop();
                }
            }
            Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    path.push(format!("[{i}]"));
                    walk(x, path, out);
                    path.pop();
                }
            }
            Value::Float(_) | Value::Integer(_) => out.push(path.clone()),
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk(v, &mut Vec::new(), &mut out);
    out
}

/// The value at `leaf`.
pub fn at<'a>(v: &'a mut Value, leaf: &[String]) -> &'a mut Value {
    leaf.iter().fold(v, |v, k| match k.strip_prefix('[') {
        Some(i) => &mut v.as_array_mut().expect("an array")
            [i.trim_end_matches(']').parse::<usize>().expect("an index")],
        None => v
            .as_table_mut()
            .expect("a table")
            .get_mut(k)
            .expect("a key"),
    })
}

/// The leaf as the scenario names it: `controller.pid[2]`, `trajectories[0].duration`.
pub fn name(leaf: &[String]) -> String {
    let mut s = String::new();
    for k in leaf {
        if !k.starts_with('[') && !s.is_empty() {
            s.push('.');
        }
        s.push_str(k);
    }
    s
}

/// `v` with the leaf set to `x` (an integer leaf gets an integer when `x` is one).
pub fn with(v: &Value, leaf: &[String], x: f64) -> Value {
    let mut v = v.clone();
    let slot = at(&mut v, leaf);
    *slot = match slot {
        Value::Integer(_) if x.fract() == 0.0 && x.abs() < 9.2e18 => Value::Integer(x as i64),
        _ => Value::Float(x),
    };
    v
}

/// Whether the scenario `base` with the leaf set to `x` parses and validates.
pub fn accepts(base: &Value, leaf: &[String], x: f64) -> bool {
    let text = toml::to_string(&with(base, leaf, x)).expect("TOML");
    flexstage_scenario::Scenario::from_toml_str(&text, "edge.toml").is_ok()
}

/// A key that orders every float (total order, -0 before +0) as the integers order it; its own
/// inverse.
pub fn key(x: f64) -> i64 {
    let b = x.to_bits() as i64;
    b ^ ((((b >> 63) as u64) >> 1) as i64)
}

pub fn from_key(k: i64) -> f64 {
    f64::from_bits(key(f64::from_bits(k as u64)) as u64)
}

/// The last key accepted going from `from` (accepted) towards `to` (refused), and the first
/// refused: bisection on the ordered keys.
pub fn boundary(accept: &dyn Fn(i64) -> bool, from: i64, to: i64) -> (i64, i64) {
    let (mut a, mut r) = (i128::from(from), i128::from(to));
    while (r - a).abs() > 1 {
        let mid = a + (r - a) / 2;
        if accept(mid as i64) { a = mid } else { r = mid }
    }
    (a as i64, r as i64)
}

/// The edges of a numeric leaf: the smallest and largest value of the accepted range around
/// its current value and the values just beyond them (found by bisection, so they are the
/// validation's own bounds), and the hostile classes zero, subnormal, smallest normal, huge,
/// largest, NaN and infinite. Integer leaves get integer edges.
pub fn edges(base: &Value, leaf: &[String]) -> Vec<(&'static str, f64)> {
    let mut v = base.clone();
    let integer = matches!(at(&mut v, leaf), Value::Integer(_));
    let mut out = Vec::new();
    if integer {
        let Value::Integer(d) = *at(&mut v, leaf) else {
            unreachable!()
        };
        let accept = |k: i64| accepts(base, leaf, k as f64);
        for (lo_name, hi_name, to) in [
            ("min", "below min", i64::MIN),
            ("max", "above max", i64::MAX),
        ] {
            if accept(to) {
                out.push((lo_name, to as f64));
            } else {
                // i64 keys are the integers themselves; TOML holds them exactly.
                let (a, r) = boundary(&|k| accept(k), d, to);
                out.push((lo_name, a as f64));
                out.push((hi_name, r as f64));
            }
        }
        for (name, x) in [
            ("zero", 0i64),
            ("minus one", -1),
            ("huge", i64::MAX),
            ("most negative", i64::MIN),
        ] {
            out.push((name, x as f64));
        }
        out.sort_by(|a, b| a.1.total_cmp(&b.1));
        out.dedup_by(|a, b| a.1 == b.1);
        return out;
    }
    let Value::Float(d) = *at(&mut v, leaf) else {
        panic!("{} is not numeric", name(leaf))
    };
    let accept = |k: i64| accepts(base, leaf, from_key(k));
    for (edge, beyond, to) in [
        ("min", "below min", -f64::MAX),
        ("max", "above max", f64::MAX),
    ] {
        if accept(key(to)) {
            out.push((edge, to));
        } else {
            let (a, r) = boundary(&accept, key(d), key(to));
            out.push((edge, from_key(a)));
            out.push((beyond, from_key(r)));
        }
    }
    for (name, x) in [
        ("zero", 0.0),
        ("negative zero", -0.0),
        ("subnormal", 5e-324),
        ("negative subnormal", -5e-324),
        ("smallest normal", f64::MIN_POSITIVE),
        ("huge", 1e308),
        ("negative huge", -1e308),
        ("NaN", f64::NAN),
        ("infinite", f64::INFINITY),
        ("negative infinite", f64::NEG_INFINITY),
    ] {
        out.push((name, x));
    }
    out
}

/// The message of an error and its sources.
pub fn chain(e: &dyn std::error::Error) -> String {
    let mut m = e.to_string();
    let mut s = e.source();
    while let Some(x) = s {
        m.push_str(": ");
        m.push_str(&x.to_string());
        s = x.source();
    }
    m
}

/// What a user-facing message must not contain: an internal type name (`Params::`), a number
/// printed with more than 24 digits in a row, more than 1500 characters. `None` when clean.
pub fn unclear(message: &str) -> Option<String> {
    if message.contains("::") {
        return Some("an internal name (`::`)".into());
    }
    let mut run = 0;
    for c in message.chars() {
        run = if c.is_ascii_digit() { run + 1 } else { 0 };
        if run > 24 {
            return Some("a number of more than 24 digits".into());
        }
    }
    (message.len() > 1500).then(|| format!("{} characters", message.len()))
}
