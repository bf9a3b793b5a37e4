//! The margins table: every candidate's loop-at-a-time gain, phase and delay margins on the
//! twin's sampled loop with the rig's delay, flagged against the targets.

use flexstage_control::margins::Margins;
use flexstage_control::registry::{Controller, Designs};

use crate::bench::Bench;
use crate::error::Result;
use crate::inject::{InjectionParams, injected_margins};

/// Targets a shipped controller must meet: 6 dB and 40°.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarginTargets {
    /// Gain margin \[dB\].
    pub gain_db: f64,
    /// Phase margin \[deg\].
    pub phase_deg: f64,
}

impl Default for MarginTargets {
    fn default() -> Self {
        MarginTargets {
            gain_db: 6.0,
            phase_deg: 40.0,
        }
    }
}

/// One row: a candidate's margins (per loop), or `None` when its closed loop is unstable.
#[derive(Debug, Clone, PartialEq)]
pub struct MarginRow {
    /// The controller.
    pub candidate: &'static Controller,
    /// The rig delay \[samples\].
    pub delay: usize,
    /// How the margins were obtained ("transfer function" or "sine injection").
    pub method: &'static str,
    /// Margins of loop q1 and q2; `None`: the closed loop is unstable.
    pub margins: Option<[Margins; 2]>,
    /// Whether both loops meet the targets.
    pub meets: bool,
    /// Monte-Carlo pass rate \[0–1\] when the study was run ([`crate::montecarlo`]).
    pub montecarlo_pass: Option<f64>,
    /// Whether the design is the one that runs under the learning layer
    /// (`Designs::for_learning`, [`learning_margins_table`]).
    pub learning: bool,
}

impl MarginRow {
    /// The margin columns of loop `l` (0 or 1) for a text table, 41 characters: gain margin
    /// \[dB\], phase margin \[deg\], gain crossover \[Hz\] and delay margin \[samples of
    /// `sample_time`\]; "closed loop unstable" when there are no margins.
    pub fn loop_columns(&self, l: usize, sample_time: f64) -> String {
        match &self.margins {
            Some(m) => format!(
                "{:>7.1}  {:>8.1}  {:>8.0}  {:>12.2}",
                m[l].gain_db,
                m[l].phase_deg,
                m[l].gain_crossover,
                m[l].delay / sample_time
            ),
            None => format!("{:>41}", "closed loop unstable"),
        }
    }
}

/// The margins of every candidate in `candidates` with `delay` samples of delay.
pub fn margins_table(
    bench: &Bench,
    candidates: &[&'static Controller],
    delay: usize,
    targets: MarginTargets,
    injection: &InjectionParams,
) -> Result<Vec<MarginRow>> {
    margins_of(bench, &bench.designs, candidates, delay, targets, injection)
}

/// [`margins_table`] of the candidates' designs in `designs` (the bench's, or those that
/// run under the learning layer) on `bench`'s linear loop.
fn margins_of(
    bench: &Bench,
    designs: &Designs,
    candidates: &[&'static Controller],
    delay: usize,
    targets: MarginTargets,
    injection: &InjectionParams,
) -> Result<Vec<MarginRow>> {
    let mut rows = Vec::new();
    let probe = bench.probe();
    for &c in candidates {
        let design = crate::bench::design_of(designs, c)?;
        let (method, m) = if let Some(p) = design.linear() {
            let stable = crate::inject::is_stable(&probe, &**design, delay, 1.0)?;
            let m = bench.analytic_margins_of(p, delay)?;
            ("transfer function", stable.then_some(m))
        } else {
            let mut mp = bench.tuning.margins;
            mp.points = 48;
            mp.refine = 10;
            (
                "sine injection",
                injected_margins(&probe, &**design, delay, &mp, injection)?,
            )
        };
        let meets = m.is_some_and(|m| {
            m.iter()
                .all(|l| l.meets(targets.gain_db, targets.phase_deg))
        });
        rows.push(MarginRow {
            candidate: c,
            delay,
            method,
            margins: m,
            meets,
            montecarlo_pass: None,
            learning: false,
        });
    }
    Ok(rows)
}

/// [`margins_table`] of the designs that run under the learning layer
/// (`Designs::for_learning`: tuned to the widened margin targets of
/// `TuningParams::learning_widening`), each row marked [`MarginRow::learning`]; only the
/// candidates whose design differs there (the others' rows are their own).
pub fn learning_margins_table(
    bench: &Bench,
    candidates: &[&'static Controller],
    delay: usize,
    targets: MarginTargets,
    injection: &InjectionParams,
) -> Result<Vec<MarginRow>> {
    let differ: Vec<&'static Controller> = candidates
        .iter()
        .copied()
        .filter(|c| bench.designs.differs_under_learning(c))
        .collect();
    let learning = bench.designs.under_learning();
    let mut rows = margins_of(bench, &learning, &differ, delay, targets, injection)?;
    for r in &mut rows {
        r.learning = true;
    }
    Ok(rows)
}
