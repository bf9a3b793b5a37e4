//! Reference: the second hardening review, "Abort": `optimization.samples = 4000` passed `check` with a design
//! memory estimate of 1.4 GiB and aborted in an allocation under a 4 GB and a 9.5 GB cap
//! (every FE workspace keeps about 60 vectors a load case, and six sets of workspaces are
//! alive at the peak). Goal: the estimate `flexstage check` prints bounds what `flexstage
//! design` allocates (`VmPeak`, polled from /proc while it runs), and its growth with the
//! samples matches the measured growth within 20 % (the slope cancels the process's own
//! threads and arenas, which depend on the machine).

#![cfg(target_os = "linux")]

use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::Duration;

const BIN: &str = env!("CARGO_BIN_EXE_flexstage");

/// The quick preset on a 24 × 12 mesh with `samples` stroke samples (robust, 3 realizations).
fn scenario(dir: &std::path::Path, samples: usize) -> PathBuf {
    let mut s = flexstage_scenario::Scenario::preset(flexstage_scenario::Preset::Quick);
    s.name = format!("memory-{samples}");
    s.mesh.nl = 24;
    s.mesh.nw = 12;
    s.optimization.samples = samples;
    s.regions.truncate(3);
    let path = dir.join(format!("{}.toml", s.name));
    std::fs::write(&path, s.to_toml()).unwrap();
    path
}

/// The estimate `check` prints [GiB].
fn estimate(path: &std::path::Path) -> f64 {
    let out = Command::new(BIN).arg("check").arg(path).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text
        .lines()
        .find(|l| l.contains("design estimate:"))
        .unwrap_or_else(|| panic!("no estimate in: {text}"));
    line.split("estimate: ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap()
}

/// The largest `VmPeak` [GiB] of `flexstage design` (2 iterations and the final analysis).
fn vm_peak(path: &std::path::Path, out: &std::path::Path) -> f64 {
    let mut child = Command::new(BIN)
        .args(["design", "--max-iterations", "2", "--out"])
        .arg(out)
        .arg(path)
        .env("RAYON_NUM_THREADS", "2")
        // One malloc arena: a thread's own arena reserves 64 MiB of address space or not,
        // depending on which thread allocates first, and made VmPeak jump by ≈ 0.1 GiB
        // between identical runs.
        .env("MALLOC_ARENA_MAX", "1")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let status = format!("/proc/{}/status", child.id());
    let mut peak_kb = 0.0f64;
    loop {
        if let Ok(text) = std::fs::read_to_string(&status) {
            if let Some(v) = text
                .lines()
                .find(|l| l.starts_with("VmPeak:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|v| v.parse::<f64>().ok())
            {
                peak_kb = peak_kb.max(v);
            }
        }
        if let Some(st) = child.try_wait().unwrap() {
            assert!(st.success(), "design failed: {st}");
            break;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    peak_kb / (1024.0 * 1024.0)
}

#[test]
fn the_design_memory_estimate_bounds_and_follows_the_allocated_peak() {
    let dir = std::env::temp_dir().join(format!("flexstage-memory-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (small, large) = (scenario(&dir, 8), scenario(&dir, 200));
    let (e_small, e_large) = (estimate(&small), estimate(&large));
    let (m_small, m_large) = (
        vm_peak(&small, &dir.join("run-small")),
        vm_peak(&large, &dir.join("run-large")),
    );
    println!("estimate {e_small:.3} / {e_large:.3} GiB, VmPeak {m_small:.3} / {m_large:.3} GiB");
    let _ = std::fs::remove_dir_all(&dir);
    let ratio = (m_large - m_small) / (e_large - e_small);
    assert!(
        (0.8..=1.2).contains(&ratio),
        "the measured growth with the samples is {ratio:.2} × the estimated one"
    );
    assert!(
        m_large <= e_large,
        "VmPeak {m_large:.3} GiB above the estimate {e_large:.3} GiB"
    );
}
