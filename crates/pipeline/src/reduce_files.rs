//! The result files of `reduce` ([`flexstage_run::layout::reduce`]): the stage parameter
//! file, the summary (TOML and JSON), the mode shapes (VTU and pictures) and the validity map.

use flexstage_figures::plot::{Figure, Series};
use flexstage_reduce::{MassLumping, ReduceParams, Reduction, ValidityMap, ValiditySample};
use flexstage_run::files::reduce::{
    ModalSummary, ReduceSummaryFile, ReduceSummaryJson, ReduceSummaryToml, VERSION, ValiditySummary,
};
use flexstage_run::files::stage::StageParamsFile;
use flexstage_run::layout::reduce as files;
use flexstage_run::{RunDir, Table};
use flexstage_topopt::Problem;

use crate::error::Result;
use crate::source::DesignSource;

/// Everything the files are made from.
pub(crate) struct Outputs<'a> {
    pub run: &'a RunDir,
    pub design: &'a DesignSource,
    pub problem: &'a Problem,
    pub rho: &'a [f64],
    pub reduction: &'a Reduction,
    pub params: &'a ReduceParams,
}

impl Outputs<'_> {
    /// Writes every file of the stage.
    pub fn write(&self) -> Result<()> {
        self.write_params()?;
        self.write_summary()?;
        if self.reduction.modes.is_some() {
            self.write_modes()?;
        }
        if let Some(v) = &self.reduction.validity {
            write_validity_tables(self.run, v)?;
            write_validity_figures(self.run, v)?;
        }
        Ok(())
    }

    fn state(&self) -> String {
        match self.reduction.operating_point {
            None => "undeformed".to_string(),
            Some(x) => format!(
                "operating point x_nom = ({:.3}, {:.3}) um",
                x[0] * 1e6,
                x[1] * 1e6
            ),
        }
    }

    fn write_params(&self) -> Result<()> {
        let header = vec![
            "Reduced stage model (flexstage reduce), paper Eq. 31-35 / Appendix C, SI units."
                .into(),
            format!(
                "design: {}; tangent at the {} state.",
                self.design,
                self.state()
            ),
            "K_qo1, K_qo2, mass and alpha come from the design; K_pea, k_in, m_in from the \
             scenario,"
                .into(),
            "damping from stage.damping_ratio. The simulated plant of the run; `flexstage \
             track --params FILE` uses it as the controller's model."
                .into(),
        ];
        let file = StageParamsFile {
            header,
            documented: true,
            coupling: None,
            params: self.reduction.params.clone(),
        };
        self.run.store(files::PARAMS, file)?;
        Ok(())
    }

    fn write_summary(&self) -> Result<()> {
        let r = self.reduction;
        let c = &r.condensation;
        let summary = ReduceSummaryFile {
            version: VERSION,
            design: self.design.to_string(),
            mesh: [self.problem.mesh().nl, self.problem.mesh().nw],
            state: self.state(),
            alpha_global: c.alpha_abs,
            alpha_moving_frame: c.alpha,
            eq26_residuals: c.eq26_residuals(),
            tan_theta: c.tan_theta(),
            theta_deg: c.theta().to_degrees(),
            alpha_scalar: c.alpha_scalar(),
            a_theta: c.a_theta(),
            a_theta_residual: c.a_theta_residual(),
            output_compliance_m_per_n: c.compliance,
            output_stiffness_n_per_m: c.output_stiffness,
            k_qo1: c.k_qo1(),
            k_qo2: c.k_qo2(),
            mass_kg: r.mass,
            volume_fraction: r.volume_fraction,
            operating_output_um: r
                .operating_point
                .map(|_| [r.operating_output[0] * 1e6, r.operating_output[1] * 1e6]),
            modal: self.modal_summary(),
            validity: r.validity.as_ref().map(validity_summary),
        };
        self.run
            .store(files::SUMMARY_TOML, ReduceSummaryToml(summary.clone()))?;
        self.run
            .store(files::SUMMARY_JSON, ReduceSummaryJson(summary))?;
        Ok(())
    }

    fn modal_summary(&self) -> Option<ModalSummary> {
        let r = self.reduction;
        let m = r.modes.as_ref()?;
        let lumped = matches!(
            self.params.modal.map(|p| p.lumping),
            Some(MassLumping::Lumped)
        );
        let a2 = r.assumption2.as_ref();
        Some(ModalSummary {
            mass: format!(
                "{} mass matrix, interpolation m = rho for rho >= 0.1, 0.1 (rho/0.1)^6 below",
                if lumped { "lumped" } else { "consistent" }
            ),
            plate_masses: self.params.plate_masses,
            frequencies_hz: m.frequencies.clone(),
            residuals: m.residuals.clone(),
            input_frequency_hz: a2.map(|a| a.input_frequency),
            assumption2_ratio: a2.map(|a| a.ratio),
            assumption2_holds: a2.map(|a| a.holds),
            assumption2: a2
                .map(|a| a.statement())
                .unwrap_or_else(|| "not checked: the scenario has no trajectories".into()),
        })
    }

    /// Mode shapes (scaled to a largest nodal displacement of 1) for ParaView, and the
    /// frequencies as CSV.
    fn write_modes(&self) -> Result<()> {
        let Some(m) = &self.reduction.modes else {
            return Ok(());
        };
        crate::figures::write_modes(
            self.run,
            files::MODES_VTU,
            files::mode_png,
            files::MODE_PNGS,
            self.problem.mesh(),
            self.rho,
            (&m.shapes, &m.frequencies),
        )?;
        let k: Vec<f64> = (1..=m.frequencies.len()).map(|k| k as f64).collect();
        let table = Table::new(
            &["mode", "frequency_hz", "residual"],
            vec![k, m.frequencies.clone(), m.residuals.clone()],
        );
        self.run.store(files::MODES_CSV, table)?;
        // The shapes as data (mass-normalized, unscaled), for notebooks and other tools.
        let mesh = self.problem.mesh();
        let mut header = vec!["x_m".to_string(), "y_m".to_string()];
        let mut columns = vec![
            (0..mesh.n_nodes())
                .map(|n| mesh.node_coords(n)[0])
                .collect::<Vec<f64>>(),
            (0..mesh.n_nodes())
                .map(|n| mesh.node_coords(n)[1])
                .collect(),
        ];
        for (k, phi) in m.shapes.iter().enumerate() {
            for (axis, name) in ["ux", "uy"].iter().enumerate() {
                header.push(format!("{name}_{}", k + 1));
                columns.push(phi.iter().skip(axis).step_by(2).copied().collect());
            }
        }
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        self.run
            .store(files::MODE_SHAPES_CSV, Table::new(&header, columns))?;
        Ok(())
    }
}

fn validity_summary(v: &ValidityMap) -> ValiditySummary {
    ValiditySummary {
        metric: "|q_reduced - q_nonlinear_FE| / max_k |q_nonlinear_FE,k| over the p_m \
                 perimeter samples at each stroke scale; q_reduced = alpha_global x_in(FE)"
            .into(),
        scales: v.scales.iter().map(|s| s.scale).collect(),
        amplitude_um: v.scales.iter().map(|s| s.amplitude * 1e6).collect(),
        max_error: v.scales.iter().map(|s| s.max_error).collect(),
        rms_error: v.scales.iter().map(|s| s.rms_error).collect(),
        max_error_linear_fe: v.scales.iter().map(|s| s.max_error_linear).collect(),
        max_error_within_stroke: v.max_error_within_stroke(),
        largest_scale_within_2_percent: v.valid_scale(0.02),
    }
}

/// Named columns of the validity samples (µm for displacements).
type SampleColumn = (&'static str, fn(&ValiditySample) -> f64);

const SAMPLE_COLUMNS: [SampleColumn; 13] = [
    ("scale", |s| s.scale),
    ("x_nom1_um", |s| s.x_nom[0] * 1e6),
    ("x_nom2_um", |s| s.x_nom[1] * 1e6),
    ("x_in1_um", |s| s.x_in[0] * 1e6),
    ("x_in2_um", |s| s.x_in[1] * 1e6),
    ("q1_fe_um", |s| s.q_fe[0] * 1e6),
    ("q2_fe_um", |s| s.q_fe[1] * 1e6),
    ("q1_reduced_um", |s| s.q_reduced[0] * 1e6),
    ("q2_reduced_um", |s| s.q_reduced[1] * 1e6),
    ("q1_linear_um", |s| s.q_linear[0] * 1e6),
    ("q2_linear_um", |s| s.q_linear[1] * 1e6),
    ("error", |s| s.error),
    ("error_linear", |s| s.error_linear),
];

/// Per-scale errors in percent: (amplitude µm, max, rms, max of linear FE).
fn scale_errors(v: &ValidityMap) -> [Vec<f64>; 4] {
    let col = |f: &dyn Fn(&flexstage_reduce::ScaleSummary) -> f64| {
        v.scales.iter().map(f).collect::<Vec<f64>>()
    };
    [
        col(&|s| s.amplitude * 1e6),
        col(&|s| s.max_error * 100.0),
        col(&|s| s.rms_error * 100.0),
        col(&|s| s.max_error_linear * 100.0),
    ]
}

fn write_validity_tables(run: &RunDir, v: &ValidityMap) -> Result<()> {
    let cols: Vec<Vec<f64>> = SAMPLE_COLUMNS
        .iter()
        .map(|(_, f)| v.samples.iter().map(f).collect())
        .collect();
    let header: Vec<&str> = SAMPLE_COLUMNS.iter().map(|(n, _)| *n).collect();
    run.store(files::VALIDITY_CSV, Table::new(&header, cols))?;
    let sc: Vec<f64> = v.scales.iter().map(|s| s.scale).collect();
    let [amp, me, re, ml] = scale_errors(v);
    let table = Table::new(
        &[
            "scale",
            "amplitude_um",
            "max_error_percent",
            "rms_error_percent",
            "max_error_linear_fe_percent",
        ],
        vec![sc, amp, me, re, ml],
    );
    run.store(files::VALIDITY_SCALE_CSV, table)?;
    Ok(())
}

/// The map: workspace polygons at the largest scale ≤ 1, and the error against stroke.
fn write_validity_figures(run: &RunDir, v: &ValidityMap) -> Result<()> {
    let top = v
        .scales
        .iter()
        .rev()
        .find(|s| s.scale <= 1.0 + 1e-12)
        .unwrap_or(&v.scales[v.scales.len() - 1]);
    let at: Vec<&ValiditySample> = v.samples.iter().filter(|s| s.scale == top.scale).collect();
    let poly = |f: fn(&ValiditySample) -> [f64; 2]| {
        at.iter()
            .map(|s| (f(s)[0] * 1e6, f(s)[1] * 1e6))
            .collect::<Vec<_>>()
    };
    let fig = Figure::new(
        format!(
            "Workspace at {:.0} % stroke: nonlinear FE vs reduced model (max error {:.2} %)",
            top.scale * 100.0,
            top.max_error * 100.0
        ),
        "q1 [µm]",
        "q2 [µm]",
    )
    .equal_aspect()
    .with(Series::closed("nonlinear FE", poly(|s| s.q_fe)))
    .with(Series::closed(
        "reduced: alpha x_in(FE)",
        poly(|s| s.q_reduced),
    ))
    .with(Series::closed(
        "linear FE, same PEA loads",
        poly(|s| s.q_linear),
    ));
    run.write(files::VALIDITY_SVG, fig.to_svg()?.as_bytes())?;
    let [amp, me, re, ml] = scale_errors(v);
    let pts = |y: &[f64]| amp.iter().copied().zip(y.iter().copied()).collect();
    let fig = Figure::new(
        "Tangent-model error vs stroke (validity map)",
        "stroke amplitude [µm]",
        "error [% of workspace radius]",
    )
    .with(Series::line("max, reduced alpha x_in", pts(&me)))
    .with(Series::line("rms, reduced alpha x_in", pts(&re)))
    .with(Series::line("max, linear FE", pts(&ml)))
    .with(Series::line(
        "2 % limit",
        vec![(0.0, 2.0), (amp.last().copied().unwrap_or(1.0), 2.0)],
    ));
    run.write(files::VALIDITY_SCALE_SVG, fig.to_svg()?.as_bytes())?;
    Ok(())
}
