//! Error against scan frequency: every controller of a `track` call on the
//! Lissajous 3:1 whose fast component runs from 1 % to 30 % of the twin's first resonance
//! ([`flexstage_assess::sweep`]), written beside the tracking results as
//! `scan_frequency.csv` and `scan_frequency.svg` (the report's figure), with learning rows
//! (`<controller>+learning`) under `track --learning`. Only on the twin: the sweep's
//! frequencies are fractions of the twin's first resonance.

use flexstage_assess::Bench;
use flexstage_assess::lab::{LabParams, operating_fast_adc};
use flexstage_assess::sweep::{self, MAX_SWEEP_TRIALS, SweepLearning, SweepParams, SweepPoint};
use flexstage_control::learning::SensorDatasheet;
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
/// `None` when the scenario has no trajectory to take amplitudes from. With `learning`
/// (`track --learning`'s trials) every candidate also runs with the learning layer at every
/// point, for those trials but at most [`MAX_SWEEP_TRIALS`] periods, told the scenario's
/// sensor settings as the datasheet lag.
pub fn scan_frequency(
    bench: &Bench,
    scenario: &Scenario,
    candidates: &[&'static Controller],
    learning: Option<usize>,
) -> Result<Option<ScanFrequency>> {
    let Some(amplitude) = start_amplitude(scenario) else {
        return Ok(None);
    };
    let learning = match learning {
        Some(trials) => Some(SweepLearning {
            trials: trials.clamp(1, MAX_SWEEP_TRIALS),
            amplitude: crate::track::LEARNING_AMPLITUDE,
            lag: SensorDatasheet::from_scenario(scenario).lag(bench.setup.rig.sample_time)?,
            fast_adc: LabParams::default()
                .fast_adc
                .map(|ratio| operating_fast_adc(&bench.setup.rig, ratio)),
        }),
        None => None,
    };
    let params = SweepParams {
        learning,
        ..SweepParams::default()
    };
    let points = sweep::sweep(bench, candidates, amplitude, &params)?;
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
