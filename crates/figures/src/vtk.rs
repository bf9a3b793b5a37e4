//! VTK XML unstructured-grid files (`.vtu`) for ParaView.
//!
//! The format is small enough to write directly (ASCII `DataArray`s); this avoids a heavy
//! dependency and keeps files diff-able. Cells are 4-node quadrilaterals (VTK type 9) in the
//! plane z = 0.

use std::fmt::Write as _;

/// Data attached to the nodes.
#[derive(Debug, Clone)]
pub enum PointField<'a> {
    /// One value per node.
    Scalar(&'a [f64]),
    /// A 2D vector per node (written with z = 0, so ParaView can warp by it).
    Vector2(&'a [[f64; 2]]),
}

/// A quadrilateral mesh with node and cell data.
#[derive(Debug, Clone)]
pub struct QuadMesh<'a> {
    /// Node coordinates (x, y).
    pub points: &'a [[f64; 2]],
    /// Node indices of each quadrilateral, counter-clockwise.
    pub cells: &'a [[usize; 4]],
    /// Named node fields.
    pub point_data: Vec<(&'a str, PointField<'a>)>,
    /// Named cell fields, one value per cell.
    pub cell_data: Vec<(&'a str, &'a [f64])>,
}

/// Errors of the VTU writer.
#[derive(Debug, thiserror::Error)]
pub enum VtkError {
    /// A field does not have one entry per node or cell.
    #[error("field {name:?} has {got} entries, expected {expected}")]
    Length {
        /// The field.
        name: String,
        /// Entries found.
        got: usize,
        /// Entries expected.
        expected: usize,
    },
    /// A cell names a node that does not exist.
    #[error("cell {cell} refers to node {node}, but there are {nodes} nodes")]
    Node {
        /// The cell.
        cell: usize,
        /// The node index.
        node: usize,
        /// Number of nodes.
        nodes: usize,
    },
}

impl QuadMesh<'_> {
    /// The mesh as a VTU document.
    pub fn to_vtu(&self) -> Result<String, VtkError> {
        let (np, nc) = (self.points.len(), self.cells.len());
        for (c, cell) in self.cells.iter().enumerate() {
            if let Some(&node) = cell.iter().find(|&&n| n >= np) {
                return Err(VtkError::Node {
                    cell: c,
                    node,
                    nodes: np,
                });
            }
        }
        let len_err = |name: &str, got: usize, expected: usize| VtkError::Length {
            name: name.to_string(),
            got,
            expected,
        };
        let mut s = String::with_capacity(64 * (np + nc));
        s.push_str("<?xml version=\"1.0\"?>\n");
        s.push_str(
            "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\">\n",
        );
        s.push_str("<UnstructuredGrid>\n");
        let _ = writeln!(s, "<Piece NumberOfPoints=\"{np}\" NumberOfCells=\"{nc}\">");
        s.push_str(
            "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n",
        );
        for p in self.points {
            let _ = writeln!(s, "{:e} {:e} 0", p[0], p[1]);
        }
        s.push_str("</DataArray>\n</Points>\n<Cells>\n");
        s.push_str("<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n");
        for c in self.cells {
            let _ = writeln!(s, "{} {} {} {}", c[0], c[1], c[2], c[3]);
        }
        s.push_str("</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n");
        for i in 0..nc {
            let _ = write!(s, "{} ", 4 * (i + 1));
        }
        s.push_str("\n</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n");
        for _ in 0..nc {
            s.push_str("9 ");
        }
        s.push_str("\n</DataArray>\n</Cells>\n<PointData>\n");
        for (name, field) in &self.point_data {
            match field {
                PointField::Scalar(v) => {
                    if v.len() != np {
                        return Err(len_err(name, v.len(), np));
                    }
                    let _ = writeln!(
                        s,
                        "<DataArray type=\"Float64\" Name=\"{name}\" format=\"ascii\">"
                    );
                    for x in v.iter() {
                        let _ = writeln!(s, "{x:e}");
                    }
                }
                PointField::Vector2(v) => {
                    if v.len() != np {
                        return Err(len_err(name, v.len(), np));
                    }
                    let _ = writeln!(
                        s,
                        "<DataArray type=\"Float64\" Name=\"{name}\" NumberOfComponents=\"3\" format=\"ascii\">"
                    );
                    for x in v.iter() {
                        let _ = writeln!(s, "{:e} {:e} 0", x[0], x[1]);
                    }
                }
            }
            s.push_str("</DataArray>\n");
        }
        s.push_str("</PointData>\n<CellData>\n");
        for (name, v) in &self.cell_data {
            if v.len() != nc {
                return Err(len_err(name, v.len(), nc));
            }
            let _ = writeln!(
                s,
                "<DataArray type=\"Float64\" Name=\"{name}\" format=\"ascii\">"
            );
            for x in v.iter() {
                let _ = writeln!(s, "{x:e}");
            }
            s.push_str("</DataArray>\n");
        }
        s.push_str("</CellData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_quads_have_consistent_counts() {
        let points = [
            [0.0, 0.0],
            [1.0, 0.0],
            [2.0, 0.0],
            [0.0, 1.0],
            [1.0, 1.0],
            [2.0, 1.0],
        ];
        let cells = [[0, 1, 4, 3], [1, 2, 5, 4]];
        let u = [[0.0, 0.1]; 6];
        let rho = [1.0, 0.5];
        let mesh = QuadMesh {
            points: &points,
            cells: &cells,
            point_data: vec![("displacement", PointField::Vector2(&u))],
            cell_data: vec![("density", &rho)],
        };
        let vtu = mesh.to_vtu().unwrap();
        assert!(vtu.contains("NumberOfPoints=\"6\" NumberOfCells=\"2\""));
        assert!(vtu.contains("Name=\"displacement\" NumberOfComponents=\"3\""));
        assert!(vtu.contains("\n4 8 \n"));
        assert_eq!(vtu.matches("<DataArray").count(), 6);
        assert_eq!(vtu.matches("</DataArray>").count(), 6);
    }

    #[test]
    fn wrong_field_length_is_reported() {
        let points = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let cells = [[0, 1, 2, 3]];
        let rho = [1.0, 0.5];
        let mesh = QuadMesh {
            points: &points,
            cells: &cells,
            point_data: vec![],
            cell_data: vec![("density", &rho)],
        };
        let e = mesh.to_vtu().unwrap_err().to_string();
        assert!(e.contains("density") && e.contains("expected 1"), "{e}");
    }
}
