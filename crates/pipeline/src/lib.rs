//! # flexstage-pipeline
//!
//! The stages of the scheme of *Integrated Development of a Topology-Optimized Compliant
//! Mechanism for Precise Positioning* (Actuators 2022, 11(7), 179) chained on one run folder:
//!
//! ```text
//! design ─► export ─► reduce ─► twin ─► pea (simulate + identify, ─► identify stage ─► track ─► report
//! (Alg. 1)  (§4.1)    (§3.2.1)   (twin)     both PEAs; App. B, Eq. 21)   (Eq. 54–56)       (§4)
//! ```
//!
//! * **One scenario per run, in memory.** [`RunFolder`] opens `runs/<scenario name>/` (or a
//!   folder the caller picks), records the scenario, and hands it to every stage; no stage
//!   re-reads the recorded copy. A folder of another scenario is refused, naming the changed
//!   fields ([`diff`]), unless replaced.
//! * **One process per folder.** An open [`RunFolder`] holds the folder's lock (`run.lock`,
//!   [`lock`]); a second process is refused with the holder's PID, host, start and command;
//!   the lock of a killed process is taken over, and the temporary files of its interrupted
//!   writes are removed.
//! * **Nothing damaged is used.** Design checkpoints carry the scenario's hash and a CRC-32
//!   ([`envelope`]); `run_state.json` records the scenario and option hashes of every finished
//!   stage ([`RunState`]). A damaged file or one of another scenario is refused with a
//!   message, never resumed.
//! * **One set of defaults.** Each stage takes a typed options struct ([`DesignOptions`],
//!   [`AnalyzeOptions`], [`ExportOptions`], [`ReduceOptions`], [`PeaOptions`],
//!   [`PeaIdOptions`], [`StageIdOptions`], [`TrackOptions`], [`RunOptions`]) whose `Default`
//!   is the only place its defaults live, and whose `validate()` names the option, the value
//!   and the accepted range. The CLI takes its defaults from these. The default scenario of
//!   every command is [`DEFAULT_PRESET`].
//! * **One typed run folder.** Every file of a run folder is named in
//!   [`flexstage_run::layout`] and has its type in [`flexstage_run::files`]; the stages store
//!   their results through it (the private `convert` module turns the stage crates' values into the file
//!   types), and a value a stage holds is passed on in memory (the folder's session keeps
//!   what was stored or loaded, so no file is parsed twice in one process).
//! * **Nothing overwritten silently.** `design` refuses to replace a finished or interrupted
//!   design unless forced; analyses and tracking conditions get their own folders
//!   (`analyze/inputs_30_-30/`, `track/compensation-off/`); every other stage reports in its
//!   summary whether it replaced earlier results.
//! * **No printing.** Progress goes to a [`Progress`] (the CLI draws bars), results come back
//!   as typed summaries.
//! * **Resumable, bitwise.** [`run::run`] records finished stages in `run_state.json`
//!   ([`RunState`]), each with the files it wrote and their SHA-256, and resumes after them
//!   once their files are checked (a stage whose files are gone or changed is done again); an
//!   interrupted design continues from its checkpoint to the same bits as an uninterrupted
//!   one (floats in checkpoint headers round-trip exactly: serde_json's `float_roundtrip`).
//!
//! The simulated experiments run on the *designed* stage: the stage identification on its
//! lumped model once the run has a reduced model ([`Plant`]), tracking on the digital twin of
//! the design in the scenario's rig ([`twin`], [`track`](mod@track); [`PlantKind::Lumped`] for the
//! lumped model, also the fallback before a design exists).

pub mod analyze;
pub mod controllers;
mod convert;
pub mod design;
pub mod diff;
pub mod envelope;
pub mod error;
pub mod export;
mod figures;
pub mod folder;
pub mod front;
pub mod lock;
pub mod montecarlo;
pub mod names;
pub mod pea;
mod pea_files;
pub mod plant;
pub mod progress;
pub mod reduce;
mod reduce_files;
pub mod run;
pub mod scan;
pub mod source;
pub mod stage_id;
pub mod state;
pub mod summary;
pub mod track;
mod track_files;
pub mod twin;

pub use analyze::{AnalyzeOptions, AnalyzeSummary, analyze};
pub use controllers::{ExportedController, Measurement, export_controller, export_measured};
pub use design::{
    DesignOptions, DesignStart, DesignSummary, GradientReport, design, gradient_check,
};
pub use error::{PipelineError, Result};
pub use export::{ExportOptions, ExportSummary, LimitOverrides, export};
pub use folder::{DEFAULT_PRESET, PRESETS, RunFolder, default_root, default_run, load_scenario};
pub use front::{FrontDesign, FrontOptions, FrontSummary, front};
pub use lock::{LockHolder, RunLock};
pub use montecarlo::MonteCarloStudy;
pub use pea::{
    PeaIdOptions, PeaIdSummary, PeaOptions, PeaRecord, identify_pea, simulate_pea, write_pea_csv,
    write_pea_record,
};
pub use plant::{Plant, PlantSource};
pub use progress::{Progress, RunEvent, Silent, StartOver};
pub use reduce::{ReduceOptions, ReduceSummary, reduce};
pub use run::{RunOptions, RunSummary, Stage, StageSummary, run_in, write_report};
pub use source::DesignSource;
pub use stage_id::{Simulation, StageData, StageIdOptions, StageIdSummary, identify_stage};
pub use state::RunState;
pub use track::{ModelSource, PlantKind, TrackOptions, TrackSummary, track};
pub use twin::{TwinOptions, TwinSummary, TwinValidation, write_twin};

/// The stage crates' types that appear in options and summaries.
pub use flexstage_control::{
    actuator::Compensation,
    registry::{CONTROLLERS, Controller},
};
pub use flexstage_piezo::WaveShape;
pub use flexstage_scenario::{DesignEstimate, Scenario, limit};
pub use flexstage_verify::outline::Unit;
pub use flexstage_verify::{Verification, VerifyParams};
