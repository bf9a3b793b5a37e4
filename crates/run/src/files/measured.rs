//! `track/[<conditions>/]measured_response.csv`: the twin's loop as `track` measured it in
//! its rig at the controller's sample time (the periodic multisine of
//! `flexstage_identify::measured`), the 2 × 2 response the controllers are designed from. The
//! columns are those of a measured response file (`docs/formats.md`), so the file is also a
//! user's input to `flexstage controller --response`.

use serde::{Deserialize, Deserializer, Serialize};

use crate::format::{Row, num};

/// One line of a measured response (`docs/formats.md`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MeasuredLineRow {
    /// Line frequency \[Hz\].
    #[serde(serialize_with = "num::exp")]
    pub f: f64,
    /// The columns after `f`.
    pub line: LineCells,
}

impl<'de> Deserialize<'de> for MeasuredLineRow {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (f, line) = Deserialize::deserialize(d)?;
        Ok(MeasuredLineRow { f, line })
    }
}

/// The columns of a response file's row after `f` (and, in a lifted response file, after
/// `phase`): one line's 2 × 2 response H (or a lifted response's G_p), its coherence, the
/// sample time and its standard deviations (`docs/formats.md`). A row type writes them
/// after its own columns and reads them back by position (the `csv` crate reads a nested
/// struct by the header's names, which would start at the row's first column; the row
/// types' headers are checked whole before).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LineCells {
    /// Re H11 (output 1 per input 1, m/m).
    #[serde(serialize_with = "num::exp")]
    pub re11: f64,
    /// Im H11.
    #[serde(serialize_with = "num::exp")]
    pub im11: f64,
    /// Re H12 (output 1 per input 2, m/m).
    #[serde(serialize_with = "num::exp")]
    pub re12: f64,
    /// Im H12.
    #[serde(serialize_with = "num::exp")]
    pub im12: f64,
    /// Re H21 (output 2 per input 1, m/m).
    #[serde(serialize_with = "num::exp")]
    pub re21: f64,
    /// Im H21.
    #[serde(serialize_with = "num::exp")]
    pub im21: f64,
    /// Re H22 (output 2 per input 2, m/m).
    #[serde(serialize_with = "num::exp")]
    pub re22: f64,
    /// Im H22.
    #[serde(serialize_with = "num::exp")]
    pub im22: f64,
    /// Coherence of H11, 0–1.
    #[serde(serialize_with = "num::exp")]
    pub coh11: f64,
    /// Coherence of H12, 0–1.
    #[serde(serialize_with = "num::exp")]
    pub coh12: f64,
    /// Coherence of H21, 0–1.
    #[serde(serialize_with = "num::exp")]
    pub coh21: f64,
    /// Coherence of H22, 0–1.
    #[serde(serialize_with = "num::exp")]
    pub coh22: f64,
    /// The controller's sample time T \[s\] (the same on every row).
    #[serde(serialize_with = "num::exp")]
    pub sample_time: f64,
    /// Standard deviation of H11 (absolute).
    #[serde(serialize_with = "num::exp")]
    pub std11: f64,
    /// Standard deviation of H12 (absolute).
    #[serde(serialize_with = "num::exp")]
    pub std12: f64,
    /// Standard deviation of H21 (absolute).
    #[serde(serialize_with = "num::exp")]
    pub std21: f64,
    /// Standard deviation of H22 (absolute).
    #[serde(serialize_with = "num::exp")]
    pub std22: f64,
}

impl From<[f64; 17]> for LineCells {
    /// The cells in column order.
    fn from(v: [f64; 17]) -> LineCells {
        LineCells {
            re11: v[0],
            im11: v[1],
            re12: v[2],
            im12: v[3],
            re21: v[4],
            im21: v[5],
            re22: v[6],
            im22: v[7],
            coh11: v[8],
            coh12: v[9],
            coh21: v[10],
            coh22: v[11],
            sample_time: v[12],
            std11: v[13],
            std12: v[14],
            std21: v[15],
            std22: v[16],
        }
    }
}

impl<'de> Deserialize<'de> for LineCells {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        <[f64; 17]>::deserialize(d).map(LineCells::from)
    }
}

impl Row for MeasuredLineRow {
    const HEADER: &'static [&'static str] = &[
        "f",
        "re11",
        "im11",
        "re12",
        "im12",
        "re21",
        "im21",
        "re22",
        "im22",
        "coh11",
        "coh12",
        "coh21",
        "coh22",
        "sample_time",
        "std11",
        "std12",
        "std21",
        "std22",
    ];
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::format::{Format, Rows};

    /// Reference: the bits written. Goal: a response file reads back bit for bit (values with
    /// no short decimal form included), with the header of `docs/formats.md`; a file missing
    /// a column is refused.
    #[test]
    fn measured_response_rows_read_back_bitwise() {
        let mut v = [0.0; 18];
        for (k, x) in v.iter_mut().enumerate() {
            *x = (k as f64 + 0.1).sqrt() * 1e-3 - 0.01;
        }
        let row = |v: [f64; 18]| MeasuredLineRow {
            f: v[0],
            line: LineCells::from(core::array::from_fn(|k| v[k + 1])),
        };
        let rows = Rows(vec![row(v), row(v.map(|x| -x / 3.0))]);
        let bytes = rows.encode().unwrap();
        let text = String::from_utf8(bytes.clone()).unwrap();
        assert!(text.starts_with("f,re11,im11,re12,im12,re21,im21,re22,im22,coh11"));
        let back = Rows::<MeasuredLineRow>::decode(&bytes).unwrap();
        assert_eq!(back, rows);
        let cut = text.replacen(",std22", "", 1);
        assert!(Rows::<MeasuredLineRow>::decode(cut.as_bytes()).is_err());
    }
}
