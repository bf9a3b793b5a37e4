//! Result files shared by `design` and `analyze`: the deformed mesh, per-case tables and
//! workspace polygons.

use flexstage_fem::Design;
use flexstage_figures::mode_shape;
use flexstage_figures::plot::{Figure, Series};
use flexstage_figures::vtk::{PointField, QuadMesh};
use flexstage_run::files::design::POLYGON;
use flexstage_run::{RunDir, Table};
use flexstage_topopt::{CaseResults as Response, Problem};

use crate::error::Result;

/// Writes the deformed mesh as VTU: displacement, density, strain-energy density and von
/// Mises stress.
pub(crate) fn write_vtu(
    run: &RunDir,
    rel: &str,
    problem: &Problem,
    rho: &[f64],
    u: &[f64],
) -> Result<()> {
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

/// Width of the mode-shape pictures \[px\] (two per row of the report).
const MODE_PNG_WIDTH: u32 = 640;

/// Mode shapes of a design: a VTU for ParaView at `vtu` (one `mode_<k>_<f>Hz` point array per
/// mode, scaled to a largest nodal displacement of 1, and the cell densities) and the lowest
/// `pngs` as pictures at `png(k)` (k from 1; the solid cells drawn deformed).
pub(crate) fn write_modes(
    run: &RunDir,
    vtu: &str,
    png: impl Fn(usize) -> String,
    pngs: usize,
    mesh: &flexstage_fem::Mesh,
    rho: &[f64],
    (shapes, frequencies): (&[Vec<f64>], &[f64]),
) -> Result<()> {
    let points: Vec<[f64; 2]> = (0..mesh.n_nodes()).map(|n| mesh.node_coords(n)).collect();
    let cells: Vec<[usize; 4]> = (0..mesh.n_elements())
        .map(|e| mesh.element_nodes(e))
        .collect();
    let shapes: Vec<Vec<[f64; 2]>> = shapes
        .iter()
        .map(|phi| {
            let mx = phi.iter().fold(0.0f64, |a, v| a.max(v.abs())).max(1e-300);
            (0..mesh.n_nodes())
                .map(|n| [phi[2 * n] / mx, phi[2 * n + 1] / mx])
                .collect()
        })
        .collect();
    let names: Vec<String> = frequencies
        .iter()
        .enumerate()
        .map(|(k, f)| format!("mode_{}_{:.0}Hz", k + 1, f))
        .collect();
    let text = QuadMesh {
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
    run.write(vtu, text.as_bytes())?;
    let picture = mode_shape::Mesh {
        points: &points,
        cells: &cells,
        density: Some(rho),
    };
    for (k, shape) in shapes.iter().take(pngs).enumerate() {
        if let Some(bytes) = mode_shape::png(&picture, shape, MODE_PNG_WIDTH) {
            run.write(&png(k + 1), &bytes)?;
        }
    }
    Ok(())
}

/// Per-case table: nominal strokes, input displacements, output (µm) and strain energy (J).
pub(crate) fn cases_table(problem: &Problem, r: &Response) -> Table {
    let col = |f: &dyn Fn(usize) -> f64| (0..r.outputs.len()).map(f).collect::<Vec<f64>>();
    let second = |v: &[f64]| v.get(1).copied().unwrap_or(0.0) * 1e6;
    let x1 = col(&|k| problem.cases[k][0] * 1e6);
    let x2 = col(&|k| second(&problem.cases[k]));
    let u1 = col(&|k| r.inputs[k][0] * 1e6);
    let u2 = col(&|k| second(&r.inputs[k]));
    let xo = col(&|k| r.outputs[k][0] * 1e6);
    let yo = col(&|k| r.outputs[k][1] * 1e6);
    Table::new(
        &[
            "x_nom1_um",
            "x_nom2_um",
            "x_in1_um",
            "x_in2_um",
            "x_out_um",
            "y_out_um",
            "strain_energy_J",
        ],
        vec![x1, x2, u1, u2, xo, yo, r.energies.clone()],
    )
}

/// Figure of one or more output polygons (µm).
pub(crate) fn polygon_svg(title: &str, polys: &[(String, &[[f64; 2]])]) -> Result<String> {
    let mut fig = Figure::new(title, "x_out [µm]", "y_out [µm]").equal_aspect();
    for (label, p) in polys {
        fig = fig.with(Series::closed(
            label.clone(),
            p.iter().map(|q| (q[0] * 1e6, q[1] * 1e6)).collect(),
        ));
    }
    Ok(fig.to_svg()?)
}

/// An output polygon \[m\] as a table in µm.
pub(crate) fn polygon_table(p: &[[f64; 2]]) -> Table {
    let x: Vec<f64> = p.iter().map(|q| q[0] * 1e6).collect();
    let y: Vec<f64> = p.iter().map(|q| q[1] * 1e6).collect();
    Table::new(&POLYGON, vec![x, y])
}

/// Reads back [`polygon_table`] (metres); rows with a missing value are skipped.
pub(crate) fn table_polygon(t: &Table) -> Vec<[f64; 2]> {
    let Ok(c) = t.columns(&POLYGON) else {
        return Vec::new();
    };
    c[0].iter()
        .zip(c[1])
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .map(|(x, y)| [x * 1e-6, y * 1e-6])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexstage_run::Format;

    #[test]
    fn polygons_round_trip_through_csv() {
        let p = [[1e-6, -2.5e-6], [3.25e-6, 4e-7]];
        let back = table_polygon(&Table::decode(&polygon_table(&p).encode().unwrap()).unwrap());
        assert_eq!(back.len(), 2);
        for (a, b) in p.iter().zip(&back) {
            assert!((a[0] - b[0]).abs() < 1e-18 && (a[1] - b[1]).abs() < 1e-18);
        }
        assert!(table_polygon(&Table::decode(b"a,b\n1,2\n").unwrap()).is_empty());
    }
}
