//! Reference: the crate order stated in ARCHITECTURE.md ("Crate order": one numbered list of
//! package names) and the workspace's real dependencies (`cargo metadata --format-version 1
//! --no-deps`).
//! Goal: every workspace crate is in the list exactly once, the list names no other crate,
//! and no crate depends on one that comes later in it (normal, build and development
//! dependencies alike), so the order the document states is the order the code has.

use std::collections::HashMap;
use std::path::Path;
use std::process::Command;

/// The package names of the "## Crate order" section's numbered list, in order.
fn stated_order(architecture: &str) -> Vec<String> {
    let Some(start) = architecture.find("\n## Crate order") else {
        return Vec::new();
    };
    let section = &architecture[start + 1..];
    let end = section[3..].find("\n## ").map_or(section.len(), |e| e + 3);
    section[..end]
        .lines()
        .filter_map(|l| {
            let (number, rest) = l.trim_start().split_once(". `")?;
            number.parse::<usize>().ok()?;
            Some(rest.split('`').next()?.to_string())
        })
        .collect()
}

/// Everything wrong with `order` for the workspace `packages` (name, [(dependency, kind)]).
fn violations(order: &[String], packages: &[(String, Vec<(String, String)>)]) -> Vec<String> {
    let mut out = Vec::new();
    let position: HashMap<&str, usize> = order
        .iter()
        .enumerate()
        .map(|(i, n)| (n.as_str(), i))
        .collect();
    if position.len() != order.len() {
        out.push(format!("a crate is listed twice: {order:?}"));
    }
    for n in order {
        if !packages.iter().any(|(p, _)| p == n) {
            out.push(format!("{n} is listed but is no workspace crate"));
        }
    }
    for (p, deps) in packages {
        let Some(&i) = position.get(p.as_str()) else {
            out.push(format!("{p} is missing from the crate order"));
            continue;
        };
        for (d, kind) in deps {
            // A dependency missing from the list is reported as missing on its own.
            if let Some(&j) = position.get(d.as_str())
                && j >= i
            {
                out.push(format!(
                    "{p} (#{}) depends on {d} (#{}, {kind}), which comes later",
                    i + 1,
                    j + 1
                ));
            }
        }
    }
    out
}

/// The workspace's packages and their dependencies on workspace packages, from cargo.
fn workspace(root: &Path) -> Vec<(String, Vec<(String, String)>)> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args(["metadata", "--format-version", "1", "--no-deps"])
        .current_dir(root)
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let packages = meta["packages"].as_array().expect("packages");
    let names: Vec<String> = packages
        .iter()
        .map(|p| p["name"].as_str().expect("name").to_string())
        .collect();
    packages
        .iter()
        .map(|p| {
            let deps = p["dependencies"]
                .as_array()
                .expect("dependencies")
                .iter()
                .filter_map(|d| {
                    let name = d["name"].as_str()?.to_string();
                    let kind = d["kind"].as_str().unwrap_or("normal").to_string();
                    names.contains(&name).then_some((name, kind))
                })
                .collect();
            (p["name"].as_str().expect("name").to_string(), deps)
        })
        .collect()
}

#[test]
fn no_crate_depends_on_a_later_one_in_architecture_md() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let text = std::fs::read_to_string(root.join("ARCHITECTURE.md")).expect("ARCHITECTURE.md");
    let order = stated_order(&text);
    assert!(order.len() > 10, "no crate order found: {order:?}");
    let found = violations(&order, &workspace(&root));
    assert!(found.is_empty(), "{}", found.join("\n"));
}

/// Goal: the check itself can fail: a dependency on a later crate, a crate missing from the
/// list and a listed crate that does not exist are each reported.
#[test]
fn the_order_check_reports_each_kind_of_violation() {
    let text = "# A\n\n## Crate order\n\n1. `a`\n2. `b`\n3. `ghost`\n\n## Next\n\n4. `c`\n";
    let order = stated_order(text);
    assert_eq!(order, ["a", "b", "ghost"]);
    let deps = |d: &[(&str, &str)]| -> Vec<(String, String)> {
        d.iter()
            .map(|(n, k)| (n.to_string(), k.to_string()))
            .collect()
    };
    let packages = vec![
        ("a".to_string(), deps(&[("b", "dev")])),
        ("b".to_string(), deps(&[("a", "normal")])),
        ("c".to_string(), deps(&[])),
    ];
    let found = violations(&order, &packages);
    assert_eq!(found.len(), 3, "{found:?}");
    assert!(
        found
            .iter()
            .any(|v| v.starts_with("a (#1) depends on b (#2, dev)"))
    );
    assert!(
        found
            .iter()
            .any(|v| v == "c is missing from the crate order")
    );
    assert!(
        found
            .iter()
            .any(|v| v == "ghost is listed but is no workspace crate")
    );
    let good = vec![
        ("a".to_string(), deps(&[])),
        ("b".to_string(), deps(&[("a", "normal")])),
        ("ghost".to_string(), deps(&[("b", "build")])),
    ];
    assert!(violations(&order, &good).is_empty());
}
