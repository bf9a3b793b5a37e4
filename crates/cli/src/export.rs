//! `flexstage export`: the manufacturing outline of a design (paper Section 4.1, wire-cut
//! from a plate): the ρ = 0.5 iso-contour as DXF and SVG closed polylines, and a binary STL
//! extruded by the plate thickness; then the verification of that outline
//! (`flexstage-verify`: body-fitted stress, α and first frequency beside the design mesh's,
//! manufacturability findings, the verdict). The logic lives in the library crates; this is a
//! thin call and print.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use flexstage_report::RunDir;
use flexstage_report::outline::{Outline, Unit};
use flexstage_scenario::Scenario;
use flexstage_verify::{Verification, VerifyParams};

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
    /// Longest chord [mm] of the exported curve (Catmull–Rom through the smoothed contour;
    /// 0: the polygon itself).
    #[arg(long, default_value_t = 0.05)]
    pub max_chord_mm: f64,
    /// Skip the verification (body-fitted re-analysis and manufacturability checks).
    #[arg(long)]
    pub no_verify: bool,
    /// Exit with status 2 when the verdict is "NOT safe" (files are written either way).
    #[arg(long)]
    pub require_safe: bool,
    /// Fatigue strength of the material [MPa] (Al 6061-T6: 96.5).
    #[arg(long, default_value_t = flexstage_verify::AL6061_T6_FATIGUE_STRENGTH * 1e-6)]
    pub fatigue_strength_mpa: f64,
    /// Safety factor: allowable stress = fatigue strength / safety factor.
    #[arg(long, default_value_t = flexstage_verify::DEFAULT_SAFETY_FACTOR)]
    pub safety_factor: f64,
    /// Minimum hinge (ligament) thickness [mm].
    #[arg(long, default_value_t = 0.5)]
    pub min_ligament_mm: f64,
    /// Minimum slot width [mm] (the wire-EDM kerf).
    #[arg(long, default_value_t = 0.4)]
    pub min_gap_mm: f64,
    /// Wire-EDM start-hole diameter [mm].
    #[arg(long, default_value_t = 1.0)]
    pub start_hole_mm: f64,
}

impl ExportArgs {
    /// The verification parameters of the options (`None` with `--no-verify`).
    pub fn verify_params(&self) -> Option<VerifyParams> {
        (!self.no_verify).then(|| VerifyParams {
            fatigue_strength: self.fatigue_strength_mpa * 1e6,
            safety_factor: self.safety_factor,
            min_ligament: self.min_ligament_mm * 1e-3,
            min_gap: self.min_gap_mm * 1e-3,
            start_hole_diameter: self.start_hole_mm * 1e-3,
            ..VerifyParams::default()
        })
    }
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
    /// The verification (`None` if skipped or failed).
    pub verification: Option<Box<Verification>>,
    /// Why the verification could not be done (the design is then not called safe).
    pub verify_error: Option<String>,
}

impl ExportSummary {
    /// Is the design verified safe?
    pub fn safe(&self) -> bool {
        self.verification.as_ref().is_some_and(|v| v.verdict.safe)
    }
}

/// Longest chord of the exported curve by default [m].
pub const DEFAULT_MAX_CHORD: f64 = 0.05e-3;

/// Exports the outline of the design `source` (default: the run's design) to
/// `<run>/export/outline.{dxf,svg,stl}` and verifies it with the default parameters.
pub fn execute(
    s: &Scenario,
    run: &RunDir,
    source: Option<&str>,
    unit: Unit,
    level: f64,
    smoothing: usize,
) -> anyhow::Result<ExportSummary> {
    execute_with(
        s,
        run,
        source,
        unit,
        (level, smoothing, DEFAULT_MAX_CHORD),
        Some(&VerifyParams::default()),
    )
}

/// [`execute`] with the contour `(level, smoothing, max_chord)` and the verification
/// parameters (`None`: no verification).
pub fn execute_with(
    s: &Scenario,
    run: &RunDir,
    source: Option<&str>,
    unit: Unit,
    (level, smoothing, max_chord): (f64, usize, f64),
    verify: Option<&VerifyParams>,
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
    let outline =
        Outline::from_fem_order(nl, nw, dx, dy, level, smoothing, &rho)?.refined(max_chord);
    let mut files = vec![
        run.write("export/outline.dxf", &outline.to_dxf(unit)?)?,
        run.write("export/outline.svg", outline.to_svg(unit).as_bytes())?,
        run.write(
            "export/outline.stl",
            &outline.to_stl(s.mesh.thickness, unit),
        )?,
    ];
    let (mut verification, mut verify_error) = (None, None);
    if let Some(p) = verify {
        match flexstage_verify::verify(s, &rho, &outline.loops, p) {
            Ok(v) => {
                files.extend(flexstage_verify::write_files(&v, run)?);
                verification = Some(Box::new(v));
            }
            Err(e) => verify_error = Some(e.to_string()),
        }
    }
    Ok(ExportSummary {
        loops: outline.loops.len(),
        area: outline.area(),
        files,
        verification,
        verify_error,
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
    anyhow::ensure!(
        args.max_chord_mm >= 0.0 && args.max_chord_mm <= 10.0,
        "--max-chord-mm must be in [0, 10], got {}",
        args.max_chord_mm
    );
    let params = args.verify_params();
    let summary = execute_with(
        &s,
        &run,
        args.design.as_deref(),
        unit,
        (args.level, args.smoothing, args.max_chord_mm * 1e-3),
        params.as_ref(),
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
    if let Some(v) = &summary.verification {
        for line in v.summary_lines() {
            println!("{line}");
        }
    } else if let Some(e) = &summary.verify_error {
        println!("verdict: NOT safe: the outline could not be verified: {e}");
    }
    if args.require_safe && !args.no_verify && !summary.safe() {
        eprintln!("--require-safe: the design is not verified safe");
        std::process::exit(2);
    }
    Ok(())
}
