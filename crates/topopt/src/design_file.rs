//! Density CSV input and output: the densities of a design as one row per element
//! (`i,j,x,y,rho`), what `flexstage design` writes beside the finished design and what
//! `--design FILE.csv` reads.

use crate::error::{Result, TopoptError};

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
