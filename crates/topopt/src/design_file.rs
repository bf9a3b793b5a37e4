//! The final design file (`design/design.json`) that `flexstage analyze` and `reduce` read, and
//! density CSV input/output.
//!
//! To rebuild the model of a design: load the run's `scenario.toml`, call
//! [`crate::Problem::from_scenario`] with `Some(Kinematics::TotalLagrangian)` (the final analysis
//! has no additive material), and use [`DesignFile::rho`] as the physical densities
//! (`Design::new(&file.rho)`), in fem element order `e = i·n_w + j`.

use serde::{Deserialize, Serialize};

use crate::error::{Result, TopoptError};
use crate::summary::DesignSummary;

/// A finished (or in-progress) design.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DesignFile {
    /// Format version (1).
    pub version: u32,
    /// Scenario name.
    pub scenario: String,
    /// Elements along x.
    pub nl: usize,
    /// Elements along y.
    pub nw: usize,
    /// Physical densities ρ (after filter, projection and passive overrides), fem order
    /// `e = i·n_w + j` (column i from the left, row j from the bottom).
    pub rho: Vec<f64>,
    /// Design iterations performed.
    pub iterations: usize,
    /// Workspace area of the initial design, final nonlinear analysis \[m²\].
    pub area_initial: f64,
    /// Workspace area of this design, final nonlinear analysis \[m²\].
    pub area: f64,
    /// Fraction of design elements with 0.1 < ρ < 0.9.
    pub grey_fraction: f64,
    /// What the design delivers: α, θ, area, mass, stress, minimum sizes (absent in files of
    /// older versions).
    #[serde(default)]
    pub summary: Option<DesignSummary>,
}

impl DesignFile {
    /// Parses and checks a design file.
    pub fn from_json(bytes: &[u8]) -> Result<Self> {
        let d: DesignFile = serde_json::from_slice(bytes).map_err(|e| TopoptError::Format {
            what: "design file".into(),
            reason: e.to_string(),
        })?;
        if d.rho.len() != d.nl * d.nw || d.rho.iter().any(|r| !(0.0..=1.0).contains(r)) {
            return Err(TopoptError::Format {
                what: "design file".into(),
                reason: format!(
                    "rho must have nl·nw = {} entries in [0, 1], it has {}",
                    d.nl * d.nw,
                    d.rho.len()
                ),
            });
        }
        Ok(d)
    }
    /// As pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("design file serializes")
    }
}

/// Density CSV with header `i,j,x,y,rho` (element column/row from the bottom-left, centroid
/// \[m\], density), one row per element in fem order.
pub fn density_csv(nl: usize, nw: usize, dx: f64, dy: f64, rho: &[f64]) -> String {
    let mut s = String::from("i,j,x,y,rho\n");
    for i in 0..nl {
        for j in 0..nw {
            s.push_str(&format!(
                "{i},{j},{},{},{}\n",
                (i as f64 + 0.5) * dx,
                (j as f64 + 0.5) * dy,
                rho[i * nw + j]
            ));
        }
    }
    s
}

/// Reads a density CSV with columns `i`, `j` and `rho` (any order, other columns ignored),
/// returning densities in fem order.
pub fn read_density_csv(text: &str, nl: usize, nw: usize) -> Result<Vec<f64>> {
    let bad = |reason: String| TopoptError::Format {
        what: "density CSV".into(),
        reason,
    };
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header: Vec<&str> = lines
        .next()
        .ok_or_else(|| bad("empty file".into()))?
        .split(',')
        .map(str::trim)
        .collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .ok_or_else(|| bad(format!("missing column {name:?} (need i, j, rho)")))
    };
    let (ci, cj, cr) = (col("i")?, col("j")?, col("rho")?);
    let mut rho = vec![f64::NAN; nl * nw];
    for (n, line) in lines.enumerate() {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let get = |c: usize| {
            f.get(c)
                .ok_or_else(|| bad(format!("row {}: too few columns", n + 2)))
        };
        let i: usize = get(ci)?
            .parse()
            .map_err(|_| bad(format!("row {}: bad i", n + 2)))?;
        let j: usize = get(cj)?
            .parse()
            .map_err(|_| bad(format!("row {}: bad j", n + 2)))?;
        let r: f64 = get(cr)?
            .parse()
            .map_err(|_| bad(format!("row {}: bad rho", n + 2)))?;
        if i >= nl || j >= nw || !(0.0..=1.0).contains(&r) {
            return Err(bad(format!(
                "row {}: (i, j, rho) = ({i}, {j}, {r}) outside the {nl} x {nw} mesh or [0, 1]",
                n + 2
            )));
        }
        rho[i * nw + j] = r;
    }
    if let Some(e) = rho.iter().position(|r| r.is_nan()) {
        return Err(bad(format!(
            "no density for element i = {}, j = {}",
            e / nw,
            e % nw
        )));
    }
    Ok(rho)
}
