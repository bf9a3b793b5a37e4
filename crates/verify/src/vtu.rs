//! The body-fitted mesh and its fields as a VTK XML unstructured grid (`.vtu`, ParaView):
//! quadratic triangles (VTK cell type 22: three vertices, then the mid-sides of edges 0–1,
//! 1–2, 2–0, the node order of [`crate::mesh::TriMesh`]).

use std::fmt::Write as _;

use crate::mesh::TriMesh;

/// The mesh with nodal `displacement` \[m\] and `von_mises` \[Pa\] as a VTU document.
pub fn to_vtu(mesh: &TriMesh, displacement: &[[f64; 2]], von_mises: &[f64]) -> String {
    let (np, nc) = (mesh.nodes.len(), mesh.elements.len());
    let mut s = String::with_capacity(96 * np + 64 * nc);
    s.push_str("<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\">\n<UnstructuredGrid>\n");
    let _ = writeln!(s, "<Piece NumberOfPoints=\"{np}\" NumberOfCells=\"{nc}\">");
    s.push_str("<PointData Scalars=\"von_mises_stress\" Vectors=\"displacement\">\n");
    s.push_str("<DataArray type=\"Float64\" Name=\"von_mises_stress\" format=\"ascii\">\n");
    for v in von_mises {
        let _ = writeln!(s, "{v:e}");
    }
    s.push_str("</DataArray>\n<DataArray type=\"Float64\" Name=\"displacement\" NumberOfComponents=\"3\" format=\"ascii\">\n");
    for d in displacement {
        let _ = writeln!(s, "{:e} {:e} 0", d[0], d[1]);
    }
    s.push_str("</DataArray>\n</PointData>\n<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n");
    for p in &mesh.nodes {
        let _ = writeln!(s, "{:e} {:e} 0", p[0], p[1]);
    }
    s.push_str("</DataArray>\n</Points>\n<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n");
    for el in &mesh.elements {
        let _ = writeln!(
            s,
            "{} {} {} {} {} {}",
            el[0], el[1], el[2], el[3], el[4], el[5]
        );
    }
    s.push_str("</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n");
    for k in 1..=nc {
        let _ = writeln!(s, "{}", 6 * k);
    }
    s.push_str("</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n");
    for _ in 0..nc {
        s.push_str("22\n");
    }
    s.push_str("</DataArray>\n</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
    s
}
