//! Shared by the tests that do whole `run`s: a tiny scenario and short stage options, so that
//! one `run` costs a few seconds of CPU (CI must fit in 20 minutes).
//!
//! The scenario is the quick preset on a 24 × 12 mesh (the quick preset's ports, supports and
//! passive regions, each still at least one element) with 8 stroke samples; the options keep
//! every stage but make each short, and switch off the twin's check against the full
//! nonlinear transient (`TwinValidation::Off`), which alone took most of a quick `run`. What
//! the run tests check (resume, refusal, locks, checksums, bitwise results) does not depend on
//! the mesh size or the transient check.

#![allow(dead_code)]

use flexstage_pipeline::folder::preset;
use flexstage_pipeline::twin::TwinValidation;
use flexstage_pipeline::{
    ReduceOptions, RunOptions, Scenario, Simulation, StageData, StageIdOptions, TrackOptions,
};

/// The quick preset on a 24 × 12 mesh with 8 stroke samples.
pub fn tiny() -> Scenario {
    let mut s = preset("quick").unwrap();
    s.mesh.nl = 24;
    s.mesh.nw = 12;
    s.optimization.samples = 8;
    s
}

/// Every stage, made short: `iterations` design iterations with a checkpoint every
/// `checkpoint_every`, no modes, a one-scale validity map (or none), no full-transient twin
/// check, 2 PEA cycles, 0.2 s of identification, 0.05 s of tracking, one Monte-Carlo plant
/// (the study's plumbing and files are the same with one plant as with a hundred).
pub fn short(iterations: usize, checkpoint_every: usize, validity: bool) -> RunOptions {
    let mut o = RunOptions::default();
    o.design.max_iterations = Some(iterations);
    o.design.checkpoint_every = checkpoint_every;
    o.reduce = ReduceOptions {
        modes: 0,
        scales: if validity { vec![1.0] } else { Vec::new() },
        ..ReduceOptions::default()
    };
    o.twin.validation = TwinValidation::Off;
    o.pea.cycles = 2;
    o.identify_stage = StageIdOptions {
        data: StageData::Simulate(Simulation {
            duration: Some(0.2),
            ..Simulation::default()
        }),
        ..StageIdOptions::default()
    };
    o.track = TrackOptions {
        duration: Some(0.05),
        montecarlo_plants: 1,
        ..TrackOptions::default()
    };
    o
}
