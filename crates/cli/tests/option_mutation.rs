//! Reference: the input-bounds and fault-handling requirements, "Every rejected input names the field or option, the value and the
//! accepted range" and "zero panics, zero hangs … under a broad mutation of … CLI options".
//! Goal: every numeric option of every subcommand, given each hostile class of value — 0,
//! negative, NaN, ±inf, huge (1e308, 4e9), tiny (1e-308) and a non-number — is refused before
//! any work: exit code 1 (our validation) or 2 (clap's parser), never 0 and never a panic
//! (101) or a signal, within a few seconds, with a message that names the option (as
//! `--option` or as its field, e.g. `design.checkpoint_every`) and, for our validation, the
//! accepted range ("expected …" / "accepted range …"). Clap's own parse errors (a non-number,
//! a negative integer) name the option and the expected type, not a range.
//!
//! The mutation is exhaustive over (option × class) rather than sampled: ~230 cheap
//! invocations. Values an option accepts are listed per option and left out, because a valid
//! value would start real work; they are in range by definition.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_flexstage");

/// The hostile classes of value.
const CLASSES: [&str; 9] = [
    "0",
    "-1",
    "NaN",
    "inf",
    "-inf",
    "1e308",
    "1e-308",
    "abc",
    "4000000000",
];

/// Longest time a refusal may take (it must come before any work).
const REFUSED_WITHIN: Duration = Duration::from_secs(10);

/// (subcommand words, option, names that count as naming it, accepted classes left out).
/// Pair options (`X1,X2`) get the value as their first element.
type OptionRow = (
    &'static [&'static str],
    &'static str,
    &'static [&'static str],
    &'static [&'static str],
);

const OPTIONS: &[OptionRow] = &[
    (
        &["design"],
        "--checkpoint-every",
        &["checkpoint_every"],
        &[],
    ),
    (&["design"], "--snapshot-every", &["snapshot_every"], &[]),
    (&["design"], "--max-iterations", &["max_iterations"], &[]),
    (
        &["analyze"],
        "--inputs",
        &["analyze.inputs"],
        &["0", "-1", "1e-308"],
    ),
    (
        &["reduce"],
        "--operating-point",
        &["operating_point"],
        &["0", "-1", "1e-308"],
    ),
    (&["reduce"], "--modes", &["reduce.modes"], &["0"]),
    (&["reduce"], "--scales", &["scales"], &["1e-308"]),
    (&["identify", "pea"], "--pea", &["identify_pea.pea"], &[]),
    (
        &["identify", "pea"],
        "--forgetting",
        &["identify_pea.forgetting"],
        &[],
    ),
    (
        &["identify", "pea"],
        "--passes",
        &["identify_pea.passes"],
        &[],
    ),
    (
        &["identify", "stage"],
        "--duration",
        &["identify_stage.duration"],
        &[],
    ),
    (&["identify", "stage"], "--f-max", &["f_max"], &[]),
    (
        &["identify", "stage"],
        "--forgetting",
        &["identify.forgetting"],
        &[],
    ),
    (
        &["identify", "stage"],
        "--prefilter",
        &["identify.prefilter"],
        &["0"],
    ),
    (
        &["identify", "stage"],
        "--decimation",
        &["identify.decimation"],
        &[],
    ),
    (&["pea", "simulate"], "--pea", &["pea.pea"], &[]),
    (&["pea", "simulate"], "--frequency", &["pea.frequency"], &[]),
    (&["pea", "simulate"], "--cycles", &["pea.cycles"], &[]),
    (
        &["pea", "simulate"],
        "--noise-nm",
        &["pea.noise_nm"],
        &["0", "1e-308"],
    ),
    (&["pea", "simulate"], "--dt", &["pea.dt"], &[]),
    (&["pea", "simulate"], "--seed", &[], &["0", "4000000000"]),
    (&["track"], "--duration", &["track.duration"], &[]),
    (
        &["track"],
        "--montecarlo-plants",
        &["track.montecarlo_plants"],
        &[],
    ),
    (
        &["run"],
        "--montecarlo-plants",
        &["track.montecarlo_plants"],
        &[],
    ),
    (
        &["track", "--learning"],
        "--trials",
        &["track.learning"],
        &[],
    ),
    (&["export"], "--level", &["export.level"], &["1e-308"]),
    (&["export"], "--smoothing", &["export.smoothing"], &["0"]),
    (
        &["export"],
        "--max-chord-mm",
        &["export.max_chord"],
        &["0", "1e-308"],
    ),
    (
        &["export"],
        "--fatigue-strength-mpa",
        &["fatigue_strength"],
        &["1e-308"],
    ),
    (&["export"], "--safety-factor", &["safety_factor"], &[]),
    (
        &["export"],
        "--min-ligament-mm",
        &["min_ligament"],
        &["0", "1e-308"],
    ),
    (&["export"], "--min-gap-mm", &["min_gap"], &["0", "1e-308"]),
    (&["export"], "--start-hole-mm", &["start_hole"], &["1e-308"]),
];

fn scratch() -> PathBuf {
    let d = std::env::temp_dir().join(format!("flexstage-options-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs one mutated command; Err describes what was wrong.
fn refused(
    words: &[&str],
    option: &str,
    names: &[&str],
    value: &str,
    out: &Path,
) -> Result<(), String> {
    let value = match option {
        "--inputs" | "--operating-point" => format!("{value},0"),
        _ => value.to_string(),
    };
    let what = format!("{} {option}={value}", words.join(" "));
    let mut child = Command::new(BIN)
        .args(words)
        .arg(format!("{option}={value}"))
        .arg("--out")
        .arg(out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t0.elapsed() > REFUSED_WITHIN {
            child.kill().unwrap();
            child.wait().unwrap();
            return Err(format!(
                "{what}: not refused within {REFUSED_WITHIN:?} (work started)"
            ));
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut stderr).unwrap();
    let code = status.code();
    let names_it =
        stderr.contains(&format!("'{option}")) || names.iter().any(|n| stderr.contains(n));
    let ranged = stderr.contains("expected") || stderr.contains("accepted range");
    match code {
        _ if stderr.contains("panicked") => Err(format!("{what}: panicked: {stderr}")),
        Some(1) if names_it && ranged => Ok(()),
        Some(2) if names_it && stderr.contains("invalid value") => Ok(()),
        _ => Err(format!("{what}: exit {code:?}, message {stderr:?}")),
    }
}

#[test]
fn every_numeric_option_refuses_every_hostile_class_before_work() {
    let root = scratch();
    let mut cases = Vec::new();
    for (words, option, names, accepted) in OPTIONS {
        for value in CLASSES.iter().filter(|v| !accepted.contains(v)) {
            cases.push((*words, *option, *names, *value));
        }
    }
    assert!(cases.len() > 200, "{} cases", cases.len());
    // Two workers: the invocations are independent processes.
    type Case<'a> = (&'a [&'a str], &'a str, &'a [&'a str], &'a str);
    let run = |part: &[Case], offset: usize| -> Vec<String> {
        part.iter()
            .enumerate()
            .filter_map(|(i, (w, o, n, v))| {
                refused(w, o, n, v, &root.join(format!("r{}", i + offset))).err()
            })
            .collect()
    };
    let half = cases.len() / 2;
    let (a, b) = cases.split_at(half);
    let failures: Vec<String> = std::thread::scope(|s| {
        let h = s.spawn(|| run(a, 0));
        let mut f = run(b, half);
        f.extend(h.join().unwrap());
        f
    });
    let _ = std::fs::remove_dir_all(&root);
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
