//! `flexstage export`: the manufacturing outline of a design (paper Section 4.1, wire-cut
//! from a plate): the ρ = 0.5 iso-contour as DXF and SVG closed polylines, and a binary STL
//! extruded by the plate thickness.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use flexstage_report::RunDir;
use flexstage_report::outline::{Outline, Unit};
use flexstage_scenario::Scenario;

use crate::build;
use crate::run_dir::open_run;
use crate::scenario_args::ScenarioArgs;

/// Arguments of `flexstage export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    #[command(flatten)]
    pub scenario: ScenarioArgs,
    /// The design: a run folder, a design.json, a density .csv/.png, or "uniform:RHO".
    /// Default: the run folder's design.
    #[arg(long)]
    pub design: Option<String>,
    /// Run folder (default runs/<scenario name>); files go to its export/ sub-folder.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Length unit of the DXF, SVG and STL files.
    #[arg(long, default_value = "mm", value_parser = ["mm", "m"])]
    pub units: String,
    /// Density level of the contour.
    #[arg(long, default_value_t = 0.5)]
    pub level: f64,
    /// Taubin smoothing passes (0: the raw marching-squares polygon).
    #[arg(long, default_value_t = 10)]
    pub smoothing: usize,
}

/// What `export` wrote.
#[derive(Debug, Clone)]
pub struct ExportSummary {
    /// Number of closed loops (outer boundaries and holes).
    pub loops: usize,
    /// Area enclosed by the outline [m²].
    pub area: f64,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// Exports the outline of the design `source` (default: the run's design) to
/// `<run>/export/outline.{dxf,svg,stl}`.
pub fn execute(
    s: &Scenario,
    run: &RunDir,
    source: Option<&str>,
    unit: Unit,
    level: f64,
    smoothing: usize,
) -> anyhow::Result<ExportSummary> {
    anyhow::ensure!(
        level > 0.0 && level < 1.0,
        "--level must be in (0, 1), got {level}"
    );
    let problem = build::analysis_problem(s)?;
    let source = match source {
        Some(d) => d.to_string(),
        None => {
            let json = run.path("design/design.json");
            anyhow::ensure!(
                json.is_file(),
                "{} not found: run `flexstage design` first or pass --design",
                json.display()
            );
            run.root().display().to_string()
        }
    };
    let rho = build::load_design(&source, &problem)?;
    let (nl, nw) = (s.mesh.nl, s.mesh.nw);
    let (dx, dy) = (s.mesh.length / nl as f64, s.mesh.width / nw as f64);
    let outline = Outline::from_fem_order(nl, nw, dx, dy, level, smoothing, &rho)?;
    let files = vec![
        run.write("export/outline.dxf", &outline.to_dxf(unit)?)?,
        run.write("export/outline.svg", outline.to_svg(unit).as_bytes())?,
        run.write(
            "export/outline.stl",
            &outline.to_stl(s.mesh.thickness, unit),
        )?,
    ];
    Ok(ExportSummary {
        loops: outline.loops.len(),
        area: outline.area(),
        files,
    })
}

/// Runs `flexstage export`.
pub fn run(args: ExportArgs) -> anyhow::Result<()> {
    let s = args.scenario.load()?;
    let run = open_run(args.out.clone(), &s)?;
    let unit = if args.units == "m" {
        Unit::Metres
    } else {
        Unit::Millimetres
    };
    let summary = execute(
        &s,
        &run,
        args.design.as_deref(),
        unit,
        args.level,
        args.smoothing,
    )
    .context("export failed")?;
    println!(
        "outline: {} closed loop(s), {:.2} mm² of material (ρ = {} level, {} smoothing passes), \
         {}",
        summary.loops,
        summary.area * 1e6,
        args.level,
        args.smoothing,
        unit.symbol()
    );
    for f in &summary.files {
        println!("  wrote {}", f.display());
    }
    Ok(())
}
