//! `flexstage analyze`: nonlinear statics of a design for given actuator inputs or for the
//! p_m samples of the workspace (DECISIONS.md), the output polygon and its area, and a VTK file.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use flexstage_fem::Design;
use flexstage_report::{
    RunDir, csv_columns,
    plot::{Figure, Series},
    vtk::{PointField, QuadMesh},
};
use flexstage_topopt::{AnalysisParams, CaseResults, Evaluator, Problem, shoelace};

use crate::build;
use crate::scenario_args::ScenarioArgs;

/// Arguments of `flexstage analyze`.
#[derive(Debug, Args)]
pub struct AnalyzeArgs {
    #[command(flatten)]
    pub scenario: ScenarioArgs,
    /// The design: "uniform", "uniform:RHO", a density .csv/.png, a design.json or a run folder.
    #[arg(long, default_value = "uniform")]
    pub design: String,
    /// Actuator input pair "X1,X2" in µm (nominal strokes of PEA1 and PEA2); repeat for more
    /// cases. Without it, the p_m samples of the stroke-square perimeter are analysed.
    #[arg(long = "inputs", value_name = "X1,X2")]
    pub inputs: Vec<String>,
    /// Run folder (default runs/<scenario name>); results go to its analyze/ sub-folder.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Writes the deformed-mesh VTU (displacement, density, strain energy density, von Mises).
pub fn write_vtu(
    run: &RunDir,
    rel: &str,
    problem: &Problem,
    rho: &[f64],
    u: &[f64],
) -> anyhow::Result<()> {
    let model = &problem.model;
    let mesh = model.mesh();
    let points: Vec<[f64; 2]> = (0..mesh.n_nodes()).map(|n| mesh.node_coords(n)).collect();
    let cells: Vec<[usize; 4]> = (0..mesh.n_elements())
        .map(|e| mesh.element_nodes(e))
        .collect();
    let disp: Vec<[f64; 2]> = (0..mesh.n_nodes())
        .map(|n| [u[2 * n], u[2 * n + 1]])
        .collect();
    let design = Design::new(rho);
    let ne = mesh.n_elements();
    let (mut sed, mut vm) = (vec![0.0; ne], vec![0.0; ne]);
    model.energy_densities(&design, u, &mut sed);
    model.von_mises_stresses(&design, u, &mut vm);
    let vtu = QuadMesh {
        points: &points,
        cells: &cells,
        point_data: vec![("displacement", PointField::Vector2(&disp))],
        cell_data: vec![
            ("density", rho),
            ("strain_energy_density", &sed),
            ("von_mises_stress", &vm),
        ],
    }
    .to_vtu()?;
    run.write(rel, vtu.as_bytes())?;
    Ok(())
}

/// Per-case table (µm and J).
pub fn cases_csv(problem: &Problem, r: &CaseResults) -> String {
    let col = |f: &dyn Fn(usize) -> f64| (0..r.outputs.len()).map(f).collect::<Vec<f64>>();
    let x1 = col(&|k| problem.cases[k][0] * 1e6);
    let x2 = col(&|k| problem.cases[k].get(1).copied().unwrap_or(0.0) * 1e6);
    let u1 = col(&|k| r.inputs[k][0] * 1e6);
    let u2 = col(&|k| r.inputs[k].get(1).copied().unwrap_or(0.0) * 1e6);
    let xo = col(&|k| r.outputs[k][0] * 1e6);
    let yo = col(&|k| r.outputs[k][1] * 1e6);
    csv_columns(
        &[
            "x_nom1_um",
            "x_nom2_um",
            "x_in1_um",
            "x_in2_um",
            "x_out_um",
            "y_out_um",
            "strain_energy_J",
        ],
        &[&x1, &x2, &u1, &u2, &xo, &yo, &r.energies],
    )
}

/// Polygon figure (µm) of one or more output polygons.
pub fn polygon_svg(title: &str, polys: &[(String, &[[f64; 2]])]) -> anyhow::Result<String> {
    let mut fig = Figure::new(title, "x_out [µm]", "y_out [µm]").equal_aspect();
    for (label, p) in polys {
        fig = fig.with(Series::closed(
            label.clone(),
            p.iter().map(|q| (q[0] * 1e6, q[1] * 1e6)).collect(),
        ));
    }
    Ok(fig.to_svg()?)
}

pub fn run(args: AnalyzeArgs) -> anyhow::Result<()> {
    let s = args.scenario.load()?;
    let mut problem = build::analysis_problem(&s)?;
    let workspace = args.inputs.is_empty();
    if !workspace {
        problem.cases = args
            .inputs
            .iter()
            .map(|t| {
                let v: Vec<f64> = t
                    .split(',')
                    .map(|x| x.trim().parse::<f64>().map(|v| v * 1e-6))
                    .collect::<Result<_, _>>()
                    .with_context(|| format!("--inputs {t:?}: expected two numbers X1,X2 in µm"))?;
                anyhow::ensure!(
                    v.len() == 2,
                    "--inputs {t:?}: expected two numbers X1,X2 in µm"
                );
                Ok(v)
            })
            .collect::<anyhow::Result<_>>()?;
    }
    let rho = build::load_design(&args.design, &problem)?;
    let run = crate::run_dir::open_run(args.out, &s)?;
    let t = std::time::Instant::now();
    let mut ev = Evaluator::new(&problem, AnalysisParams::default())?;
    let r = ev
        .solve_cases(&rho, None)
        .context("nonlinear analysis failed")?;
    let secs = t.elapsed().as_secs_f64();
    run.write("analyze/cases.csv", cases_csv(&problem, &r).as_bytes())?;
    // VTK at the compressive corner (workspace) or the first given case.
    let k_vtk = if workspace {
        problem.differential_corners().0
    } else {
        0
    };
    write_vtu(
        &run,
        "analyze/deformed.vtu",
        &problem,
        &rho,
        &ev.cases[k_vtk].u,
    )?;
    println!(
        "analyzed {} load case(s) of design {:?} in {:.2} s ({} Newton iterations)",
        r.outputs.len(),
        args.design,
        secs,
        r.newton_iterations.iter().sum::<usize>()
    );
    for (k, o) in r
        .outputs
        .iter()
        .enumerate()
        .take(if workspace { 0 } else { usize::MAX })
    {
        println!(
            "  x_nom = ({:.2}, {:.2}) µm  ->  u_out = ({:.4}, {:.4}) µm",
            problem.cases[k][0] * 1e6,
            problem.cases[k][1] * 1e6,
            o[0] * 1e6,
            o[1] * 1e6
        );
    }
    let mut summary = serde_json::json!({
        "design": args.design,
        "cases": r.outputs.len(),
        "newton_iterations": r.newton_iterations.iter().sum::<usize>(),
        "seconds": secs,
    });
    if workspace {
        let area = shoelace(&r.outputs);
        println!(
            "  workspace polygon of {} samples: area {:.6e} m² = {:.3} µm²",
            r.outputs.len(),
            area,
            area * 1e12
        );
        for (name, k) in [("(+a,+a)", 0), ("(+a,-a)", problem.cases.len() / 4)] {
            let o = r.outputs[k];
            println!(
                "  corner {name}: u_out = ({:.4}, {:.4}) µm",
                o[0] * 1e6,
                o[1] * 1e6
            );
        }
        summary["area_m2"] = serde_json::json!(area);
        run.write(
            "analyze/workspace.svg",
            polygon_svg("Output workspace", &[("design".into(), &r.outputs)])?.as_bytes(),
        )?;
    }
    run.write(
        "analyze/summary.json",
        serde_json::to_string_pretty(&summary)?.as_bytes(),
    )?;
    eprintln!("wrote {}", run.path("analyze").display());
    Ok(())
}
