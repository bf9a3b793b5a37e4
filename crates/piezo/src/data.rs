//! Measured or simulated actuator records (t, U, x) and their CSV form.

use std::io::Read;

use crate::error::{PiezoError, Result, data_error};

/// A record of one actuator: time t [s], voltage U [V] and displacement x [µm].
///
/// Invariants (checked by [`PeaData::new`]): equal lengths, at least 3 samples, every value
/// finite, time strictly increasing.
#[derive(Debug, Clone, PartialEq)]
pub struct PeaData {
    t: Vec<f64>,
    u: Vec<f64>,
    x: Vec<f64>,
}

impl PeaData {
    /// Checks and wraps the three columns.
    pub fn new(t: Vec<f64>, u: Vec<f64>, x: Vec<f64>) -> Result<Self> {
        if t.len() != u.len() || t.len() != x.len() {
            return Err(data_error(
                "pea data",
                format!(
                    "columns t, U, x have different lengths {}, {}, {}",
                    t.len(),
                    u.len(),
                    x.len()
                ),
            ));
        }
        if t.len() < 3 {
            return Err(data_error(
                "pea data",
                format!("need at least 3 samples, got {}", t.len()),
            ));
        }
        for (name, col) in [("t", &t), ("U", &u), ("x", &x)] {
            if let Some(k) = col.iter().position(|v| !v.is_finite()) {
                return Err(data_error(
                    "pea data",
                    format!("{name}[{k}] = {} is not a finite number", col[k]),
                ));
            }
        }
        if let Some(k) = (1..t.len()).find(|&k| t[k] <= t[k - 1]) {
            return Err(data_error(
                "pea data",
                format!(
                    "time must increase strictly: t[{k}] = {} after t[{}] = {}",
                    t[k],
                    k - 1,
                    t[k - 1]
                ),
            ));
        }
        Ok(PeaData { t, u, x })
    }

    /// Reads CSV text with a header naming the columns `t` [s], `U` [V] and `x` [µm] (any
    /// order, names case-insensitive, extra columns ignored, `#` comment lines skipped).
    /// `origin` (usually the file name) prefixes error messages, which give the 1-based line
    /// number for a missing or non-numeric cell, a NaN or infinity, and non-increasing time.
    pub fn from_csv(reader: impl Read, origin: &str) -> Result<Self> {
        let table = NumericCsv::open(reader, origin)?;
        let names = ["t", "U", "x"];
        let mut cols = [0usize; 3];
        for (c, name) in cols.iter_mut().zip(names) {
            *c = table
                .position(name)
                .ok_or_else(|| PiezoError::MissingColumn {
                    origin: origin.to_string(),
                    column: name,
                    found: table.found(),
                })?;
        }
        let [t, u, x]: [Vec<f64>; 3] = table
            .read(&cols, &names)?
            .try_into()
            .expect("one vector per requested column");
        PeaData::new(t, u, x).map_err(|e| match e {
            PiezoError::Data { reason, .. } => PiezoError::Csv {
                origin: origin.to_string(),
                line: 0,
                reason,
            },
            other => other,
        })
    }

    /// CSV text with header `t,U,x`, exact round-trip number format.
    pub fn to_csv(&self) -> String {
        let mut out = String::from("t,U,x\n");
        for k in 0..self.len() {
            out.push_str(&format!("{},{},{}\n", self.t[k], self.u[k], self.x[k]));
        }
        out
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Always false (at least 3 samples); for API completeness.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Time [s].
    pub fn t(&self) -> &[f64] {
        &self.t
    }

    /// Voltage [V].
    pub fn u(&self) -> &[f64] {
        &self.u
    }

    /// Displacement [µm].
    pub fn x(&self) -> &[f64] {
        &self.x
    }
}

/// A CSV file of named numeric columns: one header row, names matched case-insensitively,
/// extra columns ignored, `#` comment lines skipped, cells trimmed. Shared by the PEA records
/// here and the stage records of `flexstage-identify`, so both report bad files alike: every
/// error names the origin and the 1-based line ([`PiezoError::Csv`]).
pub struct NumericCsv<R> {
    reader: csv::Reader<R>,
    headers: csv::StringRecord,
    origin: String,
}

impl<R: Read> NumericCsv<R> {
    /// Opens the table and reads its header row.
    pub fn open(reader: R, origin: &str) -> Result<Self> {
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(true)
            .trim(csv::Trim::All)
            .comment(Some(b'#'))
            .flexible(true)
            .from_reader(reader);
        let headers = reader.headers().map_err(|e| csv_error(origin, e))?.clone();
        Ok(NumericCsv {
            reader,
            headers,
            origin: origin.to_string(),
        })
    }

    /// The index of the column called `name` (case-insensitive), if present.
    pub fn position(&self, name: &str) -> Option<usize> {
        self.headers
            .iter()
            .position(|h| h.eq_ignore_ascii_case(name))
    }

    /// The header names, comma-separated ("none" for an empty header), for error messages.
    pub fn found(&self) -> String {
        if self.headers.is_empty() {
            "none".into()
        } else {
            self.headers.iter().collect::<Vec<_>>().join(", ")
        }
    }

    /// Reads the columns at `cols` (called `names` in messages), one vector per column. Every
    /// cell must be a finite number, and the first column (time) must strictly increase.
    pub fn read(mut self, cols: &[usize], names: &[&str]) -> Result<Vec<Vec<f64>>> {
        let origin = self.origin.as_str();
        let mut data = vec![Vec::new(); cols.len()];
        let mut record = csv::StringRecord::new();
        let mut prev_t: Option<(f64, u64)> = None;
        loop {
            match self.reader.read_record(&mut record) {
                Ok(true) => {}
                Ok(false) => break,
                Err(e) => return Err(csv_error(origin, e)),
            }
            let line = record.position().map(|p| p.line()).unwrap_or(0);
            let bad = |reason: String| PiezoError::Csv {
                origin: origin.to_string(),
                line,
                reason,
            };
            for (i, &c) in cols.iter().enumerate() {
                let cell = record.get(c).ok_or_else(|| {
                    bad(format!(
                        "missing value for column {} (the row has {} fields)",
                        names[i],
                        record.len()
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
                && tk <= tp
            {
                return Err(bad(format!(
                    "time is not increasing: t = {tk} after t = {tp} on line {lp}"
                )));
            }
            prev_t = Some((tk, line));
        }
        Ok(data)
    }
}

fn csv_error(origin: &str, e: csv::Error) -> PiezoError {
    PiezoError::Csv {
        origin: origin.to_string(),
        line: e.position().map(|p| p.line()).unwrap_or(0),
        reason: e.to_string(),
    }
}
