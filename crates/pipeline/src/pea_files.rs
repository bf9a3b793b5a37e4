//! The result files of the PEA identification ([`PeaIdentification`]): the estimates, the
//! convergence history (Figure A2) and the record against the identified model.

use flexstage_figures::plot::{Figure, Series};
use flexstage_piezo::{BoucWenParams, HistoryPoint, LoopMetrics, PeaData, simulate};
use flexstage_run::files::pea::{Method, PeaEstimates, VERSION};
use flexstage_run::layout::PeaIdentification;
use flexstage_run::{RunDir, Table};
use flexstage_scenario::BoucWen;

use crate::error::Result;
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
        params: BoucWen::from(&e.params),
        rms_error_um: e.rms_error,
        difference_to_scenario_pct: BoucWen {
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
        let estimates = PeaEstimates {
            version: VERSION,
            data: s.data.display().to_string(),
            samples: s.samples,
            recommended: s.recommended.to_string(),
            record_width_pct: self.record.width_pct,
            record_max_deviation_pct: self.record.max_deviation_pct,
            recommended_params: BoucWen::from(&self.best),
            parallel_rls: method(&s.online, &self.reference),
            batch: method(&s.batch, &self.reference),
            scenario: BoucWen::from(&self.reference),
        };
        self.run.store(&self.out.estimates(), estimates)?;
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
        let mut columns = vec![t.clone()];
        columns.extend(values.iter().cloned());
        self.run
            .store(&self.out.convergence_csv(), Table::new(&header, columns))?;
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
            .write(&self.out.convergence_svg(), fig.to_svg()?.as_bytes())?;
        Ok(())
    }

    fn write_loop(&self) -> Result<()> {
        let d = self.data;
        let x_model = simulate(&self.best, d.t(), d.u(), 0.0);
        let table = Table::of(
            &["t", "U", "x", "x_model"],
            &[d.t(), d.u(), d.x(), &x_model],
        );
        self.run.store(&self.out.loop_csv(), table)?;
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
            .write(&self.out.loop_svg(), fig.to_svg()?.as_bytes())?;
        Ok(())
    }
}
