//! `flexstage reduce`: the reduced spring–mass model of a design (Section 3.2.1): transfer
//! matrix α by static condensation, lumped parameters as a `StageParams` TOML for
//! `flexstage track --params`, modal analysis with the Assumption-2 check, and the validity map
//! of the tangent model against nonlinear FE.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use flexstage_reduce::{
    MassLumping, ModalParams, ReduceParams, Reduction, ValidityParams, reduce, reduction_problem,
    stage_params_toml,
};
use flexstage_report::{
    RunDir, csv_columns,
    plot::{Figure, Series},
    vtk::{PointField, QuadMesh},
};
use flexstage_topopt::Problem;
use serde::Serialize;

use crate::build;
use crate::scenario_args::ScenarioArgs;

/// Arguments of `flexstage reduce`.
#[derive(Debug, Args)]
pub struct ReduceArgs {
    #[command(flatten)]
    pub scenario: ScenarioArgs,
    /// The design: "uniform", "uniform:RHO", a density .csv/.png, a design.json or a run
    /// folder. Default: the run folder's design/design.json if it exists, else "uniform".
    #[arg(long)]
    pub design: Option<String>,
    /// Run folder (default runs/<scenario name>); results go to its reduce/ sub-folder.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Take the tangent at this operating point "X1,X2" (nominal strokes, µm) instead of the
    /// undeformed state.
    #[arg(long, value_name = "X1,X2")]
    pub operating_point: Option<String>,
    /// Number of natural frequencies and mode shapes (0 skips the modal analysis).
    #[arg(long, default_value_t = 6)]
    pub modes: usize,
    /// Lumped (diagonal) instead of consistent mass matrices.
    #[arg(long)]
    pub lumped: bool,
    /// Leave the input-plate masses (stage.guess.m_in) out of the modal analysis.
    #[arg(long)]
    pub no_plate_mass: bool,
    /// Stroke scales of the validity map, comma separated (empty string skips it).
    #[arg(long, default_value = "0.1,0.25,0.5,0.75,1")]
    pub scales: String,
    /// Keep the optimizer's output spring (optimization.output_spring) in the model.
    #[arg(long)]
    pub keep_output_spring: bool,
}

#[derive(Debug, Serialize)]
struct Summary {
    design: String,
    mesh: [usize; 2],
    state: String,
    /// ∂q/∂x_in, global frame (FE output, rigid translation included).
    alpha_global: [[f64; 2]; 2],
    /// Paper's α (Eq. 24): moving frame u_o = q − [½(x_in1 + x_in2), 0].
    alpha_moving_frame: [[f64; 2]; 2],
    eq26_residuals: [f64; 2],
    tan_theta: f64,
    theta_deg: f64,
    alpha_scalar: f64,
    a_theta: [[f64; 2]; 2],
    a_theta_residual: f64,
    output_compliance_m_per_n: [[f64; 2]; 2],
    output_stiffness_n_per_m: [[f64; 2]; 2],
    k_qo1: f64,
    k_qo2: f64,
    mass_kg: f64,
    volume_fraction: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    operating_output_um: Option<[f64; 2]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    modal: Option<ModalSummary>,
    #[serde(skip_serializing_if = "Option::is_none")]
    validity: Option<ValiditySummary>,
}

#[derive(Debug, Serialize)]
struct ModalSummary {
    mass: String,
    plate_masses: bool,
    frequencies_hz: Vec<f64>,
    residuals: Vec<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    input_frequency_hz: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    assumption2_ratio: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    assumption2_holds: Option<bool>,
    assumption2: String,
}

#[derive(Debug, Serialize)]
struct ValiditySummary {
    metric: String,
    scales: Vec<f64>,
    amplitude_um: Vec<f64>,
    max_error: Vec<f64>,
    rms_error: Vec<f64>,
    max_error_linear_fe: Vec<f64>,
    max_error_within_stroke: f64,
    largest_scale_within_2_percent: f64,
}

fn parse_pair(text: &str, what: &str) -> anyhow::Result<[f64; 2]> {
    let v: Vec<f64> = text
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{what} {text:?}: expected two numbers \"X1,X2\""))?;
    match v.as_slice() {
        [a, b] => Ok([*a, *b]),
        _ => anyhow::bail!("{what} {text:?}: expected two numbers \"X1,X2\""),
    }
}

pub fn run(args: ReduceArgs) -> anyhow::Result<()> {
    let s = args.scenario.load()?;
    let problem = reduction_problem(&s, args.keep_output_spring)
        .context("cannot build the finite-element model of the scenario")?;
    let root = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("runs").join(&s.name));
    let source = match &args.design {
        Some(d) => d.clone(),
        None if root.join("design").join("design.json").is_file() => root.display().to_string(),
        None => "uniform".to_string(),
    };
    let rho = build::load_design(&source, &problem)?;
    let scales: Vec<f64> = if args.scales.trim().is_empty() {
        Vec::new()
    } else {
        args.scales
            .split(',')
            .map(|x| x.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .with_context(|| format!("--scales {:?}: expected numbers", args.scales))?
    };
    let params = ReduceParams {
        operating_point: args
            .operating_point
            .as_deref()
            .map(|t| parse_pair(t, "--operating-point").map(|p| [p[0] * 1e-6, p[1] * 1e-6]))
            .transpose()?,
        modal: (args.modes > 0).then(|| ModalParams {
            modes: args.modes,
            lumping: if args.lumped {
                MassLumping::Lumped
            } else {
                MassLumping::Consistent
            },
            ..ModalParams::default()
        }),
        plate_masses: !args.no_plate_mass,
        validity: (!scales.is_empty()).then(|| ValidityParams {
            scales,
            ..ValidityParams::default()
        }),
        ..ReduceParams::default()
    };
    eprintln!(
        "reducing design {source} ({} x {} mesh){}",
        problem.mesh().nl,
        problem.mesh().nw,
        if params.validity.is_some() {
            ": condensation, modes, validity map (nonlinear FE)"
        } else {
            ""
        }
    );
    let r = reduce(&s, &problem, &rho, &params).context("reduction failed")?;
    let run = crate::run_dir::open_run(args.out, &s)?;
    write_outputs(&run, &source, &problem, &rho, &r, &params)?;
    print_summary(&r, &run);
    Ok(())
}

fn write_outputs(
    run: &RunDir,
    source: &str,
    problem: &Problem,
    rho: &[f64],
    r: &Reduction,
    params: &ReduceParams,
) -> anyhow::Result<()> {
    let c = &r.condensation;
    let state = match r.operating_point {
        None => "undeformed".to_string(),
        Some(x) => format!(
            "operating point x_nom = ({:.3}, {:.3}) um",
            x[0] * 1e6,
            x[1] * 1e6
        ),
    };
    let header = vec![
        "Reduced stage model (flexstage reduce), paper Eq. 31-35 / Appendix C, SI units.".into(),
        format!("design: {source}; tangent at the {state} state."),
        "K_qo1, K_qo2, mass and alpha come from the design; K_pea, k_in, m_in from the scenario,"
            .into(),
        "damping from stage.damping_ratio. Read by `flexstage track --params FILE`.".into(),
    ];
    run.write(
        "reduce/params.toml",
        stage_params_toml(&r.params, &header).as_bytes(),
    )?;
    let modal = r.modes.as_ref().map(|m| ModalSummary {
        mass: format!(
            "{} mass matrix, interpolation m = rho for rho >= 0.1, 0.1 (rho/0.1)^6 below",
            if matches!(params.modal.map(|p| p.lumping), Some(MassLumping::Lumped)) {
                "lumped"
            } else {
                "consistent"
            }
        ),
        plate_masses: params.plate_masses,
        frequencies_hz: m.frequencies.clone(),
        residuals: m.residuals.clone(),
        input_frequency_hz: r.assumption2.as_ref().map(|a| a.input_frequency),
        assumption2_ratio: r.assumption2.as_ref().map(|a| a.ratio),
        assumption2_holds: r.assumption2.as_ref().map(|a| a.holds),
        assumption2: r
            .assumption2
            .as_ref()
            .map(|a| a.statement())
            .unwrap_or_else(|| "not checked: the scenario has no trajectories".into()),
    });
    let validity = r.validity.as_ref().map(|v| ValiditySummary {
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
    });
    let summary = Summary {
        design: source.to_string(),
        mesh: [problem.mesh().nl, problem.mesh().nw],
        state,
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
        modal,
        validity,
    };
    run.write(
        "reduce/summary.toml",
        toml::to_string(&summary)
            .context("summary as TOML")?
            .as_bytes(),
    )?;
    run.write(
        "reduce/summary.json",
        serde_json::to_string_pretty(&summary)?.as_bytes(),
    )?;
    let mesh = problem.mesh();
    if let Some(m) = &r.modes {
        let points: Vec<[f64; 2]> = (0..mesh.n_nodes()).map(|n| mesh.node_coords(n)).collect();
        let cells: Vec<[usize; 4]> = (0..mesh.n_elements())
            .map(|e| mesh.element_nodes(e))
            .collect();
        // Shapes scaled to a largest nodal displacement of 1 (dimensionless).
        let shapes: Vec<Vec<[f64; 2]>> = m
            .shapes
            .iter()
            .map(|phi| {
                let mx = phi.iter().fold(0.0f64, |a, v| a.max(v.abs())).max(1e-300);
                (0..mesh.n_nodes())
                    .map(|n| [phi[2 * n] / mx, phi[2 * n + 1] / mx])
                    .collect()
            })
            .collect();
        let names: Vec<String> = m
            .frequencies
            .iter()
            .enumerate()
            .map(|(k, f)| format!("mode_{}_{:.0}Hz", k + 1, f))
            .collect();
        let vtu = QuadMesh {
            points: &points,
            cells: &cells,
            point_data: names
                .iter()
                .zip(&shapes)
                .map(|(n, s)| (n.as_str(), PointField::Vector2(s)))
                .collect(),
            cell_data: vec![("density", rho)],
        }
        .to_vtu()?;
        run.write("reduce/modes.vtu", vtu.as_bytes())?;
        let k: Vec<f64> = (1..=m.frequencies.len()).map(|k| k as f64).collect();
        run.write(
            "reduce/modes.csv",
            csv_columns(
                &["mode", "frequency_hz", "residual"],
                &[&k, &m.frequencies, &m.residuals],
            )
            .as_bytes(),
        )?;
    }
    if let Some(v) = &r.validity {
        let col = |f: &dyn Fn(&flexstage_reduce::ValiditySample) -> f64| {
            v.samples.iter().map(f).collect::<Vec<f64>>()
        };
        let cols = [
            col(&|s| s.scale),
            col(&|s| s.x_nom[0] * 1e6),
            col(&|s| s.x_nom[1] * 1e6),
            col(&|s| s.x_in[0] * 1e6),
            col(&|s| s.x_in[1] * 1e6),
            col(&|s| s.q_fe[0] * 1e6),
            col(&|s| s.q_fe[1] * 1e6),
            col(&|s| s.q_reduced[0] * 1e6),
            col(&|s| s.q_reduced[1] * 1e6),
            col(&|s| s.q_linear[0] * 1e6),
            col(&|s| s.q_linear[1] * 1e6),
            col(&|s| s.error),
            col(&|s| s.error_linear),
        ];
        let refs: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
        run.write(
            "reduce/validity.csv",
            csv_columns(
                &[
                    "scale",
                    "x_nom1_um",
                    "x_nom2_um",
                    "x_in1_um",
                    "x_in2_um",
                    "q1_fe_um",
                    "q2_fe_um",
                    "q1_reduced_um",
                    "q2_reduced_um",
                    "q1_linear_um",
                    "q2_linear_um",
                    "error",
                    "error_linear",
                ],
                &refs,
            )
            .as_bytes(),
        )?;
        let sc: Vec<f64> = v.scales.iter().map(|s| s.scale).collect();
        let amp: Vec<f64> = v.scales.iter().map(|s| s.amplitude * 1e6).collect();
        let me: Vec<f64> = v.scales.iter().map(|s| s.max_error * 100.0).collect();
        let re: Vec<f64> = v.scales.iter().map(|s| s.rms_error * 100.0).collect();
        let ml: Vec<f64> = v
            .scales
            .iter()
            .map(|s| s.max_error_linear * 100.0)
            .collect();
        run.write(
            "reduce/validity_scale.csv",
            csv_columns(
                &[
                    "scale",
                    "amplitude_um",
                    "max_error_percent",
                    "rms_error_percent",
                    "max_error_linear_fe_percent",
                ],
                &[&sc, &amp, &me, &re, &ml],
            )
            .as_bytes(),
        )?;
        // The map: workspace polygons (largest scale ≤ 1) and error vs stroke.
        let top = v
            .scales
            .iter()
            .rev()
            .find(|s| s.scale <= 1.0 + 1e-12)
            .unwrap_or(&v.scales[v.scales.len() - 1])
            .scale;
        let at: Vec<&flexstage_reduce::ValiditySample> =
            v.samples.iter().filter(|s| s.scale == top).collect();
        let poly = |f: &dyn Fn(&flexstage_reduce::ValiditySample) -> [f64; 2]| {
            at.iter()
                .map(|s| {
                    let q = f(s);
                    (q[0] * 1e6, q[1] * 1e6)
                })
                .collect::<Vec<_>>()
        };
        let fig = Figure::new(
            format!(
                "Workspace at {:.0} % stroke: nonlinear FE vs reduced model (max error {:.2} %)",
                top * 100.0,
                v.scales
                    .iter()
                    .find(|s| s.scale == top)
                    .map_or(0.0, |s| s.max_error * 100.0)
            ),
            "q1 [µm]",
            "q2 [µm]",
        )
        .equal_aspect()
        .with(Series::closed("nonlinear FE", poly(&|s| s.q_fe)))
        .with(Series::closed(
            "reduced: alpha x_in(FE)",
            poly(&|s| s.q_reduced),
        ))
        .with(Series::closed(
            "linear FE, same PEA loads",
            poly(&|s| s.q_linear),
        ));
        run.write("reduce/validity.svg", fig.to_svg()?.as_bytes())?;
        let fig = Figure::new(
            "Tangent-model error vs stroke (validity map)",
            "stroke amplitude [µm]",
            "error [% of workspace radius]",
        )
        .with(Series::line(
            "max, reduced alpha x_in",
            amp.iter().copied().zip(me.iter().copied()).collect(),
        ))
        .with(Series::line(
            "rms, reduced alpha x_in",
            amp.iter().copied().zip(re.iter().copied()).collect(),
        ))
        .with(Series::line(
            "max, linear FE",
            amp.iter().copied().zip(ml.iter().copied()).collect(),
        ))
        .with(Series::line(
            "2 % limit",
            vec![(0.0, 2.0), (amp.last().copied().unwrap_or(1.0), 2.0)],
        ));
        run.write("reduce/validity_scale.svg", fig.to_svg()?.as_bytes())?;
    }
    Ok(())
}

fn print_summary(r: &Reduction, run: &RunDir) {
    let c = &r.condensation;
    let a = c.alpha;
    println!(
        "alpha (moving frame, Eq. 24) = [[{:+.5}, {:+.5}], [{:+.5}, {:+.5}]]",
        a[0][0], a[0][1], a[1][0], a[1][1]
    );
    println!(
        "  scalar alpha (Eq. 27) = {:.5}, tilt theta = {:.3} deg, |A(theta) - alpha| = {:.1e}",
        c.alpha_scalar(),
        c.theta().to_degrees(),
        c.a_theta_residual()
    );
    println!(
        "K_qo1 = {:.4e} N/m, K_qo2 = {:.4e} N/m, M = {:.4} kg (volume fraction {:.3})",
        c.k_qo1(),
        c.k_qo2(),
        r.mass,
        r.volume_fraction
    );
    if let Some(m) = &r.modes {
        let f: Vec<String> = m.frequencies.iter().map(|f| format!("{f:.0}")).collect();
        println!("natural frequencies [Hz]: {}", f.join(", "));
    }
    if let Some(a2) = &r.assumption2 {
        println!("{}", a2.statement());
    }
    if let Some(v) = &r.validity {
        for s in &v.scales {
            println!(
                "  stroke {:>5.1} um: reduced vs nonlinear FE max {:.3} % (rms {:.3} %), \
                 linear FE {:.3} %",
                s.amplitude * 1e6,
                s.max_error * 100.0,
                s.rms_error * 100.0,
                s.max_error_linear * 100.0
            );
        }
        println!(
            "validity: {} within the stroke (max {:.3} %); tangent model within 2 % up to {:.0} % stroke",
            if v.max_error_within_stroke() <= 0.02 {
                "agrees with nonlinear FE to 2 %"
            } else {
                "DOES NOT agree with nonlinear FE to 2 %"
            },
            v.max_error_within_stroke() * 100.0,
            v.valid_scale(0.02) * 100.0
        );
    }
    println!("wrote {}", run.path("reduce").display());
}
