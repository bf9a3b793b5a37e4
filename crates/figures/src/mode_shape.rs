//! The mode shapes of a design as pictures: the mesh cells with density ≥ 0.5 drawn deformed
//! by the mode (largest displacement 6 % of the domain length), shaded by displacement
//! magnitude. A raster keeps the file small whatever the mesh (a vector drawing needs one
//! path per cell).

use std::io::Cursor;

use image::{ImageFormat, Rgb, RgbImage};

/// A quadrilateral mesh with its cell densities.
#[derive(Debug, Clone, Copy)]
pub struct Mesh<'a> {
    /// Node coordinates (x, y).
    pub points: &'a [[f64; 2]],
    /// Four node indices per cell.
    pub cells: &'a [[usize; 4]],
    /// Density per cell (`None`: every cell drawn).
    pub density: Option<&'a [f64]>,
}

/// One mode shape (displacement per node) drawn on `mesh` as a PNG `width` pixels wide;
/// `None` when the mesh has no extent, the shape does not fit it, or encoding fails.
pub fn png(mesh: &Mesh, shape: &[[f64; 2]], width: u32) -> Option<Vec<u8>> {
    let (points, cells) = (mesh.points, mesh.cells);
    let np = points.len();
    if shape.len() != np || width == 0 {
        return None;
    }
    let density = mesh.density.filter(|d| d.len() == cells.len());
    let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
    for p in points {
        lo = [lo[0].min(p[0]), lo[1].min(p[1])];
        hi = [hi[0].max(p[0]), hi[1].max(p[1])];
    }
    let (w, h) = (hi[0] - lo[0], hi[1] - lo[1]);
    if !(w > 0.0 && h > 0.0) {
        return None;
    }
    let margin = 0.08 * w;
    let px = f64::from(width) / (w + 2.0 * margin);
    let height = ((h + 2.0 * margin) * px).ceil() as u32;
    let umax = shape.iter().map(|d| d[0].hypot(d[1])).fold(0.0, f64::max);
    let scale = if umax > 0.0 { 0.06 * w / umax } else { 0.0 };
    let mut img = RgbImage::from_pixel(width, height, Rgb([255, 255, 255]));
    for (c, nodes) in cells.iter().enumerate() {
        if density.is_some_and(|d| d[c] < 0.5) || nodes.iter().any(|&n| n >= np) {
            continue;
        }
        let mut quad = [(0.0, 0.0); 4];
        let mut mag = 0.0;
        for (k, &n) in nodes.iter().enumerate() {
            let x = points[n][0] + scale * shape[n][0] - lo[0] + margin;
            let y = points[n][1] + scale * shape[n][1] - lo[1] + margin;
            quad[k] = (x * px, f64::from(height) - y * px);
            mag += shape[n][0].hypot(shape[n][1]) / 4.0;
        }
        let t = if umax > 0.0 { mag / umax } else { 0.0 };
        // Blue (still) to red (largest displacement).
        let color = Rgb([
            (40.0 + 200.0 * t) as u8,
            (90.0 + 60.0 * (1.0 - t)) as u8,
            (200.0 * (1.0 - t) + 30.0) as u8,
        ]);
        fill_quad(&mut img, &quad, color);
    }
    let mut bytes = Vec::new();
    img.write_to(&mut Cursor::new(&mut bytes), ImageFormat::Png)
        .ok()?;
    Some(bytes)
}

/// Fills the pixels whose centres lie inside a quadrilateral (either orientation; a
/// deformed cell stays convex at these amplitudes, a non-convex one is filled as the
/// intersection of its edge half-planes).
fn fill_quad(img: &mut RgbImage, q: &[(f64, f64); 4], color: Rgb<u8>) {
    let (w, h) = img.dimensions();
    let x0 = q
        .iter()
        .map(|p| p.0)
        .fold(f64::MAX, f64::min)
        .floor()
        .max(0.0) as u32;
    let x1 = q
        .iter()
        .map(|p| p.0)
        .fold(f64::MIN, f64::max)
        .ceil()
        .min(f64::from(w)) as u32;
    let y0 = q
        .iter()
        .map(|p| p.1)
        .fold(f64::MAX, f64::min)
        .floor()
        .max(0.0) as u32;
    let y1 = q
        .iter()
        .map(|p| p.1)
        .fold(f64::MIN, f64::max)
        .ceil()
        .min(f64::from(h)) as u32;
    let edge = |a: (f64, f64), b: (f64, f64), p: (f64, f64)| {
        (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0)
    };
    for y in y0..y1 {
        for x in x0..x1 {
            let p = (f64::from(x) + 0.5, f64::from(y) + 0.5);
            let s: Vec<f64> = (0..4).map(|k| edge(q[k], q[(k + 1) % 4], p)).collect();
            if s.iter().all(|&v| v >= 0.0) || s.iter().all(|&v| v <= 0.0) {
                img.put_pixel(x, y, color);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solid_cells_are_painted_and_void_cells_skipped() {
        // Goal: solid cells are painted, void cells and the margin stay white.
        let points = [
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0],
            [0.0, 1.0],
            [2.0, 0.0],
            [2.0, 1.0],
        ];
        let cells = [[0, 1, 2, 3], [1, 4, 5, 2]];
        let u: Vec<[f64; 2]> = (0..6).map(|i| [0.0, i as f64 * 1e-4]).collect();
        let rho = [1.0, 0.2];
        let mesh = Mesh {
            points: &points,
            cells: &cells,
            density: Some(&rho),
        };
        let shape = png(&mesh, &u, 216).unwrap();
        let img = image::load_from_memory(&shape).unwrap().to_rgb8();
        // 216 px over 2 + 2·0.16 length units: 93.1 px per unit, margin 14.9 px.
        assert_eq!(img.dimensions(), (216, 123));
        let white = Rgb([255, 255, 255]);
        assert_ne!(*img.get_pixel(60, 62), white, "solid cell painted");
        assert_eq!(*img.get_pixel(155, 62), white, "void cell skipped");
        assert_eq!(*img.get_pixel(3, 3), white, "margin");
    }
}
