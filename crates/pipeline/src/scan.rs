//! Error against scan frequency (issue #18, item 5): every controller of a `track` call on the
//! Lissajous 3:1 whose fast component runs from 1 % to 30 % of the twin's first resonance
//! ([`flexstage_assess::sweep`]), written beside the tracking results as
//! `scan_frequency.csv` and `scan_frequency.svg` (the report's figure). Only on the twin: the
//! sweep's frequencies are fractions of the twin's first resonance.

use flexstage_assess::sweep::{self, SweepParams, SweepPoint};
use flexstage_assess::{Bench, Candidate};
use flexstage_report::RunDir;
use flexstage_report::layout::Tracking;
use flexstage_scenario::{Scenario, Trajectory};

use crate::error::Result;

/// The amplitudes the sweep starts from: those of the scenario's first trajectory (a
/// circle's radius on both axes); the sweep halves them until the rig can deliver each scan.
pub fn start_amplitude(s: &Scenario) -> Option<[f64; 2]> {
    s.trajectories.first().map(|t| match t {
        Trajectory::Lissajous { amplitude, .. } => *amplitude,
        Trajectory::Circle { radius, .. } => [*radius; 2],
    })
}

/// Runs the sweep for `candidates` and writes its CSV and figure into `out`; returns the
/// points (empty when the scenario has no trajectory to take amplitudes from).
pub fn write_scan_frequency(
    run: &RunDir,
    out: &Tracking,
    bench: &Bench,
    scenario: &Scenario,
    candidates: &[Candidate],
) -> Result<Vec<SweepPoint>> {
    let Some(amplitude) = start_amplitude(scenario) else {
        return Ok(Vec::new());
    };
    let points = sweep::sweep(bench, candidates, amplitude, &SweepParams::default())?;
    run.write(out.scan_frequency_csv(), sweep::csv(&points).as_bytes())?;
    run.write(
        out.scan_frequency_svg(),
        sweep::figure(&points, candidates)?.as_bytes(),
    )?;
    Ok(points)
}
