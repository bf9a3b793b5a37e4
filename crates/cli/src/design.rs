//! `flexstage design`: workspace topology optimization (paper Section 2.2, Algorithm 1) with
//! checkpoints, resume and an adjoint-vs-finite-difference gradient check.

use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;
use flexstage_fem::AdditiveYeoh;
use flexstage_report::{RunDir, csv_columns};
use flexstage_scenario::Scenario;
use flexstage_topopt::check::{CheckSetup, check_gradients};
use flexstage_topopt::summary::final_analysis;
use flexstage_topopt::{
    AnalysisParams, DesignFile, DesignSpace, Evaluator, IterationRecord, Optimizer,
    OptimizerParams, Problem, density_csv, perimeter_walk, shoelace,
};

use crate::analyze::{cases_csv, polygon_svg, write_vtu};
use crate::build;
use crate::scenario_args::ScenarioArgs;

/// Arguments of `flexstage design`.
#[derive(Debug, Args)]
pub struct DesignArgs {
    #[command(flatten)]
    pub scenario: ScenarioArgs,
    /// Run folder (default runs/<scenario name>); results go to its design/ sub-folder.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Continue an interrupted run from RUN_DIR/design/checkpoint.bin (the scenario is read
    /// from RUN_DIR/scenario.toml).
    #[arg(long, value_name = "RUN_DIR", conflicts_with = "out")]
    pub resume: Option<PathBuf>,
    /// Compare adjoint gradients with central finite differences on a small nonlinear mesh
    /// (additive material on) and exit.
    #[arg(long)]
    pub check_gradients: bool,
    /// Save a checkpoint every N iterations.
    #[arg(long, default_value_t = 10, value_name = "N")]
    pub checkpoint_every: usize,
    /// Save the workspace polygon every N iterations (and at 0 and the end).
    #[arg(long, default_value_t = 25, value_name = "N")]
    pub snapshot_every: usize,
    /// Override optimization.max_iterations.
    #[arg(long, value_name = "N")]
    pub max_iterations: Option<usize>,
}

fn gradient_check(s: &Scenario) -> anyhow::Result<()> {
    let mut s = s.clone();
    s.mesh.nl = 16;
    s.mesh.nw = 8;
    s.regions.clear();
    s.optimization.samples = 8;
    s.actuators.stroke_amplitude = 3e-4;
    s.actuators.max_stroke = s.actuators.max_stroke.max(1e-3);
    let problem = Problem::from_scenario(&s, None)?;
    let params = OptimizerParams::from_scenario(&s);
    let ne = problem.mesh().n_elements();
    let e0 = s.material.youngs_modulus;
    let yeoh = AdditiveYeoh::uniform(ne, 1e-6 * e0, 1e-3 * e0);
    let n = DesignSpace::new(problem.mesh(), problem.mirror_symmetry)?.n();
    let x: Vec<f64> = (0..n)
        .map(|j| 0.3 + 0.6 * (0.5 + 0.5 * (j as f64 * 0.77).sin()))
        .collect();
    let setup = CheckSetup {
        filter_radius: params.effective_filter_radius(),
        robust: params.thresholds(),
        eta: 0.5,
        beta: 2.0,
    };
    println!(
        "gradient check: {} x {} mesh, p_m = {}, strokes ±{} µm, nonlinear, additive material on, \
         filter {:.2} elements, projection β = 2{}; central differences h = 1e-6",
        s.mesh.nl,
        s.mesh.nw,
        s.optimization.samples,
        s.actuators.stroke_amplitude * 1e6,
        setup.filter_radius,
        if setup.robust.is_some() {
            ", eroded/blueprint/dilated designs"
        } else {
            ""
        }
    );
    let checks = check_gradients(&problem, &setup, Some(&yeoh), &x, 10, 1e-6)?;
    let mut ok = true;
    for c in &checks {
        let pass = c.relative_error <= 1e-5;
        ok &= pass;
        println!(
            "  {:<26} relative error {:.2e} over {} variables (max |grad| {:.3e})  {}",
            c.name,
            c.relative_error,
            c.checked,
            c.scale,
            if pass { "ok" } else { "FAIL (> 1e-5)" }
        );
    }
    if !ok {
        bail!("gradient check failed");
    }
    Ok(())
}

/// The lowest natural frequency of the design: the mechanism held by the PEA springs, without
/// the optimizer's output load or plate masses (flexstage-reduce's modal analysis).
fn first_frequency(s: &Scenario, rho: &[f64]) -> anyhow::Result<f64> {
    let problem = flexstage_reduce::reduction_problem(s, false)?;
    let params = flexstage_reduce::ModalParams {
        modes: 1,
        ..flexstage_reduce::ModalParams::default()
    };
    let modes =
        flexstage_reduce::modal_analysis(&problem.model, rho, s.material.density, &[], &params)?;
    Ok(modes.frequencies[0])
}

/// A named history column.
type Column<'a> = (&'a str, &'a dyn Fn(&IterationRecord) -> f64);

fn history_csv(names: &[&str], h: &[IterationRecord]) -> String {
    let col = |f: &dyn Fn(&IterationRecord) -> f64| h.iter().map(f).collect::<Vec<f64>>();
    let mut header = vec!["iteration", "area_m2", "objective", "f0"];
    let mut cols = vec![
        col(&|r| r.iteration as f64),
        col(&|r| r.area),
        col(&|r| r.objective),
        col(&|r| r.f0),
    ];
    for (i, n) in names.iter().enumerate() {
        header.push(n);
        cols.push(col(&|r| r.constraints[i]));
    }
    let rest: [Column; 13] = [
        ("energy_J", &|r| r.energy),
        ("stroke_ratio", &|r| r.stroke),
        ("volume", &|r| r.volume),
        ("grey", &|r| r.grey),
        ("change", &|r| r.change),
        ("mean_change", &|r| r.mean_change),
        ("kkt", &|r| r.kkt.unwrap_or(f64::NAN)),
        ("beta", &|r| r.beta),
        ("newton_total", &|r| r.newton_total as f64),
        ("newton_max", &|r| r.newton_max as f64),
        ("retried_cases", &|r| r.retried_cases.len() as f64),
        ("time_s", &|r| r.time),
        ("area_rel", &|r| r.area / h[0].area),
    ];
    for (n, f) in rest {
        header.push(n);
        cols.push(col(f));
    }
    let refs: Vec<&[f64]> = cols.iter().map(Vec::as_slice).collect();
    csv_columns(&header, &refs)
}

fn polygon_csv(p: &[[f64; 2]]) -> String {
    let x: Vec<f64> = p.iter().map(|q| q[0] * 1e6).collect();
    let y: Vec<f64> = p.iter().map(|q| q[1] * 1e6).collect();
    csv_columns(&["x_out_um", "y_out_um"], &[&x, &y])
}

fn read_polygon_csv(text: &str) -> Vec<[f64; 2]> {
    text.lines()
        .skip(1)
        .filter_map(|l| {
            let mut f = l.split(',').map(|v| v.trim().parse::<f64>());
            match (f.next(), f.next()) {
                (Some(Ok(x)), Some(Ok(y))) => Some([x * 1e-6, y * 1e-6]),
                _ => None,
            }
        })
        .collect()
}

pub fn run(args: DesignArgs) -> anyhow::Result<()> {
    let (mut s, run) = match &args.resume {
        Some(dir) => {
            let s = Scenario::load(&dir.join("scenario.toml"))
                .with_context(|| format!("cannot resume {}", dir.display()))?;
            (s, RunDir::create(dir)?)
        }
        None => {
            let s = args.scenario.load()?;
            if args.check_gradients {
                return gradient_check(&s);
            }
            let run = crate::run_dir::open_run(args.out.clone(), &s)?;
            (s, run)
        }
    };
    if let Some(n) = args.max_iterations {
        s.optimization.max_iterations = n;
    }
    anyhow::ensure!(args.checkpoint_every >= 1, "--checkpoint-every must be ≥ 1");
    anyhow::ensure!(args.snapshot_every >= 1, "--snapshot-every must be ≥ 1");
    let problem = Problem::from_scenario(&s, None).context("cannot build the problem")?;
    let params = OptimizerParams::from_scenario(&s);
    let mut opt = match &args.resume {
        Some(dir) => {
            let path = dir.join("design").join("checkpoint.bin");
            let bytes =
                std::fs::read(&path).with_context(|| format!("cannot read {}", path.display()))?;
            let o = Optimizer::resume(&problem, params, &bytes)
                .with_context(|| format!("cannot resume from {}", path.display()))?;
            eprintln!("resuming {} at iteration {}", dir.display(), o.iteration());
            o
        }
        None => Optimizer::new(&problem, params)?,
    };
    let names = opt.constraint_names();
    let max_it = s.optimization.max_iterations;
    let bar = crate::run_dir::progress(max_it as u64 + 1, "design");
    bar.set_position(opt.iteration() as u64);
    let t0 = std::time::Instant::now();
    let (ck_every, snap_every) = (args.checkpoint_every, args.snapshot_every);
    let input_square = (2.0 * s.actuators.stroke_amplitude).powi(2);
    let stop = opt.run(|o, rec| {
        bar.set_position(rec.iteration as u64 + 1);
        let g: Vec<String> = names
            .iter()
            .zip(&rec.constraints)
            .map(|(n, v)| format!("{n} {v:+.3}"))
            .collect();
        bar.set_message(format!(
            "J {:.0} µm² ({:.2} × input square)  {}  grey {:.2}  β {}",
            rec.area * 1e12,
            rec.area / input_square,
            g.join(" "),
            rec.grey,
            rec.beta
        ));
        for &c in &rec.retried_cases {
            bar.println(format!(
                "iteration {}: load case {c} needed a cutback retry",
                rec.iteration
            ));
        }
        let io = |e: anyhow::Error| flexstage_topopt::TopoptError::Format {
            what: "run folder".into(),
            reason: format!("{e:#}"),
        };
        if rec.iteration % snap_every == 0 || o.stopped().is_some() {
            let (_, ev) = o.last().expect("evaluated");
            run.write(
                format!("design/workspace_iter{:05}.csv", rec.iteration),
                polygon_csv(&ev.blueprint().response.outputs).as_bytes(),
            )
            .map_err(|e| io(e.into()))?;
        }
        if o.stopped().is_none() && o.iteration() % ck_every == 0 {
            run.write("design/checkpoint.bin", &o.checkpoint())
                .map_err(|e| io(e.into()))?;
            run.write(
                "design/history.csv",
                history_csv(&names, o.history()).as_bytes(),
            )
            .map_err(|e| io(e.into()))?;
        }
        Ok(())
    })?;
    bar.finish_and_clear();
    let secs = t0.elapsed().as_secs_f64();
    let h = opt.history();
    let (dens, _) = opt.last().expect("at least one iteration");
    let rho = dens.physical.clone();
    let mesh = problem.mesh();
    let (nl, nw) = (mesh.nl, mesh.nw);

    // Final analysis: nonlinear, no additive material, the workspace samples, every
    // realization; α, θ, area, mass, stress, minimum sizes.
    let mut fin = final_analysis(&s, dens, opt.params().robust).context("final analysis")?;
    fin.summary.first_frequency_hz = Some(first_frequency(&s, &rho).context("modal analysis")?);
    let r = fin.response.clone();
    let mut initial = build::analysis_problem(&s)?;
    initial.cases = perimeter_walk(s.optimization.samples, s.actuators.stroke_amplitude);
    let mut ev = Evaluator::new(&initial, AnalysisParams::default())?;
    let mut rho0 = vec![s.optimization.initial_density; rho.len()];
    mesh.apply_passive(&mut rho0, problem.rho_min);
    let r0 = ev
        .solve_cases(&rho0, None)
        .context("final analysis of the initial design")?;
    let (a0, a1) = (shoelace(&r0.outputs), fin.summary.area);
    let design_els = problem.design_elements();
    let grey = design_els
        .iter()
        .filter(|&&e| rho[e] > 0.1 && rho[e] < 0.9)
        .count() as f64
        / design_els.len() as f64;
    let file = DesignFile {
        version: 1,
        scenario: s.name.clone(),
        nl,
        nw,
        rho: rho.clone(),
        iterations: h.len(),
        area_initial: a0,
        area: a1,
        grey_fraction: grey,
        summary: Some(fin.summary.clone()),
    };
    run.write("design/design.json", file.to_json().as_bytes())?;
    run.write(
        "design/density.csv",
        density_csv(nl, nw, mesh.dx(), mesh.dy(), &rho).as_bytes(),
    )?;
    run.write(
        "design/density.png",
        &flexstage_report::image::density_png(nl, nw, 4, |i, j| rho[i * nw + j])?,
    )?;
    write_vtu(
        &run,
        "design/design.vtu",
        &initial,
        &rho,
        &fin.corner_displacement,
    )?;
    run.write("design/cases.csv", cases_csv(&initial, &r).as_bytes())?;
    run.write(
        "design/workspace_final.csv",
        polygon_csv(&r.outputs).as_bytes(),
    )?;
    run.write(
        "design/workspace_initial.csv",
        polygon_csv(&r0.outputs).as_bytes(),
    )?;
    run.write("design/history.csv", history_csv(&names, h).as_bytes())?;
    run.write(
        "design/history.json",
        serde_json::to_string_pretty(h)?.as_bytes(),
    )?;
    // Figure 4: polygons during the optimization (optimization model), initial and final
    // (final nonlinear analysis).
    let mut snaps: Vec<(usize, Vec<[f64; 2]>)> = Vec::new();
    if let Ok(rd) = std::fs::read_dir(run.path("design")) {
        for e in rd.flatten() {
            let name = e.file_name().to_string_lossy().to_string();
            if let Some(k) = name
                .strip_prefix("workspace_iter")
                .and_then(|v| v.strip_suffix(".csv"))
                .and_then(|v| v.parse::<usize>().ok())
            {
                if k < h.len() {
                    let text = std::fs::read_to_string(e.path()).unwrap_or_default();
                    snaps.push((k, read_polygon_csv(&text)));
                }
            }
        }
    }
    snaps.sort_by_key(|(k, _)| *k);
    let mut polys: Vec<(String, &[[f64; 2]])> = snaps
        .iter()
        .map(|(k, p)| (format!("iteration {k}"), p.as_slice()))
        .collect();
    run.write(
        "design/workspace_history.svg",
        polygon_svg("Output workspace during the optimization", &polys)?.as_bytes(),
    )?;
    polys = vec![
        ("initial design".into(), &r0.outputs),
        ("final design".into(), &r.outputs),
    ];
    run.write(
        "design/workspace.svg",
        polygon_svg("Output workspace, nonlinear analysis", &polys)?.as_bytes(),
    )?;
    let iters = h.len();
    let summary = serde_json::json!({
        "stop": format!("{stop:?}"),
        "iterations": iters,
        "seconds": secs,
        "seconds_per_iteration": h.iter().map(|r| r.time).sum::<f64>() / iters as f64,
        "design": fin.summary,
        "area_initial_m2": a0,
        "area_final_m2": a1,
        "grey_fraction": grey,
        "volume": h.last().map(|r| r.volume),
        "constraints": names.iter().zip(&h.last().unwrap().constraints).map(|(n, v)| (n.to_string(), *v)).collect::<std::collections::BTreeMap<_, _>>(),
        "retried_load_cases": h.iter().map(|r| r.retried_cases.len()).sum::<usize>(),
    });
    run.write(
        "design/summary.json",
        serde_json::to_string_pretty(&summary)?.as_bytes(),
    )?;
    println!(
        "{stop:?} after {iters} iterations in {secs:.1} s ({:.3} s/iteration)",
        h.iter().map(|r| r.time).sum::<f64>() / iters as f64
    );
    for line in fin.summary.lines() {
        println!("{line}");
    }
    eprintln!("wrote {}", run.path("design").display());
    Ok(())
}
