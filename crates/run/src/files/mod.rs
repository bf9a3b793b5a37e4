//! One type per structured file of a run folder, each with its [`Format`](crate::Format).
//!
//! Result documents (JSON, TOML) carry a `version` that a reader checks; CSV files are typed
//! by their header ([`crate::format::Row::HEADER`]), and a changed layout gets another header.
//! Input formats a user also writes by hand — the scenario ([`scenario`]), stage parameter
//! files ([`stage::StageParamsFile`]), PEA and stage records — carry no version: they are
//! versioned by their schema (unknown keys are refused).

pub mod analyze;
pub mod controller;
pub mod design;
pub mod export;
pub mod front;
pub mod lifted;
pub mod measured;
pub mod pea;
pub mod reduce;
pub mod scenario;
pub mod stage;
pub mod track;
pub mod twin;
