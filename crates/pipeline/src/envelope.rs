//! The envelope of a design checkpoint (`design/checkpoint.bin`): the optimizer's own bytes
//! ([`flexstage_topopt::Optimizer::checkpoint`]) wrapped with the scenario they belong to and a
//! checksum, so that a damaged checkpoint or one of another scenario is refused, never
//! resumed.
//!
//! ```text
//! offset  size  content (integers little-endian)
//!      0     8  magic "FXSCKPT\n"
//!      8     4  envelope format version (1)
//!     12     4  CRC-32 (IEEE 802.3, as zlib's crc32) of every byte from offset 16 to the end
//!     16     8  scenario hash (FNV-1a 64 of the scenario's TOML, [`flexstage_run::state::scenario_hash`])
//!     24     8  length S of the scenario TOML
//!     32     8  length P of the payload
//!     40     S  the scenario's TOML (for the message that says what changed)
//!   40+S     P  the optimizer's checkpoint
//! ```
//!
//! The file is exactly 40 + S + P bytes. CRC-32 detects every error of 1, 2 or 3 bits and every
//! burst of up to 32 bits, and any other corruption with probability 1 − 2⁻³²; magic and
//! version are checked for their exact values.

use std::path::Path;

use flexstage_scenario::Scenario;

use crate::diff::scenario_changes;
use crate::error::{PipelineError, Result};
use crate::state::{scenario_hash_u64, scenario_text};

/// The first 8 bytes of a checkpoint envelope.
pub const MAGIC: &[u8; 8] = b"FXSCKPT\n";
/// The envelope format this version writes and reads.
pub const VERSION: u32 = 1;
const HEADER: usize = 40;

/// Wraps the optimizer's checkpoint `payload` for `scenario`.
pub fn seal(scenario: &Scenario, payload: &[u8]) -> Vec<u8> {
    let toml = scenario_text(scenario);
    let mut out = Vec::with_capacity(HEADER + toml.len() + payload.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&[0; 4]); // CRC, below
    out.extend_from_slice(&scenario_hash_u64(scenario).to_le_bytes());
    out.extend_from_slice(&(toml.len() as u64).to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(toml.as_bytes());
    out.extend_from_slice(payload);
    let crc = crc32fast::hash(&out[16..]);
    out[12..16].copy_from_slice(&crc.to_le_bytes());
    out
}

/// The parts of an intact envelope.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Envelope<'a> {
    /// The scenario hash recorded.
    pub scenario_hash: u64,
    /// The scenario's TOML recorded.
    pub scenario_toml: &'a str,
    /// The optimizer's checkpoint.
    pub payload: &'a [u8],
}

/// Checks an envelope (magic, version, exact length, CRC) and returns its parts, or why it is
/// damaged.
pub fn open(bytes: &[u8]) -> std::result::Result<Envelope<'_>, String> {
    if bytes.len() < HEADER {
        return Err(format!(
            "{} bytes, shorter than the {HEADER}-byte header (truncated)",
            bytes.len()
        ));
    }
    if &bytes[..8] != MAGIC {
        return Err("not a flexstage checkpoint envelope (bad magic)".into());
    }
    let word = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes"));
    let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if version != VERSION {
        return Err(format!(
            "envelope format version {version} (this flexstage reads version {VERSION})"
        ));
    }
    let (s, p) = (word(24), word(32));
    let expected = (HEADER as u64)
        .checked_add(s)
        .and_then(|n| n.checked_add(p));
    if expected != Some(bytes.len() as u64) {
        return Err(format!(
            "{} bytes, but its header announces {HEADER} + {s} + {p} (truncated or damaged)",
            bytes.len()
        ));
    }
    let stored = u32::from_le_bytes(bytes[12..16].try_into().expect("4 bytes"));
    let crc = crc32fast::hash(&bytes[16..]);
    if crc != stored {
        return Err(format!(
            "CRC-32 mismatch (stored {stored:08x}, computed {crc:08x}): the file is damaged"
        ));
    }
    let s = s as usize;
    let scenario_toml = std::str::from_utf8(&bytes[HEADER..HEADER + s])
        .map_err(|_| "the recorded scenario is not UTF-8".to_string())?;
    Ok(Envelope {
        scenario_hash: word(16),
        scenario_toml,
        payload: &bytes[HEADER + s..],
    })
}

/// The optimizer's checkpoint in the envelope `bytes` read from `path`, if it is intact and
/// belongs to `scenario`; else [`PipelineError::Damaged`] or [`PipelineError::OtherScenario`]
/// saying what changed.
pub fn payload_for<'a>(path: &Path, bytes: &'a [u8], scenario: &Scenario) -> Result<&'a [u8]> {
    let env = open(bytes).map_err(|reason| PipelineError::Damaged {
        path: path.to_path_buf(),
        reason,
        hint: "it cannot be resumed; start the design again (--force, or --restart for `run`)"
            .into(),
    })?;
    if env.scenario_hash != scenario_hash_u64(scenario) {
        return Err(PipelineError::OtherScenario {
            root: path.to_path_buf(),
            what: "an interrupted design",
            changes: scenario_changes(env.scenario_toml, scenario).to_string(),
            hint: "resume it with the scenario it was made with, or start the design again \
                   (--force, or --restart for `run`)"
                .into(),
        });
    }
    Ok(env.payload)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> (Scenario, Vec<u8>) {
        let s = crate::folder::preset("quick").unwrap();
        let payload: Vec<u8> = (0..300u32).map(|i| (i * 37 % 251) as u8).collect();
        let bytes = seal(&s, &payload);
        (s, bytes)
    }

    #[test]
    fn an_intact_envelope_opens_to_its_payload() {
        let (s, bytes) = sample();
        let p = payload_for(Path::new("c.bin"), &bytes, &s).unwrap();
        assert_eq!(p.len(), 300);
        assert_eq!(p[1], 37);
        let env = open(&bytes).unwrap();
        assert_eq!(env.scenario_toml, scenario_text(&s));
    }

    #[test]
    fn crc_matches_the_published_check_value() {
        // Reference: the CRC-32 (IEEE, zlib) check value of "123456789" is cbf43926
        // (Williams, "A painless guide to CRC error detection algorithms", catalogue).
        assert_eq!(crc32fast::hash(b"123456789"), 0xcbf4_3926);
    }

    #[test]
    fn every_single_bit_flip_is_refused() {
        // Goal: a bit flip anywhere (header, scenario, payload) is detected, never resumed.
        let (s, bytes) = sample();
        let path = Path::new(flexstage_run::layout::design::CHECKPOINT);
        for bit in 0..bytes.len() * 8 {
            let mut b = bytes.clone();
            b[bit / 8] ^= 1 << (bit % 8);
            let e = payload_for(path, &b, &s).expect_err("a flipped bit must be refused");
            assert!(matches!(e, PipelineError::Damaged { .. }), "bit {bit}: {e}");
        }
    }

    #[test]
    fn every_truncation_and_extension_is_refused() {
        let (s, bytes) = sample();
        let path = Path::new("c.bin");
        for len in 0..bytes.len() {
            let e = payload_for(path, &bytes[..len], &s).unwrap_err();
            assert!(e.to_string().contains("c.bin"), "{e}");
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(payload_for(path, &longer, &s).is_err());
    }

    #[test]
    fn another_scenario_is_refused_saying_what_changed() {
        let (s, bytes) = sample();
        let mut other = s.clone();
        other.optimization.penalty = 2.0;
        let e = payload_for(Path::new("c.bin"), &bytes, &other)
            .unwrap_err()
            .to_string();
        assert!(e.contains("optimization.penalty: 3.0 → 2.0"), "{e}");
    }
}
