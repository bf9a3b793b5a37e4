//! `track/[<conditions>/]lifted_response.csv`: the twin's output between the samples as
//! `track` measured it during the experiments of `measured_response.csv` (the same
//! multisine), with a fast ADC on the sensor's analog output at L samples per controller
//! sample and the sensor's datasheet filter divided out (`flexstage_identify::measured::
//! LiftedResponse`): one row per line and phase p = 0..L−1 (the output at kT + pT/L). The
//! columns are those of a lifted response file (`docs/formats.md`), so the file is also a
//! user's input to `flexstage controller --response FILE --lifted FILE`.

use serde::{Deserialize, Deserializer, Serialize};

use crate::files::measured::LineCells;
use crate::format::{Row, num};

/// One line and phase of a lifted response (`docs/formats.md`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LiftedLineRow {
    /// Line frequency \[Hz\].
    #[serde(serialize_with = "num::exp")]
    pub f: f64,
    /// Phase p: the output at kT + pT/L, 0..L−1.
    pub phase: usize,
    /// The columns after `phase`: those of a measured response file after `f`, for G_p
    /// (output i per held command j).
    pub line: LineCells,
}

impl<'de> Deserialize<'de> for LiftedLineRow {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (f, phase, line) = Deserialize::deserialize(d)?;
        Ok(LiftedLineRow { f, phase, line })
    }
}

impl Row for LiftedLineRow {
    const HEADER: &'static [&'static str] = &[
        "f",
        "phase",
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

    /// Reference: the bits written. Goal: a lifted response file reads back bit for bit
    /// (values with no short decimal form included), with the header of `docs/formats.md`;
    /// a file missing a column is refused.
    #[test]
    fn lifted_response_rows_read_back_bitwise() {
        let mut v = [0.0; 18];
        for (k, x) in v.iter_mut().enumerate() {
            *x = (k as f64 + 0.1).sqrt() * 1e-3 - 0.01;
        }
        let row = |v: [f64; 18], phase: usize| LiftedLineRow {
            f: v[0],
            phase,
            line: LineCells::from(core::array::from_fn(|k| v[k + 1])),
        };
        let rows = Rows(vec![row(v, 0), row(v.map(|x| -x / 3.0), 1)]);
        let bytes = rows.encode().unwrap();
        let text = String::from_utf8(bytes.clone()).unwrap();
        assert!(text.starts_with("f,phase,re11,im11,re12,im12,re21,im21,re22,im22,coh11"));
        let back = Rows::<LiftedLineRow>::decode(&bytes).unwrap();
        assert_eq!(back, rows);
        let cut = text.replacen(",std22", "", 1);
        assert!(Rows::<LiftedLineRow>::decode(cut.as_bytes()).is_err());
    }
}
