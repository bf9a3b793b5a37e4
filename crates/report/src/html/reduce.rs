//! Reduced-model sections: the lumped parameters of Section 3.2.1 with the validity map, and
//! the mode shapes of the design (drawn from `reduce/modes.vtu`).

use std::io::Cursor;

use image::{ImageFormat, Rgb, RgbImage};

use super::{Builder, Width, fmt_num, num};
use crate::layout::reduce as files;

/// Section "reduce": α, θ, stiffnesses, mass, frequencies, checks, validity map.
pub(super) fn reduce(b: &mut Builder) {
    match b.json(files::SUMMARY_JSON) {
        Some(r) => {
            let f = |p: &[&str]| num(&r, p).map(fmt_num).unwrap_or_else(|| "–".into());
            let mut rows = vec![
                ("α (scalar, Eq. 27)".to_string(), f(&["alpha_scalar"])),
                ("tilt θ [°]".into(), f(&["theta_deg"])),
                ("K_qo1 [N/m]".into(), f(&["k_qo1"])),
                ("K_qo2 [N/m]".into(), f(&["k_qo2"])),
                ("moving mass M [kg]".into(), f(&["mass_kg"])),
                ("volume fraction".into(), f(&["volume_fraction"])),
            ];
            let modal = r.get("modal");
            if let Some(fr) = modal
                .and_then(|m| m.get("frequencies_hz"))
                .and_then(|v| v.as_array())
            {
                let list: Vec<String> = fr.iter().filter_map(|v| v.as_f64()).map(fmt_num).collect();
                rows.push(("natural frequencies [Hz]".into(), list.join(", ")));
            }
            if let Some(a2) = modal
                .and_then(|m| m.get("assumption2"))
                .and_then(|v| v.as_str())
            {
                rows.push(("Assumption 2".into(), a2.to_string()));
            }
            if let Some(v) = num(&r, &["validity", "max_error_within_stroke"]) {
                rows.push((
                    "reduced vs nonlinear FE within the stroke".into(),
                    format!("max {} %", fmt_num(100.0 * v)),
                ));
            }
            b.kv(&rows);
        }
        None => b.not_run(&format!("{} missing", files::SUMMARY_JSON)),
    }
    for (rel, caption) in [
        (
            files::VALIDITY_SVG,
            "Validity map: reduced model vs nonlinear FE",
        ),
        (
            files::VALIDITY_SCALE_SVG,
            "Model error against stroke scale",
        ),
    ] {
        if b.exists(rel) {
            b.img(rel, caption);
        }
    }
}

/// Section "modes": the lowest mode shapes, two per row.
pub(super) fn modes(b: &mut Builder) {
    let Some(vtu) = b.text(files::MODES_VTU) else {
        b.not_run(&format!("{} missing", files::MODES_VTU));
        return;
    };
    let shapes = mode_shape_pngs(&vtu, 4, 640);
    if shapes.is_empty() {
        b.not_run(&format!("{} has no mode shapes", files::MODES_VTU));
        return;
    }
    b.note(
        "Solid cells (ρ ≥ 0.5) drawn deformed by each mode (largest displacement 6 % of the \
         domain length), shaded by displacement magnitude (blue: still, red: largest).",
    );
    b.grid_open();
    for (name, png) in shapes {
        let label = name.replace('_', " ").replacen("Hz", " Hz", 1);
        b.png(&png, &label, Some(files::MODES_VTU), Width::Half);
    }
    b.grid_close();
}

/// Mode shapes of a `modes.vtu` written by `flexstage reduce`, as PNG pictures `width`
/// pixels wide: the mesh cells with density ≥ 0.5 drawn deformed (largest displacement 6 %
/// of the domain length), shaded by displacement magnitude. At most `max_modes`, each
/// `(array name, PNG bytes)`. A raster keeps the file small whatever the mesh (a vector
/// drawing needs one path per cell).
pub fn mode_shape_pngs(vtu: &str, max_modes: usize, width: u32) -> Vec<(String, Vec<u8>)> {
    let arrays = vtu_arrays(vtu);
    let get = |name: &str| arrays.iter().find(|(n, _)| n == name).map(|(_, v)| v);
    let (Some(points), Some(conn)) = (arrays.first().map(|(_, v)| v), get("connectivity")) else {
        return Vec::new();
    };
    let np = points.len() / 3;
    let nc = conn.len() / 4;
    let density = get("density").filter(|d| d.len() == nc);
    let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
    for p in points.chunks(3) {
        lo = [lo[0].min(p[0]), lo[1].min(p[1])];
        hi = [hi[0].max(p[0]), hi[1].max(p[1])];
    }
    let (w, h) = (hi[0] - lo[0], hi[1] - lo[1]);
    if !(w > 0.0 && h > 0.0) || width == 0 {
        return Vec::new();
    }
    let margin = 0.08 * w;
    let px = f64::from(width) / (w + 2.0 * margin);
    let height = ((h + 2.0 * margin) * px).ceil() as u32;
    let mut out = Vec::new();
    for (name, u) in arrays.iter().filter(|(n, _)| n.starts_with("mode_")) {
        if out.len() >= max_modes || u.len() != 3 * np {
            continue;
        }
        let umax = u.chunks(3).map(|d| d[0].hypot(d[1])).fold(0.0, f64::max);
        let scale = if umax > 0.0 { 0.06 * w / umax } else { 0.0 };
        let mut img = RgbImage::from_pixel(width, height, Rgb([255, 255, 255]));
        for c in 0..nc {
            if density.is_some_and(|d| d[c] < 0.5) {
                continue;
            }
            let nodes = &conn[4 * c..4 * c + 4];
            if nodes.iter().any(|&n| n as usize >= np) {
                continue;
            }
            let mut quad = [(0.0, 0.0); 4];
            let mut mag = 0.0;
            for (k, &nf) in nodes.iter().enumerate() {
                let n = nf as usize;
                let x = points[3 * n] + scale * u[3 * n] - lo[0] + margin;
                let y = points[3 * n + 1] + scale * u[3 * n + 1] - lo[1] + margin;
                quad[k] = (x * px, f64::from(height) - y * px);
                mag += u[3 * n].hypot(u[3 * n + 1]) / 4.0;
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
        if img
            .write_to(&mut Cursor::new(&mut bytes), ImageFormat::Png)
            .is_ok()
        {
            out.push((name.clone(), bytes));
        }
    }
    out
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

/// Every `<DataArray>` of an ASCII VTU: (name, values); the unnamed points array is "".
fn vtu_arrays(vtu: &str) -> Vec<(String, Vec<f64>)> {
    let mut out = Vec::new();
    let mut rest = vtu;
    while let Some(start) = rest.find("<DataArray") {
        let after = &rest[start..];
        let Some(tag_end) = after.find('>') else {
            break;
        };
        let tag = &after[..tag_end];
        let name = tag
            .split("Name=\"")
            .nth(1)
            .and_then(|s| s.split('"').next())
            .unwrap_or("")
            .to_string();
        let body_start = tag_end + 1;
        let Some(body_len) = after[body_start..].find("</DataArray>") else {
            break;
        };
        let values = after[body_start..body_start + body_len]
            .split_whitespace()
            .filter_map(|t| t.parse::<f64>().ok())
            .collect();
        out.push((name, values));
        rest = &after[body_start + body_len..];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mode_shapes_are_drawn_from_a_vtu() {
        // Goal: the VTU reader finds the mode arrays; solid cells are painted, void cells
        // and the margin stay white.
        use crate::vtk::{PointField, QuadMesh};
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
        let mesh = QuadMesh {
            points: &points,
            cells: &cells,
            point_data: vec![("mode_1_100Hz", PointField::Vector2(&u))],
            cell_data: vec![("density", &rho[..])],
        };
        let shapes = mode_shape_pngs(&mesh.to_vtu().unwrap(), 4, 216);
        assert_eq!(shapes.len(), 1);
        assert_eq!(shapes[0].0, "mode_1_100Hz");
        let img = image::load_from_memory(&shapes[0].1).unwrap().to_rgb8();
        // 216 px over 2 + 2·0.16 length units: 93.1 px per unit, margin 14.9 px.
        assert_eq!(img.dimensions(), (216, 123));
        let white = Rgb([255, 255, 255]);
        assert_ne!(*img.get_pixel(60, 62), white, "solid cell painted");
        assert_eq!(*img.get_pixel(155, 62), white, "void cell skipped");
        assert_eq!(*img.get_pixel(3, 3), white, "margin");
    }
}
