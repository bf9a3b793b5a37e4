//! `track/[<conditions>/]lifted_response.csv`: the twin's output between the samples as
//! `track` measured it during the experiments of `measured_response.csv` (the same
//! multisine), with a fast ADC on the sensor's analog output at L samples per controller
//! sample and the sensor's datasheet filter divided out (`flexstage_identify::measured::
//! LiftedResponse`): one row per line and phase p = 0..L−1 (the output at kT + pT/L). The
//! columns are those of a lifted response file (`docs/formats.md`), so the file is also a
//! user's input to `flexstage controller --response FILE --lifted FILE`.

use serde::{Deserialize, Serialize};

use crate::format::{Row, num};

/// One line and phase of a lifted response (`docs/formats.md`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LiftedLineRow {
    /// Line frequency \[Hz\].
    #[serde(serialize_with = "num::exp")]
    pub f: f64,
    /// Phase p: the output at kT + pT/L, 0..L−1.
    pub phase: usize,
    /// Re G_p,11 (output 1 per held command 1, m/m).
    #[serde(serialize_with = "num::exp")]
    pub re11: f64,
    /// Im G_p,11.
    #[serde(serialize_with = "num::exp")]
    pub im11: f64,
    /// Re G_p,12 (output 1 per held command 2, m/m).
    #[serde(serialize_with = "num::exp")]
    pub re12: f64,
    /// Im G_p,12.
    #[serde(serialize_with = "num::exp")]
    pub im12: f64,
    /// Re G_p,21 (output 2 per held command 1, m/m).
    #[serde(serialize_with = "num::exp")]
    pub re21: f64,
    /// Im G_p,21.
    #[serde(serialize_with = "num::exp")]
    pub im21: f64,
    /// Re G_p,22 (output 2 per held command 2, m/m).
    #[serde(serialize_with = "num::exp")]
    pub re22: f64,
    /// Im G_p,22.
    #[serde(serialize_with = "num::exp")]
    pub im22: f64,
    /// Coherence of G_p,11, 0–1.
    #[serde(serialize_with = "num::exp")]
    pub coh11: f64,
    /// Coherence of G_p,12, 0–1.
    #[serde(serialize_with = "num::exp")]
    pub coh12: f64,
    /// Coherence of G_p,21, 0–1.
    #[serde(serialize_with = "num::exp")]
    pub coh21: f64,
    /// Coherence of G_p,22, 0–1.
    #[serde(serialize_with = "num::exp")]
    pub coh22: f64,
    /// The controller's sample time T \[s\] (the same on every row).
    #[serde(serialize_with = "num::exp")]
    pub sample_time: f64,
    /// Standard deviation of G_p,11 (absolute).
    #[serde(serialize_with = "num::exp")]
    pub std11: f64,
    /// Standard deviation of G_p,12 (absolute).
    #[serde(serialize_with = "num::exp")]
    pub std12: f64,
    /// Standard deviation of G_p,21 (absolute).
    #[serde(serialize_with = "num::exp")]
    pub std21: f64,
    /// Standard deviation of G_p,22 (absolute).
    #[serde(serialize_with = "num::exp")]
    pub std22: f64,
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
            re11: v[1],
            im11: v[2],
            re12: v[3],
            im12: v[4],
            re21: v[5],
            im21: v[6],
            re22: v[7],
            im22: v[8],
            coh11: v[9],
            coh12: v[10],
            coh21: v[11],
            coh22: v[12],
            sample_time: v[13],
            std11: v[14],
            std12: v[15],
            std21: v[16],
            std22: v[17],
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
