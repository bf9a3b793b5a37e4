//! Numeric CSV records: a header row naming the columns, then one sample per line.
//!
//! [`NumericCsv`] reads the actuator records of `flexstage-piezo` (t, U, x) and the stage
//! records of `flexstage-identify` (t, x_nom or U, x_in, q) alike, so both report a bad file
//! the same way: every [`RecordError`] names the origin (the file) and, for a bad cell, the
//! 1-based line.
//!
//! ```
//! use flexstage_numerics::records::NumericCsv;
//! let text = "# a comment\nx, T ,unused\n1.5, 0.0, a\n2.5, 0.1, b\n";
//! let table = NumericCsv::open(text.as_bytes(), "example.csv")?;
//! let cols = table.require(&["t", "x"], "t, x")?;
//! let data = table.read(&cols, &["t", "x"])?;
//! assert_eq!(data, vec![vec![0.0, 0.1], vec![1.5, 2.5]]);
//! # Ok::<(), flexstage_numerics::records::RecordError>(())
//! ```

use std::io::{BufRead, BufReader, Read};

use crate::validate::DataError;

/// A CSV file that cannot be read as a numeric record.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RecordError {
    /// The header lacks a required column.
    #[error(
        "{origin}: missing column {column:?} (found columns: {found}); expected a header with {expected}"
    )]
    MissingColumn {
        /// File name or other origin.
        origin: String,
        /// The column looked for.
        column: String,
        /// The columns present, comma-separated ("none" for an empty header).
        found: String,
        /// The columns a record of this kind has.
        expected: String,
    },
    /// A line is malformed: a missing or non-numeric cell, NaN or infinity, time that does
    /// not increase; line 0 stands for the record as a whole.
    #[error("{origin}{}: {reason}", at_line(*.line))]
    Line {
        /// File name or other origin.
        origin: String,
        /// 1-based line number in the file (0: the whole record).
        line: u64,
        /// What is wrong with the line.
        reason: String,
    },
}

/// ", line N" for a line, nothing for the whole record (line 0).
fn at_line(line: u64) -> String {
    if line == 0 {
        String::new()
    } else {
        format!(", line {line}")
    }
}

impl RecordError {
    /// A record whose lines all parse but whose data as a whole are invalid (`line` 0),
    /// e.g. too short or with columns that do not fit together.
    pub fn whole(origin: &str, e: DataError) -> Self {
        RecordError::Line {
            origin: origin.to_string(),
            line: 0,
            reason: e.reason,
        }
    }
}

/// A CSV table of named numeric columns: one header row, names matched case-insensitively,
/// extra columns ignored, blank lines and `#` comment lines skipped, cells trimmed (and
/// unquoted: `"t"` is `t`). Line numbers count every line of the file, comments included.
///
/// Records are strict: every row has as many fields as the header (a missing or an extra
/// field is refused with its line, also in a column that is not read), and every row ends
/// with a line end, so a file cut off in its last row is refused rather than read short.
///
/// The format is plain comma-separated numbers, so no quoting rules beyond that are
/// needed; reading is streamed line by line.
pub struct NumericCsv<R> {
    reader: BufReader<R>,
    /// The text of the line being read (reused).
    buf: String,
    /// 1-based number of the last line read.
    line: u64,
    headers: Vec<String>,
    origin: String,
}

impl<R: Read> NumericCsv<R> {
    /// Opens the table and reads its header row (the first line that is neither blank nor a
    /// comment); `origin` (usually the file name) prefixes every error message.
    pub fn open(reader: R, origin: &str) -> Result<Self, RecordError> {
        let mut table = NumericCsv {
            reader: BufReader::new(reader),
            buf: String::new(),
            line: 0,
            headers: Vec::new(),
            origin: origin.to_string(),
        };
        if table.next_row()? {
            table.headers = cells(&table.buf).map(str::to_string).collect();
        }
        Ok(table)
    }

    /// Reads the next line that is neither blank nor a comment into `buf` (without its line
    /// end); `false` at the end of the file. A line without a line end (the last one of a file
    /// cut off while it was written) is refused.
    fn next_row(&mut self) -> Result<bool, RecordError> {
        loop {
            self.buf.clear();
            let n = self.reader.read_line(&mut self.buf);
            self.line += 1;
            let bad = |reason: String| RecordError::Line {
                origin: self.origin.clone(),
                line: self.line,
                reason,
            };
            if n.map_err(|e| bad(format!("cannot read the line: {e}")))? == 0 {
                return Ok(false);
            }
            let ended = self.buf.ends_with('\n');
            let text = self.buf.trim_end_matches(['\n', '\r']);
            let t = text.trim();
            if t.is_empty() || t.starts_with('#') {
                continue;
            }
            if !ended {
                return Err(bad(
                    "the last line has no line end: the file may have been cut off while it \
                     was written (a complete record ends every line with a newline)"
                        .into(),
                ));
            }
            let len = text.len();
            self.buf.truncate(len);
            return Ok(true);
        }
    }

    /// The index of the column called `name` (case-insensitive), if present.
    pub fn position(&self, name: &str) -> Option<usize> {
        self.headers
            .iter()
            .position(|h| h.eq_ignore_ascii_case(name))
    }

    /// The indexes of the columns `names`, or [`RecordError::MissingColumn`] for the first
    /// one absent (`expected` lists the columns of a complete header, for the message).
    pub fn require(&self, names: &[&str], expected: &str) -> Result<Vec<usize>, RecordError> {
        names
            .iter()
            .map(|&name| {
                self.position(name)
                    .ok_or_else(|| RecordError::MissingColumn {
                        origin: self.origin.clone(),
                        column: name.to_string(),
                        found: self.found(),
                        expected: expected.to_string(),
                    })
            })
            .collect()
    }

    /// The header names, comma-separated ("none" for an empty header), for error messages.
    pub fn found(&self) -> String {
        if self.headers.is_empty() {
            "none".into()
        } else {
            self.headers.join(", ")
        }
    }

    /// The origin given to [`NumericCsv::open`].
    pub fn origin(&self) -> &str {
        &self.origin
    }

    /// Reads the columns at `cols` (called `names` in messages), one vector per column. Every
    /// cell must be a finite number, and the first column is the time axis: it must strictly
    /// increase.
    pub fn read(self, cols: &[usize], names: &[&str]) -> Result<Vec<Vec<f64>>, RecordError> {
        self.read_ordered(cols, names, true)
    }

    /// [`NumericCsv::read`] for a table whose rows come in groups that share the first
    /// column (e.g. the phases of one frequency line): it must not decrease.
    pub fn read_grouped(
        self,
        cols: &[usize],
        names: &[&str],
    ) -> Result<Vec<Vec<f64>>, RecordError> {
        self.read_ordered(cols, names, false)
    }

    /// The columns, the first strictly increasing (`strict`) or not decreasing.
    fn read_ordered(
        mut self,
        cols: &[usize],
        names: &[&str],
        strict: bool,
    ) -> Result<Vec<Vec<f64>>, RecordError> {
        let mut data = vec![Vec::new(); cols.len()];
        let mut prev_t: Option<(f64, u64)> = None;
        let width = self.headers.len();
        while self.next_row()? {
            let line = self.line;
            let bad = |reason: String| RecordError::Line {
                origin: self.origin.clone(),
                line,
                reason,
            };
            let row: Vec<&str> = cells(&self.buf).collect();
            if row.len() != width {
                return Err(bad(format!(
                    "{} fields, but the header has {width} ({}): a row {} (every row has one \
                     value per column)",
                    row.len(),
                    self.found(),
                    if row.len() < width {
                        "cut short"
                    } else {
                        "with an extra field"
                    }
                )));
            }
            for (i, &c) in cols.iter().enumerate() {
                let cell = *row.get(c).ok_or_else(|| {
                    bad(format!(
                        "missing value for column {} (column {c})",
                        names[i]
                    ))
                })?;
                let v: f64 = cell
                    .parse()
                    .map_err(|_| bad(format!("column {}: {cell:?} is not a number", names[i])))?;
                if !v.is_finite() {
                    return Err(bad(format!(
                        "column {}: {cell} is not a finite number",
                        names[i]
                    )));
                }
                data[i].push(v);
            }
            let tk = data[0][data[0].len() - 1];
            if let Some((tp, lp)) = prev_t
                && (tk < tp || (strict && tk == tp))
            {
                return Err(bad(if strict {
                    format!("time is not increasing: t = {tk} after t = {tp} on line {lp}")
                } else {
                    format!(
                        "{} is not ascending: {tk} after {tp} on line {lp}",
                        names[0]
                    )
                }));
            }
            prev_t = Some((tk, line));
        }
        Ok(data)
    }
}

/// The cells of a line: split at commas, trimmed, surrounding double quotes removed.
fn cells(line: &str) -> impl Iterator<Item = &str> {
    line.split(',').map(|c| {
        let c = c.trim();
        c.strip_prefix('"')
            .and_then(|c| c.strip_suffix('"'))
            .unwrap_or(c)
    })
}

#[cfg(test)]
mod tests {
    //! Reference: the contract in the module docs. Goal: every malformed file is rejected
    //! with its origin and the 1-based line of the offending cell.

    use super::*;

    fn read(text: &str) -> Result<Vec<Vec<f64>>, RecordError> {
        let t = NumericCsv::open(text.as_bytes(), "f.csv")?;
        let cols = t.require(&["t", "x"], "t, x")?;
        t.read(&cols, &["t", "x"])
    }

    fn line_of(e: RecordError) -> u64 {
        match e {
            RecordError::Line { line, .. } => line,
            other => panic!("unexpected {other}"),
        }
    }

    #[test]
    fn bad_cells_report_their_line() {
        assert_eq!(line_of(read("t,x\n0,1\n1,abc\n").unwrap_err()), 3);
        assert_eq!(line_of(read("t,x\n0,1\n1,NaN\n").unwrap_err()), 3);
        assert_eq!(line_of(read("t,x\n0,1\n# c\n1\n").unwrap_err()), 4);
        let e = read("t,x\n0,1\n1,2\n1,3\n").unwrap_err();
        assert!(e.to_string().contains("not increasing"), "{e}");
        assert_eq!(line_of(e), 4);
    }

    #[test]
    fn missing_column_lists_what_was_found() {
        let e = read("t,y\n0,1\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "f.csv: missing column \"x\" (found columns: t, y); expected a header with t, x"
        );
        let e = read("").unwrap_err();
        assert!(e.to_string().contains("found columns: none"), "{e}");
    }

    #[test]
    fn header_is_case_insensitive_and_extra_columns_are_ignored() {
        let data = read(" X ,extra, T\n1,a,0\n2,b,0.5\n").unwrap();
        assert_eq!(data, vec![vec![0.0, 0.5], vec![1.0, 2.0]]);
        let data = read("# made by a logger\n\n\"t\",\"x\"\r\n0,1\r\n\r\n1,2\r\n").unwrap();
        assert_eq!(data, vec![vec![0.0, 1.0], vec![1.0, 2.0]]);
        assert_eq!(line_of(read("t,x\n\n\n0,1\n1,z\n").unwrap_err()), 5);
    }

    /// Reference: the second hardening review, "a CSV with a truncated last row or one extra field is read
    /// silently". Goal: a row with a field too few or too many (also in a column not read)
    /// and a last line without its line end are refused with their line.
    #[test]
    fn rows_are_strict_and_a_cut_off_last_line_is_refused() {
        let e = read("t,x,u\n0,1,2\n1,2\n").unwrap_err();
        assert!(
            e.to_string().contains("2 fields, but the header has 3"),
            "{e}"
        );
        assert!(e.to_string().contains("cut short"), "{e}");
        assert_eq!(line_of(e), 3);
        let e = read("t,x\n0,1\n1,2,3\n2,3\n").unwrap_err();
        assert!(e.to_string().contains("an extra field"), "{e}");
        assert_eq!(line_of(e), 3);
        let e = read("t,x\n0,1\n1,2\n2,3").unwrap_err();
        assert!(e.to_string().contains("no line end"), "{e}");
        assert_eq!(line_of(e), 4);
        // A comment or blank line at the end needs no line end; CRLF ends a line.
        assert_eq!(
            read("t,x\r\n0,1\r\n# end").unwrap(),
            vec![vec![0.0], vec![1.0]]
        );
    }

    #[test]
    fn invalid_text_reports_its_line() {
        let t = NumericCsv::open(&b"t,x\n0,1\n\xff,2\n"[..], "f.csv").unwrap();
        let e = t.read(&[0, 1], &["t", "x"]).unwrap_err();
        assert!(e.to_string().contains("cannot read the line"), "{e}");
        assert_eq!(line_of(e), 3);
    }
}
