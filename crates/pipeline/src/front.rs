//! `front`: the workspace–first-resonance front of a scenario (DECISIONS.md, "Design for
//! bandwidth"). The paper's design stage maximizes the workspace and hands whatever resonance
//! results to the controller; a designer who needs a faster scan needs the trade-off itself.
//!
//! * **Designs by continuation.** `d0` is the scenario's workspace design (no resonance
//!   bound; first natural frequency `f0`). Design `k` maximizes the workspace with the stage's
//!   first natural frequency at least `f0·(1 + k(r − 1)/(n − 1))` (`r` =
//!   [`FrontOptions::max_ratio`]), warm-started from design `k − 1`'s variables with the
//!   projection restarted at β = [`RESTART_BETA`] (so hinges can move and members thicken;
//!   restarting at the final β left the topology frozen and the bound unmet) and smaller MMA
//!   steps ([`CONTINUATION_STEP`]).
//! * **Each design verified.** The final nonlinear analysis (area, mass, stress, sizes,
//!   symmetry, the stage's frequencies), the body-fitted verification of its exported outline
//!   (frequency, stress, manufacturability, verdict), its digital twin (first resonance), and
//!   the error against scan frequency of every controller `track` runs, designed exactly as
//!   `track` designs them on that twin (every controller designed from the twin's loop
//!   measured in its rig at the controller's rate, never from its exact modes), including
//!   the scan speed the user names.
//! * **Files** in `front/` ([`flexstage_run::layout::front`]): `front.csv`, `front.json`, the figure
//!   `front.svg` (workspace against first resonance, each design's tracking error at the named
//!   scan speed in the legend), and per design `d<k>/`: `design.json` (a design source for the
//!   other commands), `outline.svg`, `modes.vtu` and the lowest mode shapes as pictures.

use std::time::Instant;

use flexstage_assess::sweep::{self, SweepParams};
use flexstage_control::experiment::Setup;
use flexstage_control::registry::CONTROLLERS;
use flexstage_figures::plot::{Figure, Legend, Series};
use flexstage_run::Table;
use flexstage_run::files::design::{DESIGN_VERSION, DesignFile};
use flexstage_run::files::front::VERSION;
pub use flexstage_run::files::front::{FrontDesign, FrontFile, ScanError};
use flexstage_run::layout::front as files;
use flexstage_scenario::{ObjectiveKind, Scenario};
use flexstage_topopt::summary::final_analysis;
use flexstage_topopt::{ModalParams, Optimizer, OptimizerParams, Problem, stage_modes};
use flexstage_verify::outline::{Outline, Unit};

use crate::error::{PipelineError, Result, require};
use crate::folder::RunFolder;
use crate::progress::Progress;

/// β at which a continuation design restarts its projection (module docs).
pub const RESTART_BETA: f64 = 4.0;

/// MMA's initial asymptote distance and move limit of a continuation design (the default
/// 0.5 of a fresh start throws a converged design away at a sharp projection).
pub const CONTINUATION_STEP: f64 = 0.2;

/// Options of `front`.
#[derive(Debug, Clone, PartialEq)]
pub struct FrontOptions {
    /// Designs on the front, the workspace design included, in [2, 20]. Default 5.
    pub designs: usize,
    /// The last design's bound as a multiple of the first design's frequency, in (1, 5].
    /// Default 1.6.
    pub max_ratio: f64,
    /// The scan speed the user needs: the fast component of a 3:1 Lissajous \[Hz\], in
    /// (0, 1e5]. Default 250.
    pub scan_hz: f64,
    /// The tracking error the user accepts at `scan_hz`, in % of each axis's range, in
    /// (0, 100]: the front picks the design with the largest workspace whose best controller
    /// stays within it on both axes. Default 1.
    pub max_error_pct: f64,
    /// Iterations of each continuation design, in [1, 100 000]; `None`: twice the β interval
    /// (β from 4 to 16) plus twice the stagnation window.
    pub iterations: Option<usize>,
}

impl Default for FrontOptions {
    fn default() -> Self {
        FrontOptions {
            designs: 5,
            max_ratio: 1.6,
            scan_hz: 250.0,
            max_error_pct: 1.0,
            iterations: None,
        }
    }
}

impl FrontOptions {
    /// Checks every option.
    pub fn validate(&self) -> Result<()> {
        require(
            (2..=20).contains(&self.designs),
            "front.designs",
            self.designs,
            "an integer in [2, 20]",
        )?;
        require(
            self.max_ratio > 1.0 && self.max_ratio <= 5.0,
            "front.max_ratio",
            self.max_ratio,
            "a ratio in (1, 5]",
        )?;
        require(
            self.scan_hz > 0.0 && self.scan_hz <= 1e5,
            "front.scan_hz",
            self.scan_hz,
            "a frequency in (0, 1e5] Hz",
        )?;
        require(
            self.max_error_pct > 0.0 && self.max_error_pct <= 100.0,
            "front.max_error_pct",
            self.max_error_pct,
            "a percentage in (0, 100]",
        )?;
        if let Some(n) = self.iterations {
            require(
                (1..=100_000).contains(&n),
                "front.iterations",
                n,
                "an integer in [1, 100000]",
            )?;
        }
        Ok(())
    }
}

/// What `front` computed: the front as `front/front.json` holds it, and the folder.
#[derive(Debug, Clone, PartialEq)]
pub struct FrontSummary {
    /// The front.
    pub front: FrontFile,
    /// The folder written.
    pub dir: std::path::PathBuf,
}

/// Builds the front (module docs) and writes its files.
pub fn front(
    folder: &RunFolder,
    options: &FrontOptions,
    progress: &dyn Progress,
) -> Result<FrontSummary> {
    options.validate()?;
    let t0 = Instant::now();
    let s0 = front_scenario(folder.scenario())?;
    let n = options.designs;
    let mut x: Option<Vec<f64>> = None;
    let mut f0 = 0.0;
    let mut designs = Vec::with_capacity(n);
    for k in 0..n {
        let mut s = s0.clone();
        if k > 0 {
            let ratio = 1.0 + (options.max_ratio - 1.0) * k as f64 / (n - 1) as f64;
            s.optimization.min_frequency = ratio * f0;
            s.optimization.max_iterations = options.iterations.unwrap_or(
                2 * s.optimization.projection.interval + 2 * s.optimization.stagnation_window,
            );
        }
        progress.note(&format!(
            "front d{k} of {}: {}",
            n - 1,
            if k == 0 {
                "the workspace design".to_string()
            } else {
                format!("first frequency ≥ {:.0} Hz", s.optimization.min_frequency)
            }
        ));
        let (d, xk) = design_one(folder, &s, k, x.as_deref(), options.scan_hz, progress)?;
        if k == 0 {
            f0 = d.design.first_frequency_hz.unwrap_or(0.0);
            if f0.is_nan() || f0 <= 0.0 {
                return Err(PipelineError::Unphysical {
                    what: "front: d0's first natural frequency".into(),
                    value: format!("{f0}"),
                    expected: "a frequency > 0 Hz",
                    hint: "the workspace design has no stage eigenproblem to continue from".into(),
                });
            }
        }
        progress.note(&line(&d, options.scan_hz));
        designs.push(d);
        x = Some(xk);
    }
    let front = FrontFile {
        version: VERSION,
        scan_hz: options.scan_hz,
        max_error_pct: options.max_error_pct,
        designs,
        seconds: t0.elapsed().as_secs_f64(),
    };
    write_front(folder, &front)?;
    Ok(FrontSummary {
        front,
        dir: folder.dir().path(files::DIR),
    })
}

/// The scenario of the front: the run's, with its resonance bound removed (d0 is the workspace
/// design); the front needs the two-PEA workspace objective.
fn front_scenario(s: &Scenario) -> Result<Scenario> {
    crate::design::two_pea_stage(s, "front")?;
    if s.optimization.objective != ObjectiveKind::Workspace {
        return Err(flexstage_scenario::ScenarioError::Inconsistent {
            fields: "optimization.objective".into(),
            reason: "the front sweeps a first-frequency bound on the workspace design: set \
                     objective = \"workspace\""
                .into(),
        }
        .into());
    }
    let mut s = s.clone();
    s.optimization.min_frequency = 0.0;
    Ok(s)
}

/// A one-line account of a design.
pub fn line(d: &FrontDesign, scan_hz: f64) -> String {
    let f = |v: Option<f64>| v.map_or("-".into(), |x| format!("{x:.0}"));
    let scan = d.best().map_or("no scan".into(), |b| {
        format!(
            "{} {:.2}/{:.2} % of range at {scan_hz:.0} Hz",
            b.controller, b.percent[0], b.percent[1]
        )
    });
    format!(
        "d{}: workspace {:.0} µm², first frequency {} Hz (body-fitted {}, twin {}), {:.1} g, \
         {} ({} it); {}",
        d.index,
        d.design.area * 1e12,
        f(d.design.first_frequency_hz),
        f(d.body_fitted_hz),
        f(d.twin_hz),
        d.design.mass * 1e3,
        if d.safe { "safe" } else { "NOT safe" },
        d.iterations,
        scan
    )
}

/// Designs, analyses, verifies and assesses one design of the front; returns it with its
/// design variables (the next design's start).
fn design_one(
    folder: &RunFolder,
    s: &Scenario,
    k: usize,
    start: Option<&[f64]>,
    scan_hz: f64,
    progress: &dyn Progress,
) -> Result<(FrontDesign, Vec<f64>)> {
    let problem = Problem::from_scenario(s, None)?;
    let mut params = OptimizerParams::from_scenario(s);
    let t = Instant::now();
    let mut opt = match start {
        None => Optimizer::new(&problem, params)?,
        Some(x) => {
            params.mma.asyinit = CONTINUATION_STEP;
            params.mma.move_limit = CONTINUATION_STEP;
            Optimizer::continue_from(&problem, params, x, RESTART_BETA)?
        }
    };
    progress.start(
        &format!("front d{k}"),
        s.optimization.max_iterations as u64 + 1,
    );
    let stop = opt.run(|_, rec| {
        progress.set_position(rec.iteration as u64 + 1);
        let f1 = rec
            .frequencies
            .first()
            .map_or(String::new(), |f| format!(", f1 {f:.0} Hz"));
        progress.set_message(&format!("J {:.0} µm²{f1}", rec.area * 1e12));
        Ok(())
    })?;
    progress.finish();
    let seconds = t.elapsed().as_secs_f64();
    let (dens, _) = opt.last().expect("an iteration ran");
    let rho = dens.physical.clone();
    let fin = final_analysis(s, dens, opt.params().robust)?;
    let run = folder.dir();
    let mesh = problem.mesh();
    let record = crate::convert::design_record(&fin.summary);
    let file = DesignFile {
        version: DESIGN_VERSION,
        scenario: s.name.clone(),
        nl: mesh.nl,
        nw: mesh.nw,
        rho: rho.clone(),
        iterations: opt.history().len(),
        area_initial: opt.history()[0].area,
        area: fin.summary.area,
        grey_fraction: opt.history().last().map_or(0.0, |r| r.grey),
        summary: Some(record.clone()),
    };
    run.store(&files::design(k), file)?;
    let modes = stage_modes(&problem, &rho, &ModalParams::default(), false)?;
    crate::figures::write_modes(
        run,
        &files::modes(k),
        |m| files::mode_png(k, m),
        files::MODE_PNGS,
        mesh,
        &rho,
        (&modes.shapes, &modes.frequencies),
    )?;
    let mut d = FrontDesign {
        index: k,
        min_frequency_hz: s.optimization.min_frequency,
        stop: format!("{stop:?}"),
        iterations: opt.history().len(),
        seconds,
        design: record,
        body_fitted_hz: None,
        body_fitted_stress: None,
        safe: false,
        reasons: Vec::new(),
        twin_hz: None,
        scan: Vec::new(),
    };
    verify_one(folder, s, k, &rho, &mut d)?;
    assess_one(s, &rho, scan_hz, &mut d, progress)?;
    Ok((d, opt.x().to_vec()))
}

/// The outline of design `k` and its body-fitted verification (frequency, stress, verdict).
fn verify_one(
    folder: &RunFolder,
    s: &Scenario,
    k: usize,
    rho: &[f64],
    d: &mut FrontDesign,
) -> Result<()> {
    let o = crate::export::ExportOptions::default();
    let (nl, nw) = (s.mesh.nl, s.mesh.nw);
    let (dx, dy) = (s.mesh.length / nl as f64, s.mesh.width / nw as f64);
    let outline =
        Outline::from_fem_order(nl, nw, dx, dy, o.level, o.smoothing, rho)?.refined(o.max_chord);
    folder.dir().write(
        &files::outline(k),
        outline.to_svg(Unit::Millimetres).as_bytes(),
    )?;
    let p = flexstage_verify::VerifyParams::from_limits(&s.limits);
    match flexstage_verify::verify(s, rho, &outline.loops, &p) {
        Ok(v) => {
            d.body_fitted_hz = v.body_fitted.frequencies.first().copied();
            d.body_fitted_stress = Some(v.body_fitted.peak().von_mises);
            d.safe = v.verdict.safe;
            d.reasons = v.verdict.reasons.clone();
        }
        Err(e) => d.reasons = vec![format!("the verification could not run: {e}")],
    }
    Ok(())
}

/// The twin of the design and the error against scan frequency of `track`'s controllers on
/// it, designed as `track` designs them, at the default sweep's fractions and the named speed.
fn assess_one(
    s: &Scenario,
    rho: &[f64],
    scan_hz: f64,
    d: &mut FrontDesign,
    progress: &dyn Progress,
) -> Result<()> {
    let twin = match flexstage_twin::Twin::from_scenario(s, rho) {
        Ok(t) => t,
        Err(e) => {
            d.reasons.push(format!("no twin: {e}"));
            return Ok(());
        }
    };
    let f1 = twin.first_resonance();
    d.twin_hz = Some(f1);
    // The plant `track` would simulate: the reduced model of this design (Section 4.2).
    let problem = flexstage_reduce::reduction_problem(s, false)?;
    let reduced = flexstage_reduce::reduce(
        s,
        &problem,
        rho,
        &flexstage_reduce::ReduceParams {
            modal: None,
            validity: None,
            ..flexstage_reduce::ReduceParams::default()
        },
    )?;
    let plant = crate::plant::designed(s, reduced.params)?;
    // The controllers designed from the twin measured in its rig, as `track` designs them.
    let (bench, _) =
        crate::track::measured_bench(&Setup::from_scenario(&plant), &twin, false, progress)?;
    let Some(amplitude) = crate::scan::start_amplitude(s) else {
        return Ok(());
    };
    let fraction = scan_hz / f1;
    if !(fraction > 0.0 && fraction < 0.45) {
        progress.note(&format!(
            "d{}: {scan_hz:.0} Hz is beyond the scan sweep's reach (0.45 × the twin's {f1:.0} Hz)",
            d.index
        ));
        return Ok(());
    }
    let points = sweep::sweep(
        &bench,
        &CONTROLLERS,
        amplitude,
        &SweepParams {
            fractions: vec![fraction],
            ..SweepParams::default()
        },
    )?;
    if let Some(p) = points.first() {
        d.scan = p
            .results
            .iter()
            .map(|r| ScanError {
                controller: r.controller.name.into(),
                rms: r.rms,
                percent: r.rms_pct,
                amplitude: r.amplitude,
            })
            .collect();
    }
    Ok(())
}

/// `front.json`, `front.csv` and the figure `front.svg`.
fn write_front(folder: &RunFolder, f: &FrontFile) -> Result<()> {
    let run = folder.dir();
    run.store(files::JSON, f.clone())?;
    run.store(files::CSV, front_table(f))?;
    run.write(files::SVG, front_svg(f)?.as_bytes())?;
    Ok(())
}

fn front_table(f: &FrontFile) -> Table {
    let col = |g: &dyn Fn(&FrontDesign) -> f64| f.designs.iter().map(g).collect::<Vec<f64>>();
    let opt = |v: Option<f64>| v.unwrap_or(f64::NAN);
    let best = |d: &FrontDesign, a: usize| d.best().map_or(f64::NAN, |b| b.percent[a]);
    Table::new(
        &[
            "design",
            "min_frequency_hz",
            "area_m2",
            "first_frequency_hz",
            "body_fitted_hz",
            "twin_hz",
            "mass_kg",
            "design_mesh_stress_pa",
            "body_fitted_stress_pa",
            "safe",
            "best_scan_error_q1_pct",
            "best_scan_error_q2_pct",
            "iterations",
        ],
        vec![
            col(&|d| d.index as f64),
            col(&|d| d.min_frequency_hz),
            col(&|d| d.design.area),
            col(&|d| opt(d.design.first_frequency_hz)),
            col(&|d| opt(d.body_fitted_hz)),
            col(&|d| opt(d.twin_hz)),
            col(&|d| d.design.mass),
            col(&|d| d.design.peak_stress),
            col(&|d| opt(d.body_fitted_stress)),
            col(&|d| f64::from(u8::from(d.safe))),
            col(&|d| best(d, 0)),
            col(&|d| best(d, 1)),
            col(&|d| d.iterations as f64),
        ],
    )
}

/// Workspace against first resonance, one marker per design, its best controller's error at
/// the scan speed in the legend.
fn front_svg(f: &FrontFile) -> Result<String> {
    let mut fig = Figure::new(
        format!(
            "Workspace–first-resonance front (tracking error at a {:.0} Hz scan)",
            f.scan_hz
        ),
        "workspace area [µm²]",
        "stage's first natural frequency [Hz]",
    )
    .with_legend(Legend::UpperRight);
    let pts: Vec<(f64, f64)> = f
        .designs
        .iter()
        .filter_map(|d| Some((d.design.area * 1e12, d.design.first_frequency_hz?)))
        .collect();
    // Each design a diamond marker a few percent of the data range across.
    let span = |v: &dyn Fn(&(f64, f64)) -> f64| {
        let (lo, hi) = pts
            .iter()
            .map(v)
            .fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
        (hi - lo).max(1e-9 * hi.abs()).max(f64::MIN_POSITIVE)
    };
    let (rx, ry) = (0.015 * span(&|p| p.0), 0.025 * span(&|p| p.1));
    fig = fig.with(Series::line("", pts.clone()).with_color(0));
    for (i, d) in f.designs.iter().enumerate() {
        let Some(f1) = d.design.first_frequency_hz else {
            continue;
        };
        let err = d.best().map_or("no scan".into(), |b| {
            format!(
                "{} {:.2} % / {:.2} %",
                b.controller, b.percent[0], b.percent[1]
            )
        });
        let (x, y) = (d.design.area * 1e12, f1);
        fig = fig.with(
            Series::closed(
                format!(
                    "d{}: {f1:.0} Hz, {err}{}",
                    d.index,
                    if d.safe { "" } else { ", NOT safe" }
                ),
                vec![(x - rx, y), (x, y + ry), (x + rx, y), (x, y - ry)],
            )
            .with_color(i + 1),
        );
    }
    Ok(fig.to_svg()?)
}
