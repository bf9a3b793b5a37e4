//! # flexstage-report
//!
//! The self-contained HTML report of a run folder ([`html::build_report`]): every result of
//! the scheme of *Integrated Development of a Topology-Optimized Compliant Mechanism for
//! Precise Positioning* (Actuators 2022, 11(7), 179) beside the scenario that produced it.
//!
//! The report sits on top: it reads the typed files of `flexstage-run` (never a CSV, TOML,
//! VTU or SVG by hand; an SVG file's bytes are embedded as they are) and draws with
//! `flexstage-figures`; it depends on no stage crate. A missing result is "not run"; a file
//! that exists but does not parse is an error on the page and in [`html::Report::errors`].

pub mod html;

pub use html::{Headline, Report, build_report, fmt_num, headline_rows};
