//! Manufacturing outline of a density field (paper Section 4.1: the stage is wire-cut from a
//! plate): the ρ = 0.5 iso-contour by marching squares, smoothed, as closed polylines, written
//! as DXF (R2000 `LWPOLYLINE`), SVG and a binary STL extruded by the plate thickness.
//!
//! The field is sampled at element centroids and padded with a ring of void (ρ = 0), so every
//! contour is closed and a solid element on the domain edge is cut exactly on that edge.
//! Every loop has the solid on its left: outer boundaries run counter-clockwise, holes
//! clockwise.

use std::collections::{HashMap, HashSet};
use std::fmt::Write as _;

/// Errors of the outline export.
#[derive(Debug, thiserror::Error)]
pub enum OutlineError {
    /// The density field does not match the grid.
    #[error("density field has {got} values; expected {nl} x {nw} = {}", nl * nw)]
    Size {
        /// Values given.
        got: usize,
        /// Elements along x.
        nl: usize,
        /// Elements along y.
        nw: usize,
    },
    /// The DXF writer failed.
    #[error("DXF: {0}")]
    Dxf(String),
}

/// Length unit of the exported drawings (the geometry itself is in metres).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// Metres.
    Metres,
    /// Millimetres.
    Millimetres,
}

impl Unit {
    /// Scale factor from metres to this unit.
    pub fn scale(self) -> f64 {
        match self {
            Unit::Metres => 1.0,
            Unit::Millimetres => 1e3,
        }
    }

    /// Short name ("m", "mm").
    pub fn symbol(self) -> &'static str {
        match self {
            Unit::Metres => "m",
            Unit::Millimetres => "mm",
        }
    }
}

/// The iso-contour of a density field on a regular grid of `nl × nw` elements of size
/// `dx × dy` [m].
#[derive(Debug, Clone)]
pub struct Outline {
    /// Closed loops (first point not repeated), metres, solid on the left.
    pub loops: Vec<Vec<[f64; 2]>>,
    /// Domain size [m] (`nl·dx`, `nw·dy`).
    pub domain: [f64; 2],
    /// Cap triangles of the solid region (unit-free indices into `cap_points`), counter-
    /// clockwise, for the STL extrusion.
    cap_triangles: Vec<[usize; 3]>,
    cap_points: Vec<[f64; 2]>,
    /// Loops as indices into `cap_points` (same order as `loops`).
    loop_indices: Vec<Vec<usize>>,
}

/// Padded sample grid: points `(a, b)` with `a ∈ 0..nl+2`, `b ∈ 0..nw+2`; point `(a, b)` is
/// the centroid of element `(a−1, b−1)`, or void outside the mesh.
struct Samples<'a> {
    nl: usize,
    nw: usize,
    dx: f64,
    dy: f64,
    rho: &'a dyn Fn(usize, usize) -> f64,
}

impl Samples<'_> {
    fn nx(&self) -> usize {
        self.nl + 2
    }
    fn value(&self, a: usize, b: usize) -> f64 {
        if a == 0 || b == 0 || a > self.nl || b > self.nw {
            0.0
        } else {
            (self.rho)(a - 1, b - 1)
        }
    }
    /// Position [m] of sample point `(a, b)`; the void ring sits on the domain edge so that
    /// the 0.5 crossing between a solid edge element and the ring is exactly on the edge.
    fn position(&self, a: usize, b: usize) -> [f64; 2] {
        let x = if a == 0 {
            -0.5 * self.dx
        } else {
            (a as f64 - 0.5) * self.dx
        };
        let y = if b == 0 {
            -0.5 * self.dy
        } else {
            (b as f64 - 0.5) * self.dy
        };
        [x, y]
    }
}

impl Outline {
    /// Extracts the `level` iso-contour of the density field `rho(i, j)` (column `i` from the
    /// left, row `j` from the bottom) and smooths it with `smoothing` Taubin passes
    /// (λ = 0.5, μ = −0.53; about shrink-free, 0 for the raw marching-squares polygon).
    pub fn extract(
        nl: usize,
        nw: usize,
        dx: f64,
        dy: f64,
        level: f64,
        smoothing: usize,
        rho: impl Fn(usize, usize) -> f64,
    ) -> Outline {
        let s = Samples {
            nl,
            nw,
            dx,
            dy,
            rho: &rho,
        };
        let nx = s.nx();
        let ny = nw + 2;
        // Crossing points, keyed by sample-grid edge: 2·(b·nx + a) is the edge from (a, b) to
        // (a+1, b), 2·(b·nx + a) + 1 the edge from (a, b) to (a, b+1).
        let mut point_of_edge: HashMap<usize, usize> = HashMap::new();
        let mut points: Vec<[f64; 2]> = Vec::new();
        let mut corner_point: HashMap<(usize, usize), usize> = HashMap::new();
        let mut next: HashMap<usize, usize> = HashMap::new();
        let mut triangles: Vec<[usize; 3]> = Vec::new();
        let inside = |v: f64| v >= level;
        for b in 0..ny - 1 {
            for a in 0..nx - 1 {
                // Corners counter-clockwise: (a,b), (a+1,b), (a+1,b+1), (a,b+1).
                let c = [(a, b), (a + 1, b), (a + 1, b + 1), (a, b + 1)];
                let v = c.map(|(p, q)| s.value(p, q));
                let ins = v.map(inside);
                let n_in = ins.iter().filter(|&&x| x).count();
                if n_in == 0 {
                    continue;
                }
                // Edge k joins corner k and corner k+1.
                let edge_key = |k: usize| -> usize {
                    match k {
                        0 => 2 * (b * nx + a),
                        1 => 2 * (b * nx + a + 1) + 1,
                        2 => 2 * ((b + 1) * nx + a),
                        _ => 2 * (b * nx + a) + 1,
                    }
                };
                // The cell's inside polygon (counter-clockwise): corners inside and crossings.
                let mut poly: Vec<usize> = Vec::with_capacity(8);
                let mut crossings: Vec<(usize, bool)> = Vec::with_capacity(4); // (edge k, exit?)
                for k in 0..4 {
                    let k1 = (k + 1) % 4;
                    if ins[k] {
                        let id = *corner_point.entry(c[k]).or_insert_with(|| {
                            points.push(s.position(c[k].0, c[k].1));
                            points.len() - 1
                        });
                        poly.push(id);
                    }
                    if ins[k] != ins[k1] {
                        let key = edge_key(k);
                        let id = *point_of_edge.entry(key).or_insert_with(|| {
                            let p0 = s.position(c[k].0, c[k].1);
                            let p1 = s.position(c[k1].0, c[k1].1);
                            let t = ((level - v[k]) / (v[k1] - v[k])).clamp(0.0, 1.0);
                            points.push([p0[0] + t * (p1[0] - p0[0]), p0[1] + t * (p1[1] - p0[1])]);
                            points.len() - 1
                        });
                        poly.push(id);
                        crossings.push((k, ins[k]));
                    }
                }
                // Segments run from an exit crossing (inside → outside, counter-clockwise) to
                // an entry crossing, which puts the solid on their left.
                let m = crossings.len();
                if m > 0 {
                    let center_inside = inside(v.iter().sum::<f64>() / 4.0);
                    for (idx, &(k, exit)) in crossings.iter().enumerate() {
                        if !exit {
                            continue;
                        }
                        // Saddle: a connected inside joins each exit to the next entry
                        // (cutting off outside corners), otherwise to the previous one.
                        let j = if m == 2 || center_inside {
                            (idx + 1) % m
                        } else {
                            (idx + m - 1) % m
                        };
                        let from = point_of_edge[&edge_key(k)];
                        let to = point_of_edge[&edge_key(crossings[j].0)];
                        next.insert(from, to);
                    }
                }
                // Caps: fan triangulation; the saddle with a void centre is two triangles.
                if m == 4 && !inside(v.iter().sum::<f64>() / 4.0) {
                    // poly is [c_k, x_k, x_{k+1}... ] per inside corner: split per corner.
                    for k in 0..4 {
                        if ins[k] {
                            let corner = corner_point[&c[k]];
                            let a_edge = point_of_edge[&edge_key(k)];
                            let b_edge = point_of_edge[&edge_key((k + 3) % 4)];
                            triangles.push([corner, a_edge, b_edge]);
                        }
                    }
                } else {
                    for w in 1..poly.len() - 1 {
                        triangles.push([poly[0], poly[w], poly[w + 1]]);
                    }
                }
            }
        }
        // Chain the segments into loops.
        let mut loop_indices: Vec<Vec<usize>> = Vec::new();
        let mut starts: Vec<usize> = next.keys().copied().collect();
        starts.sort_unstable();
        let mut used: HashSet<usize> = HashSet::new();
        for start in starts {
            if used.contains(&start) {
                continue;
            }
            let mut lp = vec![start];
            used.insert(start);
            let mut cur = next[&start];
            while cur != start {
                used.insert(cur);
                lp.push(cur);
                match next.get(&cur) {
                    Some(&n) => cur = n,
                    None => break,
                }
            }
            if lp.len() >= 3 {
                loop_indices.push(lp);
            }
        }
        // Taubin smoothing of the loop points (shared with the caps, so the STL stays closed).
        for _ in 0..smoothing {
            for factor in [0.5, -0.53] {
                let mut moved: Vec<(usize, [f64; 2])> = Vec::new();
                for lp in &loop_indices {
                    let n = lp.len();
                    for i in 0..n {
                        let p = points[lp[i]];
                        let a = points[lp[(i + n - 1) % n]];
                        let b = points[lp[(i + 1) % n]];
                        let lap = [0.5 * (a[0] + b[0]) - p[0], 0.5 * (a[1] + b[1]) - p[1]];
                        moved.push((lp[i], [p[0] + factor * lap[0], p[1] + factor * lap[1]]));
                    }
                }
                for (i, p) in moved {
                    points[i] = p;
                }
            }
        }
        let loops = loop_indices
            .iter()
            .map(|lp| lp.iter().map(|&i| points[i]).collect())
            .collect();
        Outline {
            loops,
            domain: [nl as f64 * dx, nw as f64 * dy],
            cap_triangles: triangles,
            cap_points: points,
            loop_indices,
        }
    }

    /// Like [`Outline::extract`] from densities in fem order `rho[i·nw + j]`.
    #[allow(clippy::too_many_arguments)]
    pub fn from_fem_order(
        nl: usize,
        nw: usize,
        dx: f64,
        dy: f64,
        level: f64,
        smoothing: usize,
        rho: &[f64],
    ) -> Result<Outline, OutlineError> {
        if rho.len() != nl * nw {
            return Err(OutlineError::Size {
                got: rho.len(),
                nl,
                nw,
            });
        }
        Ok(Outline::extract(
            nl,
            nw,
            dx,
            dy,
            level,
            smoothing,
            |i, j| rho[i * nw + j],
        ))
    }

    /// Signed area of each loop [m²] (positive: outer boundary, negative: hole).
    pub fn signed_areas(&self) -> Vec<f64> {
        self.loops.iter().map(|l| signed_area(l)).collect()
    }

    /// Area of the solid region enclosed by the loops [m²].
    pub fn area(&self) -> f64 {
        self.signed_areas().iter().sum()
    }

    /// The outline as a DXF drawing (AutoCAD R2000, one closed `LWPOLYLINE` per loop on layer
    /// "OUTLINE", `$INSUNITS` set), coordinates in `unit`.
    pub fn to_dxf(&self, unit: Unit) -> Result<Vec<u8>, OutlineError> {
        use dxf::entities::{Entity, EntityType, LwPolyline};
        use dxf::enums::{AcadVersion, Units};
        let mut drawing = dxf::Drawing::new();
        // dxf 0.6 writes R12 by default, which has no LWPOLYLINE and silently drops it.
        drawing.header.version = AcadVersion::R2000;
        drawing.header.default_drawing_units = match unit {
            Unit::Metres => Units::Meters,
            Unit::Millimetres => Units::Millimeters,
        };
        let k = unit.scale();
        for lp in &self.loops {
            let mut poly = LwPolyline::default();
            poly.set_is_closed(true);
            poly.vertices = lp
                .iter()
                .map(|p| dxf::LwPolylineVertex {
                    x: p[0] * k,
                    y: p[1] * k,
                    ..Default::default()
                })
                .collect();
            let mut e = Entity::new(EntityType::LwPolyline(poly));
            e.common.layer = "OUTLINE".into();
            drawing.add_entity(e);
        }
        let mut out = Vec::new();
        drawing
            .save(&mut out)
            .map_err(|e| OutlineError::Dxf(e.to_string()))?;
        Ok(out)
    }

    /// The outline as an SVG drawing: one `<path>` (even-odd fill, so holes stay open) in
    /// `unit`, y up, with the domain rectangle dashed.
    pub fn to_svg(&self, unit: Unit) -> String {
        let k = unit.scale();
        let (w, h) = (self.domain[0] * k, self.domain[1] * k);
        let m = 0.02 * w.max(h);
        let mut d = String::new();
        for lp in &self.loops {
            for (i, p) in lp.iter().enumerate() {
                let _ = write!(
                    d,
                    "{}{:.6} {:.6} ",
                    if i == 0 { "M" } else { "L" },
                    p[0] * k,
                    h - p[1] * k
                );
            }
            d.push_str("Z ");
        }
        let u = unit.symbol();
        format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{ww}{u}\" height=\"{hh}{u}\" \
             viewBox=\"{x0} {x0} {ww} {hh}\">\n\
             <title>flexstage outline, rho = 0.5 iso-contour ({u})</title>\n\
             <rect x=\"0\" y=\"0\" width=\"{w}\" height=\"{h}\" fill=\"none\" stroke=\"#999\" \
             stroke-width=\"{sw}\" stroke-dasharray=\"{dash}\"/>\n\
             <path d=\"{d}\" fill=\"#4a6fa5\" fill-opacity=\"0.35\" fill-rule=\"evenodd\" \
             stroke=\"#1b2a41\" stroke-width=\"{sw}\"/>\n</svg>\n",
            ww = w + 2.0 * m,
            hh = h + 2.0 * m,
            x0 = -m,
            sw = 0.002 * w.max(h),
            dash = 0.01 * w.max(h),
            d = d.trim_end(),
        )
    }

    /// The solid region extruded by `thickness` [m] as a binary STL in `unit`: top and bottom
    /// caps from the marching-squares cells and side walls along every loop. The mesh is
    /// closed (every edge is shared by two triangles) and normals point outwards.
    pub fn to_stl(&self, thickness: f64, unit: Unit) -> Vec<u8> {
        let k = unit.scale();
        let t = thickness * k;
        let p = |i: usize| [self.cap_points[i][0] * k, self.cap_points[i][1] * k];
        let mut tris: Vec<[[f64; 3]; 3]> = Vec::new();
        for tri in &self.cap_triangles {
            let [a, b, c] = tri.map(p);
            tris.push([[a[0], a[1], t], [b[0], b[1], t], [c[0], c[1], t]]);
            tris.push([[a[0], a[1], 0.0], [c[0], c[1], 0.0], [b[0], b[1], 0.0]]);
        }
        for lp in &self.loop_indices {
            let n = lp.len();
            for i in 0..n {
                let a = p(lp[i]);
                let b = p(lp[(i + 1) % n]);
                let (a0, b0) = ([a[0], a[1], 0.0], [b[0], b[1], 0.0]);
                let (a1, b1) = ([a[0], a[1], t], [b[0], b[1], t]);
                tris.push([a0, b0, b1]);
                tris.push([a0, b1, a1]);
            }
        }
        let mut out = Vec::with_capacity(84 + 50 * tris.len());
        let mut header = [0u8; 80];
        let title = format!("flexstage outline extruded, {}", unit.symbol());
        header[..title.len()].copy_from_slice(title.as_bytes());
        out.extend_from_slice(&header);
        out.extend_from_slice(&(tris.len() as u32).to_le_bytes());
        for tri in &tris {
            let n = normal(tri);
            for v in std::iter::once(n).chain(tri.iter().copied()) {
                for x in v {
                    out.extend_from_slice(&(x as f32).to_le_bytes());
                }
            }
            out.extend_from_slice(&0u16.to_le_bytes());
        }
        out
    }
}

/// Unit normal of a triangle (right-hand rule); zero for a degenerate one.
fn normal(t: &[[f64; 3]; 3]) -> [f64; 3] {
    let u = [t[1][0] - t[0][0], t[1][1] - t[0][1], t[1][2] - t[0][2]];
    let v = [t[2][0] - t[0][0], t[2][1] - t[0][1], t[2][2] - t[0][2]];
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if l > 0.0 { n.map(|x| x / l) } else { [0.0; 3] }
}

/// Shoelace signed area of a closed polygon.
pub fn signed_area(p: &[[f64; 2]]) -> f64 {
    let n = p.len();
    (0..n)
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
        * 0.5
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A disc of density 0.5 + 0.5·tanh((R − r)/w): its 0.5 level is the circle r = R exactly.
    fn disc(n: usize, h: f64, r: f64) -> impl Fn(usize, usize) -> f64 {
        let c = 0.5 * n as f64 * h;
        move |i, j| {
            let x = (i as f64 + 0.5) * h - c;
            let y = (j as f64 + 0.5) * h - c;
            0.5 + 0.5 * ((r - (x * x + y * y).sqrt()) / (2.0 * h)).tanh()
        }
    }

    #[test]
    fn disc_contour_lies_on_the_analytic_half_level() {
        // Goal: marching squares + Taubin smoothing keep the 0.5 iso-line of a smooth disc
        // within 1 % of its radius (linear interpolation error is O(h²)).
        let (n, h, r) = (60, 1e-3, 0.02);
        let c = 0.5 * n as f64 * h;
        for smoothing in [0, 10] {
            let o = Outline::extract(n, n, h, h, 0.5, smoothing, disc(n, h, r));
            assert_eq!(o.loops.len(), 1, "one closed loop");
            for p in &o.loops[0] {
                let rr = ((p[0] - c).powi(2) + (p[1] - c).powi(2)).sqrt();
                assert!((rr - r).abs() < 0.01 * r, "radius {rr} vs {r}");
            }
            let area = o.area();
            let exact = std::f64::consts::PI * r * r;
            assert!(
                (area - exact).abs() < 0.02 * exact,
                "area {area} vs {exact}"
            );
            assert!(o.signed_areas()[0] > 0.0, "outer loop counter-clockwise");
        }
    }

    #[test]
    fn solid_block_on_the_edge_is_cut_on_the_domain_edge_and_holes_run_clockwise() {
        // Goal: padding puts the outline of a full plate on its edges (a wire-cut part keeps
        // the domain size), and a void square gives a clockwise hole.
        let (nl, nw, h) = (20, 10, 1e-3);
        let o = Outline::extract(nl, nw, h, h, 0.5, 0, |i, j| {
            if (8..12).contains(&i) && (3..7).contains(&j) {
                0.0
            } else {
                1.0
            }
        });
        assert_eq!(o.loops.len(), 2);
        let areas = o.signed_areas();
        let outer = areas.iter().cloned().fold(f64::MIN, f64::max);
        let hole = areas.iter().cloned().fold(f64::MAX, f64::min);
        // Marching squares chamfers each of the 4 plate corners by a half-cell triangle h²/8.
        let expected = 20e-3 * 10e-3 - 4.0 * h * h / 8.0;
        assert!((outer - expected).abs() < 1e-12, "outer area {outer}");
        assert!(hole < 0.0, "hole clockwise");
        let xs: Vec<f64> = o.loops.iter().flatten().map(|p| p[0]).collect();
        let min = xs.iter().cloned().fold(f64::MAX, f64::min);
        let max = xs.iter().cloned().fold(f64::MIN, f64::max);
        assert!(min.abs() < 1e-15 && (max - 0.02).abs() < 1e-15);
    }

    #[test]
    fn dxf_reads_back_closed_lwpolylines_with_the_bounding_box() {
        // Goal: the DXF opens with a DXF reader (the dxf crate) and holds closed LWPOLYLINEs
        // in millimetres spanning the disc (RUST-NOTES: R12 would silently drop them).
        let (n, h, r) = (40, 1e-3, 0.015);
        let o = Outline::extract(n, n, h, h, 0.5, 5, disc(n, h, r));
        let bytes = o.to_dxf(Unit::Millimetres).unwrap();
        let d = dxf::Drawing::load(&mut bytes.as_slice()).unwrap();
        let mut polys = 0;
        let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
        for e in d.entities() {
            if let dxf::entities::EntityType::LwPolyline(p) = &e.specific {
                polys += 1;
                assert!(p.is_closed());
                for v in &p.vertices {
                    lo = [lo[0].min(v.x), lo[1].min(v.y)];
                    hi = [hi[0].max(v.x), hi[1].max(v.y)];
                }
            }
        }
        assert_eq!(polys, 1);
        for k in 0..2 {
            assert!((lo[k] - 5.0).abs() < 0.15, "min {lo:?}");
            assert!((hi[k] - 35.0).abs() < 0.15, "max {hi:?}");
        }
    }

    #[test]
    fn stl_is_closed_with_outward_normals_and_the_extruded_volume() {
        // Goal: a watertight solid for CAD/CAM: every edge in two triangles, divergence-theorem
        // volume = area × t, side normals horizontal, caps ±z.
        let (nl, nw, h, t) = (16, 8, 1e-3, 5e-3);
        let o = Outline::extract(nl, nw, h, h, 0.5, 3, |i, j| {
            if (5..9).contains(&i) && (2..5).contains(&j) {
                0.0
            } else {
                1.0
            }
        });
        let stl = o.to_stl(t, Unit::Millimetres);
        let n = u32::from_le_bytes(stl[80..84].try_into().unwrap()) as usize;
        assert_eq!(stl.len(), 84 + 50 * n);
        let f = |o: usize| f32::from_le_bytes(stl[o..o + 4].try_into().unwrap()) as f64;
        let mut volume = 0.0;
        let mut edges: HashMap<[[i64; 3]; 2], i32> = HashMap::new();
        let key = |v: [f64; 3]| v.map(|x| (x * 1e4).round() as i64);
        for k in 0..n {
            let base = 84 + 50 * k;
            let nrm = [f(base), f(base + 4), f(base + 8)];
            let v: Vec<[f64; 3]> = (0..3)
                .map(|m| {
                    [
                        f(base + 12 + 12 * m),
                        f(base + 16 + 12 * m),
                        f(base + 20 + 12 * m),
                    ]
                })
                .collect();
            let len = (nrm[0].powi(2) + nrm[1].powi(2) + nrm[2].powi(2)).sqrt();
            assert!((len - 1.0).abs() < 1e-5 || len == 0.0);
            // Signed volume of the tetrahedron with the origin.
            volume += (v[0][0] * (v[1][1] * v[2][2] - v[1][2] * v[2][1])
                - v[0][1] * (v[1][0] * v[2][2] - v[1][2] * v[2][0])
                + v[0][2] * (v[1][0] * v[2][1] - v[1][1] * v[2][0]))
                / 6.0;
            for m in 0..3 {
                let (a, b) = (key(v[m]), key(v[(m + 1) % 3]));
                // Directed edges: a closed, consistently oriented mesh cancels them pairwise.
                *edges.entry([a, b]).or_default() += 1;
                *edges.entry([b, a]).or_default() -= 1;
            }
        }
        assert!(
            edges.values().all(|&c| c == 0),
            "open or inconsistent edges"
        );
        let exact = o.area() * 1e6 * t * 1e3;
        assert!((volume - exact).abs() < 1e-6 * exact, "{volume} vs {exact}");
    }

    #[test]
    fn svg_has_one_path_per_drawing_with_every_loop() {
        // Goal: the SVG outline carries each loop as a closed subpath.
        let o = Outline::extract(10, 10, 1e-3, 1e-3, 0.5, 0, |i, j| {
            if (3..6).contains(&i) && (3..6).contains(&j) {
                0.0
            } else {
                1.0
            }
        });
        let svg = o.to_svg(Unit::Millimetres);
        assert!(svg.starts_with("<svg"));
        assert_eq!(svg.matches("<path").count(), 1);
        assert_eq!(svg.matches('Z').count(), o.loops.len());
        assert_eq!(o.loops.len(), 2);
    }
}
