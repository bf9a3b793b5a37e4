//! Reference: the second hardening review, "Look for the next ones yourselves: a property-based test that drives
//! every numeric scenario field and CLI option to its edges (minimum, maximum, just beyond,
//! subnormal, huge, NaN) through `check`, the first design iterations and a short `track`, and
//! requires a clear error or a finite result, never a panic, an abort or a run past its bound."
//!
//! Goal: the cases are every *accepted* edge value of every numeric leaf of a small quick
//! scenario (24 × 12 mesh, 8 samples) and of every numeric CLI option. The edges of a field
//! are the bounds of its accepted range around its default (found by bisection on
//! `Scenario::from_toml_str`, so they are the validation's own bounds) and the hostile classes
//! (zero, subnormal, smallest normal, 1e308, largest, NaN, ∞) that it accepts; an option's come
//! from its options type's `validate()` (the refused edges of both are the scenario's and the
//! option-mutation tests'). Each case runs the real command: a design field `flexstage design
//! --max-iterations 2`, any other field a `flexstage track --plant lumped` (the trajectory's
//! own for its fields), an option its subcommand on a run folder holding a 2-iteration design
//! and a PEA record; and the tracking options that are words (every trajectory under every
//! `--compensation`). Required: exit 0 with no NaN or ∞ printed and, for `track`, every row
//! of `metrics.csv` with a status that does not refuse it (`ok` or the flag `saturated`), or
//! exit 1/2 with an error message in the scenario's words (no internal type name, no number of
//! more than 24 digits); never a panic (101), a signal (an abort) or more than `BOUND` (a run
//! past its bound).
//!
//! proptest samples `CASES` of them per run with a fixed seed (CI time stays bounded and
//! repeatable; `PROPTEST_RNG_SEED=<n>` draws another sample); `every_edge_case` (ignored,
//! about 15 minutes) runs them all.

#[path = "../../scenario/tests/common/leaves.rs"]
mod leaves;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use flexstage_pipeline::{
    AnalyzeOptions, DesignOptions, ExportOptions, LimitOverrides, PeaIdOptions, PeaOptions,
    ReduceOptions, StageData, StageIdOptions, TrackOptions,
};
use flexstage_run::layout::Tracking;
use flexstage_scenario::{Preset, Scenario};
use leaves::{accepts, boundary, edges, from_key, key, name, numeric_leaves, unclear, with};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use toml::Value;

const BIN: &str = env!("CARGO_BIN_EXE_flexstage");
/// Longest a case may run: a field or option at its edge stays within its documented work.
const BOUND: Duration = Duration::from_secs(120);
/// Cases proptest runs per CI run.
const CASES: u32 = 40;

/// One command to run.
#[derive(Debug, Clone)]
struct Case {
    /// What is at its edge, e.g. `mesh.nl = 4000 (max)`.
    what: String,
    /// The scenario (TOML) to give the command.
    scenario: String,
    /// The command's words and options.
    args: Vec<String>,
    /// Run in a copy of the prepared run folder (options) or a fresh one (fields).
    prepared: bool,
    /// Documented to take minutes (a record of more than [`HEAVY_STEPS`] plant steps, an
    /// option at the end of its range that sets the length of the work): only in
    /// `every_edge_case`, with [`HEAVY_BOUND`]; likewise a design mesh of more than
    /// [`HEAVY_DOFS`].
    heavy: bool,
}

/// Plant steps of one tracking record above which a case is heavy (about 1 s of lumped
/// simulation a variant).
const HEAVY_STEPS: f64 = 2e7;
/// Longest a heavy case may run (a 1e7-sample record is documented at about five minutes).
const HEAVY_BOUND: Duration = Duration::from_secs(900);

/// DOFs of the design mesh above which a design case is heavy (the 4000 × 12 mesh, 10⁵ DOFs,
/// takes a minute for two iterations and the final analysis).
const HEAVY_DOFS: f64 = 5e4;

/// Whether a design case's mesh has more than [`HEAVY_DOFS`] DOFs.
fn heavy_design(scenario: &str) -> bool {
    let s = Scenario::from_toml_str(scenario, "edge.toml").expect("accepted");
    flexstage_scenario::DesignEstimate::of(&s).dofs > HEAVY_DOFS
}

/// Whether a field case runs a tracking record of more than [`HEAVY_STEPS`] steps.
fn heavy_track(scenario: &str) -> bool {
    let s = Scenario::from_toml_str(scenario, "edge.toml").expect("accepted");
    s.trajectories.iter().any(|t| {
        let d = match t {
            flexstage_scenario::Trajectory::Lissajous { duration, .. }
            | flexstage_scenario::Trajectory::Circle { duration, .. } => *duration,
        };
        flexstage_scenario::RecordEstimate::track(&s, d).steps > HEAVY_STEPS
    })
}

/// The small quick scenario every case starts from.
fn base() -> Value {
    let mut s = Scenario::preset(Preset::Quick);
    s.name = "edges".into();
    s.mesh.nl = 24;
    s.mesh.nw = 12;
    s.optimization.samples = 8;
    toml::from_str(&s.to_toml()).unwrap()
}

/// Top-level groups that the design reads.
const DESIGN_GROUPS: [&str; 8] = [
    "mesh",
    "material",
    "actuators",
    "output",
    "optimization",
    "limits",
    "supports",
    "regions",
];

fn field_cases(base: &Value) -> Vec<Case> {
    let mut out = Vec::new();
    for leaf in numeric_leaves(base) {
        for (edge, x) in edges(base, &leaf) {
            if !accepts(base, &leaf, x) {
                continue;
            }
            let scenario = toml::to_string(&with(base, &leaf, x)).unwrap();
            let design = DESIGN_GROUPS.contains(&leaf[0].as_str());
            let heavy = if design {
                heavy_design(&scenario)
            } else {
                heavy_track(&scenario)
            };
            let args: Vec<String> = if design {
                vec!["design".into(), "--max-iterations".into(), "2".into()]
            } else {
                let mut a: Vec<String> = vec!["track".into(), "--plant".into(), "lumped".into()];
                if leaf[0] == "trajectories" {
                    let i: usize = leaf[1].trim_matches(['[', ']']).parse().unwrap();
                    let t = &base["trajectories"][i]["name"];
                    a.extend(["--trajectory".into(), t.as_str().unwrap().into()]);
                } else {
                    a.extend(["--trajectory".into(), "circle".into()]);
                }
                a
            };
            out.push(Case {
                what: format!("{} = {x:e} ({edge})", name(&leaf)),
                scenario,
                args,
                prepared: false,
                heavy,
            });
        }
    }
    out
}

/// A numeric CLI option: its subcommand words, its flag, whether it takes integers (and the
/// largest its type holds), how `X` is written, and whether the options type accepts `v`.
struct CliOption {
    words: &'static [&'static str],
    flag: &'static str,
    integer: Option<f64>,
    /// `{}` is replaced by the value (pairs: `{},0`).
    form: &'static str,
    valid: fn(f64) -> bool,
    /// The edges at which the option sets minutes of work (a 600 s record, 1e5 iterations).
    heavy_at: &'static [&'static str],
}

fn cli_options() -> Vec<CliOption> {
    fn design(f: impl Fn(&mut DesignOptions)) -> bool {
        let mut o = DesignOptions::default();
        f(&mut o);
        o.validate().is_ok()
    }
    fn stage_id(f: impl Fn(&mut StageIdOptions)) -> bool {
        let mut o = StageIdOptions::default();
        f(&mut o);
        o.validate().is_ok()
    }
    fn simulation(o: &mut StageIdOptions) -> &mut flexstage_pipeline::Simulation {
        match &mut o.data {
            StageData::Simulate(s) => s,
            StageData::Record(_) | StageData::Columns { .. } => {
                unreachable!("the default simulates")
            }
        }
    }
    fn pea(f: impl Fn(&mut PeaOptions)) -> bool {
        let mut o = PeaOptions::default();
        f(&mut o);
        o.validate().is_ok()
    }
    fn pea_id(f: impl Fn(&mut PeaIdOptions)) -> bool {
        let mut o = PeaIdOptions::default();
        f(&mut o);
        o.validate().is_ok()
    }
    fn export(f: impl Fn(&mut LimitOverrides), g: impl Fn(&mut ExportOptions)) -> bool {
        let mut o = ExportOptions::default();
        let mut l = LimitOverrides::default();
        f(&mut l);
        o.verify = Some(l);
        g(&mut o);
        o.validate().is_ok()
    }
    let int = |max: f64| Some(max);
    let usize_max = Some(usize::MAX as f64);
    vec![
        CliOption {
            words: &["design"],
            flag: "--checkpoint-every",
            integer: usize_max,
            form: "{}",
            valid: |v| design(|o| o.checkpoint_every = v as usize),
            heavy_at: &[],
        },
        CliOption {
            words: &["design"],
            flag: "--snapshot-every",
            integer: usize_max,
            form: "{}",
            valid: |v| design(|o| o.snapshot_every = v as usize),
            heavy_at: &[],
        },
        CliOption {
            words: &["design"],
            flag: "--max-iterations",
            integer: usize_max,
            form: "{}",
            valid: |v| design(|o| o.max_iterations = Some(v as usize)),
            heavy_at: &["max"],
        },
        CliOption {
            words: &["analyze"],
            flag: "--inputs",
            integer: None,
            form: "{},0",
            valid: |v| {
                AnalyzeOptions {
                    inputs: vec![[v * 1e-6, 0.0]],
                    ..AnalyzeOptions::default()
                }
                .validate()
                .is_ok()
            },
            heavy_at: &[],
        },
        CliOption {
            words: &["reduce"],
            flag: "--operating-point",
            integer: None,
            form: "{},0",
            valid: |v| {
                ReduceOptions {
                    operating_point: Some([v * 1e-6, 0.0]),
                    ..ReduceOptions::default()
                }
                .validate()
                .is_ok()
            },
            heavy_at: &[],
        },
        CliOption {
            words: &["reduce"],
            flag: "--modes",
            integer: usize_max,
            form: "{}",
            valid: |v| {
                ReduceOptions {
                    modes: v as usize,
                    ..ReduceOptions::default()
                }
                .validate()
                .is_ok()
            },
            heavy_at: &[],
        },
        CliOption {
            words: &["reduce"],
            flag: "--scales",
            integer: None,
            form: "{}",
            valid: |v| {
                ReduceOptions {
                    scales: vec![v],
                    ..ReduceOptions::default()
                }
                .validate()
                .is_ok()
            },
            heavy_at: &[],
        },
        CliOption {
            words: &["identify", "pea"],
            flag: "--pea",
            integer: int(255.0),
            form: "{}",
            valid: |v| pea_id(|o| o.pea = v as u8),
            heavy_at: &[],
        },
        CliOption {
            words: &["identify", "pea"],
            flag: "--forgetting",
            integer: None,
            form: "{}",
            valid: |v| pea_id(|o| o.forgetting = v),
            heavy_at: &[],
        },
        CliOption {
            words: &["identify", "pea"],
            flag: "--passes",
            integer: int(u32::MAX as f64),
            form: "{}",
            valid: |v| pea_id(|o| o.passes = v as u32),
            heavy_at: &["max"],
        },
        CliOption {
            words: &["identify", "stage"],
            flag: "--duration",
            integer: None,
            form: "{}",
            valid: |v| stage_id(|o| simulation(o).duration = Some(v)),
            heavy_at: &["max"],
        },
        CliOption {
            words: &["identify", "stage"],
            flag: "--f-max",
            integer: None,
            form: "{}",
            valid: |v| stage_id(|o| simulation(o).f_max = v),
            heavy_at: &[],
        },
        CliOption {
            words: &["identify", "stage"],
            flag: "--resonance-um",
            integer: None,
            form: "{}",
            valid: |v| stage_id(|o| simulation(o).resonance_amplitude = v * 1e-6),
            heavy_at: &[],
        },
        CliOption {
            words: &["identify", "stage"],
            flag: "--forgetting",
            integer: None,
            form: "{}",
            valid: |v| stage_id(|o| o.estimator.forgetting = v),
            heavy_at: &[],
        },
        CliOption {
            words: &["identify", "stage"],
            flag: "--prefilter",
            integer: None,
            form: "{}",
            valid: |v| stage_id(|o| o.estimator.prefilter = v),
            heavy_at: &[],
        },
        CliOption {
            words: &["identify", "stage"],
            flag: "--decimation",
            integer: usize_max,
            form: "{}",
            valid: |v| stage_id(|o| o.estimator.decimation = v as usize),
            heavy_at: &[],
        },
        CliOption {
            words: &["pea", "simulate"],
            flag: "--pea",
            integer: int(255.0),
            form: "{}",
            valid: |v| pea(|o| o.pea = v as u8),
            heavy_at: &[],
        },
        CliOption {
            words: &["pea", "simulate"],
            flag: "--frequency",
            integer: None,
            form: "{}",
            valid: |v| pea(|o| o.frequency = v),
            heavy_at: &["min"],
        },
        CliOption {
            words: &["pea", "simulate"],
            flag: "--cycles",
            integer: int(u32::MAX as f64),
            form: "{}",
            valid: |v| pea(|o| o.cycles = v as u32),
            heavy_at: &["max"],
        },
        CliOption {
            words: &["pea", "simulate"],
            flag: "--noise-nm",
            integer: None,
            form: "{}",
            valid: |v| pea(|o| o.noise_nm = v),
            heavy_at: &[],
        },
        CliOption {
            words: &["pea", "simulate"],
            flag: "--dt",
            integer: None,
            form: "{}",
            valid: |v| pea(|o| o.dt = Some(v)),
            heavy_at: &["min"],
        },
        CliOption {
            words: &["pea", "simulate"],
            flag: "--seed",
            integer: int(u64::MAX as f64),
            form: "{}",
            valid: |v| pea(|o| o.seed = Some(v as u64)),
            heavy_at: &[],
        },
        CliOption {
            words: &["track", "--plant", "lumped"],
            flag: "--duration",
            integer: None,
            form: "{}",
            valid: |v| {
                TrackOptions {
                    duration: Some(v),
                    ..TrackOptions::default()
                }
                .validate()
                .is_ok()
            },
            heavy_at: &["max"],
        },
        CliOption {
            words: &["export"],
            flag: "--level",
            integer: None,
            form: "{}",
            valid: |v| export(|_| (), |o| o.level = v),
            heavy_at: &[],
        },
        CliOption {
            words: &["export"],
            flag: "--smoothing",
            integer: usize_max,
            form: "{}",
            valid: |v| export(|_| (), |o| o.smoothing = v as usize),
            heavy_at: &[],
        },
        CliOption {
            words: &["export"],
            flag: "--max-chord-mm",
            integer: None,
            form: "{}",
            valid: |v| export(|_| (), |o| o.max_chord = v * 1e-3),
            heavy_at: &[],
        },
        CliOption {
            words: &["export"],
            flag: "--fatigue-strength-mpa",
            integer: None,
            form: "{}",
            valid: |v| export(|l| l.fatigue_strength = Some(v * 1e6), |_| ()),
            heavy_at: &[],
        },
        CliOption {
            words: &["export"],
            flag: "--safety-factor",
            integer: None,
            form: "{}",
            valid: |v| export(|l| l.safety_factor = Some(v), |_| ()),
            heavy_at: &[],
        },
        CliOption {
            words: &["export"],
            flag: "--min-ligament-mm",
            integer: None,
            form: "{}",
            valid: |v| export(|l| l.min_ligament = Some(v * 1e-3), |_| ()),
            heavy_at: &[],
        },
        CliOption {
            words: &["export"],
            flag: "--min-gap-mm",
            integer: None,
            form: "{}",
            valid: |v| export(|l| l.min_gap = Some(v * 1e-3), |_| ()),
            heavy_at: &[],
        },
        CliOption {
            words: &["export"],
            flag: "--start-hole-mm",
            integer: None,
            form: "{}",
            valid: |v| export(|l| l.start_hole_diameter = Some(v * 1e-3), |_| ()),
            heavy_at: &[],
        },
    ]
}

fn option_cases(scenario: &str) -> Vec<Case> {
    let mut out = Vec::new();
    for o in cli_options() {
        let valid = o.valid;
        let start = (1..=10)
            .map(f64::from)
            .chain([0.5, 1e-3, 1e-6, 0.0])
            .find(|&v| valid(v))
            .unwrap_or_else(|| panic!("{}: no accepted start", o.flag));
        let mut values: Vec<(&str, f64)> = Vec::new();
        match o.integer {
            Some(max) => {
                // Integer options: the integers themselves are the keys (within i64).
                let accept = |k: i64| valid(k as f64);
                let top = max.min(i64::MAX as f64) as i64;
                for (edge, to) in [("min", 0i64), ("max", top)] {
                    let x = if accept(to) {
                        to
                    } else {
                        boundary(&accept, start as i64, to).0
                    };
                    values.push((edge, x as f64));
                }
            }
            None => {
                let accept = |k: i64| valid(from_key(k));
                for (edge, to) in [("min", -f64::MAX), ("max", f64::MAX)] {
                    let x = if valid(to) {
                        to
                    } else {
                        from_key(boundary(&accept, key(start), key(to)).0)
                    };
                    values.push((edge, x));
                }
                for (edge, x) in [
                    ("zero", 0.0),
                    ("subnormal", 5e-324),
                    ("huge", 1e308),
                    ("NaN", f64::NAN),
                ] {
                    if valid(x) {
                        values.push((edge, x));
                    }
                }
            }
        }
        values.dedup_by(|a, b| a.1 == b.1);
        for (edge, x) in values {
            let shown = if o.integer.is_some() {
                format!("{}", x as u64)
            } else {
                format!("{x:e}")
            };
            let v = o.form.replace("{}", &shown);
            let mut args: Vec<String> = o.words.iter().map(|w| w.to_string()).collect();
            args.push(format!("{}={v}", o.flag));
            out.push(Case {
                what: format!("{} {}={v} ({edge})", o.words.join(" "), o.flag),
                scenario: scenario.to_string(),
                args,
                prepared: true,
                heavy: o.heavy_at.contains(&edge),
            });
        }
    }
    out
}

/// The tracking options that are words, not numbers: every trajectory of the scenario under
/// every hysteresis compensation, all default controllers, on the lumped plant.
fn tracking_cases(base: &Value, scenario: &str) -> Vec<Case> {
    let mut out = Vec::new();
    for t in base["trajectories"].as_array().unwrap() {
        let name = t["name"].as_str().unwrap();
        for compensation in ["inverse", "off", "ideal"] {
            out.push(Case {
                what: format!("track --trajectory {name} --compensation {compensation}"),
                scenario: scenario.to_string(),
                args: [
                    "track",
                    "--plant",
                    "lumped",
                    "--trajectory",
                    name,
                    "--compensation",
                    compensation,
                ]
                .map(String::from)
                .to_vec(),
                prepared: false,
                heavy: false,
            });
        }
    }
    out
}

/// `Err` naming a `metrics.csv` under `out` whose rows lack a status, or have one that
/// refuses the result (`diverged`, `error-above-bound`) although the command exited 0.
fn statuses_agree_with_exit_0(out: &Path) -> Result<(), String> {
    let mut folders = vec![out.join("track")];
    while let Some(dir) = folders.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for e in entries.flatten() {
            let path = e.path();
            if path.is_dir() {
                folders.push(path);
            } else if path.file_name() == Path::new(&Tracking::main().metrics()).file_name() {
                let text = std::fs::read_to_string(&path).unwrap_or_default();
                let mut lines = text.lines();
                let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
                let Some(col) = header.iter().position(|h| *h == "status") else {
                    return Err(format!("{}: no status column", path.display()));
                };
                for line in lines {
                    let status = line.split(',').nth(col).unwrap_or("");
                    if !matches!(status, "ok" | "saturated") {
                        return Err(format!(
                            "{}: exit 0 with status {status:?}: {line}",
                            path.display()
                        ));
                    }
                }
            }
        }
    }
    Ok(())
}

struct Setup {
    dir: PathBuf,
    prepared: PathBuf,
    cases: Vec<Case>,
}

/// The cases and a run folder with a 2-iteration design and a PEA1 record (once per process).
fn setup() -> &'static Setup {
    static SETUP: OnceLock<Setup> = OnceLock::new();
    SETUP.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("flexstage-edges-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let base = base();
        let text = toml::to_string(&base).unwrap();
        let file = dir.join("base.toml");
        std::fs::write(&file, &text).unwrap();
        let prepared = dir.join("prepared");
        for args in [
            vec!["design", "--max-iterations", "2"],
            vec!["pea", "simulate"],
        ] {
            let st = Command::new(BIN)
                .args(&args)
                .arg(&file)
                .arg("--out")
                .arg(&prepared)
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .status()
                .unwrap();
            assert!(st.success(), "preparing {args:?}");
        }
        let mut cases = field_cases(&base);
        cases.extend(option_cases(&text));
        cases.extend(tracking_cases(&base, &text));
        Setup {
            dir,
            prepared,
            cases,
        }
    })
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), target).unwrap();
        }
    }
}

/// Runs a case; `Err` says what was wrong.
fn run(case: &Case, k: usize) -> Result<(), String> {
    let s = setup();
    let work = s.dir.join(format!("case-{k}"));
    let _ = std::fs::remove_dir_all(&work);
    std::fs::create_dir_all(&work).unwrap();
    let file = work.join("case.toml");
    std::fs::write(&file, &case.scenario).unwrap();
    let out = work.join("run");
    if case.prepared {
        copy_dir(&s.prepared, &out);
    }
    let mut child = Command::new(BIN)
        .args(&case.args)
        .arg(&file)
        .arg("--out")
        .arg(&out)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (mut so, mut se) = (child.stdout.take().unwrap(), child.stderr.take().unwrap());
    let reader = std::thread::spawn(move || {
        let mut t = String::new();
        std::io::Read::read_to_string(&mut so, &mut t).ok();
        t
    });
    let ereader = std::thread::spawn(move || {
        let mut t = String::new();
        std::io::Read::read_to_string(&mut se, &mut t).ok();
        t
    });
    let t0 = Instant::now();
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        let bound = if case.heavy { HEAVY_BOUND } else { BOUND };
        if t0.elapsed() > bound {
            child.kill().ok();
            child.wait().ok();
            return Err(format!("{}: ran past {bound:?}", case.what));
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let (stdout, stderr) = (reader.join().unwrap(), ereader.join().unwrap());
    let flagged = if status.code() == Some(0) && case.args[0] == "track" {
        statuses_agree_with_exit_0(&out)
    } else {
        Ok(())
    };
    let _ = std::fs::remove_dir_all(&work);
    flagged.map_err(|e| format!("{}: {e}", case.what))?;
    let tail = |t: &str| t.lines().rev().take(6).collect::<Vec<_>>().join(" | ");
    match status.code() {
        _ if stderr.contains("panicked") => {
            Err(format!("{}: panicked: {}", case.what, tail(&stderr)))
        }
        None => Err(format!(
            "{}: killed by a signal ({status}): {}",
            case.what,
            tail(&stderr)
        )),
        Some(0) => {
            let bad = stdout
                .split(|c: char| !c.is_alphanumeric())
                .find(|w| matches!(*w, "NaN" | "inf"));
            match bad {
                Some(w) => Err(format!(
                    "{}: exit 0 printing {w}: {}",
                    case.what,
                    tail(&stdout)
                )),
                None => Ok(()),
            }
        }
        Some(1 | 2) => {
            let message = stderr
                .lines()
                .filter(|l| l.starts_with("error"))
                .collect::<Vec<_>>()
                .join(" ");
            if message.is_empty() {
                return Err(format!(
                    "{}: exit {:?} without an error line: {}",
                    case.what,
                    status.code(),
                    tail(&stderr)
                ));
            }
            match unclear(&message) {
                Some(why) => Err(format!("{}: unclear message ({why}): {message}", case.what)),
                None => Ok(()),
            }
        }
        Some(c) => Err(format!("{}: exit {c}: {}", case.what, tail(&stderr))),
    }
}

fn config() -> Config {
    let seed = std::env::var("PROPTEST_RNG_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(32);
    Config {
        cases: CASES,
        failure_persistence: None,
        rng_seed: RngSeed::Fixed(seed),
        ..Config::default()
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn an_edge_value_gives_a_clear_error_or_a_finite_result(i in any::<prop::sample::Index>()) {
        let s = setup();
        let light: Vec<usize> = (0..s.cases.len()).filter(|&k| !s.cases[k].heavy).collect();
        let k = light[i.index(light.len())];
        let t0 = Instant::now();
        let result = run(&s.cases[k], k);
        println!("{:6.1} s  {}", t0.elapsed().as_secs_f64(), s.cases[k].what);
        prop_assert!(result.is_ok(), "{}", result.unwrap_err());
    }
}

/// Every case (about 15 minutes): `cargo test --release -p flexstage --test edges_proptest --
/// --ignored --nocapture`.
#[test]
#[ignore]
fn every_edge_case() {
    let s = setup();
    println!("{} cases", s.cases.len());
    let failures: Vec<String> = s
        .cases
        .iter()
        .enumerate()
        .filter_map(|(k, c)| {
            let t0 = Instant::now();
            let r = run(c, k);
            println!(
                "{:6.1} s  {}{}",
                t0.elapsed().as_secs_f64(),
                c.what,
                if r.is_err() { "  FAILED" } else { "" }
            );
            r.err()
        })
        .collect();
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
