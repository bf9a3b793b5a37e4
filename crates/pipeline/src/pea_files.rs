//! The result files of the PEA identification ([`PeaIdentification`]): the estimates, the
//! convergence history (Figure A2) and the record against the identified model.

use flexstage_piezo::{BoucWenParams, HistoryPoint, LoopMetrics, PeaData, simulate};
use flexstage_report::layout::PeaIdentification;
use flexstage_report::plot::{Figure, Series};
use flexstage_report::{RunDir, csv_columns};
use serde::Serialize;

use crate::error::{PipelineError, Result};
use crate::pea::{PeaEstimate, PeaIdSummary};

/// Everything the files are made from.
pub(crate) struct Outputs<'a> {
    pub run: &'a RunDir,
    pub out: PeaIdentification,
    pub data: &'a PeaData,
    pub summary: &'a PeaIdSummary,
    /// The scenario's parameters of this PEA.
    pub reference: BoucWenParams,
    /// The recommended estimate.
    pub best: BoucWenParams,
    /// Hysteresis of the record.
    pub record: LoopMetrics,
    /// Convergence of the parallel RLS.
    pub history: &'a [HistoryPoint],
}

#[derive(Serialize)]
struct Estimates {
    /// Record identified.
    data: String,
    samples: usize,
    /// Which estimate is recommended and used for loop.svg: the one with the lower RMS error
    /// of the simulated model along the record.
    recommended: &'static str,
    recommended_params: BoucWenParams,
    parallel_rls: Method,
    batch: Method,
    /// The scenario's parameters of this PEA, for comparison.
    scenario: BoucWenParams,
    /// Hysteresis of the record: width and maximum deviation from linear, % of range.
    record_width_pct: f64,
    record_max_deviation_pct: f64,
}

#[derive(Serialize)]
struct Method {
    params: BoucWenParams,
    /// RMS of x − x_model along the record \[µm\].
    rms_error_um: f64,
    /// Relative difference to the scenario's parameters \[%\].
    difference_to_scenario_pct: Diff,
}

#[derive(Serialize)]
struct Diff {
    d_p: f64,
    a_bw: f64,
    b_bw: f64,
    gamma_bw: f64,
    delta_bw: f64,
}

/// One parameter of [`BoucWenParams`].
type Getter = fn(&BoucWenParams) -> f64;

/// The parameters: (file name, display name, getter).
const PARAMETERS: [(&str, &str, Getter); 5] = [
    ("d_p", "d_p", |p| p.d_p),
    ("a_bw", "A_bw", |p| p.a_bw),
    ("b_bw", "B_bw", |p| p.b_bw),
    ("gamma_bw", "Γ_bw", |p| p.gamma_bw),
    ("delta_bw", "δ_bw", |p| p.delta_bw),
];

fn method(e: &PeaEstimate, reference: &BoucWenParams) -> Method {
    let r = |f: Getter| {
        let (x, y) = (f(&e.params), f(reference));
        if y != 0.0 {
            100.0 * (x - y) / y
        } else {
            f64::NAN
        }
    };
    Method {
        params: e.params,
        rms_error_um: e.rms_error,
        difference_to_scenario_pct: Diff {
            d_p: r(PARAMETERS[0].2),
            a_bw: r(PARAMETERS[1].2),
            b_bw: r(PARAMETERS[2].2),
            gamma_bw: r(PARAMETERS[3].2),
            delta_bw: r(PARAMETERS[4].2),
        },
    }
}

impl Outputs<'_> {
    /// Writes every file of the folder.
    pub fn write(&self) -> Result<()> {
        self.write_estimates()?;
        self.write_convergence()?;
        self.write_loop()
    }

    fn write_estimates(&self) -> Result<()> {
        let s = self.summary;
        let estimates = Estimates {
            data: s.data.display().to_string(),
            samples: s.samples,
            recommended: s.recommended,
            recommended_params: self.best,
            parallel_rls: method(&s.online, &self.reference),
            batch: method(&s.batch, &self.reference),
            scenario: self.reference,
            record_width_pct: self.record.width_pct,
            record_max_deviation_pct: self.record.max_deviation_pct,
        };
        let body = toml::to_string_pretty(&estimates).map_err(|e| PipelineError::Format {
            path: self.out.estimates(),
            reason: e.to_string(),
        })?;
        let text = format!(
            "# Bouc–Wen estimates, Eq. (18) with n = 1: x, h in µm, U in V, t in s\n\
             # (d_p, a_bw in µm/V; b_bw, gamma_bw in 1/V; delta_bw in µm/(V·s)).\n{body}"
        );
        self.run.write(self.out.estimates(), text.as_bytes())?;
        Ok(())
    }

    /// Convergence history (Figure A2): each estimate divided by the batch estimate, so that
    /// the five parameters share one axis and converge to 1.
    fn write_convergence(&self) -> Result<()> {
        let h = self.history;
        let t: Vec<f64> = h.iter().map(|p| p.t).collect();
        let values: Vec<Vec<f64>> = PARAMETERS
            .iter()
            .map(|c| h.iter().map(|p| (c.2)(&p.estimate)).collect())
            .collect();
        let mut header = vec!["t"];
        header.extend(PARAMETERS.iter().map(|c| c.0));
        let mut columns: Vec<&[f64]> = vec![&t];
        columns.extend(values.iter().map(Vec::as_slice));
        self.run.write(
            self.out.convergence_csv(),
            csv_columns(&header, &columns).as_bytes(),
        )?;
        let mut fig = Figure::new(
            "Parallel RLS convergence (estimate / batch estimate)",
            "t [s]",
            "relative estimate [-]",
        );
        for (c, v) in PARAMETERS.iter().zip(&values) {
            let final_value = (c.2)(&self.summary.batch.params);
            let points = t
                .iter()
                .zip(v)
                .map(|(&t, &v)| (t, (v / final_value).clamp(-2.0, 4.0)))
                .collect();
            fig = fig.with(Series::line(c.1, points));
        }
        self.run
            .write(self.out.convergence_svg(), fig.to_svg()?.as_bytes())?;
        Ok(())
    }

    fn write_loop(&self) -> Result<()> {
        let d = self.data;
        let x_model = simulate(&self.best, d.t(), d.u(), 0.0);
        let csv = csv_columns(
            &["t", "U", "x", "x_model"],
            &[d.t(), d.u(), d.x(), &x_model],
        );
        self.run.write(self.out.loop_csv(), csv.as_bytes())?;
        let pairs = |x: &[f64], y: &[f64]| x.iter().copied().zip(y.iter().copied()).collect();
        let fig = Figure::new(
            format!(
                "Hysteresis loop: measured and identified model ({})",
                self.summary.recommended
            ),
            "U [V]",
            "x [µm]",
        )
        .with(Series::line("measured", pairs(d.u(), d.x())))
        .with(Series::line("model", pairs(d.u(), &x_model)));
        self.run
            .write(self.out.loop_svg(), fig.to_svg()?.as_bytes())?;
        Ok(())
    }
}
