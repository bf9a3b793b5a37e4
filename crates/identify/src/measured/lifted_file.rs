//! The file of a lifted response (`docs/formats.md`): one row per line and phase, the
//! columns of a measured response file with `phase` after `f`. What a lab's fast ADC
//! recorded (as [`LiftedResponse::from_multisine`] estimates it) is what a design reads
//! back, bit for bit.

use std::fmt::Write as _;
use std::io::Read;

use flexstage_numerics::DataError;
use flexstage_numerics::records::{NumericCsv, RecordError};

use crate::error::Result;
use crate::measured::lifted::{LiftedLine, LiftedResponse};
use crate::measured::{
    MeasuredLine, MeasuredResponse, RESPONSE_COLUMNS, STD_COLUMNS, line_from_cells, write_cells,
};

/// The columns of a lifted response file, in file order: `f`, `phase` (p = 0..L−1, the
/// output at kT + pT/L), then those of a measured response file after `f`.
pub fn lifted_columns() -> Vec<&'static str> {
    let mut names = vec!["f", "phase"];
    names.extend(RESPONSE_COLUMNS[1..].iter().chain(&STD_COLUMNS));
    names
}

impl LiftedResponse {
    /// The lifted response as CSV text (`docs/formats.md`): header [`lifted_columns`], one
    /// row per line and phase (the phases of a line together, lines by frequency), numbers
    /// in Rust's shortest round-trip form ([`LiftedResponse::from_csv`] reads it back bit
    /// for bit).
    pub fn to_csv(&self) -> String {
        let mut s = lifted_columns().join(",");
        s.push('\n');
        for line in self.lines() {
            for (p, l) in line.phase.iter().enumerate() {
                let _ = write!(s, "{:e},{p}", line.f);
                write_cells(&mut s, l, self.sample_time());
                s.push('\n');
            }
        }
        s
    }

    /// Reads a lifted response file (`docs/formats.md`); `origin` names it in errors. Every
    /// line holds the phases 0..L−1 in order with one L (1–64) and one frequency, the
    /// `sample_time` column one value; each phase's lines are checked as a measured
    /// response's (ascending frequencies below Nyquist, finite values, coherence in
    /// \[0, 1\], standard deviations ≥ 0).
    pub fn from_csv(reader: impl Read, origin: &str) -> Result<LiftedResponse> {
        let table = NumericCsv::open(reader, origin)?;
        let names = lifted_columns();
        let cols = table.require(&names, &names.join(", "))?;
        let d = table.read_grouped(&cols, &names)?;
        let bad = |what: &str, reason: String| -> crate::error::IdentifyError {
            RecordError::whole(origin, DataError::new(what, reason)).into()
        };
        let Some(&ts) = d[14].first() else {
            return Err(bad("lifted response", "no line".into()));
        };
        if let Some(k) = d[14].iter().position(|v| v.to_bits() != ts.to_bits()) {
            return Err(bad(
                "sample_time",
                format!(
                    "row {k} of the data has {} s, the first {ts} s: one response has one \
                     sample time",
                    d[14][k]
                ),
            ));
        }
        // L: the rows before the first phase 0 after the first row.
        let ratio = d[1]
            .iter()
            .skip(1)
            .position(|&p| p == 0.0)
            .map_or(d[1].len(), |k| k + 1);
        if !(1..=64).contains(&ratio) || d[1].len() % ratio != 0 {
            return Err(bad(
                "phase",
                format!(
                    "{} rows with {ratio} phases per line: each line holds the phases 0..L−1, \
                     1 ≤ L ≤ 64, with one L",
                    d[1].len()
                ),
            ));
        }
        let mut phases = vec![Vec::with_capacity(d[0].len() / ratio); ratio];
        for (k, (&f, &p)) in d[0].iter().zip(&d[1]).enumerate() {
            let want = k % ratio;
            if p != want as f64 || f.to_bits() != d[0][k - want].to_bits() {
                return Err(bad(
                    "phase",
                    format!(
                        "row {k} has phase {p} at {f} Hz; expected phase {want} at {} Hz (the \
                         phases 0..{} of each line in order)",
                        d[0][k - want],
                        ratio - 1
                    ),
                ));
            }
            phases[want].push(line_from_cells(f, |col| d[col + 2][k]));
        }
        // Each phase checked as a measured response (the same ranges and their messages).
        let phases: Vec<Vec<MeasuredLine>> = phases
            .into_iter()
            .map(|lines| MeasuredResponse::new(ts, lines).map(|r| r.lines().to_vec()))
            .collect::<Result<_>>()?;
        let lines = (0..phases[0].len())
            .map(|n| LiftedLine {
                f: phases[0][n].f,
                phase: phases.iter().map(|ph| ph[n]).collect(),
            })
            .collect();
        Ok(LiftedResponse::from_parts(ts, ratio, lines))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frequency::C64;

    /// A lifted response of three lines and `l` phases with values that have no short
    /// decimal form.
    fn sample(l: usize) -> LiftedResponse {
        let lines = (1..=3)
            .map(|n| LiftedLine {
                f: 5.0 * n as f64 + 1.0 / 3.0,
                phase: (0..l)
                    .map(|p| {
                        let x = |k: usize| ((n * 31 + p * 7 + k) as f64).sqrt() * 1e-3 - 0.01;
                        MeasuredLine {
                            f: 5.0 * n as f64 + 1.0 / 3.0,
                            h: [
                                [C64::new(x(0), x(1)), C64::new(x(2), x(3))],
                                [C64::new(x(4), x(5)), C64::new(x(6), x(7))],
                            ],
                            coherence: [[1.0 / 3.0, 0.5], [0.7, 1.0]],
                            std: [[x(8).abs(), 0.0], [1e-7 / 3.0, x(9).abs()]],
                        }
                    })
                    .collect(),
            })
            .collect();
        LiftedResponse::from_parts(1e-4, l, lines)
    }

    /// Reference: the bits written. Goal: a lifted response file reads back bit for bit
    /// (L = 1 and L = 10), with the header of `docs/formats.md`.
    #[test]
    fn lifted_response_file_reads_back_bitwise() {
        for l in [1, 10] {
            let r = sample(l);
            let text = r.to_csv();
            assert!(text.starts_with("f,phase,re11,im11,re12,im12,re21,im21,re22,im22,coh11"));
            assert_eq!(text.lines().count(), 1 + 3 * l);
            let back = LiftedResponse::from_csv(text.as_bytes(), "written").unwrap();
            assert_eq!(back, r);
            assert_eq!(back.ratio(), l);
        }
    }

    /// Goal: a file whose phases are out of order, whose lines hold different numbers of
    /// phases, whose frequencies descend or whose coherence is out of range is refused
    /// naming the column; a missing column is refused.
    #[test]
    fn a_damaged_lifted_response_file_is_refused_naming_the_column() {
        let text = sample(4).to_csv();
        let rows: Vec<&str> = text.lines().collect();
        let swapped = [rows[0], rows[2], rows[1]]
            .iter()
            .chain(&rows[3..])
            .copied()
            .map(|r| format!("{r}\n"))
            .collect::<String>();
        let short: String = [&rows[..4], &rows[5..]]
            .concat()
            .iter()
            .map(|r| format!("{r}\n"))
            .collect();
        let other_f = text.replacen(&rows[2][..rows[2].find(',').unwrap()], "7e0", 1);
        let coherence = {
            let mut cells: Vec<String> = rows[1].split(',').map(str::to_string).collect();
            cells[10] = "1.5".into();
            [rows[0].to_string(), cells.join(",")]
                .into_iter()
                .chain(rows[2..].iter().map(|s| s.to_string()))
                .map(|r| r + "\n")
                .collect::<String>()
        };
        for (bad, column) in [
            (swapped, "phase"),
            (short, "phase"),
            (other_f, "f is not ascending"),
            (coherence, "coh11"),
        ] {
            let e = LiftedResponse::from_csv(bad.as_bytes(), "damaged")
                .unwrap_err()
                .to_string();
            assert!(e.contains(column), "{column}: {e}");
        }
        let cut = text.replacen(",std22", "", 1);
        assert!(LiftedResponse::from_csv(cut.as_bytes(), "cut").is_err());
    }
}
