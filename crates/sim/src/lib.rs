//! # flexstage-sim — the simulated world the controllers run in
//!
//! Everything between a controller's command and its next measurement, as a rig would have
//! it, and the experiment that runs a controller on it (Section 4 of Actuators 2022, 11(7),
//! 179, with the rig of DECISIONS.md). It knows nothing of how a controller is designed: the
//! controllers are `flexstage-control`'s, and they meet the simulation only through
//! [`experiment::StageControl`] (measurement in, [`experiment::Command`] out).
//!
//! * [`rig`]: the loop around a simulated stage in composable parts (delay, amplifier
//!   bandwidth / slew / current limit, the plant's own Bouc–Wen PEAs with creep, floor
//!   vibration, sensor chain with optional anti-aliasing filter, white + 1/f noise,
//!   quantization); the [`rig::Mechanics`] trait for what sits inside and the
//!   [`rig::StagePlant`] trait the experiment runner drives;
//! * [`model`]: the lumped 8-state model of Eq. (31)–(36) with B and D of (A13–A14), from a
//!   [`flexstage_scenario::StageParams`]: the lumped plant's mechanics here, and the model
//!   every later stage reasons with (identification, the controllers' model);
//! * [`plant`]: the lumped mechanics with the cross terms of Eq. (30)
//!   ([`plant::LumpedStage`]), in the scenario's rig ([`plant::PlantParams::in_rig`]) or in
//!   its minimal loop ([`plant::Plant`]); the finite-element twin of the designed stage is
//!   `flexstage-twin`;
//! * [`modal`]: the exact sampled response of a stage known by its modes, with the rig's
//!   delay and sensor chain ([`modal::ModalPlant`]), and [`modal::LoopPlant`], what a design
//!   may know of a sampled response;
//! * [`pea`]: the PEAs as the rig drives them: preload, deliverable stroke, mean slope;
//! * [`trajectory`]: Lissajous curves of any ratio, circle, steps and ramps with a smooth
//!   start, and the designed workspace;
//! * [`experiment`]: one run of a controller on a plant ([`experiment::run`]), its time
//!   series ([`experiment::Record`]) and metrics ([`experiment::Metrics`]);
//! * [`linalg`]: `expm`, `c2d`, `lyap`, `dlyap`, `poles` in python-control style;
//! * [`samples`]: problems with known answers.
//!
//! # Units
//! SI throughout (m, s, N, kg, V), except the Bouc–Wen parameters, which stay in the µm/V/s
//! units of Table A1 as in flexstage-piezo.

// Loops over the two axes index several arrays at once, as the equations do.
#![allow(clippy::needless_range_loop)]

mod error;
pub mod experiment;
pub mod linalg;
pub mod modal;
pub mod model;
pub mod pea;
pub mod plant;
pub mod rig;
pub mod samples;
pub mod trajectory;

pub use error::{Result, SimError};
