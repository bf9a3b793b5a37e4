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
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(true)
            .trim(csv::Trim::All)
            .comment(Some(b'#'))
            .flexible(true)
            .from_reader(reader);
        let csv_err = |e: csv::Error| {
            let line = e.position().map(|p| p.line()).unwrap_or(0);
            PiezoError::Csv {
                origin: origin.to_string(),
                line,
                reason: e.to_string(),
            }
        };
        let headers = rdr.headers().map_err(csv_err)?.clone();
        let find = |name: &'static str| {
            headers
                .iter()
                .position(|h| h.eq_ignore_ascii_case(name))
                .ok_or_else(|| PiezoError::MissingColumn {
                    origin: origin.to_string(),
                    column: name,
                    found: if headers.is_empty() {
                        "none".into()
                    } else {
                        headers.iter().collect::<Vec<_>>().join(", ")
                    },
                })
        };
        let cols = [find("t")?, find("U")?, find("x")?];
        let names = ["t", "U", "x"];
        let (mut t, mut u, mut x) = (Vec::new(), Vec::new(), Vec::new());
        let mut record = csv::StringRecord::new();
        let mut prev_t: Option<(f64, u64)> = None;
        loop {
            match rdr.read_record(&mut record) {
                Ok(true) => {}
                Ok(false) => break,
                Err(e) => return Err(csv_err(e)),
            }
            let line = record.position().map(|p| p.line()).unwrap_or(0);
            let mut vals = [0.0; 3];
            for (i, &c) in cols.iter().enumerate() {
                let bad = |reason: String| PiezoError::Csv {
                    origin: origin.to_string(),
                    line,
                    reason,
                };
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
                vals[i] = v;
            }
            if let Some((tp, lp)) = prev_t
                && vals[0] <= tp
            {
                return Err(PiezoError::Csv {
                    origin: origin.to_string(),
                    line,
                    reason: format!(
                        "time is not increasing: t = {} after t = {tp} on line {lp}",
                        vals[0]
                    ),
                });
            }
            prev_t = Some((vals[0], line));
            t.push(vals[0]);
            u.push(vals[1]);
            x.push(vals[2]);
        }
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
