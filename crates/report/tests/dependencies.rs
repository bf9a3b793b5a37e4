//! Goal: the report sits on top of the run folder, not inside the stages: `flexstage-report`
//! depends (directly or through other workspace crates) only on `flexstage-run`,
//! `flexstage-figures` and what those two use (the scenario and the numerics' validation),
//! never on a stage crate. Read from `cargo metadata` (the manifests of the workspace).

use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;

/// The workspace crates the report may reach.
const ALLOWED: [&str; 4] = [
    "flexstage-run",
    "flexstage-figures",
    "flexstage-scenario",
    "flexstage-numerics",
];

/// Each workspace package with its workspace dependencies (normal and build, not dev).
fn workspace_graph() -> BTreeMap<String, Vec<String>> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let packages = v["packages"].as_array().unwrap();
    let names: BTreeSet<String> = packages
        .iter()
        .map(|p| p["name"].as_str().unwrap().to_string())
        .collect();
    packages
        .iter()
        .map(|p| {
            let deps = p["dependencies"]
                .as_array()
                .unwrap()
                .iter()
                .filter(|d| d["kind"].as_str() != Some("dev"))
                .map(|d| d["name"].as_str().unwrap().to_string())
                .filter(|n| names.contains(n))
                .collect();
            (p["name"].as_str().unwrap().to_string(), deps)
        })
        .collect()
}

/// Every workspace crate `from` reaches through normal dependencies.
fn reached(graph: &BTreeMap<String, Vec<String>>, from: &str) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut todo = vec![from.to_string()];
    while let Some(p) = todo.pop() {
        for d in graph.get(&p).into_iter().flatten() {
            if seen.insert(d.clone()) {
                todo.push(d.clone());
            }
        }
    }
    seen
}

#[test]
fn the_report_depends_on_no_stage_crate() {
    let graph = workspace_graph();
    let reach = reached(&graph, "flexstage-report");
    let stages: Vec<&String> = reach
        .iter()
        .filter(|c| !ALLOWED.contains(&c.as_str()))
        .collect();
    assert!(
        stages.is_empty(),
        "flexstage-report depends on stage crate(s) {stages:?}"
    );
    assert!(reach.contains("flexstage-run") && reach.contains("flexstage-figures"));
    // The run crate stays at the bottom: the scenario and the numerics at most.
    let run = reached(&graph, "flexstage-run");
    assert!(
        run.iter()
            .all(|c| c == "flexstage-scenario" || c == "flexstage-numerics"),
        "{run:?}"
    );
    // The check can fail: the pipeline reaches stage crates.
    assert!(reached(&graph, "flexstage-pipeline").contains("flexstage-topopt"));
}
