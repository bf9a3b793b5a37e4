//! # flexstage-assess — the controllers on the twin, as a practitioner would check them
//!
//! Every controller of `flexstage-control` on the digital twin
//! of the designed stage (`flexstage-twin`), checked the way a rig would be:
//!
//! * [`margins`]: gain, phase and delay margins of each loop with the other loop closed, on
//!   the sampled loop with the rig's delay. Linear controllers from their discrete transfer
//!   function and the twin's exact ZOH modal response ([`flexstage_control::tuning`]); the
//!   backstepping controllers by sine injection at the sensor ([`inject`]), which needs no
//!   linear model. Flagged below 6 dB / 40°.
//! * [`bench`](mod@bench): the candidates, including the PID + FF and PI + notch + FF baselines tuned
//!   on the twin's frequency response by one documented procedure with equal search budget
//!   ([`flexstage_control::tuning`]).
//! * [`lab`]: the twin measured as a lab measures its stage (multisine through the full rig
//!   at the controller's rate, the measured response and its z-domain loop model), from which
//!   [`Bench::measured`] designs the controllers.
//! * [`montecarlo`]: pass rate over ≥ 100 perturbed twins (K, M, α ± 20 %, damping 0.5–3 %,
//!   coupling 0–15 %, compensator Bouc–Wen ± 20 %, delay 0–2 samples), in parallel.
//! * [`sweep`]: RMS error of each candidate on the Lissajous 3:1 from 1 % to 30 % of the
//!   first resonance, and its figure.
//!
//! [`Assessment::run`] does all of it and returns the values; the pipeline's `track` stores
//! them in the run folder.

// Loops over the two axes index several arrays at once.
#![allow(clippy::needless_range_loop)]

pub mod bench;
mod error;
pub mod inject;
pub mod lab;
pub mod margins;
pub mod montecarlo;
pub mod sweep;
pub mod track;

pub use bench::Bench;
pub use error::{AssessError, Result};

use flexstage_control::registry::{CONTROLLERS, Controller};
use flexstage_scenario::{Scenario, Trajectory};
use flexstage_sim::trajectory::Reference;

/// Settings of a whole assessment.
#[derive(Debug, Clone, PartialEq)]
pub struct AssessParams {
    /// Which controllers (default: every controller of the registry).
    pub candidates: Vec<&'static Controller>,
    /// Margin targets.
    pub targets: margins::MarginTargets,
    /// Sine injection.
    pub injection: inject::InjectionParams,
    /// Monte-Carlo study.
    pub montecarlo: montecarlo::MonteCarloParams,
    /// Scan-frequency sweep.
    pub sweep: sweep::SweepParams,
    /// Duration of the nominal tracking run \[s\] (`None`: the scenario's).
    pub duration: Option<f64>,
}

impl Default for AssessParams {
    fn default() -> Self {
        AssessParams {
            candidates: CONTROLLERS.to_vec(),
            targets: Default::default(),
            injection: Default::default(),
            montecarlo: Default::default(),
            sweep: Default::default(),
            duration: None,
        }
    }
}

/// The result of an assessment.
#[derive(Debug, Clone, PartialEq)]
pub struct Assessment {
    /// The margins table (rig delay).
    pub margins: Vec<margins::MarginRow>,
    /// Nominal tracking of the scenario's first trajectory: RMS per axis \[m\] per candidate.
    pub tracking: Vec<(&'static Controller, [f64; 2])>,
    /// Standstill noise per candidate \[m\].
    pub standstill: Vec<(&'static Controller, [f64; 2])>,
    /// The Monte-Carlo study.
    pub montecarlo: montecarlo::MonteCarlo,
    /// The sweep.
    pub sweep: Vec<sweep::SweepPoint>,
    sample_time: f64,
}

impl Assessment {
    /// Runs margins, nominal tracking, standstill noise, Monte-Carlo and the sweep.
    pub fn run(bench: &Bench, scenario: &Scenario, p: &AssessParams) -> Result<Assessment> {
        let cands = &p.candidates;
        let delay = bench.setup.rig.delay;
        let margins = margins::margins_table(bench, cands, delay, p.targets, &p.injection)?;
        let first = scenario.trajectories.first().ok_or_else(|| {
            flexstage_numerics::RangeError::new("trajectories", "none", "at least one")
        })?;
        let (reference, duration) = Reference::from_scenario(first);
        let duration = p.duration.unwrap_or(duration);
        let mut tracking = Vec::new();
        let mut standstill = Vec::new();
        for &c in cands {
            let m = track::track_on(
                bench,
                &bench.setup,
                &bench.twin,
                &bench.setup.rig,
                c,
                reference,
                duration,
            )?;
            tracking.push((
                c,
                if track::diverged(&m) {
                    [f64::INFINITY; 2]
                } else {
                    m.rms
                },
            ));
            standstill.push((c, track::standstill(bench, c, 0.2)?));
        }
        let mc = montecarlo::monte_carlo(bench, cands, reference, &p.montecarlo)?;
        let amplitude = match first {
            Trajectory::Lissajous { amplitude, .. } => *amplitude,
            Trajectory::Circle { radius, .. } => [*radius; 2],
        };
        let sw = sweep::sweep(bench, cands, amplitude, &p.sweep)?;
        Ok(Assessment {
            margins,
            tracking,
            standstill,
            montecarlo: mc,
            sweep: sw,
            sample_time: bench.setup.rig.sample_time,
        })
    }

    /// A text summary: margins, nominal RMS, standstill noise, pass rates.
    pub fn summary(&self) -> String {
        let mut s = String::from(
            "controller      loop  GM [dB]  PM [deg]  f_c [Hz]  DM [samples]  targets | RMS q1/q2 [nm] | standstill [nm] | MC pass\n",
        );
        for (j, r) in self.margins.iter().enumerate() {
            for l in 0..2 {
                let m = r.loop_columns(l, self.sample_time);
                let extra = if l == 0 {
                    let t = self.tracking.get(j).map_or([f64::NAN; 2], |x| x.1);
                    let n = self.standstill.get(j).map_or([f64::NAN; 2], |x| x.1);
                    format!(
                        " | {:>6.1}/{:<6.1} | {:>5.1}/{:<5.1} | {:>5.0} %",
                        t[0] * 1e9,
                        t[1] * 1e9,
                        n[0] * 1e9,
                        n[1] * 1e9,
                        100.0 * self.montecarlo.pass_rate(j)
                    )
                } else {
                    String::new()
                };
                s.push_str(&format!(
                    "{:<15} q{}   {}  {:<7}{}\n",
                    r.candidate.name,
                    l + 1,
                    m,
                    if r.meets { "met" } else { "FLAGGED" },
                    extra
                ));
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Goal: the assessment covers every controller of the registry by default, in its
    /// order, so a controller added to the registry is assessed without a change here.
    #[test]
    fn the_assessment_covers_the_registry() {
        assert_eq!(AssessParams::default().candidates, CONTROLLERS.to_vec());
    }
}
