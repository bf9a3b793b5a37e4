//! What changed between two scenarios, field by field (`optimization.penalty: 3.0 → 2.0`), for
//! the messages that refuse to resume or to mix a run folder with another scenario.

use std::fmt;

use flexstage_scenario::Scenario;
use toml::Value;

use crate::state::scenario_text;

/// How many changes a message lists before "and N more".
pub const LISTED: usize = 8;

/// One changed field.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Change {
    /// The field path, e.g. `optimization.penalty` or `trajectories[1].amplitude`.
    pub path: String,
    /// The old value as TOML (`(absent)` if it had none).
    pub old: String,
    /// The new value as TOML (`(absent)` if it has none).
    pub new: String,
}

/// The changes from a recorded scenario to a new one, in field order.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Changes(pub Vec<Change>);

impl fmt::Display for Changes {
    /// `a.b: 1 → 2, c: "x" → "y" and 3 more changes`, or a sentence when there are none.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.is_empty() {
            return write!(
                f,
                "no field differs, but the recorded scenario's hash does (recorded by another \
                 flexstage version?)"
            );
        }
        let shown: Vec<String> = self
            .0
            .iter()
            .take(LISTED)
            .map(|c| format!("{}: {} → {}", c.path, c.old, c.new))
            .collect();
        write!(f, "changed {}", shown.join(", "))?;
        if self.0.len() > LISTED {
            write!(f, " and {} more", self.0.len() - LISTED)?;
        }
        Ok(())
    }
}

/// The changes from the recorded TOML `old` to `new`. A recorded text that does not parse is
/// one change of the whole scenario.
pub fn scenario_changes(old: &str, new: &Scenario) -> Changes {
    let new_value: Value = match toml::from_str(&scenario_text(new)) {
        Ok(v) => v,
        Err(_) => return Changes::default(),
    };
    match toml::from_str::<Value>(old) {
        Ok(old_value) => {
            let mut out = Vec::new();
            diff("", &old_value, &new_value, &mut out);
            Changes(out)
        }
        Err(e) => Changes(vec![Change {
            path: "(whole scenario)".into(),
            old: format!("unreadable TOML ({})", e.message()),
            new: format!("scenario {:?}", new.name),
        }]),
    }
}

/// Appends the changes from `old` to `new` below `path`.
fn diff(path: &str, old: &Value, new: &Value, out: &mut Vec<Change>) {
    let join = |key: &str| {
        if path.is_empty() {
            key.to_string()
        } else {
            format!("{path}.{key}")
        }
    };
    match (old, new) {
        (Value::Table(a), Value::Table(b)) => {
            for (k, va) in a {
                match b.get(k) {
                    Some(vb) => diff(&join(k), va, vb, out),
                    None => out.push(change(&join(k), Some(va), None)),
                }
            }
            for (k, vb) in b.iter().filter(|(k, _)| !a.contains_key(*k)) {
                out.push(change(&join(k), None, Some(vb)));
            }
        }
        (Value::Array(a), Value::Array(b)) => {
            for (i, (va, vb)) in a.iter().zip(b).enumerate() {
                diff(&format!("{path}[{i}]"), va, vb, out);
            }
            if a.len() != b.len() {
                out.push(Change {
                    path: path.to_string(),
                    old: entries(a.len()),
                    new: entries(b.len()),
                });
            }
        }
        (a, b) if a != b => out.push(change(path, Some(a), Some(b))),
        _ => {}
    }
}

fn entries(n: usize) -> String {
    format!("{n} {}", if n == 1 { "entry" } else { "entries" })
}

fn change(path: &str, old: Option<&Value>, new: Option<&Value>) -> Change {
    let show = |v: Option<&Value>| v.map_or_else(|| "(absent)".to_string(), short);
    Change {
        path: path.to_string(),
        old: show(old),
        new: show(new),
    }
}

/// A value as inline TOML, at most 60 characters.
fn short(v: &Value) -> String {
    let mut s = v.to_string();
    if let Some((cut, _)) = s.char_indices().nth(60) {
        s.truncate(cut);
        s.push('…');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn changes_name_the_field_path_and_both_values() {
        let old = crate::folder::preset("quick").unwrap();
        let mut new = old.clone();
        assert_eq!(
            scenario_changes(&scenario_text(&old), &new),
            Changes::default()
        );
        new.optimization.penalty = 2.0;
        new.name = "other".into();
        if let flexstage_scenario::Trajectory::Lissajous { duration, .. } = &mut new.trajectories[1]
        {
            *duration = 2.0;
        }
        new.supports.pop();
        let c = scenario_changes(&scenario_text(&old), &new);
        let text = c.to_string();
        for part in [
            "name: \"quick\" → \"other\"",
            "optimization.penalty: 3.0 → 2.0",
            "trajectories[1].duration: 1.0 → 2.0",
            "supports: ",
        ] {
            assert!(text.contains(part), "{part:?} missing in {text}");
        }
        assert_eq!(c.0.len(), 4, "{text}");
    }

    #[test]
    fn long_lists_are_cut_and_unreadable_records_said_so() {
        let old = crate::folder::preset("quick").unwrap();
        let new = crate::folder::preset("paper").unwrap();
        let text = scenario_changes(&scenario_text(&old), &new).to_string();
        assert!(text.contains(" more"), "{text}");
        let bad = scenario_changes("mesh = [", &new).to_string();
        assert!(bad.contains("unreadable TOML"), "{bad}");
    }
}
