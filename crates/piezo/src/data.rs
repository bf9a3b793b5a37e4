//! Measured or simulated actuator records (t, U, x) and their CSV form.

use std::io::Read;

use flexstage_numerics::DataError;
pub use flexstage_numerics::records::NumericCsv;
use flexstage_numerics::records::RecordError;

use crate::error::{PiezoError, Result};

/// The columns of a PEA record, in the order of [`PeaData::new`].
const COLUMNS: [&str; 3] = ["t", "U", "x"];

/// A record of one actuator: time t \[s\], voltage U \[V\] and displacement x \[µm\].
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
    /// The three columns t \[s\], U \[V\], x \[µm\], moved out.
    pub fn into_columns(self) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        (self.t, self.u, self.x)
    }

    /// Checks and wraps the three columns.
    pub fn new(t: Vec<f64>, u: Vec<f64>, x: Vec<f64>) -> Result<Self> {
        if t.len() != u.len() || t.len() != x.len() {
            return Err(DataError::new(
                "pea data",
                format!(
                    "columns t, U, x have different lengths {}, {}, {}",
                    t.len(),
                    u.len(),
                    x.len()
                ),
            )
            .into());
        }
        if t.len() < 3 {
            return Err(DataError::new(
                "pea data",
                format!("need at least 3 samples, got {}", t.len()),
            )
            .into());
        }
        // Magnitudes beyond any PEA (|U| ≤ 1e5 V, |x| ≤ 1e6 µm, t within 1e9 s) would
        // overflow the estimators' products: refused as the unit error they are.
        for (name, col, limit) in [("t", &t, 1e9), ("U", &u, 1e5), ("x", &x, 1e6)] {
            if let Some(k) = col.iter().position(|v| !v.is_finite()) {
                return Err(DataError::new(
                    "pea data",
                    format!("{name}[{k}] = {} is not a finite number", col[k]),
                )
                .into());
            }
            if let Some(k) = col.iter().position(|v| v.abs() > limit) {
                return Err(DataError::new(
                    "pea data",
                    format!(
                        "{name}[{k}] = {:e} is beyond ±{limit:e} (t in s, U in V, x in µm)",
                        col[k]
                    ),
                )
                .into());
            }
        }
        if let Some(k) = (1..t.len()).find(|&k| t[k] <= t[k - 1]) {
            return Err(DataError::new(
                "pea data",
                format!(
                    "time must increase strictly: t[{k}] = {} after t[{}] = {}",
                    t[k],
                    k - 1,
                    t[k - 1]
                ),
            )
            .into());
        }
        Ok(PeaData { t, u, x })
    }

    /// Reads CSV text with a header naming the columns `t` \[s\], `U` \[V\] and `x` \[µm\] (any
    /// order, names case-insensitive, extra columns ignored, `#` comment lines skipped).
    /// `origin` (usually the file name) prefixes error messages, which give the 1-based line
    /// number for a missing or non-numeric cell, a NaN or infinity, and non-increasing time.
    pub fn from_csv(reader: impl Read, origin: &str) -> Result<Self> {
        let table = NumericCsv::open(reader, origin)?;
        let cols = table.require(&COLUMNS, "t, U, x")?;
        let [t, u, x]: [Vec<f64>; 3] = table
            .read(&cols, &COLUMNS)?
            .try_into()
            .expect("one vector per requested column");
        PeaData::new(t, u, x).map_err(|e| match e {
            PiezoError::Data(e) => RecordError::whole(origin, e).into(),
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

    /// Time \[s\].
    pub fn t(&self) -> &[f64] {
        &self.t
    }

    /// Voltage \[V\].
    pub fn u(&self) -> &[f64] {
        &self.u
    }

    /// Displacement \[µm\].
    pub fn x(&self) -> &[f64] {
        &self.x
    }
}
