//! # flexstage-twin — the digital twin of the designed stage
//!
//! (Crate documentation: see the module docs; the full overview is written below.)

// Loops over the two axes and the two inputs index several arrays at once, as the equations do.
#![allow(clippy::needless_range_loop)]

pub mod craig_bampton;
mod error;
pub mod modal;
pub mod nonlinear;
pub mod reference;
pub mod report;
pub mod samples;
pub mod stage;
pub mod structure;
pub mod twin;

pub use error::{Result, TwinError};
pub use reference::{Agreement, ModeCheck, ReferenceParams, ValidationParams, Validity, validate};
pub use stage::TwinStage;
pub use structure::StageFe;
pub use twin::{Twin, TwinParams, plant};
