//! Logged stage records (t, x_nom or U, x_in1, x_in2, q1, q2) and their CSV form.
//!
//! Units are SI: t \[s\], x_nom, x_in, q \[m\], U \[V\]. The record must be sampled uniformly
//! (the regression of Eq. 54–56 is written at a fixed sample time T_s).

use std::io::Read;

use flexstage_numerics::DataError;
use flexstage_numerics::records::{NumericCsv, RecordError};
use flexstage_piezo::{BoucWen, BoucWenParams, MICROMETRE};
use flexstage_sim::pea::preload;

use crate::error::{IdentifyError, Result};

/// Fewest samples [`StageRecord::new`] accepts: two for the two-step delays of Eq. (54)
/// plus enough equations for the 16 regression parameters several times over.
pub const MIN_SAMPLES: usize = 200;

/// A uniformly sampled record of the stage.
///
/// Invariants (checked by [`StageRecord::new`]): equal lengths, at least [`MIN_SAMPLES`]
/// samples, every value finite and within ±1 m (displacements), ±1e5 V (voltages), 1e9 s
/// (time), time strictly increasing and uniform within the tolerance.
#[derive(Debug, Clone, PartialEq)]
pub struct StageRecord {
    /// Time \[s\].
    pub t: Vec<f64>,
    /// Nominal PEA displacements x_nom1, x_nom2 \[m\] (the input u of Eq. 36).
    pub x_nom: [Vec<f64>; 2],
    /// Input plate displacements x_in1, x_in2 \[m\].
    pub x_in: [Vec<f64>; 2],
    /// Output displacements q1, q2 \[m\].
    pub q: [Vec<f64>; 2],
    /// Amplifier voltages U1, U2 \[V\], when the record has them.
    pub voltage: Option<[Vec<f64>; 2]>,
}

/// The input columns of a CSV record before conversion: x_nom directly, or voltages that
/// the PEA model turns into x_nom.
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// x_nom1, x_nom2 \[m\].
    Nominal([Vec<f64>; 2]),
    /// U1, U2 \[V\].
    Voltage([Vec<f64>; 2]),
}

impl StageRecord {
    /// Checks and wraps the columns. `tolerance` is the largest accepted relative deviation
    /// of a time step from the mean step (e.g. 1e-3).
    pub fn new(
        t: Vec<f64>,
        x_nom: [Vec<f64>; 2],
        x_in: [Vec<f64>; 2],
        q: [Vec<f64>; 2],
        voltage: Option<[Vec<f64>; 2]>,
        tolerance: f64,
    ) -> Result<Self> {
        let n = t.len();
        let mut cols: Vec<(&str, &Vec<f64>)> = vec![
            ("t", &t),
            ("x_nom1", &x_nom[0]),
            ("x_nom2", &x_nom[1]),
            ("x_in1", &x_in[0]),
            ("x_in2", &x_in[1]),
            ("q1", &q[0]),
            ("q2", &q[1]),
        ];
        if let Some(v) = &voltage {
            cols.push(("U1", &v[0]));
            cols.push(("U2", &v[1]));
        }
        for (name, c) in &cols {
            if c.len() != n {
                return Err(DataError::new(
                    "stage record",
                    format!("column {name} has {} samples, t has {n}", c.len()),
                )
                .into());
            }
            if let Some(k) = c.iter().position(|v| !v.is_finite()) {
                return Err(DataError::new(
                    "stage record",
                    format!("{name}[{k}] = {} is not a finite number", c[k]),
                )
                .into());
            }
            // Magnitudes beyond any stage (displacements ±1 m, voltages ±1e5 V, times 1e9 s)
            // are a unit error: x_nom1 × 1e300 left the x_in1 regression at its guess.
            let (limit, unit) = match name.as_bytes()[0] {
                b't' => (1e9, "s"),
                b'U' => (1e5, "V"),
                _ => (1.0, "m"),
            };
            if let Some(k) = c.iter().position(|v| v.abs() > limit) {
                return Err(DataError::new(
                    "stage record",
                    format!(
                        "{name}[{k}] = {:e} is beyond ±{} {unit} (displacements in m, \
                         voltages in V, time in s)",
                        c[k],
                        flexstage_numerics::compact(limit)
                    ),
                )
                .into());
            }
        }
        if n < MIN_SAMPLES {
            return Err(DataError::new(
                "stage record",
                format!(
                    "too few samples: {n}, need at least {MIN_SAMPLES} (and about 2 s at 10 kHz, \
                     20 000 samples, for 1 % stiffness estimates)"
                ),
            )
            .into());
        }
        check_uniform(&t, tolerance)?;
        Ok(StageRecord {
            t,
            x_nom,
            x_in,
            q,
            voltage,
        })
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when empty (never, for a checked record).
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The sample time T_s \[s\]: the mean time step.
    pub fn sample_time(&self) -> f64 {
        (self.t[self.t.len() - 1] - self.t[0]) / (self.t.len() - 1) as f64
    }

    /// Reads CSV text with a header naming the columns `t`, `x_nom1`, `x_nom2` (or `U1`,
    /// `U2`), `x_in1`, `x_in2`, `q1`, `q2` (any order, names case-insensitive, extra columns
    /// ignored, `#` comment lines skipped). Errors name the file, 1-based line and column.
    /// Returns the columns and the input as found; see [`StageRecord::from_input`].
    pub fn read_csv(reader: impl Read, origin: &str) -> Result<(Vec<f64>, Input, Columns)> {
        let table = NumericCsv::open(reader, origin)?;
        let nominal = table.position("x_nom1").is_some() || table.position("x_nom2").is_some();
        let input_names = if nominal || table.position("U1").is_none() {
            ["x_nom1", "x_nom2"]
        } else {
            ["U1", "U2"]
        };
        let names = [
            "t",
            input_names[0],
            input_names[1],
            "x_in1",
            "x_in2",
            "q1",
            "q2",
        ];
        let cols = table.require(
            &names,
            "t, x_nom1, x_nom2 (or U1, U2), x_in1, x_in2, q1, q2",
        )?;
        let data: [Vec<f64>; 7] = table
            .read(&cols, &names)?
            .try_into()
            .expect("one vector per requested column");
        let [t, i1, i2, x1, x2, q1, q2] = data;
        let input = if input_names[0] == "U1" {
            Input::Voltage([i1, i2])
        } else {
            Input::Nominal([i1, i2])
        };
        Ok((
            t,
            input,
            Columns {
                x_in: [x1, x2],
                q: [q1, q2],
            },
        ))
    }

    /// Builds a record from CSV columns. Voltages are turned into x_nom with the Bouc–Wen
    /// models `hysteresis` of the two PEAs, preloaded to `bias_voltage` and ramped linearly
    /// between samples (x_nom = x_pea − x_bias, as in flexstage-control's plant).
    pub fn from_input(
        t: Vec<f64>,
        input: Input,
        columns: Columns,
        hysteresis: &[BoucWenParams; 2],
        bias_voltage: f64,
        tolerance: f64,
    ) -> Result<Self> {
        match input {
            Input::Nominal(x_nom) => {
                StageRecord::new(t, x_nom, columns.x_in, columns.q, None, tolerance)
            }
            Input::Voltage(u) => {
                let x_nom =
                    [0, 1].map(|i| voltage_to_x_nom(&t, &u[i], &hysteresis[i], bias_voltage));
                StageRecord::new(t, x_nom, columns.x_in, columns.q, Some(u), tolerance)
            }
        }
    }

    /// Reads a CSV record ([`StageRecord::read_csv`] then [`StageRecord::from_input`]).
    pub fn from_csv(
        reader: impl Read,
        origin: &str,
        hysteresis: &[BoucWenParams; 2],
        bias_voltage: f64,
        tolerance: f64,
    ) -> Result<Self> {
        let (t, input, columns) = StageRecord::read_csv(reader, origin)?;
        StageRecord::from_input(t, input, columns, hysteresis, bias_voltage, tolerance).map_err(
            |e| match e {
                IdentifyError::Data(e) => RecordError::whole(origin, e).into(),
                other => other,
            },
        )
    }

    /// CSV text with header `t,x_nom1,x_nom2[,U1,U2],x_in1,x_in2,q1,q2` (SI), exact
    /// round-trip number format.
    pub fn to_csv(&self) -> String {
        let mut out = String::from("t,x_nom1,x_nom2,");
        if self.voltage.is_some() {
            out.push_str("U1,U2,");
        }
        out.push_str("x_in1,x_in2,q1,q2\n");
        for k in 0..self.len() {
            out.push_str(&format!(
                "{},{},{},",
                self.t[k], self.x_nom[0][k], self.x_nom[1][k]
            ));
            if let Some(v) = &self.voltage {
                out.push_str(&format!("{},{},", v[0][k], v[1][k]));
            }
            out.push_str(&format!(
                "{},{},{},{}\n",
                self.x_in[0][k], self.x_in[1][k], self.q[0][k], self.q[1][k]
            ));
        }
        out
    }
}

/// The measured columns of a CSV record.
#[derive(Debug, Clone, PartialEq)]
pub struct Columns {
    /// x_in1, x_in2 \[m\].
    pub x_in: [Vec<f64>; 2],
    /// q1, q2 \[m\].
    pub q: [Vec<f64>; 2],
}

/// x_nom \[m\] of a PEA driven by the voltage samples `u` \[V\] (linear between samples),
/// starting from the preloaded state at `bias_voltage`.
pub fn voltage_to_x_nom(t: &[f64], u: &[f64], p: &BoucWenParams, bias_voltage: f64) -> Vec<f64> {
    let (ub, hb, x_bias) = preload(p, bias_voltage);
    let mut pea = BoucWen::with_state(*p, ub, hb);
    let mut out = Vec::with_capacity(u.len());
    for k in 0..u.len() {
        let dt = if k == 0 { 0.0 } else { t[k] - t[k - 1] };
        let x = pea.step(u[k], dt);
        out.push((x - x_bias) * MICROMETRE);
    }
    out
}

/// Checks that `t` is strictly increasing and uniform: every step within `tolerance`
/// (relative) of the mean step.
pub fn check_uniform(t: &[f64], tolerance: f64) -> Result<()> {
    let n = t.len();
    if n < 2 {
        return Err(DataError::new("stage record", "need at least 2 time samples").into());
    }
    let ts = (t[n - 1] - t[0]) / (n - 1) as f64;
    if ts.is_nan() || ts <= 0.0 {
        return Err(DataError::new(
            "stage record",
            format!(
                "time must increase: t[0] = {}, t[{}] = {}",
                t[0],
                n - 1,
                t[n - 1]
            ),
        )
        .into());
    }
    for k in 1..n {
        let dt = t[k] - t[k - 1];
        if (dt - ts).abs() > tolerance * ts {
            return Err(DataError::new(
                "stage record",
                format!(
                    "non-uniform sampling: step t[{k}] − t[{}] = {dt:e} s differs from the mean \
                     step T_s = {ts:e} s by more than {:.3} % (resample the record to a fixed \
                     sample time; the regression of Eq. 54–56 assumes one)",
                    k - 1,
                    tolerance * 100.0
                ),
            )
            .into());
        }
    }
    Ok(())
}
