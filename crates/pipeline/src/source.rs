//! Where a design comes from (`--design`): the run's own design, a uniform density, or a file.

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use flexstage_run::files::design::DesignFile;
use flexstage_run::{Format, layout};
use flexstage_topopt::{Problem, read_density_csv};

use crate::error::{PipelineError, Result};
use crate::folder::RunFolder;

/// A design to analyse, reduce or export.
#[derive(Debug, Clone, PartialEq)]
pub enum DesignSource {
    /// The run folder's finished design ([`layout::design::DESIGN`]).
    Run,
    /// A uniform density: the scenario's initial density (`None`) or the given one.
    Uniform(Option<f64>),
    /// A `design.json`, a density `.csv` (`i,j,rho` columns) or `.png`, or another run folder
    /// (its finished design).
    File(PathBuf),
}

impl DesignSource {
    /// The run's design if it has a finished one, else the uniform start design.
    pub fn run_or_uniform(folder: &RunFolder) -> DesignSource {
        if folder.dir().exists(layout::design::DESIGN) {
            DesignSource::Run
        } else {
            DesignSource::Uniform(None)
        }
    }

    /// A folder-name tag for results of this design: `None` for the run's own design.
    pub fn tag(&self) -> Option<String> {
        match self {
            DesignSource::Run => None,
            DesignSource::Uniform(None) => Some("uniform".into()),
            DesignSource::Uniform(Some(v)) => Some(format!("uniform-{v}")),
            DesignSource::File(p) => {
                let stem = p
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_else(|| "design".into());
                Some(plain(&stem))
            }
        }
    }
}

/// `name` with every character that is not a letter, digit, `-`, `_` or `.` replaced by `-`,
/// at most 60 characters.
pub(crate) fn plain(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '-'
            }
        })
        .take(60)
        .collect();
    if layout::is_plain_name(&s) {
        s
    } else {
        "x".into()
    }
}

impl FromStr for DesignSource {
    type Err = PipelineError;

    /// `run`, `uniform`, `uniform:RHO` (RHO in [0, 1]) or a path.
    fn from_str(text: &str) -> Result<Self> {
        if text == "run" {
            return Ok(DesignSource::Run);
        }
        let Some(rest) = text.strip_prefix("uniform") else {
            return Ok(DesignSource::File(PathBuf::from(text)));
        };
        let bad = || PipelineError::Option {
            option: "design",
            value: format!("{text:?}"),
            expected: "run, uniform, uniform:RHO with RHO in [0, 1], or a file".into(),
        };
        match rest.strip_prefix(':') {
            None if rest.is_empty() => Ok(DesignSource::Uniform(None)),
            None => Ok(DesignSource::File(PathBuf::from(text))),
            Some(v) => match v.parse::<f64>() {
                Ok(v) if (0.0..=1.0).contains(&v) => Ok(DesignSource::Uniform(Some(v))),
                _ => Err(bad()),
            },
        }
    }
}

impl fmt::Display for DesignSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DesignSource::Run => write!(f, "the run's design"),
            DesignSource::Uniform(None) => write!(f, "the uniform start design"),
            DesignSource::Uniform(Some(v)) => write!(f, "uniform density {v}"),
            DesignSource::File(p) => write!(f, "{}", p.display()),
        }
    }
}

/// Physical densities (fem order `e = i·n_w + j`, passive overrides applied) of `source` on
/// the mesh of `problem`.
pub fn load_design(
    folder: &RunFolder,
    source: &DesignSource,
    problem: &Problem,
) -> Result<Vec<f64>> {
    let mesh = problem.mesh();
    let (nl, nw) = (mesh.nl, mesh.nw);
    let mut rho = match source {
        DesignSource::Uniform(v) => vec![v.unwrap_or(problem.initial_density); nl * nw],
        DesignSource::Run => {
            let path = folder.dir().path(layout::design::DESIGN);
            // The design this process stored or loaded is not parsed again.
            let Some(d) = folder.dir().load::<DesignFile>(layout::design::DESIGN)? else {
                return Err(PipelineError::Missing {
                    what: "finished design",
                    path,
                    hint: "run `flexstage design` first, or choose a design".into(),
                });
            };
            check_mesh(&path, &d, nl, nw)?;
            d.rho.clone()
        }
        DesignSource::File(path) if path.is_dir() => {
            read_file(&path.join(layout::design::DESIGN), nl, nw)?
        }
        DesignSource::File(path) => read_file(path, nl, nw)?,
    };
    mesh.apply_passive(&mut rho, problem.rho_min);
    Ok(rho)
}

/// Densities in fem order from a design.json, density CSV or density PNG.
fn read_file(path: &Path, nl: usize, nw: usize) -> Result<Vec<f64>> {
    let bytes = crate::error::read_bytes(path)?;
    let format = |reason: String| PipelineError::Format {
        path: path.display().to_string(),
        reason,
    };
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "json" => {
            let d = DesignFile::decode(&bytes).map_err(|r| format(format!("design file: {r}")))?;
            check_mesh(path, &d, nl, nw)?;
            Ok(d.rho)
        }
        "csv" => Ok(read_density_csv(&String::from_utf8_lossy(&bytes), nl, nw)?),
        "png" => {
            let r = flexstage_figures::image::read_density_png(&bytes, nl, nw)?;
            // image order r[j·nl + i] → fem order e = i·nw + j
            Ok((0..nl * nw).map(|e| r[(e % nw) * nl + e / nw]).collect())
        }
        other => Err(format(format!(
            "unknown design file type {other:?}: expected .json, .csv, .png or a run folder"
        ))),
    }
}

/// Refuses a design of another mesh than the scenario's.
fn check_mesh(path: &Path, d: &DesignFile, nl: usize, nw: usize) -> Result<()> {
    if (d.nl, d.nw) != (nl, nw) {
        return Err(PipelineError::Format {
            path: path.display().to_string(),
            reason: format!(
                "a {} x {} design; the scenario's mesh is {nl} x {nw}",
                d.nl, d.nw
            ),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexstage_fem::Kinematics;

    #[test]
    fn sources_parse_and_name_their_variant() {
        assert_eq!("run".parse::<DesignSource>().unwrap(), DesignSource::Run);
        assert_eq!(
            "uniform".parse::<DesignSource>().unwrap(),
            DesignSource::Uniform(None)
        );
        assert_eq!(
            "uniform:0.3".parse::<DesignSource>().unwrap(),
            DesignSource::Uniform(Some(0.3))
        );
        let e = "uniform:1.5"
            .parse::<DesignSource>()
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("design") && e.contains("1.5") && e.contains("[0, 1]"),
            "{e}"
        );
        let f = "runs/a b/picture.png".parse::<DesignSource>().unwrap();
        assert_eq!(f.tag().as_deref(), Some("picture"));
        assert_eq!(DesignSource::Run.tag(), None);
        assert_eq!(plain("a b/c"), "a-b-c");
    }

    #[test]
    fn csv_png_and_json_designs_read_the_same_densities() {
        // Reference: the writers of the same crates (density_csv, density_png, DesignFile).
        // Goal: one asymmetric density, written in the three formats, reads back in fem order
        // (the PNG to its 8-bit grey resolution) with the passive regions applied.
        let s = crate::folder::preset("quick").unwrap();
        let problem = Problem::from_scenario(&s, Some(Kinematics::TotalLagrangian)).unwrap();
        let mesh = problem.mesh();
        let (nl, nw) = (mesh.nl, mesh.nw);
        let rho: Vec<f64> = (0..nl * nw)
            .map(|e| ((e / nw) as f64 / nl as f64 + 0.3 * (e % nw) as f64 / nw as f64).min(1.0))
            .collect();
        let mut expected = rho.clone();
        mesh.apply_passive(&mut expected, problem.rho_min);
        let root = std::env::temp_dir().join(format!("flexstage-source-{}", std::process::id()));
        let folder = RunFolder::open(s.clone(), &root, true).unwrap();
        let dir = folder.dir();
        let csv = flexstage_topopt::density_csv(nl, nw, mesh.dx(), mesh.dy(), &rho);
        let png = flexstage_figures::image::density_png(nl, nw, 1, |i, j| rho[i * nw + j]).unwrap();
        let file = DesignFile {
            version: flexstage_run::files::design::DESIGN_VERSION,
            scenario: s.name.clone(),
            nl,
            nw,
            rho: rho.clone(),
            iterations: 0,
            area_initial: 0.0,
            area: 0.0,
            grey_fraction: 0.0,
            summary: None,
        };
        let csv_path = dir.path("d.csv");
        std::fs::write(&csv_path, csv).unwrap();
        let png_path = dir.path("d.png");
        std::fs::write(&png_path, png).unwrap();
        dir.write(layout::design::DESIGN, &file.encode().unwrap())
            .unwrap();
        let load = |src: DesignSource| load_design(&folder, &src, &problem).unwrap();
        let worst = |rho: Vec<f64>| {
            assert_eq!(rho.len(), expected.len());
            rho.iter()
                .zip(&expected)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max)
        };
        // JSON: exact (serde_json's float_roundtrip).
        assert_eq!(worst(load(DesignSource::Run)), 0.0);
        assert_eq!(worst(load(DesignSource::File(root.clone()))), 0.0);
        assert_eq!(load(DesignSource::File(csv_path)), expected, "CSV is exact");
        let png = worst(load(DesignSource::File(png_path)));
        assert!(png <= 0.5 / 255.0 + 1e-12, "PNG differs by {png}");
        let bad = dir.path("d.txt");
        std::fs::write(&bad, b"").unwrap();
        let e = load_design(&folder, &DesignSource::File(bad), &problem).unwrap_err();
        assert!(e.to_string().contains("unknown design file type"), "{e}");
        std::fs::remove_dir_all(&root).unwrap();
    }
}
