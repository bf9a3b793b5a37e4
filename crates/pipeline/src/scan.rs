//! Error against scan frequency: every controller of a `track` call on the
//! Lissajous 3:1 whose fast component runs from 1 % to 30 % of the twin's first resonance
//! ([`flexstage_assess::sweep`]), written beside the tracking results as
//! `scan_frequency.csv` and `scan_frequency.svg` (the report's figure). Only on the twin: the
//! sweep's frequencies are fractions of the twin's first resonance.

use flexstage_assess::Bench;
use flexstage_assess::sweep::{self, SweepParams, SweepPoint};
use flexstage_control::registry::Controller;
use flexstage_run::RunDir;
use flexstage_run::format::Rows;
use flexstage_run::layout::Tracking;
use flexstage_scenario::{Scenario, Trajectory};

use crate::error::Result;

/// The sweep of one `track` call: its points and the controllers they hold, in order.
#[derive(Debug, Clone)]
pub struct ScanFrequency {
    /// The points, each with one result per candidate.
    pub points: Vec<SweepPoint>,
    /// The candidates.
    pub candidates: Vec<&'static Controller>,
}

/// The amplitudes the sweep starts from: those of the scenario's first trajectory (a
/// circle's radius on both axes); the sweep halves them until the rig can deliver each scan.
pub fn start_amplitude(s: &Scenario) -> Option<[f64; 2]> {
    s.trajectories.first().map(|t| match t {
        Trajectory::Lissajous { amplitude, .. } => *amplitude,
        Trajectory::Circle { radius, .. } => [*radius; 2],
    })
}

/// Runs the default sweep ([`SweepParams::default`]) for `candidates` on the bench's twin;
/// `None` when the scenario has no trajectory to take amplitudes from.
pub fn scan_frequency(
    bench: &Bench,
    scenario: &Scenario,
    candidates: &[&'static Controller],
) -> Result<Option<ScanFrequency>> {
    let Some(amplitude) = start_amplitude(scenario) else {
        return Ok(None);
    };
    let points = sweep::sweep(bench, candidates, amplitude, &SweepParams::default())?;
    Ok(Some(ScanFrequency {
        points,
        candidates: candidates.to_vec(),
    }))
}

impl ScanFrequency {
    /// Writes `scan_frequency.csv` and `scan_frequency.svg` into `out`.
    pub fn write(&self, run: &RunDir, out: &Tracking) -> Result<()> {
        let rows = crate::convert::scan_rows(&self.points);
        run.store(&out.scan_frequency_csv(), Rows(rows))?;
        run.write(
            &out.scan_frequency_svg(),
            sweep::figure(&self.points, &self.candidates)?.as_bytes(),
        )?;
        Ok(())
    }
}
