//! Scenario → problem, and where a design comes from (`--design`): shared by `analyze` and
//! `design`. The scenario → FE model mapping itself lives in `flexstage_topopt::problem`
//! (one place for analyze, design and reduce).

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use flexstage_fem::Kinematics;
use flexstage_scenario::Scenario;
use flexstage_topopt::{DesignFile, Problem, read_density_csv};

/// The final-analysis problem of a scenario: nonlinear kinematics, no additive material.
pub fn analysis_problem(s: &Scenario) -> anyhow::Result<Problem> {
    Problem::from_scenario(s, Some(Kinematics::TotalLagrangian))
        .context("cannot build the finite-element model of the scenario")
}

/// Physical densities (fem order `e = i·n_w + j`, passive overrides applied) from a design
/// source: `uniform` / `uniform:RHO`, a density CSV (`i,j,rho` columns), a density PNG, a
/// `design.json`, or a run folder (its `design/design.json`).
pub fn load_design(source: &str, problem: &Problem) -> anyhow::Result<Vec<f64>> {
    let mesh = problem.mesh();
    let (nl, nw) = (mesh.nl, mesh.nw);
    let mut rho = if let Some(rest) = source.strip_prefix("uniform") {
        let v = match rest.strip_prefix(':') {
            Some(v) => v
                .parse::<f64>()
                .with_context(|| format!("--design {source}: bad density {v:?}"))?,
            None if rest.is_empty() => problem.initial_density,
            None => bail!("--design {source}: expected uniform or uniform:RHO"),
        };
        if !(0.0..=1.0).contains(&v) {
            bail!("--design {source}: the density must be in [0, 1]");
        }
        vec![v; nl * nw]
    } else {
        let path = PathBuf::from(source);
        let file = if path.is_dir() {
            path.join("design").join("design.json")
        } else {
            path.clone()
        };
        let bytes =
            std::fs::read(&file).with_context(|| format!("cannot read {}", file.display()))?;
        match ext(&file).as_str() {
            "json" => {
                let d = DesignFile::from_json(&bytes)
                    .with_context(|| format!("in {}", file.display()))?;
                if (d.nl, d.nw) != (nl, nw) {
                    bail!(
                        "{} is a {} x {} design, the scenario mesh is {nl} x {nw}",
                        file.display(),
                        d.nl,
                        d.nw
                    );
                }
                d.rho
            }
            "csv" => read_density_csv(&String::from_utf8_lossy(&bytes), nl, nw)
                .with_context(|| format!("in {}", file.display()))?,
            "png" => {
                let r = flexstage_report::image::read_density_png(&bytes, nl, nw)
                    .with_context(|| format!("in {}", file.display()))?;
                // image order rho[j*nl + i] → fem order e = i*nw + j
                let mut out = vec![0.0; nl * nw];
                for i in 0..nl {
                    for j in 0..nw {
                        out[i * nw + j] = r[j * nl + i];
                    }
                }
                out
            }
            other => bail!(
                "--design {}: unknown file type {other:?} (expected .csv, .png, .json or a run folder)",
                file.display()
            ),
        }
    };
    mesh.apply_passive(&mut rho, problem.rho_min);
    Ok(rho)
}

fn ext(p: &Path) -> String {
    p.extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default()
}
