//! Strict parsing of fixed-length arrays.
//!
//! serde's own `[T; N]` reads the first N elements of a TOML array and ignores the rest, so
//! `pid = [1, 2, 3, 4]` passed as `[1, 2, 3]`. Every fixed-length array of the scenario is
//! read through [`array`] instead (`#[serde(deserialize_with = "strict::array")]`), which
//! refuses any other length with the parser's line and column:
//! `invalid length 4, expected an array of exactly 3 elements`.

use serde::de::{Deserialize, Deserializer, Error};

/// `[T; N]` from an array of exactly `N` elements.
pub(crate) fn array<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    let v: Vec<T> = Vec::deserialize(d)?;
    let len = v.len();
    v.try_into().map_err(|_| {
        D::Error::invalid_length(len, &format!("an array of exactly {N} elements").as_str())
    })
}

/// `Option<[T; N]>` from an array of exactly `N` elements (with `#[serde(default)]`, absent
/// is `None`).
pub(crate) fn option_array<'de, D, T, const N: usize>(d: D) -> Result<Option<[T; N]>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    array(d).map(Some)
}
