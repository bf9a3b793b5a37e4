//! The hashes of the run folder: SHA-256 of result files (what `run` checks before it skips a
//! finished stage) and the 64-bit FNV-1a of a scenario's text (which scenario a stage ran
//! with).
//!
//! SHA-256 because a user can check any recorded hash with `sha256sum FILE`, and because it
//! detects every accidental change (truncation, an edited number, a flipped bit) with a
//! chance of a miss far below any hardware fault; its cost is small beside writing the file
//! (docs/DECISIONS.md, "Resume").

use sha2::{Digest, Sha256};

/// SHA-256 of `bytes` as 64 lower-case hex digits (the output of `sha256sum`).
pub fn sha256_hex(bytes: &[u8]) -> String {
    let digest = Sha256::digest(bytes);
    let mut out = String::with_capacity(64);
    for b in digest {
        out.push_str(&format!("{b:02x}"));
    }
    out
}

/// The 64-bit FNV-1a hash.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf29ce484222325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x100000001b3)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sha256_matches_the_fips_180_2_vectors() {
        // Reference: FIPS 180-2, Appendix B.1 ("abc") and the empty message.
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        assert_eq!(
            sha256_hex(b""),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"
        );
    }

    #[test]
    fn fnv1a_matches_the_published_vectors() {
        // Reference: FNV-1a 64-bit test vectors (Fowler, Noll, Vo; IETF draft
        // draft-eastlake-fnv, appendix C): "" → cbf29ce484222325, "a" → af63dc4c8601ec8c.
        assert_eq!(fnv1a(b""), 0xcbf29ce484222325);
        assert_eq!(fnv1a(b"a"), 0xaf63dc4c8601ec8c);
        assert_eq!(fnv1a(b"foobar"), 0x85944171f73967e8);
    }
}
