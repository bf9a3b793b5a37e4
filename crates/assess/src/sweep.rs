//! Error against scan frequency: every candidate on the Lissajous 3:1 whose fast component
//! (q1, 3 f) runs from 1 % to 30 % of the twin's first resonance, on the twin in the full
//! rig. Amplitudes start at the scenario's first Lissajous and are halved until the rig can
//! deliver the scan (amplifier range, current, stroke: `Setup::check_reference`); the RMS is
//! taken over the second half of the run (after the smooth start), also in % of the range.

use flexstage_figures::plot::{Figure, Series};
use flexstage_sim::trajectory::{Reference, Shape};

use flexstage_control::registry::Controller;

use crate::bench::Bench;
use crate::error::{Result, check};
use crate::track::{diverged, track_on};

/// Settings of the sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepParams {
    /// Fractions of the first resonance for the fast component (each in (0, 0.45)).
    pub fractions: Vec<f64>,
    /// Base periods simulated per point, ≥ 1 (the run is at least 50 ms).
    pub periods: f64,
}

impl Default for SweepParams {
    fn default() -> Self {
        SweepParams {
            fractions: vec![0.01, 0.02, 0.03, 0.05, 0.08, 0.12, 0.2, 0.3],
            periods: 2.0,
        }
    }
}

/// One point of the sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepPoint {
    /// Fraction of the first resonance.
    pub fraction: f64,
    /// Frequency of the fast component \[Hz\].
    pub frequency: f64,
    /// Amplitudes used (A1, A2) \[m\].
    pub amplitude: [f64; 2],
    /// Per candidate: steady RMS error per axis \[m\] (∞: diverged), and in % of the range.
    pub results: Vec<(&'static Controller, [f64; 2], [f64; 2])>,
}

/// Runs the sweep for `candidates`, starting from the Lissajous amplitudes `amplitude`.
pub fn sweep(
    bench: &Bench,
    candidates: &[&'static Controller],
    amplitude: [f64; 2],
    p: &SweepParams,
) -> Result<Vec<SweepPoint>> {
    check("sweep.periods", p.periods, p.periods >= 1.0, "≥ 1")?;
    let f1 = bench.twin.first_resonance();
    let t = bench.setup.rig.sample_time;
    let mut out = Vec::new();
    for &frac in &p.fractions {
        check("sweep.fractions", frac, frac > 0.0 && frac < 0.45, "0–0.45")?;
        let fast = frac * f1;
        let base = fast / 3.0;
        let duration = (p.periods / base).max(0.05);
        let mut amp = amplitude;
        let mut reference = None;
        for _ in 0..12 {
            let r = Reference::new(Shape::Lissajous {
                ratio: 3.0,
                amplitude: amp,
                frequency: base,
            });
            if bench
                .setup
                .check_reference(&r, duration, Some(bench.twin.dc_gain()))
                .is_ok()
            {
                reference = Some(r);
                break;
            }
            amp = amp.map(|a| 0.5 * a);
        }
        let Some(r) = reference else { continue };
        let half = r.half_range(duration, t);
        let mut results = Vec::new();
        for &c in candidates {
            let m = track_on(
                bench,
                &bench.setup,
                &bench.twin,
                &bench.setup.rig,
                c,
                r,
                duration,
            )?;
            let rms = if diverged(&m) {
                [f64::INFINITY; 2]
            } else {
                m.steady_rms
            };
            let pct = [0, 1].map(|i| 100.0 * rms[i] / (2.0 * half[i]));
            results.push((c, rms, pct));
        }
        out.push(SweepPoint {
            fraction: frac,
            frequency: fast,
            amplitude: amp,
            results,
        });
    }
    Ok(out)
}

/// The figure: RMS error (mean of both axes, % of range, log10) against the fast
/// component's frequency in % of the first resonance, one line per candidate.
pub fn figure(points: &[SweepPoint], candidates: &[&Controller]) -> Result<String> {
    let mut fig = Figure::new(
        "Lissajous 3:1 on the twin: error against scan frequency",
        "fast component [% of first resonance]",
        "log10 RMS error [% of range], mean of q1, q2",
    );
    for (j, c) in candidates.iter().enumerate() {
        let pts = points
            .iter()
            .filter_map(|p| {
                let pct = p.results.get(j)?.2;
                let v = 0.5 * (pct[0] + pct[1]);
                v.is_finite().then(|| (100.0 * p.fraction, v.log10()))
            })
            .collect();
        fig = fig.with(Series::line(c.name, pts));
    }
    Ok(fig.to_svg()?)
}
