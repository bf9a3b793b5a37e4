//! One tracking run of a candidate on the twin in the full rig, and its metrics.

use flexstage_control::actuator::Compensation;
use flexstage_control::experiment::Setup;
use flexstage_sim::experiment::{Metrics, run};
use flexstage_sim::rig::RigParams;
use flexstage_sim::trajectory::{Reference, Shape};
use flexstage_twin::Twin;

use flexstage_control::registry::Controller;

use crate::bench::Bench;
use crate::error::Result;

/// Runs `c` (built with `setup`) on `twin` in `rig` for `duration` seconds; returns the
/// metrics (errors against the true output).
pub fn track_on(
    bench: &Bench,
    setup: &Setup,
    twin: &Twin,
    rig: &RigParams,
    c: &Controller,
    reference: Reference,
    duration: f64,
) -> Result<Metrics> {
    let mut ctrl = bench.controller_with(setup, c, Compensation::Inverse, reference)?;
    let mut plant = twin.plant(rig)?;
    let rec = run(ctrl.as_mut(), &mut plant, duration, rig.sample_time, |_| {});
    Ok(rec.metrics(reference.half_range(duration, rig.sample_time)))
}

/// Whether a run diverged: a non-finite error or one above 1 µm.
pub fn diverged(m: &Metrics) -> bool {
    !(m.rms[0].is_finite() && m.rms[1].is_finite()) || m.max[0] > 1e-6 || m.max[1] > 1e-6
}

/// The standstill noise of a candidate: RMS of the true output over the second half of
/// `duration` with a zero reference in the full rig (sensor noise fed back) \[m\].
pub fn standstill(bench: &Bench, c: &Controller, duration: f64) -> Result<[f64; 2]> {
    let r = Reference::new(Shape::Step { target: [0.0; 2] });
    let m = track_on(
        bench,
        &bench.setup,
        &bench.twin,
        &bench.setup.rig,
        c,
        r,
        duration,
    )?;
    Ok(m.steady_rms)
}
