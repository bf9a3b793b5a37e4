//! Reference: the run-and-report requirements "`flexstage run`, an HTML report, CAD outline export". Goal: the
//! README's main command runs every stage on the quick preset (made small: `tiny_scenario`), writes a self-contained
//! `report.html` with every section and its figures (no network needed), the outline files,
//! and running it again resumes (every stage skipped). The newcomer's path: both PEAs and Table 4's
//! gains are in the report.

use std::path::PathBuf;
use std::process::Command;

use flexstage_run::layout;

const BIN: &str = env!("CARGO_BIN_EXE_flexstage");

/// Section ids of the report, in order (flexstage_report::html::SECTIONS).
const SECTIONS: [&str; 9] = [
    "summary",
    "design",
    "convergence",
    "reduce",
    "modes",
    "pea",
    "stage",
    "tracking",
    "export",
];

/// The quick preset as `flexstage init` writes it, made small for CI: a 24 × 12
/// mesh, 8 stroke samples, 10 design iterations (and 2 Monte-Carlo plants, `run`). Every stage and report section still runs.
fn tiny_scenario(dir: &std::path::Path) -> PathBuf {
    let path = dir.with_extension("toml");
    let _ = std::fs::remove_file(&path);
    let ok = Command::new(BIN)
        .arg("init")
        .arg(&path)
        .status()
        .unwrap()
        .success();
    assert!(ok, "flexstage init");
    let mut text = std::fs::read_to_string(&path).unwrap();
    for (from, to) in [
        ("\nnl = 48\n", "\nnl = 24\n"),
        ("\nnw = 24\n", "\nnw = 12\n"),
        ("\nsamples = 16\n", "\nsamples = 8\n"),
        ("\nmax_iterations = 100\n", "\nmax_iterations = 10\n"),
    ] {
        assert!(text.contains(from), "the quick preset has {from:?}");
        text = text.replacen(from, to, 1);
    }
    std::fs::write(&path, text).unwrap();
    path
}

fn run(dir: &PathBuf) -> (String, String) {
    let scenario = tiny_scenario(dir);
    let out = Command::new(BIN)
        .arg("run")
        .arg(&scenario)
        .arg("--out")
        .arg(dir)
        // Every stage and section runs; the Monte-Carlo's pass rates need no 100 plants here.
        .arg("--montecarlo-plants")
        .arg("2")
        .output()
        .expect("flexstage runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "flexstage run failed:\n{stderr}");
    (stdout, stderr)
}

/// The text of every `attr="..."` value in the HTML.
fn attribute_values<'a>(html: &'a str, attr: &str) -> Vec<&'a str> {
    html.split(&format!("{attr}=\""))
        .skip(1)
        .filter_map(|s| s.split('"').next())
        .collect()
}

#[test]
fn run_writes_a_self_contained_report_with_every_section_and_resumes() {
    let dir = std::env::temp_dir().join(format!("flexstage-run-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (stdout, _) = run(&dir);
    assert!(stdout.contains("report: "), "prints where the report is");
    assert!(stdout.contains("workspace area"), "prints the summary");
    assert!(stdout.contains("use: "), "prints which controller to use");

    let html = std::fs::read_to_string(dir.join(layout::REPORT)).unwrap();
    // Every section present, in order, and none reported as not run.
    let mut at = 0;
    for id in SECTIONS {
        let pos = html
            .find(&format!("<section id=\"{id}\">"))
            .unwrap_or_else(|| panic!("section {id} missing"));
        assert!(pos > at, "section {id} out of order");
        at = pos;
    }
    assert_eq!(
        html.matches("<section").count(),
        html.matches("</section>").count()
    );
    // The twin section is "not run" until `run` writes twin/ (wired in parallel), the front's
    // until `flexstage front` runs (a command of its own, not a stage of `run`); every other
    // section must have its results.
    let without = |html: &str, id: &str| match html.split_once(&format!("<section id=\"{id}\">")) {
        Some((before, after)) => format!(
            "{before}{}",
            after.split_once("</section>").map_or("", |(_, rest)| rest)
        ),
        None => html.to_string(),
    };
    let run_sections = without(&without(&html, "twin"), "front");
    assert!(
        !run_sections.contains("class=\"notrun\""),
        "a stage is missing in a full run"
    );
    // Figures: embedded only (SVG inline, PNG as data URIs), and enough of them: density,
    // workspace, convergence, validity, mode shapes, Table A1/Figure A2 for both PEAs,
    // Table 4 convergence, tracking (Figures 9-11 and the error view).
    assert!(
        html.matches("<figure").count() >= 25,
        "only {} figures",
        html.matches("<figure").count()
    );
    for s in attribute_values(&html, "src") {
        assert!(
            s.starts_with("data:image/svg+xml;base64,") || s.starts_with("data:image/png;base64,"),
            "not an embedded image: {}",
            &s[..s.len().min(60)]
        );
    }
    for id in SECTIONS.iter().skip(1) {
        let start = html.find(&format!("<section id=\"{id}\">")).unwrap();
        let end = start + html[start..].find("</section>").unwrap();
        assert!(
            html[start..end].contains("<figure"),
            "section {id} has no figure"
        );
    }
    assert!(html.contains("PEA2 estimate"), "Table A1 shows both PEAs");
    assert!(
        html.contains("k_e1") && html.contains("k_ε1"),
        "Table 4 shows the gains"
    );
    // No network: no external URL in any src/href (the nav links are fragments, a picture's
    // link to its full size is embedded); the one
    // script (click to enlarge) loads nothing.
    for h in attribute_values(&html, "href") {
        assert!(
            h.starts_with('#') || h.starts_with("data:image/"),
            "external link {h}"
        );
    }
    assert!(!html.contains("src=\"http"), "external image");
    assert_eq!(html.matches("<script").count(), 1, "one inline script");
    let script = &html[html.find("<script>").unwrap()..html.find("</script>").unwrap()];
    for net in ["http", "fetch(", "XMLHttpRequest", "import("] {
        assert!(!script.contains(net), "the script uses the network: {net}");
    }

    // Outline export: DXF with LWPOLYLINE entities, STL with its declared triangle count.
    let dxf = std::fs::read_to_string(dir.join(layout::export::DXF)).unwrap();
    assert!(
        dxf.contains("LWPOLYLINE") && dxf.contains("AC1015"),
        "R2000 DXF outline"
    );
    let stl = std::fs::read(dir.join(layout::export::STL)).unwrap();
    let n = u32::from_le_bytes(stl[80..84].try_into().unwrap()) as usize;
    assert!(n > 0 && stl.len() == 84 + 50 * n);

    // The simulated stage is the designed one: the plant's truth is the reduced model.
    let reduced: flexstage_scenario::StageParams =
        toml::from_str(&std::fs::read_to_string(dir.join(layout::reduce::PARAMS)).unwrap())
            .unwrap();
    let plant =
        flexstage_scenario::Scenario::load(&dir.join(layout::PLANT)).expect("plant.toml is valid");
    assert_eq!(plant.stage.truth, reduced);
    assert_eq!(plant.stage.guess.mass, reduced.mass);

    // `run --montecarlo-plants 2` reaches the study: plants 0 and 1, every controller each.
    let study = std::fs::read_to_string(dir.join(layout::Tracking::main().montecarlo())).unwrap();
    let plants: std::collections::BTreeSet<&str> = study
        .lines()
        .skip(1)
        .filter_map(|l| l.split(',').next())
        .collect();
    assert_eq!(plants.into_iter().collect::<Vec<_>>(), ["0", "1"]);

    // Resume: every finished stage is skipped.
    let (_, stderr) = run(&dir);
    assert_eq!(
        stderr.matches("done earlier, skipped").count(),
        8,
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_file(dir.with_extension("toml"));
}
