//! [`LabLog`]: what a rig records, and its CSV file (`docs/formats.md`, "Time log").

use std::fmt::Write as _;
use std::io::Read;

use flexstage_numerics::DataError;
use flexstage_numerics::records::{NumericCsv, RecordError};

use crate::error::{IdentifyError, Result};

/// The columns of a time log, in file order.
pub const LOG_COLUMNS: [&str; 5] = ["t", "command1", "command2", "reading1", "reading2"];

/// What a rig records at its controller's sample time, and nothing else: per sample k the
/// two DAC commands (x_nom \[m\], issued right after the readings of sample k and held until
/// sample k + 1) and the two ADC readings (the measured output \[m\] at t_k = k·T).
#[derive(Debug, Clone, PartialEq)]
pub struct LabLog {
    sample_time: f64,
    command: [Vec<f64>; 2],
    reading: [Vec<f64>; 2],
}

impl LabLog {
    /// A log of `sample_time` \[s\] (> 0) with equally long, finite channels of at least 2
    /// samples.
    pub fn new(sample_time: f64, command: [Vec<f64>; 2], reading: [Vec<f64>; 2]) -> Result<Self> {
        crate::error::check(
            "log.sample_time",
            sample_time,
            sample_time > 0.0 && sample_time.is_finite(),
            "a time > 0 [s]",
        )?;
        let n = command[0].len();
        for (name, ch) in [
            ("command1", &command[0]),
            ("command2", &command[1]),
            ("reading1", &reading[0]),
            ("reading2", &reading[1]),
        ] {
            if ch.len() != n || n < 2 {
                return Err(data(format!(
                    "channel {name} has {} samples, command1 {n}: every channel needs the same \
                     number, at least 2",
                    ch.len()
                )));
            }
            if let Some(k) = ch.iter().position(|v| !v.is_finite()) {
                return Err(data(format!(
                    "channel {name} sample {k} is {}: every value must be finite",
                    ch[k]
                )));
            }
        }
        Ok(LabLog {
            sample_time,
            command,
            reading,
        })
    }

    /// The sample time \[s\].
    pub fn sample_time(&self) -> f64 {
        self.sample_time
    }

    /// The number of samples.
    pub fn len(&self) -> usize {
        self.command[0].len()
    }

    /// Whether the log holds no sample (never: [`LabLog::new`] asks for 2).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The DAC commands x_nom1, x_nom2 \[m\].
    pub fn command(&self) -> &[Vec<f64>; 2] {
        &self.command
    }

    /// The ADC readings y1, y2 \[m\].
    pub fn reading(&self) -> &[Vec<f64>; 2] {
        &self.reading
    }

    /// The log as CSV text (`docs/formats.md`): a header `t,command1,command2,reading1,reading2`
    /// and one line per sample with t_k = k·T; every number in Rust's shortest round-trip
    /// form, so [`LabLog::from_csv`] gives back the same log bit for bit.
    pub fn to_csv(&self) -> String {
        let mut s = String::with_capacity(self.len() * 96);
        s.push_str(&LOG_COLUMNS.join(","));
        s.push('\n');
        for k in 0..self.len() {
            let _ = writeln!(
                s,
                "{:e},{:e},{:e},{:e},{:e}",
                k as f64 * self.sample_time,
                self.command[0][k],
                self.command[1][k],
                self.reading[0][k],
                self.reading[1][k]
            );
        }
        s
    }

    /// Reads a time log (`docs/formats.md`); `origin` names the file in errors. The sample
    /// time is t₁ − t₀; every t_k must lie within 10⁻⁶ T of t₀ + k·T.
    pub fn from_csv(reader: impl Read, origin: &str) -> Result<LabLog> {
        let table = NumericCsv::open(reader, origin)?;
        let cols = table.require(&LOG_COLUMNS, &LOG_COLUMNS.join(", "))?;
        let mut d = table.read(&cols, &LOG_COLUMNS)?.into_iter();
        let mut next = || d.next().unwrap_or_default();
        let t = next();
        let command = [next(), next()];
        let reading = [next(), next()];
        if t.len() < 2 {
            return Err(RecordError::whole(
                origin,
                DataError::new(
                    "log",
                    format!("{} samples; a log needs at least 2", t.len()),
                ),
            )
            .into());
        }
        let ts = t[1] - t[0];
        if let Some(k) = (0..t.len()).find(|&k| {
            let expect = t[0] + k as f64 * ts;
            (t[k] - expect).abs() > 1e-6 * ts
        }) {
            return Err(RecordError::whole(
                origin,
                DataError::new(
                    "t",
                    format!(
                        "sample {k} at {} s, not t₀ + k·T = {} s: a log is sampled uniformly",
                        t[k],
                        t[0] + k as f64 * ts
                    ),
                ),
            )
            .into());
        }
        LabLog::new(ts, command, reading)
    }
}

/// A [`DataError`] of the log.
fn data(reason: String) -> IdentifyError {
    IdentifyError::Data(DataError::new("log", reason))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Goal: write → read gives the same log bit for bit (values chosen to need all 17
    /// significant digits, a subnormal and a negative zero), and a non-uniform time axis is
    /// refused naming the sample.
    #[test]
    fn a_log_written_and_read_back_is_bitwise_the_same_and_a_gap_is_refused() {
        let ts = 1.0 / 12_345.0;
        let c = [
            vec![0.1 + 0.2, -1e-300, 5e-324, -0.0],
            vec![1.0 / 3.0, 2e-6, -7.123456789012345e-9, 1e10],
        ];
        let r = [vec![f64::MIN_POSITIVE, 1.0, -2.5, 3.3e-7], vec![0.0; 4]];
        let log = LabLog::new(ts, c, r).unwrap();
        let back = LabLog::from_csv(log.to_csv().as_bytes(), "log.csv").unwrap();
        assert_eq!(back.sample_time().to_bits(), ts.to_bits());
        for i in 0..2 {
            for k in 0..4 {
                assert_eq!(
                    back.command()[i][k].to_bits(),
                    log.command()[i][k].to_bits()
                );
                assert_eq!(
                    back.reading()[i][k].to_bits(),
                    log.reading()[i][k].to_bits()
                );
            }
        }
        let text = "t,command1,command2,reading1,reading2\n0,0,0,0,0\n1,0,0,0,0\n2.5,0,0,0,0\n";
        let err = LabLog::from_csv(text.as_bytes(), "gap.csv")
            .unwrap_err()
            .to_string();
        assert!(err.contains("gap.csv") && err.contains("sample 2"), "{err}");
    }
}
