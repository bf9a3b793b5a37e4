//! The resume state of `run` (`run_state.json`), kept by `flexstage-run`
//! ([`flexstage_run::state`]): which stages finished, with which scenario and options, and the
//! files each wrote with their SHA-256.

pub use flexstage_run::state::*;

pub(crate) use flexstage_run::hash::fnv1a;
